// The ego-motion the obstacle methods get from a visual odometry that can drop frames (issue 10:
// "No ego-motion available (fall back to static-camera assumptions and say so)").
//
// arm::StereoOdometry (arm/odometry/stereo_odometry.h) reports a frame invalid when fewer than
// min_inliers circle matches survive: a view filled by a near object, the camera passing under a
// sign, a texture-poor stretch. The odometry then holds its pose, and a method fed no ego-motion
// assumes a static camera for that frame. On a moving vehicle that is a jump: every static object
// seems to step one frame's travel towards the camera (1.2 m at 12 m/s and 10 Hz) in the world frame
// the voxel map, the grids and the tracker keep, and the tracker's Kalman filter turns the step into
// a speed that flags static objects "moving" for several frames. Measured on the preset sequences
// (bench/obstacles3d_eval, seed 3, 300 frames): a one-frame dropout in country (frame 39) flagged a
// static bin moving in frames 40-44 (-1.4 m/s; 0.0 +- 0.1 m/s with the true ego-motion); four in
// floating (frames 36-39, the camera under the hanging sign: 0-11 stereo matches) gave 36 false flags
// of 140 static object-frames in the first 70 frames against 17 with the true ego-motion.
//
// So a dropout after a valid increment is bridged by the constant-velocity model (the last valid
// increment again), the prediction the odometry itself uses to search its next matches and the
// motion model of a vehicle over a fraction of a second (at 2 m/s^2 the position error after 0.5 s
// is 0.25 m, against 6 m travelled at 12 m/s); after more than max_extrapolated_frames dropouts in a
// row, or when no increment was ever valid, the camera is assumed static, as the issue asks, and the
// note says which.
//
// An increment the odometry calls valid can still be wrong where it just recovered: on urban seed 1
// the first increment after the dropout of frames 38-40 (the camera under a near object) was 0.80 m
// off the true one, a whole frame's travel at 8 m/s, against a median error of 5 mm. A vehicle's
// velocity cannot change that fast: between two frames dt apart its translation per frame changes
// by at most a dt^2 (a = max_acceleration_mps2, 10 m/s^2 ~ 1 g, a road vehicle's braking limit),
// after k bridged frames by a dt^2 (k + 1). An increment whose translation differs from the last
// valid one by more than that plus increment_noise_m (the odometry's own error: 95th percentile 1-6
// cm per frame on the preset sequences, up to 10 cm) is implausible and treated as a dropout,
// unless the next increment agrees with it (within one frame's bound): two in a row are a real change,
// or the accepted one was the outlier, and the second is accepted.
//
// The increment is converted to the vehicle frame, V E V^-1 (V = vehicle_from_camera,
// arm/point_cloud.h), the form EgoMotion holds (obstacle_points.h).
#pragma once

#include <string>

#include <Eigen/Geometry>

#include "arm/obstacles3d/obstacle_points.h"

namespace lpstereo::arm::obstacles3d {

enum class EgoMotionSource {
  first_frame,    // nothing to compare with yet: no ego-motion
  odometry,       // the odometry's increment
  extrapolated,   // an odometry dropout bridged with the last valid increment
  static_camera,  // no valid increment to bridge with (or the dropout too long): static camera assumed
};
const char* ego_motion_source_name(EgoMotionSource source);

struct OdometryEgoMotionParameters {
  double frame_period_s = 0.1;        // (0, 10] s
  int max_extrapolated_frames = 5;    // dropouts in a row bridged, [0, 100] (0: every dropout is a static frame)
  double max_acceleration_mps2 = 10;  // plausibility bound (header), [0, 1000]; 0: every valid increment accepted
  double increment_noise_m = 0.1;     // the odometry's per-frame error allowed on top, [0, 100] m
  // Throws std::invalid_argument "<name>: expected <range>, got <value>".
  void validate() const;
};

class OdometryEgoMotion {
 public:
  explicit OdometryEgoMotion(const OdometryEgoMotionParameters& parameters = {});  // validates

  // One frame, in order: whether the odometry's increment is valid, the increment (camera t ->
  // camera t-1, StereoOdometryFrame::increment) and the camera mount it is expressed in the vehicle
  // frame with (CameraToVehicle::vehicle_from_camera; a mount estimated later may change it). The
  // first call is the first frame (no ego-motion).
  EgoMotion next(bool odometry_valid, const Eigen::Isometry3d& camera_previous_from_current, const Eigen::Isometry3d& vehicle_from_camera);

  EgoMotionSource source() const { return source_; }  // of the last next()
  int consecutive_dropouts() const { return consecutive_dropouts_; }
  // The last next() was given a valid increment but found it implausible (header) and bridged it.
  bool rejected_implausible() const { return rejected_implausible_; }
  // One phrase for a status line: "ego-motion applied", "odometry failed: last increment applied
  // (dropout 2 of at most 5)", "odometry implausible (0.80 m off the last increment, at most 0.20 m):
  // last increment applied (dropout 1 of at most 5)", "no ego-motion: static camera assumed", "first
  // frame: no ego-motion".
  std::string note() const;

 private:
  OdometryEgoMotionParameters parameters_;
  bool started_ = false;
  bool rejected_implausible_ = false, previous_frame_rejected_ = false;
  Eigen::Isometry3d last_rejected_camera_increment_ = Eigen::Isometry3d::Identity();
  double rejected_change_m_ = 0, rejected_bound_m_ = 0;
  bool has_valid_ = false;
  Eigen::Isometry3d last_valid_camera_increment_ = Eigen::Isometry3d::Identity();
  int consecutive_dropouts_ = 0;
  EgoMotionSource source_ = EgoMotionSource::first_frame;
};

}  // namespace lpstereo::arm::obstacles3d
