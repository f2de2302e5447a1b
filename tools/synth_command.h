// lpstereo synth -o DIR [--width W --height H --hfov-deg A --baseline-m B --camera-height-m H
//     --pitch-deg P --slope-deg S --noise-sigma N --gain G --offset O --seed S --samples N --colour
//     --threads T] [--lineup DIST_M | --empty]
// A rendered rectified stereo pair with exact ground truth into a folder (io/stereo_synth.h,
// docs/synth.md): left.png, right.png, disparity.png (KITTI), object_ids.png, objects.json,
// calib.yaml, calib_cam_to_cam.txt. The scene: random objects on the road (by --seed), the range-test
// row of objects at a distance (--lineup), or no objects (--empty).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "io/stereo_synth.h"

namespace lpstereo::tools {

class SynthCommand {
 public:
  explicit SynthCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run();  // throws CommandError (one line) on bad input

 private:
  CLI::App* command_ = nullptr;
  CLI::Option* lineup_option_ = nullptr;
  std::string output_;
  io::StereoSynthOptions options_;
  double pitch_deg_ = 0;
  double lineup_m_ = 0;
  bool empty_ = false;
};

}  // namespace lpstereo::tools
