// lpstereo terrain LEFT RIGHT --calib C [--calib C2] -o terrain.json [--area-m 34x22] [--cell-m 0.5]
//     [--control 25x25] [--degree 3] [--camera-height-m H [--pitch-deg P] [--roll-deg R]]
//     [--obstacle-height-m 0.2] [--discontinuity-radius 3] [--discontinuity-jump 2]
//     [--map FILE.png] [--points FILE.ply] [--overlay FILE.png]
//     [--threads N] [the disparity engine's options: --min-disp, --num-disp, --paths, ...]
// Issue 9 deliverable 5. The rectified pair through the disparity engine, the discontinuity filter
// (arm::invalidate_near_side_of_discontinuities: the near side of every disparity jump of more than
// --discontinuity-jump px, --discontinuity-radius px wide, is dropped: the fattened object edges,
// whose points would stand in the air beside the object; 0 turns it off; the settings issue 9's
// figures are measured with, bench/terrain_synth_eval), disparity_to_points, the
// camera mount, the point_cell_binning kernel into the 2.5D grid (arm/terrain_points.h), the
// iterative re-weighted B-spline fit, the traversability cost and the point classes
// (arm/terrain/terrain_model.h; docs/terrain.md "The terrain command").
//
// Area: --area-m FORWARDxLATERAL metres in the vehicle frame (x forward from the camera's foot,
// 0 .. FORWARD; y left, -LATERAL/2 .. LATERAL/2); --control N0xN1 control points of the final fit
// (the first iteration uses min(5, N)); --degree D for both directions.
// Mount: --camera-height-m H (camera above the ground under it) with --pitch-deg P (+ = looking down)
// and --roll-deg R (+ = the right side lower), or, without --camera-height-m, estimated from a RANSAC
// ground plane through the points of the lower image half (arm::estimate_ground_mount; the JSON's
// "mount.source" says which).
//
// terrain.json:
//   {"width", "height", "known", "reason" (null when known),
//    "mount": {"source": "given" | "estimated", "camera_height_m", "pitch_rad", "roll_rad",
//              "camera_to_vehicle": {"rotation": 3x3 rows, "translation_m": [x, y, z]}},
//    "grid": {"frame": "vehicle", "forward_min_m", "forward_max_m", "lateral_min_m", "lateral_max_m",
//             "cell_m", "forward_cells", "lateral_cells", "valid_cells", "measured_cells", "points"},
//    "spline": {"frame": "vehicle", "axes": "x forward, y left, z up, metres", "degree_forward",
//               "degree_lateral", "knots_forward_m", "knots_lateral_m", "control_z_m" (n0 rows of n1),
//               "control_weights" (null: polynomial), "domain_m": {...}, "iterations",
//               "equalised_cells_last", "mean_abs_error_m"} | null when unknown,
//    "cost_grid": {"frame": "vehicle", "forward_m" (cell centres, rows), "lateral_m" (centres,
//                  columns), "cost", "slope", "occupancy": rows of columns, null where unknown} | null,
//    "surface_grid": {"frame": "camera", "x_m": [...], "z_m": [...], "y_m": [[...]]}: y_m[i][j] the
//                    camera-frame y (down) of the surface at lateral x_m[j] and forward z_m[i], null
//                    where the surface is unknown (no data in that cell, outside the area, unknown terrain),
//    "obstacle_points_camera_m": [[x, y, z], ...] (more than --obstacle-height-m above the surface),
//    "point_counts": {"terrain", "obstacle", "outside"},
//    "discontinuity_filter": {"radius_px", "jump_px", "invalidated_px"} (radius 0: off, none invalidated)}
// Pictures: --map a top view of the cost grid (far at the top, left on the left: green 0 to red at
// cost >= 1, occupied cells magenta, unknown black); --overlay the left image with the terrain points
// green and the obstacle points red; --points a PLY of every point in the camera frame coloured by
// class (terrain green, obstacle red, outside the area grey; comment "classes: ..."). Every file is
// written atomically (temporary name, then rename).
//
// Exit status: 0 the terrain is known; 4 the terrain is unknown (too few valid cells, all points on
// a line, a wall filling the view, no ground plane for the mount estimate): terrain.json is written
// with "known": false and the reason, and that reason is the one line on stderr; 1 bad input (missing
// or unreadable files, a calibration without a baseline, sizes that differ): one line, no output
// file; 2 bad usage (flags and their values).
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "arm/terrain_points.h"
#include "tools/disparity_options.h"

namespace lpstereo::tools {

inline constexpr int kExitTerrainUnknown = 4;

class TerrainCommand {
 public:
  explicit TerrainCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run() const;  // throws CommandError (one line) on bad input

 private:
  CLI::App* command_ = nullptr;
  std::string left_, right_, output_;
  std::vector<std::string> calibration_files_;
  std::string area_m_ = "34x22", control_ = "25x25";
  double cell_m_ = 0.5;
  int degree_ = 3;
  double camera_height_m_ = 0, pitch_deg_ = 0, roll_deg_ = 0;
  double obstacle_height_m_ = 0.2;
  arm::DiscontinuityFilter discontinuity_filter_;
  std::string map_path_, points_path_, overlay_path_;
  DisparityEngineOptions engine_options_;
  int threads_ = 0;
};

}  // namespace lpstereo::tools
