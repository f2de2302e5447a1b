// The 2.5D sampling (arm/terrain/height_grid.cpp): the area's cells, the cell rule of thesis eq. 3.2
// on hand-computed cells, the neighbour fill, rejected points and the counted work.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "arm/terrain/terrain_model.h"

namespace lpstereo::arm::terrain {
namespace {

TerrainGridSpec small_spec() {
  TerrainGridSpec spec;
  spec.forward_min_m = 0, spec.forward_max_m = 3, spec.lateral_min_m = -1, spec.lateral_max_m = 1, spec.cell_m = 0.5;
  return spec;
}

TEST(TerrainGridSpec, CellsAndCentres) {
  const TerrainGridSpec spec = small_spec();
  EXPECT_EQ(spec.forward_cells(), 6);
  EXPECT_EQ(spec.lateral_cells(), 4);
  TerrainGridSpec thesis;  // 34 x 22 m at 0.5 m
  EXPECT_EQ(thesis.forward_cells(), 68);
  EXPECT_EQ(thesis.lateral_cells(), 44);
  int i = -1, j = -1;
  ASSERT_TRUE(spec.cell_of(1.2, -0.1, &i, &j));
  EXPECT_EQ(i, 2);
  EXPECT_EQ(j, 1);
  EXPECT_DOUBLE_EQ(spec.cell_centre_x_m(2), 1.25);
  EXPECT_DOUBLE_EQ(spec.cell_centre_y_m(1), -0.25);
  EXPECT_FALSE(spec.cell_of(3.0, 0, &i, &j));   // the far edge is outside (half-open cells)
  EXPECT_FALSE(spec.cell_of(-0.01, 0, &i, &j));
  EXPECT_FALSE(spec.cell_of(1, std::numeric_limits<double>::quiet_NaN(), &i, &j));
}

void expect_spec_error(const TerrainGridSpec& spec, const std::string& name) {
  try {
    spec.validate();
    ADD_FAILURE() << name << ": no throw";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()).rfind(name + ":", 0), 0u) << error.what();
  }
}

TEST(TerrainGridSpec, ValidateNamesTheParameter) {
  TerrainGridSpec spec = small_spec();
  spec.cell_m = 0;
  expect_spec_error(spec, "cell_m");
  spec = small_spec();
  spec.forward_max_m = -1;
  expect_spec_error(spec, "forward_max_m");
  spec = small_spec();
  spec.lateral_max_m = -2;
  expect_spec_error(spec, "lateral_max_m");
  spec = small_spec();
  spec.lateral_min_m = std::numeric_limits<double>::infinity();
  EXPECT_THROW(spec.validate(), std::invalid_argument);
  EXPECT_THROW(HeightGridAccumulator{spec}, std::invalid_argument);
}

// Cells by hand (eq. 3.2, sigma the population standard deviation):
//   (0, 0): z = {1, 2, 3, 10}: mean 4, sigma = sqrt(114/4 - 16) = 3.5355, mean - sigma = 0.464 < min:
//           Z = min = 1 (a tall thing over ground keeps the ground).
//   (0, 1): z = {1.0, 1.2, 1.4}: mean 1.2, sigma = sqrt(4.4/3 - 1.44) = 0.16330, Z = 1.03670 > min 1.0.
//   (5, 3): one point z = 2: Z = 2.
// Empty cells: (1, 0) has measured neighbours (0, 0) and (0, 1): Z = (1 + 1.03670) / 2; (1, 1)
// also; (3, 0) has none (its neighbours rows 2-4 are empty): invalid, NaN. (4, 2) next to (5, 3): 2.
TEST(HeightGridAccumulator, CellRuleAndNeighbourFill) {
  TerrainGridSpec spec = small_spec();
  spec.cell_rule = TerrainGridSpec::CellRule::thesis;
  HeightGridAccumulator accumulator(spec);
  for (double z : {1.0, 2.0, 3.0, 10.0}) EXPECT_TRUE(accumulator.add_point(Eigen::Vector3d(0.1, -0.9, z)));
  for (double z : {1.0, 1.2, 1.4}) EXPECT_TRUE(accumulator.add_point(Eigen::Vector3d(0.4, -0.3, z)));
  EXPECT_TRUE(accumulator.add_to_cell(5, 3, 2.0));
  EXPECT_FALSE(accumulator.add_point(Eigen::Vector3d(3.5, 0, 0)));  // outside
  EXPECT_FALSE(accumulator.add_point(Eigen::Vector3d(1, 0, std::numeric_limits<double>::quiet_NaN())));
  EXPECT_FALSE(accumulator.add_point(Eigen::Vector3d(std::numeric_limits<double>::infinity(), 0, 0)));
  EXPECT_FALSE(accumulator.add_to_cell(6, 0, 1.0));
  EXPECT_FALSE(accumulator.add_to_cell(0, -1, 1.0));
  EXPECT_EQ(accumulator.accepted(), 8);
  EXPECT_EQ(accumulator.rejected(), 5);

  const HeightGrid grid = accumulator.finish();
  ASSERT_EQ(grid.height_m.rows(), 6);
  ASSERT_EQ(grid.height_m.cols(), 4);
  const double sigma01 = std::sqrt((1.0 + 1.44 + 1.96) / 3.0 - 1.44);
  EXPECT_NEAR(grid.height_m(0, 0), 1.0, 1e-12);
  EXPECT_NEAR(grid.height_m(0, 1), 1.2 - sigma01, 1e-12);
  EXPECT_NEAR(grid.height_m(0, 1), 1.03670, 1e-5);
  EXPECT_NEAR(grid.height_m(5, 3), 2.0, 1e-12);
  EXPECT_EQ(grid.state(0, 0), kCellMeasured);
  EXPECT_EQ(grid.point_count(0, 0), 4);
  EXPECT_EQ(grid.point_count(0, 1), 3);
  EXPECT_NEAR(grid.height_m(1, 0), (1.0 + 1.2 - sigma01) / 2, 1e-12);
  EXPECT_EQ(grid.state(1, 0), kCellFilled);
  EXPECT_EQ(grid.point_count(1, 0), 0);
  EXPECT_NEAR(grid.height_m(1, 1), (1.0 + 1.2 - sigma01) / 2, 1e-12);
  EXPECT_NEAR(grid.height_m(0, 2), 1.2 - sigma01, 1e-12);  // only (0, 1) is a measured neighbour
  EXPECT_NEAR(grid.height_m(4, 2), 2.0, 1e-12);
  EXPECT_EQ(grid.state(3, 0), kCellInvalid);
  EXPECT_TRUE(std::isnan(grid.height_m(3, 0)));
  // Filled cells: (1,0), (1,1), (1,2), (0,2) around the first two; (4,2), (4,3), (5,2) around (5,3).
  EXPECT_EQ(grid.valid_cells(), 3 + 4 + 3);
  // The highest point of each measured cell, whatever the cell rule made of it; NaN without points.
  EXPECT_EQ(grid.max_height_m(0, 0), 10.0);
  EXPECT_EQ(grid.max_height_m(0, 1), 1.4);
  EXPECT_EQ(grid.max_height_m(5, 3), 2.0);
  EXPECT_TRUE(std::isnan(grid.max_height_m(1, 0)));  // filled
  EXPECT_TRUE(std::isnan(grid.max_height_m(3, 0)));  // invalid
  EXPECT_EQ(grid.max_height_m.rows(), 6);
  EXPECT_EQ(grid.max_height_m.cols(), 4);
}

// The noise-floor rule on one forward row (row 2 of small_spec, 4 cells), stereo-like noise +-s
// (s = 0.05 m, equal counts: mean g, population sigma exactly s):
//   (2, 0), (2, 1), (2, 2): 8 points each at g +- s, g = 0.3: variance s^2 = 0.0025;
//   (2, 3): the same 8 noise points about 0 plus 2 points of an obstacle 0.6 m up: n = 10,
//           mean = 1.2 / 10 = 0.12, mean z^2 = (8 x 0.0025 + 2 x 0.36) / 10 = 0.074,
//           variance = 0.074 - 0.0144 = 0.0596.
// Noise floor: the median (quantile 0.5) of the 4 variances of rows 1-3 (rank round(0.5 x 3) = 2 of
// {0.0025, 0.0025, 0.0025, 0.0596}) = 0.0025. Ground cells: excess 0, Z = mean = 0.3 (eq. 3.2 would
// give 0.3 - 0.05: one noise sigma low). Obstacle cell: Z = max(-0.05, 0.12 - sqrt(0.0596 - 0.0025))
// = max(-0.05, 0.12 - 0.238956) = -0.05 (the min: the obstacle's spread is still subtracted).
// With quantile 0: the lowest variance, the same 0.0025 here. With the thesis rule: 0.25 and -0.05.
TEST(HeightGridAccumulator, NoiseFloorRuleSubtractsOnlyTheSpreadAboveTheRowsNoise) {
  const double s = 0.05, g = 0.3;
  const auto fill = [&](HeightGridAccumulator& accumulator) {
    for (int j = 0; j < 4; ++j) {
      const double ground = j < 3 ? g : 0.0;
      for (int k = 0; k < 8; ++k) accumulator.add_to_cell(2, j, ground + (k % 2 == 0 ? s : -s));
    }
    accumulator.add_to_cell(2, 3, 0.6);
    accumulator.add_to_cell(2, 3, 0.6);
  };
  TerrainGridSpec spec = small_spec();
  spec.cell_rule = TerrainGridSpec::CellRule::noise_floor;
  HeightGridAccumulator noise_floor(spec);
  fill(noise_floor);
  const HeightGrid grid = noise_floor.finish();
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(grid.height_m(2, j), g, 1e-12) << j;
  EXPECT_NEAR(grid.height_m(2, 3), -s, 1e-12);
  // A lower obstacle point set where mean - excess lies above the min: 8 noise points about 0 plus
  // one point at 0.3 in cell (2, 3): n = 9, mean = 0.3 / 9, mean z^2 = (0.02 + 0.09) / 9,
  // variance = 0.11 / 9 - (0.3 / 9)^2 = 0.0111111; the median of {0.0025 x 3, 0.0111} is 0.0025:
  // Z = 0.033333 - sqrt(0.0086111) = 0.033333 - 0.092796 = -0.059463 < -0.05: the min again; so
  // check the excess directly on a cell without the min bound: 16 points, 8 at +-s about 0 and 8 at
  // 0.1 +- s: mean 0.05, variance = s^2 + 0.05^2 = 0.005, excess sqrt(0.005 - 0.0025) = 0.05,
  // Z = max(-0.05, 0.05 - 0.05) = 0.
  HeightGridAccumulator two_levels(spec);
  for (int j = 0; j < 3; ++j)
    for (int k = 0; k < 8; ++k) two_levels.add_to_cell(2, j, g + (k % 2 == 0 ? s : -s));
  for (int k = 0; k < 8; ++k) two_levels.add_to_cell(2, 3, k % 2 == 0 ? s : -s);
  for (int k = 0; k < 8; ++k) two_levels.add_to_cell(2, 3, 0.1 + (k % 2 == 0 ? s : -s));
  EXPECT_NEAR(two_levels.finish().height_m(2, 3), 0.0, 1e-9);

  spec.cell_rule = TerrainGridSpec::CellRule::thesis;
  HeightGridAccumulator thesis(spec);
  fill(thesis);
  const HeightGrid thesis_grid = thesis.finish();
  for (int j = 0; j < 3; ++j) EXPECT_NEAR(thesis_grid.height_m(2, j), g - s, 1e-12) << j;
  EXPECT_NEAR(thesis_grid.height_m(2, 3), -s, 1e-12);

  // Cells with fewer than 4 points give no noise estimate: a row of 3-point cells keeps eq. 3.2.
  spec.cell_rule = TerrainGridSpec::CellRule::noise_floor;
  HeightGridAccumulator sparse(spec);
  for (double z : {1.0, 1.2, 1.4}) sparse.add_to_cell(4, 1, z);
  const double sigma = std::sqrt((1.0 + 1.44 + 1.96) / 3.0 - 1.44);
  EXPECT_NEAR(sparse.finish().height_m(4, 1), 1.2 - sigma, 1e-12);

  spec.noise_floor_quantile = 1.5;
  expect_spec_error(spec, "noise_floor_quantile");
}

TEST(HeightGridAccumulator, EqualHeightsGiveThatHeight) {
  // Rounding must not make the variance of equal heights negative (a NaN sigma).
  HeightGridAccumulator accumulator(small_spec());
  for (int k = 0; k < 1000; ++k) accumulator.add_point(Eigen::Vector3d(1.1, 0.1, 0.1));
  const HeightGrid grid = accumulator.finish();
  EXPECT_NEAR(grid.height_m(2, 2), 0.1, 1e-12);
}

TEST(HeightGridAccumulator, WorkFollowsTheDocumentedModel) {
  HeightGridAccumulator accumulator(small_spec());
  for (int k = 0; k < 10; ++k) accumulator.add_point(Eigen::Vector3d(0.2 * k, 0, 1));  // 0 .. 1.8: all inside
  accumulator.add_point(Eigen::Vector3d(9, 0, 1));                                    // rejected
  for (int k = 0; k < 3; ++k) accumulator.add_to_cell(1, 1, 0.5);
  // 10 per add_point call, 7 per accepted point, 2 per add_to_cell call, 12 + 8 per cell (24 cells)
  // with the noise-floor rule, 12 with eq. 3.2; 12 bytes per point, 36 + 16 per cell.
  EXPECT_EQ(accumulator.work().scalar_ops, 10u * 11 + 7u * 13 + 2u * 3 + 20u * 24);
  EXPECT_EQ(accumulator.work().memory_bytes, 12u * 13 + 52u * 24);
  TerrainGridSpec thesis_spec = small_spec();
  thesis_spec.cell_rule = TerrainGridSpec::CellRule::thesis;
  HeightGridAccumulator thesis(thesis_spec);
  thesis.add_to_cell(1, 1, 0.5);
  EXPECT_EQ(thesis.work().scalar_ops, 7u + 2u + 12u * 24);
}

// The vertical-gap rule (TerrainGridSpec::vertical_gap_m), eq. 3.2 for hand-computed cells. Cell
// (2, 1): 6 road points at 0, 0.02, .., 0.10 under 24 points of a sign hanging from 1.90 to 2.36 m
// (0.02 m apart): what a 0.5 m cell at 12 m sees of a sign 1.9 m up over the road.
//   rule off: n = 30, mean = (0.3 + 51.12) / 30 = 1.714, Z = max(0, mean - sigma) far above the road;
//   gap 0.5 m: the cut between 0.10 and 1.90 has 6 >= 4 points under it, the road alone remains:
//   mean 0.05, sigma^2 = 2 (0.05^2 + 0.03^2 + 0.01^2) / 6 = 0.007 / 6, Z = 0.05 - 0.0341565.
TEST(HeightGridAccumulator, VerticalGapRuleLeavesAHangingObstacleOutOfItsCell) {
  TerrainGridSpec spec = small_spec();
  spec.cell_rule = TerrainGridSpec::CellRule::thesis;
  const auto fill = [](HeightGridAccumulator& accumulator) {
    for (int k = 0; k <= 5; ++k) accumulator.add_to_cell(2, 1, 0.02 * k);
    for (int k = 0; k < 24; ++k) accumulator.add_point(Eigen::Vector3d(1.2, -0.4, 1.90 + 0.02 * k));  // cell (2, 1)
  };
  HeightGridAccumulator off(spec);
  fill(off);
  const HeightGrid off_grid = off.finish();
  EXPECT_GT(off_grid.height_m(2, 1), 0.5);  // the cell lifted by the sign
  spec.vertical_gap_m = 0.5;
  HeightGridAccumulator on(spec);
  fill(on);
  const HeightGrid on_grid = on.finish();
  EXPECT_NEAR(on_grid.height_m(2, 1), 0.05 - std::sqrt(0.007 / 6), 1e-6);
  EXPECT_NEAR(on_grid.height_m(2, 1), 0.0158435, 1e-6);
  EXPECT_EQ(on_grid.point_count(2, 1), 30);  // every binned point is still counted
  EXPECT_EQ(on_grid.state(2, 1), kCellMeasured);
  // The neighbour fill reads the cut cell: (1, 1) has (2, 1) as its only measured neighbour.
  EXPECT_NEAR(on_grid.height_m(1, 1), on_grid.height_m(2, 1), 1e-12);
  // With the noise-floor rule (the default) the cut cell is the road's mean, 0.05 (its own
  // variance is the row's only one, so the noise floor removes all of it).
  spec.cell_rule = TerrainGridSpec::CellRule::noise_floor;
  HeightGridAccumulator noise_floor(spec);
  fill(noise_floor);
  EXPECT_NEAR(noise_floor.finish().height_m(2, 1), 0.05, 1e-6);
}

// Cells the rule must leave exactly as they are without it (the same double sums).
TEST(HeightGridAccumulator, VerticalGapRuleKeepsCellsWithoutAWideGap) {
  TerrainGridSpec spec = small_spec();
  spec.cell_rule = TerrainGridSpec::CellRule::thesis;
  const auto fill = [](HeightGridAccumulator& accumulator) {
    // (0, 0) a pole from the road up to 2 m, a point every 5 cm: no gap
    for (int k = 0; k <= 40; ++k) accumulator.add_to_cell(0, 0, 0.05 * k);
    // (1, 0) 3 low mismatches 1 m under 10 road points: the gap has only 3 points under it
    for (int k = 0; k < 3; ++k) accumulator.add_to_cell(1, 0, -1.0 - 0.01 * k);
    for (int k = 0; k < 10; ++k) accumulator.add_to_cell(1, 0, 0.01 * k);
    // (2, 2) 6 road points and a board 0.4 m above them: a gap narrower than 0.5 m
    for (int k = 0; k < 6; ++k) accumulator.add_to_cell(2, 2, 0.02 * k);
    for (int k = 0; k < 10; ++k) accumulator.add_to_cell(2, 2, 0.5 + 0.02 * k);
    // (3, 3) 4 points only, with a 1 m gap above the lowest: at most 4 points is never cut
    for (double z : {0.0, 0.01, 0.02, 1.5}) accumulator.add_to_cell(3, 3, z);
  };
  HeightGridAccumulator off(spec);
  fill(off);
  spec.vertical_gap_m = 0.5;
  HeightGridAccumulator on(spec);
  fill(on);
  const HeightGrid off_grid = off.finish(), on_grid = on.finish();
  for (const auto& [i, j] : {std::pair{0, 0}, std::pair{1, 0}, std::pair{2, 2}, std::pair{3, 3}}) {
    EXPECT_EQ(on_grid.height_m(i, j), off_grid.height_m(i, j)) << i << ", " << j;
  }
}

// The cut is at the first wide gap up from the road: road, a board 1.0-1.1 m, a sign 2.5 m up.
// Only the 5 road points at 0.1 m remain: Z = 0.1.
TEST(HeightGridAccumulator, VerticalGapRuleCutsAtTheFirstGap) {
  TerrainGridSpec spec = small_spec();
  spec.cell_rule = TerrainGridSpec::CellRule::thesis;
  spec.vertical_gap_m = 0.5;
  HeightGridAccumulator accumulator(spec);
  for (int k = 0; k < 8; ++k) accumulator.add_to_cell(4, 2, 2.5);
  for (int k = 0; k < 6; ++k) accumulator.add_to_cell(4, 2, 1.0 + 0.02 * k);
  for (int k = 0; k < 5; ++k) accumulator.add_to_cell(4, 2, 0.1);
  EXPECT_NEAR(accumulator.finish().height_m(4, 2), 0.1, 1e-6);

  spec.vertical_gap_m = -0.1;
  expect_spec_error(spec, "vertical_gap_m");
  spec.vertical_gap_m = std::numeric_limits<double>::infinity();
  expect_spec_error(spec, "vertical_gap_m");
}

TEST(HeightGridAccumulator, VerticalGapRuleWorkFollowsTheDocumentedModel) {
  TerrainGridSpec spec = small_spec();
  spec.cell_rule = TerrainGridSpec::CellRule::thesis;
  spec.vertical_gap_m = 0.5;
  HeightGridAccumulator accumulator(spec);
  for (int k = 0; k < 5; ++k) accumulator.add_to_cell(1, 1, 0.1 * k);
  for (int k = 0; k < 3; ++k) accumulator.add_to_cell(2, 0, 0.0);
  // eq. 3.2's 2 per add_to_cell call, 6 per accepted point, 12 per cell (24 cells); the rule's
  // (2 + 3) per point and n ceil(log2 n) + n per cell: 5 x 3 + 5 = 20 and 3 x 2 + 3 = 9.
  EXPECT_EQ(accumulator.work().scalar_ops, 2u * 8 + 7u * 8 + 12u * 24 + 5u * 8 + 20u + 9u);
  EXPECT_EQ(accumulator.work().memory_bytes, 12u * 8 + 52u * 24 + 16u * 8);
}

}  // namespace
}  // namespace lpstereo::arm::terrain
