// lpstereo points LEFT RIGHT --calib C [--calib C2] -o cloud.ply [--ascii] [--min-disp M]
//     [--num-disp N] [--roll-rad R --pitch-rad P --yaw-rad Y --position-m X Y Z]
// The rectified pair (what `lpstereo rectify` writes, or a dataset's rectified views) through the
// disparity engine (defaults), the disparity_to_points kernel with the calibration's rectified
// geometry (focal length, baseline, principal point, Middlebury doffs), and out as a PLY point
// cloud of the valid pixels with the left image's colours (binary little-endian, or --ascii), in
// the camera frame, or in the vehicle frame when a mount is given (arm/point_cloud.h).
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace lpstereo::tools {

class PointsCommand {
 public:
  explicit PointsCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run() const;  // throws CommandError (one line) on bad input

 private:
  CLI::App* command_ = nullptr;
  std::string left_, right_, output_;
  std::vector<std::string> calibration_files_;
  bool ascii_ = false;
  int min_disparity_ = 0;
  int num_disparities_ = 64;
  double roll_rad_ = 0, pitch_rad_ = 0, yaw_rad_ = 0;
  std::vector<double> position_m_;
};

}  // namespace lpstereo::tools
