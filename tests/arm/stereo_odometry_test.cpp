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
                                     static_cast<uint64_t>(s.reprojection_tests) * arm::kOdometryWorkReprojectionOps);
    // The accumulated pose is the trajectory within 1.2 cm per step so far.
    EXPECT_LT((result.pose.translation() - pose.translation()).norm(), 0.012 * frame) << "frame " << frame;
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
