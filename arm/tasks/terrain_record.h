// The records the ARM task "terrain_estimate" writes (arm/tasks/terrain_estimate.cpp), fixed layout
// s32 words (BufferFormat {s32, 0}), so a consumer (a JSON writer, the next frame's planner, a
// delayed edge) reads them without parsing:
//
// "terrain": one row of kTerrainHeaderWords + control_forward * control_lateral words: the header
// below, then the control heights S_ij of the fitted B-spline surface in millimetres, row i
// (forward) major, in the vehicle frame of arm/terrain/terrain_model.h (x forward, y left, z up).
// The knots are not stored: they are clamped uniform over the area (forward_min .. forward_max,
// lateral_min .. lateral_max, the task's parameters), which the degrees and counts determine.
// known = 0: the terrain is unknown (reason word says why), every control word is 0, no surface.
//
// "cost": lateral_cells x forward_cells s32 (row i forward, column j lateral, the cell layout of
// TerrainGridSpec): the traversability cost Tc = w_occ occupancy + w_slope |grad S| in thousandths
// (round(1000 Tc)), kUnknownCostMilli where unknown. Tc is clamped to [0, 2e6] before scaling, so
// 1000 Tc <= 2e9 < 2^31 (a cost that large means a vertical surface; every real one is far below).
// The control heights are clamped to +-2e6 m the same way (+-2e9 mm).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "arm/terrain/terrain_model.h"
#include "kernels/kernel.h"

namespace lpstereo::arm {

enum TerrainRecordWord : int {
  kTerrainKnown = 0,             // 1: a fitted surface; 0: unknown
  kTerrainReason = 1,            // TerrainUnknownReason, 0 when known
  kTerrainValidCells = 2,        // measured + filled cells of the grid
  kTerrainMeasuredCells = 3,     // cells with at least one point
  kTerrainAcceptedPoints = 4,    // points summed into cells
  kTerrainSampledPixels = 5,     // pixels read (every sample_step-th row and column)
  kTerrainIterations = 6,        // re-weighting iterations run
  kTerrainEqualisedCells = 7,    // cells pulled down in the last iteration
  kTerrainMeanAbsErrorUm = 8,    // mean |Z - S| over valid cells, final fit, micrometres
  kTerrainOccupiedCells = 9,     // cells whose height is more than obstacle_height above S
  kTerrainDegreeForward = 10,
  kTerrainDegreeLateral = 11,
  kTerrainControlForward = 12,   // n0: control rows that follow (0 when unknown)
  kTerrainControlLateral = 13,   // n1
  kTerrainCellMm = 14,           // the grid's cell size, mm
  kTerrainHeaderWords = 16,      // control heights start here (word 15 is spare, 0)
};

enum class TerrainUnknownReason : int32_t {
  none = 0,
  too_few_cells = 1,   // fewer than min_valid_cells valid cells
  fit_refused = 2,     // fit_terrain returned known = false for another reason (line, singular, non-finite)
  no_ground_extent = 3,  // points in fewer than 4 forward rows or lateral columns of cells (a wall, a line)
};

inline constexpr int32_t kUnknownCostMilli = -1;

// The terrain area and the spline's shape: the params of every task that writes or reads a
// "terrain" record (forward_min_m, forward_max_m, lateral_min_m, lateral_max_m, cell_m,
// degree_forward, degree_lateral, control_forward, control_lateral), so that producer and consumer
// read them with the same defaults and ranges.
struct TerrainRecordShape {
  terrain::TerrainGridSpec grid;
  int degree_forward = 3, degree_lateral = 3, control_forward = 25, control_lateral = 25;
  int record_words() const { return kTerrainHeaderWords + control_forward * control_lateral; }
};

// Throws KernelError naming the parameter, its range and the value (the grid's own check too).
inline TerrainRecordShape terrain_record_shape_params(const nlohmann::json& params) {
  TerrainRecordShape shape;
  shape.grid.forward_min_m = param_double(params, "forward_min_m", 0.0, -1000.0, 1000.0);
  shape.grid.forward_max_m = param_double(params, "forward_max_m", 34.0, -1000.0, 1000.0);
  shape.grid.lateral_min_m = param_double(params, "lateral_min_m", -11.0, -1000.0, 1000.0);
  shape.grid.lateral_max_m = param_double(params, "lateral_max_m", 11.0, -1000.0, 1000.0);
  shape.grid.cell_m = param_double(params, "cell_m", 0.5, 0.016, 100.0);
  try {
    shape.grid.validate();
  } catch (const std::invalid_argument& error) {
    throw KernelError(std::string("grid parameters: ") + error.what());
  }
  shape.degree_forward = param_int(params, "degree_forward", 3, 1, 5);
  shape.degree_lateral = param_int(params, "degree_lateral", 3, 1, 5);
  shape.control_forward = param_int(params, "control_forward", 25, shape.degree_forward + 1, 64);
  shape.control_lateral = param_int(params, "control_lateral", 25, shape.degree_lateral + 1, 64);
  return shape;
}

}  // namespace lpstereo::arm
