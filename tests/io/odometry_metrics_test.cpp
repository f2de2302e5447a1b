// The KITTI odometry metric on trajectories whose errors are known in closed form: a straight drive
// at 1 m per frame along z (the camera's forward axis), and estimates that differ from it by a
// scale, a constant yaw drift or one displaced frame.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "io/odometry_metrics.h"

namespace lpstereo::io {
namespace {

constexpr double kPi = 3.14159265358979323846;
using Trajectory = std::vector<Eigen::Isometry3d>;

// Frame i at (0, 0, i * step_m), looking forward: distance(i) = i * step_m exactly.
Trajectory straight_drive(int frames, double step_m = 1.0) {
  Trajectory poses;
  for (int i = 0; i < frames; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0, 0, i * step_m);
    poses.push_back(pose);
  }
  return poses;
}

// A drive that turns: 2 m per frame, 3 degrees of yaw (about the camera's y axis) per frame.
Trajectory turning_drive(int frames) {
  Trajectory poses = {Eigen::Isometry3d::Identity()};
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(0, 0, 2);
  step.linear() = Eigen::AngleAxisd(3 * kPi / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  while (static_cast<int>(poses.size()) < frames) poses.push_back(poses.back() * step);
  return poses;
}

const LengthErrors& length_errors(const OdometryErrors& errors, double length_m) {
  for (const LengthErrors& summary : errors.per_length) {
    if (summary.length_m == length_m) return summary;
  }
  throw std::runtime_error("no length " + std::to_string(length_m));
}

std::string what_of(const Trajectory& estimate, const Trajectory& ground_truth, const OdometrySettings& settings = {}) {
  try {
    evaluate_odometry(estimate, ground_truth, settings);
  } catch (const OdometryEvaluationError& error) {
    return error.what();
  }
  return "(no error)";
}

TEST(OdometryMetrics, GroundTruthAgainstItselfScoresZero) {
  const Trajectory truth = turning_drive(40);  // 78 m
  const OdometryErrors errors = evaluate_odometry(truth, truth);
  ASSERT_FALSE(errors.segments.empty());
  EXPECT_EQ(errors.translation_error_pct, 0);
  EXPECT_EQ(errors.rotation_error_deg_per_m, 0);
  for (const LengthErrors& summary : errors.per_length) {
    EXPECT_GT(summary.segments, 0) << summary.length_m;
    EXPECT_EQ(summary.translation_error_pct, 0) << summary.length_m;
    EXPECT_EQ(summary.rotation_error_deg_per_m, 0) << summary.length_m;
  }
  EXPECT_EQ(errors.end_point_error_m, 0);
  EXPECT_EQ(errors.ate_rmse_m, 0);
  EXPECT_NEAR(errors.ground_truth_path_m, 39 * 2.0, 1e-9);
  EXPECT_NEAR(errors.estimate_path_m, errors.ground_truth_path_m, 1e-12);
}

TEST(OdometryMetrics, ScaleOfOnePercentGivesOnePercentAtEveryLength) {
  // Every position scaled by 1.01: over a straight segment of L metres the estimate travels 1.01 L,
  // an error of 0.01 L, i.e. 1 % whatever L; the rotation is exact.
  const Trajectory truth = straight_drive(61);  // 60 m
  Trajectory estimate = truth;
  for (Eigen::Isometry3d& pose : estimate) pose.translation() *= 1.01;
  const OdometryErrors errors = evaluate_odometry(estimate, truth);
  // Automatic lengths for 60 m: spacing the multiple of 5 m nearest 6 m, up to the path.
  ASSERT_EQ(errors.per_length.size(), 12u);
  for (size_t k = 0; k < errors.per_length.size(); ++k) {
    const LengthErrors& summary = errors.per_length[k];
    const double length_m = 5.0 * static_cast<double>(k + 1);
    EXPECT_EQ(summary.length_m, length_m);
    // First frames 0..60 - L (step 1): frame i + L is the first at L metres.
    EXPECT_EQ(summary.segments, 61 - static_cast<int>(length_m)) << length_m;
    EXPECT_NEAR(summary.translation_error_pct, 1.0, 1e-9) << length_m;
    EXPECT_NEAR(summary.rotation_error_deg_per_m, 0, 1e-12) << length_m;
  }
  EXPECT_NEAR(errors.translation_error_pct, 1.0, 1e-9);
  EXPECT_NEAR(errors.end_point_error_m, 0.6, 1e-9);
  EXPECT_NEAR(errors.end_point_error_pct, 1.0, 1e-9);
  EXPECT_NEAR(errors.estimate_path_m, 60.6, 1e-9);
  // ATE: frame i is 0.01 i m off; RMS = 0.01 sqrt(sum i^2 / 61), sum i^2 = 60 * 61 * 121 / 6.
  EXPECT_NEAR(errors.ate_rmse_m, 0.01 * std::sqrt(60.0 * 121 / 6), 1e-9);
}

TEST(OdometryMetrics, ConstantYawDriftGivesItsRateInDegreesPerMetre) {
  // The estimate composes each true step (1 m forward) with an extra yaw of 0.2 degrees: between
  // frames i and j it has turned (j - i) * 0.2 degrees too much, over j - i metres.
  const double drift_deg_per_frame = 0.2;
  const Trajectory truth = straight_drive(41);
  Trajectory estimate = {Eigen::Isometry3d::Identity()};
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(drift_deg_per_frame * kPi / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  for (size_t i = 1; i < truth.size(); ++i) {
    Eigen::Isometry3d step = truth[i - 1].inverse() * truth[i];
    step.linear() = step.linear() * yaw;
    estimate.push_back(estimate.back() * step);
  }
  OdometrySettings settings;
  settings.segment_lengths_m = {5, 10, 20};
  const OdometryErrors errors = evaluate_odometry(estimate, truth, settings);
  for (const LengthErrors& summary : errors.per_length) {
    EXPECT_NEAR(summary.rotation_error_deg_per_m, drift_deg_per_frame, 1e-9) << summary.length_m;
    EXPECT_GT(summary.translation_error_pct, 0) << summary.length_m;  // the turn bends the path too
  }
  EXPECT_NEAR(errors.rotation_error_deg_per_m, drift_deg_per_frame, 1e-9);
  EXPECT_NEAR(errors.end_rotation_error_deg, 40 * drift_deg_per_frame, 1e-9);
}

TEST(OdometryMetrics, OneDisplacedFrameSpoilsOnlyTheSegmentsThatStartOrEndThere) {
  // Frame 15 of 31 displaced 0.5 m sideways: of the 26 segments of 5 m (first frames 0..25), the one
  // from frame 10 (ending at 15) and the one from 15 are 0.5 m off (10 %), the others exact.
  const Trajectory truth = straight_drive(31);
  Trajectory estimate = truth;
  estimate[15].translation() += Eigen::Vector3d(0.5, 0, 0);
  OdometrySettings settings;
  settings.segment_lengths_m = {5};
  const OdometryErrors errors = evaluate_odometry(estimate, truth, settings);
  ASSERT_EQ(errors.segments.size(), 26u);
  for (const SegmentError& segment : errors.segments) {
    const bool touches = segment.first_frame == 15 || segment.last_frame == 15;
    EXPECT_NEAR(segment.translation_error_m, touches ? 0.5 : 0.0, 1e-12) << segment.first_frame;
    EXPECT_EQ(segment.rotation_error_rad, 0) << segment.first_frame;
  }
  EXPECT_NEAR(errors.translation_error_pct, 2 * 10.0 / 26, 1e-9);
  EXPECT_EQ(errors.end_point_error_m, 0);
  EXPECT_NEAR(errors.ate_rmse_m, std::sqrt(0.25 / 31), 1e-12);
}

TEST(OdometryMetrics, SegmentEndsAtTheFirstFrameAtLeastTheLengthAway) {
  // Unevenly spaced frames at 0, 3, 7, 12 m; length 5 m: 0 -> 7 m, 3 -> 12 m, 7 -> 12 m (exactly
  // 5 m), none from 12 m.
  Trajectory truth;
  for (double z_m : {0.0, 3.0, 7.0, 12.0}) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation().z() = z_m;
    truth.push_back(pose);
  }
  OdometrySettings settings;
  settings.segment_lengths_m = {5};
  const OdometryErrors errors = evaluate_odometry(truth, truth, settings);
  ASSERT_EQ(errors.segments.size(), 3u);
  const int expected_last[] = {2, 3, 3};
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(errors.segments[k].first_frame, k);
    EXPECT_EQ(errors.segments[k].last_frame, expected_last[k]);
  }
  EXPECT_EQ(errors.ground_truth_path_m, 12);
}

TEST(OdometryMetrics, StepChoosesTheFirstFrames) {
  const Trajectory truth = straight_drive(31);
  OdometrySettings settings;
  settings.segment_lengths_m = {5, 10};
  settings.step_frames = 10;  // the devkit's
  const OdometryErrors errors = evaluate_odometry(truth, truth, settings);
  // First frames 0, 10, 20 (30 has nothing ahead); from 20 both fit (30 is 10 m away).
  ASSERT_EQ(errors.segments.size(), 6u);
  EXPECT_EQ(errors.step_frames, 10);
  for (size_t k = 0; k < errors.segments.size(); ++k) {
    EXPECT_EQ(errors.segments[k].first_frame, 10 * static_cast<int>(k / 2));
    EXPECT_EQ(errors.segments[k].last_frame - errors.segments[k].first_frame, k % 2 == 0 ? 5 : 10);
  }
  EXPECT_EQ(length_errors(errors, 5).segments, 3);
}

TEST(OdometryMetrics, LengthsTheDataCannotHoldAreReportedEmpty) {
  const Trajectory truth = straight_drive(11);  // 10 m
  OdometrySettings settings;
  settings.segment_lengths_m = {5, 50};
  const OdometryErrors errors = evaluate_odometry(truth, truth, settings);
  EXPECT_EQ(length_errors(errors, 5).segments, 6);
  EXPECT_EQ(length_errors(errors, 50).segments, 0);
  EXPECT_TRUE(std::isnan(length_errors(errors, 50).translation_error_pct));
  EXPECT_EQ(errors.translation_error_pct, 0);  // the mean is over the segments that exist
}

TEST(OdometryMetrics, AutomaticLengthsFollowThePathLength) {
  const std::vector<double> kitti_06 = automatic_segment_lengths_m(59.9);
  EXPECT_EQ(kitti_06, (std::vector<double>{5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55}));
  const std::vector<double> four_hundred = automatic_segment_lengths_m(400);
  ASSERT_EQ(four_hundred.size(), 10u);
  EXPECT_EQ(four_hundred.front(), 40);
  EXPECT_EQ(four_hundred.back(), 400);
  EXPECT_EQ(automatic_segment_lengths_m(3000), kitti_segment_lengths_m());
  EXPECT_EQ(kitti_segment_lengths_m(), (std::vector<double>{100, 200, 300, 400, 500, 600, 700, 800}));
  EXPECT_EQ(automatic_segment_lengths_m(12), (std::vector<double>{5, 10}));
  EXPECT_TRUE(automatic_segment_lengths_m(4.9).empty());
}

TEST(OdometryMetrics, RotationAngleIsAccurateNearZeroAndNearPi) {
  for (double angle_rad : {1e-9, 1e-6, 0.3, 3.0, 3.14159}) {
    const Eigen::Matrix3d rotation = Eigen::AngleAxisd(angle_rad, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
    EXPECT_NEAR(rotation_angle_rad(rotation), angle_rad, 1e-12 + 1e-9 * angle_rad) << angle_rad;
  }
}

TEST(OdometryMetrics, RotationAngleSurvivesPosesPrintedWithSevenDigits) {
  // KITTI's pose files carry 7 significant digits (%e), so a relative rotation is only nearly
  // orthonormal. Between two such poses 0.25 degrees apart, acos((trace - 1) / 2) reads 0.24967
  // degrees (the rounding shifts the trace, and acos is steep near 1); the axis part does not move.
  auto printed = [](double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6e", value);
    return std::atof(text);
  };
  const Eigen::Matrix3d first = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 1, -0.3).normalized()).toRotationMatrix();
  const Eigen::Matrix3d second = first * Eigen::AngleAxisd(0.25 * kPi / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d relative = first.unaryExpr(printed).transpose() * second.unaryExpr(printed);
  EXPECT_NEAR(rotation_angle_rad(relative) * 180 / kPi, 0.25, 2e-5);
}

TEST(OdometryMetrics, RefusesTrajectoriesThatCannotBeCompared) {
  const Trajectory truth = straight_drive(51);
  EXPECT_EQ(what_of(straight_drive(50), truth),
            "expected as many estimated poses as ground-truth poses (one per frame), got 50 estimated and 51 ground-truth "
            "poses");
  EXPECT_EQ(what_of({}, {}), "expected at least one pose, got none");
  OdometrySettings settings;
  settings.segment_lengths_m = {5, 10};
  const std::string too_short = what_of(straight_drive(3), straight_drive(3), settings);
  EXPECT_NE(too_short.find("path is 2 m over 3 frame(s): no segment of 5 m to 10 m fits"), std::string::npos) << too_short;
  const std::string automatic = what_of(straight_drive(2), straight_drive(2));
  EXPECT_NE(automatic.find("path is 1 m over 2 frame(s): expected at least 5 m"), std::string::npos) << automatic;
  settings.step_frames = 0;
  EXPECT_EQ(what_of(truth, truth, settings), "step: expected a positive number of frames, got 0");
  settings.step_frames = 1;
  settings.segment_lengths_m = {5, -1};
  EXPECT_NE(what_of(truth, truth, settings).find("expected a positive number of metres, got -1"), std::string::npos);
  settings.segment_lengths_m = {5, 10, 5};
  EXPECT_EQ(what_of(truth, truth, settings), "segment length: expected each length once, got 5 m twice");
}

}  // namespace
}  // namespace lpstereo::io
