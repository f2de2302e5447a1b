// Slope, cost and segmentation (arm/terrain/traversability.cpp): the slope of a tilted plane is its
// gradient's norm, the cost is eq. 3.1 on a hand-made occupied cell, points are classified by their
// height above the surface, unknown terrain gives NaN and "outside", and bad parameters throw.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "arm/terrain/terrain_model.h"

namespace lpstereo::arm::terrain {
namespace {

HeightGrid plane_grid(double slope_x, double slope_y) {
  HeightGrid grid;
  grid.spec.forward_min_m = 0, grid.spec.forward_max_m = 12, grid.spec.lateral_min_m = -5, grid.spec.lateral_max_m = 5;
  grid.spec.cell_m = 0.5;
  const int m0 = grid.spec.forward_cells(), m1 = grid.spec.lateral_cells();
  grid.height_m.resize(m0, m1);
  grid.point_count = Eigen::MatrixXi::Constant(m0, m1, 3);
  grid.state = Eigen::MatrixXi::Constant(m0, m1, kCellMeasured);
  for (int i = 0; i < m0; ++i)
    for (int j = 0; j < m1; ++j)
      grid.height_m(i, j) = 1.0 + slope_x * grid.spec.cell_centre_x_m(i) + slope_y * grid.spec.cell_centre_y_m(j);
  return grid;
}

TerrainFitParameters parameters_for_plane() {
  TerrainFitParameters parameters;
  parameters.control_forward = 10, parameters.control_lateral = 8;
  // A negligible Tikhonov term, so that the plane is fitted exactly and the slope checks below test
  // the traversability's derivatives to 1e-6 (the default's bias, under 0.5 mm over 34 m, is
  // bounded in terrain_fit_test).
  parameters.regularisation = 1e-8;
  return parameters;
}

TEST(Traversability, SlopeOfATiltedPlaneIsItsGradient) {
  const HeightGrid grid = plane_grid(0.1, -0.2);
  const TerrainEstimate terrain = fit_terrain(grid, parameters_for_plane());
  ASSERT_TRUE(terrain.known) << terrain.reason;
  TraversabilityParameters parameters;
  parameters.slope_weight = 2.0;
  const TraversabilityMap map = compute_traversability(terrain, grid, parameters);
  const double expected = std::sqrt(0.1 * 0.1 + 0.2 * 0.2);
  for (int i = 0; i < grid.height_m.rows(); ++i) {
    for (int j = 0; j < grid.height_m.cols(); ++j) {
      EXPECT_NEAR(map.slope(i, j), expected, 1e-6) << i << " " << j;
      EXPECT_EQ(map.occupancy(i, j), 0.0);
      EXPECT_NEAR(map.cost(i, j), 2.0 * expected, 2e-6);
    }
  }
  const Eigen::Vector2d gradient = terrain.surface.gradient(3.3, 1.7);
  EXPECT_NEAR(gradient.x(), 0.1, 1e-6);
  EXPECT_NEAR(gradient.y(), -0.2, 1e-6);
  // traversability.cpp's model: 24 x 20 cells, 10 x 8 control points, degree 3.
  EXPECT_EQ(map.work.scalar_ops, uint64_t(6 * 3 * 4 * 24 + 6 * 3 * 4 * 20) + 3u * (2 * 24 * 10 * 8 + 2 * 24 * 8 * 20) + 12u * 480);
  EXPECT_EQ(map.work.memory_bytes, 12u * 480 + 8u * 80 + 24u * 480);
}

TEST(Traversability, CostIsEquation31OnAnOccupiedCell) {
  const HeightGrid grid = plane_grid(0.05, 0.0);
  const TerrainEstimate terrain = fit_terrain(grid, parameters_for_plane());
  ASSERT_TRUE(terrain.known) << terrain.reason;
  HeightGrid measured = grid;
  measured.height_m(6, 7) += 0.5;   // 0.5 m above the surface: occupied at 0.3 m
  measured.height_m(8, 3) += 0.25;  // below the threshold: free
  measured.state(2, 2) = kCellInvalid;
  measured.height_m(2, 2) = std::numeric_limits<double>::quiet_NaN();
  TraversabilityParameters parameters;
  parameters.occupancy_weight = 3.0;
  parameters.slope_weight = 4.0;
  parameters.obstacle_height_m = 0.3;
  const TraversabilityMap map = compute_traversability(terrain, measured, parameters);
  EXPECT_EQ(map.occupancy(6, 7), 1.0);
  EXPECT_NEAR(map.cost(6, 7), 3.0 * 1.0 + 4.0 * 0.05, 1e-6);
  EXPECT_EQ(map.occupancy(8, 3), 0.0);
  EXPECT_NEAR(map.cost(8, 3), 4.0 * 0.05, 1e-6);
  EXPECT_TRUE(std::isnan(map.occupancy(2, 2)));  // no data: unknown, not free
  EXPECT_TRUE(std::isnan(map.cost(2, 2)));
  EXPECT_NEAR(map.slope(2, 2), 0.05, 1e-6);      // the surface still has a slope there
  int occupied = 0;
  for (Eigen::Index k = 0; k < map.occupancy.size(); ++k) occupied += map.occupancy.data()[k] == 1.0 ? 1 : 0;
  EXPECT_EQ(occupied, 1);
}

TEST(Traversability, UnknownTerrainGivesNaNEverywhere) {
  const HeightGrid grid = plane_grid(0, 0);
  TerrainEstimate unknown;  // known = false
  unknown.reason = "terrain unknown: test";
  const TraversabilityMap map = compute_traversability(unknown, grid, TraversabilityParameters{});
  ASSERT_EQ(map.cost.rows(), grid.height_m.rows());
  for (Eigen::Index k = 0; k < map.cost.size(); ++k) {
    EXPECT_TRUE(std::isnan(map.cost.data()[k]));
    EXPECT_TRUE(std::isnan(map.slope.data()[k]));
  }
}

TEST(Traversability, ParametersOutOfRangeThrowNamingTheParameter) {
  const HeightGrid grid = plane_grid(0, 0);
  const TerrainEstimate terrain = fit_terrain(grid, parameters_for_plane());
  const auto expect_named = [&](TraversabilityParameters parameters, const std::string& name) {
    try {
      compute_traversability(terrain, grid, parameters);
      ADD_FAILURE() << name << ": no throw";
    } catch (const std::invalid_argument& error) {
      EXPECT_EQ(std::string(error.what()).rfind(name + ":", 0), 0u) << error.what();
    }
  };
  TraversabilityParameters p;
  p.occupancy_weight = -1;
  expect_named(p, "occupancy_weight");
  p = TraversabilityParameters{}, p.slope_weight = std::numeric_limits<double>::infinity();
  expect_named(p, "slope_weight");
  p = TraversabilityParameters{}, p.obstacle_height_m = 0;
  expect_named(p, "obstacle_height_m");
  EXPECT_THROW(classify_points({}, terrain, -0.2), std::invalid_argument);
}

TEST(ClassifyPoints, ByHeightAboveTheSurface) {
  const HeightGrid grid = plane_grid(0.1, 0.0);  // z = 1 + 0.1 x
  const TerrainEstimate terrain = fit_terrain(grid, parameters_for_plane());
  ASSERT_TRUE(terrain.known) << terrain.reason;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Eigen::Vector3d> points = {
      {5, 0, 1.5 + 0.1},      // 0.1 m above: terrain
      {5, 1, 1.5 + 0.5},      // 0.5 m above: obstacle
      {8, -2, 1.8 - 1.0},     // 1 m below (a ditch seen through): terrain
      {8, -2, 1.8 + 0.19},    // just under the 0.2 m threshold
      {8, -2, 1.8 + 0.21},    // just over it
      {-1, 0, 0},             // behind the area
      {5, 6, 1.5},            // beside it
      {5, nan, 1.5},          // not finite
      {5, 0, std::numeric_limits<double>::infinity()},
  };
  const std::vector<PointClass> classes = classify_points(points, terrain, 0.2);
  const std::vector<PointClass> expected = {PointClass::terrain, PointClass::obstacle, PointClass::terrain,
                                            PointClass::terrain, PointClass::obstacle, PointClass::outside,
                                            PointClass::outside, PointClass::outside, PointClass::outside};
  ASSERT_EQ(classes.size(), expected.size());
  for (size_t k = 0; k < classes.size(); ++k) EXPECT_EQ(int(classes[k]), int(expected[k])) << "point " << k;
  TerrainEstimate unknown;
  for (const PointClass point_class : classify_points(points, unknown, 0.2)) EXPECT_EQ(int(point_class), int(PointClass::outside));
}

// The stereo-aware classification on the flat surface z = 0 (plane_grid(0, 0) + 1 m offset removed
// below): a camera 1.5 m up looking along x, f B = 166 px m (f 554 px, B 0.30 m), margin 1 px.
//   (20, 0, 0.30): d = 166 / 20 = 8.3 px; pushed by 8.3 / 7.3 = 1.13699 along the ray (20, 0, -1.2)
//                  from the camera: z = 1.5 - 1.2 x 1.13699 = 0.1356 <= 0.2: terrain (the plain rule
//                  says obstacle);
//   (20, 0, 0.80): pushed z = 1.5 - 0.7 x 1.13699 = 0.7041 > 0.2: obstacle;
//   (6, 0, 0.30):  d = 27.67 px, scale 27.67 / 26.67 = 1.0375, z = 1.5 - 1.2 x 1.0375 = 0.255: obstacle;
//   (200, 0, 0.5) is outside the area: outside either way.
// The flat surface z = 0 of these tests, and their camera: 1.5 m up looking along x, f B = 166 px m.
TerrainEstimate flat_terrain() {
  HeightGrid grid = plane_grid(0.0, 0.0);
  grid.height_m.setZero();
  return fit_terrain(grid, parameters_for_plane());
}

StereoRayModel camera_1_5_m_up(double disparity_margin_px) {
  StereoRayModel stereo;
  stereo.camera_centre_m = Eigen::Vector3d(0, 0, 1.5);
  stereo.optical_axis = Eigen::Vector3d::UnitX();
  stereo.focal_baseline_px_m = 166;
  stereo.disparity_margin_px = disparity_margin_px;
  return stereo;
}

TEST(ClassifyPoints, StereoMarginPushesGroundLikePointsBackOntoTheSurface) {
  const TerrainEstimate terrain = flat_terrain();
  ASSERT_TRUE(terrain.known) << terrain.reason;
  StereoRayModel stereo = camera_1_5_m_up(1.0);
  // Hand computation of the first case, independent of the implementation's form.
  const double pushed_z = 1.5 - 1.2 * (8.3 / 7.3);
  EXPECT_NEAR(pushed_z, 0.1356, 1e-4);
  const std::vector<Eigen::Vector3d> points = {{10, 0, 0.30}, {10, 0, 0.80}, {6, 0, 0.30}, {200, 0, 0.5}};
  // Scaled to the 12 m area: the same geometry at x = 10 (d = 16.6 px, scale 16.6 / 15.6):
  //   (10, 0, 0.30): z = 1.5 - 1.2 x 1.0641 = 0.2231 > 0.2: obstacle (nearer: smaller height error);
  const std::vector<PointClass> plain = classify_points(points, terrain, 0.2);
  const std::vector<PointClass> with_margin = classify_points(points, terrain, 0.2, stereo);
  EXPECT_EQ(int(plain[0]), int(PointClass::obstacle));
  EXPECT_EQ(int(with_margin[0]), int(PointClass::obstacle));
  EXPECT_EQ(int(with_margin[1]), int(PointClass::obstacle));
  EXPECT_EQ(int(with_margin[2]), int(PointClass::obstacle));
  EXPECT_EQ(int(with_margin[3]), int(PointClass::outside));
  // A wider margin (2 px) at x = 10: scale 16.6 / 14.6 = 1.13699, z = 0.1356: terrain; 0.8 m stays.
  stereo.disparity_margin_px = 2.0;
  const std::vector<PointClass> wider = classify_points(points, terrain, 0.2, stereo);
  EXPECT_EQ(int(wider[0]), int(PointClass::terrain));
  EXPECT_EQ(int(wider[1]), int(PointClass::obstacle));
  // A margin at or above the disparity: the point could be anywhere beyond: terrain.
  stereo.disparity_margin_px = 17.0;
  EXPECT_EQ(int(classify_points(points, terrain, 0.2, stereo)[1]), int(PointClass::terrain));
  stereo.disparity_margin_px = -1;
  EXPECT_THROW(classify_points(points, terrain, 0.2, stereo), std::invalid_argument);
  stereo.disparity_margin_px = 1;
  stereo.focal_baseline_px_m = 0;
  EXPECT_THROW(classify_points(points, terrain, 0.2, stereo), std::invalid_argument);
  stereo.focal_baseline_px_m = 166;
  stereo.optical_axis = Eigen::Vector3d(2, 0, 0);
  EXPECT_THROW(classify_points(points, terrain, 0.2, stereo), std::invalid_argument);
}

// Support: with a 2 px margin (10, 0, 0.30) falls back (worked above); beside a sure obstacle point
// (10.1, 0.1, 0.80) in the same 0.5 m cell it is an obstacle again with support_reach_cells 0, while
// the same height at (10, -3) with no sure point within a cell stays terrain; one cell away
// ((10.6, 0.1), the next forward cell) it needs reach 1; off (-1) both fall back.
TEST(ClassifyPoints, SupportKeepsLowPointsBesideSureOnes) {
  const TerrainEstimate terrain = flat_terrain();
  ASSERT_TRUE(terrain.known) << terrain.reason;
  StereoRayModel stereo = camera_1_5_m_up(2.0);
  const std::vector<Eigen::Vector3d> same_cell = {{10, 0, 0.30}, {10.1, 0.1, 0.80}, {10, -3, 0.30}};
  const std::vector<Eigen::Vector3d> next_cell = {{10, 0, 0.30}, {10.6, 0.1, 0.80}};
  const auto classes = [&](const std::vector<Eigen::Vector3d>& points, int reach) {
    stereo.support_reach_cells = reach;
    std::vector<int> result;
    for (PointClass c : classify_points(points, terrain, 0.2, stereo)) result.push_back(int(c));
    return result;
  };
  const int obstacle = int(PointClass::obstacle), ground = int(PointClass::terrain);
  EXPECT_EQ(classes(same_cell, -1), (std::vector<int>{ground, obstacle, ground}));
  EXPECT_EQ(classes(same_cell, 0), (std::vector<int>{obstacle, obstacle, ground}));
  EXPECT_EQ(classes(next_cell, 0), (std::vector<int>{ground, obstacle}));
  EXPECT_EQ(classes(next_cell, 1), (std::vector<int>{obstacle, obstacle}));
  stereo.support_reach_cells = -2;
  EXPECT_THROW(classify_points(same_cell, terrain, 0.2, stereo), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm::terrain
