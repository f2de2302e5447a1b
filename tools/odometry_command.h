// lpstereo odometry --left 'dir/%06d.png' --right 'dir/%06d.png' --calib C [--calib C2] -o TRAJ.txt
//     [--first N] [--frames N] [--stats STATS.jsonl] [--threads N] [tuning flags]
// Stereo visual odometry (arm/odometry/stereo_odometry.h, docs/odometry.md) over a rectified image
// sequence: frames --first (default 0), --first + 1, ... until the first frame whose left or right
// file is missing, or --frames frames (each pattern holds one printf integer conversion), read through
// the image-sequence source (io/camera/file_source.h) as `lpstereo obstacles` sequence mode reads them.
// The calibration's rectified geometry gives the focal length, principal point and baseline.
// Output: the trajectory in the KITTI odometry pose format (io/kitti_poses.h: one line per frame, the
// 3x4 camera-to-first-frame matrix row-major), written atomically once every frame is done; with
// --stats one JSON line per frame {"frame", "valid", "confidence", "left_features", "right_features",
// "stereo_matches", "circle_matches", "inliers", "reprojection_rms_px", "predicted", "hamming_distances",
// "arm_scalar_ops"} (the counted ARM-side work, arm/odometry/stereo_odometry.h). A progress bar on
// stderr when it is a terminal; a summary line (frames, invalid frames, path length, mean inliers,
// mean ms per frame).
// Tuning flags (defaults from arm::StereoOdometryParameters, the single source): --harris-threshold,
// --cell-size, --per-cell, --max-hamming, --ratio, --epipolar-tolerance, --max-disparity,
// --predicted-radius, --search-radius, --ransac-iterations, --inlier-threshold, --min-inliers.
// Bad input (no first frame, a pattern without one %d, the size changing mid-sequence, a calibration
// that is missing, unreadable or without a baseline): one line, exit 1 (2 for bad usage), no output.
// Frames whose motion cannot be estimated (textureless views) are not errors: the pose is held, the
// frame is counted as invalid in the summary and in --stats.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "arm/odometry/stereo_odometry.h"

namespace lpstereo::tools {

class OdometryCommand {
 public:
  explicit OdometryCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run() const;  // throws CommandError (one line) on bad input

 private:
  CLI::App* command_ = nullptr;
  std::string left_pattern_, right_pattern_, output_, stats_path_;
  std::vector<std::string> calibration_files_;
  int first_frame_ = 0;
  int frame_limit_ = 0;  // 0: until the first missing frame
  int threads_ = 2;
  arm::StereoOdometryParameters parameters_;  // the tuning flags write into it; defaults are its own
};

}  // namespace lpstereo::tools
