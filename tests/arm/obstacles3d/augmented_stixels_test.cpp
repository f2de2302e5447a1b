// Augmented stixels (arm/obstacles3d/augmented_stixels.h): a hanging board (points only 1.0-1.5 m
// above the road) gives stixels whose minimum height is 1.0 m within 10 cm and free space under
// them, while the cartesian and polar grids call the same place occupied (they have no height); a
// board on two poles is one obstacle with its poles' stixels grounded and the board's hanging; a
// sign beside a low box, in neighbouring cells, stays a separate obstacle (height gap); stixels carry their
// points and colours; the trimmed height ignores one stray low point; a sign above a box in the same
// cells is one interval per stixel (the representation's limit); bad parameters throw; the counted
// work adds the header's binning terms to the grid's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/occupancy_grid.h"
#include "tests/arm/obstacles3d/synthetic_points.h"

namespace lpstereo::arm::obstacles3d {
namespace {

using testing::add_patch;
using testing::grid_parameters;
using testing::point_at;

AugmentedStixelParameters stixel_parameters() {
  AugmentedStixelParameters parameters;
  parameters.grid = grid_parameters(GridKind::polar);
  return parameters;
}

bool cell_occupied_at(const OccupancyGrid& grid, double x_m, double z_m) {
  const Eigen::Vector2d coordinates = grid.grid_coordinates_of(x_m, z_m);
  int row = 0, column = 0;
  return grid.cell_of(coordinates(0), coordinates(1), &row, &column) && grid.occupied(row, column);
}

TEST(AugmentedStixels, HangingBoardKeepsTheFreeSpaceUnderItWhereTheGridsSayOccupied) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.5, 0.5, 1.0, 1.5, 8.0);  // a board hanging 1.0-1.5 m above the road, 8 m ahead
  AugmentedStixels stixels(stixel_parameters());
  OccupancyGrid cartesian(grid_parameters(GridKind::cartesian));
  for (int frame = 0; frame < 3; ++frame) {
    stixels.update(points, EgoMotion{});
    cartesian.update(points, EgoMotion{});
  }
  ASSERT_FALSE(stixels.stixels().empty()) << stixels.status();
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    EXPECT_NEAR(stixel.min_height_m, 1.0, 0.1);
    EXPECT_NEAR(stixel.max_height_m, 1.5, 0.1);
    EXPECT_GE(stixel.free_below_m(), 0.9f);
  }
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  EXPECT_NEAR(stixels.obstacles()[0].min_height_m, 1.0, 0.1);
  EXPECT_NEAR(stixels.obstacles()[0].max_height_m, 1.5, 0.1);
  // The 2D grids: the board's cell is occupied, whatever the height (a vehicle 1.2 m tall could pass).
  EXPECT_TRUE(cell_occupied_at(cartesian, 0.1, 8.0));
  EXPECT_TRUE(cell_occupied_at(stixels.grid(), 0.1, 8.0));
}

TEST(AugmentedStixels, BoardOnTwoPolesIsOneObstacleWithGroundedPolesAndAHangingBoard) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.8, 0.8, 1.0, 1.5, 10.0);   // the board
  add_patch(points, -0.8, -0.74, 0.0, 1.0, 10.0);  // left pole (6 cm)
  add_patch(points, 0.74, 0.8, 0.0, 1.0, 10.0);    // right pole
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  EXPECT_NEAR(stixels.obstacles()[0].min_height_m, 0.0, 0.1);
  EXPECT_NEAR(stixels.obstacles()[0].max_height_m, 1.5, 0.1);
  int grounded = 0, hanging = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    const double centre_x = 10.0 * std::tan((stixel.angle_min_rad + stixel.angle_max_rad) / 2);
    if (std::abs(centre_x) < 0.6) {  // between the poles: under the board is free
      EXPECT_NEAR(stixel.min_height_m, 1.0, 0.1) << "x " << centre_x;
      ++hanging;
    }
    if (std::abs(centre_x) > 0.72) {  // the cell holding a pole (x in [0.70, 0.82] at 10 m)
      EXPECT_LT(stixel.min_height_m, 0.1) << "x " << centre_x;
      ++grounded;
    }
    EXPECT_EQ(stixel.cluster, 0);
  }
  EXPECT_GT(hanging, 5);
  EXPECT_GE(grounded, 1);
}

TEST(AugmentedStixels, SignOverALowBoxInTheSameCellsIsOneHeightInterval) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.4, 0.4, 0.0, 0.3, 12.0);   // a low box
  add_patch(points, -0.4, 0.4, 2.0, 2.4, 12.0);   // a sign 1.7 m above it (gap > max_height_gap_m)
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  // Same cells hold both: each stixel spans 0-2.4 m, so they join into one obstacle. The thesis'
  // stixels have one height interval per cell; the sign over the box is one stixel per cell.
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  EXPECT_NEAR(stixels.obstacles()[0].max_height_m, 2.4, 0.1);
}

TEST(AugmentedStixels, NeighbouringStixelsFarApartInHeightAreSeparateObstacles) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.6, -0.02, 0.0, 0.3, 12.0);  // a low box on the left, up to theta's cell [-0.01, 0)
  add_patch(points, 0.04, 0.6, 2.0, 2.4, 12.0);    // a sign on the right from cell [0, 0.01), 1.7 m higher
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 2u) << stixels.status();
  const double low_max = std::min(stixels.obstacles()[0].max_height_m, stixels.obstacles()[1].max_height_m);
  const double high_min = std::max(stixels.obstacles()[0].min_height_m, stixels.obstacles()[1].min_height_m);
  EXPECT_NEAR(low_max, 0.3, 0.1);
  EXPECT_NEAR(high_min, 2.0, 0.1);
}

TEST(AugmentedStixels, StixelsCarryTheirPointsAndColours) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.3, 0.3, 0.0, 1.0, 6.0);
  for (ObstaclePoint& point : points) point.rgb = {200, 100, 50};
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 2; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_FALSE(stixels.stixels().empty());
  size_t carried = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    EXPECT_EQ(stixel.mean_rgb, (std::array<uint8_t, 3>{200, 100, 50}));
    for (int k = 0; k < stixel.point_count; ++k) {
      const ObstaclePoint& point =
          points[static_cast<size_t>(stixels.point_indices()[static_cast<size_t>(stixel.first_point + k)])];
      // Each carried point lies in its stixel's polar cell.
      const double angle = std::atan2(point.camera_m.x(), point.camera_m.z());
      EXPECT_GE(angle, stixel.angle_min_rad - 1e-9);
      EXPECT_LT(angle, stixel.angle_max_rad + 1e-9);
    }
    carried += static_cast<size_t>(stixel.point_count);
  }
  EXPECT_EQ(carried, points.size());  // every point of the patch is in an (occupied) stixel
}

TEST(AugmentedStixels, TrimmedHeightIgnoresAStrayLowPoint) {
  std::vector<ObstaclePoint> points;
  add_patch(points, 0.02, 0.08, 1.0, 1.5, 8.0);  // one angular cell's worth of a hanging sign
  points.push_back(point_at(0.05, 0.0, 8.0));    // one stray point on the road under it
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 2; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_FALSE(stixels.stixels().empty());
  for (const AugmentedStixel& stixel : stixels.stixels()) EXPECT_NEAR(stixel.min_height_m, 1.0, 0.1);
}

TEST(AugmentedStixels, BadParametersThrowNamingTheParameter) {
  auto message_of = [](const AugmentedStixelParameters& parameters) {
    try {
      AugmentedStixels stixels(parameters);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("no exception");
  };
  AugmentedStixelParameters parameters = stixel_parameters();
  parameters.grid.row_cell = -0.2;
  EXPECT_EQ(message_of(parameters), "grid.row_cell: expected > 0 (cell depth), got -0.2");
  parameters = stixel_parameters();
  parameters.grid.kind = GridKind::cartesian;
  EXPECT_EQ(message_of(parameters), "grid.kind: expected polar, got cartesian");
  parameters = stixel_parameters();
  parameters.min_points = 0;
  EXPECT_EQ(message_of(parameters), "min_points: expected >= 1, got 0");
}

TEST(AugmentedStixels, EmptyCloudGivesNoStixelsAndSaysSo) {
  AugmentedStixels stixels(stixel_parameters());
  stixels.update({}, EgoMotion{});
  EXPECT_TRUE(stixels.stixels().empty());
  EXPECT_TRUE(stixels.obstacles().empty());
  EXPECT_NE(stixels.status().find("empty cloud"), std::string::npos) << stixels.status();
  EXPECT_NE(stixels.status().find("0 stixels"), std::string::npos) << stixels.status();
}

TEST(AugmentedStixels, WorkIsTheGridsPlusTheHeadersBinningTerms) {
  AugmentedStixels stixels(stixel_parameters());
  stixels.update({}, EgoMotion{});
  const uint64_t cells = static_cast<uint64_t>(stixels.grid().rows()) * static_cast<uint64_t>(stixels.grid().columns());
  // No points: only the prefix sum over the cells (4 ops + 4 bytes per cell) on top of the grid.
  EXPECT_EQ(stixels.work().scalar_ops, stixels.grid().work().scalar_ops + 4 * cells);
  EXPECT_EQ(stixels.work().memory_bytes, stixels.grid().work().memory_bytes + 4 * cells);
  // One point in a cell (below min_points: no stixel): 8 + 6 ops and 16 bytes more for its binning.
  stixels.update({point_at(0.0, 0.5, 10.0)}, EgoMotion{});
  EXPECT_TRUE(stixels.stixels().empty());
  EXPECT_EQ(stixels.work().scalar_ops, stixels.grid().work().scalar_ops + 4 * cells + 14);
  EXPECT_EQ(stixels.work().memory_bytes, stixels.grid().work().memory_bytes + 4 * cells + 16);
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
