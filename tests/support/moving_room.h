// A rendered stereo sequence with a known camera trajectory, for the odometry tests (no data files):
// a textured box room (floor, ceiling, side walls, a far wall; io::synthetic_texture_grey, the texture
// of the built-in scene) seen by a rectified pinhole pair, ray cast with 2 x 2 samples per pixel.
// World frame = the first camera's (x right, y down, z forward, metres).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "dag/plane.h"
#include "io/synthetic_scene.h"

namespace lpstereo::testing::moving_room {

constexpr int kWidth = 480, kHeight = 240;
constexpr double kFocalPx = 300.0, kBaselineM = 0.3;
constexpr double kCxPx = (kWidth - 1) / 2.0, kCyPx = (kHeight - 1) / 2.0;

// The room: planes n . X = d in world coordinates (world = the first camera's frame), each with its
// own texture seed; texture coordinates are the two in-plane world axes, 40 texture units per metre.
struct Wall {
  int axis;       // 0: x = offset, 1: y = offset, 2: z = offset
  double offset;  // metres
  uint32_t seed;
};
inline const std::vector<Wall> kRoom = {{0, -4.0, 11}, {0, 4.0, 12}, {1, 1.6, 13}, {1, -3.0, 14}, {2, 30.0, 15}};

// An optional textured panel in the room, facing the camera: the rectangle z = z_m, x in [x0_m, x1_m],
// y in [y0_m, y1_m] (world); its texture is fixed to it (coordinates from its corner (x0_m, y0_m)), so
// moving the rectangle moves the texture: a rigid moving object.
struct Panel {
  double z_m, x0_m, x1_m, y0_m, y1_m;
  uint32_t seed = 16;
};

inline double scene_grey(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, const Panel* panel = nullptr) {
  double nearest = std::numeric_limits<double>::infinity();
  double grey = 0;
  if (panel != nullptr && std::abs(direction.z()) > 1e-12) {
    const double distance = (panel->z_m - origin.z()) / direction.z();
    const Eigen::Vector3d hit = origin + distance * direction;
    if (distance > 0 && hit.x() >= panel->x0_m && hit.x() <= panel->x1_m && hit.y() >= panel->y0_m && hit.y() <= panel->y1_m) {
      nearest = distance;
      grey = io::synthetic_texture_grey(40.0 * (hit.x() - panel->x0_m), 40.0 * (hit.y() - panel->y0_m), panel->seed, 128.0);
    }
  }
  for (const Wall& wall : kRoom) {
    const double along = direction[wall.axis];
    if (std::abs(along) < 1e-12) continue;
    const double distance = (wall.offset - origin[wall.axis]) / along;
    if (distance <= 0 || distance >= nearest) continue;
    nearest = distance;
    const Eigen::Vector3d hit = origin + distance * direction;
    const int s_axis = (wall.axis + 1) % 3, t_axis = (wall.axis + 2) % 3;
    grey = io::synthetic_texture_grey(40.0 * hit[s_axis], 40.0 * hit[t_axis], wall.seed, 128.0);
  }
  return grey;
}

// Renders the view of the camera at `pose` (camera to world); right = true: the right camera,
// baseline_m along the camera's x axis. 2 x 2 samples per pixel. panel: the optional moving object.
inline Plane render(const Eigen::Isometry3d& pose, bool right, const Panel* panel = nullptr) {
  Plane image(kWidth, kHeight, {ElementType::u8, 0}, kWidth + 24);
  const Eigen::Vector3d origin = pose * Eigen::Vector3d(right ? kBaselineM : 0.0, 0, 0);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      double sum = 0;
      for (double sy : {-0.25, 0.25}) {
        for (double sx : {-0.25, 0.25}) {
          const Eigen::Vector3d ray((x + sx - kCxPx) / kFocalPx, (y + sy - kCyPx) / kFocalPx, 1.0);
          sum += scene_grey(origin, pose.linear() * ray.normalized(), panel);
        }
      }
      image.at<uint8_t>(x, y) = static_cast<uint8_t>(std::clamp(std::lround(sum / 4.0), 0L, 255L));
    }
  }
  return image;
}

// The camera's pose at frame i: forward 0.4 m per frame, drifting 0.05 m right and 0.02 m up per
// frame, turning 1 degree left (yaw about y) and pitching 0.3 degree per frame.
inline Eigen::Isometry3d true_pose(int frame) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(0.05 * frame, -0.02 * frame, 0.4 * frame);
  pose.linear() = (Eigen::AngleAxisd(-frame * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(0.3 * frame * M_PI / 180.0, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  return pose;
}

// The view of frame `frame` of true_pose()'s trajectory, rendered once per test program (the tests
// revisit the same frames; single-threaded use).
inline const Plane& view_at_frame(int frame, bool right) {
  static std::map<std::pair<int, bool>, Plane> rendered;
  const auto key = std::make_pair(frame, right);
  auto found = rendered.find(key);
  if (found == rendered.end()) found = rendered.emplace(key, render(true_pose(frame), right)).first;
  return found->second;
}

}  // namespace lpstereo::testing::moving_room
