// lpstereo obstacles LEFT RIGHT --calib C [--calib C2] -o OBST.json [--overlay FILE.png] [--grid FILE.png]
//     [--mask FILE.png] [--vdisp FILE.png] [--min-disp M --num-disp N --paths ... (the disparity options)]
// The rectified pair through the disparity engine, then the obstacle detector (arm/obstacle_detector.h)
// with the calibration's rectified focal length, baseline and principal point. Output (issue 6):
//   {"width", "height",
//    "road": {"valid", "carried", "confidence", "slope_px_per_row", "intercept_px", "horizon_row_px",
//             "camera_height_m", "pitch_rad", "inlier_rows", "point_rows", "rms_residual_px"}
//            -- only {"valid": false, "confidence"} when there is no road: never a made-up one,
//    "obstacles": [{"id", "bbox_px": [x0, y0, x1, y1], "disparity", "distance_m", "position_m": [x, y, z],
//                   "width_m", "height_m", "pixels", "features", "track_id", "velocity_mps"}]}
// camera frame (x right, y down, z forward), metres; position_m is the bounding box's bottom centre
// (the foot); bbox_px inclusive. "features": the Harris corners that validated the obstacle (null
// with --feature-validation false). Single-frame mode: "track_id" and "velocity_mps" are null (not
// tracked). The matcher's defaults are arm::obstacle_disparity_defaults(), the detector's tuning.
// Pictures: --overlay the left image with the boxes coloured by distance and labelled; --grid the
// Advanced U-disparity grid as a top view (far at the top; cell value in grey, occupied cells white,
// each obstacle's cells in its colour); --mask the VLDH mask (black no vote, green free, red obstacle);
// --vdisp the V-disparity image with the fitted road line.
// Tuning flags (defaults from arm::ObstacleParameters, the single source): --near-height-m,
// --far-height-m, --switch-distance-m, --min-width-m, --min-cells, --min-pixels, --columns-per-cell,
// --grid-rows, --grid-k, --obstacle-weight, --free-weight, --vldh-rows, --vldh-min-count,
// --vldh-tolerance-q4, --road-margin-q4, --road-margin-per-mille, --feature-validation,
// --harris-threshold, --min-features, --mask-radius.
// Bad input (missing or unreadable files, a calibration without a baseline, image sizes that differ):
// one line and exit 1 (2 for bad usage), no output file. An all-invalid disparity map or a scene
// without a road (sky, wall): the road's confidence and an empty obstacle list, exit 0.
//
// Sequence mode: lpstereo obstacles --left 'dir/%06d.png' --right 'dir/%06d.png' --calib C
//     -o TRACKS.jsonl [--first N] [--frames N] [--fps F] [the disparity and tuning options]
// Frames --first (default 0), --first + 1, ... until the first frame whose left or right file is
// missing, or --frames frames; each pattern holds one printf integer conversion (%d, %06d, ...). The
// detector runs with tracking (arm/tasks/obstacle_tracker.cpp) at a frame period of 1 / --fps
// (default 30). Output: JSON lines, one object per frame,
//   {"frame": index, "width", "height", "road": {...}, "obstacles": [...]}
// with the single-frame fields, "track_id" (>= 1; 0 = not tracked, the tracker full) and
// "velocity_mps": [vx, vy, vz] (camera frame, m/s; 0 until the track has min_hits_for_velocity
// measurements, vy always 0: ground-plane filter). Written atomically once every frame is done; a
// progress bar on stderr when it is a terminal; a summary line (frames, tracks, mean ms per frame).
// Bad input (no first frame, a pattern without one %d, the size changing mid-sequence, LEFT RIGHT
// given with --left/--right, single-frame pictures asked for): one line, non-zero exit, no output file.
#pragma once

#include <CLI/CLI.hpp>

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "arm/obstacle_detector.h"
#include "io/rectification.h"
#include "tools/disparity_options.h"

namespace lpstereo::tools {

// Shared with `lpstereo run --graph obstacles` (tools/run_command.h), so both write the same records.
// The output object of one frame: single-frame mode's file, one line of sequence mode's (with "frame").
nlohmann::json obstacle_frame_json(int width, int height, const arm::ObstacleFrame& frame, const arm::ObstacleParameters& parameters);
// The calibration must give what the detector needs: a baseline and a pinhole rectification
// (CommandError naming the calibration files otherwise).
void check_obstacle_geometry(const io::RectifiedGeometry& geometry, const std::vector<std::string>& calibration_files);
// The detector's parameters (the tuning flags' values) with the calibration's camera and the
// engine's search range.
// The detector's tuning flags (--near-height-m ... --mask-radius, listed above), writing into `parameters`
// (their defaults are its own).
void add_obstacle_tuning_options(CLI::App& command, arm::ObstacleParameters& parameters);
arm::ObstacleParameters detector_parameters_for(arm::ObstacleParameters parameters, const io::RectifiedGeometry& geometry,
                                                const arm::DisparityParameters& disparity_parameters);

class ObstaclesCommand {
 public:
  explicit ObstaclesCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run() const;  // throws CommandError (one line) on bad input

 private:
  int run_single_frame() const;
  int run_sequence() const;

  CLI::App* command_ = nullptr;
  std::string left_, right_, output_;
  std::vector<std::string> calibration_files_;
  std::string overlay_path_, grid_path_, mask_path_, vdisp_path_;
  DisparityEngineOptions engine_options_{arm::obstacle_disparity_defaults()};
  arm::ObstacleParameters detector_parameters_;  // the tuning flags write into it; defaults are its own
  int threads_ = 0;
  // Sequence mode.
  std::string left_pattern_, right_pattern_;
  int first_frame_ = 0;
  int frame_limit_ = 0;  // 0: until the first missing frame
  double fps_ = 30.0;
};

}  // namespace lpstereo::tools
