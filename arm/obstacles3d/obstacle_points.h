// 3D obstacle representations (issue 10): what every method takes and what it reports, shared by
// the occupancy grids (Cartesian, column/disparity, polar), the augmented stixels, the voxel map with
// its clustering and tracking, and `lpstereo obstacles3d`.
//
// Input: the obstacle candidates, i.e. the terrain's outliers (arm/terrain/terrain_model.h,
// classify_points), each with its camera-frame and vehicle-frame position, its height above the
// fitted terrain, its stereo measurement (for the error model) and its colour. Frames: camera x right,
// y down, z forward; vehicle x forward, y left, z up (arm/point_cloud.h); metres.
//
// Ego-motion: the visual odometry's increment (arm/odometry/stereo_odometry.h) expressed in the
// vehicle frame, previous_from_current (a point fixed in the world: p_previous = T p_current). When
// it is unavailable, methods fall back to a static camera (identity) and say so in their status.
//
// Output: one Obstacle3d per detected obstacle, the fields of tracks.jsonl (issue 10 deliverable 6):
// position and size in the frame's camera frame, heights above the fitted terrain, velocity relative
// to the ground (ego-motion removed), in the camera frame's axes.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lpstereo::arm::obstacles3d {

struct ObstaclePoint {
  Eigen::Vector3f camera_m = Eigen::Vector3f::Zero();
  Eigen::Vector3f vehicle_m = Eigen::Vector3f::Zero();
  float height_above_ground_m = 0;  // above the fitted terrain surface, or the local ground seen under it (obstacle_candidates.h)
  float disparity_px = 0;           // the measurement behind the point (> 0)
  uint16_t u_px = 0, v_px = 0;      // left-image pixel
  std::array<uint8_t, 3> rgb{};     // R, G, B; a grey source repeats its value
};

// The stereo error model (the likelihoods of the grids): a disparity error of disparity_sigma_px
// gives a depth error sigma_Z = Z^2 sigma_d / (f B) and a lateral error sigma_X = Z sigma_u / f with
// sigma_u = pixel_sigma_px (Badino, Franke, Mester, "Free space computation using stochastic
// occupancy grids and dynamic programming", ICCV workshops 2007).
struct StereoErrorModel {
  double focal_px = 0;          // > 0
  double baseline_m = 0;        // > 0
  double disparity_sigma_px = 0.25;
  double pixel_sigma_px = 0.5;
  double depth_sigma_m(double depth_m) const { return depth_m * depth_m * disparity_sigma_px / (focal_px * baseline_m); }
  double lateral_sigma_m(double depth_m) const { return depth_m * pixel_sigma_px / focal_px; }
  // A bias of bias_px (not an error drawn anew each frame) puts a point short of its range Z by
  // about bias_px Z^2 / (f B); while the range changes at range_rate_mps that error changes at
  // 2 bias_px Z |range rate| / (f B), the rate a static point seems to move along its ray
  // (obstacle_tracking.h, "The range drift of a disparity bias").
  double range_drift_mps(double depth_m, double range_rate_mps, double bias_px) const {
    return 2 * bias_px * depth_m * std::abs(range_rate_mps) / (focal_px * baseline_m);
  }
  bool defined() const { return focal_px > 0 && baseline_m > 0; }  // false: no stereo terms
};

struct EgoMotion {
  bool available = false;  // false: static camera assumed (identity), reported by the method
  Eigen::Isometry3d previous_from_current = Eigen::Isometry3d::Identity();  // vehicle frames
};

struct Obstacle3d {
  int id = 0;                 // index within the frame
  int track_id = -1;          // persistent id across frames; -1 when the method does not track
  std::array<int, 4> bbox_px{-1, -1, -1, -1};  // x0, y0, x1, y1 inclusive, left image
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // centre, camera frame
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();      // width (x), height (y), length (z)
  double min_height_m = 0;    // lowest point above the terrain (a hanging obstacle's lower edge)
  double max_height_m = 0;    // highest point above the terrain
  Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();  // relative to the ground, camera axes
  bool moving = false;
};

}  // namespace lpstereo::arm::obstacles3d
