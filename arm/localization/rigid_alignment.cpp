// Formulas and sources: rigid_alignment.h.
#include "arm/localization/rigid_alignment.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "arm/localization/ransac_sampling.h"

namespace lpstereo::arm::localization {
namespace {

// The ratio s2 / s1 of the centred points' singular values (0 when all coincide): how far from a line.
double spread_ratio(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& used, const Eigen::Vector3d& centroid) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const int i : used) {
    const Eigen::Vector3d centred = points[static_cast<size_t>(i)] - centroid;
    scatter += centred * centred.transpose();
  }
  // Eigenvalues of the scatter are the squared singular values of the centred point matrix.
  const Eigen::Vector3d eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter, Eigen::EigenvaluesOnly).eigenvalues();
  const double largest = std::max(eigenvalues(2), 0.0);
  const double second = std::max(eigenvalues(1), 0.0);
  if (largest <= 0) return 0;
  return std::sqrt(second / largest);
}

// align_rigid over the pairs listed in `used`.
RigidAlignment align_subset(const std::vector<Eigen::Vector3d>& source_m, const std::vector<Eigen::Vector3d>& target_m,
                            const std::vector<int>& used, double collinear_tolerance) {
  RigidAlignment result;
  const size_t count = used.size();
  if (count < 3) {
    result.failure = "rigid alignment needs at least 3 point pairs, got " + std::to_string(count);
    return result;
  }
  Eigen::Vector3d source_centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d target_centroid = Eigen::Vector3d::Zero();
  for (const int i : used) {
    const auto& a = source_m[static_cast<size_t>(i)];
    const auto& b = target_m[static_cast<size_t>(i)];
    if (!a.allFinite() || !b.allFinite()) {
      result.failure = "rigid alignment: point pair " + std::to_string(i) + " is not finite";
      return result;
    }
    source_centroid += a;
    target_centroid += b;
  }
  source_centroid /= static_cast<double>(count);  // eq. 3.4
  target_centroid /= static_cast<double>(count);  // eq. 3.5
  const double source_spread = spread_ratio(source_m, used, source_centroid);
  const double target_spread = spread_ratio(target_m, used, target_centroid);
  if (source_spread <= collinear_tolerance || target_spread <= collinear_tolerance) {
    result.failure = std::string("rigid alignment: the ") + (source_spread <= collinear_tolerance ? "source" : "target") +
                     " points are collinear or coincident (second/first singular value " +
                     format_number(std::min(source_spread, target_spread)) + ", expected > " + format_number(collinear_tolerance) +
                     "): the rotation about their line is undetermined";
    return result;
  }
  Eigen::Matrix3d cross_covariance = Eigen::Matrix3d::Zero();  // eq. 3.8
  for (const int i : used) {
    cross_covariance += (source_m[static_cast<size_t>(i)] - source_centroid) *
                        (target_m[static_cast<size_t>(i)] - target_centroid).transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross_covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d v = svd.matrixV();
  const Eigen::Matrix3d& u = svd.matrixU();
  if ((v * u.transpose()).determinant() < 0) {
    v.col(2) *= -1;  // Umeyama's D = diag(1, 1, -1): the third column belongs to the smallest singular value
    result.reflection_fixed = true;
  }
  const Eigen::Matrix3d rotation = v * u.transpose();  // eq. 3.9
  result.target_from_source.linear() = rotation;
  result.target_from_source.translation() = target_centroid - rotation * source_centroid;  // eq. 3.10
  double squared_error = 0;  // eq. 3.11
  for (const int i : used) {
    squared_error += (result.target_from_source * source_m[static_cast<size_t>(i)] - target_m[static_cast<size_t>(i)]).squaredNorm();
  }
  result.rms_error_m = std::sqrt(squared_error / static_cast<double>(count));
  result.ok = true;
  return result;
}

void check_parameters(const RigidRansacParameters& p) {
  check_ransac_parameters("rigid RANSAC", "inlier_threshold_m", p.inlier_threshold_m, p.max_iterations, p.confidence,
                          p.min_inliers, 3);
  if (!(p.sample_collinear_tolerance >= 0 && p.sample_collinear_tolerance < 1)) {
    throw_parameter_error("rigid RANSAC", "sample_collinear_tolerance", "in [0, 1)", p.sample_collinear_tolerance);
  }
}

}  // namespace

RigidAlignment align_rigid(const std::vector<Eigen::Vector3d>& source_m, const std::vector<Eigen::Vector3d>& target_m,
                           double collinear_tolerance) {
  if (source_m.size() != target_m.size()) {
    RigidAlignment result;
    result.failure = "rigid alignment: " + std::to_string(source_m.size()) + " source points but " +
                     std::to_string(target_m.size()) + " target points, expected the same count";
    return result;
  }
  std::vector<int> all(source_m.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return align_subset(source_m, target_m, all, collinear_tolerance);
}

RigidRansacResult align_rigid_ransac(const std::vector<Eigen::Vector3d>& source_m,
                                     const std::vector<Eigen::Vector3d>& target_m, const RigidRansacParameters& parameters) {
  check_parameters(parameters);
  RigidRansacResult result;
  const int count = static_cast<int>(source_m.size());
  if (source_m.size() != target_m.size()) {
    result.failure = "rigid RANSAC: " + std::to_string(source_m.size()) + " source points but " +
                     std::to_string(target_m.size()) + " target points, expected the same count";
    return result;
  }
  if (count < parameters.min_inliers) {
    result.failure = "rigid RANSAC needs at least min_inliers = " + std::to_string(parameters.min_inliers) +
                     " point pairs, got " + std::to_string(count);
    return result;
  }
  const double threshold_squared = parameters.inlier_threshold_m * parameters.inlier_threshold_m;
  auto inliers_of = [&](const Eigen::Isometry3d& transform) {
    std::vector<int> inliers;
    for (int i = 0; i < count; ++i) {
      const double residual = (transform * source_m[static_cast<size_t>(i)] - target_m[static_cast<size_t>(i)]).squaredNorm();
      if (residual <= threshold_squared) inliers.push_back(i);  // NaN residuals are never inliers
    }
    return inliers;
  };

  const auto consensus = find_consensus<Eigen::Isometry3d>(
      count, 3, parameters.max_iterations, parameters.confidence, parameters.seed,
      [&](const std::vector<int>& sample) -> std::optional<Eigen::Isometry3d> {
        const RigidAlignment candidate = align_subset(source_m, target_m, sample, parameters.sample_collinear_tolerance);
        if (!candidate.ok) return std::nullopt;
        return candidate.target_from_source;
      },
      inliers_of);
  result.iterations = consensus.iterations;
  std::vector<int> best_inliers = consensus.inliers;
  if (static_cast<int>(best_inliers.size()) < parameters.min_inliers) {
    result.failure = "rigid RANSAC: best model has " + std::to_string(best_inliers.size()) + " inliers within " +
                     format_number(parameters.inlier_threshold_m) + " m, expected at least min_inliers = " +
                     std::to_string(parameters.min_inliers) + " (of " + std::to_string(count) + " pairs, " +
                     std::to_string(result.iterations) + " samples)";
    return result;
  }
  // Refit on the inliers; the refit's own inliers may grow the set (the sample's model is noisier).
  RigidAlignment refit = align_subset(source_m, target_m, best_inliers, kDefaultCollinearTolerance);
  for (int round = 0; round < 3 && refit.ok; ++round) {
    std::vector<int> grown = inliers_of(refit.target_from_source);
    if (grown.size() <= best_inliers.size()) break;
    RigidAlignment next = align_subset(source_m, target_m, grown, kDefaultCollinearTolerance);
    if (!next.ok) break;
    best_inliers = std::move(grown);
    refit = next;
  }
  if (!refit.ok) {
    result.failure = "rigid RANSAC: refit on " + std::to_string(best_inliers.size()) + " inliers failed: " + refit.failure;
    return result;
  }
  result.ok = true;
  result.target_from_source = refit.target_from_source;
  result.rms_error_m = refit.rms_error_m;
  result.inlier_mask.assign(static_cast<size_t>(count), 0);
  for (const int i : best_inliers) result.inlier_mask[static_cast<size_t>(i)] = 1;
  result.inlier_count = static_cast<int>(best_inliers.size());
  return result;
}

}  // namespace lpstereo::arm::localization
