// lpstereo eval middlebury|kitti: the disparity engine (and optionally OpenCV's StereoSGBM in its
// three modes) on the real pairs of the shared data folder, scored with io/disparity_metrics.h.
#pragma once

#include <optional>
#include <string>

namespace lpstereo::tools {

struct EvalOptions {
  std::string benchmark;           // "middlebury" or "kitti"
  std::string data_directory;      // empty: io::shared_data_directory()
  std::string baseline;            // "" or "opencv"
  std::string json_path;           // empty: no JSON
  std::optional<int> num_disparities;   // overrides every pair's range
  std::optional<int> min_disparity_px;  // overrides every pair's range
  int threads = 0;                 // engine worker threads (0 = one per hardware thread)
};

int run_eval(const EvalOptions& options);

}  // namespace lpstereo::tools
