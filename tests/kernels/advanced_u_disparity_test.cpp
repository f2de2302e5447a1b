// advanced_u_disparity: bit-exact against the reference on every back end at odd sizes in padded
// buffers (tiles of grid cells, several bands of image rows and windows of grid rows), the grid of a
// synthetic flat road with a box derived by hand from its pixel counts, exact u16 column totals and
// the clamp at 65535 at the tallest accepted map, the closed-form op count, refused parameters.
#include <gtest/gtest.h>

#include <random>

#include "kernels/advanced_u_disparity.h"
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

// Q4 disparities from below d_min to above d_max (and the s16 extremes), vertical runs so that cells
// collect many votes, in a padded buffer.
Plane disparity_map(int width, int height, ptrdiff_t stride, uint32_t seed, double min_px, double max_px) {
  Plane plane = random_plane(width, height, {ElementType::s16, 4}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> value_q4(static_cast<int>(16 * min_px) - 40, static_cast<int>(16 * max_px) + 40);
  for (int x = 0; x < width; ++x) {
    int run_value = value_q4(generator);
    for (int y = 0; y < height; ++y) {
      const double draw = unit(generator);
      if (draw < 0.1) run_value = value_q4(generator);
      int value = run_value;
      if (draw > 0.99) value = draw > 0.995 ? 32767 : -32768;
      plane.at<int16_t>(x, y) = static_cast<int16_t>(std::clamp(value, -32768, 32767));
    }
  }
  return plane;
}

// Mask values: mostly obstacle (so that cells pass zero and, with big weights, 65535), free, no vote
// and 7 (not a mask value: no vote).
Plane mask_map(int width, int height, ptrdiff_t stride, uint32_t seed, double obstacle_share) {
  Plane plane = random_plane(width, height, {ElementType::u8, 0}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double draw = unit(generator);
      uint8_t value = 7;
      if (draw < obstacle_share) value = kMaskObstacle;
      else if (draw < 0.85) value = kMaskFree;
      else if (draw < 0.95) value = kMaskNoVote;
      plane.at<uint8_t>(x, y) = value;
    }
  }
  return plane;
}

KernelCase aud_case(const nlohmann::json& params, int width, int height, uint32_t seed, double obstacle_share = 0.5) {
  KernelCase test_case{"advanced_u_disparity", params, {}, 6};
  const double min_px = params.value("min_disparity_px", 2.0);
  const double max_px = params.value("max_disparity_px", 128.0);
  test_case.inputs.push_back(disparity_map(width, height, width * 2 + 10, seed, min_px, max_px));
  test_case.inputs.push_back(mask_map(width, height, width + 7, seed + 1, obstacle_share));
  return test_case;
}

TEST(AdvancedUDisparity, MatchesReferenceAtOddSizeInPaddedBuffer) {
  // Tiles in grid cells: a full grid, strips, odd blocks, single cells.
  const std::vector<std::pair<int, int>> tile_shapes = {{1000, 1000}, {16, 128}, {7, 5}, {3, 40}, {1, 1}};
  const std::vector<nlohmann::json> settings = {
      {{"grid_rows", 40}},
      {{"grid_rows", 33}, {"columns_per_cell", 5}, {"exponent_k", 2.5}, {"obstacle_weight", 255}, {"free_weight", 0}},
      {{"grid_rows", 24}, {"columns_per_cell", 1}, {"min_disparity_px", 0.0625}, {"max_disparity_px", 9.0}, {"exponent_k", 0.4}},
      {{"grid_rows", 17}, {"columns_per_cell", 64}, {"free_weight", 255}, {"obstacle_weight", 1}},
      {{"grid_rows", 20}, {"columns_per_cell", 33}, {"min_disparity_px", 100.5}, {"max_disparity_px", 2048.0}},
  };
  for (const nlohmann::json& params : settings) {
    expect_all_back_ends_match_reference(aud_case(params, 203, 97, 61), tile_shapes);
  }
}

// More than 255 image rows (a second band of u8 counts) and more than 255 grid rows (a second window
// of u8 keys), and tiny images.
TEST(AdvancedUDisparity, MatchesReferenceAcrossBandsWindowsAndTinyImages) {
  expect_all_back_ends_match_reference(aud_case({{"grid_rows", 300}, {"columns_per_cell", 3}}, 37, 301, 62),
                                       {{13, 300}, {5, 257}, {13, 100}});
  expect_all_back_ends_match_reference(aud_case({{"grid_rows", 9}, {"columns_per_cell", 2}}, 150, 600, 63, 0.9),
                                       {{75, 9}, {8, 4}});
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {33, 2}, {65, 1}, {129, 4}}) {
    expect_all_back_ends_match_reference(aud_case({{"grid_rows", 12}, {"columns_per_cell", 4}}, width, height, 64),
                                         {{100, 12}, {1, 3}});
  }
}

// The scene of tests/kernels/vldh_mask_test.cpp, with the mask that test derives by hand: a flat road
// D(v) = 4 (v - 20) Q4 below row 20 (free), a wall D = 32 on rows 0 .. 19 (no vote above row 10,
// obstacle on rows 10 .. 17, free on 18 and 19), a box D = 276 on columns 20 .. 35, rows 60 .. 89
// (obstacle on rows 60 .. 85, free on 86 .. 89, its foot within the road margin).
constexpr int kSceneWidth = 64, kSceneHeight = 120;

void make_scene(Plane& disparity, Plane& mask) {
  for (int v = 0; v < kSceneHeight; ++v) {
    for (int u = 0; u < kSceneWidth; ++u) {
      const bool box = u >= 20 && u <= 35 && v >= 60 && v <= 89;
      disparity.at<int16_t>(u, v) = static_cast<int16_t>(box ? 276 : v < 20 ? 32 : 4 * (v - 20));
      uint8_t value = kMaskFree;
      if (v < 10) value = kMaskNoVote;
      else if (v < 20) value = v <= 17 ? kMaskObstacle : kMaskFree;
      else if (box) value = v <= 85 ? kMaskObstacle : kMaskFree;
      mask.at<uint8_t>(u, v) = value;
    }
  }
}

// 8 columns per cell (8 cells), 32 rows from 2 to 64 px, k = 1: boundary_q4[r] = ceil(32 * 2^(5 r / 32)),
// so row 0 = [32, 36), row 19 = [251, 280) (32 * 2^(95/32) = 250.6, 32 * 2^(100/32) = 279.2).
// Row 19 (the box, D = 276): box columns vote 26 x (+2) - 4 x 1 = 48 each; road columns vote -1 for
// each of their 7 rows with D in [251, 280) (v = 83 .. 89, D = 252 .. 276).
//   cell 3 (columns 24 .. 31, all box): 8 x 48 = 384, the maximum of the grid;
//   cells 2 and 4 (4 box and 4 road columns): 4 x 48 - 4 x 7 = 164; the other cells: -56 -> 0.
// Row 0 (the wall, D = 32): per column 8 x (+2) - 2 x 1 (rows 18, 19) - 1 (the road at v = 28,
// D = 32): 13, per cell 104. Every other cell only gets road (free) votes: 0.
TEST(AdvancedUDisparity, RoadWithABoxPeaksInTheBoxCellWithTheValueFromItsPixelCounts) {
  KernelCase test_case{"advanced_u_disparity",
                       {{"columns_per_cell", 8}, {"grid_rows", 32}, {"min_disparity_px", 2.0}, {"max_disparity_px", 64.0},
                        {"exponent_k", 1.0}, {"obstacle_weight", 2}, {"free_weight", 1}},
                       {}, 4};
  Plane disparity(kSceneWidth, kSceneHeight, {ElementType::s16, 4}, kSceneWidth * 2 + 6);
  Plane mask(kSceneWidth, kSceneHeight, {ElementType::u8, 0}, kSceneWidth + 5);
  make_scene(disparity, mask);
  test_case.inputs.push_back(std::move(disparity));
  test_case.inputs.push_back(std::move(mask));
  const std::vector<int32_t> boundaries = kernels::aud_row_boundaries_q4({2.0, 64.0, 1.0, 32});
  ASSERT_EQ(boundaries[19], 251);
  ASSERT_EQ(boundaries[20], 280);
  ASSERT_EQ(boundaries[1], 36);
  const std::vector<Plane> grid = expect_all_back_ends_match_reference(test_case, {{8, 32}, {3, 7}, {1, 1}});
  ASSERT_EQ(grid[0].width(), 8);
  ASSERT_EQ(grid[0].height(), 32);
  int best_column = -1, best_row = -1, best_value = -1;
  for (int row = 0; row < 32; ++row) {
    for (int column = 0; column < 8; ++column) {
      const int value = grid[0].at<uint16_t>(column, row);
      int expected = 0;
      if (row == 0) expected = 104;
      if (row == 19) expected = column == 3 ? 384 : column == 2 || column == 4 ? 164 : 0;
      EXPECT_EQ(value, expected) << "cell " << column << ", row " << row;
      if (value > best_value) best_column = column, best_row = row, best_value = value;
    }
  }
  EXPECT_EQ(best_column, 3);
  EXPECT_EQ(best_row, 19);
}

Plane run_aud(const nlohmann::json& params, const Plane& disparity, const Plane& mask, KernelBackend backend, simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("advanced_u_disparity");
  const PreparedKernel prepared = kernel.prepare(params, {{disparity.width(), disparity.height()}, {mask.width(), mask.height()}});
  Plane output(prepared.output_shapes[0].width, prepared.output_shapes[0].height, {ElementType::u16, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {disparity.view(), mask.view()}, {output.view()}};
  run_vector_node(binding, 16, 8, backend, isa);
  return output;
}

// The tallest accepted map, 65535 rows (257 bands of u8 counts): a u16 column total reaches exactly
// 65535 without wrapping; 40000 obstacle and 25535 free votes per column give 14465 exactly (both
// totals above 32767: not s16); 64 columns of 65535 obstacle votes at weight 255 (1.07e9 in the s32
// merge) clamp to 65535; free votes only clamp to 0.
TEST(AdvancedUDisparity, TotalsAreExactAndCellsClampAtTheTallestMap) {
  constexpr int kHeight = 65535;
  Plane disparity(64, kHeight, {ElementType::s16, 4});
  Plane split_mask(64, kHeight, {ElementType::u8, 0});
  Plane obstacle_mask(64, kHeight, {ElementType::u8, 0});
  Plane free_mask(64, kHeight, {ElementType::u8, 0});
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < 64; ++u) {
      disparity.at<int16_t>(u, v) = 5 * 16;  // 5 px: grid row 0 of [4, 8) px in 2 rows
      split_mask.at<uint8_t>(u, v) = v < 40000 ? kMaskObstacle : kMaskFree;
      obstacle_mask.at<uint8_t>(u, v) = kMaskObstacle;
      free_mask.at<uint8_t>(u, v) = kMaskFree;
    }
  }
  const nlohmann::json geometry = {{"grid_rows", 2}, {"min_disparity_px", 4.0}, {"max_disparity_px", 8.0}};
  nlohmann::json per_column = geometry;
  per_column["columns_per_cell"] = 1;
  per_column["obstacle_weight"] = 1;
  per_column["free_weight"] = 1;
  nlohmann::json heavy = geometry;
  heavy["columns_per_cell"] = 64;
  heavy["obstacle_weight"] = 255;
  nlohmann::json one_column_heavy = per_column;
  one_column_heavy["obstacle_weight"] = 255;
  auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Plane split = run_aud(per_column, disparity, split_mask, backend, isa);
    const Plane full = run_aud(per_column, disparity, obstacle_mask, backend, isa);
    const Plane clamped = run_aud(heavy, disparity, obstacle_mask, backend, isa);
    const Plane negative = run_aud(heavy, disparity, free_mask, backend, isa);
    for (int u = 0; u < 64; ++u) {
      EXPECT_EQ(split.at<uint16_t>(u, 0), 14465) << label << " column " << u;
      EXPECT_EQ(split.at<uint16_t>(u, 1), 0) << label;
      EXPECT_EQ(full.at<uint16_t>(u, 0), 65535) << label << " column " << u;
    }
    EXPECT_EQ(clamped.at<uint16_t>(0, 0), 65535) << label;
    EXPECT_EQ(negative.at<uint16_t>(0, 0), 0) << label;
  };
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The closed form of kernels/advanced_u_disparity.cpp for the counting back end (64 u8, 32 u16 lanes).
TEST(AdvancedUDisparity, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64 && simd::Counting::kLanesU16 == 32, "the closed form assumes 512 bits");
  constexpr int64_t L8 = 64, L16 = 32;
  struct Shape {
    int width, height, columns_per_cell, grid_rows, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{203, 97, 8, 40, 16, 40}, {203, 97, 5, 33, 7, 5}, {37, 301, 3, 300, 13, 300},
                                               {1, 1, 1, 1, 1, 1}, {640, 20, 64, 128, 4, 128}, {129, 256, 2, 16, 100, 3}}) {
    const nlohmann::json params = {{"columns_per_cell", shape.columns_per_cell}, {"grid_rows", shape.grid_rows}};
    KernelCase test_case = aud_case(params, shape.width, shape.height, 65);
    const PreparedKernel prepared = testing::prepare_case(testing::kernel_named("advanced_u_disparity"), test_case);
    const std::vector<int32_t> boundaries = kernels::aud_row_boundaries_q4({2.0, 128.0, 1.0, shape.grid_rows});
    const int64_t entries = std::min(boundaries.back(), 32767) - (boundaries.front() - 1) + 1;
    const int64_t K = shape.columns_per_cell;
    const int grid_columns = prepared.output_shapes[0].width;
    simd::OpCounts expected;
    for (const TileRect& tile : make_tiles(grid_columns, shape.grid_rows, shape.tile_width, shape.tile_height)) {
      expected[simd::OpClass::load] += (entries + L16 - 1) / L16 + 1;
      expected[simd::OpClass::store] += (entries + L16 - 1) / L16;
      expected[simd::OpClass::permute] += 9;
      expected[simd::OpClass::multiply] += 1;
      const int64_t chunks = (tile.width * K + L8 - 1) / L8;
      for (int window = 0; window < tile.height; window += 255) {
        const int window_rows = std::min(255, tile.height - window);
        expected[simd::OpClass::permute] += chunks;
        const int64_t rows = shape.height;
        expected[simd::OpClass::load] += chunks * rows * 3;
        expected[simd::OpClass::arith] += chunks * rows * 8;
        expected[simd::OpClass::permute] += chunks * rows * 7;
        expected[simd::OpClass::gather] += chunks * rows * 4;
        expected[simd::OpClass::compare] += chunks * rows * 2;
        expected[simd::OpClass::logic] += chunks * rows * 2;
        expected[simd::OpClass::store] += chunks * rows * 2;
        for (int band = 0; band < shape.height; band += 255) {
          const int64_t band_rows = std::min(255, shape.height - band);
          for (int pass = 0; pass < window_rows; pass += 16) {
            const int64_t g = std::min(16, window_rows - pass);
            expected[simd::OpClass::permute] += chunks * (g + 4 * g);
            expected[simd::OpClass::load] += chunks * (band_rows * 2 + (band > 0 ? 4 * g : 0));
            expected[simd::OpClass::compare] += chunks * band_rows * 2 * g;
            expected[simd::OpClass::arith] += chunks * (band_rows * 2 * g + (band > 0 ? 4 * g : 0));
            expected[simd::OpClass::store] += chunks * 4 * g;
          }
        }
      }
      const int64_t blocks = (tile.width + L16 - 1) / L16;
      expected[simd::OpClass::gather] += tile.height * blocks * 4 * K;
      expected[simd::OpClass::arith] += tile.height * blocks * (4 * K - 2);
      expected[simd::OpClass::multiply] += tile.height * blocks * 4;
      expected[simd::OpClass::permute] += tile.height * blocks;
      expected[simd::OpClass::store] += tile.height * blocks;
    }
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " K " << K << " rows " << shape.grid_rows << " in tiles of "
        << shape.tile_width << "x" << shape.tile_height;
  }
}

TEST(AdvancedUDisparityMustFail, RefusesBadParametersAndShapes) {
  const KernelDescriptor& kernel = testing::kernel_named("advanced_u_disparity");
  const std::vector<PlaneShape> shapes = {{10, 10}, {10, 10}};
  EXPECT_THROW(kernel.prepare({{"rows", 2}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"columns_per_cell", 0}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"columns_per_cell", 65}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"grid_rows", 0}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"grid_rows", 1025}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"min_disparity_px", 0.0}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"max_disparity_px", 2048.5}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"exponent_k", 0.0}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"obstacle_weight", 0}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"obstacle_weight", 256}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"free_weight", -1}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare({{"free_weight", 256}}, shapes), KernelError);
  EXPECT_THROW(kernel.prepare(nlohmann::json::object(), {{10, 10}}), KernelError);
  try {
    kernel.prepare({{"min_disparity_px", 8.0}, {"max_disparity_px", 8.0}}, shapes);
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "parameter 'max_disparity_px': expected more than min_disparity_px (8.000000), got 8.000000");
  }
  try {
    kernel.prepare(nlohmann::json::object(), {{10, 10}, {10, 9}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'mask': expected the disparity's size 10 x 10, got 10 x 9");
  }
  try {
    kernel.prepare(nlohmann::json::object(), {{4, 65536}, {4, 65536}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(),
                 "input 'disparity': expected a height of at most 65535 rows (u16 column totals, see "
                 "kernels/advanced_u_disparity.cpp), got 65536");
  }
  const PreparedKernel prepared = kernel.prepare({{"columns_per_cell", 7}, {"grid_rows", 50}}, {{100, 10}, {100, 10}});
  EXPECT_EQ(prepared.output_shapes.at(0), (PlaneShape{15, 50}));  // ceil(100 / 7) cells
}

}  // namespace
}  // namespace lpstereo
