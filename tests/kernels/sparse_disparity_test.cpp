// sparse_disparity: bit-exact agreement of every back end with the reference at odd sizes in padded
// buffers (random and real census planes, keypoints at and past every border, invalid rows), values
// worked out by hand at the extremes of the s16 Q4 range (sub-pixel +-8/16 at |d| = 2046, the
// invalid value -32768, the 800-bit cost bound), agreement with the dense census_wta_disparity at the
// keypoints of the project's synthetic stereo pair, the closed-form op count, refused inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <tuple>

#include "arm/tasks/keypoint_record.h"
#include "dag/tile_executor.h"
#include "io/synthetic_scene.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::sparse_census;


// `count` keypoint rows over a width x height image: random places, every seventh at or past a
// border (or far outside), some invalid rows, the last 3 rows zero; padded stride.
Plane keypoint_list(int count, int width, int height, uint32_t seed) {
  Plane list(arm::kKeypointWords, count, {ElementType::s32, 0}, arm::kKeypointWords * 4 + 8);
  std::mt19937 generator(seed);
  const int32_t special[][2] = {{0, 0}, {width - 1, height - 1}, {-1, 5}, {5, -1}, {width, 5}, {5, height}, {1, 2},
                                {width - 2, 1}, {-2147483647 - 1, 3}, {3, 2000000000}, {70000, 7}};
  for (int k = 0; k < count; ++k) {
    int32_t* word = list.row<int32_t>(k);
    word[arm::kKeypointValid] = k % 11 == 5 ? 0 : (k % 13 == 6 ? 0x10000 : 1);
    word[arm::kKeypointXPx] = static_cast<int32_t>(generator() % static_cast<uint32_t>(width));
    word[arm::kKeypointYPx] = static_cast<int32_t>(generator() % static_cast<uint32_t>(height));
    word[arm::kKeypointResponse] = 0;
    if (k % 7 == 3) {
      const auto& place = special[(k / 7) % std::size(special)];
      word[arm::kKeypointXPx] = place[0];
      word[arm::kKeypointYPx] = place[1];
    }
    if (k >= count - 3) std::fill(word, word + arm::kKeypointWords, 0);
  }
  return list;
}

// Runs a kernel on the counting back end (or a native level) over whole planes.
std::vector<Plane> run_kernel(const std::string& name, const nlohmann::json& params, const std::vector<const Plane*>& inputs,
                              KernelBackend backend = KernelBackend::counting, simd::Isa isa = simd::Isa::scalar,
                              int tile_width = 64, int tile_height = 16) {
  const KernelDescriptor& kernel = testing::kernel_named(name);
  std::vector<PlaneShape> shapes;
  std::vector<PlaneView> views;
  for (const Plane* input : inputs) {
    shapes.push_back({input->width(), input->height()});
    views.push_back(input->view());
  }
  const PreparedKernel prepared = kernel.prepare(params, shapes);
  std::vector<Plane> outputs = testing::make_output_planes(kernel, prepared, 0, 0);
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, views, testing::plane_views(outputs),
                            prepared.input_halos, prepared.input_scales};
  run_vector_node(binding, tile_width, tile_height, backend, isa);
  return outputs;
}

io::SyntheticStereoScene scene(int width, int height) {
  io::SyntheticSceneOptions options;
  options.width = width;
  options.height = height;
  return io::make_synthetic_stereo_scene(options);
}

TEST(SparseDisparity, MatchesReferenceAtOddSizesInPaddedBuffers) {
  const std::vector<nlohmann::json> settings = {
      {{"min_disparity", 0}, {"num_disparities", 1}, {"window_radius", 0}, {"uniqueness_percent", 0}},
      {{"min_disparity", 0}, {"num_disparities", 3}, {"window_radius", 1}, {"uniqueness_percent", 10}},
      {{"min_disparity", -9}, {"num_disparities", 40}, {"window_radius", 2}, {"uniqueness_percent", 0}},
      {{"min_disparity", 5}, {"num_disparities", 17}, {"window_radius", 1}, {"uniqueness_percent", 50}},
  };
  for (const nlohmann::json& params : settings) {
    KernelCase test_case{"sparse_disparity", params, {}, 6};
    test_case.inputs.push_back(sparse_census(631, 97, 640 * 4, 11));
    test_case.inputs.push_back(sparse_census(631, 97, 640 * 4 + 12, 12));
    test_case.inputs.push_back(keypoint_list(203, 631, 97, 13));
    expect_all_back_ends_match_reference(test_case, {{203, 1}, {64, 1}, {7, 1}, {33, 1}});
  }
  // Real census planes of the synthetic pair: most keypoints valid, sub-pixel steps of every size.
  const io::SyntheticStereoScene pair = scene(193, 121);
  const std::vector<Plane> left = run_kernel("census5x5", {}, {&pair.left});
  const std::vector<Plane> right = run_kernel("census5x5", {}, {&pair.right});
  KernelCase real{"sparse_disparity", {{"num_disparities", 32}}, {}, 2};
  real.inputs.push_back(left[0].clone());
  real.inputs.push_back(right[0].clone());
  real.inputs.push_back(keypoint_list(101, 193, 121, 14));
  const std::vector<Plane> reference = expect_all_back_ends_match_reference(real, {{101, 1}, {32, 1}, {5, 1}});
  int valid = 0, fractional = 0;
  for (int k = 0; k < 101; ++k) {
    const int16_t value = reference[0].at<int16_t>(k, 0);
    valid += value != -16;
    fractional += value != -16 && value % 16 != 0;
  }
  EXPECT_GT(valid, 50);
  EXPECT_GT(fractional, 20);
}

// Census words with a chosen number of differing bits from an all-ones word: cost(word) = bits.
uint32_t word_at_cost(int bits) { return bits >= 32 ? 0u : ~uint32_t{0} << bits; }

// r = 0, one keypoint on a one-row pair, the right row built so that C(d) is chosen for every d.
int16_t value_for_costs(int width, int x, int min_disparity, int num_disparities, int uniqueness_percent,
                        const std::vector<std::pair<int, int>>& costs_at, KernelBackend backend, simd::Isa isa) {
  Plane left(width, 1, {ElementType::census32, 0});
  Plane right(width, 1, {ElementType::census32, 0});
  for (int column = 0; column < width; ++column) {
    left.at<uint32_t>(column, 0) = ~uint32_t{0};
    right.at<uint32_t>(column, 0) = 0u;  // cost 32 everywhere else
  }
  for (auto [d, cost] : costs_at) right.at<uint32_t>(x - d, 0) = word_at_cost(cost);
  Plane list(arm::kKeypointWords, 1, {ElementType::s32, 0});
  list.at<int32_t>(arm::kKeypointValid, 0) = 1;
  list.at<int32_t>(arm::kKeypointXPx, 0) = x;
  list.at<int32_t>(arm::kKeypointYPx, 0) = 0;
  list.at<int32_t>(arm::kKeypointResponse, 0) = 0;
  const std::vector<Plane> out = run_kernel("sparse_disparity",
                                            {{"min_disparity", min_disparity}, {"num_disparities", num_disparities},
                                             {"window_radius", 0}, {"uniqueness_percent", uniqueness_percent}},
                                            {&left, &right, &list}, backend, isa, 1, 1);
  return out[0].at<int16_t>(0, 0);
}

template <class Check>
void on_every_back_end(const Check& check) {
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The extremes of the Q4 range, derived by hand: q = (16 |a - c| + a + c) / (2 (a + c)).
TEST(SparseDisparity, ExtremeDisparitiesAndSubPixelStepsByHand) {
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    // [1791, 2047): best d = 2045 (cost 0), a = C(2044) - 0 = 31, c = C(2046) - 0 = 1:
    // q = (480 + 32) / 64 = 8, c < a: +8 -> 2045 x 16 + 8 = 32728, the largest value (no clamp).
    EXPECT_EQ(value_for_costs(2100, 2060, 1791, 256, 0, {{2045, 0}, {2044, 31}, {2046, 1}}, backend, isa), 32728) << label;
    // [-2047, -1791): best d = -2046, a = 1, c = 31: -8 -> -2046 x 16 - 8 = -32744.
    EXPECT_EQ(value_for_costs(2100, 10, -2047, 256, 0, {{-2046, 0}, {-2047, 1}, {-2045, 31}}, backend, isa), -32744) << label;
    // best at the first disparity: no sub-pixel step; -2047 x 16 = -32752.
    EXPECT_EQ(value_for_costs(2100, 10, -2047, 256, 0, {{-2047, 0}, {-2046, 1}}, backend, isa), -32752) << label;
    // a = 4, c = 2: q = (32 + 6) / 12 = 3 -> 10 x 16 + 3 = 163.
    EXPECT_EQ(value_for_costs(100, 60, 0, 40, 0, {{10, 2}, {9, 6}, {11, 4}}, backend, isa), 163) << label;
    // A second minimum 20 px away at cost 3 against 2: 2 x 100 > 3 x (100 - 50) -> invalid with U = 50
    // ((0 - 1) x 16 = -16), valid with U = 30 (200 > 210 is false).
    EXPECT_EQ(value_for_costs(100, 60, 0, 40, 50, {{10, 2}, {30, 3}}, backend, isa), -16) << label;
    EXPECT_EQ(value_for_costs(100, 60, 0, 40, 30, {{10, 2}, {30, 3}}, backend, isa), 160) << label;
    // The invalid value at the bottom of the range: -2048 x 16 = -32768 for an ambiguous keypoint
    // (every cost 32, U = 10: 3200 > 2880).
    EXPECT_EQ(value_for_costs(2100, 10, -2047, 256, 10, {}, backend, isa), -32768) << label;
    // A tie is ambiguous: C(10) = 2 and C(30) = 2 with U = 10 (200 >= 180). Also at cost 0 (every
    // cost 0 at d = 0 .. 7, where 0 x 100 > 0 x 90 would have kept it): invalid; with U = 0 (the
    // check off) the tie goes to the smallest d, the range's first, so no sub-pixel step: 0.
    EXPECT_EQ(value_for_costs(100, 60, 0, 40, 10, {{10, 2}, {30, 2}}, backend, isa), -16) << label;
    std::vector<std::pair<int, int>> zero_costs;
    for (int d = 0; d <= 7; ++d) zero_costs.push_back({d, 0});
    EXPECT_EQ(value_for_costs(100, 60, 0, 40, 10, zero_costs, backend, isa), -16) << label;
    EXPECT_EQ(value_for_costs(100, 60, 0, 40, 0, zero_costs, backend, isa), 0) << label;
  });
  // The cost bound: r = 2, every left word all ones, every right word zero: C = 25 x 32 = 800 at
  // every d, best = the first; kept with U = 0.
  Plane left(50, 9, {ElementType::census32, 0}), right(50, 9, {ElementType::census32, 0});
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 50; ++x) {
      left.at<uint32_t>(x, y) = ~uint32_t{0};
      right.at<uint32_t>(x, y) = 0u;
    }
  }
  Plane list(arm::kKeypointWords, 1, {ElementType::s32, 0});
  list.at<int32_t>(arm::kKeypointValid, 0) = 1;
  list.at<int32_t>(arm::kKeypointXPx, 0) = 40;
  list.at<int32_t>(arm::kKeypointYPx, 0) = 4;
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const std::vector<Plane> out = run_kernel(
        "sparse_disparity", {{"min_disparity", 3}, {"num_disparities", 30}, {"window_radius", 2}, {"uniqueness_percent", 0}},
        {&left, &right, &list}, backend, isa, 1, 1);
    EXPECT_EQ(out[0].at<int16_t>(0, 0), 48) << label;
  });
}

// The dense matcher at the keypoints. With r = 0 and U = 0 the cost and the winner are
// census_wta_disparity's (max_cost_bits 24: never invalid), so every keypoint differs from the dense
// value by the sub-pixel step only: |sparse - dense| <= 8 (0.5 px). With the defaults (3 x 3
// window, U = 10) the values are held to the dense ones within 1 px at 85 % of the keypoints both
// keep, and to the scene's truth at least as well as the dense matcher's.
TEST(SparseDisparity, AgreesWithTheDenseCensusMatcherAtKeypoints) {
  const int width = 321, height = 181, disparities = 48;
  const io::SyntheticStereoScene pair = scene(width, height);
  ASSERT_LT(pair.max_disparity_px, disparities);
  const std::vector<Plane> left = run_kernel("census5x5", {}, {&pair.left});
  const std::vector<Plane> right = run_kernel("census5x5", {}, {&pair.right});
  const std::vector<Plane> dense =
      run_kernel("census_wta_disparity", {{"num_disparities", disparities}, {"max_cost_bits", 24}}, {&left[0], &right[0]});
  // Keypoints on a grid, right of the search range so every candidate lies in the right view.
  std::vector<std::array<int, 2>> places;
  for (int y = 8; y < height - 8; y += 9) {
    for (int x = disparities + 4; x < width - 8; x += 11) places.push_back({x, y});
  }
  const int count = static_cast<int>(places.size());
  Plane list(arm::kKeypointWords, count, {ElementType::s32, 0});
  for (int k = 0; k < count; ++k) {
    list.at<int32_t>(arm::kKeypointValid, k) = 1;
    list.at<int32_t>(arm::kKeypointXPx, k) = places[static_cast<size_t>(k)][0];
    list.at<int32_t>(arm::kKeypointYPx, k) = places[static_cast<size_t>(k)][1];
    list.at<int32_t>(arm::kKeypointResponse, k) = 0;
  }
  auto dense_at = [&](int k) { return dense[0].at<int16_t>(places[static_cast<size_t>(k)][0], places[static_cast<size_t>(k)][1]); };
  auto truth_at = [&](int k) { return pair.disparity_q4.at<int16_t>(places[static_cast<size_t>(k)][0], places[static_cast<size_t>(k)][1]); };

  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const std::vector<Plane> single = run_kernel(
        "sparse_disparity", {{"num_disparities", disparities}, {"window_radius", 0}, {"uniqueness_percent", 0}},
        {&left[0], &right[0], &list}, backend, isa, 37, 1);
    for (int k = 0; k < count; ++k) {
      ASSERT_LE(std::abs(single[0].at<int16_t>(k, 0) - dense_at(k)), 8) << label << " keypoint " << k;
    }
  });

  const std::vector<Plane> windowed = run_kernel("sparse_disparity", {{"num_disparities", disparities}}, {&left[0], &right[0], &list});
  int both = 0, agree = 0, sparse_good = 0, dense_good = 0;
  for (int k = 0; k < count; ++k) {
    const int16_t value = windowed[0].at<int16_t>(k, 0);
    if (value == -16) continue;
    ++both;
    agree += std::abs(value - dense_at(k)) <= 16;
    sparse_good += std::abs(value - truth_at(k)) <= 16;
    dense_good += std::abs(dense_at(k) - truth_at(k)) <= 16;
  }
  std::printf("%d keypoints, %d kept by the 3x3 window with U = 10; within 1 px: of the dense value %d, of the truth %d "
              "(dense WTA: %d)\n", count, both, agree, sparse_good, dense_good);
  EXPECT_GT(both, count * 7 / 10);
  EXPECT_GE(agree * 100, both * 85);
  EXPECT_GE(sparse_good, dense_good);
}

// The closed form of kernels/sparse_disparity.cpp for the counting back end (L = 16, 32 keypoints a chunk).
TEST(SparseDisparity, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU32 == 16, "the closed form assumes 16 32-bit lanes");
  for (auto [keypoints, tile_width, radius, disparities] :
       std::vector<std::tuple<int, int, int, int>>{{203, 203, 1, 40}, {203, 64, 0, 1}, {1, 1, 2, 7}, {70, 33, 2, 64}}) {
    KernelCase test_case{"sparse_disparity", {{"min_disparity", -2}, {"num_disparities", disparities}, {"window_radius", radius}}, {}, 0};
    test_case.inputs.push_back(sparse_census(97, 61, 0, 21));
    test_case.inputs.push_back(sparse_census(97, 61, 0, 22));
    test_case.inputs.push_back(keypoint_list(keypoints, 97, 61, 23));
    const int64_t a = (2 * radius + 1) * (2 * radius + 1), r = 2 * radius + 1, e = disparities + 2 * radius, d = disparities;
    simd::OpCounts expected;
    for (const TileRect& tile : make_tiles(keypoints, 1, tile_width, 1)) {
      const int64_t chunks = (tile.width + 31) / 32, halves = 2 * chunks;
      expected[simd::OpClass::gather] += halves * (6 + 2 * a + 2 * r * e);
      expected[simd::OpClass::load] += 1 + halves * (a + 1) * d;
      expected[simd::OpClass::store] += chunks + halves * (r * e + d);
      expected[simd::OpClass::popcount] += halves * a * d;
      expected[simd::OpClass::arith] += 1 + halves * (26 + 6 * r + a + 3 * e + r * e + (a + 3) * d);
      expected[simd::OpClass::logic] += halves * (19 + a + r * e + (a + 4) * d);
      expected[simd::OpClass::shift] += halves * (7 + r + a + e + r * e);
      expected[simd::OpClass::compare] += halves * (13 + 4 * d);
      expected[simd::OpClass::multiply] += halves * (3 + 2 * r);
      expected[simd::OpClass::permute] += 27 + r + chunks;
    }
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, tile_width, 1)))
        << keypoints << " keypoints in tiles of " << tile_width << ", r " << radius << ", D " << disparities;
  }
}

TEST(SparseDisparityMustFail, RefusesBadInputsAndParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("sparse_disparity");
  const std::vector<PlaneShape> good = {{100, 50}, {100, 50}, {4, 10}};
  EXPECT_NO_THROW(kernel.prepare({}, good));
  EXPECT_THROW(kernel.prepare({{"window_radius", 3}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({{"num_disparities", 257}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({{"min_disparity", 2000}, {"num_disparities", 48}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({{"uniqueness_percent", 51}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({{"radius", 1}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({}, {{100, 50}, {100, 50}}), KernelError);
  EXPECT_THROW(kernel.prepare({}, {{100, 50}, {100, 50}, {4, 0}}), KernelError);
  try {
    kernel.prepare({}, {{100, 50}, {101, 50}, {4, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'right': expected the left view's size 100x50, got 101x50");
  }
  try {
    kernel.prepare({}, {{100, 50}, {100, 50}, {5, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'keypoints': expected 4 words (arm/tasks/keypoint_record.h) x at least 1 row, got 5x10");
  }
}

}  // namespace
}  // namespace lpstereo
