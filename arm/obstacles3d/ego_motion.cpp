// Ego-motion across odometry dropouts: the model and its figures in ego_motion.h.
#include "arm/obstacles3d/ego_motion.h"

#include <cstdio>

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

void OdometryEgoMotionParameters::validate() const {
  require_parameter(frame_period_s > 0 && frame_period_s <= 10, "frame_period_s", "(0, 10] s", frame_period_s);
  require_parameter(max_extrapolated_frames >= 0 && max_extrapolated_frames <= 100, "max_extrapolated_frames", "[0, 100]",
                    max_extrapolated_frames);
  require_parameter(max_acceleration_mps2 >= 0 && max_acceleration_mps2 <= 1000, "max_acceleration_mps2", "[0, 1000] m/s^2",
                    max_acceleration_mps2);
  require_parameter(increment_noise_m >= 0 && increment_noise_m <= 100, "increment_noise_m", "[0, 100] m", increment_noise_m);
}

OdometryEgoMotion::OdometryEgoMotion(const OdometryEgoMotionParameters& parameters) : parameters_(parameters) { parameters.validate(); }

EgoMotion OdometryEgoMotion::next(bool odometry_valid, const Eigen::Isometry3d& camera_previous_from_current,
                                  const Eigen::Isometry3d& vehicle_from_camera) {
  EgoMotion ego_motion;
  previous_frame_rejected_ = rejected_implausible_;
  rejected_implausible_ = false;
  if (!started_) {  // the first frame: its increment is the identity by definition, not a measurement
    started_ = true;
    source_ = EgoMotionSource::first_frame;
    return ego_motion;
  }
  if (odometry_valid && has_valid_ && parameters_.max_acceleration_mps2 > 0) {
    // The plausibility bound (header): the translation per frame changes by at most a dt^2 per frame
    // since the last valid increment.
    const double period_s = parameters_.frame_period_s;
    const double bound_m = parameters_.max_acceleration_mps2 * period_s * period_s * (consecutive_dropouts_ + 1) + parameters_.increment_noise_m;
    const double change_m = (camera_previous_from_current.translation() - last_valid_camera_increment_.translation()).norm();
    // Two increments in a row that agree with each other (within one frame's bound) but not with the
    // last accepted one are a real change of speed, or the accepted one was the outlier: accept.
    const double single_frame_bound_m = parameters_.max_acceleration_mps2 * period_s * period_s + parameters_.increment_noise_m;
    const bool confirms_rejected = previous_frame_rejected_ &&
                                   (camera_previous_from_current.translation() - last_rejected_camera_increment_.translation()).norm() <=
                                       single_frame_bound_m;
    if (change_m > bound_m && !confirms_rejected) {
      last_rejected_camera_increment_ = camera_previous_from_current;
      odometry_valid = false;
      rejected_implausible_ = true;
      rejected_change_m_ = change_m;
      rejected_bound_m_ = bound_m;
    }
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
  if (has_valid_ && consecutive_dropouts_ <= parameters_.max_extrapolated_frames) {
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
    case EgoMotionSource::extrapolated: {
      char cause[96] = "odometry failed";
      if (rejected_implausible_) {
        std::snprintf(cause, sizeof cause, "odometry implausible (%.2f m off the last increment, at most %.2f m)", rejected_change_m_,
                      rejected_bound_m_);
      }
      return std::string(cause) + ": last increment applied (dropout " + std::to_string(consecutive_dropouts_) + " of at most " +
             std::to_string(parameters_.max_extrapolated_frames) + ")";
    }
    case EgoMotionSource::static_camera: return "no ego-motion: static camera assumed";
  }
  return "?";
}

}  // namespace lpstereo::arm::obstacles3d
