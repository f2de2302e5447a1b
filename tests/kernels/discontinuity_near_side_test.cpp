// discontinuity_near_side: bit-exact against the reference on every back end at odd sizes in padded
// buffers and across tile shapes (a disparity-like map with nearer blocks, invalid pixels, values
// below the invalid one and the s16 extremes; random bits with extreme invalid values, where the
// u16 mapping of kernels/discontinuity_near_side.cpp is at its bounds); the rule in golden cases
// worked by hand; the host function arm::invalidate_near_side_of_discontinuities gives the same
// bits; the closed-form op count; refused parameters.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "arm/terrain_points.h"
#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

constexpr int16_t kInvalid = -16;  // min_disparity 0

// A disparity map like the matcher's: a ground ramp (disparity growing down the rows), nearer
// rectangles (a few px more), about `invalid_share` invalid pixels, a few values below the invalid
// one and the s16 extremes; in a padded buffer (stride) whose padding holds random bits.
Plane disparity_map(int width, int height, ptrdiff_t stride, uint32_t seed, double invalid_share) {
  Plane plane = random_plane(width, height, {ElementType::s16, 4}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> noise(-6, 6);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      int value = 16 * 2 + y * 3 + noise(generator);  // the ground: 0.2 px a row
      if ((x / 23 + y / 17) % 5 == 0) value += 16 * 6;     // nearer blocks, 6 px up
      const double draw = unit(generator);
      if (draw < invalid_share) value = kInvalid;
      else if (draw > 0.997) value = -32768;
      else if (draw > 0.994) value = 32767;
      plane.at<int16_t>(x, y) = static_cast<int16_t>(value);
    }
  }
  return plane;
}

nlohmann::json params(int radius, int jump_q4, int invalid_q4 = kInvalid) {
  return {{"invalid_q4", invalid_q4}, {"radius_px", radius}, {"jump_q4", jump_q4}};
}

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}, {1, 1}};

TEST(DiscontinuityNearSide, MatchesReferenceAtOddSizeInPaddedBuffer) {
  for (const auto& [radius, jump_q4] : std::vector<std::pair<int, int>>{{3, 32}, {1, 1}, {8, 200}, {2, 32767}}) {
    for (double invalid_share : {0.0, 0.3}) {
      KernelCase test_case{"discontinuity_near_side", params(radius, jump_q4), {}, 6};
      test_case.inputs.push_back(disparity_map(631, 479, 640 * 2 + 4, 41, invalid_share));
      SCOPED_TRACE("radius " + std::to_string(radius) + " jump " + std::to_string(jump_q4));
      expect_all_back_ends_match_reference(test_case, kTileShapes);
    }
  }
}

TEST(DiscontinuityNearSide, MatchesReferenceOnRandomBitsWithExtremeInvalidValues) {
  for (int invalid_q4 : {-32768, -1008, -16, 0, 32766}) {
    KernelCase random_bits{"discontinuity_near_side", params(3, 32, invalid_q4), {}, 2};
    random_bits.inputs.push_back(random_plane(203, 97, {ElementType::s16, 4}, 203 * 2 + 10, 42));
    SCOPED_TRACE("invalid_q4 " + std::to_string(invalid_q4));
    expect_all_back_ends_match_reference(random_bits, {{203, 97}, {16, 8}, {3, 2}});
  }
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {33, 2}, {65, 1}}) {
    KernelCase test_case{"discontinuity_near_side", params(3, 32), {}, 4};
    test_case.inputs.push_back(disparity_map(width, height, width * 2 + 6, 43, 0.3));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
}

Plane run_kernel(const Plane& input, const nlohmann::json& kernel_params, KernelBackend backend, simd::Isa isa, int tile_width,
                 int tile_height) {
  const KernelDescriptor& kernel = testing::kernel_named("discontinuity_near_side");
  const PreparedKernel prepared = kernel.prepare(kernel_params, {{input.width(), input.height()}});
  Plane output(input.width(), input.height(), {ElementType::s16, 4});
  VectorNodeBinding binding{&kernel,        prepared.params.get(), BorderMode::replicate, 0, {input.view()}, {output.view()},
                            prepared.input_halos};
  run_vector_node(binding, tile_width, tile_height, backend, isa);
  return output;
}

// Worked by hand, radius 1, jump 2 px (32): a 12 x 9 map of 4 px (64) ground with a 4 x 5 block of
// 10 px (160) at x 4..7, y 2..6. The block's outer ring has ground within 1 px, 6 px lower: invalid;
// its inner 2 x 3 (x 5..6, y 3..5) keeps 160; the ground keeps 64 (nothing lower near it). An
// invalid pixel (-16) at (5, 3) changes nothing around it (not a value to compare with) and stays
// -16; a value below the invalid one (-32768) at (6, 4) is copied and ignored likewise; a pixel at
// 2 px + 1 above the ground (64 + 33 = 97) at (10, 7) is dropped, one at 2 px (96) at (1, 7) is not.
TEST(DiscontinuityNearSide, GoldenValuesOfTheRule) {
  Plane map(12, 9, {ElementType::s16, 4}, 12 * 2 + 8);
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 12; ++x) map.at<int16_t>(x, y) = (x >= 4 && x <= 7 && y >= 2 && y <= 6) ? int16_t{160} : int16_t{64};
  }
  map.at<int16_t>(5, 3) = kInvalid;
  map.at<int16_t>(6, 4) = -32768;
  map.at<int16_t>(10, 7) = 97;
  map.at<int16_t>(1, 7) = 96;
  auto expected = [](int x, int y) -> int16_t {
    if (x == 5 && y == 3) return kInvalid;
    if (x == 6 && y == 4) return -32768;
    if (x == 10 && y == 7) return kInvalid;
    if (x == 1 && y == 7) return 96;
    const bool block = x >= 4 && x <= 7 && y >= 2 && y <= 6;
    if (!block) return 64;
    const bool inner = x >= 5 && x <= 6 && y >= 3 && y <= 5;
    return inner ? int16_t{160} : kInvalid;
  };
  auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    for (auto [tile_width, tile_height] : std::vector<std::pair<int, int>>{{12, 9}, {5, 2}}) {
      const Plane out = run_kernel(map, params(1, 32), backend, isa, tile_width, tile_height);
      for (int y = 0; y < 9; ++y) {
        for (int x = 0; x < 12; ++x) {
          EXPECT_EQ(out.at<int16_t>(x, y), expected(x, y)) << label << " x=" << x << " y=" << y << " tiles " << tile_width;
        }
      }
    }
  };
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The host function (arm/terrain_points.h), which `lpstereo terrain` and the terrain evaluation run,
// gives the same bits: jump_px 2.0 is jump_q4 32, 1.3 px is ceil(20.8) = 21.
TEST(DiscontinuityNearSide, EqualsTheHostFunction) {
  for (const auto& [radius, jump_px] : std::vector<std::pair<int, double>>{{3, 2.0}, {1, 1.3}, {5, 0.5}}) {
    const Plane input = disparity_map(331, 211, 0, 44, 0.2);
    Plane host = input.clone();
    const int64_t dropped = arm::invalidate_near_side_of_discontinuities(host, kInvalid, radius, jump_px);
    const int jump_q4 = static_cast<int>(std::ceil(16 * jump_px));
    const Plane out = run_kernel(input, params(radius, jump_q4), KernelBackend::native, simd::available_isas().back(), 100, 37);
    EXPECT_TRUE(testing::planes_equal(host, out)) << "radius " << radius << " jump " << jump_px;
    EXPECT_GT(dropped, 100) << "the map has jumps to drop";
  }
}

// The closed form of kernels/discontinuity_near_side.cpp, counting back end (L = 32 u16 lanes).
TEST(DiscontinuityNearSide, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU16 == 32, "the closed form assumes 32 16-bit lanes");
  struct Shape {
    int width, height, tile_width, tile_height, radius;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479, 3}, {640, 480, 640, 16, 3}, {1, 1, 1, 1, 1}, {33, 7, 33, 7, 8},
                                               {631, 479, 100, 37, 2}, {200, 3, 7, 5, 3}}) {
    KernelCase test_case{"discontinuity_near_side", params(shape.radius, 32), {}, 0};
    test_case.inputs.push_back(disparity_map(shape.width, shape.height, 0, 45, 0.2));
    const int64_t R = 2 * shape.radius + 1;
    simd::OpCounts expected;
    for (const TileRect& tile : make_tiles(shape.width, shape.height, shape.tile_width, shape.tile_height)) {
      const int64_t c1 = (tile.width + 2 * shape.radius + 31) / 32, c2 = (tile.width + 31) / 32, rows = tile.height;
      expected[simd::OpClass::load] += rows * (R * c1 + (R + 1) * c2);
      expected[simd::OpClass::arith] += rows * ((2 * R - 1) * c1 + (R + 1) * c2);
      expected[simd::OpClass::compare] += rows * 2 * c2;
      expected[simd::OpClass::logic] += rows * 2 * c2;
      expected[simd::OpClass::store] += rows * (c1 + c2);
      expected[simd::OpClass::permute] += 3;
    }
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height << " radius "
        << shape.radius;
  }
}

TEST(DiscontinuityNearSideMustFail, RefusesUnknownAndOutOfRangeParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("discontinuity_near_side");
  EXPECT_THROW(kernel.prepare({{"jump_px", 2}}, {{10, 10}}), KernelError);
  for (const auto& [name, value] : std::vector<std::pair<std::string, int>>{
           {"radius_px", 0}, {"radius_px", 9}, {"jump_q4", 0}, {"jump_q4", 32768}, {"invalid_q4", 32767}}) {
    try {
      kernel.prepare({{name, value}}, {{10, 10}});
      ADD_FAILURE() << name << " " << value << ": expected KernelError";
    } catch (const KernelError& error) {
      EXPECT_NE(std::string(error.what()).find("parameter '" + name + "'"), std::string::npos) << error.what();
      EXPECT_NE(std::string(error.what()).find("got " + std::to_string(value)), std::string::npos) << error.what();
    }
  }
}

}  // namespace
}  // namespace lpstereo
