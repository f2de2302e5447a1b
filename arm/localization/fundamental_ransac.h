// The fundamental matrix by the normalised 8-point algorithm inside RANSAC, to drop outlier matches
// between the current frame and a keyframe (thesis 003 §3.2.4, eq. 3.1).
//
// Epipolar constraint (eq. 3.1; Hartley and Zisserman, "Multiple View Geometry", 2nd ed., eq. 9.3):
// x2^T F x1 = 0 for homogeneous pixels x1 = (u1, v1, 1) in view 1 and x2 in view 2 of one scene point.
//
// Normalised 8-point algorithm (Hartley, "In defense of the eight-point algorithm", IEEE PAMI 19(6),
// 1997; H&Z Algorithm 11.1):
//   1. normalise each view: translate the centroid to the origin and scale so that the mean distance
//      from it is sqrt(2): x^ = T x (without this the system's conditioning ruins the estimate);
//   2. each pair gives a row (u2 u1, u2 v1, u2, v2 u1, v2 v1, v2, u1, v1, 1) of A, A f = 0; f is the
//      right singular vector of A's smallest singular value (least squares for more than 8 pairs);
//   3. rank 2: F^ = U diag(s1, s2, 0) V^T from the SVD of F^ (the closest singular matrix in
//      Frobenius norm: every epipolar line passes through the epipole);
//   4. denormalise F = T2^T F^ T1, scaled to unit Frobenius norm.
// Sampson distance (H&Z eq. 11.9, the first-order geometric error, px):
//   d^2 = (x2^T F x1)^2 / ((F x1)_1^2 + (F x1)_2^2 + (F^T x2)_1^2 + (F^T x2)_2^2),
// a pair is an inlier when d <= inlier_threshold_px.
//
// Planar scenes (a downward camera over flat ground): the 8 x 9 system of points on a plane has a
// 3-dimensional null space (every F = [e']x H with H the plane's homography, H&Z §11.9), so F is not
// unique. Each of them still holds every on-plane match with zero error, so RANSAC still rejects
// matches that disagree with the plane's motion, only less sharply (an outlier near the arbitrary
// epipolar line passes). The rigid RANSAC after it (pose_correction.h) catches what passes.
//
// Degenerate input, reported as ok = false with one line (no crash): fewer than 8 pairs, sizes that
// differ, non-finite pixels, or the points of either view collinear or coincident (normalisation
// impossible or the system rank-deficient beyond the plane case). RANSAC skips minimal samples that
// are collinear in either view.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace lpstereo::arm::localization {

struct FundamentalEstimate {
  bool ok = false;
  std::string failure;                                 // one line when !ok
  Eigen::Matrix3d fundamental = Eigen::Matrix3d::Zero();  // x2^T F x1 = 0, unit Frobenius norm, rank 2
};

// Normalised 8-point over all pairs (view1_px[i] matches view2_px[i]), pixels.
FundamentalEstimate fundamental_eight_point(const std::vector<Eigen::Vector2d>& view1_px,
                                            const std::vector<Eigen::Vector2d>& view2_px);

// The Sampson distance of one pair under F, px (formula in the header comment); +inf when the
// denominator is 0 (a pixel on the epipole).
double sampson_distance_px(const Eigen::Matrix3d& fundamental, const Eigen::Vector2d& view1_px,
                           const Eigen::Vector2d& view2_px);

struct FundamentalRansacParameters {
  double inlier_threshold_px = 1.0;  // Sampson distance, px (> 0)
  int max_iterations = 2000;         // cap on the adaptive count (>= 1)
  double confidence = 0.999;         // probability of one all-inlier sample, (0, 1)
  int min_inliers = 8;               // fewer than this (>= 8) fails
  uint64_t seed = 1;                 // generator seed (ransac_sampling.h)
};

struct FundamentalRansacResult {
  bool ok = false;
  std::string failure;  // one line when !ok
  Eigen::Matrix3d fundamental = Eigen::Matrix3d::Zero();
  std::vector<uint8_t> inlier_mask;  // 1 per inlier pair under the final F, size N
  int inlier_count = 0;
  int iterations = 0;                // samples drawn
  double rms_sampson_px = 0;         // over the final inliers
};

// RANSAC over minimal sets of 8 pairs (ties keep the earlier sample), adaptive iteration count, then
// the 8-point algorithm on all inliers of the best sample and the inliers of that refit. Throws
// std::invalid_argument for parameters out of range (naming the parameter, expected and value).
FundamentalRansacResult fundamental_ransac(const std::vector<Eigen::Vector2d>& view1_px,
                                           const std::vector<Eigen::Vector2d>& view2_px,
                                           const FundamentalRansacParameters& parameters);

}  // namespace lpstereo::arm::localization
