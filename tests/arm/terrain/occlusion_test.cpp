// The occlusion-aware 2.5D sampling (TerrainGridSpec::occlusion_upper_bounds; arm/terrain/height_grid.cpp
// has the model): arm::pixels_over_occluder on hand-built disparity columns and against the rule read
// pixel by pixel; a ray-cast scene (a board on poles hiding the road under a hanging sign, a low box
// beside) where the sign's cells are marked as upper bounds and the ground in front of the box and
// under the board is not; the fill; the one-sided fit keeping the surface on the ground under an
// island of marked cells while the unmarked fit rises; the hole membrane doing it for an unmarked
// island, bridging a hole on a slope and leaving a grid without holes bit for bit; the counted work
// and bad parameters.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "arm/terrain_points.h"
#include "arm/terrain/terrain_model.h"
#include "tests/arm/terrain/disparity_planes.h"

namespace lpstereo::arm {
namespace {

using terrain::HeightGrid;
using terrain::HeightGridAccumulator;
using terrain::TerrainGridSpec;

using testing::disparity_plane;
using testing::kInvalidQ4;
using testing::q4;

void expect_error(const std::function<void()>& call, const std::string& expected_text) {
  try {
    call();
    ADD_FAILURE() << expected_text << ": no throw";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()), expected_text);
  }
}

// Six columns of 30 rows, read from the top (row 0) down; disparities in px, -1 invalid. Jump 2 px,
// reach 6 rows (the defaults).
TEST(PixelsOverOccluder, HandBuiltColumns) {
  const int height = 30;
  Plane disparity = disparity_plane(6, height);
  const auto ground = [](int v) { return 5.0 + 0.2 * v; };  // 0.2 px a row: baseline / camera height
  for (int v = 0; v < height; ++v) {
    // 0: ground only
    disparity.at<int16_t>(0, v) = q4(ground(v));
    // 1: a sign (3 px, rows 0-9) right above a board (20 px, rows 10-19), the road under it
    disparity.at<int16_t>(1, v) = q4(v < 10 ? 3.0 : v < 20 ? 20.0 : ground(v));
    // 2: the same with two rows of far background (0.5 px) between the sign and the board (rows 12-19)
    disparity.at<int16_t>(2, v) = q4(v < 10 ? 3.0 : v < 12 ? 0.5 : v < 20 ? 20.0 : ground(v));
    // 3: the same with three invalid rows (the discontinuity filter's near side) before the board (13-19)
    disparity.at<int16_t>(3, v) = q4(v < 10 ? 3.0 : v < 13 ? -1.0 : v < 20 ? 20.0 : ground(v));
    // 4: a board on poles (rows 10-14) over the farther road: background above, road below
    disparity.at<int16_t>(4, v) = q4(v < 10 ? 0.5 : v < 15 ? 20.0 : ground(v));
    // 5: ground seen above a low box (11 px, rows 20-25) standing on nearer ground
    disparity.at<int16_t>(5, v) = q4(v >= 20 && v < 26 ? 11.0 : ground(v));
  }
  const std::vector<uint8_t> flags = pixels_over_occluder(disparity, kInvalidQ4);
  const auto expected = [](int u, int v) {
    switch (u) {
      case 1: return v >= 4 && v <= 9;   // the sign's bottom 6 rows, over the board's top at row 10
      case 2: return v >= 6 && v <= 11;  // within 6 rows of the board's top at row 12, across the background
      case 3: return v >= 7 && v <= 9;   // within 6 rows of the board's top at row 13, across the gap
      case 4: return v >= 4 && v <= 9;   // the background over the board; the board and the road never
      case 5: return v >= 14 && v <= 19; // ground seen over the box (an upper bound too); not the box
      default: return false;             // ground continues into nearer ground without a jump
    }
  };
  for (int u = 0; u < 6; ++u) {
    for (int v = 0; v < height; ++v) {
      EXPECT_EQ(flags[static_cast<size_t>(v) * 6 + u], expected(u, v) ? 1 : 0) << "column " << u << ", row " << v;
    }
  }
  // A shorter reach flags fewer rows: 2 rows over the board in column 1.
  const std::vector<uint8_t> short_reach = pixels_over_occluder(disparity, kInvalidQ4, OccluderTest{2, 2.0});
  for (int v = 0; v < height; ++v) EXPECT_EQ(short_reach[static_cast<size_t>(v) * 6 + 1], v == 8 || v == 9 ? 1 : 0) << v;
}

TEST(PixelsOverOccluder, AgreesWithTheRuleReadPixelByPixel) {
  std::mt19937 random(11);
  std::uniform_int_distribution<int> value(-4, 40);  // < 0: invalid; else 0 .. 40 px
  const int width = 19, height = 31;
  const OccluderTest test{4, 3.5};
  Plane disparity = disparity_plane(width, height);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) disparity.at<int16_t>(u, v) = q4(value(random));
  const std::vector<uint8_t> flags = pixels_over_occluder(disparity, kInvalidQ4, test);
  const auto valid = [&](int u, int v) { return disparity.at<int16_t>(u, v) > kInvalidQ4; };
  const auto px = [&](int u, int v) { return disparity.at<int16_t>(u, v) / 16.0; };
  int flagged = 0;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      // p is over an occluder when a valid q within reach below is more than the jump nearer than
      // the nearest valid pixel above q (which lies at or below p) and than p.
      bool over = false;
      for (int w = v + 1; valid(u, v) && w <= std::min(height - 1, v + test.rows_below_px); ++w) {
        if (!valid(u, w)) continue;
        int above = w - 1;
        while (!valid(u, above)) --above;
        if (px(u, w) - px(u, above) > test.jump_px && px(u, w) - px(u, v) > test.jump_px) over = true;
      }
      EXPECT_EQ(flags[static_cast<size_t>(v) * width + u], over ? 1 : 0) << u << "," << v;
      flagged += over ? 1 : 0;
    }
  }
  EXPECT_GT(flagged, 50);
}

TEST(PixelsOverOccluder, BadParametersNameTheParameter) {
  Plane disparity = disparity_plane(4, 4);
  expect_error([&] { pixels_over_occluder(disparity, kInvalidQ4, OccluderTest{0, 2.0}); }, "rows_below_px: expected in [1, 64], got 0");
  expect_error([&] { pixels_over_occluder(disparity, kInvalidQ4, OccluderTest{6, 0.0}); }, "jump_px: expected a finite value > 0, got 0");
  Plane grey(4, 4, BufferFormat{ElementType::u8});
  expect_error([&] { pixels_over_occluder(grey, kInvalidQ4); }, "disparity_q4: expected an s16 plane");
}

// A level camera 1.5 m up (f = 300 px, 320 x 240, baseline 0.3 m) sees flat ground, a board on two
// poles (x = 4 m, |y| <= 1 m, 0.9-1.6 m up: the floating scene's), a sign hanging at x = 12 m (|y| <=
// 1 m, 1.9-3.0 m up) and a low box face (x = 6 m, y 2.5-3.5 m, 0-0.5 m up). Pixels are ray-cast; the
// points are the exact ones of each pixel.
struct RayCastScene {
  static constexpr int kWidth = 320, kHeight = 240;
  static constexpr double kFocalPx = 300, kBaselineM = 0.3, kCameraHeightM = 1.5;
  Plane disparity = disparity_plane(kWidth, kHeight);
  std::vector<Eigen::Vector3d> points;  // per pixel, vehicle frame; NaN where nothing is hit
  RayCastScene() {
    points.assign(static_cast<size_t>(kWidth) * kHeight, Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        // ray (x, y, z) = (t, -t a, h - t b), t the forward depth
        const double a = (u - (kWidth - 1) / 2.0) / kFocalPx, b = (v - (kHeight - 1) / 2.0) / kFocalPx;
        double depth = std::numeric_limits<double>::infinity();
        const auto vertical = [&](double x, double y_min, double y_max, double z_min, double z_max) {
          const double y = -x * a, z = kCameraHeightM - x * b;
          if (y >= y_min && y <= y_max && z >= z_min && z <= z_max) depth = std::min(depth, x);
        };
        if (b > 0) depth = kCameraHeightM / b;  // the ground
        vertical(4.0, -1.0, 1.0, 0.9, 1.6);     // the board
        vertical(12.0, -1.0, 1.0, 1.9, 3.0);    // the sign
        vertical(6.0, 2.5, 3.5, 0.0, 0.5);      // the box's face
        if (!(depth < 100)) {
          disparity.at<int16_t>(u, v) = kInvalidQ4;
          continue;
        }
        disparity.at<int16_t>(u, v) = q4(kFocalPx * kBaselineM / depth);
        points[static_cast<size_t>(v) * kWidth + u] = Eigen::Vector3d(depth, -depth * a, kCameraHeightM - depth * b);
      }
    }
  }
  HeightGrid grid(bool occlusion, HeightGridAccumulator* accumulator_out = nullptr) const {
    TerrainGridSpec spec;  // 34 x 22 m, 0.5 m cells
    spec.occlusion_upper_bounds = occlusion;
    HeightGridAccumulator accumulator(spec);
    const std::vector<uint8_t> flags = pixels_over_occluder(disparity, kInvalidQ4);
    for (size_t k = 0; k < points.size(); ++k) {
      if (points[k].allFinite()) accumulator.add_point(points[k], flags[k] != 0);
    }
    if (accumulator_out != nullptr) *accumulator_out = accumulator;
    return accumulator.finish();
  }
};

TEST(OcclusionUpperBounds, SignBehindABoardIsMarkedAndGroundInFrontOfABoxIsNot) {
  const RayCastScene scene;
  const HeightGrid grid = scene.grid(true);
  const TerrainGridSpec& spec = grid.spec;
  ASSERT_EQ(grid.upper_bound.rows(), spec.forward_cells());
  ASSERT_EQ(grid.upper_bound.cols(), spec.lateral_cells());
  int i = 0, j = 0;
  // The sign's cells (x 12-12.5 m, |y| < 1 m): only sign points, the road under them hidden by the
  // board, the sample at the sign's lower part: marked.
  for (const double y : {-0.75, -0.25, 0.25, 0.75}) {
    ASSERT_TRUE(spec.cell_of(12.2, y, &i, &j));
    EXPECT_EQ(grid.state(i, j), terrain::kCellMeasured) << y;
    EXPECT_GT(grid.height_m(i, j), 1.8) << y;
    EXPECT_EQ(grid.upper_bound(i, j), 1) << "sign cell at y " << y;
  }
  // Ground in front of the box (x 5.5-6 m, y 2.5-3.5 m) and open ground: not marked, at the ground.
  // The open-ground cells are on the side without the box: ground at x 10-10.5 m, y 4-4.5 m is seen
  // 5-6 rows above the box's top edge, on the rule's 6-row limit, where the last bit of the ray
  // arithmetic (fused multiply-add on aarch64) decides whether its lowest pixel is flagged.
  for (const auto& [x, y] : std::vector<std::pair<double, double>>{{5.7, 2.7}, {5.7, 3.2}, {8.2, -3.3}, {10.2, -4.3}}) {
    ASSERT_TRUE(spec.cell_of(x, y, &i, &j));
    EXPECT_EQ(grid.state(i, j), terrain::kCellMeasured) << x << " " << y;
    EXPECT_NEAR(grid.height_m(i, j), 0.0, 0.01) << x << " " << y;
    EXPECT_EQ(grid.upper_bound(i, j), 0) << "ground cell at " << x << ", " << y;
  }
  // The board on poles (x 4-4.5 m): its points and the road seen under it, the road's lowest: not
  // marked (its sample is lifted by the board, a mixed cell the fit's equalisation handles).
  ASSERT_TRUE(spec.cell_of(4.2, 0.2, &i, &j));
  EXPECT_EQ(grid.state(i, j), terrain::kCellMeasured);
  EXPECT_EQ(grid.upper_bound(i, j), 0);
  // The rule off: no marks, the same measured heights.
  const HeightGrid plain = scene.grid(false);
  EXPECT_EQ(plain.upper_bound.size(), 0);
  for (int a = 0; a < spec.forward_cells(); ++a) {
    for (int b = 0; b < spec.lateral_cells(); ++b) {
      if (plain.state(a, b) == terrain::kCellMeasured) {
        EXPECT_EQ(plain.height_m(a, b), grid.height_m(a, b)) << a << " " << b;
      }
    }
  }
}

TEST(OcclusionUpperBounds, LowestPointDecidesAndTheFillPrefersUnmarkedNeighbours) {
  TerrainGridSpec spec;
  spec.forward_min_m = 0, spec.forward_max_m = 2, spec.lateral_min_m = 0, spec.lateral_max_m = 1.5, spec.cell_m = 0.5;  // 4 x 3
  spec.occlusion_upper_bounds = true;
  spec.cell_rule = TerrainGridSpec::CellRule::thesis;  // eq. 3.2: the heights below by hand
  HeightGridAccumulator accumulator(spec);
  // cell (0, 0): its lowest point (0.10 m) over an occluder -> marked, though most points are not
  for (const double z : {0.3, 0.4, 0.5}) accumulator.add_point({0.25, 0.25, z}, false);
  accumulator.add_point({0.25, 0.25, 0.1}, true);
  // cell (0, 2): a flagged point, but the lowest (0.0 m) is not -> not marked
  accumulator.add_point({0.25, 1.25, 0.2}, true);
  accumulator.add_point({0.25, 1.25, 0.0}, false);
  // cell (2, 0) and (3, 2): marked; cell (2, 2) unmarked at 1.0 m
  accumulator.add_point({1.25, 0.25, 2.0}, true);
  accumulator.add_point({1.75, 1.25, 3.0}, true);
  accumulator.add_point({1.25, 1.25, 1.0}, false);
  const HeightGrid grid = accumulator.finish();
  EXPECT_EQ(grid.upper_bound(0, 0), 1);
  EXPECT_EQ(grid.upper_bound(0, 2), 0);
  EXPECT_EQ(grid.upper_bound(2, 0), 1);
  EXPECT_EQ(grid.upper_bound(2, 2), 0);
  // (1, 1) is filled from its unmarked measured neighbours (0, 2) (eq. 3.2: mean 0.1 - sigma 0.1)
  // and (2, 2) only: (0 + 1) / 2.
  EXPECT_EQ(grid.state(1, 1), terrain::kCellFilled);
  EXPECT_NEAR(grid.height_m(1, 1), (0.0 + 1.0) / 2, 1e-12);
  EXPECT_EQ(grid.upper_bound(1, 1), 0);
  // (3, 0) sees only the marked (2, 0) among its measured neighbours: its fill is an upper bound too.
  EXPECT_EQ(grid.state(3, 0), terrain::kCellFilled);
  EXPECT_NEAR(grid.height_m(3, 0), 2.0, 1e-12);
  EXPECT_EQ(grid.upper_bound(3, 0), 1);
  // Without the rule, the flags are ignored and (1, 1) is the mean of all five measured neighbours.
  spec.occlusion_upper_bounds = false;
  HeightGridAccumulator plain(spec);
  for (const auto& [x, y, z] : std::vector<std::tuple<double, double, double>>{
           {0.25, 0.25, 0.1}, {0.25, 1.25, 0.0}, {1.25, 0.25, 2.0}, {1.75, 1.25, 3.0}, {1.25, 1.25, 1.0}}) {
    plain.add_point({x, y, z}, true);
  }
  const HeightGrid plain_grid = plain.finish();
  EXPECT_EQ(plain_grid.upper_bound.size(), 0);
  EXPECT_NEAR(plain_grid.height_m(1, 1), (0.1 + 0.0 + 2.0 + 1.0) / 4, 1e-12);  // (0,0), (0,2), (2,0), (2,2); (3,2) is not a neighbour
}

TEST(OcclusionUpperBounds, CountedWorkFollowsTheDocumentedModel) {
  // height_grid.cpp: + 2 ops per accepted point and 2 per cell, + 1 byte per point and 8 per cell.
  const RayCastScene scene;
  TerrainGridSpec spec;
  HeightGridAccumulator with_rule(spec), without_rule(spec);
  scene.grid(true, &with_rule);
  scene.grid(false, &without_rule);
  const uint64_t points = static_cast<uint64_t>(with_rule.accepted()), cells = static_cast<uint64_t>(spec.forward_cells() * spec.lateral_cells());
  ASSERT_GT(points, 10000u);
  EXPECT_EQ(with_rule.work().scalar_ops, without_rule.work().scalar_ops + 2 * points + 2 * cells);
  EXPECT_EQ(with_rule.work().memory_bytes, without_rule.work().memory_bytes + points + 8 * cells);
}

// The floating scene's failure in a grid (the measured grid of obstacles3d_eval, floating seed 1,
// frame 31, read off a dump: docs/obstacles3d.md): flat ground at z = 0; the board's shadow, the
// wedge x > 7.5 m, |y| < x / 4 (a board 2 m wide at 4 m hides the road beyond 7.5 m), empty; in it
// the sign's cells, which stereo spreads along the rays from 10.5 to 17 m, 4 m wide, rising from
// 1.9 to 2.7 m (a point farther along a ray above the camera is higher). Nothing under the island
// says where the ground is: the plain fit follows the island up; with the island marked as upper
// bounds the one-sided fit sets it aside and carries the ground's level across the shadow.
HeightGrid shadow_with_island(bool marked) {
  constexpr double x0 = 10.5, x1 = 17, half = 2.0, rise = 0.12;
  TerrainGridSpec spec;
  HeightGrid grid;
  grid.spec = spec;
  const int m0 = spec.forward_cells(), m1 = spec.lateral_cells();
  grid.height_m = Eigen::MatrixXd::Zero(m0, m1);
  grid.point_count = Eigen::MatrixXi::Constant(m0, m1, 10);
  grid.state = Eigen::MatrixXi::Constant(m0, m1, terrain::kCellMeasured);
  if (marked) grid.upper_bound = Eigen::MatrixXi::Zero(m0, m1);
  for (int i = 0; i < m0; ++i) {
    for (int j = 0; j < m1; ++j) {
      const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
      if (x > x0 && x < x1 && std::abs(y) < half) {
        grid.height_m(i, j) = 1.9 + rise * (x - x0);
        if (marked) grid.upper_bound(i, j) = 1;
      } else if (x > 7.5 && std::abs(y) < x / 4) {
        grid.height_m(i, j) = std::numeric_limits<double>::quiet_NaN();
        grid.state(i, j) = terrain::kCellInvalid;
        grid.point_count(i, j) = 0;
      }
    }
  }
  return grid;
}

TEST(OneSidedFit, KeepsTheSurfaceOnTheGroundUnderAnIslandOfMarkedCells) {
  const terrain::TerrainFitParameters parameters;  // the defaults
  const terrain::TerrainEstimate plain = terrain::fit_terrain(shadow_with_island(false), parameters);
  const terrain::TerrainEstimate one_sided = terrain::fit_terrain(shadow_with_island(true), parameters);
  ASSERT_TRUE(plain.known) << plain.reason;
  ASSERT_TRUE(one_sided.known) << one_sided.reason;
  double plain_highest = 0, one_sided_farthest = 0;
  for (double x = 10.75; x < 17; x += 0.5) {
    for (double y = -1.75; y < 2; y += 0.5) plain_highest = std::max(plain_highest, plain.surface.height_m(x, y));
  }
  for (double x = 0.25; x < 34; x += 0.5) {
    for (double y = -10.75; y < 11; y += 0.5) one_sided_farthest = std::max(one_sided_farthest, std::abs(one_sided.surface.height_m(x, y)));
  }
  EXPECT_GT(plain_highest, 0.4) << "the unmarked fit should rise under the island";
  EXPECT_LT(one_sided_farthest, 0.02) << "the one-sided fit should stay on the ground everywhere";
  // The island's cells end with weight 0 (set aside), the ground's with eq. 3.6's.
  int i = 0, j = 0;
  ASSERT_TRUE(one_sided.grid.spec.cell_of(12.7, 0.2, &i, &j));
  EXPECT_EQ(one_sided.weights(i, j), 0.0);
  ASSERT_TRUE(one_sided.grid.spec.cell_of(5.2, 0.2, &i, &j));
  EXPECT_GE(one_sided.weights(i, j), 1.0);
  // Set aside, the island is not equalised either: its cells keep their heights.
  ASSERT_TRUE(one_sided.grid.spec.cell_of(12.7, 0.2, &i, &j));
  EXPECT_DOUBLE_EQ(one_sided.grid.height_m(i, j), 1.9 + 0.12 * (12.75 - 10.5));
}

// Every cell of the default spec measured: height(x, y) plus Gaussian noise (seed 3) of noise_sigma_m.
HeightGrid noisy_ground(const std::function<double(double, double)>& height, double noise_sigma_m) {
  HeightGrid grid;
  grid.spec = TerrainGridSpec{};
  const int m0 = grid.spec.forward_cells(), m1 = grid.spec.lateral_cells();
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0.0, noise_sigma_m);
  grid.height_m.resize(m0, m1);
  for (int i = 0; i < m0; ++i)
    for (int j = 0; j < m1; ++j) grid.height_m(i, j) = height(grid.spec.cell_centre_x_m(i), grid.spec.cell_centre_y_m(j)) + noise(random);
  grid.point_count = Eigen::MatrixXi::Constant(m0, m1, 10);
  grid.state = Eigen::MatrixXi::Constant(m0, m1, terrain::kCellMeasured);
  return grid;
}

TEST(OneSidedFit, MarkedGroundIsFittedAsUnmarkedGround) {
  // Noisy ground seen behind objects (3 cm noise, a 5 % climb): a marked sample within the
  // tolerance of the surface counts as any. Every cell marked (too few unmarked ones to start from:
  // all start two-sided): the same surface to the bit; a third of the cells marked (they start set
  // aside and come back at once): the same within 5 mm, not pushed low; a marked hollow below the
  // surface pulls it down as an unmarked one does.
  HeightGrid grid = noisy_ground([](double x, double) { return 0.05 * x; }, 0.03);
  const TerrainGridSpec& spec = grid.spec;
  const int m0 = spec.forward_cells(), m1 = spec.lateral_cells();
  const terrain::TerrainEstimate plain = terrain::fit_terrain(grid, {});
  grid.upper_bound = Eigen::MatrixXi::Ones(m0, m1);
  const terrain::TerrainEstimate marked = terrain::fit_terrain(grid, {});
  ASSERT_TRUE(plain.known && marked.known);
  EXPECT_EQ((plain.surface.control_z_m - marked.surface.control_z_m).cwiseAbs().maxCoeff(), 0.0);
  for (int i = 0; i < m0; ++i)
    for (int j = 0; j < m1; ++j) grid.upper_bound(i, j) = (i + 2 * j) % 3 == 0 ? 1 : 0;
  const terrain::TerrainEstimate third = terrain::fit_terrain(grid, {});
  ASSERT_TRUE(third.known);
  double largest_difference = 0;
  for (double x = 0.25; x < 34; x += 0.5)
    for (double y = -10.75; y < 11; y += 0.5) largest_difference = std::max(largest_difference, std::abs(third.surface.height_m(x, y) - plain.surface.height_m(x, y)));
  EXPECT_LT(largest_difference, 0.005);
  // A marked hollow (0.5 m deep, 2 x 2 m) below the surface is a sample like any.
  for (int i = 0; i < m0; ++i) {
    for (int j = 0; j < m1; ++j) {
      const bool hollow = std::abs(spec.cell_centre_x_m(i) - 15) < 1 && std::abs(spec.cell_centre_y_m(j)) < 1;
      grid.upper_bound(i, j) = hollow ? 1 : 0;
      if (hollow) grid.height_m(i, j) -= 0.5;
    }
  }
  const terrain::TerrainEstimate hollow_marked = terrain::fit_terrain(grid, {});
  grid.upper_bound.resize(0, 0);
  const terrain::TerrainEstimate hollow_plain = terrain::fit_terrain(grid, {});
  ASSERT_TRUE(hollow_marked.known && hollow_plain.known);
  EXPECT_LT(hollow_plain.surface.height_m(15, 0), 0.05 * 15 - 0.1);  // the fit does go down into it
  EXPECT_NEAR(hollow_marked.surface.height_m(15, 0), hollow_plain.surface.height_m(15, 0), 0.01);
}

TEST(OneSidedFit, CountedWorkFollowsTheDocumentedModel) {
  // terrain_fit.cpp: with marks, 3 C once (+ 3 V and a first fit when enough unmarked cells
  // remain) and 3 V per iteration. Every cell of a plane marked: no first fit; one iteration
  // (nothing to equalise, no cell set aside: the loop stops after it).
  TerrainGridSpec spec;
  spec.forward_max_m = 10, spec.lateral_min_m = -4, spec.lateral_max_m = 4;  // 20 x 16 = 320 cells
  HeightGrid grid;
  grid.spec = spec;
  grid.height_m.resize(20, 16);
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 16; ++j) grid.height_m(i, j) = 0.1 * spec.cell_centre_x_m(i);
  grid.point_count = Eigen::MatrixXi::Constant(20, 16, 5);
  grid.state = Eigen::MatrixXi::Constant(20, 16, terrain::kCellMeasured);
  terrain::TerrainFitParameters parameters;
  parameters.control_forward = 8, parameters.control_lateral = 6;
  parameters.initial_control_forward = parameters.initial_control_lateral = 4;
  parameters.max_iterations = 1;
  const terrain::TerrainEstimate plain = terrain::fit_terrain(grid, parameters);
  grid.upper_bound = Eigen::MatrixXi::Ones(20, 16);
  const terrain::TerrainEstimate marked = terrain::fit_terrain(grid, parameters);
  ASSERT_TRUE(plain.known && marked.known);
  ASSERT_EQ(plain.iterations, 1);
  ASSERT_EQ(marked.iterations, 1);
  EXPECT_EQ(marked.work.scalar_ops, plain.work.scalar_ops + 3 * 320 + 3 * 320);
  EXPECT_EQ(marked.work.memory_bytes, plain.work.memory_bytes);
}

TEST(OneSidedFit, BadParametersNameTheParameter) {
  HeightGrid grid = shadow_with_island(true);
  terrain::TerrainFitParameters parameters;
  parameters.upper_bound_tolerance_m = -0.1;
  expect_error([&] { terrain::fit_terrain(grid, parameters); }, "upper_bound_tolerance_m: expected a finite value >= 0, got -0.1");
  parameters.upper_bound_tolerance_m = std::numeric_limits<double>::infinity();
  expect_error([&] { terrain::fit_terrain(grid, parameters); }, "upper_bound_tolerance_m: expected a finite value >= 0, got inf");
  grid.upper_bound = Eigen::MatrixXi::Zero(3, 4);
  expect_error([&] { terrain::fit_terrain(grid, {}); }, "grid.upper_bound: expected 68x44 marks (the spec's cells) or empty, got 3x4");
  // accumulate_binned's flags must cover the binned pixels.
  TerrainGridSpec spec;
  HeightGridAccumulator accumulator(spec);
  BinnedPoints binned{Plane(4, 2, BufferFormat{ElementType::s32}), Plane(4, 2, BufferFormat{ElementType::s32})};
  const std::vector<uint8_t> flags(7, 0);
  expect_error([&] { accumulate_binned(binned, spec, accumulator, &flags); }, "over_occluder: expected 8 flags (one per binned pixel), got 7");
}

// The hole membrane (TerrainFitParameters::hole_membrane, terrain_fit.cpp): the same shadow with the
// island unmarked. The plain fit follows the island up (the test above); tied to the ground at the
// shadow's edge the surface stays low, the island stands far above it and is equalised away.
TEST(HoleMembrane, HoldsTheGroundUnderAnUnmarkedIslandInTheShadow) {
  terrain::TerrainFitParameters parameters;
  parameters.hole_membrane = 1.0;
  const terrain::TerrainEstimate fit = terrain::fit_terrain(shadow_with_island(false), parameters);
  ASSERT_TRUE(fit.known) << fit.reason;
  double farthest = 0;
  for (double x = 0.25; x < 34; x += 0.5) {
    for (double y = -10.75; y < 11; y += 0.5) farthest = std::max(farthest, std::abs(fit.surface.height_m(x, y)));
  }
  EXPECT_LT(farthest, 0.02) << "the surface should stay on the ground, under the island and beyond it";
  int i = 0, j = 0;
  ASSERT_TRUE(fit.grid.spec.cell_of(12.7, 0.2, &i, &j));
  EXPECT_LT(fit.grid.height_m(i, j), 1.0) << "the island's sample should have been equalised down";
}

// A 5 % climb with a 0.3 m swell (sin(x / 4 m): 25 m from crest to crest), a 2 % cross slope.
double swell(double x_m, double y_m) { return 0.05 * x_m + 0.3 * std::sin(x_m / 4) + 0.02 * y_m; }
// The swell with 2 cm noise; with `hole`, a 6 m x 6 m hole at 12-18 m.
HeightGrid swell_with_hole(bool hole) {
  HeightGrid grid = noisy_ground(swell, 0.02);
  for (int i = 0; i < grid.spec.forward_cells(); ++i) {
    for (int j = 0; j < grid.spec.lateral_cells(); ++j) {
      if (hole && grid.spec.cell_centre_x_m(i) > 12 && grid.spec.cell_centre_x_m(i) < 18 && std::abs(grid.spec.cell_centre_y_m(j)) < 3) {
        grid.height_m(i, j) = std::numeric_limits<double>::quiet_NaN();
        grid.state(i, j) = terrain::kCellInvalid;
        grid.point_count(i, j) = 0;
      }
    }
  }
  return grid;
}

// Where the membrane acts: on the edges of control points whose re-weighted information is under 5 %
// of the mean, so not only over holes but also where the re-weighting distrusts the samples (W ~ 1
// against up to 1000 near the surface). On a full grid of the swell the coarse first surfaces miss
// it leaves the fit's error as it was (1.8 cm RMS either way when this was written); over a hole it
// bridges the swell that the plain spline swings through.
TEST(HoleMembrane, BridgesAHoleOnASlopeAndMovesAFullGridLittle) {
  terrain::TerrainFitParameters with;
  with.hole_membrane = 1.0;
  const auto& truth = swell;
  // The largest and the RMS error against the true swell over the cells inside (or outside) the hole.
  const auto errors = [&](const terrain::TerrainEstimate& fit, bool in_hole) {
    double largest = 0, squares = 0;
    int cells = 0;
    for (double x = 0.25; x < 34; x += 0.5) {
      for (double y = -10.75; y < 11; y += 0.5) {
        if ((x > 12 && x < 18 && std::abs(y) < 3) != in_hole) continue;
        const double error = std::abs(fit.surface.height_m(x, y) - truth(x, y));
        largest = std::max(largest, error), squares += error * error, ++cells;
      }
    }
    return std::make_pair(largest, std::sqrt(squares / std::max(cells, 1)));
  };
  const terrain::TerrainEstimate full_off = terrain::fit_terrain(swell_with_hole(false), {});
  const terrain::TerrainEstimate full_on = terrain::fit_terrain(swell_with_hole(false), with);
  const terrain::TerrainEstimate hole_off = terrain::fit_terrain(swell_with_hole(true), {});
  const terrain::TerrainEstimate hole_on = terrain::fit_terrain(swell_with_hole(true), with);
  ASSERT_TRUE(full_off.known && full_on.known && hole_off.known && hole_on.known);
  // Full grid: the same RMS within 5 mm (0.018 m both).
  EXPECT_LT(errors(full_on, false).second, errors(full_off, false).second + 0.005);
  // Hole: the plain spline swings in it (0.094 m RMS, 0.22 m worst), the membrane bridges it (0.036,
  // 0.081); the seen ground's RMS stays (0.017 both).
  EXPECT_GT(errors(hole_off, true).second, 0.07);
  EXPECT_LT(errors(hole_on, true).second, 0.5 * errors(hole_off, true).second);
  EXPECT_LT(errors(hole_on, true).first, 0.1);
  EXPECT_LT(errors(hole_on, false).second, errors(hole_off, false).second + 0.005);
}

TEST(HoleMembrane, CountedWorkAndBadParameters) {
  // terrain_fit.cpp: 4 more ops per control point per regularised system. With no iteration, one
  // fit: step 1's m1 columns (all with samples) of n0, step 2's n0 rows of n1.
  terrain::TerrainFitParameters off;
  off.max_iterations = 0;
  terrain::TerrainFitParameters on = off;
  on.hole_membrane = 1.0;
  const HeightGrid grid = swell_with_hole(true);
  const terrain::TerrainEstimate plain = terrain::fit_terrain(grid, off);
  const terrain::TerrainEstimate membrane = terrain::fit_terrain(grid, on);
  ASSERT_TRUE(plain.known && membrane.known);
  const uint64_t m1 = static_cast<uint64_t>(grid.spec.lateral_cells()), n0 = 25, n1 = 25;
  EXPECT_EQ(membrane.work.scalar_ops, plain.work.scalar_ops + 4 * (m1 * n0 + n0 * n1));
  EXPECT_EQ(membrane.work.memory_bytes, plain.work.memory_bytes);
  terrain::TerrainFitParameters bad;
  bad.hole_membrane = -1;
  expect_error([&] { terrain::fit_terrain(grid, bad); }, "hole_membrane: expected a finite value >= 0, got -1");
  bad.hole_membrane = std::numeric_limits<double>::quiet_NaN();
  expect_error([&] { terrain::fit_terrain(grid, bad); }, "hole_membrane: expected a finite value >= 0, got nan");
}

}  // namespace
}  // namespace lpstereo::arm
