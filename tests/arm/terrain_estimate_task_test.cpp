// ARM task terrain_estimate (arm/tasks/terrain_estimate.cpp): binned planes of a tilted plane ground
// give a known record whose control heights and cost grid match the ground (the plane z = 0.3 +
// 0.05 x m: every control height on the line, slope 0.05 in every cell), the counts and the counted
// work in the documented closed form (the fit's and traversability's own counts taken from the same
// public calls); no points give an unknown record (too_few_cells, every cost -1), a wall one with
// no_ground_extent; the parameters and shapes it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "arm/tasks/terrain_record.h"
#include "arm/terrain/terrain_model.h"
#include "dag/arm_task.h"

namespace lpstereo {
namespace {

namespace terrain = arm::terrain;

const ArmTaskDescriptor& terrain_task() {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("terrain_estimate");
  if (task == nullptr) throw std::runtime_error("ARM task 'terrain_estimate' is not registered");
  return *task;
}

struct TaskRun {
  Plane record, cost;
  ArmWork work;
};

TaskRun run_task(const Plane& cells, const Plane& heights, const nlohmann::json& params) {
  const ArmTaskDescriptor& task = terrain_task();
  const PreparedKernel prepared = task.prepare(params, {{cells.width(), cells.height()}, {heights.width(), heights.height()}});
  TaskRun result{Plane(prepared.output_shapes[0].width, 1, {ElementType::s32, 0}),
                 Plane(prepared.output_shapes[1].width, prepared.output_shapes[1].height, {ElementType::s32, 0}),
                 {}};
  ArmTaskArgs args{{&cells, &heights}, {&result.record, &result.cost}, prepared.params.get(), &result.work};
  task.run(args);
  return result;
}

// A 10 m x 8 m area of 0.5 m cells (20 x 16), 8 x 6 control points: small enough to check by hand.
const nlohmann::json kParams = {{"forward_min_m", 0.0}, {"forward_max_m", 10.0}, {"lateral_min_m", -4.0},
                                {"lateral_max_m", 4.0}, {"cell_m", 0.5},         {"control_forward", 8},
                                {"control_lateral", 6}, {"initial_control_forward", 4}, {"initial_control_lateral", 4},
                                {"sample_step", 2}};

// The planes the binning kernel would give for the ground z = 0.3 + 0.05 x: pixel (u, v) of a 160 x
// 64 image falls in cell (i, j) = (v * 20 / 64, u * 16 / 160) at the height of that cell's centre
// (mm); every 7th pixel has no cell.
void ground_planes(Plane& cells, Plane& heights) {
  for (int v = 0; v < cells.height(); ++v) {
    for (int u = 0; u < cells.width(); ++u) {
      const int i = v * 20 / cells.height(), j = u * 16 / cells.width();
      const bool none = (u + 3 * v) % 7 == 0;
      cells.at<int32_t>(u, v) = none ? -1 : i * 16 + j;
      heights.at<int32_t>(u, v) = none ? INT32_MIN : static_cast<int32_t>(std::lround(1000 * (0.3 + 0.05 * (0.25 + 0.5 * i))));
    }
  }
}

TEST(TerrainEstimateTask, TiltedPlaneGroundGivesItsControlHeightsAndSlope) {
  Plane cells(160, 64, {ElementType::s32, 0}), heights(160, 64, {ElementType::s32, 0});
  ground_planes(cells, heights);
  const TaskRun run = run_task(cells, heights, kParams);
  ASSERT_EQ(run.record.width(), arm::kTerrainHeaderWords + 8 * 6);
  ASSERT_EQ(run.cost.width(), 16);
  ASSERT_EQ(run.cost.height(), 20);
  const int32_t* record = run.record.row<const int32_t>(0);
  ASSERT_EQ(record[arm::kTerrainKnown], 1) << "reason " << record[arm::kTerrainReason];
  EXPECT_EQ(record[arm::kTerrainReason], 0);
  EXPECT_EQ(record[arm::kTerrainValidCells], 20 * 16);
  EXPECT_EQ(record[arm::kTerrainMeasuredCells], 20 * 16);
  // Sampled: every 2nd row and column, 80 x 32; accepted: those without (u + 3 v) % 7 == 0.
  int accepted = 0;
  for (int v = 0; v < 64; v += 2) {
    for (int u = 0; u < 160; u += 2) accepted += (u + 3 * v) % 7 != 0;
  }
  EXPECT_EQ(record[arm::kTerrainSampledPixels], 80 * 32);
  EXPECT_EQ(record[arm::kTerrainAcceptedPoints], accepted);
  EXPECT_EQ(record[arm::kTerrainControlForward], 8);
  EXPECT_EQ(record[arm::kTerrainControlLateral], 6);
  EXPECT_EQ(record[arm::kTerrainDegreeForward], 3);
  EXPECT_EQ(record[arm::kTerrainCellMm], 500);
  EXPECT_EQ(record[arm::kTerrainOccupiedCells], 0);
  // A clamped B-spline reproduces a linear function with control values on the line at the Greville
  // abscissae (knot averages): z = 0.3 + 0.05 x there.
  const std::vector<double> knots = terrain::clamped_uniform_knots(8, 3, 0.0, 10.0);
  for (int a = 0; a < 8; ++a) {
    const double greville_m = (knots[static_cast<size_t>(a + 1)] + knots[static_cast<size_t>(a + 2)] + knots[static_cast<size_t>(a + 3)]) / 3;
    for (int b = 0; b < 6; ++b) {
      EXPECT_NEAR(record[arm::kTerrainHeaderWords + a * 6 + b], 1000 * (0.3 + 0.05 * greville_m), 6) << a << "," << b;
    }
  }
  // Cost = w_occ 0 + w_slope |grad S| = 0.05 in thousandths.
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 16; ++j) EXPECT_NEAR(run.cost.at<int32_t>(j, i), 50, 6) << i << "," << j;
  }
  // Counted work: the closed form of the header, with the library's own counts from the same calls.
  terrain::TerrainGridSpec grid;
  grid.forward_max_m = 10.0;
  grid.lateral_min_m = -4.0;
  grid.lateral_max_m = 4.0;
  terrain::HeightGridAccumulator accumulator(grid);
  for (int v = 0; v < 64; v += 2) {
    for (int u = 0; u < 160; u += 2) {
      const int32_t cell = cells.at<int32_t>(u, v);
      if (cell >= 0) accumulator.add_to_cell(cell / 16, cell % 16, heights.at<int32_t>(u, v) / 1000.0);
    }
  }
  const terrain::HeightGrid measured = accumulator.finish();
  terrain::TerrainFitParameters fit;
  fit.control_forward = 8;
  fit.control_lateral = 6;
  fit.initial_control_forward = fit.initial_control_lateral = 4;
  const terrain::TerrainEstimate estimate = terrain::fit_terrain(measured, fit);
  const terrain::TraversabilityMap map = terrain::compute_traversability(estimate, measured, {});
  const uint64_t sampled = 80 * 32, cells_count = 20 * 16, control = 8 * 6;
  EXPECT_EQ(run.work.scalar_ops, 3 * sampled + 4 * static_cast<uint64_t>(accepted) + 32 + 2 * cells_count + 2 * cells_count + 2 * control +
                                     accumulator.work().scalar_ops + estimate.work.scalar_ops + map.work.scalar_ops);
  EXPECT_EQ(run.work.memory_bytes, 4ull * 160 * 32 + 4ull * static_cast<uint64_t>(accepted) + 4 * cells_count +
                                       4ull * (arm::kTerrainHeaderWords + control) + accumulator.work().memory_bytes +
                                       estimate.work.memory_bytes + map.work.memory_bytes);
}

TEST(TerrainEstimateTask, NoPointsGiveAnUnknownRecord) {
  Plane cells(40, 20, {ElementType::s32, 0}), heights(40, 20, {ElementType::s32, 0});
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < 40; ++u) cells.at<int32_t>(u, v) = -1;
  }
  const TaskRun run = run_task(cells, heights, kParams);
  const int32_t* record = run.record.row<const int32_t>(0);
  EXPECT_EQ(record[arm::kTerrainKnown], 0);
  EXPECT_EQ(record[arm::kTerrainReason], static_cast<int32_t>(arm::TerrainUnknownReason::too_few_cells));
  EXPECT_EQ(record[arm::kTerrainValidCells], 0);
  EXPECT_EQ(record[arm::kTerrainControlForward], 0);
  for (int w = arm::kTerrainHeaderWords; w < run.record.width(); ++w) EXPECT_EQ(record[w], 0);  // no made-up surface
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 16; ++j) EXPECT_EQ(run.cost.at<int32_t>(j, i), arm::kUnknownCostMilli);
  }
}

// A wall 5 m ahead filling the view: every point in forward row 10, at heights 0 .. 3 m. The fill
// would widen the row to three and a fit would make up a surface; the task says unknown.
TEST(TerrainEstimateTask, AWallGivesNoGroundExtent) {
  Plane cells(160, 64, {ElementType::s32, 0}), heights(160, 64, {ElementType::s32, 0});
  for (int v = 0; v < 64; ++v) {
    for (int u = 0; u < 160; ++u) {
      cells.at<int32_t>(u, v) = 10 * 16 + u * 16 / 160;
      heights.at<int32_t>(u, v) = 3000 - v * 3000 / 64;
    }
  }
  const TaskRun run = run_task(cells, heights, kParams);
  const int32_t* record = run.record.row<const int32_t>(0);
  EXPECT_EQ(record[arm::kTerrainKnown], 0);
  EXPECT_EQ(record[arm::kTerrainReason], static_cast<int32_t>(arm::TerrainUnknownReason::no_ground_extent));
  EXPECT_EQ(record[arm::kTerrainMeasuredCells], 16);
  EXPECT_EQ(run.cost.at<int32_t>(5, 10), arm::kUnknownCostMilli);
}

TEST(TerrainEstimateTaskMustFail, RefusesBadParametersAndShapes) {
  const ArmTaskDescriptor& task = terrain_task();
  auto message = [&](const nlohmann::json& params, PlaneShape second = {40, 20}) -> std::string {
    try {
      task.prepare(params, {{40, 20}, second});
    } catch (const KernelError& error) {
      return error.what();
    }
    return "accepted";
  };
  EXPECT_EQ(message({{"sample_step", 0}}), "parameter 'sample_step': expected an integer in [1, 64], got 0");
  EXPECT_EQ(message({{"control_forward", 3}}), "parameter 'control_forward': expected an integer in [4, 64], got 3");
  EXPECT_EQ(message(nlohmann::json::object(), {41, 20}), "input 'height': expected the size of 'cell' (40x20), got 41x20");
  EXPECT_NE(message({{"forward_min_m", 5.0}, {"forward_max_m", 5.0}}).find("grid parameters"), std::string::npos);
  EXPECT_NE(message({{"cell", 0.5}}).find("unknown parameter 'cell'"), std::string::npos);
  EXPECT_EQ(message(kParams), "accepted");
}

}  // namespace
}  // namespace lpstereo
