// lpstereo eval middlebury|kitti: the disparity engine (and optionally OpenCV's StereoSGBM in its
// three modes) on the real pairs of the shared data folder, scored with io/disparity_metrics.h.
// lpstereo eval odometry TRAJ.txt POSES.txt: a trajectory against its ground truth (KITTI pose
// files), scored with io/odometry_metrics.h, optionally drawn (tools/trajectory_plot.h).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "tools/disparity_options.h"

namespace lpstereo::tools {

struct EvalOptions {
  std::string benchmark;           // "middlebury", "kitti" or "odometry"
  std::vector<std::string> files;  // odometry: the estimate and the ground truth (KITTI pose files)
  std::string data_directory;      // empty: io::shared_data_directory()
  std::string baseline;            // "" or "opencv"
  std::string json_path;           // empty: no JSON
  std::optional<int> num_disparities;   // overrides every pair's range
  std::optional<int> min_disparity_px;  // overrides every pair's range
  int threads = 0;                 // engine worker threads (0 = one per hardware thread)
  MultiresOptions multires;        // --multires on|off [--multires-far F]: the engine's multi-resolution mode
  std::string chip_target;         // --chip TARGET: also the chip configuration of TARGET's stereo unit; empty: not
  // odometry only
  std::vector<double> segment_lengths_m;  // --lengths; empty: io::automatic_segment_lengths_m
  std::optional<int> step_frames;         // --step; default 1
  std::string plot_path;                  // --plot: top view PNG; empty: none
};

int run_eval(const EvalOptions& options);

}  // namespace lpstereo::tools
