// disparity_to_points: bit-exact against the reference on every back end at odd sizes in padded
// buffers, golden points worked out by hand, the error bound of kernels/disparity_to_points.cpp
// against double precision for every Q4 disparity of the largest range, no overflow at the
// parameter limits, the closed-form op count, and the parameters it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "dag/tile_executor.h"
#include "kernels/disparity_to_points.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using kernels::kNoPointMm;
using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;

nlohmann::json camera(double baseline_m, double focal_px, double u0_px, double v0_px, int min_disparity,
                      int num_disparities) {
  return {{"baseline_m", baseline_m}, {"focal_px", focal_px},           {"u0_px", u0_px},
          {"v0_px", v0_px},           {"min_disparity", min_disparity}, {"num_disparities", num_disparities}};
}

// A disparity map over [min_disparity, min_disparity + num_disparities) in Q4 with sub-pixel
// values, about 20 % invalid, and a few values outside the range (0, negative, above), padded.
Plane disparity_map(int width, int height, ptrdiff_t stride, uint32_t seed, int min_disparity, int num_disparities) {
  Plane plane = testing::random_plane(width, height, {ElementType::s16, 4}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> value(16 * min_disparity, 16 * (min_disparity + num_disparities) + 15);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double draw = unit(generator);
      int v = value(generator);
      if (draw < 0.2) v = (min_disparity - 1) * 16;
      else if (draw < 0.22) v = 0;
      else if (draw < 0.24) v = -1 - static_cast<int>(draw * 1000);
      else if (draw > 0.99) v = draw > 0.995 ? 32767 : 16 * (min_disparity + num_disparities) + 1;
      plane.at<int16_t>(x, y) = static_cast<int16_t>(v);
    }
  }
  return plane;
}

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}, {1, 1}};

TEST(DisparityToPoints, MatchesReferenceAtOddSizeInPaddedBuffer) {
  // min_disparity -3 (invalid marker negative) and 5 (marker 64 = 4 px, inside the table: flagged).
  for (int min_disparity : {-3, 5}) {
    KernelCase test_case{"disparity_to_points", camera(0.12, 700.3, 315.37, 240.81, min_disparity, 64), {}, 12};
    test_case.inputs.push_back(disparity_map(631, 479, 640 * 2 + 6, 41, min_disparity, 64));
    const std::vector<Plane> reference = expect_all_back_ends_match_reference(test_case, kTileShapes);
    // The test means something only if both kinds of pixel occur.
    int points = 0, no_points = 0;
    for (int y = 0; y < 479; ++y) {
      for (int x = 0; x < 631; ++x) (reference[2].at<int32_t>(x, y) == kNoPointMm ? no_points : points) += 1;
    }
    EXPECT_GT(points, 631 * 479 / 2);
    EXPECT_GT(no_points, 631 * 479 / 10);
  }
}

TEST(DisparityToPoints, MatchesReferenceOnTinyImagesAndRandomBits) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {17, 2}, {33, 1}}) {
    KernelCase test_case{"disparity_to_points", camera(0.3, 1200.0, width / 2.0, height / 2.0, 0, 128), {}, 4};
    test_case.inputs.push_back(disparity_map(width, height, width * 2 + 2, 42, 0, 128));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
  KernelCase random_bits{"disparity_to_points", camera(1.5, 2000.0, 100.0, 50.0, -20, 2000), {}, 8};
  random_bits.inputs.push_back(testing::random_plane(203, 97, {ElementType::s16, 4}, 203 * 2 + 10, 43));
  expect_all_back_ends_match_reference(random_bits, {{203, 97}, {16, 8}, {3, 2}});
}

struct Points {
  std::vector<Plane> planes;  // x, y, z
  int32_t at(int plane, int x, int y) const { return planes[static_cast<size_t>(plane)].at<int32_t>(x, y); }
};

Points run_points(const nlohmann::json& params, const Plane& disparity, KernelBackend backend = KernelBackend::native,
                  simd::Isa isa = simd::active_isa()) {
  const KernelDescriptor& kernel = testing::kernel_named("disparity_to_points");
  const PreparedKernel prepared = kernel.prepare(params, {{disparity.width(), disparity.height()}});
  Points points;
  std::vector<PlaneView> views;
  for (int i = 0; i < 3; ++i) {
    points.planes.emplace_back(disparity.width(), disparity.height(), BufferFormat{ElementType::s32, 0});
    views.push_back(points.planes.back().view());
  }
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {disparity.view()}, views};
  run_vector_node(binding, 64, 16, backend, isa);
  return points;
}

// b = 0.1 m, f = 500 px, (u0, v0) = (10, 5), min_disparity 2 (invalid marker 16 = 1 px):
//   (30, 5), d = 10 px:    z = 0.1 * 500 / 10 = 5 m, x = 0.1 * 20 / 10 = 0.2 m, y = 0;
//   (0, 25), d = 2.5 px:   z = 20 m, x = 0.1 * -10 / 2.5 = -0.4 m, y = 0.1 * 20 / 2.5 = 0.8 m;
//   (3, 0), d = 0.0625 px: z = 800 m, x = 0.1 * -7 / 0.0625 = -11.2 m, y = -8 m (the smallest d);
//   the invalid marker 1 px, d = 0, d < 0 and d above 16 (min + num) px: no point.
TEST(DisparityToPoints, GoldenPointsWorkedByHand) {
  Plane disparity(31, 26, {ElementType::s16, 4});
  disparity.at<int16_t>(30, 5) = 160;
  disparity.at<int16_t>(0, 25) = 40;
  disparity.at<int16_t>(3, 0) = 1;
  disparity.at<int16_t>(4, 0) = 16;
  disparity.at<int16_t>(5, 0) = 0;
  disparity.at<int16_t>(6, 0) = -5;
  disparity.at<int16_t>(7, 0) = 16 * 16 + 1;
  disparity.at<int16_t>(8, 0) = 16 * 16;  // the top of the range still has a point: 0.1 * 500 / 16 m
  const nlohmann::json params = camera(0.1, 500.0, 10.0, 5.0, 2, 14);
  auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Points points = run_points(params, disparity, backend, isa);
    EXPECT_EQ(points.at(0, 30, 5), 200) << label;
    EXPECT_EQ(points.at(1, 30, 5), 0) << label;
    EXPECT_EQ(points.at(2, 30, 5), 5000) << label;
    EXPECT_EQ(points.at(0, 0, 25), -400) << label;
    EXPECT_EQ(points.at(1, 0, 25), 800) << label;
    EXPECT_EQ(points.at(2, 0, 25), 20000) << label;
    EXPECT_EQ(points.at(0, 3, 0), -11200) << label;
    EXPECT_EQ(points.at(1, 3, 0), -8000) << label;
    EXPECT_EQ(points.at(2, 3, 0), 800000) << label;
    EXPECT_EQ(points.at(2, 8, 0), 3125) << label;
    for (int x = 4; x <= 7; ++x) {
      for (int plane = 0; plane < 3; ++plane) EXPECT_EQ(points.at(plane, x, 0), kNoPointMm) << label << " x=" << x;
    }
  };
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// Middlebury's doffs (Z = f B / (d + doffs)): b = 0.2 m, f = 1000 px, doffs = 2.5 px, (u0, v0) =
// (4, 2); d = 7.5 px at (24, 2) -> z = 0.2 * 1000 / 10 = 20 m, x = 0.2 * 20 / 10 = 0.4 m. With
// doffs = -3 px, d = 2 px gives d + doffs < 1/16 px: no point; d = 4 px -> z = 200 m.
TEST(DisparityToPoints, DisparityOffsetShiftsTheTable) {
  Plane disparity(25, 3, {ElementType::s16, 4});
  disparity.at<int16_t>(24, 2) = 120;
  nlohmann::json params = camera(0.2, 1000.0, 4.0, 2.0, 0, 64);
  params["disparity_offset_px"] = 2.5;
  Points points = run_points(params, disparity);
  EXPECT_EQ(points.at(0, 24, 2), 400);
  EXPECT_EQ(points.at(1, 24, 2), 0);
  EXPECT_EQ(points.at(2, 24, 2), 20000);
  disparity.at<int16_t>(0, 0) = 32;
  disparity.at<int16_t>(1, 0) = 64;
  params["disparity_offset_px"] = -3.0;
  points = run_points(params, disparity);
  EXPECT_EQ(points.at(2, 0, 0), kNoPointMm);
  EXPECT_EQ(points.at(2, 1, 0), 200000);
  KernelCase test_case{"disparity_to_points", params, {}, 4};
  test_case.inputs.push_back(disparity_map(97, 31, 97 * 2 + 4, 45, 0, 64));
  expect_all_back_ends_match_reference(test_case, {{97, 31}, {16, 4}});
}

// Every Q4 disparity of the largest range (1/16 .. 2047 px), at |u - u0| up to the 4096 px limit on
// either side: |z - 16 b f / d_q4| <= 0.5 mm and |x - b du_q4 / d_q4| <= 0.5 + |du_q4| / 2^16 mm
// (<= 1.5 mm) against double precision, with du_q4 = 16 u - round(16 u0) (the header's bound); y
// the same with v. Prints the largest errors seen.
TEST(DisparityToPoints, ErrorWithinTheBoundForEveryQ4Disparity) {
  const double baseline_m = 0.3, focal_px = 1400.0;
  const int width = 4096, height = 8;
  Plane disparity(width, height, {ElementType::s16, 4});
  for (int i = 0; i < width * height; ++i) disparity.at<int16_t>(i % width, i / width) = static_cast<int16_t>(std::min(i + 1, 32752));
  double worst_x = 0, worst_y = 0, worst_z = 0;
  for (double u0_px : {0.2, 4095.7}) {
    const double v0_px = 3.4;
    const Points points = run_points(camera(baseline_m, focal_px, u0_px, v0_px, 0, 2047), disparity);
    const double u0_q4 = std::lround(16 * u0_px), v0_q4 = std::lround(16 * v0_px), b_mm = 1000 * baseline_m;
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const double d_q4 = disparity.at<int16_t>(u, v);
        const double du_q4 = 16.0 * u - u0_q4, dv_q4 = 16.0 * v - v0_q4;
        const double error_x = std::abs(points.at(0, u, v) - b_mm * du_q4 / d_q4);
        const double error_y = std::abs(points.at(1, u, v) - b_mm * dv_q4 / d_q4);
        const double error_z = std::abs(points.at(2, u, v) - 16.0 * b_mm * focal_px / d_q4);
        ASSERT_LE(error_x, 0.5 + std::abs(du_q4) / 65536.0 + 1e-9) << "u=" << u << " v=" << v << " d_q4=" << d_q4;
        ASSERT_LE(error_y, 0.5 + std::abs(dv_q4) / 65536.0 + 1e-9) << "u=" << u << " v=" << v << " d_q4=" << d_q4;
        ASSERT_LE(error_z, 0.5 + 1e-9) << "u=" << u << " v=" << v << " d_q4=" << d_q4;
        worst_x = std::max(worst_x, error_x);
        worst_y = std::max(worst_y, error_y);
        worst_z = std::max(worst_z, error_z);
      }
    }
  }
  std::printf("largest error against double precision: x %.3f mm, y %.3f mm, z %.3f mm\n", worst_x, worst_y, worst_z);
  EXPECT_LE(worst_x, 1.5);
  EXPECT_GT(worst_x, 0.5);  // |du| reaches 2^16: the table term of the bound is exercised
}

// The parameter limits of the no-overflow proof: b = 32 m, |u - u0| and |v - v0| at 4096 px, the
// smallest disparity (1/16 px) and the top of the largest range. x and y keep their sign and stay
// within the bound of the exact value; z saturates to 2^31 - 1 where 16 b f / d_q4 exceeds it.
TEST(DisparityToPoints, NoOverflowAtTheLargestRangeAndSmallestDisparity) {
  const double baseline_m = 32.0, focal_px = 1e5;
  Plane disparity(4096, 2, {ElementType::s16, 4});
  for (int u = 0; u < 4096; ++u) {
    for (int v = 0; v < 2; ++v) disparity.at<int16_t>(u, v) = static_cast<int16_t>(u % 3 == 0 ? 1 : (u % 3 == 1 ? 32752 : 2));
  }
  // u0 at the left edge (du up to +65520), v0 4096 px below row 0 (dv = -65536).
  const nlohmann::json params = camera(baseline_m, focal_px, 0.0, 4096.0, 0, 2047);
  KernelCase test_case{"disparity_to_points", params, {}, 0};
  test_case.inputs.push_back(disparity);
  expect_all_back_ends_match_reference(test_case, {{4096, 2}, {64, 1}});
  const Points points = run_points(params, disparity);
  for (int v = 0; v < 2; ++v) {
    for (int u : {0, 1, 2, 4093, 4094, 4095}) {
      const long double d_q4 = disparity.at<int16_t>(u, v);
      const long double exact_x = 32000.0L * (16.0L * u) / d_q4;
      const long double exact_y = 32000.0L * (16.0L * v - 65536.0L) / d_q4;
      const long double exact_z = 16.0L * 32000.0L * 1e5L / d_q4;
      EXPECT_LE(std::abs(points.at(0, u, v) - exact_x), 1.5L) << "u=" << u << " v=" << v << " d_q4=" << d_q4;
      EXPECT_LE(std::abs(points.at(1, u, v) - exact_y), 1.5L) << "u=" << u << " v=" << v << " d_q4=" << d_q4;
      if (exact_z >= 2147483647.0L) {
        EXPECT_EQ(points.at(2, u, v), 2147483647) << "u=" << u << " d_q4=" << d_q4;
      } else {
        EXPECT_LE(std::abs(points.at(2, u, v) - exact_z), 0.5L) << "u=" << u << " d_q4=" << d_q4;
      }
    }
  }
  // The extremes: x at u = 4095, d = 1/16 px is 32 m * 4095 / 0.0625 = 2,096,640,000 mm, within
  // 2^26 of the s32 limit; y at v = 0, d = 1/16 px is 32 m * -4096 / 0.0625 = -2,097,152,000 mm.
  EXPECT_EQ(points.at(0, 4095, 0), 2096640000);
  EXPECT_EQ(points.at(1, 0, 0), -2097152000);
}

// The closed form of kernels/disparity_to_points.cpp: per chunk of 16 pixels (the counting back
// end's 32-bit lanes) 1 load, 1 permute, 7 arith, 4 gathers, 1 compare, 4 multiplies, 3 shifts,
// 4 logic, 3 stores; per tile row 2 permutes and 1 arith; per tile 6 permutes and 1 load.
TEST(DisparityToPoints, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU32 == 16, "the closed form assumes 16 32-bit lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 640, 16}, {1, 1, 1, 1}, {33, 7, 33, 7},
                                               {631, 479, 100, 37}, {200, 3, 7, 5}}) {
    KernelCase test_case{"disparity_to_points", camera(0.2, 800.0, shape.width / 2.0, shape.height / 2.0, 0, 64), {}, 0};
    test_case.inputs.push_back(disparity_map(shape.width, shape.height, 0, 44, 0, 64));
    const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 16);
    simd::OpCounts expected;
    expected[simd::OpClass::load] = work.chunks + work.tiles;
    expected[simd::OpClass::permute] = work.chunks + 2 * work.rows + 6 * work.tiles;
    expected[simd::OpClass::arith] = 7 * work.chunks + work.rows;
    expected[simd::OpClass::gather] = 4 * work.chunks;
    expected[simd::OpClass::compare] = work.chunks;
    expected[simd::OpClass::multiply] = 4 * work.chunks;
    expected[simd::OpClass::shift] = 3 * work.chunks;
    expected[simd::OpClass::logic] = 4 * work.chunks;
    expected[simd::OpClass::store] = 3 * work.chunks;
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
  }
}

TEST(DisparityToPointsMustFail, RefusesParametersOutsideTheProof) {
  const KernelDescriptor& kernel = testing::kernel_named("disparity_to_points");
  auto message = [&](const nlohmann::json& params, PlaneShape shape) -> std::string {
    try {
      kernel.prepare(params, {shape});
    } catch (const KernelError& error) {
      return error.what();
    }
    return "accepted";
  };
  EXPECT_EQ(message(camera(40.0, 500, 10, 10, 0, 64), {20, 20}),
            "parameter 'baseline_m': expected a number in [1e-06, 32], got 40.0");
  EXPECT_NE(message(camera(0.1, 0.0, 10, 10, 0, 64), {20, 20}).find("focal_px"), std::string::npos);
  EXPECT_EQ(message(camera(0.1, 500, 10, 10, 0, 2048), {20, 20}).find("parameter 'num_disparities'"), 0u);
  EXPECT_EQ(message(camera(0.1, 500, 10, 10, -64, 64), {20, 20}),
            "parameters 'min_disparity' + 'num_disparities': expected a range reaching a positive disparity (sum >= 1), "
            "got -64 + 64");
  EXPECT_EQ(message(camera(0.1, 500, 10, 10, 0, 64), {5000, 20}),
            "parameter 'u0_px': |16 (pixel - u0_px)| over an image of 5000 px must stay <= 65536 (4096 px), got 79824 "
            "with u0_px = 10.000000");
  EXPECT_NE(message(camera(0.1, 500, 10, -5000, 0, 64), {20, 20}).find("'v0_px'"), std::string::npos);
  EXPECT_NE(message({{"baseline_m", 0.1}, {"focal_px", 500}, {"cx", 3}}, {20, 20}).find("cx"), std::string::npos);
  EXPECT_EQ(message(camera(0.1, 500, 10, 10, 0, 64), {20, 20}), "accepted");
}

}  // namespace
}  // namespace lpstereo
