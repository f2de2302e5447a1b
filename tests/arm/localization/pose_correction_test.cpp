// The pose correction from a keyframe (arm/localization/pose_correction.h) on synthetic downward views.
#include "arm/localization/pose_correction.h"

#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace lpstereo::arm::localization {
namespace {

struct CorrectionScene {
  Keyframe keyframe;
  std::vector<KeyframeFeature> current;
  std::vector<FeatureMatch> matches;
  std::vector<uint8_t> is_inlier;
  Eigen::Isometry3d true_world_from_current;
};

// A keyframe 2 m above the ground looking down; the current camera moved and turned; ground heights
// vary by relief_m (0: flat ground). The first outlier_share of the matches pair wrong features.
CorrectionScene correction_scene(int count, double outlier_share, double relief_m, unsigned seed) {
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> lateral(-1.5, 1.5), relief(-relief_m, relief_m);
  std::normal_distribution<double> pixel_noise(0.0, 0.2), point_noise(0.0, 0.004);
  Eigen::Matrix3d k;
  k << 700, 0, 320, 0, 700, 240, 0, 0, 1;
  CorrectionScene scene;
  scene.keyframe.world_from_camera.translation() = Eigen::Vector3d(4.0, -2.0, 2.0);
  scene.keyframe.world_from_camera.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();  // z down
  Eigen::Isometry3d current_from_keyframe = Eigen::Isometry3d::Identity();
  current_from_keyframe.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d(0.05, -0.05, 1.0).normalized()).toRotationMatrix();
  current_from_keyframe.translation() = Eigen::Vector3d(0.3, -0.2, 0.1);
  scene.true_world_from_current = scene.keyframe.world_from_camera * current_from_keyframe.inverse();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d in_keyframe(lateral(generator), lateral(generator), 2.0 + relief(generator));
    const Eigen::Vector3d in_current = current_from_keyframe * in_keyframe;
    KeyframeFeature stored, seen;
    stored.pixel_px = ((k * in_keyframe).hnormalized() + Eigen::Vector2d(pixel_noise(generator), pixel_noise(generator))).cast<float>();
    stored.point_m = (in_keyframe + Eigen::Vector3d(point_noise(generator), point_noise(generator), point_noise(generator))).cast<float>();
    seen.pixel_px = ((k * in_current).hnormalized() + Eigen::Vector2d(pixel_noise(generator), pixel_noise(generator))).cast<float>();
    seen.point_m = (in_current + Eigen::Vector3d(point_noise(generator), point_noise(generator), point_noise(generator))).cast<float>();
    scene.keyframe.features.push_back(stored);
    scene.current.push_back(seen);
  }
  const int outliers = static_cast<int>(outlier_share * count);
  for (int i = 0; i < count; ++i) {
    const bool inlier = i >= outliers;
    scene.matches.push_back({i, inlier ? i : (i + count / 2) % count});
    scene.is_inlier.push_back(inlier ? 1 : 0);
  }
  return scene;
}

double distance_of_true_pair(const CorrectionScene& scene, const FeatureMatch& match) {
  const Eigen::Isometry3d keyframe_from_current = scene.keyframe.world_from_camera.inverse() * scene.true_world_from_current;
  return (keyframe_from_current * scene.current[static_cast<size_t>(match.current_index)].point_m.cast<double>() -
          scene.keyframe.features[static_cast<size_t>(match.keyframe_index)].point_m.cast<double>())
      .norm();
}

void expect_correct(const CorrectionScene& scene, const PoseCorrection& correction) {
  ASSERT_TRUE(correction.ok) << correction.failure;
  EXPECT_LT((correction.world_from_current.translation() - scene.true_world_from_current.translation()).norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(correction.world_from_current.linear() * scene.true_world_from_current.linear().transpose()).angle(), 0.005);
  for (size_t m = 0; m < scene.matches.size(); ++m) {
    // A wrong match whose two points happen to agree within the threshold is no error; the others must go.
    if (!scene.is_inlier[m] && distance_of_true_pair(scene, scene.matches[m]) > 0.1) {
      EXPECT_EQ(correction.inlier_mask[m], 0) << "wrong match " << m << " kept";
    }
  }
}

TEST(PoseCorrection, RecoversThePoseOverReliefWithWrongMatches) {
  const CorrectionScene scene = correction_scene(150, 0.25, 0.3, 41);
  const PoseCorrection correction = correct_pose(scene.current, scene.keyframe, scene.matches, {});
  expect_correct(scene, correction);
  EXPECT_TRUE(correction.fundamental_note.empty()) << correction.fundamental_note;
  EXPECT_EQ(correction.matches, 150);
  EXPECT_GE(correction.rigid_inliers, 105);  // of 113 true matches; 0.2 px and 4 mm noise lose a few at most
  EXPECT_GT(correction.confidence, 0.7);
  EXPECT_LE(correction.confidence, 1.0);
}

TEST(PoseCorrection, FlatGroundStillCorrects) {
  // F is not unique for a plane (fundamental_ransac.h); the rigid step must still find the pose.
  const CorrectionScene scene = correction_scene(150, 0.25, 0.0, 42);
  const PoseCorrection correction = correct_pose(scene.current, scene.keyframe, scene.matches, {});
  expect_correct(scene, correction);
}

TEST(PoseCorrection, FewMatchesSkipTheEpipolarTestAndLowCountsFail) {
  CorrectionScene scene = correction_scene(20, 0.0, 0.3, 43);
  scene.matches.resize(6);
  PoseCorrectionParameters parameters;
  parameters.min_inliers = 5;
  PoseCorrection correction = correct_pose(scene.current, scene.keyframe, scene.matches, parameters);
  ASSERT_TRUE(correction.ok) << correction.failure;
  EXPECT_NE(correction.fundamental_note.find("skipped"), std::string::npos);
  EXPECT_NEAR(correction.confidence, 6.0 / 50.0, 1e-12);  // all 6 agree, damped by 6 / full_confidence_inliers

  parameters.min_inliers = 8;
  correction = correct_pose(scene.current, scene.keyframe, scene.matches, parameters);
  EXPECT_FALSE(correction.ok);
  EXPECT_EQ(correction.failure, "pose correction: 6 matches left after the epipolar test, expected at least 8");

  correction = correct_pose(scene.current, scene.keyframe, {}, parameters);  // textureless: no matches
  EXPECT_FALSE(correction.ok);
  EXPECT_EQ(correction.confidence, 0.0);
}

TEST(PoseCorrection, MatchIndexOutOfRangeThrowsNamingIt) {
  const CorrectionScene scene = correction_scene(10, 0.0, 0.3, 44);
  std::vector<FeatureMatch> matches = {{0, 0}, {3, 10}};
  try {
    correct_pose(scene.current, scene.keyframe, matches, {});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "pose correction: match 1 keyframe_index expected 0 .. 9, got 10");
  }
}

}  // namespace
}  // namespace lpstereo::arm::localization
