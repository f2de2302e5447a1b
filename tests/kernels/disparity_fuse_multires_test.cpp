// disparity_fuse_multires: bit-exact against the reference on every back end at odd sizes and tile
// shapes (the half input is scaled 1/2), the fusion rule on golden pixels, the closed-form op count
// of kernels/disparity_fuse_multires.cpp, and refused parameters and shapes.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

// far [0, 64) full px, near [24, 64) half px = [48, 126] full px, margin 2: top = 61 px.
const nlohmann::json kParams = {{"min_far", 0}, {"num_far", 64}, {"min_near", 24}, {"num_near", 40}, {"margin_px", 2}};

// Values of a matcher over [min, min + num) (Q4, integer and fractional), its invalid value
// (min - 1) * 16 with probability invalid_share, and now and then any s16 at all.
Plane matcher_output(int width, int height, ptrdiff_t stride, uint32_t seed, int min, int num, double invalid_share) {
  Plane plane = random_plane(width, height, {ElementType::s16, 4}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> value(min * 16, (min + num - 1) * 16);
  std::uniform_int_distribution<int> any(-32768, 32767);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double draw = unit(generator);
      plane.at<int16_t>(x, y) = static_cast<int16_t>(draw < invalid_share ? (min - 1) * 16 : (draw > 0.99 ? any(generator) : value(generator)));
    }
  }
  return plane;
}

KernelCase fuse_case(int width, int height, uint32_t seed, double invalid_share) {
  KernelCase test_case{"disparity_fuse_multires", kParams, {}, 6};
  test_case.inputs.push_back(matcher_output(width, height, width * 2 + 10, seed, 0, 64, invalid_share));
  test_case.inputs.push_back(matcher_output((width + 1) / 2, (height + 1) / 2, (width + 1) / 2 * 2 + 8, seed + 1, 24, 40, invalid_share));
  return test_case;
}

// Tile widths are even (block_width 2) except a whole-width tile; tile heights may be odd, so that
// tiles start on odd rows of the output and even or odd rows of the half input.
const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {34, 7}, {630, 1}, {2, 1}, {2, 3}};

TEST(DisparityFuseMultires, MatchesReferenceAtOddSizeInPaddedBuffers) {
  for (double invalid_share : {0.0, 0.25, 0.8}) {
    expect_all_back_ends_match_reference(fuse_case(631, 479, 41, invalid_share), kTileShapes);
  }
}

TEST(DisparityFuseMultires, MatchesReferenceAtEvenAndTinySizes) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{640, 480}, {1, 1}, {2, 2}, {3, 1}, {65, 3}, {129, 2}}) {
    expect_all_back_ends_match_reference(fuse_case(width, height, 42, 0.3), {{width, height}, {2, 1}, {64, 2}});
  }
}

// One row of full-resolution pixels with their half-resolution neighbours (x / 2): each case of the
// rule. far invalid = -16, near invalid = 23 * 16 = 368, top = 61 * 16 = 976. The left band is half
// columns 0 .. 62 (min_near + num_near - 1 = 63): the cases of the rule as such start at half column
// 63, the band's cases sit at its first and last half columns, and the rest of the band holds two
// invalid values.
TEST(DisparityFuseMultires, GoldenValuesOfTheFusionRule) {
  struct Case {
    int half_column;
    int16_t full, half, expected;
    const char* why;
  };
  constexpr int kBandEnd = 63;
  const std::vector<Case> cases = {
      {0, 100, 368, -16, "left band, near invalid: the far value refused (its match may lie left of the right image)"},
      {1, 976, 368, -16, "left band, near invalid: even the top trusted far value refused"},
      {2, 100, 480, 100, "left band, near x 2 = 960 inside the far range: the far value"},
      {3, 100, 500, 1000, "left band, near x 2 = 1000 beyond the far range: the near value x 2"},
      {4, -16, 700, 1400, "left band, far invalid: the near value x 2"},
      {kBandEnd - 1, 100, 368, -16, "the band's last half column, near invalid: the far value refused"},
      {kBandEnd + 0, 100, 480, 100, "near x 2 = 960 inside the far range: the far value"},
      {kBandEnd + 1, 100, 500, 1000, "near x 2 = 1000 beyond the far range: the near value x 2, whatever the far pass found"},
      {kBandEnd + 2, 976, 368, 976, "past the band, near invalid: the top trusted far value"},
      {kBandEnd + 3, 977, 368, -16, "far value in the top margin, near invalid: invalid"},
      {kBandEnd + 4, 977, 480, -16, "far value in the top margin, near inside the far range: invalid"},
      {kBandEnd + 5, -16, 700, 1400, "far invalid: the near value x 2"},
      {kBandEnd + 6, -16, 480, -16, "far invalid, near x 2 = 960 inside the far range: invalid"},
      {kBandEnd + 7, -16, 489, 978, "far invalid, near x 2 = 978 just above top"},
      {kBandEnd + 8, -16, 368, -16, "both invalid"},
      {kBandEnd + 9, 0, 300, 0, "near below its invalid value counts as invalid; disparity 0 is a valid far value"},
      {kBandEnd + 10, -20, 368, -16, "far below its invalid value counts as invalid"},
      {kBandEnd + 11, 100, 368, 100, "past the band, near invalid: the far value"},
  };
  const int half_width = cases.back().half_column + 1;
  const int width = 2 * half_width;
  Plane full(width, 2, {ElementType::s16, 4});
  Plane half(half_width, 1, {ElementType::s16, 4});
  std::vector<int16_t> expected(static_cast<size_t>(half_width), -16);  // the band's filler: both invalid
  std::vector<const char*> why(static_cast<size_t>(half_width), "left band, both invalid");
  for (int h = 0; h < half_width; ++h) {
    half.at<int16_t>(h, 0) = 368;
    for (int y = 0; y < 2; ++y) {
      for (int dx = 0; dx < 2; ++dx) full.at<int16_t>(2 * h + dx, y) = -16;
    }
  }
  for (const Case& c : cases) {
    half.at<int16_t>(c.half_column, 0) = c.half;
    for (int y = 0; y < 2; ++y) {
      for (int dx = 0; dx < 2; ++dx) full.at<int16_t>(2 * c.half_column + dx, y) = c.full;
    }
    expected[static_cast<size_t>(c.half_column)] = c.expected;
    why[static_cast<size_t>(c.half_column)] = c.why;
  }
  const KernelDescriptor& kernel = testing::kernel_named("disparity_fuse_multires");
  const PreparedKernel prepared = kernel.prepare(kParams, {{width, 2}, {width / 2, 1}});
  auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    // Tiles of 2 and 4 columns and of 124 (the band's end inside the second tile) start in the band
    // and past it: the band is the image's, not the tile's.
    for (auto [tile_width, tile_height] : std::vector<std::pair<int, int>>{{width, 2}, {2, 1}, {4, 1}, {124, 2}}) {
      Plane output(width, 2, {ElementType::s16, 4});
      VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {full.view(), half.view()},
                                {output.view()}, prepared.input_halos, prepared.input_scales};
      run_vector_node(binding, tile_width, tile_height, backend, isa);
      for (int h = 0; h < half_width; ++h) {
        for (int y = 0; y < 2; ++y) {
          for (int dx = 0; dx < 2; ++dx) {
            EXPECT_EQ(output.at<int16_t>(2 * h + dx, y), expected[static_cast<size_t>(h)])
                << label << " tile " << tile_width << "x" << tile_height << ", half column " << h << ": " << why[static_cast<size_t>(h)];
          }
        }
      }
    }
  };
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The closed form of kernels/disparity_fuse_multires.cpp: per chunk of 64 output pixels (two
// vectors of the counting back end's 32 16-bit lanes) 3 loads, 1 shift, 6 compares, 6 logic,
// 2 max (arith), 2 zips (permute), 2 stores; per chunk whose first output column lies in the left
// band (column < 2 x 63 = 126 with kParams) 3 permutes, 1 arith, 1 compare, 3 logic more; per tile
// 1 load and 5 broadcasts (permute).
TEST(DisparityFuseMultires, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU16 == 32, "the closed form assumes 32 16-bit lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 640, 16}, {1, 1, 1, 1}, {65, 7, 64, 7},
                                               {631, 479, 100, 37}, {200, 3, 6, 5}}) {
    const KernelCase test_case = fuse_case(shape.width, shape.height, 43, 0.3);
    const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 64);
    int64_t band_chunks = 0;  // chunk starts at output columns below 126, one per row of the image
    for (int tile_x = 0; tile_x < shape.width; tile_x += shape.tile_width) {
      const int tile_width = std::min(shape.tile_width, shape.width - tile_x);
      for (int x = 0; x < tile_width; x += 64) band_chunks += tile_x + x < 2 * 63 ? shape.height : 0;
    }
    simd::OpCounts expected;
    expected[simd::OpClass::load] = 3 * work.chunks + work.tiles;
    expected[simd::OpClass::shift] = work.chunks;
    expected[simd::OpClass::compare] = 6 * work.chunks + band_chunks;
    expected[simd::OpClass::logic] = 6 * work.chunks + 3 * band_chunks;
    expected[simd::OpClass::arith] = 2 * work.chunks + band_chunks;
    expected[simd::OpClass::permute] = 2 * work.chunks + 3 * band_chunks + 5 * work.tiles;
    expected[simd::OpClass::store] = 2 * work.chunks;
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
  }
}

std::string prepare_error(const nlohmann::json& params, const std::vector<PlaneShape>& shapes) {
  try {
    testing::kernel_named("disparity_fuse_multires").prepare(params, shapes);
  } catch (const KernelError& error) {
    return error.what();
  }
  return "no error";
}

TEST(DisparityFuseMultiresMustFail, RefusesAWrongHalfSizeAndANearRangeThatAddsNothing) {
  EXPECT_EQ(prepare_error(kParams, {{631, 479}, {315, 240}}),
            "port 'half': expected half of the full-resolution 631x479 (316x240), got 315x240");
  nlohmann::json short_near = kParams;
  short_near["num_near"] = 7;  // near top 2 x 30 = 60 <= 61
  EXPECT_EQ(prepare_error(short_near, {{64, 64}, {32, 32}}),
            "parameters 'min_near' + 'num_near': expected a near range reaching beyond the trusted far range (2 x 30 > 61 "
            "full-resolution px), got 60");
  nlohmann::json wide_near = kParams;
  wide_near["num_near"] = 1000;  // 2 x (24 + 999) would not fit s16 Q4
  EXPECT_EQ(prepare_error(wide_near, {{64, 64}, {32, 32}}),
            "parameter 'num_near': expected an integer in [1, 999], got 1000");
  nlohmann::json unknown = kParams;
  unknown["upsampling"] = "bilinear";
  EXPECT_NE(prepare_error(unknown, {{64, 64}, {32, 32}}).find("unknown parameter 'upsampling'"), std::string::npos);
  EXPECT_EQ(testing::kernel_named("disparity_fuse_multires").block_width, 2);
}

}  // namespace
}  // namespace lpstereo
