// Kabsch / Umeyama without scale and its RANSAC (arm/localization/rigid_alignment.h): exact recovery,
// noise, the reflection case, outliers, degenerate input.
#include "arm/localization/rigid_alignment.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <Eigen/SVD>
#include <gtest/gtest.h>

namespace lpstereo::arm::localization {
namespace {

std::vector<Eigen::Vector3d> random_points(int count, std::mt19937& generator, double half_extent_m) {
  std::uniform_real_distribution<double> coordinate(-half_extent_m, half_extent_m);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) points.emplace_back(coordinate(generator), coordinate(generator), coordinate(generator) + 3.0);
  return points;
}

Eigen::Isometry3d make_transform(double angle_rad, const Eigen::Vector3d& axis, const Eigen::Vector3d& translation_m) {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  transform.translation() = translation_m;
  return transform;
}

double rotation_error_rad(const Eigen::Matrix3d& estimate, const Eigen::Matrix3d& truth) {
  return Eigen::AngleAxisd(estimate * truth.transpose()).angle();
}

Eigen::Vector3d centroid(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& point : points) sum += point;
  return sum / static_cast<double>(points.size());
}

// The naive SVD answer V U^T of eq. 3.9, without the fix, computed here independently.
double naive_determinant(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  const Eigen::Vector3d ca = centroid(a), cb = centroid(b);
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) h += (a[i] - ca) * (b[i] - cb).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return (svd.matrixV() * svd.matrixU().transpose()).determinant();
}

TEST(RigidAlignment, RecoversAKnownRotationAndTranslationExactly) {
  std::mt19937 generator(11);
  const auto source = random_points(25, generator, 2.0);
  const Eigen::Isometry3d truth = make_transform(0.7, {0.3, -1.0, 0.4}, {0.5, -1.2, 2.0});
  std::vector<Eigen::Vector3d> target;
  for (const auto& a : source) target.push_back(truth * a);
  const RigidAlignment result = align_rigid(source, target);
  ASSERT_TRUE(result.ok) << result.failure;
  EXPECT_LT((result.target_from_source.linear() - truth.linear()).norm(), 1e-10);
  EXPECT_LT((result.target_from_source.translation() - truth.translation()).norm(), 1e-10);
  EXPECT_LT(result.rms_error_m, 1e-10);
  EXPECT_FALSE(result.reflection_fixed);
}

TEST(RigidAlignment, RecoversWithinToleranceUnderNoise) {
  std::mt19937 generator(12);
  const auto source = random_points(200, generator, 2.0);
  const Eigen::Isometry3d truth = make_transform(-1.1, {1.0, 0.2, 0.1}, {-0.3, 0.4, 0.8});
  std::normal_distribution<double> noise(0.0, 0.005);  // 5 mm per coordinate
  std::vector<Eigen::Vector3d> target;
  for (const auto& a : source) target.push_back(truth * a + Eigen::Vector3d(noise(generator), noise(generator), noise(generator)));
  const RigidAlignment result = align_rigid(source, target);
  ASSERT_TRUE(result.ok) << result.failure;
  // 200 points spread over 4 m with 5 mm noise: the rotation to ~1e-3 rad, the translation to ~1 cm.
  EXPECT_LT(rotation_error_rad(result.target_from_source.linear(), truth.linear()), 2e-3);
  EXPECT_LT((result.target_from_source.translation() - truth.translation()).norm(), 0.01);
  // The residual is the noise: sqrt(3) * 5 mm RMS.
  EXPECT_NEAR(result.rms_error_m, std::sqrt(3.0) * 0.005, 0.0015);
}

// Points on a plane (the ground under a downward camera): H has rank 2, the sign of its third singular
// vectors is arbitrary, so the naive V U^T is a mirror for some rotations; the fix must recover every one.
TEST(RigidAlignment, PlanarPointsRecoverTheRotationWhereTheNaiveSvdGivesAMirror) {
  std::mt19937 generator(13);
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  std::vector<Eigen::Vector3d> source;
  for (int i = 0; i < 30; ++i) source.emplace_back(coordinate(generator), coordinate(generator), 1.5);
  int naive_mirrors = 0;
  for (int k = 0; k < 24; ++k) {
    const Eigen::Isometry3d truth =
        make_transform(0.25 * k - 3.0, {std::sin(k), std::cos(1.7 * k), 0.5}, {0.1 * k, -0.2, 0.3});
    std::vector<Eigen::Vector3d> target;
    for (const auto& a : source) target.push_back(truth * a);
    if (naive_determinant(source, target) < 0) ++naive_mirrors;
    const RigidAlignment result = align_rigid(source, target);
    ASSERT_TRUE(result.ok) << result.failure;
    EXPECT_NEAR(result.target_from_source.linear().determinant(), 1.0, 1e-12) << "rotation " << k;
    EXPECT_LT((result.target_from_source.linear() - truth.linear()).norm(), 1e-9) << "rotation " << k;
    EXPECT_LT((result.target_from_source.translation() - truth.translation()).norm(), 1e-9) << "rotation " << k;
  }
  EXPECT_GT(naive_mirrors, 0) << "the test needs at least one configuration where the naive SVD is a reflection";
}

// A mirrored target: the best orthogonal matrix is a reflection (det -1); the result must be the best
// proper rotation instead, flagged as fixed.
TEST(RigidAlignment, MirroredTargetGivesAProperRotation) {
  std::mt19937 generator(14);
  const auto source = random_points(40, generator, 1.0);
  std::vector<Eigen::Vector3d> target;
  for (const auto& a : source) target.push_back(Eigen::Vector3d(a.x(), a.y(), -a.z()));
  ASSERT_LT(naive_determinant(source, target), 0);
  const RigidAlignment result = align_rigid(source, target);
  ASSERT_TRUE(result.ok) << result.failure;
  EXPECT_TRUE(result.reflection_fixed);
  const Eigen::Matrix3d rotation = result.target_from_source.linear();
  EXPECT_NEAR(rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  // Local optimality among proper rotations: small rotations of the answer never do better.
  auto squared_error = [&](const Eigen::Isometry3d& transform) {
    double sum = 0;
    for (size_t i = 0; i < source.size(); ++i) sum += (transform * source[i] - target[i]).squaredNorm();
    return sum;
  };
  const double best = squared_error(result.target_from_source);
  for (int axis = 0; axis < 3; ++axis) {
    for (const double angle : {-0.01, 0.01}) {
      Eigen::Isometry3d perturbed = result.target_from_source;
      perturbed.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::Unit(axis)).toRotationMatrix() * rotation;
      // Re-centre the translation for the perturbed rotation (the optimum for a given R).
      perturbed.translation() = centroid(target) - perturbed.linear() * centroid(source);
      EXPECT_GE(squared_error(perturbed), best) << "axis " << axis << " angle " << angle;
    }
  }
}

TEST(RigidAlignment, DegenerateInputFailsWithOneLine) {
  const std::vector<Eigen::Vector3d> two = {{0, 0, 1}, {1, 0, 1}};
  RigidAlignment result = align_rigid(two, two);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("at least 3"), std::string::npos) << result.failure;

  const std::vector<Eigen::Vector3d> collinear = {{0, 0, 1}, {1, 1, 2}, {2, 2, 3}, {3, 3, 4}};
  result = align_rigid(collinear, collinear);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("collinear"), std::string::npos) << result.failure;

  const std::vector<Eigen::Vector3d> coincident(5, Eigen::Vector3d(1, 2, 3));
  result = align_rigid(coincident, coincident);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("collinear or coincident"), std::string::npos) << result.failure;

  const std::vector<Eigen::Vector3d> three = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  result = align_rigid(three, two);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("3 source points but 2 target points"), std::string::npos) << result.failure;

  std::vector<Eigen::Vector3d> not_finite = three;
  not_finite[1].x() = std::nan("");
  result = align_rigid(not_finite, three);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("not finite"), std::string::npos) << result.failure;
  EXPECT_EQ(result.failure.find('\n'), std::string::npos);
}

struct OutlierScene {
  std::vector<Eigen::Vector3d> source, target;
  std::vector<uint8_t> is_inlier;
  Eigen::Isometry3d truth;
};

OutlierScene outlier_scene(int count, double outlier_share, unsigned seed) {
  std::mt19937 generator(seed);
  OutlierScene scene;
  scene.source = random_points(count, generator, 2.0);
  scene.truth = make_transform(0.4, {0.1, 0.2, 1.0}, {1.0, 0.5, -0.2});
  std::normal_distribution<double> noise(0.0, 0.003);
  std::uniform_real_distribution<double> offset(-1.0, 1.0);
  const int outliers = static_cast<int>(outlier_share * count);
  for (int i = 0; i < count; ++i) {
    Eigen::Vector3d b = scene.truth * scene.source[static_cast<size_t>(i)];
    b += Eigen::Vector3d(noise(generator), noise(generator), noise(generator));
    const bool inlier = i >= outliers;
    if (!inlier) {
      // A gross error: moved by at least 0.5 m in a random direction.
      Eigen::Vector3d direction(offset(generator), offset(generator), offset(generator));
      direction = direction.normalized() * (0.5 + std::abs(offset(generator)));
      b += direction;
    }
    scene.target.push_back(b);
    scene.is_inlier.push_back(inlier ? 1 : 0);
  }
  return scene;
}

TEST(RigidRansac, FlagsEveryGrossOutlierAndRecoversTheTransform) {
  const OutlierScene scene = outlier_scene(120, 0.3, 21);
  RigidRansacParameters parameters;
  parameters.inlier_threshold_m = 0.03;  // 3 mm noise per coordinate: residual norms ~5 mm, max well below 30 mm
  const RigidRansacResult result = align_rigid_ransac(scene.source, scene.target, parameters);
  ASSERT_TRUE(result.ok) << result.failure;
  ASSERT_EQ(result.inlier_mask.size(), scene.source.size());
  EXPECT_EQ(result.inlier_mask, scene.is_inlier);
  EXPECT_EQ(result.inlier_count, 84);
  EXPECT_LT(rotation_error_rad(result.target_from_source.linear(), scene.truth.linear()), 3e-3);
  EXPECT_LT((result.target_from_source.translation() - scene.truth.translation()).norm(), 0.01);
  // 70 % inliers, sample of 3, 0.999: N = log(0.001) / log(1 - 0.343) = 16.5 -> 17 samples at most
  // once the full inlier set is found; it may take more draws to find it but never the cap.
  EXPECT_LT(result.iterations, parameters.max_iterations);
}

TEST(RigidRansac, SameSeedSameResultAndTheSeedIsUsed) {
  const OutlierScene scene = outlier_scene(60, 0.4, 22);
  RigidRansacParameters parameters;
  const RigidRansacResult first = align_rigid_ransac(scene.source, scene.target, parameters);
  const RigidRansacResult again = align_rigid_ransac(scene.source, scene.target, parameters);
  ASSERT_TRUE(first.ok && again.ok);
  EXPECT_EQ(first.iterations, again.iterations);
  EXPECT_EQ(first.inlier_mask, again.inlier_mask);
  EXPECT_TRUE(first.target_from_source.isApprox(again.target_from_source, 0));
  parameters.seed = 99;
  const RigidRansacResult other = align_rigid_ransac(scene.source, scene.target, parameters);
  ASSERT_TRUE(other.ok);
  EXPECT_EQ(other.inlier_mask, first.inlier_mask);  // the same consensus from other samples
}

TEST(RigidRansac, DegenerateInputFailsWithoutThrowing) {
  const std::vector<Eigen::Vector3d> two = {{0, 0, 1}, {1, 0, 1}};
  RigidRansacResult result = align_rigid_ransac(two, two, {});
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("got 2"), std::string::npos) << result.failure;

  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 20; ++i) line.emplace_back(0.1 * i, 0.0, 2.0);
  result = align_rigid_ransac(line, line, {});
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("0 inliers"), std::string::npos) << result.failure;
  EXPECT_EQ(result.iterations, RigidRansacParameters{}.max_iterations);  // every sample was degenerate
}

TEST(RigidRansac, ParametersOutOfRangeThrowNamingThem) {
  const std::vector<Eigen::Vector3d> three = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  RigidRansacParameters parameters;
  parameters.inlier_threshold_m = 0;
  try {
    align_rigid_ransac(three, three, parameters);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "rigid RANSAC parameter inlier_threshold_m: expected > 0, got 0");
  }
  parameters = {};
  parameters.confidence = 1.0;
  EXPECT_THROW(align_rigid_ransac(three, three, parameters), std::invalid_argument);
  parameters = {};
  parameters.min_inliers = 2;
  EXPECT_THROW(align_rigid_ransac(three, three, parameters), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm::localization
