// Augmented stixels (arm/obstacles3d/augmented_stixels.h): a hanging board (points only 1.0-1.5 m
// above the road) gives stixels whose minimum height is 1.0 m within 10 cm and free space under
// them, while the cartesian and polar grids call the same place occupied (they have no height); a
// board on two poles is a hanging board obstacle between two grounded poles (one height interval per
// obstacle); a board's lower edge from fattened, noisy points is within 10 cm; scattered noise
// points give no obstacle; a
// sign beside a low box, in neighbouring cells, stays a separate obstacle (height gap); stixels carry their
// points and colours; the trimmed height ignores one stray low point; a sign above a box in the same
// cells is two stixels per cell (multi-layer); a dense near board's lower edge is its edge, not its
// lowest tenth; a board's top rows cut off by the lower-edge step and a sign's arm past the sign
// join the board and the sign (fragments); sparse stixels (a pole's foot) chained into a board's
// cluster do not pull its lower edge down (point-weighted tercile); a thin post under a ball in the
// same cell is its own stixel (support split), an evenly dense box is not split and the split's
// scan counts 8 ops per point of a stixel cell; bad parameters throw; the counted
// work adds the header's binning terms to the grid's; a car's rear and a pedestrian at one depth in
// neighbouring cells with 4 empty image columns between them are two obstacles (one with the column
// gap split off), and a wide object with 2 empty columns stays one; a part split off a cluster keeps
// only the heights its points reach (a board's top rows beside its pole); a pedestrian touching the far end
// of a car's side (no empty column, no range peak) is its own obstacle with the concavity split and
// not without it, and the car alone stays one; two threads give the one-thread stixels and obstacles
// (the per-cluster steps dealt over the threads).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
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

TEST(AugmentedStixels, BoardOnTwoPolesIsAHangingBoardBetweenTwoGroundedPoles) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.8, 0.8, 1.0, 1.5, 10.0);   // the board
  add_patch(points, -0.8, -0.74, 0.0, 1.0, 10.0);  // left pole (6 cm)
  add_patch(points, 0.74, 0.8, 0.0, 1.0, 10.0);    // right pole
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  // An obstacle has one height interval: the poles' stixels (lower edge 0 m) and the board's (1 m)
  // differ by more than max_lower_edge_step_m, so the board is its own obstacle with its free space.
  ASSERT_EQ(stixels.obstacles().size(), 3u) << stixels.status();
  int boards = 0, poles = 0;
  for (const Obstacle3d& obstacle : stixels.obstacles()) {
    if (std::abs(obstacle.position_m.x()) < 0.2) {
      EXPECT_NEAR(obstacle.min_height_m, 1.0, 0.1);
      EXPECT_NEAR(obstacle.max_height_m, 1.5, 0.1);
      ++boards;
    } else {
      // Grounded: the pole's cell holds 0-1.5 m (pole and board end), its lowest tenth
      // (lower_edge_fraction) lies under 0.25 m.
      EXPECT_LT(obstacle.min_height_m, 0.25);
      ++poles;
    }
  }
  EXPECT_EQ(boards, 1);
  EXPECT_EQ(poles, 2);
  int grounded = 0, hanging = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    const double centre_x = 10.0 * std::tan((stixel.angle_min_rad + stixel.angle_max_rad) / 2);
    if (std::abs(centre_x) < 0.6) {  // between the poles: under the board is free
      EXPECT_NEAR(stixel.min_height_m, 1.0, 0.1) << "x " << centre_x;
      ++hanging;
    }
    if (std::abs(centre_x) > 0.72) {  // the cell holding a pole (x in [0.70, 0.82] at 10 m)
      EXPECT_LT(stixel.min_height_m, 0.25) << "x " << centre_x;
      ++grounded;
    }
    EXPECT_GE(stixel.cluster, 0);
  }
  EXPECT_GT(hanging, 5);
  EXPECT_GE(grounded, 1);
}

// Deterministic uniform numbers in [0, 1) (a 64-bit LCG, Knuth's MMIX constants).
struct Uniform {
  uint64_t state;
  double operator()() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  }
};

// A point seen by the test camera at (x, height, z) with its disparity off by disparity_error_px: the
// point moves along its ray (the stereo error model's depth error), its pixel stays.
ObstaclePoint point_with_disparity_error(double x_m, double height_m, double z_m, double disparity_error_px) {
  const double disparity = testing::kFocalPx * testing::kBaselineM / z_m + disparity_error_px;
  const double scale = testing::kFocalPx * testing::kBaselineM / disparity / z_m;
  ObstaclePoint point = point_at(x_m * scale, testing::kCameraHeightM - (testing::kCameraHeightM - height_m) * scale, z_m * scale);
  return point;
}

TEST(AugmentedStixels, HangingBoardLowerEdgeFromFattenedNoisyPointsIsWithin10Cm) {
  // A board 0.9-1.6 m above the road at 18 m, one point per pixel (18 m / 500 px = 3.6 cm), each
  // disparity off by up to +-0.4 px; under it 3 rows of "fattened" points (the stereo window's
  // border effect: the board's disparity given to the road pixels just below its edge), 9 % of
  // the board's points, the lowest 11 cm under the edge.
  const double z_m = 18.0, pixel_m = z_m / testing::kFocalPx, edge_m = 0.9;
  Uniform uniform{7};
  std::vector<ObstaclePoint> points;
  for (double x = -1.0; x <= 1.0; x += pixel_m) {
    for (double height = edge_m; height <= 1.6; height += pixel_m) points.push_back(point_with_disparity_error(x, height, z_m, 0.8 * uniform() - 0.4));
    for (int row = 1; row <= 3; ++row) points.push_back(point_with_disparity_error(x, edge_m - row * pixel_m, z_m, 0.8 * uniform() - 0.4));
  }
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_FALSE(stixels.obstacles().empty()) << stixels.status();
  double best_error_m = 1e9;
  for (const Obstacle3d& obstacle : stixels.obstacles()) best_error_m = std::min(best_error_m, std::abs(obstacle.min_height_m - edge_m));
  EXPECT_LE(best_error_m, 0.10);
  // The lowest point is 11 cm under the edge: the plain minimum would miss the line.
  double lowest_m = 1e9;
  for (const ObstaclePoint& point : points) lowest_m = std::min<double>(lowest_m, point.height_above_ground_m);
  EXPECT_LT(lowest_m, edge_m - 0.10);
  // And the free space under it: no obstacle reaches below 0.8 m.
  for (const Obstacle3d& obstacle : stixels.obstacles()) EXPECT_GE(obstacle.min_height_m, edge_m - 0.10) << obstacle.position_m.transpose();
}

TEST(AugmentedStixels, DenseCellIsAStixelBeforeTheGridCallsItOccupied) {
  // 20 frames without points 20 m ahead (a box elsewhere, at 10 m, keeps the cloud non-empty): the
  // grid's log-odds there sink to log_odds_min = -4 (miss_probability each frame); then a box 0.6 m wide, 0-1 m, walks in at 20 m: its cells
  // hold dozens of points each (min_points_unoccupied = 30 and more), so it is an obstacle at
  // once, while the grid needs a few frames to call its cells occupied (with the dense-cell rule
  // off there is no obstacle at 20 m yet).
  std::vector<ObstaclePoint> other;
  add_patch(other, 2.0, 2.6, 0.0, 1.0, 10.0, 0.02);
  std::vector<ObstaclePoint> points = other;
  add_patch(points, -0.3, 0.3, 0.0, 1.0, 20.0, 0.02);
  // A deep lower clamp (-4, the grid's default before it became -1): with the default -1, one frame of
  // full evidence already makes a cell occupied and the rule would not be exercised.
  AugmentedStixelParameters dense_rule = stixel_parameters();
  dense_rule.grid.log_odds_min = -4.0;
  AugmentedStixelParameters occupied_only = dense_rule;
  occupied_only.min_points_unoccupied = 1 << 30;
  AugmentedStixels stixels(dense_rule), grid_only(occupied_only);
  for (int frame = 0; frame < 20; ++frame) {
    stixels.update(other, EgoMotion{});
    grid_only.update(other, EgoMotion{});
  }
  stixels.update(points, EgoMotion{});
  grid_only.update(points, EgoMotion{});
  auto obstacles_at_20_m = [](const AugmentedStixels& method) {
    int count = 0;
    for (const Obstacle3d& obstacle : method.obstacles()) count += std::abs(obstacle.position_m.z() - 20.0) < 1.0 ? 1 : 0;
    return count;
  };
  EXPECT_EQ(obstacles_at_20_m(stixels), 1) << stixels.status();
  EXPECT_EQ(obstacles_at_20_m(grid_only), 0) << grid_only.status();
  int unoccupied = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    if (!stixels.grid().occupied(stixel.range_cell, stixel.angle_cell)) {
      ++unoccupied;
      EXPECT_GE(stixel.point_count, 30);
    }
  }
  EXPECT_GT(unoccupied, 0);
}

TEST(AugmentedStixels, ScatteredNoisePointsDoNotBecomeObstacles) {
  // 3000 isolated points a frame (terrain-fit outliers, mismatches) spread over 5-35 m ahead and
  // +-8 m across, new ones every frame: no obstacle.
  AugmentedStixels stixels(stixel_parameters());
  Uniform uniform{11};
  for (int frame = 0; frame < 5; ++frame) {
    std::vector<ObstaclePoint> points;
    for (int i = 0; i < 3000; ++i) points.push_back(point_at(16 * uniform() - 8, 0.2 + 0.3 * uniform(), 5 + 30 * uniform()));
    stixels.update(points, EgoMotion{});
    EXPECT_TRUE(stixels.obstacles().empty()) << "frame " << frame << ": " << stixels.status();
  }
}

TEST(AugmentedStixels, SignOverALowBoxInTheSameCellsIsTwoStixelsPerCell) {
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.4, 0.4, 0.0, 0.3, 12.0);   // a low box
  add_patch(points, -0.4, 0.4, 2.0, 2.4, 12.0);   // a sign 1.7 m above it (gap > max_height_gap_m)
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  // Same cells hold both: the gap of 1.7 m (> max_height_gap_m) splits each cell's points into two
  // stixels (multi-layer), so the free space between 0.3 and 2.0 m is kept: two obstacles.
  ASSERT_EQ(stixels.obstacles().size(), 2u) << stixels.status();
  const double low_max = std::min(stixels.obstacles()[0].max_height_m, stixels.obstacles()[1].max_height_m);
  const double high_min = std::max(stixels.obstacles()[0].min_height_m, stixels.obstacles()[1].min_height_m);
  const double high_max = std::max(stixels.obstacles()[0].max_height_m, stixels.obstacles()[1].max_height_m);
  EXPECT_NEAR(low_max, 0.3, 0.1);
  EXPECT_NEAR(high_min, 2.0, 0.1);
  EXPECT_NEAR(high_max, 2.4, 0.1);
  // Every cell with a stixel has one under 0.4 m and one over 1.9 m, in order of height.
  std::vector<const AugmentedStixel*> previous;
  int cells = 0;
  for (size_t i = 0; i < stixels.stixels().size(); ++i) {
    const AugmentedStixel& stixel = stixels.stixels()[i];
    const bool first_of_cell = i == 0 || stixels.stixels()[i - 1].angle_cell != stixel.angle_cell ||
                               stixels.stixels()[i - 1].range_cell != stixel.range_cell;
    if (first_of_cell) {
      ++cells;
      EXPECT_LT(stixel.max_height_m, 0.4f) << stixel.angle_cell << "/" << stixel.range_cell;
    } else {
      EXPECT_GT(stixel.min_height_m, 1.9f) << stixel.angle_cell << "/" << stixel.range_cell;
    }
  }
  EXPECT_EQ(static_cast<int>(stixels.stixels().size()), 2 * cells);
}

TEST(AugmentedStixels, LowerEdgeOfADenseNearBoardIsItsEdgeNotItsLowestTenth) {
  // A board 1.0-1.7 m above the road at 5 m, exact points: its lowest tenth of points ends 7 cm
  // above the edge; the extrapolated edge (header, step 3) plus 1.5 px of fattening at 5 m
  // (1.5 cm) is within 3 cm of 1.0 m.
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.5, 0.5, 1.0, 1.7, 5.0);
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  EXPECT_NEAR(stixels.obstacles()[0].min_height_m, 1.0, 0.03);
  AugmentedStixelParameters plain = stixel_parameters();
  plain.lower_edge_fattening_px = 0;
  AugmentedStixels unfattened(plain);
  for (int frame = 0; frame < 3; ++frame) unfattened.update(points, EgoMotion{});
  ASSERT_EQ(unfattened.obstacles().size(), 1u) << unfattened.status();
  // The fattening term is 1.5 px x 5 m / 500 px = 1.5 cm.
  EXPECT_NEAR(stixels.obstacles()[0].min_height_m - unfattened.obstacles()[0].min_height_m, 1.5 * 5.0 / testing::kFocalPx, 0.002);
}

TEST(AugmentedStixels, TopRowsOfABoardCutOffByTheLowerEdgeStepJoinTheBoard) {
  // A board 1.0-1.6 m at 10 m and a strip of its top rows (1.45-1.6 m) whose points landed one
  // range cell behind (stereo scatter): the strip's lower edge is more than max_lower_edge_step_m
  // above the board's, so the stixels do not join, but the strip is a fragment (a tenth of the
  // board's points) and joins the board: one obstacle, whose lower edge stays the board's.
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.8, 0.8, 1.0, 1.6, 10.0);
  add_patch(points, -0.2, 0.2, 1.45, 1.6, 10.25);
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  EXPECT_NEAR(stixels.obstacles()[0].min_height_m, 1.0, 0.1);
  EXPECT_NEAR(stixels.obstacles()[0].max_height_m, 1.6, 0.1);
  int strip_stixels = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    if (stixel.min_height_m > 1.3f) ++strip_stixels;
    EXPECT_EQ(stixel.cluster, 0);
  }
  EXPECT_GT(strip_stixels, 0);  // the strip's stixels are there, apart in height from the board's
  // Without fragments (max_fragment_fraction 0) the strip is an obstacle of its own, hanging at 1.45 m.
  AugmentedStixelParameters no_fragments = stixel_parameters();
  no_fragments.max_fragment_fraction = 0;
  AugmentedStixels apart(no_fragments);
  for (int frame = 0; frame < 3; ++frame) apart.update(points, EgoMotion{});
  ASSERT_EQ(apart.obstacles().size(), 2u) << apart.status();
}

TEST(AugmentedStixels, SignArmPastTheSignJoinsTheSignNotThePost) {
  // A hanging sign 1.9-2.65 m at 8 m, x in [-0.6, 0.6]; its arm 2.9-3.0 m from x = -0.6 to the
  // post at x = 1.15 (0.1 m wide, 0-3.0 m). Past the sign the arm's stixels (2.9-3.0 m) are cut
  // off from the sign's by the lower-edge step and from the post's too: a fragment of both
  // intervals, it joins the sign (the host with the highest lower edge), so no obstacle reports a
  // lower edge at the arm's 2.9 m, and the sign's stays at 1.9 m.
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.6, 0.6, 1.9, 2.65, 8.0);
  add_patch(points, -0.6, 1.1, 2.9, 3.0, 8.0);
  add_patch(points, 1.1, 1.2, 0.0, 3.0, 8.0);
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 2u) << stixels.status();
  int signs = 0;
  for (const Obstacle3d& obstacle : stixels.obstacles()) {
    EXPECT_LT(obstacle.min_height_m, 2.5) << obstacle.position_m.transpose();
    if (obstacle.min_height_m > 1.0) {
      EXPECT_NEAR(obstacle.min_height_m, 1.9, 0.1);
      EXPECT_NEAR(obstacle.max_height_m, 3.0, 0.1);
      ++signs;
    }
  }
  EXPECT_EQ(signs, 1);
}

TEST(AugmentedStixels, ThinPostUnderABallIsItsOwnStixelInTheSharedCell) {
  // A ball 0.8-1.2 m (a 0.4 m wide patch, 1 cm spacing) on a 2 cm post from the ground at 10 m:
  // the post's points lie in the cell x in [0, 0.1) m with the ball's, no height gap between them.
  // Per metre of height the post has 2 points a row against the ball's 10 (ratio 0.2 < 0.3), so the
  // support split makes the cell two stixels: the post's (grounded) and the ball's (from 0.8 m).
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.2, 0.2, 0.8, 1.2, 10.0);
  add_patch(points, 0.03, 0.05, 0.0, 0.8, 10.0);
  auto centre_cell_stixels = [&](const AugmentedStixels& stixels) {
    std::vector<AugmentedStixel> found;
    for (const AugmentedStixel& stixel : stixels.stixels()) {
      const double centre_x = 10.0 * std::tan((stixel.angle_min_rad + stixel.angle_max_rad) / 2);
      if (centre_x > 0.0 && centre_x < 0.1) found.push_back(stixel);
    }
    return found;
  };
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  const std::vector<AugmentedStixel> split = centre_cell_stixels(stixels);
  ASSERT_EQ(split.size(), 2u) << stixels.status();
  EXPECT_LT(split[0].min_height_m, 0.25);  // the post (by height within the cell)
  EXPECT_LT(split[0].max_height_m, 0.85);
  EXPECT_NEAR(split[1].min_height_m, 0.8, 0.1);  // the ball
  EXPECT_NEAR(split[1].max_height_m, 1.2, 0.1);
  bool ball_found = false;
  for (const Obstacle3d& obstacle : stixels.obstacles()) {
    if (obstacle.max_height_m > 1.1) {
      EXPECT_NEAR(obstacle.min_height_m, 0.8, 0.1);
      ball_found = true;
    }
  }
  EXPECT_TRUE(ball_found) << stixels.status();
  // Without the split the cell is one stixel from the post's foot to the ball's top.
  AugmentedStixelParameters unsplit_parameters = stixel_parameters();
  unsplit_parameters.support_density_ratio = 0;
  AugmentedStixels unsplit(unsplit_parameters);
  for (int frame = 0; frame < 3; ++frame) unsplit.update(points, EgoMotion{});
  const std::vector<AugmentedStixel> whole = centre_cell_stixels(unsplit);
  ASSERT_EQ(whole.size(), 1u) << unsplit.status();
  EXPECT_LT(whole[0].min_height_m, 0.25);
  EXPECT_NEAR(whole[0].max_height_m, 1.2, 0.1);
}

TEST(AugmentedStixels, EvenlyDenseStandingObjectIsNotSplitBySupport) {
  // A box 0-1.2 m, 0.6 m wide, at 12 m, as dense at every height: no cut (the ratio is about 1).
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.3, 0.3, 0.0, 1.2, 12.0);
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_FALSE(stixels.stixels().empty());
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    EXPECT_LT(stixel.min_height_m, 0.1);
    EXPECT_GT(stixel.max_height_m, 1.1);
  }
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
}

TEST(AugmentedStixels, ABoardsLowerEdgeComesFromItsPooledPointsNotFromStixelsHoldingPartOfIt) {
  // A board 2 m wide, 0.9-1.6 m above the road at 17 m, one point per pixel row and column (3.4 cm),
  // the rows' centres from half a row above the edge. As the matcher leaves a hanging board (floating
  // seed 1 frame 3 in bench/obstacles3d_eval), its bottom rows' disparity is lower than the rest
  // (mixed with the road under them): by 0.25 px exp(-row / 3) here, plus +-0.05 px of noise. 0.1 px
  // is 0.2 m of range at 17 m, one range cell, so the bottom rows fall in farther cells than the
  // rows above and most stixels hold no bottom row: their point-weighted tercile was 1.10 m here
  // (in the eval's frame the stixel edges lay 0.89-1.16 m, the tercile 1.01 m). The obstacle's edge
  // is the estimate on the pooled points of its stixels: the edge plus half a row and the 1.5 px
  // fattening term (5.1 cm at 17 m), 0.968 m.
  const double z_m = 17.0, pixel_m = z_m / testing::kFocalPx, edge_m = 0.9;
  Uniform uniform{11};
  std::vector<ObstaclePoint> points;
  for (double x = -1.0; x <= 1.0; x += pixel_m) {
    int row = 0;
    for (double height = edge_m + pixel_m / 2; height <= 1.6; height += pixel_m, ++row)
      points.push_back(point_with_disparity_error(x, height, z_m, -0.25 * std::exp(-row / 3.0) + 0.1 * uniform() - 0.05));
  }
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  const Obstacle3d& board = stixels.obstacles()[0];
  EXPECT_NEAR(board.min_height_m, edge_m + pixel_m / 2 + 1.5 * z_m / testing::kFocalPx, 0.03);
  EXPECT_LT(board.min_height_m, edge_m + 0.10);
  EXPECT_NEAR(board.max_height_m, 1.6, 0.05);
  // The stixels keep their own edges: those of the stixels holding most of the points lie higher.
  int points_above = 0, points_total = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    points_total += stixel.point_count;
    if (stixel.min_height_m > edge_m + 0.10) points_above += stixel.point_count;
  }
  EXPECT_GT(2 * points_above, points_total);
}

TEST(AugmentedStixels, SparseStixelsChainedIntoABoardDoNotPullItsLowerEdgeDown) {
  // A dense board 1.0-1.5 m at 10 m, x in [-0.19, 0.19] (four 0.01 rad cells of 10 cm, 1 cm
  // spacing: about 500 points each), and beside it four sparse cells (5 cm spacing) reaching down
  // from 0.75, 0.5, 0.25 and 0 m to 1.5 m, like a pole's foot and scattered border points: each
  // lower edge lies within max_lower_edge_step_m (0.3 m) of its neighbour's, so the eight stixels
  // are one cluster. By stixel count the four sparse ones are half of the cluster and the plain
  // tercile (k = 8 / 3 = 2, third lowest) would be the 0.5 m cell's edge; by points they hold about
  // 150 of ~2100, so the point-weighted tercile is a board stixel's, 1.0 m.
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.19, 0.19, 1.0, 1.5, 10.0);
  const double sparse_low_m[4] = {0.75, 0.5, 0.25, 0.0};
  for (int cell = 0; cell < 4; ++cell) {
    const double x0 = 0.215 + 0.1 * cell;  // inside the cell [0.2 + 0.1 cell, 0.3 + 0.1 cell) at 10 m
    add_patch(points, x0, x0 + 0.05, sparse_low_m[cell], 1.5, 10.0, 0.05);
  }
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  // The sparse stixels are members of the board's cluster and keep their own low edges.
  int sparse_members = 0, dense_points = 0, sparse_points = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    const double centre_x = 10.0 * std::tan((stixel.angle_min_rad + stixel.angle_max_rad) / 2);
    EXPECT_EQ(stixel.cluster, 0);
    if (centre_x > 0.2) {
      ++sparse_members;
      sparse_points += stixel.point_count;
      EXPECT_LT(stixel.min_height_m, 0.85) << "x " << centre_x;
    } else {
      dense_points += stixel.point_count;
    }
  }
  EXPECT_EQ(sparse_members, 4);
  EXPECT_LT(3 * sparse_points, dense_points + sparse_points);  // under a third of the points
  EXPECT_NEAR(stixels.obstacles()[0].min_height_m, 1.0, 0.1);
  EXPECT_NEAR(stixels.obstacles()[0].max_height_m, 1.5, 0.1);
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

TEST(AugmentedStixels, TwoObjectsAtOneDepthWithAColumnGapAreTwoObstacles) {
  // The grid test's scene (occupancy_grid_test.cpp, OccupancyGridColumnGaps): a car's rear over
  // image columns 250-316 and a pedestrian over 321-336, both at 15 m and standing on the road, in
  // neighbouring polar columns 59 and 60. Their stixels are 8-neighbours with overlapping heights
  // and lower edges, one cluster; the 4 empty image columns make two obstacles, each with its own
  // stixels. With the split off, one obstacle.
  for (int gap_px : {3, 0}) {
    AugmentedStixelParameters parameters = stixel_parameters();
    parameters.grid.min_column_gap_px = gap_px;
    AugmentedStixels stixels(parameters);
    std::vector<ObstaclePoint> points;
    testing::add_pixel_columns(points, 250, 316, 0.2, 1.4, 15.0);
    testing::add_pixel_columns(points, 321, 336, 0.2, 1.7, 15.0);
    for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
    if (gap_px == 0) {
      ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
      continue;
    }
    ASSERT_EQ(stixels.obstacles().size(), 2u) << stixels.status();
    const double pixel_m = 15.0 / testing::kFocalPx;
    const int car = stixels.obstacles()[0].position_m.x() < stixels.obstacles()[1].position_m.x() ? 0 : 1;
    const Obstacle3d& car_obstacle = stixels.obstacles()[static_cast<size_t>(car)];
    const Obstacle3d& pedestrian_obstacle = stixels.obstacles()[static_cast<size_t>(1 - car)];
    EXPECT_NEAR(car_obstacle.position_m.x(), ((250 + 316) / 2.0 - testing::kPrincipalUPx) * pixel_m, 0.05);
    EXPECT_NEAR(pedestrian_obstacle.position_m.x(), ((321 + 336) / 2.0 - testing::kPrincipalUPx) * pixel_m, 0.05);
    EXPECT_NEAR(pedestrian_obstacle.size_m.x(), 15 * pixel_m, 0.05);
    // Every stixel names the obstacle on its side: columns 59 and below the car's, 60 the pedestrian's.
    for (const AugmentedStixel& stixel : stixels.stixels()) {
      EXPECT_EQ(stixel.cluster, stixel.angle_cell <= 59 ? car : 1 - car) << "stixel at column " << stixel.angle_cell;
    }
  }
}

TEST(AugmentedStixels, APartSplitOffAClusterKeepsOnlyTheHeightsItsPointsReach) {
  // A board's pole at 7 m (image columns 300-306, 0.2-1.6 m, 707 points) and, 4 empty columns to its
  // right, the board's top rows alone (columns 311-330, 1.57-1.60 m: 60 points, under a quarter of
  // the pole's), as in floating seed 1 frame 24. The top rows' lower edge lies more than the step
  // above the pole's and within its interval: a fragment, it joins the pole's cluster; the column
  // gap then cuts it off again. Its obstacle keeps the cluster's interval only as far as its own
  // points reach, 1.57-1.60 m, not the pole's 0.2 m: no obstacle under the board.
  AugmentedStixels stixels(stixel_parameters());
  std::vector<ObstaclePoint> points;
  testing::add_pixel_columns(points, 300, 306, 0.2, 1.6, 7.0);
  const size_t pole_points = points.size();
  testing::add_pixel_columns(points, 311, 330, 1.57, 1.60, 7.0);
  ASSERT_LE(points.size() - pole_points, pole_points / 4);
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 2u) << stixels.status();
  const int pole = stixels.obstacles()[0].position_m.x() < stixels.obstacles()[1].position_m.x() ? 0 : 1;
  const Obstacle3d& pole_obstacle = stixels.obstacles()[static_cast<size_t>(pole)];
  const Obstacle3d& top_rows = stixels.obstacles()[static_cast<size_t>(1 - pole)];
  EXPECT_NEAR(pole_obstacle.min_height_m, 0.2, 0.1);
  EXPECT_NEAR(pole_obstacle.max_height_m, 1.6, 0.05);
  EXPECT_GE(top_rows.min_height_m, 1.57 - 1e-6);
  EXPECT_LE(top_rows.max_height_m, 1.60 + 1e-6);
  EXPECT_LE(top_rows.min_height_m, top_rows.max_height_m);
}

TEST(AugmentedStixels, AWideObjectWithTwoEmptyColumnsStaysOneObstacle) {
  // A car's rear 2 m wide at 10 m (columns 270-370) whose columns 318-319 have no point: fewer than
  // the 3 of a gap, one obstacle 2 m wide.
  AugmentedStixels stixels(stixel_parameters());
  std::vector<ObstaclePoint> points;
  testing::add_pixel_columns(points, 270, 317, 0.2, 1.4, 10.0);
  testing::add_pixel_columns(points, 320, 370, 0.2, 1.4, 10.0);
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
  EXPECT_NEAR(stixels.obstacles()[0].size_m.x(), 100 * 10.0 / testing::kFocalPx, 0.05);
}

TEST(AugmentedStixels, APedestrianTouchingACarSidesFarEndIsItsOwnObstacle) {
  // synthetic_points.h, add_car_side_and_pedestrian (occupancy_grid_test.cpp, OccupancyGridConcavity):
  // no empty image column and no range peak between the side's far end and the pedestrian, so only
  // the concavity split separates them. With it, an obstacle on the pedestrian (centre within 0.3 m
  // of x -2.75, z 15.0 m) with the pedestrian's stixels; off, one obstacle over both, 2.24 m wide
  // (the box leaves out 1 % of the points at each end; 2.29 m with all) and centred 1.75 m nearer
  // than the pedestrian.
  // The car at its corner alone stays one obstacle.
  for (double concavity_px : {0.5, 0.0}) {
    AugmentedStixelParameters parameters = stixel_parameters();
    parameters.grid.min_concavity_px = concavity_px;
    AugmentedStixels stixels(parameters);
    std::vector<ObstaclePoint> points;
    testing::add_car_side_and_pedestrian(points);
    for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
    int pedestrian = -1;
    for (const Obstacle3d& obstacle : stixels.obstacles())
      if (std::abs(obstacle.position_m.x() + 2.75) < 0.3 && std::abs(obstacle.position_m.z() - 15.0) < 0.3) pedestrian = obstacle.id;
    if (concavity_px == 0) {
      EXPECT_EQ(pedestrian, -1) << stixels.status();
      ASSERT_EQ(stixels.obstacles().size(), 1u) << stixels.status();
      EXPECT_NEAR(stixels.obstacles()[0].size_m.x(), 2.24, 0.05);
      EXPECT_NEAR(stixels.obstacles()[0].position_m.z(), 13.25, 0.1);
      continue;
    }
    ASSERT_GE(pedestrian, 0) << stixels.status();
    EXPECT_EQ(stixels.obstacles().size(), 2u) << stixels.status();
    EXPECT_NEAR(stixels.obstacles()[static_cast<size_t>(pedestrian)].max_height_m, 1.7, 0.1);
    // The stixels at 15 m beyond the side's far end (x > -2.9 m) name the pedestrian's obstacle.
    int named = 0;
    for (const AugmentedStixel& stixel : stixels.stixels()) {
      const Eigen::Vector2d xz = stixels.grid().camera_xz_of(parameters.grid.column_min + (stixel.angle_cell + 0.5) * parameters.grid.column_cell,
                                                             parameters.grid.row_min + (stixel.range_cell + 0.5) * parameters.grid.row_cell);
      if (xz.x() > -2.9 && std::abs(xz.y() - 15.0) < 0.5) {
        EXPECT_EQ(stixel.cluster, pedestrian) << "stixel at column " << stixel.angle_cell;
        ++named;
      }
    }
    EXPECT_GT(named, 0);
  }
  AugmentedStixels car_alone(stixel_parameters());
  std::vector<ObstaclePoint> car;
  testing::add_car_side_and_pedestrian(car, true, false);
  for (int frame = 0; frame < 3; ++frame) car_alone.update(car, EgoMotion{});
  EXPECT_EQ(car_alone.obstacles().size(), 1u) << car_alone.status();
}

TEST(AugmentedStixels, TwoThreadsGiveTheOneThreadStixelsAndObstacles) {
  // Enough stixel points for two threads (a thread per 4096), several clusters, one of them split
  // at a column gap (a car's rear and a pedestrian), a board on poles, a sign over a box.
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.8, 0.8, 1.0, 1.5, 10.0);
  add_patch(points, -0.8, -0.74, 0.0, 1.0, 10.0);
  add_patch(points, 0.74, 0.8, 0.0, 1.0, 10.0);
  testing::add_pixel_columns(points, 420, 486, 0.2, 1.4, 15.0);
  testing::add_pixel_columns(points, 491, 506, 0.2, 1.7, 15.0);
  add_patch(points, -3.0, -2.0, 2.0, 2.6, 18.0);
  add_patch(points, -3.0, -2.0, 0.0, 0.5, 18.0);
  add_patch(points, 2.0, 4.0, 0.0, 1.0, 25.0, 0.02);
  AugmentedStixelParameters parameters = stixel_parameters();
  AugmentedStixels one(parameters);
  parameters.grid.threads = 2;
  AugmentedStixels two(parameters);
  for (int frame = 0; frame < 3; ++frame) {
    one.update(points, EgoMotion{});
    two.update(points, EgoMotion{});
  }
  ASSERT_GT(one.point_indices().size(), 2u * 4096u);
  ASSERT_GE(one.obstacles().size(), 6u) << one.status();
  ASSERT_EQ(two.stixels().size(), one.stixels().size()) << two.status();
  EXPECT_EQ(two.point_indices(), one.point_indices());
  for (size_t i = 0; i < one.stixels().size(); ++i) {
    const AugmentedStixel &a = one.stixels()[i], &b = two.stixels()[i];
    EXPECT_EQ(b.angle_cell, a.angle_cell);
    EXPECT_EQ(b.range_cell, a.range_cell);
    EXPECT_EQ(b.first_point, a.first_point);
    EXPECT_EQ(b.point_count, a.point_count);
    EXPECT_EQ(b.min_height_m, a.min_height_m);
    EXPECT_EQ(b.max_height_m, a.max_height_m);
    EXPECT_EQ(b.mean_range_m, a.mean_range_m);
    EXPECT_EQ(b.mean_rgb, a.mean_rgb);
    EXPECT_EQ(b.cluster, a.cluster) << "stixel " << i;
    // The grid's evidence is summed per thread, so its probabilities agree to rounding only.
    EXPECT_NEAR(b.occupancy_probability, a.occupancy_probability, 1e-5);
  }
  ASSERT_EQ(two.obstacles().size(), one.obstacles().size());
  for (size_t i = 0; i < one.obstacles().size(); ++i) {
    const Obstacle3d &a = one.obstacles()[i], &b = two.obstacles()[i];
    EXPECT_EQ(b.id, static_cast<int>(i));
    EXPECT_EQ(b.bbox_px, a.bbox_px);
    EXPECT_EQ(b.position_m, a.position_m);
    EXPECT_EQ(b.size_m, a.size_m);
    EXPECT_EQ(b.min_height_m, a.min_height_m);
    EXPECT_EQ(b.max_height_m, a.max_height_m);
  }
  EXPECT_EQ(two.work().scalar_ops, one.work().scalar_ops);
  EXPECT_EQ(two.work().memory_bytes, one.work().memory_bytes);
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
  parameters = stixel_parameters();
  parameters.lower_edge_fraction = 0.5;
  EXPECT_EQ(message_of(parameters), "lower_edge_fraction: expected in [0, 0.5), got 0.5");
  parameters = stixel_parameters();
  parameters.min_points_unoccupied = 0;
  EXPECT_EQ(message_of(parameters), "min_points_unoccupied: expected >= 1, got 0");
  parameters = stixel_parameters();
  parameters.support_density_ratio = 1.0;
  EXPECT_EQ(message_of(parameters), "support_density_ratio: expected in [0, 1), got 1");
  parameters = stixel_parameters();
  parameters.lower_edge_fattening_px = -1;
  EXPECT_EQ(message_of(parameters), "lower_edge_fattening_px: expected in [0, 16], got -1");
  parameters = stixel_parameters();
  parameters.max_fragment_fraction = 1;
  EXPECT_EQ(message_of(parameters), "max_fragment_fraction: expected in [0, 1), got 1");
  parameters = stixel_parameters();
  parameters.min_obstacle_points = 0;
  EXPECT_EQ(message_of(parameters), "min_obstacle_points: expected >= 1, got 0");
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

TEST(AugmentedStixels, SupportSplitCountsEightOpsPerPointOfAStixelCell) {
  // A patch of points 4 cm wide, 1.0-1.1 m, at 10 m inside one 0.01 rad cell (x in [0, 0.1) m):
  // every point in one stixel cell, scanned once by the support split, 8 ops each (header, counted
  // work); no cut.
  std::vector<ObstaclePoint> points;
  add_patch(points, 0.03, 0.07, 1.0, 1.1, 10.0);
  AugmentedStixelParameters off = stixel_parameters();
  off.support_density_ratio = 0;
  AugmentedStixels with_split(stixel_parameters()), without_split(off);
  for (int frame = 0; frame < 3; ++frame) {
    with_split.update(points, EgoMotion{});
    without_split.update(points, EgoMotion{});
  }
  ASSERT_EQ(with_split.stixels().size(), 1u) << with_split.status();
  ASSERT_EQ(without_split.stixels().size(), 1u) << without_split.status();
  EXPECT_EQ(with_split.work().scalar_ops, without_split.work().scalar_ops + 8 * points.size());
  EXPECT_EQ(with_split.work().memory_bytes, without_split.work().memory_bytes);
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
