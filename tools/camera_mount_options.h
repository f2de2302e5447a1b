// The camera mount as the commands that need the vehicle frame take it (`lpstereo obstacles3d`):
// --camera-height-m H (the camera centre above the ground under it), --pitch-deg P (+ = looking
// down) and --roll-deg R (+ = the right side lower), the flags and conventions of `lpstereo terrain`.
// The mount is arm::CameraMount (arm/point_cloud.h): p_vehicle = Rz(yaw) Ry(pitch) Rx(roll) C
// p_camera + (0, 0, H), vehicle x forward, y left, z up, origin on the ground under the camera.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
#include <string>

#include "arm/point_cloud.h"
#include "tools/command_error.h"

namespace lpstereo::tools {

struct CameraMountOptions {
  double camera_height_m = 1.5;  // the synthetic scenes' and a car roof's camera height
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
};

inline void add_camera_mount_options(CLI::App& command, CameraMountOptions& options) {
  command.add_option("--camera-height-m", options.camera_height_m, "camera centre above the ground under it, m")
      ->capture_default_str();
  command.add_option("--pitch-deg", options.pitch_deg, "camera pitch, degrees, + = looking down")->capture_default_str();
  command.add_option("--roll-deg", options.roll_deg, "camera roll, degrees, + = the right side lower")->capture_default_str();
}

// Throws CommandError(kExitUsage, "<flag>: expected ..., got ...") for a height outside (0, 100] m or
// an angle outside [-90, 90] degrees.
inline arm::CameraMount camera_mount_from(const CameraMountOptions& options) {
  if (!(options.camera_height_m > 0 && options.camera_height_m <= 100)) {
    throw CommandError(kExitUsage, "--camera-height-m: expected a height in (0, 100] m, got " + std::to_string(options.camera_height_m));
  }
  for (const auto& [flag, value] : {std::pair{"--pitch-deg", options.pitch_deg}, std::pair{"--roll-deg", options.roll_deg}}) {
    if (!(std::abs(value) <= 90)) {
      throw CommandError(kExitUsage, std::string(flag) + ": expected an angle in [-90, 90] degrees, got " + std::to_string(value));
    }
  }
  arm::CameraMount mount;
  mount.pitch_rad = options.pitch_deg * M_PI / 180.0;
  mount.roll_rad = options.roll_deg * M_PI / 180.0;
  mount.position_m = Eigen::Vector3d(0, 0, options.camera_height_m);
  return mount;
}

}  // namespace lpstereo::tools
