// point_cell_binning: bit-exact against the kernel's reference on every back end at odd sizes in
// padded buffers, against an independent scalar model written here (doubles and std::floor), the
// reciprocal division exact for every offset of the largest area, golden cells worked by hand, no
// overflow at the range and rotation limits, the closed-form op count, and the parameters it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dag/tile_executor.h"
#include "kernels/disparity_to_points.h"
#include "kernels/point_cell_binning.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using kernels::kNoCell;
using kernels::kNoPointMm;
using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;

// A camera 1.65 m up, 0.1 m ahead of the origin, rolled 3 degrees, pitched 5 degrees down, yawed
// 2 degrees: R C of arm/point_cloud.h in Q14, written out here (Rz Ry Rx times the axis change C).
std::vector<int> mount_rotation_q14() {
  const double roll = 3 * M_PI / 180, pitch = 5 * M_PI / 180, yaw = 2 * M_PI / 180;
  const double cr = std::cos(roll), sr = std::sin(roll), cp = std::cos(pitch), sp = std::sin(pitch), cy = std::cos(yaw),
               sy = std::sin(yaw);
  const double r[3][3] = {{cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr},
                          {sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr},
                          {-sp, cp * sr, cp * cr}};
  // C: x_v = z_c, y_v = -x_c, z_v = -y_c, so (R C) column 0 = -R column 1, column 1 = -R column 2,
  // column 2 = R column 0.
  std::vector<int> q14;
  for (int k = 0; k < 3; ++k) {
    q14.push_back(static_cast<int>(std::lround(-16384 * r[k][1])));
    q14.push_back(static_cast<int>(std::lround(-16384 * r[k][2])));
    q14.push_back(static_cast<int>(std::lround(16384 * r[k][0])));
  }
  return q14;
}

nlohmann::json mount_params(int cell_mm = 500) {
  return {{"rotation_q14", mount_rotation_q14()}, {"translation_mm", {100, 0, 1650}}, {"forward_min_mm", 0},
          {"forward_max_mm", 34000},             {"lateral_min_mm", -11000},       {"lateral_max_mm", 11000},
          {"cell_mm", cell_mm}};
}

// Camera points over a scene in front of the camera (x in +-20 m, y from 3 m up to 4 m down, z to
// 40 m), about 10 % without a point and 3 % beyond the kernel's range, in padded planes.
std::vector<Plane> camera_points(int width, int height, ptrdiff_t stride, uint32_t seed) {
  std::vector<Plane> planes;
  for (int p = 0; p < 3; ++p) planes.push_back(testing::random_plane(width, height, {ElementType::s32, 0}, stride, seed + p));
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> lateral(-20000, 20000), vertical(-3000, 4000), forward(-1000, 40000);
  std::uniform_int_distribution<int> far(-200000, 200000);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      int32_t point[3] = {lateral(generator), vertical(generator), forward(generator)};
      const double draw = unit(generator);
      if (draw < 0.1) point[0] = point[1] = point[2] = kNoPointMm;
      else if (draw < 0.13) point[static_cast<int>(draw * 1000) % 3] = far(generator);
      for (int p = 0; p < 3; ++p) planes[static_cast<size_t>(p)].at<int32_t>(x, y) = point[p];
    }
  }
  return planes;
}

// The model written independently of the kernel file: doubles (exact for these magnitudes) and
// std::floor; returns {cell, height}.
std::pair<int32_t, int32_t> model_cell(const nlohmann::json& params, const int32_t point[3]) {
  for (int l = 0; l < 3; ++l) {
    if (point[l] < -65536 || point[l] > 65535) return {kNoCell, kNoPointMm};
  }
  const std::vector<int> rotation = params.at("rotation_q14").get<std::vector<int>>();
  const std::vector<int> translation = params.at("translation_mm").get<std::vector<int>>();
  double vehicle[3];
  for (int k = 0; k < 3; ++k) {
    double sum = 0;
    for (int l = 0; l < 3; ++l) sum += static_cast<double>(rotation[static_cast<size_t>(3 * k + l)]) * point[l];
    vehicle[k] = std::floor(sum / 16384.0 + 0.5) + translation[static_cast<size_t>(k)];
  }
  const double forward_min = params.at("forward_min_mm"), forward_max = params.at("forward_max_mm");
  const double lateral_min = params.at("lateral_min_mm"), lateral_max = params.at("lateral_max_mm");
  const double cell = params.at("cell_mm");
  if (vehicle[0] < forward_min || vehicle[0] >= forward_max || vehicle[1] < lateral_min || vehicle[1] >= lateral_max) {
    return {kNoCell, kNoPointMm};
  }
  const int lateral_cells = static_cast<int>(std::ceil((lateral_max - lateral_min) / cell));
  const int i = static_cast<int>(std::floor((vehicle[0] - forward_min) / cell));
  const int j = static_cast<int>(std::floor((vehicle[1] - lateral_min) / cell));
  return {i * lateral_cells + j, static_cast<int32_t>(vehicle[2])};
}

// Three separate s32 planes (Plane copies share their pixels, so not vector(3, plane)).
std::vector<Plane> point_planes(int width, int height) {
  std::vector<Plane> planes;
  for (int p = 0; p < 3; ++p) planes.emplace_back(width, height, BufferFormat{ElementType::s32, 0});
  return planes;
}

struct Binned {
  Plane cell, height;
};

Binned run_binning(const nlohmann::json& params, const std::vector<Plane>& points, KernelBackend backend = KernelBackend::native,
                   simd::Isa isa = simd::active_isa()) {
  const KernelDescriptor& kernel = testing::kernel_named("point_cell_binning");
  const PlaneShape shape{points[0].width(), points[0].height()};
  const PreparedKernel prepared = kernel.prepare(params, {shape, shape, shape});
  Binned binned{Plane(shape.width, shape.height, {ElementType::s32, 0}), Plane(shape.width, shape.height, {ElementType::s32, 0})};
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0,
                            {points[0].view(), points[1].view(), points[2].view()}, {binned.cell.view(), binned.height.view()}};
  run_vector_node(binding, 64, 16, backend, isa);
  return binned;
}

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}, {1, 1}};

TEST(PointCellBinning, MatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"point_cell_binning", mount_params(), {}, 12};
  test_case.inputs = camera_points(631, 479, 640 * 4 + 8, 51);
  const std::vector<Plane> reference = expect_all_back_ends_match_reference(test_case, kTileShapes);
  int cells = 0, no_cells = 0;
  for (int y = 0; y < 479; ++y) {
    for (int x = 0; x < 631; ++x) (reference[0].at<int32_t>(x, y) == kNoCell ? no_cells : cells) += 1;
  }
  EXPECT_GT(cells, 631 * 479 / 3);
  EXPECT_GT(no_cells, 631 * 479 / 10);
}

TEST(PointCellBinning, MatchesTheIndependentModel) {
  for (int cell_mm : {500, 173, 16}) {
    const nlohmann::json params = mount_params(cell_mm);
    const std::vector<Plane> points = camera_points(203, 97, 203 * 4 + 4, 52 + static_cast<uint32_t>(cell_mm));
    for (simd::Isa isa : simd::available_isas()) {
      const Binned binned = run_binning(params, points, KernelBackend::native, isa);
      for (int y = 0; y < 97; ++y) {
        for (int x = 0; x < 203; ++x) {
          const int32_t point[3] = {points[0].at<int32_t>(x, y), points[1].at<int32_t>(x, y), points[2].at<int32_t>(x, y)};
          const auto [cell, height] = model_cell(params, point);
          ASSERT_EQ(binned.cell.at<int32_t>(x, y), cell) << simd::isa_name(isa) << " x=" << x << " y=" << y << " cell " << cell_mm;
          ASSERT_EQ(binned.height.at<int32_t>(x, y), height) << simd::isa_name(isa) << " x=" << x << " y=" << y;
        }
      }
    }
  }
}

TEST(PointCellBinning, MatchesReferenceOnTinyImagesAndRandomBits) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {17, 2}, {33, 1}}) {
    KernelCase test_case{"point_cell_binning", mount_params(), {}, 4};
    test_case.inputs = camera_points(width, height, width * 4 + 4, 53);
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
  KernelCase random_bits{"point_cell_binning", mount_params(250), {}, 8};
  for (uint32_t p = 0; p < 3; ++p) random_bits.inputs.push_back(testing::random_plane(203, 97, {ElementType::s32, 0}, 203 * 4 + 12, 54 + p));
  expect_all_back_ends_match_reference(random_bits, {{203, 97}, {16, 8}, {3, 2}});
}

// The reciprocal division is exact for every lateral offset of the widest area the kernel takes
// (130 m: -65 m .. 65 m; the level camera maps y_v = -x_c): every n in [0, 130000) against integer
// division, for cell sizes that divide 2^17 and ones that do not.
TEST(PointCellBinning, ReciprocalDivisionExactOverTheWidestArea) {
  const int width = 1000, height = 130;
  std::vector<Plane> points = point_planes(width, height);
  for (int n = 0; n < width * height; ++n) {
    points[0].at<int32_t>(n % width, n / width) = 65000 - n;  // y_v = n - 65000, lateral offset n
    points[1].at<int32_t>(n % width, n / width) = 0;
    points[2].at<int32_t>(n % width, n / width) = 500;  // x_v = 500
  }
  for (int cell_mm : {16, 17, 333, 500, 4096, 4097, 65535}) {
    const nlohmann::json params = {{"translation_mm", {0, 0, 0}}, {"forward_min_mm", 0}, {"forward_max_mm", 1000},
                                   {"lateral_min_mm", -65000},    {"lateral_max_mm", 65000}, {"cell_mm", cell_mm}};
    const Binned binned = run_binning(params, points);
    // x_v = 500 mm: forward cell 500 / c; lateral cell n / c of ceil(130000 / c).
    const int lateral_cells = (130000 + cell_mm - 1) / cell_mm;
    for (int n = 0; n < width * height; ++n) {
      ASSERT_EQ(binned.cell.at<int32_t>(n % width, n / width), 500 / cell_mm * lateral_cells + n / cell_mm)
          << "n=" << n << " cell " << cell_mm;
    }
    KernelCase test_case{"point_cell_binning", params, points, 0};
    expect_all_back_ends_match_reference(test_case, {{width, height}});
  }
}

// The level camera 1.65 m up (default rotation, T = (0, 0, 1650)), area 34 m x 22 m, 0.5 m cells
// (68 x 44):
//   (1000, 1650, 10000) mm -> vehicle (10000, -1000, 0): cell (20, 20) = 20 * 44 + 20 = 900, height 0;
//   (-10999, 0, 0)        -> (0, 10999, 1650): cell (0, 43) = 43, height 1650;
//   (-11000, 0, 0)        -> y_v = 11000, at the open end of the area: no cell;
//   (0, 0, 33999)         -> cell (67, 22) = 2970; (0, 0, 34000) -> x_v = 34000: no cell;
//   (0, 65535, 10000)     -> in range: cell (20, 22) = 902, height 1650 - 65535 = -63885;
//   (0, 70000, 10000)     -> inside the area but beyond the kernel's range: no cell;
//   (0, -65536, 10000)    -> in range (the negative end is one further): height 67186;
//   (0, -65537, 10000)    -> beyond: no cell; kNoPointMm: no cell.
// A rotation that halves y (z_v = -y_c / 2, Q14 -8192) shows the rounding half up: y_c = 3 ->
// -1.5 -> -1; y_c = -3 -> 1.5 -> 2.
TEST(PointCellBinning, GoldenCellsWorkedByHand) {
  struct Case {
    int32_t x, y, z, cell, height;
  };
  const std::vector<Case> level = {{1000, 1650, 10000, 900, 0},
                                   {-10999, 0, 0, 43, 1650},
                                   {-11000, 0, 0, kNoCell, kNoPointMm},
                                   {0, 0, 33999, 2970, 1650},
                                   {0, 0, 34000, kNoCell, kNoPointMm},
                                   {0, 65535, 10000, 902, -63885},
                                   {0, 70000, 10000, kNoCell, kNoPointMm},
                                   {0, -65536, 10000, 902, 67186},
                                   {0, -65537, 10000, kNoCell, kNoPointMm},
                                   {kNoPointMm, kNoPointMm, kNoPointMm, kNoCell, kNoPointMm}};
  const std::vector<Case> halving = {{0, 3, 1000, 2 * 44 + 22, -1}, {0, -3, 1000, 2 * 44 + 22, 2}};
  auto check = [](const nlohmann::json& params, const std::vector<Case>& cases, KernelBackend backend, simd::Isa isa,
                  const std::string& label) {
    std::vector<Plane> points = point_planes(static_cast<int>(cases.size()), 1);
    for (size_t i = 0; i < cases.size(); ++i) {
      points[0].at<int32_t>(static_cast<int>(i), 0) = cases[i].x;
      points[1].at<int32_t>(static_cast<int>(i), 0) = cases[i].y;
      points[2].at<int32_t>(static_cast<int>(i), 0) = cases[i].z;
    }
    const Binned binned = run_binning(params, points, backend, isa);
    for (size_t i = 0; i < cases.size(); ++i) {
      EXPECT_EQ(binned.cell.at<int32_t>(static_cast<int>(i), 0), cases[i].cell) << label << " case " << i;
      EXPECT_EQ(binned.height.at<int32_t>(static_cast<int>(i), 0), cases[i].height) << label << " case " << i;
    }
  };
  const nlohmann::json level_params = {{"translation_mm", {0, 0, 1650}}};
  const nlohmann::json halving_params = {{"rotation_q14", {0, 0, 16384, -16384, 0, 0, 0, -8192, 0}}};
  for (simd::Isa isa : simd::available_isas()) {
    check(level_params, level, KernelBackend::native, isa, std::string(simd::isa_name(isa)));
    check(halving_params, halving, KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  }
  check(level_params, level, KernelBackend::counting, simd::Isa::scalar, "counting");
  check(halving_params, halving, KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The proof's extremes: rotation rows with sum |r| = 32767 (the limit), every combination of the
// range ends (-65536, 65535) and just beyond them, a translation at 2^20 mm: every back end agrees
// with the 64-bit reference, and the reference with the double model.
TEST(PointCellBinning, NoOverflowAtTheRangeAndRotationLimits) {
  const nlohmann::json params = {{"rotation_q14", {16384, 16383, 0, -16383, 0, -16384, 10000, -12767, 10000}},
                                 {"translation_mm", {-60000, 0, 1048576}},
                                 {"forward_min_mm", -65000},
                                 {"forward_max_mm", 0},
                                 {"lateral_min_mm", -20000},
                                 {"lateral_max_mm", 20000},
                                 {"cell_mm", 100}};
  const int32_t values[] = {-65537, -65536, -65535, 0, 65534, 65535, 65536, kNoPointMm, 2147483647};
  const int count = 9 * 9 * 9;
  std::vector<Plane> points = point_planes(count, 1);
  for (int n = 0; n < count; ++n) {
    points[0].at<int32_t>(n, 0) = values[n % 9];
    points[1].at<int32_t>(n, 0) = values[n / 9 % 9];
    points[2].at<int32_t>(n, 0) = values[n / 81];
  }
  KernelCase test_case{"point_cell_binning", params, points, 0};
  const std::vector<Plane> reference = expect_all_back_ends_match_reference(test_case, {{count, 1}, {64, 1}, {5, 1}});
  int inside = 0;
  for (int n = 0; n < count; ++n) {
    const int32_t point[3] = {values[n % 9], values[n / 9 % 9], values[n / 81]};
    const auto [cell, height] = model_cell(params, point);
    EXPECT_EQ(reference[0].at<int32_t>(n, 0), cell) << "n=" << n;
    EXPECT_EQ(reference[1].at<int32_t>(n, 0), height) << "n=" << n;
    inside += cell != kNoCell;
  }
  EXPECT_EQ(inside, 17);  // extreme points land in the area (17, counted by hand in Python), so the products are exercised
}

// The closed form of kernels/point_cell_binning.cpp: per chunk of 16 pixels 3 loads, 8 shifts,
// 9 logic, 22 arith, 3 compares, 14 multiplies, 2 stores; per tile 23 permutes.
TEST(PointCellBinning, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU32 == 16, "the closed form assumes 16 32-bit lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 640, 16}, {1, 1, 1, 1}, {33, 7, 33, 7},
                                               {631, 479, 100, 37}, {200, 3, 7, 5}}) {
    KernelCase test_case{"point_cell_binning", mount_params(), {}, 0};
    test_case.inputs = camera_points(shape.width, shape.height, 0, 55);
    const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 16);
    simd::OpCounts expected;
    expected[simd::OpClass::load] = 3 * work.chunks;
    expected[simd::OpClass::shift] = 8 * work.chunks;
    expected[simd::OpClass::logic] = 9 * work.chunks;
    expected[simd::OpClass::arith] = 22 * work.chunks;
    expected[simd::OpClass::compare] = 3 * work.chunks;
    expected[simd::OpClass::multiply] = 14 * work.chunks;
    expected[simd::OpClass::store] = 2 * work.chunks;
    expected[simd::OpClass::permute] = 23 * work.tiles;
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
  }
}

TEST(PointCellBinningMustFail, RefusesParametersOutsideTheProof) {
  const KernelDescriptor& kernel = testing::kernel_named("point_cell_binning");
  auto message = [&](const nlohmann::json& params, PlaneShape other = {20, 20}) -> std::string {
    try {
      kernel.prepare(params, {{20, 20}, {20, 20}, other});
    } catch (const KernelError& error) {
      return error.what();
    }
    return "accepted";
  };
  EXPECT_EQ(message({{"rotation_q14", {16384, 16384, 0, 0, 0, 0, 0, 0, 0}}}),
            "parameter 'rotation_q14' row 0: expected sum of |entries| <= 32767 (a rotation has at most 28378), got 32768");
  EXPECT_EQ(message({{"rotation_q14", {1, 2, 3}}}), "parameter 'rotation_q14': expected an array of 9 integers, got [1,2,3]");
  EXPECT_EQ(message({{"translation_mm", {0, 0, 2000000}}}),
            "parameter 'translation_mm' entry 2: expected an integer in [-1048576, 1048576], got 2000000");
  EXPECT_EQ(message({{"cell_mm", 10}}), "parameter 'cell_mm': expected an integer in [16, 131072], got 10");
  EXPECT_EQ(message({{"forward_min_mm", 5000}, {"forward_max_mm", 5000}}),
            "parameter 'forward_max_mm': expected an extent (max - min) in [1, 131072] mm, got 5000 - 5000 = 0");
  EXPECT_NE(message({{"forward_max_mm", 80000}}).find("within 65535 mm of the camera"), std::string::npos);
  EXPECT_EQ(message(nlohmann::json::object(), {21, 20}), "input 2: expected the size of input 0 (20x20), got 21x20");
  EXPECT_NE(message({{"cell", 500}}).find("cell"), std::string::npos);
  EXPECT_EQ(message(mount_params()), "accepted");
}

}  // namespace
}  // namespace lpstereo
