// lpstereo synth -o DIR [--width W --height H --hfov-deg A --baseline-m B --camera-height-m H
//     --pitch-deg P --roll-deg R --slope-deg S --ground flat|hills+ditch+berm+rough [--hills-amplitude-m ...]
//     --noise-sigma N --gain G --offset O --seed S --samples N --colour
//     --threads T] [--lineup DIST_M | --empty]
// A rendered rectified stereo pair with exact ground truth into a folder (io/stereo_synth.h,
// docs/synth.md): left.png, right.png, disparity.png (KITTI), object_ids.png, objects.json,
// ground.json, calib.yaml, calib_cam_to_cam.txt. The scene: random objects on the road (by --seed), the range-test
// row of objects at a distance (--lineup), or no objects (--empty).
//
// lpstereo synth --flight -o DIR [--frames N | --fps F] [--yaw none|corners:DEG[,DEG,DEG,DEG]|continuous:DEG_S]
//     [--side-m L --altitude-m A --start-height-m H --speed-mps V --focal-px F --disparity] (+ the shared
//     --width --height --hfov-deg --baseline-m --noise-sigma --gain --offset --seed --samples --threads)
// A downward-looking drone flight (io/stereo_flight.h): left/ and right/ frames, poses.txt (KITTI),
// times.txt, heights.txt, calib.txt (KITTI odometry P0 P1), calib.yaml, flight.json.
//
// lpstereo synth --sequence urban|country|mining|floating -o DIR [--frames N] [--fps F]
//     [--camera-speed-mps V] [--camera-yaw-rate-deg-s R] [--colour] (+ the camera and sensor options;
//     --ground replaces the preset's ground)
// A sequence driving through a preset scene with moving objects (io/stereo_sequence.h): left/,
// right/, disparity/, object_ids/ frames, poses.txt (KITTI), truth.jsonl, calib files.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "io/stereo_flight.h"
#include "io/stereo_sequence.h"
#include "io/stereo_synth.h"

namespace lpstereo::tools {

class SynthCommand {
 public:
  explicit SynthCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run();  // throws CommandError (one line) on bad input

 private:
  int run_flight();
  int run_sequence();
  // --pitch-deg, --roll-deg into target (one-line errors in degrees); --ground (when parse_ground) and
  // the ground sizes given.
  void apply_mount_and_ground(io::StereoSynthOptions& target, bool parse_ground) const;

  CLI::App* command_ = nullptr;
  CLI::Option* lineup_option_ = nullptr;
  std::string output_;
  io::StereoSynthOptions options_;
  double pitch_deg_ = 0;
  double roll_deg_ = 0;
  std::string ground_spec_ = "flat";
  std::string surface_ = "textured";  // --surface, io::parse_synth_road_surface
  bool real_camera_ = false;          // --real-camera: io::use_real_camera_pair under the options given
  io::SynthRoadSurface road_surface() const;
  // --real-camera: io::use_real_camera_pair, then the sensor and lens options the user gave on top.
  void apply_real_camera();
  // --hills-amplitude-m ...: each option writes into its field of ground_sizes_given_ and, when
  // given, replaces that field of the --ground kind's defaults.
  std::vector<std::pair<CLI::Option*, double io::SynthGround::*>> ground_sizes_;
  io::SynthGround ground_sizes_given_;
  double lineup_m_ = 0;
  bool empty_ = false;
  // --flight
  bool flight_ = false;
  io::StereoFlightOptions flight_options_;
  std::string yaw_spec_ = "none";
  double focal_px_ = 0;  // 0: from --hfov-deg
  bool flight_disparity_ = false;
  std::vector<CLI::Option*> road_only_, flight_only_;
  // --sequence
  std::string sequence_;
  double camera_speed_mps_ = 0;
  double camera_yaw_rate_deg_s_ = 0;
  std::vector<CLI::Option*> sequence_only_;
};

}  // namespace lpstereo::tools
