// The localization filter (issue 8 deliverable 3; thesis 003 §1.3 and §3.6: visual odometry, the
// visual height and the keyframe corrections fused by one filter): an extended Kalman filter over
// the drone's position and yaw in the map frame.
//
// State x = (x_m, y_m, z_m, yaw_rad): map frame x, y horizontal, z up (height above the take-off
// ground), yaw about z, counter-clockwise from the map's x axis. Roll and pitch are not estimated:
// the flight controller levels the drone and its IMU gives them; the visual odometry increments
// are expressed in the levelled body frame (x forward, y left, z up).
//
// Prediction by a visual-odometry increment u = (dx, dy, dz, dyaw) in the body frame of the previous
// step (Thrun, Burgard, Fox, "Probabilistic Robotics", 2005, Table 3.3, the EKF algorithm):
//     x' = x + cos(yaw) dx - sin(yaw) dy,   y' = y + sin(yaw) dx + cos(yaw) dy,
//     z' = z + dz,                          yaw' = wrap(yaw + dyaw)
//     P' = F P F^T + G Q G^T
// F = d x' / d x (identity but the yaw column: d x'/d yaw = -sin dx - cos dy, d y'/d yaw = cos dx - sin dy),
// G = d x' / d u (the yaw rotation on dx, dy; identity on dz, dyaw), Q = diag of the increment's
// variances: sigma_xy = odometry_translation_fraction |(dx, dy, dz)| + odometry_translation_floor_m,
// the same for dz, sigma_yaw = odometry_yaw_fraction |dyaw| + odometry_yaw_floor_rad (odometry drifts
// in proportion to the motion), each combined in quadrature with the increment's extra sigma (a lost
// frame's unseen motion, arm/localization/localizer.h).
//
// Updates (linear measurements, H a selection of the state; K = P H^T (H P H^T + R)^-1,
// x += K r, P = (I - K H) P (I - K H)^T + K R K^T, the Joseph form, which stays symmetric positive):
//   - height: z measured by the downward disparity (z_h = f B / d of the ground), variance
//     height_sigma_m^2;
//   - keyframe correction (pose_correction.h, converted by the caller to the body pose): x, y, z, yaw,
//     variances keyframe_position_sigma_m^2 / confidence and keyframe_yaw_sigma_rad^2 / confidence;
//     the yaw innovation is wrapped to (-pi, pi].
// A correction whose Mahalanobis distance r^T S^-1 r exceeds gate_chi_square (chi-square, 4 degrees
// of freedom: 18.47 at 0.999) is refused (a wrong keyframe match must not teleport the drone); so is
// a height beyond its own 1-degree gate (10.83 at 0.999).
//
// Confidence when nothing corrects the filter (textureless ground, a pure rotation, missing frames):
// the filter keeps predicting, its covariance grows, and position_sigma_m() says how far to trust it.
// log_line() gives one line per step: step number, kind, accepted, the state and the covariance's
// upper triangle (10 numbers, row-major).
#pragma once

#include <string>

#include <Eigen/Core>

namespace lpstereo::arm::localization {

struct EkfParameters {
  double odometry_translation_fraction = 0.02;  // sigma per metre travelled (2 %)
  double odometry_translation_floor_m = 0.002;  // sigma per increment at rest, metres
  double odometry_yaw_fraction = 0.02;          // sigma per radian turned
  double odometry_yaw_floor_rad = 0.0005;       // sigma per increment at rest
  double height_sigma_m = 0.03;                 // visual height measurement sigma (> 0)
  double keyframe_position_sigma_m = 0.03;      // keyframe correction sigma at confidence 1 (> 0)
  double keyframe_yaw_sigma_rad = 0.01;         // (> 0)
  double min_keyframe_confidence = 0.05;        // corrections below are ignored, (0, 1]
  double gate_chi_square = 18.47;               // 4 dof at 0.999 (> 0)
  double height_gate_chi_square = 10.83;        // 1 dof at 0.999 (> 0)
  double initial_position_sigma_m = 0.01;       // the known start point (> 0)
  double initial_yaw_sigma_rad = 0.01;          // (> 0)
};

struct OdometryIncrement {
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();  // body frame of the previous step
  double yaw_rad = 0;
  // Extra sigma added in quadrature to the proportional model's (a frame the odometry lost: the
  // caller predicts a zero increment with the motion the drone may have made unseen), >= 0.
  double extra_translation_sigma_m = 0;
  double extra_yaw_sigma_rad = 0;
};

struct KeyframePoseMeasurement {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // body position in the map frame
  double yaw_rad = 0;
  double confidence = 1;  // (0, 1], PoseCorrection::confidence
};

class LocalizationEkf {
 public:
  // Throws std::invalid_argument for a parameter out of range (naming it, the range and the value).
  LocalizationEkf(const EkfParameters& parameters, const Eigen::Vector3d& start_position_m, double start_yaw_rad);

  void predict(const OdometryIncrement& increment);
  bool update_height(double height_m);                         // false when gated out or not finite
  bool update_keyframe(const KeyframePoseMeasurement& measurement);  // false when gated out or too unsure

  const Eigen::Vector4d& state() const { return state_; }
  const Eigen::Matrix4d& covariance() const { return covariance_; }
  Eigen::Vector3d position_m() const { return state_.head<3>(); }
  double yaw_rad() const { return state_(3); }
  double position_sigma_m() const;  // sqrt of the trace of the position block
  std::string log_line() const;     // the last step, one line (header comment)

 private:
  bool update(const Eigen::MatrixXd& selection, const Eigen::VectorXd& innovation, const Eigen::MatrixXd& noise,
              double gate);
  void record(const char* kind, bool accepted);

  EkfParameters parameters_;
  Eigen::Vector4d state_;
  Eigen::Matrix4d covariance_;
  long step_ = 0;
  const char* last_kind_ = "start";
  bool last_accepted_ = true;
};

// Wraps an angle to (-pi, pi].
double wrap_angle_rad(double angle_rad);

}  // namespace lpstereo::arm::localization
