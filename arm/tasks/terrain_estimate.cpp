// ARM task "terrain_estimate": the ARM half of issue 9's terrain graph. Reads the two planes of the
// point_cell_binning kernel (each pixel's terrain cell and vehicle-frame height), sums the points
// per cell (arm::terrain::HeightGridAccumulator::add_to_cell), applies the 2.5D cell rule and the
// neighbour fill (finish), fits the B-spline surface with the iterative re-weighting and
// equalisation (fit_terrain) and computes the traversability cost (compute_traversability). Model
// and formulas: arm/terrain/terrain_model.h and its implementation files (thesis 004). Record
// layouts: arm/tasks/terrain_record.h.
//
// Steps, per frame:
//   1. every sample_step-th row and column of the cell plane (sample_step 1: every pixel; at 4K a
//      step of 4 still gives 4x the points of the thesis's 640x480 frames, and keeps the per-pixel
//      loop within the ARM budget): a pixel with cell >= 0 adds its height (mm -> m) to its cell;
//      cells outside this task's grid (a kernel configured for another area) are rejected;
//   2. finish(): cell height Z = max(min z, mean z - sigma), empty cells filled from valid
//      neighbours, else invalid;
//   3. fewer than min_valid_cells valid cells: unknown (reason too_few_cells), no fit; points in
//      fewer than 4 forward rows or 4 lateral columns of cells, each holding 1 % of them
//      (arm::ground_extent_problem: a wall filling the view, a line of points): unknown (reason
//      no_ground_extent), no fit; otherwise fit_terrain;
//      known = false from it: unknown (reason fit_refused);
//   4. known: compute_traversability against the grid of step 2; write the record and the cost grid.
//
// Ports: inputs "cell" s32 and "height" s32 (kernels/point_cell_binning.h, same size); outputs
// "terrain" s32 (kTerrainHeaderWords + control_forward * control_lateral) x 1 and "cost" s32
// lateral_cells x forward_cells.
//
// Parameters (units in the names): the grid, which must match the kernel's area and cell in mm:
// forward_min_m (default 0), forward_max_m (34), lateral_min_m (-11), lateral_max_m (11), cell_m
// (0.5); the fit (TerrainFitParameters): degree_forward, degree_lateral (3, 1 .. 5),
// control_forward, control_lateral (25, degree + 1 .. 64), initial_control_forward,
// initial_control_lateral (5), max_iterations (8, 0 .. 50), min_valid_cells (16); traversability:
// obstacle_height_m (0.2), occupancy_weight (1), slope_weight (1) (weights in [0, 1000]);
// sample_step (1, 1 .. 64).
//
// Counted work (deterministic, ArmWork), with S = ceil(W / step) ceil(H / step) sampled pixels of a
// W x H plane, A of them accepted (cell >= 0), C = forward_cells lateral_cells, n0 n1 control points:
//   scalar_ops   = 3 S (load cell, compare, branch) + 2 C (the extent check, when run) + 4 A (load height, split the index: divide and
//                  multiply-subtract, convert) + the accumulator's, fit's and traversability's own
//                  counted work (HeightGridAccumulator::work, TerrainEstimate::work,
//                  TraversabilityMap::work) + 2 C (writing the cost) + 2 n0 n1 + 32 (the record);
//   memory_bytes = 4 W ceil(H / step) (the sampled rows of the cell plane, whole cache lines: a
//                  step below 16 touches every line of a row) + 4 A (heights, scattered) + 4 C (cost)
//                  + 4 (kTerrainHeaderWords + n0 n1) (record) + the accumulator's, fit's and
//                  traversability's counted bytes.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "arm/tasks/terrain_record.h"
#include "arm/terrain_points.h"
#include "arm/terrain/terrain_model.h"
#include "dag/arm_task.h"

namespace lpstereo::arm {
namespace {

struct TerrainEstimateParams {
  terrain::TerrainGridSpec grid;
  terrain::TerrainFitParameters fit;
  terrain::TraversabilityParameters traversability;
  int sample_step = 1;
};

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"forward_min_m", "forward_max_m", "lateral_min_m", "lateral_max_m", "cell_m", "degree_forward",
                             "degree_lateral", "control_forward", "control_lateral", "initial_control_forward",
                             "initial_control_lateral", "max_iterations", "min_valid_cells", "obstacle_height_m",
                             "occupancy_weight", "slope_weight", "sample_step"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (cell, height), got " + std::to_string(input_shapes.size()));
  }
  if (input_shapes[0].width != input_shapes[1].width || input_shapes[0].height != input_shapes[1].height) {
    throw KernelError("input 'height': expected the size of 'cell' (" + std::to_string(input_shapes[0].width) + "x" +
                      std::to_string(input_shapes[0].height) + "), got " + std::to_string(input_shapes[1].width) + "x" +
                      std::to_string(input_shapes[1].height));
  }
  auto prepared = std::make_shared<TerrainEstimateParams>();
  TerrainEstimateParams& p = *prepared;
  const TerrainRecordShape shape = terrain_record_shape_params(params);
  p.grid = shape.grid;
  p.fit.degree_forward = shape.degree_forward;
  p.fit.degree_lateral = shape.degree_lateral;
  p.fit.control_forward = shape.control_forward;
  p.fit.control_lateral = shape.control_lateral;
  p.fit.initial_control_forward = param_int(params, "initial_control_forward", std::min(5, p.fit.control_forward),
                                            p.fit.degree_forward + 1, p.fit.control_forward);
  p.fit.initial_control_lateral = param_int(params, "initial_control_lateral", std::min(5, p.fit.control_lateral),
                                            p.fit.degree_lateral + 1, p.fit.control_lateral);
  p.fit.max_iterations = param_int(params, "max_iterations", 8, 0, 50);
  p.fit.min_valid_cells = param_int(params, "min_valid_cells", 16, 1, 1 << 24);
  p.traversability.obstacle_height_m = param_double(params, "obstacle_height_m", 0.2, 0.0, 100.0);
  p.traversability.occupancy_weight = param_double(params, "occupancy_weight", 1.0, 0.0, 1000.0);
  p.traversability.slope_weight = param_double(params, "slope_weight", 1.0, 0.0, 1000.0);
  p.sample_step = param_int(params, "sample_step", 1, 1, 64);
  const int record_words = kTerrainHeaderWords + p.fit.control_forward * p.fit.control_lateral;
  return PreparedKernel{prepared, {{record_words, 1}, {p.grid.lateral_cells(), p.grid.forward_cells()}}};
}

int32_t to_milli(double value) { return static_cast<int32_t>(std::lround(1000.0 * value)); }

void run(const ArmTaskArgs& args) {
  const auto& p = *static_cast<const TerrainEstimateParams*>(args.params);
  const Plane& cells = *args.inputs.at(0);
  const Plane& heights = *args.inputs.at(1);
  Plane& record_plane = *args.outputs.at(0);
  Plane& cost_plane = *args.outputs.at(1);
  const int lateral_cells = p.grid.lateral_cells();
  const int forward_cells = p.grid.forward_cells();

  // 1. Accumulate the sampled pixels.
  terrain::HeightGridAccumulator accumulator(p.grid);
  uint64_t sampled = 0, accepted_pixels = 0;
  for (int y = 0; y < cells.height(); y += p.sample_step) {
    const int32_t* cell_row = cells.row<const int32_t>(y);
    const int32_t* height_row = heights.row<const int32_t>(y);
    for (int x = 0; x < cells.width(); x += p.sample_step) {
      ++sampled;
      const int32_t cell = cell_row[x];
      if (cell < 0) continue;
      ++accepted_pixels;
      accumulator.add_to_cell(cell / lateral_cells, cell % lateral_cells, height_row[x] / 1000.0);
    }
  }
  // 2. The cell rule and the fill.
  const terrain::HeightGrid grid = accumulator.finish();
  ArmWork work = accumulator.work();

  // 3. Fit, or unknown.
  int32_t* record = record_plane.row<int32_t>(0);
  std::memset(record, 0, sizeof(int32_t) * static_cast<size_t>(record_plane.width()));
  for (int i = 0; i < forward_cells; ++i) {
    int32_t* cost_row = cost_plane.row<int32_t>(i);
    for (int j = 0; j < lateral_cells; ++j) cost_row[j] = kUnknownCostMilli;
  }
  int measured = 0;
  for (int i = 0; i < forward_cells; ++i) {
    for (int j = 0; j < lateral_cells; ++j) measured += grid.state(i, j) == terrain::kCellMeasured;
  }
  record[kTerrainValidCells] = grid.valid_cells();
  record[kTerrainMeasuredCells] = measured;
  record[kTerrainAcceptedPoints] = static_cast<int32_t>(accumulator.accepted());
  record[kTerrainSampledPixels] = static_cast<int32_t>(std::min<uint64_t>(sampled, 0x7FFFFFFF));
  record[kTerrainDegreeForward] = p.fit.degree_forward;
  record[kTerrainDegreeLateral] = p.fit.degree_lateral;
  record[kTerrainCellMm] = to_milli(p.grid.cell_m);
  uint64_t ops = 3 * sampled + 4 * accepted_pixels + 32;
  const uint64_t cell_count = static_cast<uint64_t>(forward_cells) * static_cast<uint64_t>(lateral_cells);
  const bool enough_cells = grid.valid_cells() >= p.fit.min_valid_cells;
  if (enough_cells) ops += 2 * cell_count;  // the extent check sums every cell's count twice
  const bool ground_extent = enough_cells && ground_extent_problem(grid).empty();
  if (!enough_cells) {
    record[kTerrainReason] = static_cast<int32_t>(TerrainUnknownReason::too_few_cells);
  } else if (!ground_extent) {
    record[kTerrainReason] = static_cast<int32_t>(TerrainUnknownReason::no_ground_extent);
  } else {
    const terrain::TerrainEstimate estimate = terrain::fit_terrain(grid, p.fit);
    work += estimate.work;
    record[kTerrainIterations] = estimate.iterations;
    record[kTerrainEqualisedCells] = estimate.equalised_cells_last;
    if (!estimate.known) {
      record[kTerrainReason] = static_cast<int32_t>(TerrainUnknownReason::fit_refused);
    } else {
      // 4. Traversability and the record.
      const terrain::TraversabilityMap map = terrain::compute_traversability(estimate, grid, p.traversability);
      work += map.work;
      record[kTerrainKnown] = 1;
      record[kTerrainMeanAbsErrorUm] = static_cast<int32_t>(std::lround(std::min(1e6 * estimate.mean_abs_error_m, 2e9)));
      const auto& control = estimate.surface.control_z_m;
      record[kTerrainControlForward] = static_cast<int32_t>(control.rows());
      record[kTerrainControlLateral] = static_cast<int32_t>(control.cols());
      const int64_t control_words = static_cast<int64_t>(control.rows()) * control.cols();
      if (kTerrainHeaderWords + control_words > record_plane.width()) {
        throw KernelError("output 'terrain': expected at most " + std::to_string(record_plane.width() - kTerrainHeaderWords) +
                          " control points, the fit returned " + std::to_string(control_words));
      }
      for (int i = 0; i < control.rows(); ++i) {
        for (int j = 0; j < control.cols(); ++j) {
          record[kTerrainHeaderWords + i * control.cols() + j] = to_milli(std::clamp(control(i, j), -2e6, 2e6));
        }
      }
      int occupied = 0;
      for (int i = 0; i < forward_cells; ++i) {
        int32_t* cost_row = cost_plane.row<int32_t>(i);
        for (int j = 0; j < lateral_cells; ++j) {
          const double cost = map.cost(i, j);
          if (std::isfinite(cost)) cost_row[j] = to_milli(std::clamp(cost, 0.0, 2e6));
          occupied += map.occupancy(i, j) == 1.0;
        }
      }
      record[kTerrainOccupiedCells] = occupied;
      ops += 2ull * static_cast<uint64_t>(forward_cells) * static_cast<uint64_t>(lateral_cells) + 2ull * static_cast<uint64_t>(control_words);
    }
  }
  if (args.work != nullptr) {
    work.scalar_ops += ops;
    work.memory_bytes += 4ull * static_cast<uint64_t>(cells.width()) * ((static_cast<uint64_t>(cells.height()) + p.sample_step - 1) / p.sample_step) +
                         4ull * accepted_pixels + 4ull * static_cast<uint64_t>(forward_cells) * static_cast<uint64_t>(lateral_cells) +
                         4ull * static_cast<uint64_t>(record_plane.width());
    *args.work += work;
  }
}

ArmTaskDescriptor make_terrain_estimate() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "terrain_estimate";
  descriptor.summary =
      "2.5D height grid from the binned points, iterative re-weighted B-spline terrain fit with equalisation, traversability cost";
  descriptor.ports = {{"cell", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"height", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"terrain", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole},
                      {"cost", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(terrain_estimate, lpstereo::arm::make_terrain_estimate);
