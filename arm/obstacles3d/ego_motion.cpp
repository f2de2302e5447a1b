// Ego-motion across odometry dropouts: the model and its figures in ego_motion.h.
#include "arm/obstacles3d/ego_motion.h"

#include "arm/obstacles3d/parameter_check.h"

namespace lpstereo::arm::obstacles3d {

const char* ego_motion_source_name(EgoMotionSource source) {
  switch (source) {
    case EgoMotionSource::first_frame: return "first_frame";
    case EgoMotionSource::odometry: return "odometry";
    case EgoMotionSource::extrapolated: return "extrapolated";
    case EgoMotionSource::static_camera: return "static_camera";
  }
  return "?";
}

OdometryEgoMotion::OdometryEgoMotion(int max_extrapolated_frames) : max_extrapolated_frames_(max_extrapolated_frames) {
  require_parameter(max_extrapolated_frames >= 0 && max_extrapolated_frames <= 100, "max_extrapolated_frames", "[0, 100]",
                    max_extrapolated_frames);
}

EgoMotion OdometryEgoMotion::next(bool odometry_valid, const Eigen::Isometry3d& camera_previous_from_current,
                                  const Eigen::Isometry3d& vehicle_from_camera) {
  EgoMotion ego_motion;
  if (!started_) {  // the first frame: its increment is the identity by definition, not a measurement
    started_ = true;
    source_ = EgoMotionSource::first_frame;
    return ego_motion;
  }
  if (odometry_valid) {
    last_valid_camera_increment_ = camera_previous_from_current;
    has_valid_ = true;
    consecutive_dropouts_ = 0;
    source_ = EgoMotionSource::odometry;
    ego_motion.available = true;
    ego_motion.previous_from_current = vehicle_from_camera * last_valid_camera_increment_ * vehicle_from_camera.inverse();
    return ego_motion;
  }
  ++consecutive_dropouts_;
  if (has_valid_ && consecutive_dropouts_ <= max_extrapolated_frames_) {
    source_ = EgoMotionSource::extrapolated;
    ego_motion.available = true;
    ego_motion.previous_from_current = vehicle_from_camera * last_valid_camera_increment_ * vehicle_from_camera.inverse();
    return ego_motion;
  }
  source_ = EgoMotionSource::static_camera;
  return ego_motion;
}

std::string OdometryEgoMotion::note() const {
  switch (source_) {
    case EgoMotionSource::first_frame: return "first frame: no ego-motion";
    case EgoMotionSource::odometry: return "ego-motion applied";
    case EgoMotionSource::extrapolated:
      return "odometry failed: last increment applied (dropout " + std::to_string(consecutive_dropouts_) + " of at most " +
             std::to_string(max_extrapolated_frames_) + ")";
    case EgoMotionSource::static_camera: return "no ego-motion: static camera assumed";
  }
  return "?";
}

}  // namespace lpstereo::arm::obstacles3d
