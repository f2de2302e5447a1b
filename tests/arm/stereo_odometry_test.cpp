// The stereo visual odometry (arm/odometry/stereo_odometry.h) on sequences the test renders itself
// (tests/support/moving_room.h: a textured box room seen by a rectified pair moving along a known
// trajectory). The expected increments come from that
// trajectory (camera t -> camera t-1 = P(t-1)^-1 P(t)), not from the code under test. Also: uniform
// (textureless) views, a blank frame in the middle of a sequence, the matcher's windows and ratio test,
// and the parameters' validation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "arm/odometry/stereo_odometry.h"
#include "tests/support/moving_room.h"

namespace lpstereo {
namespace {

using namespace testing::moving_room;

arm::StereoOdometryParameters parameters() {
  arm::StereoOdometryParameters p;
  p.focal_px = kFocalPx;
  p.baseline_m = kBaselineM;
  p.principal_point_x_px = kCxPx;
  p.principal_point_y_px = kCyPx;
  p.max_disparity_px = 120;
  return p;
}

double angle_deg(const Eigen::Matrix3d& rotation) {
  return std::acos(std::clamp((rotation.trace() - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / M_PI;
}

double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
  return values[values.size() / 2];
}

// A feature motion's displacement seen in the image: where the point at t-1 carried by the frame's
// motion (position - displacement) projects, against the feature at t: the larger of the column and
// the disparity difference, px. A static point's is its matching error (sub-pixel Harris corners:
// well under half a pixel), whatever its depth.
double image_motion_error_px(const arm::FeatureMotion& feature) {
  const Eigen::Vector3d carried = feature.position_m - feature.displacement_m;
  const double column_px = kFocalPx * carried.x() / carried.z() + kCxPx;
  const double disparity_px = kFocalPx * kBaselineM / carried.z();
  return std::max(std::abs(column_px - feature.left_px.x()), std::abs(disparity_px - feature.disparity_px));
}

TEST(StereoOdometry, RecoversTheIncrementsOfAKnownTrajectory) {
  constexpr int kFrames = 7;
  arm::StereoOdometry odometry(kWidth, kHeight, parameters(), 2);
  for (int frame = 0; frame < kFrames; ++frame) {
    const Eigen::Isometry3d pose = true_pose(frame);
    const arm::StereoOdometryFrame result = odometry.process(view_at_frame(frame, false), view_at_frame(frame, true));
    const arm::StereoOdometryStatistics& s = result.statistics;
    EXPECT_TRUE(s.valid) << "frame " << frame;
    if (frame == 0) {
      EXPECT_TRUE(result.pose.isApprox(Eigen::Isometry3d::Identity()));
      EXPECT_GT(s.left_features, 200);
      EXPECT_GT(s.stereo_matches, 100);
      continue;
    }
    const Eigen::Isometry3d expected = true_pose(frame - 1).inverse() * pose;
    const Eigen::Isometry3d error = expected.inverse() * result.increment;
    // 0.41 m steps: within 1.2 cm (3 % of the step) and 0.1 degree (Harris corners refined by a
    // parabola, 300 px focal length, far wall at 30 m = 3 px disparity; the errors seen are 1 - 5 mm
    // and 0.003 - 0.03 degree).
    EXPECT_LT(error.translation().norm(), 0.012) << "frame " << frame << ": increment " << result.increment.translation().transpose()
                                                << ", expected " << expected.translation().transpose();
    EXPECT_LT(angle_deg(error.rotation()), 0.1) << "frame " << frame;
    EXPECT_GT(s.circle_matches, 50) << "frame " << frame;
    EXPECT_GE(s.inliers, s.circle_matches / 2) << "frame " << frame;
    EXPECT_LE(s.inliers, s.circle_matches);
    EXPECT_LT(s.reprojection_rms_px, 1.0);
    EXPECT_GT(s.confidence, 0.5);
    EXPECT_EQ(s.predicted, frame >= 2) << "the prediction needs one estimated increment";
    // The counted work: RANSAC tests every circle match per minimal set at least; ArmWork is the
    // counts times the documented per-item costs.
    EXPECT_GE(s.hamming_distances, s.stereo_matches);
    EXPECT_GE(s.reprojection_tests, static_cast<int64_t>(s.circle_matches));
    EXPECT_GE(s.gauss_newton_point_steps, 3);
    EXPECT_EQ(s.work.scalar_ops, static_cast<uint64_t>(s.hamming_distances) * arm::kOdometryWorkHammingOps +
                                     static_cast<uint64_t>(s.gauss_newton_point_steps) * arm::kOdometryWorkPointStepOps +
                                     static_cast<uint64_t>(s.gauss_newton_solves) * arm::kOdometryWorkSolveOps +
                                     static_cast<uint64_t>(s.reprojection_tests) * arm::kOdometryWorkReprojectionOps +
                                     static_cast<uint64_t>(s.feature_motions) * arm::kOdometryWorkFeatureMotionOps);
    // Step 5: one feature motion per circle, flagged as the inliers; the room is static, so the
    // inliers' own motion is their stereo error (image_motion_error_px).
    ASSERT_EQ(result.feature_motions.size(), static_cast<size_t>(s.circle_matches)) << "frame " << frame;
    EXPECT_EQ(s.feature_motions, s.circle_matches);
    std::vector<double> inlier_error_px;
    for (const arm::FeatureMotion& feature : result.feature_motions) {
      EXPECT_GT(feature.disparity_px, 0);
      EXPECT_NEAR(feature.position_m.z(), kFocalPx * kBaselineM / feature.disparity_px, 1e-9);
      if (feature.inlier) inlier_error_px.push_back(image_motion_error_px(feature));
    }
    EXPECT_EQ(static_cast<int>(inlier_error_px.size()), s.inliers);
    EXPECT_LT(median(inlier_error_px), 0.5) << "frame " << frame;
    // The accumulated pose is the trajectory within 1.2 cm per step so far.
    EXPECT_LT((result.pose.translation() - pose.translation()).norm(), 0.012 * frame) << "frame " << frame;
  }
}

// A textured panel 2.2 m wide crossing the room at 0.25 m a frame (world x) while the camera moves:
// the features on it report that motion as their own (FeatureMotion, in camera axes), the room's
// report about none, and the panel's are not inliers of the camera's motion.
TEST(StereoOdometry, FeaturesOnAMovingObjectReportItsMotion) {
  constexpr int kFrames = 4;
  const Eigen::Vector3d panel_step_world_m(0.25, 0, 0);
  const auto panel_at = [&](int frame) { return Panel{9.0, -1.6 + 0.25 * frame, 0.6 + 0.25 * frame, -1.6, 1.0}; };
  arm::StereoOdometry odometry(kWidth, kHeight, parameters(), 2);
  for (int frame = 0; frame < kFrames; ++frame) {
    const Panel panel = panel_at(frame);
    const arm::StereoOdometryFrame result =
        odometry.process(render(true_pose(frame), false, &panel), render(true_pose(frame), true, &panel));
    ASSERT_TRUE(result.statistics.valid) << "frame " << frame;
    if (frame == 0) {
      EXPECT_TRUE(result.feature_motions.empty());
      continue;
    }
    // The panel's world step in the camera t axes; a feature is on the panel when its world position
    // (true pose) lies inside the rectangle, with 5 cm of margin, within 0.5 m of its plane.
    const Eigen::Isometry3d pose = true_pose(frame);
    const Eigen::Vector3d expected_m = pose.linear().transpose() * panel_step_world_m;
    std::vector<double> panel_x_m, panel_z_m, room_error_px;
    int panel_inliers = 0;
    for (const arm::FeatureMotion& feature : result.feature_motions) {
      const Eigen::Vector3d world = pose * feature.position_m;
      const bool on_panel = std::abs(world.z() - panel.z_m) < 0.5 && world.x() > panel.x0_m + 0.05 && world.x() < panel.x1_m - 0.05 &&
                            world.y() > panel.y0_m + 0.05 && world.y() < panel.y1_m - 0.05;
      const bool near_panel = std::abs(world.z() - panel.z_m) < 1.0 && world.x() > panel.x0_m - 0.6 && world.x() < panel.x1_m + 0.6;
      if (on_panel) {
        panel_x_m.push_back(feature.displacement_m.x());
        panel_z_m.push_back(feature.displacement_m.z());
        panel_inliers += feature.inlier ? 1 : 0;
      } else if (!near_panel && feature.inlier) {
        room_error_px.push_back(image_motion_error_px(feature));
      }
    }
    ASSERT_GE(panel_x_m.size(), 8u) << "frame " << frame << ": too few features on the panel to test";
    ASSERT_GE(room_error_px.size(), 20u) << "frame " << frame;
    // Across the line of sight: within 2 cm of the 25 cm step (a feature's lateral error at 9 m is
    // 9 m x 0.3 px / 300 px = 1 cm); along it, the disparity's error at 9 m (a quarter pixel is
    // 25 cm) halved by the median of the panel's features: within 15 cm.
    EXPECT_NEAR(median(panel_x_m), expected_m.x(), 0.02) << "frame " << frame;
    EXPECT_NEAR(median(panel_z_m), expected_m.z(), 0.15) << "frame " << frame;
    EXPECT_LE(panel_inliers * 4, static_cast<int>(panel_x_m.size())) << "frame " << frame << ": the panel's motion is not the camera's";
    EXPECT_LT(median(room_error_px), 0.5) << "frame " << frame;
  }
}

TEST(StereoOdometry, TexturelessViewsGiveLowConfidenceAndHoldThePose) {
  Plane grey(kWidth, kHeight, {ElementType::u8, 0});
  for (int y = 0; y < kHeight; ++y) std::fill_n(grey.row<uint8_t>(y), kWidth, uint8_t{128});
  arm::StereoOdometry odometry(kWidth, kHeight, parameters(), 2);
  for (int frame = 0; frame < 3; ++frame) {
    const arm::StereoOdometryFrame result = odometry.process(grey, grey);
    EXPECT_EQ(result.statistics.left_features, 0);
    EXPECT_EQ(result.statistics.circle_matches, 0);
    EXPECT_EQ(result.statistics.hamming_distances, 0);
    EXPECT_EQ(result.statistics.work.scalar_ops, 0u);
    EXPECT_TRUE(result.pose.isApprox(Eigen::Isometry3d::Identity()));
    if (frame > 0) {
      EXPECT_FALSE(result.statistics.valid);
      EXPECT_EQ(result.statistics.confidence, 0.0);
      EXPECT_TRUE(result.increment.isApprox(Eigen::Isometry3d::Identity()));
    }
  }
}

TEST(StereoOdometry, ABlankFrameMidSequenceIsInvalidAndTheNextTexturedPairRecovers) {
  Plane black(kWidth, kHeight, {ElementType::u8, 0});
  arm::StereoOdometry odometry(kWidth, kHeight, parameters(), 2);
  Eigen::Isometry3d held = Eigen::Isometry3d::Identity();
  for (int frame = 0; frame < 6; ++frame) {
    const Eigen::Isometry3d pose = true_pose(frame);
    const bool blank = frame == 2;
    const arm::StereoOdometryFrame result =
        blank ? odometry.process(black, black) : odometry.process(view_at_frame(frame, false), view_at_frame(frame, true));
    if (frame == 1) held = result.pose;
    if (blank || frame == 3) {
      // The blank frame has no features; the next one has no reference features: both hold the pose.
      EXPECT_FALSE(result.statistics.valid) << "frame " << frame;
      EXPECT_TRUE(result.pose.isApprox(held)) << "frame " << frame;
    }
    if (frame == 4) {
      EXPECT_TRUE(result.statistics.valid);
      EXPECT_FALSE(result.statistics.predicted) << "no prediction after invalid frames";
      const Eigen::Isometry3d error = (true_pose(3).inverse() * pose).inverse() * result.increment;
      EXPECT_LT(error.translation().norm(), 0.02);
    }
  }
}

TEST(StereoOdometry, ADroppedFrameGivesTheDoubleStep) {
  // Frames 0, 1, 2, 4, 5: the pair after the gap moved two steps (0.8 m, 2 degrees), twice what the
  // constant-velocity prediction expects, and the pair after it one step where two are predicted:
  // both inside predicted_radius_px here, so both are estimated.
  arm::StereoOdometry odometry(kWidth, kHeight, parameters(), 2);
  int previous = -1;
  for (int frame : {0, 1, 2, 4, 5}) {
    const Eigen::Isometry3d pose = true_pose(frame);
    const arm::StereoOdometryFrame result = odometry.process(view_at_frame(frame, false), view_at_frame(frame, true));
    if (previous >= 0) {
      EXPECT_TRUE(result.statistics.valid) << "frame " << frame;
      EXPECT_EQ(result.statistics.predicted, frame >= 2) << "frame " << frame;
      const Eigen::Isometry3d error = (true_pose(previous).inverse() * pose).inverse() * result.increment;
      EXPECT_LT(error.translation().norm(), 0.012 * (frame - previous)) << "frame " << frame;
      EXPECT_LT(angle_deg(error.rotation()), 0.1 * (frame - previous)) << "frame " << frame;
    }
    previous = frame;
  }
}

arm::OdometryFeature feature(double x, double y, uint32_t pattern) {
  arm::OdometryFeature f;
  f.x_px = x;
  f.y_px = y;
  for (uint32_t& word : f.descriptor) word = pattern;
  return f;
}

TEST(StereoOdometry, MatcherKeepsToItsWindowAndRatioTest) {
  // Query at (100, 50). Stereo window: rows 50 +- 1, disparity 1 .. 40 (x in [60, 99]).
  const std::vector<arm::OdometryFeature> queries = {feature(100, 50, 0x0000FFFF)};
  arm::MatchWindow stereo;
  stereo.kind = arm::MatchWindow::Kind::epipolar;
  stereo.epipolar_tolerance_px = 1.0;
  stereo.min_disparity_px = 1.0;
  stereo.max_disparity_px = 40.0;
  // The identical descriptor at a negative disparity, two rows off, and beyond the range: no match;
  // one 8 bits off (1 bit per word) inside the window: that one.
  const std::vector<arm::OdometryFeature> candidates = {feature(105, 50, 0x0000FFFF), feature(90, 52, 0x0000FFFF),
                                                        feature(50, 50, 0x0000FFFF), feature(80, 50.5, 0x0001FFFF)};
  int64_t comparisons = 0;
  EXPECT_EQ(arm::match_features(queries, {}, candidates, stereo, 64, 0.9, &comparisons), std::vector<int>{3});
  EXPECT_EQ(comparisons, 1) << "only the candidate inside the window is compared";
  // A second candidate as close in Hamming distance fails the ratio test.
  std::vector<arm::OdometryFeature> ambiguous = candidates;
  ambiguous.push_back(feature(70, 49.5, 0x0002FFFF));  // also 8 bits off
  EXPECT_EQ(arm::match_features(queries, {}, ambiguous, stereo, 64, 0.9, &comparisons), std::vector<int>{-1});
  EXPECT_EQ(comparisons, 1 + 2);
  // Beyond max_hamming_distance: none.
  EXPECT_EQ(arm::match_features(queries, {}, candidates, stereo, 7, 0.9), std::vector<int>{-1});
  // Radius window around a centre that is not the query's position.
  arm::MatchWindow radius;
  radius.kind = arm::MatchWindow::Kind::radius;
  radius.radius_px = 5.0;
  const std::vector<arm::OdometryFeature> moved = {feature(100, 50, 0x0000FFFF), feature(203, 154, 0x0000FFFF)};
  EXPECT_EQ(arm::match_features(queries, {Eigen::Vector2d(200, 150)}, moved, radius, 64, 0.9), std::vector<int>{1});
  EXPECT_EQ(arm::match_features(queries, {Eigen::Vector2d(300, 150)}, moved, radius, 64, 0.9), std::vector<int>{-1});
  EXPECT_THROW(arm::match_features(queries, {}, moved, radius, 64, 0.9), std::invalid_argument) << "no centre for the query";
}

TEST(StereoOdometry, ParametersAreValidatedByName) {
  arm::StereoOdometryParameters p = parameters();
  p.baseline_m = 0;
  try {
    arm::StereoOdometry odometry(kWidth, kHeight, p, 1);
    FAIL() << "a zero baseline was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("baseline_m"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("got 0"), std::string::npos) << error.what();
  }
  p = parameters();
  p.min_inliers = 2;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = parameters();
  p.ratio_test = 1.5;
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo
