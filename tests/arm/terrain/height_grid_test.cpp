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
  HeightGridAccumulator accumulator(small_spec());
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
  // 10 per add_point call, 6 per accepted point, 2 per add_to_cell call, 12 per cell (24 cells).
  EXPECT_EQ(accumulator.work().scalar_ops, 10u * 11 + 6u * 13 + 2u * 3 + 12u * 24);
  EXPECT_EQ(accumulator.work().memory_bytes, 12u * 13 + 36u * 24);
}

}  // namespace
}  // namespace lpstereo::arm::terrain
