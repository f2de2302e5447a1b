// vldh_mask: bit-exact against the reference on every back end at odd sizes in padded buffers (tiles
// with the window's halo below, several parameter sets and road records), the mask of a synthetic
// flat road with a box standing on it derived by hand, no vote without a road, the s16 extremes
// (no wrapping difference), the closed-form op count of kernels/vldh_mask.cpp, refused parameters.
#include <gtest/gtest.h>

#include <random>

#include "arm/tasks/road_profile.h"
#include "kernels/obstacle_mask.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using kernels::kMaskFree;
using kernels::kMaskNoVote;
using kernels::kMaskObstacle;
using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

struct RoadRecord {
  int valid = 1;
  int slope_q16 = 0;
  int intercept_q16 = 0;
  int horizon_q8 = 0;
};

Plane road_record(const RoadRecord& road) {
  Plane record(arm::kRoadProfileWords, 1, {ElementType::s32, 0});
  for (int word = 0; word < arm::kRoadProfileWords; ++word) record.at<int32_t>(word, 0) = 0;
  record.at<int32_t>(arm::kRoadValid, 0) = road.valid;
  record.at<int32_t>(arm::kRoadSlopeQ16, 0) = road.slope_q16;
  record.at<int32_t>(arm::kRoadInterceptQ16, 0) = road.intercept_q16;
  record.at<int32_t>(arm::kRoadHorizonRowQ8, 0) = road.horizon_q8;
  return record;
}

// A disparity map with vertical runs (so windows match), invalid pixels, values around the road line
// and a few s16 extremes, in a padded buffer.
Plane disparity_map(int width, int height, ptrdiff_t stride, uint32_t seed, int min_disparity, double invalid_share) {
  Plane plane = random_plane(width, height, {ElementType::s16, 4}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> value_q4((min_disparity - 2) * 16, (min_disparity + 40) * 16);
  std::uniform_int_distribution<int> jitter(-6, 6);
  const auto invalid = static_cast<int16_t>((min_disparity - 1) * 16);
  for (int x = 0; x < width; ++x) {
    int run_value = value_q4(generator);
    for (int y = 0; y < height; ++y) {
      const double draw = unit(generator);
      if (draw < 0.2) run_value = value_q4(generator);  // a new vertical run
      int value = run_value + jitter(generator);
      if (draw > 1.0 - invalid_share) value = invalid;
      else if (draw > 0.995 - invalid_share) value = draw > 0.9975 - invalid_share ? 32767 : -32768;
      plane.at<int16_t>(x, y) = static_cast<int16_t>(std::clamp(value, -32768, 32767));
    }
  }
  return plane;
}

const std::vector<std::pair<int, int>> kTileShapes = {{64, 479}, {64, 16}, {7, 5}, {1, 1}, {200, 3}};

TEST(VldhMask, MatchesReferenceAtOddSizeInPaddedBuffer) {
  struct Setting {
    nlohmann::json params;
    RoadRecord road;
  };
  // Road d(v) = 0.1 (v - 60) px: Q16 slope 6554, intercept -393216 (-6 px), horizon 60 (Q8 15360).
  const RoadRecord road{1, 6554, -393216, 15360};
  const std::vector<Setting> settings = {
      {nlohmann::json::object(), road},
      {{{"window_rows", 1}, {"min_count", 1}}, road},
      {{{"window_rows", 7}, {"min_count", 5}, {"match_tolerance_q4", 0}, {"rows_above_horizon", 0}}, road},
      {{{"window_rows", 32}, {"min_count", 32}, {"match_tolerance_q4", 255}, {"road_margin_q4", 1023}}, road},
      {{{"min_disparity", -3}, {"road_margin_per_mille", 1000}, {"road_margin_q4", 0}}, road},
      {{{"min_disparity", 2}, {"window_rows", 5}, {"min_count", 2}}, RoadRecord{1, -3000, 900000, -2000}},
      {nlohmann::json::object(), RoadRecord{0, 6554, -393216, 15360}},  // no road
      {nlohmann::json::object(), RoadRecord{1, 6554, -393216, 479 * 256 + 300}},  // region below the image
      {{{"rows_above_horizon", 4096}}, RoadRecord{1, 2147483647, -2147483647 - 1, 0}},  // int64 paths, clamped thresholds
      {{{"rows_above_horizon", 0}}, RoadRecord{1, -2147483647 - 1, 2147483647, -2147483647 - 1}},
  };
  for (const Setting& setting : settings) {
    const int min_disparity = setting.params.value("min_disparity", 0);
    KernelCase test_case{"vldh_mask", setting.params, {}, 5};
    test_case.inputs.push_back(disparity_map(631, 479, 640 * 2 + 4, 51, min_disparity, 0.15));
    test_case.inputs.push_back(road_record(setting.road));
    expect_all_back_ends_match_reference(test_case, kTileShapes);
  }
}

TEST(VldhMask, MatchesReferenceOnRandomBitsAndTinyImages) {
  KernelCase random_bits{"vldh_mask", {{"min_disparity", -2047}, {"match_tolerance_q4", 255}}, {}, 3};
  random_bits.inputs.push_back(random_plane(203, 9, {ElementType::s16, 4}, 203 * 2 + 10, 52));
  random_bits.inputs.push_back(road_record({1, 100000, -50000, -700}));
  expect_all_back_ends_match_reference(random_bits, {{16, 8}, {3, 2}});
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {33, 2}, {65, 1}, {8, 1}, {31, 4}}) {
    KernelCase test_case{"vldh_mask", {{"window_rows", 3}, {"min_count", 2}}, {}, 4};
    test_case.inputs.push_back(disparity_map(width, height, width * 2 + 6, 53, 0, 0.2));
    test_case.inputs.push_back(road_record({1, 65536, -65536, 256}));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
}

// The synthetic scene of the behaviour tests: a flat road d(v) = 0.25 (v - 20) px below the horizon
// row 20, i.e. D(v) = 4 (v - 20) in Q4; a far wall at D = 32 (2 px) on rows 0 .. 19; a box of
// constant D = 276 (the road's disparity at its foot, row 89) on columns 20 .. 35, rows 60 .. 89.
constexpr int kSceneWidth = 64, kSceneHeight = 120;
constexpr int kBoxLeft = 20, kBoxRight = 35, kBoxTop = 60, kBoxBottom = 89, kBoxDisparityQ4 = 276;

Plane road_and_box_scene() {
  Plane plane(kSceneWidth, kSceneHeight, {ElementType::s16, 4}, kSceneWidth * 2 + 14);
  for (int v = 0; v < kSceneHeight; ++v) {
    for (int u = 0; u < kSceneWidth; ++u) {
      int value = v < 20 ? 32 : 4 * (v - 20);
      if (u >= kBoxLeft && u <= kBoxRight && v >= kBoxTop && v <= kBoxBottom) value = kBoxDisparityQ4;
      plane.at<int16_t>(u, v) = static_cast<int16_t>(value);
    }
  }
  return plane;
}

// slope 0.25 px/row = 16384 Q16, intercept -5 px = -327680 Q16, horizon row 20 = 5120 Q8.
const RoadRecord kSceneRoad{1, 16384, -327680, 5120};

// Expected by hand, defaults (N = 4, tolerance 4, min_count 3, margin 8 + 20 per mille), rows above
// the horizon: 10:
//   rows 0 .. 9: above horizon - 10: no vote.
//   wall rows 10 .. 19 (D = 32, threshold 4 (v - 20) + 8 <= 4): count = wall rows in the window
//     (the road's D <= 4 below row 20 is 28 or more away) = min(4, 20 - v): >= 3 up to row 17, so
//     rows 10 .. 17 obstacle, 18 and 19 free.
//   road pixels: D = road_q4 < threshold: free.
//   box pixels, t = v - 20: D = 276 > 4 t + 8 + floor(80 t / 1000) holds up to t = 65 (273) and not
//     at t = 66 (277): rows 60 .. 85 are above the margin; their window counts are 4 (the rows below
//     86 .. 89 are box, and row 90's road D = 280 is within the tolerance of 276): obstacle. Rows 86
//     .. 89 are within the road margin (the box's foot): free.
uint8_t expected_scene_mask(int u, int v) {
  if (v < 10) return kMaskNoVote;
  if (v < 20) return v <= 17 ? kMaskObstacle : kMaskFree;
  if (u >= kBoxLeft && u <= kBoxRight && v >= kBoxTop && v <= kBoxBottom) return v <= 85 ? kMaskObstacle : kMaskFree;
  return kMaskFree;
}

TEST(VldhMask, FlatRoadWithABoxGivesTheMaskDerivedByHand) {
  KernelCase test_case{"vldh_mask", {{"rows_above_horizon", 10}}, {}, 7};
  test_case.inputs.push_back(road_and_box_scene());
  test_case.inputs.push_back(road_record(kSceneRoad));
  const std::vector<Plane> mask = expect_all_back_ends_match_reference(test_case, {{64, 16}, {13, 7}, {64, 120}});
  int obstacle_pixels = 0;
  for (int v = 0; v < kSceneHeight; ++v) {
    for (int u = 0; u < kSceneWidth; ++u) {
      ASSERT_EQ(mask[0].at<uint8_t>(u, v), expected_scene_mask(u, v)) << "u=" << u << " v=" << v;
      obstacle_pixels += mask[0].at<uint8_t>(u, v) == kMaskObstacle;
    }
  }
  EXPECT_EQ(obstacle_pixels, 8 * kSceneWidth + 16 * 26);  // the wall's 8 rows and the box's 26
}

TEST(VldhMask, NoRoadRecordMeansNoVoteEverywhere) {
  for (int valid_word : {0, 2, -1}) {
    RoadRecord road = kSceneRoad;
    road.valid = valid_word;
    KernelCase test_case{"vldh_mask", nlohmann::json::object(), {}, 3};
    test_case.inputs.push_back(road_and_box_scene());
    test_case.inputs.push_back(road_record(road));
    const std::vector<Plane> mask = expect_all_back_ends_match_reference(test_case, {{64, 16}, {13, 7}});
    for (int v = 0; v < kSceneHeight; ++v) {
      for (int u = 0; u < kSceneWidth; ++u) ASSERT_EQ(mask[0].at<uint8_t>(u, v), kMaskNoVote) << valid_word;
    }
  }
}

// s16 extremes: with min_disparity -2047 every value >= -32752 is valid. A wrapping 16-bit
// difference 32767 - (-32752) = 65519 = -17 (mod 2^16) would match at tolerance 255; the exact one
// does not. Column 0: 32767 over -32752, -32752, 32767: count 2 (itself and row 3). Column 1:
// -32768 (invalid) over valid values: no vote. Column 2: 32767 four times: count 4.
TEST(VldhMask, ExtremeDisparitiesNeverWrap) {
  Plane map(3, 4, {ElementType::s16, 4});
  const int16_t column0[4] = {32767, -32752, -32752, 32767};
  for (int v = 0; v < 4; ++v) {
    map.at<int16_t>(0, v) = column0[v];
    map.at<int16_t>(1, v) = v == 0 ? -32768 : 100;
    map.at<int16_t>(2, v) = 32767;
  }
  KernelCase test_case{"vldh_mask",
                       {{"min_disparity", -2047}, {"match_tolerance_q4", 255}, {"min_count", 3}, {"road_margin_q4", 0},
                        {"road_margin_per_mille", 0}},
                       {}, 2};
  test_case.inputs.push_back(std::move(map));
  test_case.inputs.push_back(road_record({1, 0, 0, 0}));  // road D = 0 everywhere, threshold 0
  const std::vector<Plane> mask = expect_all_back_ends_match_reference(test_case, {{3, 4}, {1, 1}});
  EXPECT_EQ(mask[0].at<uint8_t>(0, 0), kMaskFree);      // count 2 < 3
  EXPECT_EQ(mask[0].at<uint8_t>(1, 0), kMaskNoVote);    // invalid centre
  EXPECT_EQ(mask[0].at<uint8_t>(2, 0), kMaskObstacle);  // count 4, 32767 > 0
  EXPECT_EQ(mask[0].at<uint8_t>(0, 1), kMaskFree);      // -32752: count 2, below the road
  EXPECT_EQ(mask[0].at<uint8_t>(2, 3), kMaskFree);      // the bottom row: count 1 (nothing below)
}

// The closed form of kernels/vldh_mask.cpp for the counting back end (L = 32 u16 lanes).
TEST(VldhMask, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU16 == 32, "the closed form assumes 32 16-bit lanes");
  constexpr int64_t L = 32;
  struct Shape {
    int width, height, tile_width, tile_height, window_rows, horizon_row, rows_above;
    bool road_valid;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 64, 16, 4, 60, 20, true},
                                               {640, 480, 640, 64, 7, -10, 0, true},
                                               {33, 7, 7, 3, 1, 3, 0, true},
                                               {65, 9, 32, 4, 32, 2, 1, true},
                                               {100, 20, 50, 8, 4, 0, 0, false}}) {
    KernelCase test_case{"vldh_mask",
                         {{"window_rows", shape.window_rows}, {"min_count", 1}, {"rows_above_horizon", shape.rows_above}},
                         {}, 0};
    test_case.inputs.push_back(disparity_map(shape.width, shape.height, 0, 54, 0, 0.2));
    test_case.inputs.push_back(road_record({shape.road_valid ? 1 : 0, 6554, -393216, shape.horizon_row * 256}));
    simd::OpCounts expected;
    for (const TileRect& tile : make_tiles(shape.width, shape.height, shape.tile_width, shape.tile_height)) {
      const int64_t chunks = (tile.width + L - 1) / L;
      expected[simd::OpClass::permute] += 7;
      for (int v = tile.y; v < tile.y + tile.height; ++v) {
        const bool votes = shape.road_valid && v >= shape.horizon_row - shape.rows_above;
        if (!votes) {
          expected[simd::OpClass::store] += chunks;
          continue;
        }
        const int64_t rows_in_window = std::min(shape.window_rows, shape.height - v);
        expected[simd::OpClass::load] += chunks * rows_in_window;
        expected[simd::OpClass::logic] += chunks * (2 * rows_in_window + 1);
        expected[simd::OpClass::arith] += chunks * 2 * rows_in_window;
        expected[simd::OpClass::compare] += chunks * (2 * rows_in_window + 1);
        expected[simd::OpClass::permute] += chunks + 1;
        expected[simd::OpClass::store] += chunks;
      }
    }
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
  }
}

TEST(VldhMaskMustFail, RefusesBadParametersAndRecords) {
  const KernelDescriptor& kernel = testing::kernel_named("vldh_mask");
  const std::vector<PlaneShape> shapes = {{10, 10}, {arm::kRoadProfileWords, 1}};
  EXPECT_THROW(kernel.prepare({{"window", 2}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"window_rows", 0}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"window_rows", 33}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"window_rows", 4}, {"min_count", 5}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"min_count", 0}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"match_tolerance_q4", 256}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"road_margin_q4", -1}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"road_margin_per_mille", 1001}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"rows_above_horizon", 4097}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"min_disparity", 2048}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare(nlohmann::json::object(), {{10, 10}}), KernelError);
  try {
    kernel.prepare({{"window_rows", 4}, {"min_count", 5}}, shapes);
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_NE(std::string(error.what()).find("min_count"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("5"), std::string::npos) << error.what();
  }
  try {
    kernel.prepare(nlohmann::json::object(), {{10, 10}, {11, 1}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'road': expected a 12 x 1 road profile record (arm/tasks/road_profile.h), got 11 x 1");
  }
  const PreparedKernel prepared = kernel.prepare({{"window_rows", 9}, {"min_count", 2}}, shapes);
  ASSERT_EQ(prepared.input_halos.size(), 2u);
  EXPECT_EQ(prepared.input_halos[0], (Halo{0, 0, 0, 8}));  // window_rows - 1 rows below
}

}  // namespace
}  // namespace lpstereo
