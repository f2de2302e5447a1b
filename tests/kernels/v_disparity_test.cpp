// v_disparity: bit-exact against the reference on every back end at odd sizes in padded buffers,
// counts by hand on small rows, saturation at 65535 (never a wrap, never 8-bit) up to the widest row
// the kernel accepts, the closed-form op count of kernels/v_disparity.cpp, and refused parameters.
#include <gtest/gtest.h>

#include <random>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

// A disparity map for min_disparity `min_disparity`: Q4 values from a little below the range
// (negative bins) to above it, about `invalid_share` invalid, a few extremes, in a padded buffer.
Plane disparity_map(int width, int height, ptrdiff_t stride, uint32_t seed, int min_disparity, int num_disparities,
                    double invalid_share) {
  Plane plane = random_plane(width, height, {ElementType::s16, 4}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> value_q4((min_disparity - 3) * 16, (min_disparity + num_disparities + 3) * 16);
  const auto invalid = static_cast<int16_t>((min_disparity - 1) * 16);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double draw = unit(generator);
      int16_t value = static_cast<int16_t>(value_q4(generator));
      if (draw < invalid_share) value = invalid;
      else if (draw > 0.995) value = static_cast<int16_t>(draw > 0.9975 ? 32767 : -32768);
      plane.at<int16_t>(x, y) = value;
    }
  }
  return plane;
}

const std::vector<std::pair<int, int>> kTileShapes = {{64, 479}, {64, 16}, {7, 5}, {1, 1}};

TEST(VDisparity, MatchesReferenceAtOddSizeInPaddedBuffer) {
  struct Range {
    int min_disparity, num_bins;
  };
  for (const Range& range : std::vector<Range>{{0, 64}, {-3, 40}, {5, 1}, {0, 33}, {-20, 129}}) {
    KernelCase test_case{"v_disparity", {{"min_disparity", range.min_disparity}, {"num_bins", range.num_bins}}, {}, 6};
    test_case.inputs.push_back(disparity_map(631, 479, 640 * 2 + 4, 41, range.min_disparity, range.num_bins, 0.2));
    expect_all_back_ends_match_reference(test_case, kTileShapes);
  }
}

TEST(VDisparity, MatchesReferenceOnRandomBitsAndTinyImages) {
  KernelCase random_bits{"v_disparity", {{"min_disparity", -2047}, {"num_bins", 2048 + 2047}}, {}, 2};
  random_bits.inputs.push_back(random_plane(203, 9, {ElementType::s16, 4}, 203 * 2 + 10, 42));
  expect_all_back_ends_match_reference(random_bits, {{16, 8}, {3, 2}});
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {33, 2}, {65, 1}, {8, 1}, {31, 4}}) {
    KernelCase test_case{"v_disparity", {{"min_disparity", 0}, {"num_bins", 17}}, {}, 4};
    test_case.inputs.push_back(disparity_map(width, height, width * 2 + 6, 43, 0, 17, 0.3));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
}

Plane run_v_disparity(const Plane& input, int min_disparity, int num_bins, KernelBackend backend, simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("v_disparity");
  const PreparedKernel prepared =
      kernel.prepare({{"min_disparity", min_disparity}, {"num_bins", num_bins}}, {{input.width(), input.height()}});
  Plane output(num_bins, input.height(), {ElementType::u16, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {input.view()}, {output.view()}};
  run_vector_node(binding, num_bins, 16, backend, isa);
  return output;
}

template <class Check>
void on_every_back_end(const Check& check) {
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// One row by hand, min_disparity -2, 4 bins (integer disparities -2 .. 1):
//   -48 (invalid, (-2 - 1) * 16) -> not counted; -32 (-2.0) and -17 (floor(-1.0625) = -2) -> bin 0;
//   -1 (floor(-0.0625) = -1) -> bin 1; 0 and 15 -> bin 2; 16 and 31 -> bin 3; 32 (integer 2) -> above.
TEST(VDisparity, CountsOneRowByHand) {
  Plane row(9, 1, {ElementType::s16, 4});
  const int16_t values[9] = {-48, -32, -17, -1, 0, 15, 16, 31, 32};
  for (int x = 0; x < 9; ++x) row.at<int16_t>(x, 0) = values[x];
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Plane histogram = run_v_disparity(row, -2, 4, backend, isa);
    EXPECT_EQ(histogram.at<uint16_t>(0, 0), 2) << label;
    EXPECT_EQ(histogram.at<uint16_t>(1, 0), 1) << label;
    EXPECT_EQ(histogram.at<uint16_t>(2, 0), 2) << label;
    EXPECT_EQ(histogram.at<uint16_t>(3, 0), 2) << label;
  });
}

// Counts past 32767 (not s16), past 65535 saturate (not wrap), and the widest accepted row of one
// bin: on 8-lane back ends every lane then holds exactly 65535, the most a u16 lane count can take.
TEST(VDisparity, CountsSaturateAt65535AndNeverWrap) {
  constexpr int kWide = 70001;
  Plane split(kWide, 2, {ElementType::s16, 4});
  for (int x = 0; x < kWide; ++x) {
    split.at<int16_t>(x, 0) = static_cast<int16_t>(x < 35000 ? 3 * 16 : 4 * 16 + 15);  // 35000 in bin 3, 35001 in bin 4
    split.at<int16_t>(x, 1) = 7 * 16 + 8;                                               // 70001 in bin 7
  }
  constexpr int kWidest = 65535 * 8;
  Plane widest(kWidest, 1, {ElementType::s16, 4});
  for (int x = 0; x < kWidest; ++x) widest.at<int16_t>(x, 0) = static_cast<int16_t>(x < 60000 ? 16 : 2 * 16);
  Plane one_bin(kWidest, 1, {ElementType::s16, 4});
  for (int x = 0; x < kWidest; ++x) one_bin.at<int16_t>(x, 0) = 5 * 16;
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Plane histogram = run_v_disparity(split, 0, 8, backend, isa);
    EXPECT_EQ(histogram.at<uint16_t>(3, 0), 35000) << label;
    EXPECT_EQ(histogram.at<uint16_t>(4, 0), 35001) << label;
    EXPECT_EQ(histogram.at<uint16_t>(7, 1), 65535) << label;
    EXPECT_EQ(histogram.at<uint16_t>(3, 1), 0) << label;
    const Plane widest_histogram = run_v_disparity(widest, 0, 8, backend, isa);
    EXPECT_EQ(widest_histogram.at<uint16_t>(1, 0), 60000) << label;
    EXPECT_EQ(widest_histogram.at<uint16_t>(2, 0), 65535) << label;  // 464,280 pixels
    const Plane one_bin_histogram = run_v_disparity(one_bin, 0, 8, backend, isa);
    EXPECT_EQ(one_bin_histogram.at<uint16_t>(5, 0), 65535) << label;
    EXPECT_EQ(one_bin_histogram.at<uint16_t>(4, 0), 0) << label;
    EXPECT_EQ(one_bin_histogram.at<uint16_t>(6, 0), 0) << label;
  });
}

// The closed form of kernels/v_disparity.cpp for the counting back end (L = 32 u16 lanes).
TEST(VDisparity, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU16 == 32, "the closed form assumes 32 16-bit lanes");
  constexpr int64_t L = 32;
  struct Shape {
    int width, height, tile_height, num_bins;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 479, 64}, {640, 480, 16, 128}, {1, 1, 1, 1}, {33, 7, 3, 40},
                                               {64, 5, 2, 8}, {200, 3, 5, 33}}) {
    KernelCase test_case{"v_disparity", {{"min_disparity", 0}, {"num_bins", shape.num_bins}}, {}, 0};
    test_case.inputs.push_back(disparity_map(shape.width, shape.height, 0, 44, 0, shape.num_bins, 0.2));
    const int64_t rows = shape.height;
    const int64_t tiles = (shape.height + shape.tile_height - 1) / shape.tile_height;
    const int64_t chunks = (shape.width + L - 1) / L;
    const int64_t tail = shape.width % L != 0 ? 1 : 0;
    const int64_t passes = (shape.num_bins + 7) / 8;
    const int64_t bins8 = passes * 8;
    const int64_t blocks = (shape.num_bins + L - 1) / L;
    simd::OpCounts expected;
    expected[simd::OpClass::load] = rows * chunks * passes + 2 * tiles;
    expected[simd::OpClass::shift] = rows * chunks * passes + tiles;
    expected[simd::OpClass::logic] = rows * tail * passes;
    expected[simd::OpClass::compare] = rows * chunks * bins8 + tiles;
    expected[simd::OpClass::arith] = rows * (chunks * bins8 + blocks * 2 * (L - 1));
    expected[simd::OpClass::permute] = rows * (bins8 + blocks) + 3 * tiles;
    expected[simd::OpClass::store] = rows * (bins8 + blocks);
    expected[simd::OpClass::gather] = rows * blocks * 2 * L;
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.num_bins, shape.tile_height)))
        << shape.width << "x" << shape.height << " bins " << shape.num_bins << " in tiles of " << shape.tile_height << " rows";
  }
}

TEST(VDisparityMustFail, RefusesBadParametersAndTooWideRows) {
  const KernelDescriptor& kernel = testing::kernel_named("v_disparity");
  EXPECT_THROW(kernel.prepare({{"bins", 2}}, {{10, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"num_bins", 0}}, {{10, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"min_disparity", 2000}, {"num_bins", 64}}, {{10, 10}}), KernelError);
  try {
    kernel.prepare({{"num_bins", 64}}, {{65535 * 8 + 1, 2}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(),
                 "input 'disparity': expected a width of at most 524280 px (u16 per-lane counts, see "
                 "kernels/v_disparity.cpp), got 524281");
  }
}

}  // namespace
}  // namespace lpstereo
