// The chain of docs/localization.md on one synthetic homing step: a keyframe taken at 0.4 m over
// textured ground, the drone back over it with a drifted filter; 3D validation of the sparse
// disparities, nearest keyframe, pose correction with wrong matches, EKF update.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "arm/localization/ekf.h"
#include "arm/localization/keyframe_database.h"
#include "arm/localization/pose_correction.h"

namespace lpstereo::arm::localization {
namespace {

constexpr double kFocalPx = 400, kBaselineM = 0.1, kU0Px = 320, kV0Px = 240;

// Body frame x forward, y left, z up; the camera looks down: its x is the body's -y, its y the
// body's -x, its z the body's -z (a proper rotation).
Eigen::Isometry3d body_from_camera() {
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.linear() << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  return mount;
}

Eigen::Isometry3d body_pose(const Eigen::Vector3d& position_m, double yaw_rad) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = position_m;
  return pose;
}

// What the feature stage hands over: pixels, sparse disparities (Q4, rounded as the kernel does),
// descriptors; ground point ids kept aside to build the matches a matcher would find.
struct Observation {
  std::vector<CandidateFeature> candidates;
  std::vector<int> ground_ids;
};

Observation observe(const std::vector<Eigen::Vector3d>& ground_m, const Eigen::Isometry3d& world_from_body) {
  const Eigen::Isometry3d camera_from_world = (world_from_body * body_from_camera()).inverse();
  Observation observation;
  for (size_t id = 0; id < ground_m.size(); ++id) {
    const Eigen::Vector3d p = camera_from_world * ground_m[id];
    if (p.z() <= 0.05) continue;
    const double u = kFocalPx * p.x() / p.z() + kU0Px, v = kFocalPx * p.y() / p.z() + kV0Px;
    if (u < 16 || u >= 624 || v < 16 || v >= 464) continue;
    CandidateFeature candidate;
    candidate.pixel_px = Eigen::Vector2f(static_cast<float>(u), static_cast<float>(v));
    candidate.disparity_q4 = static_cast<int16_t>(std::lround(16.0 * kFocalPx * kBaselineM / p.z()));
    candidate.descriptor[0] = static_cast<uint32_t>(id);
    observation.candidates.push_back(candidate);
    observation.ground_ids.push_back(static_cast<int>(id));
  }
  return observation;
}

double yaw_of(const Eigen::Matrix3d& rotation) { return std::atan2(rotation(1, 0), rotation(0, 0)); }

TEST(LocalizationChain, AKeyframeCorrectionPullsADriftedFilterBackOverTheTakeOffPad) {
  std::mt19937 generator(51);
  std::uniform_real_distribution<double> lateral(-1.2, 1.2), relief(0.0, 0.05);
  std::vector<Eigen::Vector3d> ground_m;
  for (int i = 0; i < 3000; ++i) ground_m.emplace_back(lateral(generator), lateral(generator), relief(generator));
  const StereoGeometry geometry{kFocalPx, kBaselineM, kU0Px, kV0Px};
  FeatureValidationParameters validation;
  validation.min_disparity_px = 4;
  validation.max_disparity_px = 200;

  // Take-off: the filter is exact at the pad; the first keyframe at 0.4 m.
  KeyframeDatabase database;
  const Eigen::Isometry3d take_off = body_pose({0, 0, 0.4}, 0.0);
  const Observation at_take_off = observe(ground_m, take_off);
  const std::vector<KeyframeFeature> stored = validate_features_3d(at_take_off.candidates, geometry, validation);
  ASSERT_EQ(stored.size(), at_take_off.candidates.size());  // every disparity valid and in range here
  FrameSummary summary;
  summary.position_m = take_off.translation();
  summary.height_above_ground_m = 0.4;
  summary.validated_features = static_cast<int>(stored.size());
  ASSERT_EQ(database.decide(summary), KeyframeDecision::first_at_height);
  Keyframe keyframe;
  keyframe.world_from_camera = take_off * body_from_camera();
  keyframe.features = stored;
  database.add(keyframe);

  // Back for landing: truth a little off the pad, the filter 35 cm and 0.04 rad off after the flight.
  const Eigen::Isometry3d truth = body_pose({0.1, -0.05, 0.5}, 0.05);
  EkfParameters parameters;
  parameters.initial_position_sigma_m = 0.3;  // the uncertainty a flight's odometry left
  parameters.initial_yaw_sigma_rad = 0.05;
  LocalizationEkf filter(parameters, {0.35, 0.2, 0.5}, 0.01);
  const Observation now = observe(ground_m, truth);
  const std::vector<KeyframeFeature> current = validate_features_3d(now.candidates, geometry, validation);
  ASSERT_EQ(current.size(), now.candidates.size());

  const std::optional<size_t> nearest = database.nearest(filter.position_m());
  ASSERT_TRUE(nearest.has_value());
  const Keyframe& reference = database.keyframes()[*nearest];
  // The matcher's output: the same ground point in both (the descriptor carries its id here), and
  // every fifth match paired with a wrong keyframe feature.
  std::vector<FeatureMatch> matches;
  for (size_t c = 0; c < current.size(); ++c) {
    for (size_t k = 0; k < reference.features.size(); ++k) {
      if (reference.features[k].descriptor[0] == current[c].descriptor[0]) {
        const bool wrong = matches.size() % 5 == 0;
        matches.push_back({static_cast<int>(c), static_cast<int>(wrong ? (k + reference.features.size() / 2) % reference.features.size() : k)});
      }
    }
  }
  ASSERT_GT(matches.size(), 100u);
  const PoseCorrection correction = correct_pose(current, reference, matches, {});
  ASSERT_TRUE(correction.ok) << correction.failure;
  EXPECT_GT(correction.confidence, 0.6);

  const Eigen::Isometry3d measured_body = correction.world_from_current * body_from_camera().inverse();
  EXPECT_LT((measured_body.translation() - truth.translation()).norm(), 0.01);
  const double error_before_m = (filter.position_m() - truth.translation()).norm();
  ASSERT_TRUE(filter.update_keyframe({measured_body.translation(), yaw_of(measured_body.linear()), correction.confidence}));
  const double error_after_m = (filter.position_m() - truth.translation()).norm();
  EXPECT_GT(error_before_m, 0.3);
  EXPECT_LT(error_after_m, 0.05);
  EXPECT_LT(std::abs(wrap_angle_rad(filter.yaw_rad() - 0.05)), 0.01);
}

}  // namespace
}  // namespace lpstereo::arm::localization
