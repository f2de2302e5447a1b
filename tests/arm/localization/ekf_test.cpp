// The localization EKF (arm/localization/ekf.h): prediction, its covariance in closed form, the
// height and keyframe updates, gating, wrapping, the log line.
#include "arm/localization/ekf.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace lpstereo::arm::localization {
namespace {

TEST(LocalizationEkf, SquareRouteWithExactOdometryReturnsHome) {
  LocalizationEkf filter({}, {0, 0, 2}, 0);
  double previous_sigma = filter.position_sigma_m();
  for (int side = 0; side < 4; ++side) {
    for (int step = 0; step < 10; ++step) {
      filter.predict({{0.2, 0, 0}, 0});
      // On the first leg the uncertainty only grows; later legs may shrink it (walking back, the
      // lateral error a yaw error caused cancels: the yaw-position cross-covariance at work).
      if (side == 0) {
        EXPECT_GT(filter.position_sigma_m(), previous_sigma);
      }
      previous_sigma = filter.position_sigma_m();
    }
    filter.predict({{0, 0, 0}, M_PI / 2});
  }
  EXPECT_LT((filter.position_m() - Eigen::Vector3d(0, 0, 2)).norm(), 1e-12);
  EXPECT_NEAR(filter.yaw_rad(), 0.0, 1e-12);
  EXPECT_GT(filter.position_sigma_m(), 0.1);  // 8 m of 2 % odometry and no correction
  // After a left turn, "forward" is the map's +y.
  filter.predict({{0, 0, 0}, M_PI / 2});
  filter.predict({{1.0, 0.5, 0.1}, 0});
  EXPECT_LT((filter.position_m() - Eigen::Vector3d(-0.5, 1.0, 2.1)).norm(), 1e-12);
}

TEST(LocalizationEkf, YawUncertaintyBecomesLateralUncertaintyInClosedForm) {
  EkfParameters parameters;
  parameters.initial_position_sigma_m = 0.01;
  parameters.initial_yaw_sigma_rad = 0.1;
  LocalizationEkf filter(parameters, {0, 0, 0}, 0);
  filter.predict({{10.0, 0, 0}, 0});
  // y' = y + sin(yaw) dx: d y'/d yaw = 10 at yaw 0, so P_yy = 0.01^2 + 10^2 0.1^2 + sigma_u^2 with
  // sigma_u = 0.02 * 10 + 0.002 the increment's own sigma; x' = x + cos(yaw) dx has zero yaw slope.
  const double sigma_u = 0.02 * 10.0 + 0.002;
  const Eigen::Matrix4d& p = filter.covariance();
  EXPECT_NEAR(p(1, 1), 0.0001 + 100 * 0.01 + sigma_u * sigma_u, 1e-12);
  EXPECT_NEAR(p(0, 0), 0.0001 + sigma_u * sigma_u, 1e-12);
  EXPECT_NEAR(p(1, 3), 10 * 0.01, 1e-12);  // the cross term d y'/d yaw P_yaw,yaw
  EXPECT_NEAR(p(3, 3), 0.01 + 0.0005 * 0.0005, 1e-12);
}

TEST(LocalizationEkf, HeightUpdateIsTheScalarKalmanUpdate) {
  EkfParameters parameters;
  parameters.initial_position_sigma_m = 0.2;
  parameters.height_sigma_m = 0.1;
  LocalizationEkf filter(parameters, {0, 0, 1.0}, 0);
  ASSERT_TRUE(filter.update_height(1.25));
  // gain = P / (P + R) = 0.04 / 0.05 = 0.8: z = 1 + 0.8 * 0.25, P_zz = P R / (P + R) = 0.008.
  EXPECT_NEAR(filter.position_m().z(), 1.2, 1e-12);
  EXPECT_NEAR(filter.covariance()(2, 2), 0.008, 1e-12);
  EXPECT_NEAR(filter.covariance()(0, 0), 0.04, 1e-12);  // x untouched
  EXPECT_FALSE(filter.update_height(5.0));                 // 3.8 m off with sigma ~0.13 m: gated
  EXPECT_FALSE(filter.update_height(std::nan("")));
  EXPECT_NEAR(filter.position_m().z(), 1.2, 1e-12);
}

TEST(LocalizationEkf, KeyframeCorrectionPullsTheDriftBackAndGatesOutliers) {
  LocalizationEkf filter({}, {0, 0, 2}, 0);
  for (int step = 0; step < 100; ++step) filter.predict({{0.1, 0.0005, 0}, 0.0001});  // a drifting odometry (~0.1 m, 0.01 rad off after 10 m)
  const double sigma_before = filter.position_sigma_m();
  // Truth: straight 10 m along x. The correction at confidence 1 (sigma 3 cm) dominates.
  ASSERT_TRUE(filter.update_keyframe({{10.0, 0.0, 2.0}, 0.0, 1.0}));
  EXPECT_LT(filter.position_sigma_m(), sigma_before);
  EXPECT_LT((filter.position_m() - Eigen::Vector3d(10, 0, 2)).norm(), 0.05);
  EXPECT_LT(std::abs(filter.yaw_rad()), 0.02);
  const Eigen::Vector4d before = filter.state();
  EXPECT_FALSE(filter.update_keyframe({{25.0, 3.0, 2.0}, 0.0, 1.0}));  // a wrong keyframe: refused
  EXPECT_FALSE(filter.update_keyframe({{10.0, 0.0, 2.0}, 0.0, 0.01}));  // below min_keyframe_confidence
  EXPECT_EQ(filter.state(), before);
  EXPECT_NE(filter.log_line().find("kind=keyframe accepted=0"), std::string::npos);
}

TEST(LocalizationEkf, YawInnovationWrapsAroundPi) {
  LocalizationEkf filter({}, {0, 0, 0}, M_PI - 0.01);
  ASSERT_TRUE(filter.update_keyframe({{0, 0, 0}, -M_PI + 0.01, 1.0}));  // 0.02 rad away, not 2 pi - 0.02
  EXPECT_GT(std::abs(filter.yaw_rad()), M_PI - 0.011);
  EXPECT_NEAR(wrap_angle_rad(3 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(-M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrap_angle_rad(-0.5), -0.5, 1e-15);
}

TEST(LocalizationEkf, LostOdometryKeepsPredictingWithGrowingUncertainty) {
  LocalizationEkf filter({}, {1, 2, 3}, 0.5);
  const double sigma = filter.position_sigma_m();
  filter.predict({{std::nan(""), 0, 0}, 0});
  EXPECT_EQ(filter.position_m(), Eigen::Vector3d(1, 2, 3));
  EXPECT_GT(filter.position_sigma_m(), sigma);
  EXPECT_NE(filter.log_line().find("kind=predict accepted=0"), std::string::npos);
}

// A zero increment with an extra sigma (the localizer's lost frame): the variances grow by the floor
// and the extra sigma in quadrature, (floor^2 + extra^2) per axis; the state does not move.
TEST(LocalizationEkf, ExtraSigmaAddsInQuadrature) {
  EkfParameters parameters;
  LocalizationEkf filter(parameters, {1, 2, 3}, 0.5);
  const Eigen::Matrix4d before = filter.covariance();
  OdometryIncrement lost;
  lost.extra_translation_sigma_m = 0.1;
  lost.extra_yaw_sigma_rad = 0.05;
  filter.predict(lost);
  const double floor_m = parameters.odometry_translation_floor_m, floor_rad = parameters.odometry_yaw_floor_rad;
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(filter.covariance()(axis, axis) - before(axis, axis), floor_m * floor_m + 0.1 * 0.1, 1e-12) << "axis " << axis;
  }
  EXPECT_NEAR(filter.covariance()(3, 3) - before(3, 3), floor_rad * floor_rad + 0.05 * 0.05, 1e-12);
  EXPECT_LT((filter.position_m() - Eigen::Vector3d(1, 2, 3)).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(filter.yaw_rad(), 0.5);
}

TEST(LocalizationEkf, LogLineHoldsTheStateAndTheCovarianceTriangle) {
  LocalizationEkf filter({}, {1.5, -2, 0.4}, 0.25);
  filter.predict({{0.1, 0, 0}, 0});
  const std::string line = filter.log_line();
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_EQ(line.rfind("step=1 kind=predict accepted=1 x_m=1.596891 y_m=-1.975260 z_m=0.400000 yaw_rad=0.250000 P=", 0), 0u) << line;
  const std::string triangle = line.substr(line.find("P=") + 2);
  std::stringstream numbers(triangle);
  std::string item;
  int count = 0;
  while (std::getline(numbers, item, ',')) {
    const int row = count < 4 ? 0 : count < 7 ? 1 : count < 9 ? 2 : 3;
    const int column = row + (count - (row == 0 ? 0 : row == 1 ? 4 : row == 2 ? 7 : 9));
    EXPECT_NEAR(std::stod(item), filter.covariance()(row, column), 1e-6 * std::abs(filter.covariance()(row, column)) + 1e-15) << item;
    ++count;
  }
  EXPECT_EQ(count, 10);
}

TEST(LocalizationEkf, ParametersOutOfRangeThrowNamingThem) {
  EkfParameters parameters;
  parameters.height_sigma_m = 0;
  try {
    LocalizationEkf filter(parameters, {0, 0, 0}, 0);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "EKF parameter height_sigma_m: expected > 0, got 0");
  }
}

}  // namespace
}  // namespace lpstereo::arm::localization
