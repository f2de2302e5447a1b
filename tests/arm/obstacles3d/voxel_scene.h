// Hand-made obstacle candidate points for the voxel map, clustering and tracking tests: solid boxes of
// points at a regular spacing, seen by a level camera 1.5 m above flat ground (z = 0 in the vehicle
// frame, so a point's height above the ground is its vehicle z).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "arm/obstacles3d/obstacle_points.h"
#include "arm/point_cloud.h"

namespace lpstereo::arm::obstacles3d::test {

constexpr double kCameraHeightM = 1.5;
constexpr double kFocalPx = 500.0;

inline CameraMount test_mount() {
  CameraMount mount;
  mount.position_m = Eigen::Vector3d(0, 0, kCameraHeightM);
  return mount;
}

// A point given in the current vehicle frame, with its camera-frame position and its pixel (640x480).
inline ObstaclePoint make_point(const Eigen::Vector3d& vehicle_m, std::array<uint8_t, 3> rgb) {
  static const CameraToVehicle camera_to_vehicle(test_mount());
  const Eigen::Vector3d camera = camera_to_vehicle.rotation().transpose() * (vehicle_m - camera_to_vehicle.translation_m());
  ObstaclePoint point;
  point.vehicle_m = vehicle_m.cast<float>();
  point.camera_m = camera.cast<float>();
  point.height_above_ground_m = static_cast<float>(vehicle_m.z());
  point.disparity_px = camera.z() > 0 ? static_cast<float>(kFocalPx * 0.3 / camera.z()) : 0.0f;
  const double u = camera.z() > 0 ? kFocalPx * camera.x() / camera.z() + 319.5 : 0.0;
  const double v = camera.z() > 0 ? kFocalPx * camera.y() / camera.z() + 239.5 : 0.0;
  point.u_px = static_cast<uint16_t>(std::clamp(std::lround(u), 0L, 639L));
  point.v_px = static_cast<uint16_t>(std::clamp(std::lround(v), 0L, 479L));
  point.rgb = rgb;
  return point;
}

// Points filling the axis-aligned box [minimum, maximum] (vehicle frame) at spacing_m (0.0625 m: exact in binary, so points never sit on a voxel face by rounding), first point at
// minimum + spacing / 2 on each axis.
inline void add_box(std::vector<ObstaclePoint>& points, const Eigen::Vector3d& minimum_m, const Eigen::Vector3d& maximum_m,
                    std::array<uint8_t, 3> rgb, double spacing_m = 0.0625) {
  for (double x = minimum_m.x() + spacing_m / 2; x < maximum_m.x(); x += spacing_m) {
    for (double y = minimum_m.y() + spacing_m / 2; y < maximum_m.y(); y += spacing_m) {
      for (double z = minimum_m.z() + spacing_m / 2; z < maximum_m.z(); z += spacing_m) {
        points.push_back(make_point(Eigen::Vector3d(x, y, z), rgb));
      }
    }
  }
}

}  // namespace lpstereo::arm::obstacles3d::test
