// Occupancy grids (arm/obstacles3d/occupancy_grid.h): a single point's likelihood has the window's
// mass (2 Phi(3) - 1)^2 and peaks at its cell in all three grids; the cartesian covariance equals
// J diag(sigma_u^2, sigma_d^2) J^T with J a numerical Jacobian of the triangulation; log-odds fusion
// rises monotonically to the clamp and decays without evidence; a cell long without evidence is
// occupied after one frame of full evidence (the shallow lower clamp); ego-motion (a translation in the
// cartesian grid, a yaw in the polar grid, driving forward in the column/disparity grid) moves an
// occupied cell where a hand derivation says;
// gift wrapping on hand-made sets (interior, collinear and duplicate points, degenerate sets, and a
// random set checked by brute force); connected components; two separated blobs give two obstacles;
// two objects 6 m apart on one bearing at 25-31 m (one cluster of occupied cells) are two obstacles;
// points smeared along their rays metres behind a board do not stretch its obstacle;
// clipping and rejection counted and reported; empty cloud and missing ego-motion reported; bad
// parameters throw naming the parameter; the counted work's per-cell closed form; 2 threads agree
// (the points dealt in blocks), and so does the ego-motion resampling (rows dealt); an occupancy-only update has the same log-odds, no clusters and less work;
// the image-column gap split on hand-made columns, two objects at one depth with 4 empty image
// columns between them are two obstacles (one with the split off), and a wide object with 2 empty
// columns stays one; the range-peak split cuts a receding surface's far end from a nearer object
// beside it when both sides fall by more than the threshold, and not under it nor a convex profile;
// the concavity split cuts a pedestrian touching a car side's far end (no empty column, no range
// peak: the old cuts leave it) at the knee of the disparity profile, not under either threshold, and
// every grid gives the pedestrian its own obstacle (the polar grid one joint obstacle with the split
// off), while a car's side, a car at its corner, a wide box and a pedestrian alone are not cut and stay
// one obstacle in every grid.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "arm/obstacles3d/occupancy_grid.h"
#include "tests/arm/obstacles3d/synthetic_points.h"

namespace lpstereo::arm::obstacles3d {
namespace {

using testing::add_patch;
using testing::grid_parameters;
using testing::kBaselineM;
using testing::kFocalPx;
using testing::point_at;

// (2 Phi(3) - 1)^2: the mass of a 2D Gaussian inside a +-3 sigma box (independent of the code).
const double kWindowMass = std::pow(std::erf(3.0 / std::sqrt(2.0)), 2);

double logit(double p) { return std::log(p / (1 - p)); }

struct Peak {
  int row = -1, column = -1;
  float value = 0;
};
Peak peak_of(const GridMatrix& matrix) {
  Peak peak;
  Eigen::Index row = 0, column = 0;
  peak.value = matrix.maxCoeff(&row, &column);
  peak.row = static_cast<int>(row);
  peak.column = static_cast<int>(column);
  return peak;
}

void expect_single_point_mass_and_peak(GridKind kind, const ObstaclePoint& point, int expected_row,
                                       int expected_column) {
  OccupancyGrid grid(grid_parameters(kind));
  GridMatrix evidence = GridMatrix::Zero(grid.rows(), grid.columns());
  const double mass = grid.add_likelihood(grid.measurement_gaussian(point), evidence, nullptr);
  EXPECT_NEAR(mass, kWindowMass, 1e-9) << grid_kind_name(kind);
  EXPECT_NEAR(evidence.sum(), kWindowMass, 1e-5) << grid_kind_name(kind);
  const Peak peak = peak_of(evidence);
  EXPECT_EQ(peak.row, expected_row) << grid_kind_name(kind);
  EXPECT_EQ(peak.column, expected_column) << grid_kind_name(kind);
}

TEST(OccupancyGridLikelihood, SinglePointHasTheWindowMassAndPeaksAtItsCell) {
  // Cartesian: x = 0.1 m, z = 20 m: sigma_z = 20^2 0.25 / 150 = 0.67 m, spread over ~20 rows.
  // Cell (row, column) = ((20 - 0.5) / 0.2, (0.1 + 10) / 0.2) = (97.5, 50.5) -> (97, 50).
  expect_single_point_mass_and_peak(GridKind::cartesian, point_at(0.1, 0.5, 20.0), 97, 50);
  // Polar: theta = 0.055 rad at z = 20: column (0.055 + 0.6) / 0.01 = 65.5 -> 65, range
  // r = 20 / cos(0.055) = 20.0303: row (20.0303 - 0.5) / 0.2 = 97.65 -> 97.
  expect_single_point_mass_and_peak(GridKind::polar, point_at(20.0 * std::tan(0.055), 0.5, 20.0), 97, 65);
  // Column/disparity: u = 302 (cell [300, 304) = 75), d = 7.75 (cell [7.5, 8) = 15).
  ObstaclePoint point = point_at(0.0, 0.5, kFocalPx * kBaselineM / 7.75);
  point.u_px = 302;
  expect_single_point_mass_and_peak(GridKind::column_disparity, point, 15, 75);
}

TEST(OccupancyGridLikelihood, ANearPointPutsTheWholeWindowInOneCell) {
  // z = 3 m: sigma_z = 9 0.25 / 150 = 0.015 m, sigma_x = 0.003 m; the +-3 sigma box (0.09 x 0.018 m)
  // lies inside the cell x in [0.0, 0.2), z in [2.9, 3.1).
  OccupancyGrid grid(grid_parameters(GridKind::cartesian));
  GridMatrix evidence = GridMatrix::Zero(grid.rows(), grid.columns());
  grid.add_likelihood(grid.measurement_gaussian(point_at(0.1, 0.5, 3.0)), evidence, nullptr);
  EXPECT_NEAR(evidence(12, 50), kWindowMass, 1e-6);  // row (3.0 - 0.5) / 0.2 = 12.5 -> 12
  EXPECT_EQ((evidence.array() > 0).count(), 1);
}

TEST(OccupancyGridLikelihood, CartesianCovarianceIsTheTriangulationJacobianOfThePixelErrors) {
  OccupancyGrid grid(grid_parameters(GridKind::cartesian));
  const double x = 3.0, z = 12.0;
  const GridGaussian gaussian = grid.measurement_gaussian(point_at(x, 0.5, z));
  // x(u, d) = B (u - u0) / d, z(u, d) = f B / d, differentiated numerically at the point's (u, d).
  const double u = testing::kPrincipalUPx + kFocalPx * x / z, d = kFocalPx * kBaselineM / z;
  auto triangulate = [](double u_px, double d_px) {
    return Eigen::Vector2d(kBaselineM * (u_px - testing::kPrincipalUPx) / d_px, kFocalPx * kBaselineM / d_px);
  };
  const double h = 1e-4;
  Eigen::Matrix2d jacobian;
  jacobian.col(0) = (triangulate(u + h, d) - triangulate(u - h, d)) / (2 * h);
  jacobian.col(1) = (triangulate(u, d + h) - triangulate(u, d - h)) / (2 * h);
  const Eigen::Matrix2d pixel_covariance = Eigen::Vector2d(0.5 * 0.5, 0.25 * 0.25).asDiagonal();
  const Eigen::Matrix2d expected = jacobian * pixel_covariance * jacobian.transpose();
  EXPECT_NEAR(gaussian.covariance(0, 0), expected(0, 0), 1e-6 * expected(0, 0));
  EXPECT_NEAR(gaussian.covariance(0, 1), expected(0, 1), 1e-6 * std::abs(expected(0, 1)));
  EXPECT_NEAR(gaussian.covariance(1, 1), expected(1, 1), 1e-6 * expected(1, 1));
}

TEST(OccupancyGridFusion, RepeatedObservationsRiseMonotonicallyToTheClamp) {
  OccupancyGridParameters parameters = grid_parameters(GridKind::cartesian);
  OccupancyGrid grid(parameters);
  const std::vector<ObstaclePoint> points = {point_at(0.1, 0.5, 3.0)};
  const int row = static_cast<int>((3.0 - 0.5) / 0.2), column = 50;
  // The first frame's log-odds by the header's inverse sensor model: D = the window mass.
  const double p_first = 0.45 + (0.85 - 0.45) * (1 - std::exp(-kWindowMass / 2.0));
  float previous = 0.5f;
  bool reached_clamp = false;
  for (int frame = 0; frame < 40; ++frame) {
    grid.update(points, EgoMotion{});
    const float probability = grid.probability(row, column);
    if (frame == 0) {
      EXPECT_NEAR(grid.log_odds()(row, column), logit(p_first), 1e-5);
    }
    if (grid.log_odds()(row, column) >= parameters.log_odds_max) {
      reached_clamp = true;
      EXPECT_FLOAT_EQ(grid.log_odds()(row, column), static_cast<float>(parameters.log_odds_max));
      EXPECT_GE(probability, previous);
    } else {
      EXPECT_GT(probability, previous) << "frame " << frame;
    }
    previous = probability;
  }
  EXPECT_TRUE(reached_clamp);
  EXPECT_NEAR(previous, 1 / (1 + std::exp(-parameters.log_odds_max)), 1e-6);
  EXPECT_TRUE(grid.occupied(row, column));
  // Without evidence the cell decays by logit(miss) per frame down to the lower clamp.
  grid.update({}, EgoMotion{});
  EXPECT_NEAR(grid.log_odds()(row, column), parameters.log_odds_max + logit(0.45), 1e-5);
  for (int frame = 0; frame < 100; ++frame) grid.update({}, EgoMotion{});
  EXPECT_FLOAT_EQ(grid.log_odds()(row, column), static_cast<float>(parameters.log_odds_min));
  EXPECT_FALSE(grid.occupied(row, column));
}

TEST(OccupancyGridFusion, ACellLongWithoutEvidenceIsOccupiedAfterOneFrameOfFullEvidence) {
  // 30 frames without evidence take a cell to the lower clamp; then a dense patch (2227 points in
  // the cell at 5 m, D >> points_for_full_evidence, p(D) -> hit_probability_max) for one frame.
  // With the default clamp the cell is occupied at once: log_odds_min + logit(hit_max) >
  // logit(occupied); with a clamp at -4 it would still read free (-4 + 1.73 < 0.62).
  std::vector<ObstaclePoint> patch;
  add_patch(patch, 0.02, 0.18, 0.2, 1.5, 5.0, 0.01);  // cell row (5 - 0.5) / 0.2 = 22, column (0.1 + 10) / 0.2 = 50
  const int row = 22, column = 50;
  for (double log_odds_min : {OccupancyGridParameters{}.log_odds_min, -4.0}) {
    OccupancyGridParameters parameters = grid_parameters(GridKind::cartesian);
    parameters.log_odds_min = log_odds_min;
    OccupancyGrid grid(parameters);
    for (int frame = 0; frame < 30; ++frame) grid.update({}, EgoMotion{});
    EXPECT_FLOAT_EQ(grid.log_odds()(row, column), static_cast<float>(log_odds_min));
    grid.update(patch, EgoMotion{});
    EXPECT_GT(grid.evidence()(row, column), 100.0f);
    const bool expected = log_odds_min + logit(parameters.hit_probability_max) > logit(parameters.occupied_probability);
    EXPECT_EQ(expected, log_odds_min > -1.116) << log_odds_min;  // logit(0.65) - logit(0.85) = -1.116
    EXPECT_EQ(grid.occupied(row, column), expected) << "log_odds_min " << log_odds_min;
    EXPECT_EQ(grid.obstacles().size(), expected ? 1u : 0u) << grid.status();
  }
  EXPECT_GT(OccupancyGridParameters{}.log_odds_min, -1.116);
}

TEST(OccupancyGridEgoMotion, ATranslationMovesTheCartesianCellByTheMotion) {
  OccupancyGrid grid(grid_parameters(GridKind::cartesian));
  // Frame 1: a point at camera (x, z) = (0.1, 10.0): cell ((10 - 0.5) / 0.2, (0.1 + 10) / 0.2) = (47, 50).
  grid.update({point_at(0.1, 0.5, 10.0)}, EgoMotion{});
  const Peak before = peak_of(grid.log_odds());
  ASSERT_EQ(before.row, 47);
  ASSERT_EQ(before.column, 50);
  // The vehicle drove 1.0 m forward and 0.6 m left: p_previous = p_current + (1.0, 0.6, 0) (vehicle
  // x forward, y left). The point, at vehicle (10.0, -0.1) before, is at (9.0, -0.7) now: camera
  // x = 0.7, z = 9.0, cell ((9 - 0.5) / 0.2, (0.7 + 10) / 0.2) = (42.5, 53.5) -> (42, 53).
  EgoMotion motion;
  motion.available = true;
  motion.previous_from_current.translation() = Eigen::Vector3d(1.0, 0.6, 0.0);
  grid.update({}, motion);
  const Peak after = peak_of(grid.log_odds());
  EXPECT_EQ(after.row, 42);
  EXPECT_EQ(after.column, 53);
  EXPECT_NEAR(after.value, before.value + logit(0.45), 1e-5);  // carried, then one frame without evidence
  EXPECT_NE(grid.status().find("ego-motion compensated"), std::string::npos) << grid.status();
}

TEST(OccupancyGridEgoMotion, AYawTurnsThePolarCellByTheAngle) {
  OccupancyGrid grid(grid_parameters(GridKind::polar));
  // theta = 0.055 rad (column 65), range 10.0 m (row (10 - 0.5) / 0.2 = 47.5 -> 47).
  grid.update({point_at(10.0 * std::sin(0.055), 0.5, 10.0 * std::cos(0.055))}, EgoMotion{});
  const Peak before = peak_of(grid.log_odds());
  ASSERT_EQ(before.row, 47);
  ASSERT_EQ(before.column, 65);
  // Turning left by psi = 0.05 rad about the camera (p_previous = Rz(psi) p_current): a fixed
  // point's bearing (+ right) grows by psi, theta = 0.105 -> column 70.5 -> 70; its range is kept.
  EgoMotion motion;
  motion.available = true;
  motion.previous_from_current.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  grid.update({}, motion);
  const Peak after = peak_of(grid.log_odds());
  EXPECT_EQ(after.row, 47);
  EXPECT_EQ(after.column, 70);
}

TEST(OccupancyGridEgoMotion, DrivingForwardMovesTheColumnDisparityCellToALargerDisparity) {
  OccupancyGrid grid(grid_parameters(GridKind::column_disparity));
  // u = 318 (column [316, 320) = 79), d = 5.25 px (row [5.0, 5.5) = 10): z = f B / d = 28.57 m.
  ObstaclePoint point = point_at(0.0, 0.5, kFocalPx * kBaselineM / 5.25);
  point.u_px = 318;
  grid.update({point}, EgoMotion{});
  ASSERT_EQ(peak_of(grid.log_odds()).row, 10);
  ASSERT_EQ(peak_of(grid.log_odds()).column, 79);
  // 5 m forward. Backward lookup from the current cell centres: row 12 (d = 6.25, z = 24.0 m) was at
  // z = 29.0 m, d = 5.17 (row 10); its neighbours row 11 (d = 5.75 -> z 26.09 -> 31.09 m, d = 4.83,
  // row 9) and row 13 (d = 6.75 -> z 22.22 -> 27.22 m, d = 5.51, row 11) miss it. Column 79's
  // centre u = 318: x = -1.5 z / f keeps its x, u = 319.5 - 1.5 * 24 / 29 = 318.26 (column 79).
  EgoMotion motion;
  motion.available = true;
  motion.previous_from_current.translation() = Eigen::Vector3d(5.0, 0.0, 0.0);
  grid.update({}, motion);
  EXPECT_EQ(peak_of(grid.log_odds()).row, 12);
  EXPECT_EQ(peak_of(grid.log_odds()).column, 79);
}

std::vector<Eigen::Vector2d> points_2d(std::initializer_list<std::pair<double, double>> coordinates) {
  std::vector<Eigen::Vector2d> points;
  for (const auto& [x, y] : coordinates) points.emplace_back(x, y);
  return points;
}

TEST(GiftWrapping, SquareWithInteriorCollinearAndDuplicatePoints) {
  const std::vector<Eigen::Vector2d> points = points_2d({{1, 1}, {2, 2}, {0, 0}, {1, 0}, {2, 0}, {2, 1}, {0, 2},
                                                         {1, 2}, {0, 1}, {0.5, 1.5}, {2, 2}, {0, 0}, {2, 0}});
  const std::vector<Eigen::Vector2d> hull = gift_wrapping_hull(points);
  const std::vector<Eigen::Vector2d> expected = points_2d({{0, 0}, {2, 0}, {2, 2}, {0, 2}});  // CCW from lowest-left
  ASSERT_EQ(hull.size(), expected.size());
  for (size_t i = 0; i < hull.size(); ++i) EXPECT_EQ(hull[i], expected[i]) << i;
}

TEST(GiftWrapping, DegenerateSets) {
  EXPECT_TRUE(gift_wrapping_hull({}).empty());
  const auto same = gift_wrapping_hull(points_2d({{3, 4}, {3, 4}, {3, 4}}));
  ASSERT_EQ(same.size(), 1u);
  EXPECT_EQ(same[0], Eigen::Vector2d(3, 4));
  const auto line = gift_wrapping_hull(points_2d({{1, 1}, {3, 3}, {0, 0}, {2, 2}, {3, 3}}));
  ASSERT_EQ(line.size(), 2u);
  EXPECT_EQ(line[0], Eigen::Vector2d(0, 0));
  EXPECT_EQ(line[1], Eigen::Vector2d(3, 3));
  const auto triangle = gift_wrapping_hull(points_2d({{0, 0}, {4, 0}, {0, 0}, {2, 3}, {4, 0}, {2, 1}}));
  ASSERT_EQ(triangle.size(), 3u);
  EXPECT_EQ(triangle[0], Eigen::Vector2d(0, 0));
  EXPECT_EQ(triangle[1], Eigen::Vector2d(4, 0));
  EXPECT_EQ(triangle[2], Eigen::Vector2d(2, 3));
}

TEST(GiftWrapping, RandomSetsAgreeWithABruteForceCheck) {
  std::mt19937 random(5);
  std::uniform_real_distribution<double> coordinate(-10, 10);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<Eigen::Vector2d> points;
    for (int i = 0; i < 60; ++i) points.emplace_back(coordinate(random), coordinate(random));
    const std::vector<Eigen::Vector2d> hull = gift_wrapping_hull(points);
    ASSERT_GE(hull.size(), 3u);
    for (size_t i = 0; i < hull.size(); ++i) {
      const Eigen::Vector2d& a = hull[i];
      const Eigen::Vector2d& b = hull[(i + 1) % hull.size()];
      const Eigen::Vector2d& c = hull[(i + 2) % hull.size()];
      // Strictly left turns (convex, counter-clockwise, no collinear vertices) ...
      EXPECT_GT((b - a).x() * (c - b).y() - (b - a).y() * (c - b).x(), 0);
      // ... and every point on or left of every edge.
      for (const Eigen::Vector2d& p : points) EXPECT_GE((b - a).x() * (p - a).y() - (b - a).y() * (p - a).x(), -1e-9);
    }
    // A point is a vertex exactly when it is not inside the hull of the others: brute force over the
    // vertex list, each vertex must be an input point.
    for (const Eigen::Vector2d& vertex : hull)
      EXPECT_TRUE(std::find(points.begin(), points.end(), vertex) != points.end());
  }
}

TEST(ConnectedComponents, DiagonalNeighboursJoinAndSmallComponentsAreDropped) {
  // 4 x 5 mask:      components in raster order:
  //   1 0 0 0 1      {0, 6, 12} (diagonal chain), {4, 9} , {15} (single, dropped with min_cells 2)
  //   0 1 0 0 1
  //   0 0 1 0 0
  //   1 0 0 0 0
  const std::vector<uint8_t> mask = {1, 0, 0, 0, 1, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0};
  std::vector<int> labels;
  const auto components = connected_components_8(mask, 4, 5, 2, &labels, nullptr);
  ASSERT_EQ(components.size(), 2u);
  EXPECT_EQ(components[0], (std::vector<int>{0, 6, 12}));
  EXPECT_EQ(components[1], (std::vector<int>{4, 9}));
  EXPECT_EQ(labels[15], -1);
  EXPECT_EQ(labels[12], 0);
  EXPECT_EQ(labels[9], 1);
}

TEST(OccupancyGridClusters, TwoSeparatedBlobsGiveTwoObstacles) {
  for (GridKind kind : {GridKind::cartesian, GridKind::polar, GridKind::column_disparity}) {
    OccupancyGrid grid(grid_parameters(kind));
    std::vector<ObstaclePoint> points;
    add_patch(points, -3.3, -2.7, 0.0, 1.0, 10.0, 0.02);  // a 0.6 m wide, 1 m tall object left
    add_patch(points, 2.6, 3.4, 0.0, 0.5, 12.0, 0.02);    // a 0.8 m wide, 0.5 m tall object right
    for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
    ASSERT_EQ(grid.obstacles().size(), 2u) << grid_kind_name(kind) << ": " << grid.status();
    ASSERT_EQ(grid.clusters().size(), 2u) << grid_kind_name(kind);
    // Raster order (row = far..., cartesian row 0 is near): find each by its side.
    const Obstacle3d& left = grid.obstacles()[0].position_m.x() < 0 ? grid.obstacles()[0] : grid.obstacles()[1];
    const Obstacle3d& right = grid.obstacles()[0].position_m.x() < 0 ? grid.obstacles()[1] : grid.obstacles()[0];
    EXPECT_NEAR(left.position_m.x(), -3.0, 0.02) << grid_kind_name(kind);
    EXPECT_NEAR(left.position_m.z(), 10.0, 0.01) << grid_kind_name(kind);
    EXPECT_NEAR(left.size_m.x(), 0.6, 0.02) << grid_kind_name(kind);
    EXPECT_NEAR(left.min_height_m, 0.0, 1e-6);
    EXPECT_NEAR(left.max_height_m, 1.0, 1e-5);
    EXPECT_NEAR(right.position_m.x(), 3.0, 0.02) << grid_kind_name(kind);
    EXPECT_NEAR(right.max_height_m, 0.5, 1e-5);
    EXPECT_LT(left.bbox_px[2], right.bbox_px[0]);  // left's pixels left of right's
    for (const GridCluster& cluster : grid.clusters()) {
      EXPECT_GE(cluster.hull.size(), 3u);
      EXPECT_GT(cluster.point_count, 0);
      // Every cell centre of the cluster lies inside its hull (left of every counter-clockwise edge).
      for (int cell : cluster.cells) {
        const int row = cell / grid.columns(), column = cell % grid.columns();
        const OccupancyGridParameters& p = grid.parameters();
        const Eigen::Vector2d centre = grid.picture_plane_of(p.column_min + (column + 0.5) * p.column_cell,
                                                             p.row_min + (row + 0.5) * p.row_cell);
        for (size_t i = 0; i < cluster.hull.size(); ++i) {
          const Eigen::Vector2d& a = cluster.hull[i];
          const Eigen::Vector2d& b = cluster.hull[(i + 1) % cluster.hull.size()];
          EXPECT_GT((b - a).x() * (centre - a).y() - (b - a).y() * (centre - a).x(), 0) << grid_kind_name(kind);
        }
      }
    }
  }
}

TEST(OccupancyGridClusters, TwoObjectsOnOneBearingSixMetresApartAtRangeAreTwoObstacles) {
  // A pedestrian-sized object (0.5 m wide, 0.2-1.7 m) at 25 m and another at 31 m on the same
  // bearing, one point per pixel, each disparity off by a Gaussian of the error model's sigma_d (so
  // depths scatter by sigma_Z = 1.0 m and 1.6 m). The likelihood windows (+-3 sigma_Z) overlap, so
  // the polar grid's occupied cells join the two into one cluster; each object must still be an
  // obstacle whose centre lies within 1 m + w/2 across and max(1 m, 3 sigma_Z) + l/2 in depth
  // (bench/obstacles3d_eval's gate) by the third frame.
  const StereoErrorModel model = testing::error_model();
  std::mt19937 generator(5);
  std::normal_distribution<double> disparity_error(0.0, model.disparity_sigma_px);
  OccupancyGrid grid(grid_parameters(GridKind::polar));
  const double depths_m[2] = {25.0, 31.0};
  for (int frame = 0; frame < 3; ++frame) {
    std::vector<ObstaclePoint> points;
    for (double z : depths_m) {
      const double pixel_m = z / kFocalPx;
      for (double x = 0.75; x <= 1.25; x += pixel_m) {
        for (double height = 0.2; height <= 1.7; height += pixel_m) {
          const double disparity = kFocalPx * kBaselineM / z + disparity_error(generator);
          const double scale = kFocalPx * kBaselineM / disparity / z;  // along the ray
          points.push_back(point_at(x * scale, testing::kCameraHeightM - (testing::kCameraHeightM - height) * scale, z * scale));
        }
      }
    }
    grid.update(points, EgoMotion{});
  }
  // Each object has its own obstacle: the nearest obstacle centre to each lies in its gate, and the
  // two are different obstacles (one obstacle for both would describe neither).
  int nearest_of[2] = {-1, -1};
  for (int k = 0; k < 2; ++k) {
    const double z = depths_m[k];
    const double depth_gate_m = std::max(1.0, 3 * model.depth_sigma_m(z)) + 0.25;
    double nearest_distance_m = 1e9;
    for (size_t i = 0; i < grid.obstacles().size(); ++i) {
      const Eigen::Vector3d& centre = grid.obstacles()[i].position_m;
      const double distance_m = std::hypot(centre.x() - 1.0, centre.z() - z);
      if (distance_m < nearest_distance_m) nearest_distance_m = distance_m, nearest_of[k] = static_cast<int>(i);
    }
    ASSERT_GE(nearest_of[k], 0) << grid.status();
    const Eigen::Vector3d& centre = grid.obstacles()[static_cast<size_t>(nearest_of[k])].position_m;
    EXPECT_LE(std::abs(centre.x() - 1.0), 1.25) << "object at " << z << " m";
    EXPECT_LE(std::abs(centre.z() - z), depth_gate_m) << "object at " << z << " m: " << grid.status();
  }
  EXPECT_NE(nearest_of[0], nearest_of[1]) << grid.status();
}

// Points of an upright rectangle (x in [x0, x1], heights 0.2..top) at depth z, one per pixel, each
// disparity off by a Gaussian of the error model's sigma_d (the point moves along its ray).
void add_noisy_patch(std::vector<ObstaclePoint>& points, double x0_m, double x1_m, double top_m, double z_m, std::mt19937& generator) {
  const StereoErrorModel model = testing::error_model();
  std::normal_distribution<double> disparity_error(0.0, model.disparity_sigma_px);
  const double pixel_m = z_m / kFocalPx;
  for (double x = x0_m; x <= x1_m; x += pixel_m) {
    for (double height = 0.2; height <= top_m; height += pixel_m) {
      const double disparity = kFocalPx * kBaselineM / z_m + disparity_error(generator);
      const double scale = kFocalPx * kBaselineM / disparity / z_m;
      points.push_back(point_at(x * scale, testing::kCameraHeightM - (testing::kCameraHeightM - height) * scale, z_m * scale));
    }
  }
}

TEST(OccupancyGridClusters, APedestrianJustBehindACarOnOneBearingIsItsOwnObstacle) {
  // A car's rear (2 m wide, 0.2-1.4 m) at 15 m and a pedestrian (0.2-1.7 m) 2 m behind it, half
  // hidden: only x in [0.9, 1.4] of it shows beside the car's right edge at x = 1 m. The bearings
  // overlap and the likelihoods' windows (3 sigma_Z = 1.1 m and 1.4 m) touch, so the cells holding
  // points are one group; a single obstacle for both would run from 14 to 18 m with its centre
  // between them. Each must have its own obstacle centred within 0.5 m of its depth and no deeper
  // than its own likelihood window (the rule: the group splits where the density's mode jumps in range by more
  // than a window between neighbouring bearings).
  const StereoErrorModel model = testing::error_model();
  ASSERT_GT(3 * model.depth_sigma_m(15.0) + 3 * model.depth_sigma_m(17.0), 2.0);  // the windows meet
  std::mt19937 generator(11);
  // (The column/disparity grid splits on the same rule, but here the two depths are 10 and 8.8 px,
  // within its window of 3 sigma_d + a 0.5 px cell = 1.25 px: one object there.)
  // A Cartesian column is not a ray: it keeps one object per group of cells (see the header), so there
  // the two are separated by the profile cuts alone (the car's 10 px disparity profile steps down
  // to the pedestrian's 8.8 px for his 12 visible columns: 1.1 px and 1.8 m under the envelope, a
  // step of about 1.2 px and 2 m with the noise); with the concavity and range-step splits off
  // (min_concavity_px = 0, max_range_step_columns_px = 0), one obstacle holds both, its box running
  // over both depths.
  for (double concavity_px : {0.5, 0.0}) {
    for (GridKind kind : {GridKind::polar, GridKind::cartesian}) {
      OccupancyGridParameters parameters = grid_parameters(kind);
      parameters.min_concavity_px = concavity_px;
      if (concavity_px == 0) parameters.max_range_step_columns_px = 0;
      OccupancyGrid grid(parameters);
      for (int frame = 0; frame < 3; ++frame) {
        std::vector<ObstaclePoint> points;
        add_noisy_patch(points, -1.0, 1.0, 1.4, 15.0, generator);
        std::vector<ObstaclePoint> pedestrian;
        add_noisy_patch(pedestrian, 0.9, 1.4, 1.7, 17.0, generator);
        for (const ObstaclePoint& point : pedestrian)  // hidden behind the car where its bearing meets the car's
          if (point.u_px > testing::kPrincipalUPx + kFocalPx * 1.0 / 15.0) points.push_back(point);
        grid.update(points, EgoMotion{});
      }
      if (kind == GridKind::cartesian && concavity_px == 0) {
        ASSERT_EQ(grid.obstacles().size(), 1u) << grid.status();
        const Obstacle3d& both = grid.obstacles()[0];  // its box runs over the car's and the pedestrian's depths
        EXPECT_LT(both.position_m.z() - both.size_m.z() / 2, 15.2);
        EXPECT_GT(both.position_m.z() + both.size_m.z() / 2, 16.8);
        continue;
      }
      int nearest_of[2] = {-1, -1};
      const double depths_m[2] = {15.0, 17.0}, lateral_m[2] = {0.0, 1.15};
      for (int k = 0; k < 2; ++k) {
        double nearest_distance_m = 1e9;
        for (size_t i = 0; i < grid.obstacles().size(); ++i) {
          const Eigen::Vector3d& centre = grid.obstacles()[i].position_m;
          const double distance_m = std::hypot(centre.x() - lateral_m[k], centre.z() - depths_m[k]);
          if (distance_m < nearest_distance_m) nearest_distance_m = distance_m, nearest_of[k] = static_cast<int>(i);
        }
        ASSERT_GE(nearest_of[k], 0) << grid_kind_name(kind) << ": " << grid.status();
        const Obstacle3d& obstacle = grid.obstacles()[static_cast<size_t>(nearest_of[k])];
        EXPECT_NEAR(obstacle.position_m.z(), depths_m[k], 0.5) << grid_kind_name(kind) << " object at " << depths_m[k] << " m";
        // Its inliers lie within a window (3 sigma_Z + half a 0.2 m cell) of its depth; both objects
        // in one box would run from 14 to 18.5 m.
        EXPECT_LT(obstacle.size_m.z(), 2 * (3 * model.depth_sigma_m(depths_m[k]) + 0.1) + 0.1)
            << grid_kind_name(kind) << " object at " << depths_m[k] << " m";
      }
      EXPECT_NE(nearest_of[0], nearest_of[1]) << grid_kind_name(kind) << ": " << grid.status();
    }
  }
}

TEST(OccupancyGridClusters, AVehicleSideSeenObliquelyStaysOneObstacle) {
  // A car's side along the road, x = 2.5 m, z from 10 to 14.5 m, 0.3-1.4 m high: its range changes
  // by 0.6 m from one 0.01 rad bearing to the next, less than a window (3 sigma_Z + a cell, 0.9 m at
  // 12 m), so the depth-jump split must not cut it: one obstacle spanning it.
  const StereoErrorModel model = testing::error_model();
  ASSERT_LT(0.6, 3 * model.depth_sigma_m(12.0) + 0.2);
  std::mt19937 generator(13);
  std::normal_distribution<double> disparity_error(0.0, model.disparity_sigma_px);
  OccupancyGrid grid(grid_parameters(GridKind::polar));
  for (int frame = 0; frame < 3; ++frame) {
    std::vector<ObstaclePoint> points;
    for (double z = 10.0; z <= 14.5; z += 0.02) {
      for (double height = 0.3; height <= 1.4; height += 0.03) {
        const double disparity = kFocalPx * kBaselineM / z + disparity_error(generator);
        const double scale = kFocalPx * kBaselineM / disparity / z;
        points.push_back(point_at(2.5 * scale, testing::kCameraHeightM - (testing::kCameraHeightM - height) * scale, z * scale));
      }
    }
    grid.update(points, EgoMotion{});
  }
  ASSERT_EQ(grid.obstacles().size(), 1u) << grid.status();
  EXPECT_NEAR(grid.obstacles()[0].position_m.z(), 12.25, 0.5);
  EXPECT_GT(grid.obstacles()[0].size_m.z(), 3.5);
}

TEST(OccupancyGridClusters, ADepthStepNearerThanTheMinimumGapStaysOneObstacle) {
  // One body at 5 m like a car's front: a bumper face (x in [-0.3, 0.3], 0.2-0.8 m) at 5.0 m, a
  // windscreen face (0.8-1.5 m) at 5.6 m, and a sparser hood at 0.8 m between them, so the cells
  // holding points are one group whose columns have two density modes 0.6 m apart. The window at
  // 5.6 m is 3 sigma_Z + a cell = 0.36 m: the window alone splits the body; min_depth_gap_m = 1 m
  // keeps it one obstacle spanning both faces, and with min_depth_gap_m = 0 it is two.
  const StereoErrorModel model = testing::error_model();
  ASSERT_LT(3 * model.depth_sigma_m(5.6) + 0.2, 0.6);
  for (double gap_m : {1.0, 0.0}) {
    OccupancyGridParameters parameters = grid_parameters(GridKind::polar);
    parameters.min_depth_gap_m = gap_m;
    OccupancyGrid grid(parameters);
    std::vector<ObstaclePoint> points;
    add_patch(points, -0.3, 0.3, 0.2, 0.8, 5.0, 0.01);
    add_patch(points, -0.3, 0.3, 0.8, 1.5, 5.6, 0.01);
    for (double z = 5.05; z < 5.6; z += 0.05) {
      for (double x = -0.3; x <= 0.3; x += 0.03) points.push_back(point_at(x, 0.8, z));
    }
    for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
    ASSERT_EQ(grid.obstacles().size(), gap_m > 0 ? 1u : 2u) << "min_depth_gap_m " << gap_m << ": " << grid.status();
    if (gap_m > 0) {
      EXPECT_NEAR(grid.obstacles()[0].size_m.z(), 0.6, 0.01);
    }
  }
}

TEST(OccupancyGridColumnGaps, PointsSplitWhereEnoughImageColumnsHoldNone) {
  // Columns 10-12, 16-17 and 30, in a shuffled order: 3 empty columns (13-15) then 12 (18-29).
  std::vector<ObstaclePoint> points;
  for (int u : {16, 10, 30, 12, 11, 17, 10}) {
    ObstaclePoint point = point_at(0.0, 1.0, 10.0);
    point.u_px = static_cast<uint16_t>(u);
    points.push_back(point);
  }
  const std::vector<int> all = {0, 1, 2, 3, 4, 5, 6};
  ArmWork work;
  const std::vector<std::vector<int>> three = split_at_column_gaps(points, all, 3, &work);
  ASSERT_EQ(three.size(), 3u);
  EXPECT_EQ(three[0], (std::vector<int>{1, 3, 4, 6}));  // u 10, 12, 11, 10: increasing u, input order kept
  EXPECT_EQ(three[1], (std::vector<int>{0, 5}));        // u 16, 17
  EXPECT_EQ(three[2], (std::vector<int>{2}));           // u 30
  // 4 ops per point and 2 per column from u 10 to 30 (21 columns).
  EXPECT_EQ(work.scalar_ops, 4u * 7 + 2u * 21);
  EXPECT_EQ(work.memory_bytes, 2u * 7 + 5u * 21);
  // A gap must hold at least min_column_gap_px empty columns: 4 keeps 10-17 together.
  const std::vector<std::vector<int>> two = split_at_column_gaps(points, all, 4);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].size(), 6u);
  EXPECT_EQ(two[1], (std::vector<int>{2}));
  // 0: off.
  ASSERT_EQ(split_at_column_gaps(points, all, 0).size(), 1u);
  EXPECT_EQ(split_at_column_gaps(points, all, 0)[0], all);
}

TEST(OccupancyGridColumnGaps, TwoObjectsAtOneDepthWithAColumnGapAreTwoObstacles) {
  // A car's rear over image columns 250-316 (x in [-2.09, -0.10] m, 0.2-1.4 m) and a pedestrian over
  // 321-336 (x in [0.05, 0.50] m, 0.2-1.7 m), both at 15 m: columns 317-320 hold no point. Column
  // 316 is at bearing atan(-3.5 / 500) = -0.007 rad (polar column 59), 321 at +0.003 rad (column
  // 60): neighbouring cells of one row, so the cells holding points are one group with one density
  // mode per column in the same row, one object; only the empty image columns tell them apart.
  // With the split off (min_column_gap_px = 0) one obstacle holds both.
  for (int gap_px : {3, 0}) {
    OccupancyGridParameters parameters = grid_parameters(GridKind::polar);
    parameters.min_column_gap_px = gap_px;
    OccupancyGrid grid(parameters);
    std::vector<ObstaclePoint> points;
    testing::add_pixel_columns(points, 250, 316, 0.2, 1.4, 15.0);
    testing::add_pixel_columns(points, 321, 336, 0.2, 1.7, 15.0);
    for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
    if (gap_px == 0) {
      ASSERT_EQ(grid.obstacles().size(), 1u) << grid.status();
      continue;
    }
    ASSERT_EQ(grid.obstacles().size(), 2u) << grid.status();
    // Centres from the columns: x = (u - u0) z / f at the middle column of each.
    const double pixel_m = 15.0 / kFocalPx;
    const double car_x_m = ((250 + 316) / 2.0 - testing::kPrincipalUPx) * pixel_m;
    const double pedestrian_x_m = ((321 + 336) / 2.0 - testing::kPrincipalUPx) * pixel_m;
    const Obstacle3d& car = grid.obstacles()[0].position_m.x() < grid.obstacles()[1].position_m.x() ? grid.obstacles()[0] : grid.obstacles()[1];
    const Obstacle3d& pedestrian = &car == &grid.obstacles()[0] ? grid.obstacles()[1] : grid.obstacles()[0];
    EXPECT_NEAR(car.position_m.x(), car_x_m, 0.05);
    EXPECT_NEAR(car.size_m.x(), 66 * pixel_m, 0.05);
    EXPECT_NEAR(pedestrian.position_m.x(), pedestrian_x_m, 0.05);
    EXPECT_NEAR(pedestrian.size_m.x(), 15 * pixel_m, 0.05);
    EXPECT_NEAR(pedestrian.max_height_m, 1.7, 0.05);
    EXPECT_EQ(grid.clusters().size(), 1u);  // one cluster of cells, two obstacles
  }
}

TEST(OccupancyGridColumnGaps, AWideObjectWithTwoEmptyColumnsStaysOneObstacle) {
  // A car's rear 2 m wide at 10 m (columns 270-370, 0.2-1.4 m) whose columns 318-319 lost their
  // points (two columns, fewer than the 3 of a gap): one obstacle spanning all of it, in every grid.
  for (GridKind kind : {GridKind::polar, GridKind::cartesian, GridKind::column_disparity}) {
    OccupancyGrid grid(grid_parameters(kind));
    std::vector<ObstaclePoint> points;
    testing::add_pixel_columns(points, 270, 317, 0.2, 1.4, 10.0);
    testing::add_pixel_columns(points, 320, 370, 0.2, 1.4, 10.0);
    for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
    ASSERT_EQ(grid.obstacles().size(), 1u) << grid_kind_name(kind) << ": " << grid.status();
    EXPECT_NEAR(grid.obstacles()[0].size_m.x(), 100 * 10.0 / kFocalPx, 0.05) << grid_kind_name(kind);
  }
}

// Points at image column u and range (z, x = 0 aside from u) for the range-peak split: `count` per
// column (u_px set directly; the split reads u_px and the camera x, z).
void add_column_at_range(std::vector<ObstaclePoint>& points, int u, double range_m, int count) {
  for (int k = 0; k < count; ++k) {
    ObstaclePoint point = point_at(0.0, 0.5 + 0.01 * k, range_m);
    point.u_px = static_cast<uint16_t>(u);
    points.push_back(point);
  }
}

TEST(OccupancyGridObstacleBox, AFewMismatchesAlongTheRayDoNotStretchTheBox) {
  // A board 2 m wide at 11.7 m (0.9-1.6 m, every 1 cm: 14271 points) and 22 points of it 2 m further
  // along their rays (floating seed 2 frame 58 in bench/obstacles3d_eval: 22 of 3754 points at
  // 13.5-14.2 m put the polar obstacle's centre 1 m behind the board, outside its gate). The box
  // leaves out 1 % of the points at each end of x and z: its depth stays the board's.
  std::vector<ObstaclePoint> points;
  testing::add_patch(points, -3.7, -1.7, 0.9, 1.6, 11.7);
  for (int k = 0; k < 22; ++k) points.push_back(testing::point_at(-3.0 + 0.01 * k, 1.2, 13.7 + 0.02 * k));
  std::vector<int> all(points.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  ArmWork work;
  const Obstacle3d board = obstacle_from_points(points, all, 7, &work);
  EXPECT_EQ(board.id, 7);
  EXPECT_EQ(work.scalar_ops, 16u * points.size());  // x and z copied, two selections each
  EXPECT_EQ(work.memory_bytes, 8u * points.size());
  EXPECT_NEAR(board.position_m.z(), 11.7, 1e-4);
  EXPECT_NEAR(board.size_m.z(), 0.0, 1e-4);
  EXPECT_NEAR(board.position_m.x(), -2.7, 0.03);
  EXPECT_NEAR(board.size_m.x(), 2.0, 0.05);
  // The vertical extent, the heights and the pixel box keep every point.
  EXPECT_NEAR(board.size_m.y(), 0.7, 1e-4);
  EXPECT_NEAR(board.min_height_m, 0.9, 1e-4);
  EXPECT_NEAR(board.max_height_m, 1.6, 1e-4);
  // Under 100 points nothing is left out: 20 points at 11.7 m and one at 13.7 m span both.
  std::vector<ObstaclePoint> few;
  testing::add_patch(few, 0.0, 0.19, 1.0, 1.0, 11.7);
  few.push_back(testing::point_at(0.1, 1.0, 13.7));
  std::vector<int> all_few(few.size());
  for (size_t i = 0; i < all_few.size(); ++i) all_few[i] = static_cast<int>(i);
  ASSERT_LT(few.size(), 100u);
  ArmWork few_work;
  const Obstacle3d small = obstacle_from_points(few, all_few, 0, &few_work);
  EXPECT_EQ(few_work.scalar_ops, 0u);
  EXPECT_NEAR(small.size_m.z(), 2.0, 1e-4);
  EXPECT_NEAR(small.position_m.z(), 12.7, 1e-4);
}

TEST(OccupancyGridRangePeaks, AFarEndOccludedByANearerObjectIsCutAtThePeak) {
  // Columns 100-120 recede from 12 to 16 m (a car's side), 121-130 at 14 m (a pedestrian): the
  // profile peaks at column 120 and falls 4 m to the left and 2 m to the right; the threshold at
  // 16 m is max(3 sigma_Z(16) + 0.2, 1) = 1.48 m (sigma_Z = 16^2 0.25 / 150 = 0.427 m).
  const StereoErrorModel model = testing::error_model();
  const double threshold_m = std::max(3 * model.depth_sigma_m(16.0) + 0.2, 1.0);
  ASSERT_NEAR(threshold_m, 1.48, 0.01);
  std::vector<ObstaclePoint> points;
  for (int u = 100; u <= 120; ++u) add_column_at_range(points, u, 12.0 + 0.2 * (u - 100), 5);
  for (int u = 121; u <= 130; ++u) add_column_at_range(points, u, 14.0, 5);
  std::vector<int> all(points.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  ArmWork work;
  const std::vector<std::vector<int>> parts = split_at_range_peak(points, all, model, 3.0, 0.2, 1.0, &work);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].size(), 21u * 5);  // columns 100-120: the peak goes with the receding side it ends
  EXPECT_EQ(parts[1].size(), 10u * 5);
  for (int index : parts[1]) EXPECT_GE(points[static_cast<size_t>(index)].u_px, 121);
  EXPECT_EQ(work.scalar_ops, 6u * points.size() + 12u * 31);
  EXPECT_EQ(work.memory_bytes, 8u * points.size() + 24u * 31);
  // The same with the pedestrian at 14.6 m: a fall of 1.4 m, under the threshold, one part.
  std::vector<ObstaclePoint> nearer_fall;
  for (int u = 100; u <= 120; ++u) add_column_at_range(nearer_fall, u, 12.0 + 0.2 * (u - 100), 5);
  for (int u = 121; u <= 130; ++u) add_column_at_range(nearer_fall, u, 14.6, 5);
  std::vector<int> all_nearer(nearer_fall.size());
  for (size_t i = 0; i < all_nearer.size(); ++i) all_nearer[i] = static_cast<int>(i);
  EXPECT_EQ(split_at_range_peak(nearer_fall, all_nearer, model, 3.0, 0.2, 1.0).size(), 1u);
}

TEST(OccupancyGridRangePeaks, AConvexObjectsProfileIsNotCut) {
  // A car seen at its corner: the rear falls from 13 to 12 m, the side rises from 12 to 17 m (a
  // V, the nearest point inside); columns with fewer than 3 points do not count (a stray 2-point
  // column at 20 m in the rear is no peak).
  std::vector<ObstaclePoint> points;
  for (int u = 100; u <= 110; ++u) add_column_at_range(points, u, 13.0 - 0.1 * (u - 100), 6);
  for (int u = 111; u <= 135; ++u) add_column_at_range(points, u, 12.0 + 0.2 * (u - 110), 6);
  std::vector<ObstaclePoint> stray;
  add_column_at_range(stray, 140, 20.0, 2);
  add_column_at_range(stray, 141, 16.0, 6);
  points.insert(points.end(), stray.begin(), stray.end());
  std::vector<int> all(points.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const std::vector<std::vector<int>> parts = split_at_range_peak(points, all, testing::error_model(), 3.0, 0.2, 1.0);
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0], all);
}

std::vector<int> all_indices(const std::vector<ObstaclePoint>& points) {
  std::vector<int> all(points.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return all;
}

// A pedestrian alone: a vertical cylinder of radius 0.25 m centred at (x 0.5, z 12.25), 0.2-1.7 m,
// its near half seen over the columns its outline covers (each column's depth where the ray meets the
// circle first): a profile bulging towards the camera.
void add_pedestrian_cylinder(std::vector<ObstaclePoint>& points) {
  const double xc = 0.5, zc = 12.25, radius = 0.25;
  for (int u = 0; u < 640; ++u) {
    const double a = (u - testing::kPrincipalUPx) / kFocalPx;  // the ray (a t, t)
    const double qa = a * a + 1, qb = a * xc + zc, qc = xc * xc + zc * zc - radius * radius;
    const double discriminant = qb * qb - qa * qc;
    if (discriminant <= 0) continue;
    testing::add_pixel_column(points, u, 0.2, 1.7, (qb - std::sqrt(discriminant)) / qa);
  }
}

// The single objects that must stay one: a car's side alone (x = -3 m, 8.9-14.9 m), a car at its
// corner (rear and side), a wide box (2.5 m at 10 m) and a pedestrian alone (a cylinder).
std::vector<std::pair<std::string, std::vector<ObstaclePoint>>> single_objects() {
  std::vector<std::pair<std::string, std::vector<ObstaclePoint>>> objects(4);
  objects[0].first = "car side";
  testing::add_side_columns(objects[0].second, 150, 219, -3.0, 0.2, 1.5);
  objects[1].first = "car at its corner";
  testing::add_car_side_and_pedestrian(objects[1].second, true, false);
  objects[2].first = "wide box";
  testing::add_pixel_columns(objects[2].second, 257, 382, 0.2, 1.2, 10.0);
  objects[3].first = "pedestrian";
  add_pedestrian_cylinder(objects[3].second);
  return objects;
}

TEST(OccupancyGridConcavity, APedestrianTouchingACarSidesFarEndIsCutWhereTheOldCutsAreNot) {
  // synthetic_points.h, add_car_side_and_pedestrian. Disparity (f B / z, f B = 150 px m): the rear
  // 13.04 px, the side falling linearly in u to 10.05 px at column 219 (a plane's disparity is affine
  // in u), the pedestrian 10.0 px. The concave envelope runs from the car's corner (189, 13.04) to
  // the pedestrian's last column (236, 10.0); at column 219 it is at 13.04 - 3.04 x 30 / 47 = 11.10 px,
  // 1.05 px above the profile, and 14.93 - 150 / 11.10 = 1.42 m nearer along the ray: both beyond the
  // thresholds (0.5 px, 1 m). Column 219 goes with the pedestrian (its neighbour 220 is 0.05 px away,
  // 218 0.10 px).
  const StereoErrorModel model = testing::error_model();
  std::vector<ObstaclePoint> points;
  testing::add_car_side_and_pedestrian(points);
  const std::vector<int> all = all_indices(points);
  // The old cuts: no empty column, no range peak (the range rises along the side to 15.23 m and stays
  // at the pedestrian's 15.2-15.3 m).
  EXPECT_EQ(split_at_column_gaps(points, all, 3).size(), 1u);
  EXPECT_EQ(split_at_range_peak(points, all, model, 3.0, 0.2, 1.0).size(), 1u);
  ArmWork work;
  const std::vector<std::vector<int>> parts = split_at_concavity(points, all, model, 0.5, 1.0, &work);
  ASSERT_EQ(parts.size(), 2u);
  size_t pedestrian_side = 0;
  for (const ObstaclePoint& point : points) pedestrian_side += point.u_px >= 219 ? 1 : 0;
  EXPECT_EQ(parts[1].size(), pedestrian_side);
  for (int index : parts[0]) EXPECT_LE(points[static_cast<size_t>(index)].u_px, 218);
  for (int index : parts[1]) EXPECT_GE(points[static_cast<size_t>(index)].u_px, 219);
  // 6 ops and 8 bytes per point, 20 and 20 per column from 111 to 236 (126).
  EXPECT_EQ(work.scalar_ops, 6u * points.size() + 20u * 126);
  EXPECT_EQ(work.memory_bytes, 8u * points.size() + 20u * 126);
  // Either threshold above the concavity keeps it one part; 0 px is off.
  EXPECT_EQ(split_at_concavity(points, all, model, 1.2, 1.0).size(), 1u);
  EXPECT_EQ(split_at_concavity(points, all, model, 0.5, 1.5).size(), 1u);
  EXPECT_EQ(split_at_concavity(points, all, model, 0.0, 1.0).size(), 1u);
  // split_object with the defaults applies it after the other two cuts.
  EXPECT_EQ(split_object(points, all, grid_parameters(GridKind::polar)).size(), 2u);
}

TEST(OccupancyGridConcavity, SingleConvexObjectsAreNotCut) {
  // Each one's disparity profile is concave (a plane's is linear in u; the car's corner, the box and
  // the cylinder's near half bulge towards the camera): no column under the envelope.
  for (const auto& [name, points] : single_objects()) {
    ASSERT_GT(points.size(), 500u) << name;
    const std::vector<int> all = all_indices(points);
    EXPECT_EQ(split_at_concavity(points, all, testing::error_model(), 0.5, 1.0).size(), 1u) << name;
    EXPECT_EQ(split_object(points, all, grid_parameters(GridKind::polar)).size(), 1u) << name;
  }
}

TEST(OccupancyGridConcavity, ATerracedProfileFromFewPointsPerColumnIsNotCut) {
  // A surface seen at a grazing angle as the matcher leaves it: five fronto-parallel terraces of 12
  // columns (u 100-159) at 12, 11, 10, 9 and 8 px. The envelope runs through each terrace's last
  // column, so the first column of the next lies 1 - 1 / 12 = 0.92 px under it (1.26-1.9 m along
  // the ray): a concavity at every step. With 12 points per column (a standing object's columns
  // hold dozens) it is cut; with 6 (a low berm's at 15-30 m) the columns give no median for the
  // concavity split (it needs 10 points a column) and it is not.
  for (int per_column : {12, 6}) {
    std::vector<ObstaclePoint> points;
    for (int u = 100; u < 160; ++u) add_column_at_range(points, u, kFocalPx * kBaselineM / (12.0 - (u - 100) / 12), per_column);
    const std::vector<int> all = all_indices(points);
    EXPECT_EQ(split_at_concavity(points, all, testing::error_model(), 0.5, 1.0).size(), per_column >= 10 ? 2u : 1u)
        << per_column << " points per column";
  }
}

// A parked car's far end beside a nearer pedestrian, as the column-gap split leaves it (urban seed 2
// frame 21 in bench/obstacles3d_eval: the rest of the car cut off at an empty column): three columns
// of the car at 15.2, 15.0 and 14.8 m (198-200), two columns the matcher mixed (201-202, a third and
// two thirds of the way), and the pedestrian (0.2-1.7 m) at `pedestrian_m` over 203-218. The
// disparity profile rises and then stays flat (concave), and the range falls: no peak.
void add_far_end_and_pedestrian(std::vector<ObstaclePoint>& points, double pedestrian_m = 12.7) {
  const double car_m[3] = {15.2, 15.0, 14.8};
  for (int k = 0; k < 3; ++k) testing::add_pixel_column(points, 198 + k, 0.2, 1.5, car_m[k]);
  testing::add_pixel_column(points, 201, 0.2, 1.5, 14.8 + (pedestrian_m - 14.8) / 3);
  testing::add_pixel_column(points, 202, 0.2, 1.5, 14.8 + 2 * (pedestrian_m - 14.8) / 3);
  for (int u = 203; u <= 218; ++u) testing::add_pixel_column(points, u, 0.2, 1.7, pedestrian_m);
}

TEST(OccupancyGridRangeSteps, AFarSurfacesEndBesideANearerObjectIsCutAtTheStep) {
  // Disparity (f B / z, f B = 150 px m): the car's third column (200, 14.8 m) is 10.14 px, the
  // pedestrian's first (203) 11.81 px: 1.68 px (beyond 5 x 0.25 px) and 2.1 m nearer (beyond
  // max(3 sigma_Z(14.8) + 0.2, 1) = 1.30 m) within 3 columns; the car's first two columns cannot be a
  // step's end (3 measured columns on each side). The mixed columns are 10.64 and 11.19 px; the
  // largest change between consecutive columns inside the step is 202 -> 203 (0.62 px), so the cut
  // is after 202.
  const StereoErrorModel model = testing::error_model();
  std::vector<ObstaclePoint> points;
  add_far_end_and_pedestrian(points);
  const std::vector<int> all = all_indices(points);
  // The other cuts leave it whole: no empty column, no range peak, no concavity.
  EXPECT_EQ(split_at_column_gaps(points, all, 3).size(), 1u);
  EXPECT_EQ(split_at_range_peak(points, all, model, 3.0, 0.2, 1.0).size(), 1u);
  EXPECT_EQ(split_at_concavity(points, all, model, 0.5, 1.0).size(), 1u);
  ArmWork work;
  const std::vector<std::vector<int>> parts = split_at_range_step(points, all, model, 3.0, 0.2, 1.0, 4, &work);
  ASSERT_EQ(parts.size(), 2u);
  size_t car_side = 0;
  for (const ObstaclePoint& point : points) car_side += point.u_px <= 202 ? 1 : 0;
  EXPECT_EQ(parts[0].size(), car_side);
  for (int index : parts[0]) EXPECT_LE(points[static_cast<size_t>(index)].u_px, 202);
  for (int index : parts[1]) EXPECT_GE(points[static_cast<size_t>(index)].u_px, 203);
  // 6 ops and 8 bytes per point, 8 and 12 per column from 198 to 218 (21).
  EXPECT_EQ(work.scalar_ops, 6u * points.size() + 8u * 21);
  EXPECT_EQ(work.memory_bytes, 8u * points.size() + 12u * 21);
  // Within 2 columns no pair is both 1.25 px and a window apart (200 -> 202: 1.06 px; 201 -> 203:
  // 1.17 px); within 3 the step is found. Off at 0.
  EXPECT_EQ(split_at_range_step(points, all, model, 3.0, 0.2, 1.0, 3).size(), 2u);
  EXPECT_EQ(split_at_range_step(points, all, model, 3.0, 0.2, 1.0, 2).size(), 1u);
  EXPECT_EQ(split_at_range_step(points, all, model, 3.0, 0.2, 1.0, 0).size(), 1u);
  // A larger depth threshold (min_depth_gap_m 2.5 m) keeps it one part.
  EXPECT_EQ(split_at_range_step(points, all, model, 3.0, 0.2, 2.5, 4).size(), 1u);
  // split_object with the defaults applies it; with max_range_step_columns_px = 0 it is one part.
  OccupancyGridParameters parameters = grid_parameters(GridKind::polar);
  EXPECT_EQ(split_object(points, all, parameters).size(), 2u);
  parameters.max_range_step_columns_px = 0;
  EXPECT_EQ(split_object(points, all, parameters).size(), 1u);
}

TEST(OccupancyGridRangeSteps, StepsUnderTheThresholdsAndBorderColumnsAreNotCut) {
  const StereoErrorModel model = testing::error_model();
  // The pedestrian at 14.0 m: 0.8 m nearer than the car's end, under 1.30 m.
  std::vector<ObstaclePoint> near_step;
  add_far_end_and_pedestrian(near_step, 14.0);
  EXPECT_EQ(split_at_range_step(near_step, all_indices(near_step), model, 3.0, 0.2, 1.0, 4).size(), 1u);
  // SGM's terraces on a surface seen at a grazing angle (12, 11, 10, 9, 8 px, 12 columns each, 12
  // points a column): each 1 px step is 1.1-2.1 m of depth, beyond the window at 9-10 px, but not
  // beyond 5 disparity sigmas (1.25 px).
  std::vector<ObstaclePoint> terraces;
  for (int u = 100; u < 160; ++u) add_column_at_range(terraces, u, kFocalPx * kBaselineM / (12.0 - (u - 100) / 12), 12);
  EXPECT_EQ(split_at_range_step(terraces, all_indices(terraces), model, 3.0, 0.2, 1.0, 4).size(), 1u);
  // A car's rear at 11.5 m whose two border columns took the background's 16 m: fewer than 3
  // measured columns on that side, no cut.
  std::vector<ObstaclePoint> border;
  testing::add_pixel_column(border, 109, 0.2, 1.5, 16.0);
  testing::add_pixel_column(border, 110, 0.2, 1.5, 16.0);
  for (int u = 111; u <= 189; ++u) testing::add_pixel_column(border, u, 0.2, 1.5, 11.5);
  EXPECT_EQ(split_at_range_step(border, all_indices(border), model, 3.0, 0.2, 1.0, 4).size(), 1u);
  // With a third such column the far side is a surface of its own.
  testing::add_pixel_column(border, 108, 0.2, 1.5, 16.0);
  EXPECT_EQ(split_at_range_step(border, all_indices(border), model, 3.0, 0.2, 1.0, 4).size(), 2u);
  // The single objects, and the pedestrian touching the car side's far end at its depth (the
  // concavity split's case: no step), are not cut.
  for (const auto& [name, points] : single_objects())
    EXPECT_EQ(split_at_range_step(points, all_indices(points), model, 3.0, 0.2, 1.0, 4).size(), 1u) << name;
  std::vector<ObstaclePoint> touching;
  testing::add_car_side_and_pedestrian(touching);
  EXPECT_EQ(split_at_range_step(touching, all_indices(touching), model, 3.0, 0.2, 1.0, 4).size(), 1u);
}

TEST(OccupancyGridConcavity, ThePedestrianBesideTheCarSideIsItsOwnObstacleInEveryGrid) {
  // Through the grids' clusters, modes and cuts: with the concavity split one obstacle lies on the
  // pedestrian (its centre within 0.3 m of x -2.75 m, z 15.0 m, the eval's gate is 1.25 m); with it off
  // (min_concavity_px = 0) the polar grid's one obstacle holds the car and the pedestrian, 2.29 m
  // wide (x from -4.80 to -2.51 m; 2.24 m for the box, which leaves out 1 % of the points at each
  // end) and 3.5 m long, its centre 0.9 m left of the pedestrian and 1.75 m nearer (outside the
  // eval's gate, 1.375 m deep at 15 m).
  for (GridKind kind : {GridKind::polar, GridKind::cartesian, GridKind::column_disparity}) {
    for (double concavity_px : {0.5, 0.0}) {
      OccupancyGridParameters parameters = grid_parameters(kind);
      parameters.min_concavity_px = concavity_px;
      OccupancyGrid grid(parameters);
      std::vector<ObstaclePoint> points;
      testing::add_car_side_and_pedestrian(points);
      for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
      bool on_pedestrian = false;
      for (const Obstacle3d& obstacle : grid.obstacles())
        on_pedestrian = on_pedestrian || (std::abs(obstacle.position_m.x() + 2.75) < 0.3 && std::abs(obstacle.position_m.z() - 15.0) < 0.3);
      if (concavity_px > 0) {
        EXPECT_TRUE(on_pedestrian) << grid_kind_name(kind) << ": " << grid.status();
      } else if (kind == GridKind::polar) {
        EXPECT_FALSE(on_pedestrian) << grid.status();
        ASSERT_EQ(grid.obstacles().size(), 1u) << grid.status();
        EXPECT_NEAR(grid.obstacles()[0].size_m.x(), 2.24, 0.05);
        EXPECT_NEAR(grid.obstacles()[0].position_m.z(), 13.25, 0.1);
      }
    }
  }
}

TEST(OccupancyGridConcavity, SingleObjectsStayOneObstacleInEveryGrid) {
  for (GridKind kind : {GridKind::polar, GridKind::cartesian, GridKind::column_disparity}) {
    for (const auto& [name, points] : single_objects()) {
      OccupancyGrid grid(grid_parameters(kind));
      for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
      EXPECT_EQ(grid.obstacles().size(), 1u) << grid_kind_name(kind) << ", " << name << ": " << grid.status();
    }
  }
}

TEST(OccupancyGridGeometry, RowSigmaIsTheMeasurementsRowSigma) {
  // row_sigma_at (the depth-jump split's window) equals the row sigma of a point at the cell centre
  // (measurement_gaussian), for each kind.
  for (GridKind kind : {GridKind::cartesian, GridKind::polar, GridKind::column_disparity}) {
    OccupancyGrid grid(grid_parameters(kind));
    const OccupancyGridParameters& p = grid.parameters();
    for (const auto& [row, column] : {std::pair{20, 40}, std::pair{100, 70}, std::pair{150, 10}}) {
      const Eigen::Vector2d xz = grid.camera_xz_of(p.column_min + (column + 0.5) * p.column_cell, p.row_min + (row + 0.5) * p.row_cell);
      const GridGaussian gaussian = grid.measurement_gaussian(point_at(xz.x(), 0.5, xz.y()));
      EXPECT_NEAR(grid.row_sigma_at(row, column), std::sqrt(gaussian.covariance(1, 1)), 1e-3 * std::sqrt(gaussian.covariance(1, 1)))
          << grid_kind_name(kind) << " row " << row << " column " << column;
    }
  }
}

TEST(OccupancyGridClusters, PointsSmearedAlongTheirRaysBehindAnObjectDoNotStretchItsObstacle) {
  // A board 2 m wide (0.2-1.5 m high) at 12 m with a 5 cm pole at each end; stereo hands each pole
  // some of the background's disparity, so 25 points per pole and frame lie on the pole's rays
  // 0.1-4 m behind it (a continuous smear: their cells join the board's). sigma_Z(12 m) = 0.24 m, so
  // most of the smear lies beyond 3 sigma_Z of the board's depth. The obstacle holding the board
  // must be centred on it (polar: within 0.5 m in depth, inside the eval's 1 m gate) and less than
  // 1 m deep; the box of all points runs from 12 to 16 m, centred at 14 m.
  const StereoErrorModel model = testing::error_model();
  ASSERT_LT(3 * model.depth_sigma_m(12.0), 0.8);
  // Polar and column/disparity columns are rays (constant bearing, constant u), so the smear stays in
  // the pole's columns; a 0.5 px disparity cell is 0.48 m deep at 12 m, so the column/disparity
  // window (3 sigma_d + half a cell = 1 px) keeps 1 m of it. (A Cartesian column is not a ray: the
  // smear crosses into columns of its own and stays; not asserted.)
  struct Case {
    GridKind kind;
    double centre_tolerance_m, max_depth_m, width_tolerance_m;
  };
  for (const Case& test : {Case{GridKind::polar, 0.5, 1.0, 0.1}, Case{GridKind::column_disparity, 0.7, 1.3, 0.2}}) {
    const GridKind kind = test.kind;
    OccupancyGrid grid(grid_parameters(kind));
    std::vector<ObstaclePoint> points;
    add_patch(points, -1.0, 1.0, 0.2, 1.5, 12.0, 0.02);
    for (double pole_x : {-1.0, 0.95}) {
      for (int i = 0; i < 25; ++i) {
        const double x = pole_x + 0.05 * (i % 3) / 2, height = 0.2 + 1.3 * i / 24;
        const double scale = (12.1 + 3.9 * i / 24) / 12.0;  // along the ray through (x, height, 12 m)
        points.push_back(point_at(x * scale, testing::kCameraHeightM - (testing::kCameraHeightM - height) * scale, 12.0 * scale));
      }
    }
    for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
    const Obstacle3d* board = nullptr;
    for (const Obstacle3d& obstacle : grid.obstacles())
      if (board == nullptr || std::abs(obstacle.position_m.z() - 12.0) < std::abs(board->position_m.z() - 12.0)) board = &obstacle;
    ASSERT_NE(board, nullptr) << grid_kind_name(kind) << ": " << grid.status();
    EXPECT_NEAR(board->position_m.z(), 12.0, test.centre_tolerance_m) << grid_kind_name(kind) << ": " << grid.status();
    EXPECT_LT(board->size_m.z(), test.max_depth_m) << grid_kind_name(kind);
    EXPECT_NEAR(board->position_m.x(), 0.0, test.width_tolerance_m) << grid_kind_name(kind);
    EXPECT_NEAR(board->size_m.x(), 2.0, test.width_tolerance_m) << grid_kind_name(kind);
  }
}

TEST(OccupancyGridBadInput, PointsBeyondTheBoundsAreClippedAndCounted) {
  OccupancyGrid grid(grid_parameters(GridKind::cartesian));
  std::vector<ObstaclePoint> points = {point_at(0.0, 0.5, 10.0), point_at(0.0, 0.5, 100.0), point_at(50.0, 0.5, 20.0),
                                       point_at(-12.0, 0.5, 5.0)};
  ObstaclePoint not_finite = point_at(0.0, 0.5, 10.0);
  not_finite.camera_m.x() = std::numeric_limits<float>::quiet_NaN();
  ObstaclePoint no_disparity = point_at(0.0, 0.5, 10.0);
  no_disparity.disparity_px = 0;
  points.push_back(not_finite);
  points.push_back(no_disparity);
  grid.update(points, EgoMotion{});
  EXPECT_EQ(grid.statistics().points_in, 6);
  EXPECT_EQ(grid.statistics().points_used, 1);
  EXPECT_EQ(grid.statistics().points_clipped, 3);
  EXPECT_EQ(grid.statistics().points_rejected, 2);
  EXPECT_NE(grid.status().find("3 beyond the grid bounds (clipped)"), std::string::npos) << grid.status();
  EXPECT_NE(grid.status().find("2 rejected"), std::string::npos) << grid.status();
  EXPECT_EQ(grid.point_cells()[1], -1);
}

TEST(OccupancyGridBadInput, EmptyCloudAndNoEgoMotionAreReported) {
  OccupancyGrid grid(grid_parameters(GridKind::polar));
  grid.update({}, EgoMotion{});
  EXPECT_NE(grid.status().find("empty cloud"), std::string::npos) << grid.status();
  EXPECT_NE(grid.status().find("static camera assumed (no ego-motion)"), std::string::npos) << grid.status();
  EXPECT_TRUE(grid.obstacles().empty());
  EXPECT_FALSE(grid.statistics().ego_motion_used);
}

TEST(OccupancyGridBadInput, BadCellSizesAndParametersThrowNamingTheParameter) {
  auto message_of = [](const OccupancyGridParameters& parameters) {
    try {
      OccupancyGrid grid(parameters);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("no exception");
  };
  OccupancyGridParameters parameters = grid_parameters(GridKind::cartesian);
  parameters.row_cell = 0;
  EXPECT_EQ(message_of(parameters), "row_cell: expected > 0 (cell depth), got 0");
  parameters = grid_parameters(GridKind::polar);
  parameters.column_cell = -0.01;
  EXPECT_EQ(message_of(parameters), "column_cell: expected > 0 (cell width), got -0.01");
  parameters = grid_parameters(GridKind::column_disparity);
  parameters.error_model.focal_px = 0;
  EXPECT_EQ(message_of(parameters), "error_model.focal_px: expected > 0, got 0");
  parameters = grid_parameters(GridKind::cartesian);
  parameters.row_max = parameters.row_min;
  EXPECT_NE(message_of(parameters).find("row_max: expected > row_min"), std::string::npos);
  parameters = grid_parameters(GridKind::cartesian);
  parameters.occupied_probability = 0.4;
  EXPECT_EQ(message_of(parameters), "occupied_probability: expected in (0.5, 1), got 0.4");
  parameters = grid_parameters(GridKind::polar);
  parameters.min_depth_gap_m = -0.5;
  EXPECT_EQ(message_of(parameters), "min_depth_gap_m: expected in [0, 10] m, got -0.5");
  parameters = grid_parameters(GridKind::polar);
  parameters.min_column_gap_px = -1;
  EXPECT_EQ(message_of(parameters), "min_column_gap_px: expected in [0, 64] px, got -1");
  parameters = grid_parameters(GridKind::polar);
  parameters.max_range_step_columns_px = 17;
  EXPECT_EQ(message_of(parameters), "max_range_step_columns_px: expected in [0, 16] px (0 = off), got 17");
  parameters = grid_parameters(GridKind::polar);
  parameters.min_concavity_px = -0.5;
  EXPECT_EQ(message_of(parameters), "min_concavity_px: expected in [0, 8] px (0 = off), got -0.5");
}

TEST(OccupancyGridWork, AnEmptyFrameCostsTheHeadersPerCellModel) {
  OccupancyGrid grid(grid_parameters(GridKind::cartesian));
  grid.update({}, EgoMotion{});
  const uint64_t cells = static_cast<uint64_t>(grid.rows()) * static_cast<uint64_t>(grid.columns());
  // update + clustering of the occupied cells + components of the cells holding points, no members
  EXPECT_EQ(grid.work().scalar_ops, (24 + 12 + 12) * cells);
  EXPECT_EQ(grid.work().memory_bytes, (12 + 1 + 1) * cells);
  EgoMotion motion;
  motion.available = true;
  grid.update({}, motion);
  EXPECT_EQ(grid.work().scalar_ops, (20 + 24 + 12 + 12) * cells);  // + resampling
  // A point adds its own terms: more work than an empty frame.
  const uint64_t empty_ops = grid.work().scalar_ops;
  grid.update({point_at(0.0, 0.5, 10.0)}, motion);
  EXPECT_GT(grid.work().scalar_ops, empty_ops + 40);
}

TEST(OccupancyGridThreads, TwoThreadsGiveTheSameGrid) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -2.0, 2.0, 0.0, 1.0, 15.0, 0.005);  // 801 x 201 = 161k points, more than 4096 per thread
  OccupancyGridParameters parameters = grid_parameters(GridKind::polar);
  OccupancyGrid one(parameters);
  parameters.threads = 2;
  OccupancyGrid two(parameters);
  one.update(points, EgoMotion{});
  two.update(points, EgoMotion{});
  EXPECT_LT((one.evidence() - two.evidence()).cwiseAbs().maxCoeff(), 1e-3f * one.evidence().maxCoeff());
  EXPECT_EQ(one.obstacles().size(), two.obstacles().size());
  EXPECT_EQ(one.work().scalar_ops, two.work().scalar_ops);
}

TEST(OccupancyGridThreads, EgoMotionResamplingGivesTheSameGridOnTwoThreads) {
  // Fewer than 4096 points: the evidence is one thread's in both grids, so any difference would be
  // the resampling's, whose rows are dealt over the threads.
  std::vector<ObstaclePoint> points;
  add_patch(points, -1.0, 1.0, 0.0, 0.5, 12.0, 0.02);
  add_patch(points, 3.0, 4.0, 0.0, 1.0, 20.0, 0.05);
  ASSERT_LT(points.size(), 4096u);
  EgoMotion motion;
  motion.available = true;
  motion.previous_from_current = Eigen::Translation3d(0.5, 0.1, 0) * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ());
  for (GridKind kind : {GridKind::polar, GridKind::cartesian, GridKind::column_disparity}) {
    OccupancyGridParameters parameters = grid_parameters(kind);
    OccupancyGrid one(parameters);
    parameters.threads = 2;
    OccupancyGrid two(parameters);
    for (int frame = 0; frame < 4; ++frame) {
      one.update(frame < 2 ? points : std::vector<ObstaclePoint>{}, motion);
      two.update(frame < 2 ? points : std::vector<ObstaclePoint>{}, motion);
    }
    EXPECT_GT(one.log_odds().maxCoeff(), 0.0f) << grid_kind_name(kind);  // the memory moved, not lost
    EXPECT_EQ((one.log_odds() - two.log_odds()).cwiseAbs().maxCoeff(), 0.0f) << grid_kind_name(kind);
  }
}

TEST(OccupancyGridDescription, OccupancyOnlyHasTheSameLogOddsNoClustersAndLessWork) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -1.0, 1.0, 0.0, 1.0, 12.0);
  add_patch(points, 2.0, 2.5, 0.0, 1.5, 20.0);
  OccupancyGrid described(grid_parameters(GridKind::polar));
  OccupancyGrid occupancy(grid_parameters(GridKind::polar));
  for (int frame = 0; frame < 3; ++frame) {
    described.update(points, EgoMotion{});
    occupancy.update(points, EgoMotion{}, GridDescription::occupancy_only);
  }
  ASSERT_EQ(described.obstacles().size(), 2u) << described.status();
  EXPECT_TRUE(occupancy.clusters().empty());
  EXPECT_TRUE(occupancy.obstacles().empty());
  EXPECT_EQ((described.log_odds() - occupancy.log_odds()).cwiseAbs().maxCoeff(), 0.0f);
  EXPECT_EQ(occupancy.point_cells(), described.point_cells());
  EXPECT_LT(occupancy.work().scalar_ops, described.work().scalar_ops);
  EXPECT_NE(occupancy.status().find("occupancy only"), std::string::npos) << occupancy.status();
  EXPECT_EQ(described.status().find("occupancy only"), std::string::npos) << described.status();
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
