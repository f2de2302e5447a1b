// The normalised 8-point algorithm, the Sampson distance and F-RANSAC (arm/localization/fundamental_ransac.h)
// on a synthetic two-view scene whose true F is known in closed form.
#include "arm/localization/fundamental_ransac.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace lpstereo::arm::localization {
namespace {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

struct TwoViewScene {
  Eigen::Matrix3d true_fundamental;  // F = K^-T [t]x R K^-1 (H&Z eq. 9.2 with K1 = K2 = K)
  std::vector<Eigen::Vector2d> view1_px, view2_px;  // observed (noise, outliers)
  std::vector<Eigen::Vector2d> clean1_px, clean2_px;  // the exact projections
  std::vector<uint8_t> is_inlier;
};

TwoViewScene two_view_scene(int count, double outlier_share, double noise_px, unsigned seed) {
  std::mt19937 generator(seed);
  Eigen::Matrix3d k;
  k << 700, 0, 320, 0, 700, 240, 0, 0, 1;
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.12, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d translation(0.5, 0.1, 0.05);  // p2 = R p1 + t, metres
  TwoViewScene scene;
  scene.true_fundamental = k.inverse().transpose() * skew(translation) * rotation * k.inverse();
  std::uniform_real_distribution<double> lateral(-2.0, 2.0), depth(4.0, 8.0), offset(10.0, 40.0), sign(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  const int outliers = static_cast<int>(outlier_share * count);
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d p1(lateral(generator), lateral(generator), depth(generator));
    const Eigen::Vector3d p2 = rotation * p1 + translation;
    const Eigen::Vector2d x1 = (k * p1).hnormalized();
    const Eigen::Vector2d x2 = (k * p2).hnormalized();
    scene.clean1_px.push_back(x1);
    scene.clean2_px.push_back(x2);
    Eigen::Vector2d observed1 = x1 + Eigen::Vector2d(noise(generator), noise(generator));
    Eigen::Vector2d observed2 = x2 + Eigen::Vector2d(noise(generator), noise(generator));
    const bool inlier = i >= outliers;
    if (!inlier) {
      // Off its epipolar line by 10 .. 40 px: a wrong descriptor match.
      const Eigen::Vector3d line = scene.true_fundamental * x1.homogeneous();
      const Eigen::Vector2d normal = line.head<2>().normalized();
      observed2 += normal * offset(generator) * (sign(generator) < 0 ? -1.0 : 1.0);
    }
    scene.view1_px.push_back(observed1);
    scene.view2_px.push_back(observed2);
    scene.is_inlier.push_back(inlier ? 1 : 0);
  }
  return scene;
}

// F up to scale and sign.
double fundamental_difference(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::Matrix3d an = a / a.norm();
  const Eigen::Matrix3d bn = b / b.norm();
  return std::min((an - bn).norm(), (an + bn).norm());
}

TEST(SampsonDistance, MatchesTheClosedFormForARectifiedPair) {
  // Rectified pair: F = [e1]x with e1 = (1, 0, 0), x2^T F x1 = v1 - v2; F x1 = (0, -1, v1) and
  // F^T x2 = (0, 1, -v2), so d = |v1 - v2| / sqrt(1 + 1).
  Eigen::Matrix3d f;
  f << 0, 0, 0, 0, 0, -1, 0, 1, 0;
  EXPECT_NEAR(sampson_distance_px(f, {100, 50}, {80, 53}), 3.0 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(sampson_distance_px(f, {10, 7}, {400, 7}), 0.0, 1e-12);
  EXPECT_TRUE(std::isinf(sampson_distance_px(Eigen::Matrix3d::Zero(), {1, 2}, {3, 4})));
}

TEST(FundamentalEightPoint, NoiseFreeRecoversTheTrueMatrix) {
  const TwoViewScene scene = two_view_scene(30, 0.0, 0.0, 31);
  const FundamentalEstimate estimate = fundamental_eight_point(scene.view1_px, scene.view2_px);
  ASSERT_TRUE(estimate.ok) << estimate.failure;
  EXPECT_LT(fundamental_difference(estimate.fundamental, scene.true_fundamental), 1e-6);
  EXPECT_NEAR(estimate.fundamental.norm(), 1.0, 1e-12);
  EXPECT_NEAR(estimate.fundamental.determinant(), 0.0, 1e-12);  // rank 2
  for (size_t i = 0; i < scene.view1_px.size(); ++i) {
    EXPECT_LT(sampson_distance_px(estimate.fundamental, scene.view1_px[i], scene.view2_px[i]), 1e-6) << i;
  }
}

TEST(FundamentalEightPoint, ExactlyEightPairsGiveTheTrueMatrix) {
  TwoViewScene scene = two_view_scene(8, 0.0, 0.0, 32);
  const FundamentalEstimate estimate = fundamental_eight_point(scene.view1_px, scene.view2_px);
  ASSERT_TRUE(estimate.ok) << estimate.failure;
  EXPECT_LT(fundamental_difference(estimate.fundamental, scene.true_fundamental), 1e-5);
}

TEST(FundamentalRansac, RejectsThirtyPercentInjectedOutliers) {
  const TwoViewScene scene = two_view_scene(200, 0.3, 0.2, 33);
  FundamentalRansacParameters parameters;
  parameters.inlier_threshold_px = 1.25;
  const FundamentalRansacResult result = fundamental_ransac(scene.view1_px, scene.view2_px, parameters);
  ASSERT_TRUE(result.ok) << result.failure;
  ASSERT_EQ(result.inlier_mask.size(), scene.view1_px.size());
  int kept_inliers = 0;
  for (size_t i = 0; i < scene.is_inlier.size(); ++i) {
    if (!scene.is_inlier[i]) {
      EXPECT_EQ(result.inlier_mask[i], 0) << "outlier " << i << " accepted";
    } else {
      kept_inliers += result.inlier_mask[i];
    }
  }
  // 0.2 px noise in both views against a 1.25 px threshold: at most a few true matches lost.
  EXPECT_GE(kept_inliers, 137);  // of 140
  EXPECT_EQ(result.inlier_count, kept_inliers);
  EXPECT_LT(result.rms_sampson_px, 0.35);
  // Against the exact projections the estimated F must be close to the truth.
  double sum = 0;
  for (size_t i = 0; i < scene.clean1_px.size(); ++i) sum += sampson_distance_px(result.fundamental, scene.clean1_px[i], scene.clean2_px[i]);
  EXPECT_LT(sum / static_cast<double>(scene.clean1_px.size()), 0.3);
  EXPECT_NEAR(result.fundamental.determinant(), 0.0, 1e-12);
  EXPECT_LT(result.iterations, parameters.max_iterations);
}

TEST(FundamentalRansac, DeterministicForASeed) {
  const TwoViewScene scene = two_view_scene(80, 0.3, 0.2, 34);
  FundamentalRansacParameters parameters;
  const FundamentalRansacResult first = fundamental_ransac(scene.view1_px, scene.view2_px, parameters);
  const FundamentalRansacResult again = fundamental_ransac(scene.view1_px, scene.view2_px, parameters);
  ASSERT_TRUE(first.ok && again.ok);
  EXPECT_EQ(first.iterations, again.iterations);
  EXPECT_EQ(first.inlier_mask, again.inlier_mask);
  EXPECT_EQ(first.fundamental, again.fundamental);
}

TEST(FundamentalRansac, DegenerateInputFailsWithOneLine) {
  const TwoViewScene scene = two_view_scene(7, 0.0, 0.0, 35);
  FundamentalEstimate estimate = fundamental_eight_point(scene.view1_px, scene.view2_px);
  EXPECT_FALSE(estimate.ok);
  EXPECT_EQ(estimate.failure, "8-point algorithm needs at least 8 point pairs, got 7");
  FundamentalRansacResult result = fundamental_ransac(scene.view1_px, scene.view2_px, {});
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(result.failure, "fundamental RANSAC needs at least min_inliers = 8 point pairs, got 7");

  std::vector<Eigen::Vector2d> line1, line2;
  for (int i = 0; i < 20; ++i) {
    line1.emplace_back(10.0 * i, 5.0 * i + 3);
    line2.emplace_back(10.0 * i + 4, 5.0 * i + 1);
  }
  estimate = fundamental_eight_point(line1, line2);
  EXPECT_FALSE(estimate.ok);
  EXPECT_NE(estimate.failure.find("collinear"), std::string::npos) << estimate.failure;
  result = fundamental_ransac(line1, line2, {});
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find("0 inliers"), std::string::npos) << result.failure;

  std::vector<Eigen::Vector2d> shorter(scene.view1_px.begin(), scene.view1_px.end() - 1);
  estimate = fundamental_eight_point(scene.view1_px, shorter);
  EXPECT_FALSE(estimate.ok);
  EXPECT_NE(estimate.failure.find("7 view-1 points but 6 view-2 points"), std::string::npos) << estimate.failure;
  EXPECT_EQ(estimate.failure.find('\n'), std::string::npos);
}

TEST(FundamentalRansac, ParametersOutOfRangeThrowNamingThem) {
  const TwoViewScene scene = two_view_scene(20, 0.0, 0.0, 36);
  FundamentalRansacParameters parameters;
  parameters.min_inliers = 7;
  try {
    fundamental_ransac(scene.view1_px, scene.view2_px, parameters);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "fundamental RANSAC parameter min_inliers: expected >= 8, got 7");
  }
  parameters = {};
  parameters.inlier_threshold_px = -1;
  EXPECT_THROW(fundamental_ransac(scene.view1_px, scene.view2_px, parameters), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm::localization
