// Formulas and sources: fundamental_ransac.h.
#include "arm/localization/fundamental_ransac.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "arm/localization/ransac_sampling.h"

namespace lpstereo::arm::localization {
namespace {

constexpr double kCollinearTolerance = 1e-6;        // whole sets: exactly collinear within rounding
constexpr double kSampleCollinearTolerance = 1e-3;  // minimal samples: a sliver is as bad as a line

// sqrt(lambda_min / lambda_max) of the 2 x 2 scatter of the listed points: 0 on a line or a point.
double spread_ratio(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& used) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const int i : used) centroid += points[static_cast<size_t>(i)];
  centroid /= static_cast<double>(used.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const int i : used) {
    const Eigen::Vector2d centred = points[static_cast<size_t>(i)] - centroid;
    scatter += centred * centred.transpose();
  }
  const Eigen::Vector2d eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter, Eigen::EigenvaluesOnly).eigenvalues();
  if (eigenvalues(1) <= 0) return 0;
  return std::sqrt(std::max(eigenvalues(0), 0.0) / eigenvalues(1));
}

// Step 1: T with centroid -> origin, mean distance -> sqrt(2).
Eigen::Matrix3d normalising_transform(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& used) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const int i : used) centroid += points[static_cast<size_t>(i)];
  centroid /= static_cast<double>(used.size());
  double mean_distance = 0;
  for (const int i : used) mean_distance += (points[static_cast<size_t>(i)] - centroid).norm();
  mean_distance /= static_cast<double>(used.size());
  const double scale = std::sqrt(2.0) / mean_distance;  // mean_distance > 0: checked by the caller (spread)
  Eigen::Matrix3d transform;
  transform << scale, 0, -scale * centroid.x(), 0, scale, -scale * centroid.y(), 0, 0, 1;
  return transform;
}

FundamentalEstimate eight_point_subset(const std::vector<Eigen::Vector2d>& view1_px, const std::vector<Eigen::Vector2d>& view2_px,
                                       const std::vector<int>& used, double collinear_tolerance) {
  FundamentalEstimate result;
  if (used.size() < 8) {
    result.failure = "8-point algorithm needs at least 8 point pairs, got " + std::to_string(used.size());
    return result;
  }
  for (const int i : used) {
    if (!view1_px[static_cast<size_t>(i)].allFinite() || !view2_px[static_cast<size_t>(i)].allFinite()) {
      result.failure = "8-point algorithm: pair " + std::to_string(i) + " is not finite";
      return result;
    }
  }
  const double spread1 = spread_ratio(view1_px, used);
  const double spread2 = spread_ratio(view2_px, used);
  if (spread1 <= collinear_tolerance || spread2 <= collinear_tolerance) {
    result.failure = std::string("8-point algorithm: the points of view ") + (spread1 <= collinear_tolerance ? "1" : "2") +
                     " are collinear or coincident (spread ratio " + format_number(std::min(spread1, spread2)) + ", expected > " +
                     format_number(collinear_tolerance) + ")";
    return result;
  }
  const Eigen::Matrix3d t1 = normalising_transform(view1_px, used);
  const Eigen::Matrix3d t2 = normalising_transform(view2_px, used);
  Eigen::MatrixXd system(static_cast<Eigen::Index>(std::max<size_t>(used.size(), 9)), 9);
  system.setZero();  // 8 pairs: a zero 9th row keeps the SVD square, same null space
  Eigen::Index row = 0;
  for (const int i : used) {
    const Eigen::Vector3d a = t1 * view1_px[static_cast<size_t>(i)].homogeneous();
    const Eigen::Vector3d b = t2 * view2_px[static_cast<size_t>(i)].homogeneous();
    system.row(row++) << b.x() * a.x(), b.x() * a.y(), b.x(), b.y() * a.x(), b.y() * a.y(), b.y(), a.x(), a.y(), 1;  // step 2
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(system, Eigen::ComputeFullV);
  const Eigen::VectorXd f = svd.matrixV().col(8);
  Eigen::Matrix3d normalised;
  normalised << f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7), f(8);
  const Eigen::JacobiSVD<Eigen::Matrix3d> rank_svd(normalised, Eigen::ComputeFullU | Eigen::ComputeFullV);  // step 3
  Eigen::Vector3d singular = rank_svd.singularValues();
  singular(2) = 0;
  normalised = rank_svd.matrixU() * singular.asDiagonal() * rank_svd.matrixV().transpose();
  Eigen::Matrix3d fundamental = t2.transpose() * normalised * t1;  // step 4
  const double norm = fundamental.norm();
  if (!(norm > 0) || !fundamental.allFinite()) {
    result.failure = "8-point algorithm: the estimate is zero or not finite";
    return result;
  }
  result.fundamental = fundamental / norm;
  result.ok = true;
  return result;
}

void check_parameters(const FundamentalRansacParameters& p) {
  check_ransac_parameters("fundamental RANSAC", "inlier_threshold_px", p.inlier_threshold_px, p.max_iterations, p.confidence,
                          p.min_inliers, 8);
}

std::string size_mismatch(size_t a, size_t b) {
  return std::to_string(a) + " view-1 points but " + std::to_string(b) + " view-2 points, expected the same count";
}

}  // namespace

FundamentalEstimate fundamental_eight_point(const std::vector<Eigen::Vector2d>& view1_px,
                                            const std::vector<Eigen::Vector2d>& view2_px) {
  if (view1_px.size() != view2_px.size()) {
    FundamentalEstimate result;
    result.failure = "8-point algorithm: " + size_mismatch(view1_px.size(), view2_px.size());
    return result;
  }
  std::vector<int> all(view1_px.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return eight_point_subset(view1_px, view2_px, all, kCollinearTolerance);
}

double sampson_distance_px(const Eigen::Matrix3d& fundamental, const Eigen::Vector2d& view1_px, const Eigen::Vector2d& view2_px) {
  const Eigen::Vector3d x1 = view1_px.homogeneous();
  const Eigen::Vector3d x2 = view2_px.homogeneous();
  const Eigen::Vector3d line2 = fundamental * x1;              // epipolar line of x1 in view 2
  const Eigen::Vector3d line1 = fundamental.transpose() * x2;  // epipolar line of x2 in view 1
  const double algebraic = x2.dot(line2);
  const double denominator = line2.x() * line2.x() + line2.y() * line2.y() + line1.x() * line1.x() + line1.y() * line1.y();
  if (!(denominator > 0)) return std::numeric_limits<double>::infinity();
  return std::abs(algebraic) / std::sqrt(denominator);
}

FundamentalRansacResult fundamental_ransac(const std::vector<Eigen::Vector2d>& view1_px,
                                           const std::vector<Eigen::Vector2d>& view2_px,
                                           const FundamentalRansacParameters& parameters) {
  check_parameters(parameters);
  FundamentalRansacResult result;
  if (view1_px.size() != view2_px.size()) {
    result.failure = "fundamental RANSAC: " + size_mismatch(view1_px.size(), view2_px.size());
    return result;
  }
  const int count = static_cast<int>(view1_px.size());
  if (count < parameters.min_inliers) {
    result.failure = "fundamental RANSAC needs at least min_inliers = " + std::to_string(parameters.min_inliers) +
                     " point pairs, got " + std::to_string(count);
    return result;
  }
  auto inliers_of = [&](const Eigen::Matrix3d& fundamental) {
    std::vector<int> inliers;
    for (int i = 0; i < count; ++i) {
      // NaN distances (non-finite pixels) are never inliers.
      if (sampson_distance_px(fundamental, view1_px[static_cast<size_t>(i)], view2_px[static_cast<size_t>(i)]) <=
          parameters.inlier_threshold_px) {
        inliers.push_back(i);
      }
    }
    return inliers;
  };
  const auto consensus = find_consensus<Eigen::Matrix3d>(
      count, 8, parameters.max_iterations, parameters.confidence, parameters.seed,
      [&](const std::vector<int>& sample) -> std::optional<Eigen::Matrix3d> {
        const FundamentalEstimate candidate = eight_point_subset(view1_px, view2_px, sample, kSampleCollinearTolerance);
        if (!candidate.ok) return std::nullopt;
        return candidate.fundamental;
      },
      inliers_of);
  result.iterations = consensus.iterations;
  const std::vector<int>& best_inliers = consensus.inliers;
  if (static_cast<int>(best_inliers.size()) < parameters.min_inliers) {
    result.failure = "fundamental RANSAC: best model has " + std::to_string(best_inliers.size()) + " inliers within " +
                     format_number(parameters.inlier_threshold_px) + " px (Sampson), expected at least min_inliers = " +
                     std::to_string(parameters.min_inliers) + " (of " + std::to_string(count) + " pairs, " +
                     std::to_string(result.iterations) + " samples)";
    return result;
  }
  // Refit on the inliers; keep it when it explains at least as many pairs (least squares over noisy
  // inliers can tilt F; then the best sample's F stays).
  Eigen::Matrix3d fundamental = *consensus.model;
  std::vector<int> final_inliers = best_inliers;
  const FundamentalEstimate refit = eight_point_subset(view1_px, view2_px, best_inliers, kCollinearTolerance);
  if (refit.ok) {
    std::vector<int> refit_inliers = inliers_of(refit.fundamental);
    if (refit_inliers.size() >= best_inliers.size()) {
      fundamental = refit.fundamental;
      final_inliers = std::move(refit_inliers);
    }
  }
  double squared = 0;
  for (const int i : final_inliers) {
    const double d = sampson_distance_px(fundamental, view1_px[static_cast<size_t>(i)], view2_px[static_cast<size_t>(i)]);
    squared += d * d;
  }
  result.ok = true;
  result.fundamental = fundamental;
  result.inlier_count = static_cast<int>(final_inliers.size());
  result.rms_sampson_px = std::sqrt(squared / static_cast<double>(final_inliers.size()));
  result.inlier_mask.assign(static_cast<size_t>(count), 0);
  for (const int i : final_inliers) result.inlier_mask[static_cast<size_t>(i)] = 1;
  return result;
}

}  // namespace lpstereo::arm::localization
