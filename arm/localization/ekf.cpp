// Model, equations and sources: ekf.h.
#include "arm/localization/ekf.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace lpstereo::arm::localization {
namespace {

void require_positive(const char* name, double value) {
  if (!(value > 0) || !std::isfinite(value)) {
    char text[160];
    std::snprintf(text, sizeof text, "EKF parameter %s: expected > 0, got %g", name, value);
    throw std::invalid_argument(text);
  }
}

void require_non_negative(const char* name, double value) {
  if (!(value >= 0) || !std::isfinite(value)) {
    char text[160];
    std::snprintf(text, sizeof text, "EKF parameter %s: expected >= 0, got %g", name, value);
    throw std::invalid_argument(text);
  }
}

}  // namespace

double wrap_angle_rad(double angle_rad) {
  double wrapped = std::remainder(angle_rad, 2.0 * M_PI);  // [-pi, pi]
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

LocalizationEkf::LocalizationEkf(const EkfParameters& parameters, const Eigen::Vector3d& start_position_m, double start_yaw_rad)
    : parameters_(parameters) {
  require_non_negative("odometry_translation_fraction", parameters.odometry_translation_fraction);
  require_positive("odometry_translation_floor_m", parameters.odometry_translation_floor_m);
  require_non_negative("odometry_yaw_fraction", parameters.odometry_yaw_fraction);
  require_positive("odometry_yaw_floor_rad", parameters.odometry_yaw_floor_rad);
  require_positive("height_sigma_m", parameters.height_sigma_m);
  require_positive("keyframe_position_sigma_m", parameters.keyframe_position_sigma_m);
  require_positive("keyframe_yaw_sigma_rad", parameters.keyframe_yaw_sigma_rad);
  require_positive("min_keyframe_confidence", parameters.min_keyframe_confidence);
  if (parameters.min_keyframe_confidence > 1) {
    throw std::invalid_argument("EKF parameter min_keyframe_confidence: expected in (0, 1], got " +
                                std::to_string(parameters.min_keyframe_confidence));
  }
  require_positive("gate_chi_square", parameters.gate_chi_square);
  require_positive("height_gate_chi_square", parameters.height_gate_chi_square);
  require_positive("initial_position_sigma_m", parameters.initial_position_sigma_m);
  require_positive("initial_yaw_sigma_rad", parameters.initial_yaw_sigma_rad);
  state_ << start_position_m, wrap_angle_rad(start_yaw_rad);
  const double position_variance = parameters.initial_position_sigma_m * parameters.initial_position_sigma_m;
  covariance_ = Eigen::Vector4d(position_variance, position_variance, position_variance,
                                parameters.initial_yaw_sigma_rad * parameters.initial_yaw_sigma_rad)
                    .asDiagonal();
}

void LocalizationEkf::predict(const OdometryIncrement& increment) {
  const double yaw = state_(3);
  const double c = std::cos(yaw), s = std::sin(yaw);
  const double dx = increment.translation_m.x(), dy = increment.translation_m.y();
  if (!increment.translation_m.allFinite() || !std::isfinite(increment.yaw_rad)) {
    // A lost odometry frame: keep the state, grow the uncertainty as for a step at rest.
    OdometryIncrement rest;
    predict(rest);
    last_accepted_ = false;
    return;
  }
  Eigen::Matrix4d jacobian = Eigen::Matrix4d::Identity();  // F
  jacobian(0, 3) = -s * dx - c * dy;
  jacobian(1, 3) = c * dx - s * dy;
  Eigen::Matrix4d input_jacobian = Eigen::Matrix4d::Identity();  // G
  input_jacobian.topLeftCorner<2, 2>() << c, -s, s, c;
  const double proportional_translation_sigma =
      parameters_.odometry_translation_fraction * increment.translation_m.norm() + parameters_.odometry_translation_floor_m;
  const double proportional_yaw_sigma =
      parameters_.odometry_yaw_fraction * std::abs(increment.yaw_rad) + parameters_.odometry_yaw_floor_rad;
  const double extra_translation_sigma = std::isfinite(increment.extra_translation_sigma_m) ? std::abs(increment.extra_translation_sigma_m) : 0.0;
  const double extra_yaw_sigma = std::isfinite(increment.extra_yaw_sigma_rad) ? std::abs(increment.extra_yaw_sigma_rad) : 0.0;
  const double translation_sigma = std::hypot(proportional_translation_sigma, extra_translation_sigma);
  const double yaw_sigma = std::hypot(proportional_yaw_sigma, extra_yaw_sigma);
  const Eigen::Vector4d input_variance(translation_sigma * translation_sigma, translation_sigma * translation_sigma,
                                       translation_sigma * translation_sigma, yaw_sigma * yaw_sigma);
  state_(0) += c * dx - s * dy;
  state_(1) += s * dx + c * dy;
  state_(2) += increment.translation_m.z();
  state_(3) = wrap_angle_rad(yaw + increment.yaw_rad);
  covariance_ = jacobian * covariance_ * jacobian.transpose() +
                input_jacobian * input_variance.asDiagonal() * input_jacobian.transpose();
  record("predict", true);
}

bool LocalizationEkf::update(const Eigen::MatrixXd& selection, const Eigen::VectorXd& innovation, const Eigen::MatrixXd& noise,
                             double gate) {
  const Eigen::MatrixXd innovation_covariance = selection * covariance_ * selection.transpose() + noise;  // S
  const Eigen::LDLT<Eigen::MatrixXd> solver(innovation_covariance);
  const double mahalanobis = innovation.dot(solver.solve(innovation));
  if (!(mahalanobis <= gate)) return false;
  const Eigen::MatrixXd gain = covariance_ * selection.transpose() * solver.solve(Eigen::MatrixXd::Identity(noise.rows(), noise.cols()));
  state_ += gain * innovation;
  state_(3) = wrap_angle_rad(state_(3));
  const Eigen::Matrix4d joseph = Eigen::Matrix4d::Identity() - gain * selection;
  covariance_ = joseph * covariance_ * joseph.transpose() + gain * noise * gain.transpose();
  return true;
}

bool LocalizationEkf::update_height(double height_m) {
  bool accepted = false;
  if (std::isfinite(height_m)) {
    Eigen::MatrixXd selection = Eigen::MatrixXd::Zero(1, 4);
    selection(0, 2) = 1;
    Eigen::VectorXd innovation(1);
    innovation(0) = height_m - state_(2);
    const Eigen::MatrixXd noise = Eigen::MatrixXd::Constant(1, 1, parameters_.height_sigma_m * parameters_.height_sigma_m);
    accepted = update(selection, innovation, noise, parameters_.height_gate_chi_square);
  }
  record("height", accepted);
  return accepted;
}

bool LocalizationEkf::update_keyframe(const KeyframePoseMeasurement& measurement) {
  bool accepted = false;
  if (measurement.position_m.allFinite() && std::isfinite(measurement.yaw_rad) &&
      measurement.confidence >= parameters_.min_keyframe_confidence && measurement.confidence <= 1.0) {
    const Eigen::MatrixXd selection = Eigen::MatrixXd::Identity(4, 4);
    Eigen::VectorXd innovation(4);
    innovation << measurement.position_m - state_.head<3>(), wrap_angle_rad(measurement.yaw_rad - state_(3));
    const double position_variance = parameters_.keyframe_position_sigma_m * parameters_.keyframe_position_sigma_m / measurement.confidence;
    const double yaw_variance = parameters_.keyframe_yaw_sigma_rad * parameters_.keyframe_yaw_sigma_rad / measurement.confidence;
    const Eigen::MatrixXd noise = Eigen::Vector4d(position_variance, position_variance, position_variance, yaw_variance).asDiagonal();
    accepted = update(selection, innovation, noise, parameters_.gate_chi_square);
  }
  record("keyframe", accepted);
  return accepted;
}

double LocalizationEkf::position_sigma_m() const { return std::sqrt(covariance_.topLeftCorner<3, 3>().trace()); }

void LocalizationEkf::record(const char* kind, bool accepted) {
  ++step_;
  last_kind_ = kind;
  last_accepted_ = accepted;
}

std::string LocalizationEkf::log_line() const {
  char text[512];
  int length = std::snprintf(text, sizeof text, "step=%ld kind=%s accepted=%d x_m=%.6f y_m=%.6f z_m=%.6f yaw_rad=%.6f P=", step_,
                             last_kind_, last_accepted_ ? 1 : 0, state_(0), state_(1), state_(2), state_(3));
  for (int row = 0; row < 4; ++row) {
    for (int column = row; column < 4; ++column) {
      length += std::snprintf(text + length, sizeof text - static_cast<size_t>(length), "%s%.6e",
                              (row == 0 && column == 0) ? "" : ",", covariance_(row, column));
    }
  }
  return std::string(text, static_cast<size_t>(length));
}

}  // namespace lpstereo::arm::localization
