// Rigid alignment of matched 3D points (thesis 003 §3.2.5, eq. 3.2-3.11, after Besl and McKay 1992;
// the SVD solution of Arun, Huang, Blostein 1987, with Umeyama's reflection fix, IEEE PAMI 13(4),
// 1991, eq. 39-40), and the same inside RANSAC for matches with outliers.
//
// Problem: find R (a rotation, det R = +1) and t minimising sum_i |R a_i + t - b_i|^2 (eq. 3.11),
// so that b = R a + t (eq. 3.2). No scale: stereo gives metric points.
//   centroids      ca = mean a_i, cb = mean b_i                                (eq. 3.4, 3.5)
//   cross-covariance H = sum_i (a_i - ca)(b_i - cb)^T,  H = U S V^T             (eq. 3.8)
//   rotation       R = V D U^T,  D = diag(1, 1, sign det(V U^T))               (eq. 3.9 + the fix)
//   translation    t = cb - R ca                                               (eq. 3.10)
// Reflection: when det(V U^T) = -1 the unconstrained optimum over orthogonal matrices is a mirror
// (noisy or planar data: points on the ground seen by a downward camera make H rank 2, and the sign
// of the third singular vector is arbitrary); flipping the third column of V (the smallest singular
// value's) gives the best proper rotation (Umeyama 1991, Lemma). The thesis states the same fix.
//
// Degenerate input, reported as ok = false with one line (no exception, no crash): fewer than 3
// pairs, sizes that differ, non-finite coordinates, or source or target points that are (nearly)
// collinear or coincident: the rotation about their common line is then undetermined. "Nearly" is
// the second singular value of the centred 3 x N point matrix at most collinear_tolerance times the
// first (scale-free).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lpstereo::arm::localization {

struct RigidAlignment {
  bool ok = false;
  std::string failure;                                       // one line when !ok
  Eigen::Isometry3d target_from_source = Eigen::Isometry3d::Identity();  // b = R a + t
  double rms_error_m = 0;                                    // sqrt(eq. 3.11 / N) over the pairs used
  bool reflection_fixed = false;                             // det(V U^T) was -1 and D flipped it
};

inline constexpr double kDefaultCollinearTolerance = 1e-6;

// Kabsch / Umeyama without scale over all pairs (source_m[i] matches target_m[i]), metres.
RigidAlignment align_rigid(const std::vector<Eigen::Vector3d>& source_m, const std::vector<Eigen::Vector3d>& target_m,
                           double collinear_tolerance = kDefaultCollinearTolerance);

struct RigidRansacParameters {
  double inlier_threshold_m = 0.05;  // a pair is an inlier when |R a + t - b| <= this, metres (> 0)
  int max_iterations = 200;          // cap on the adaptive count (>= 1); the thesis needed <= 10 on clean data
  double confidence = 0.999;         // probability of drawing one all-inlier sample, (0, 1)
  int min_inliers = 3;               // fewer inliers than this (>= 3) fails
  // Minimal samples whose points are this close to collinear (relative second singular value) are
  // skipped and drawn again; larger than the exact-data tolerance because a thin triangle of noisy
  // points gives a badly conditioned rotation.
  double sample_collinear_tolerance = 1e-3;
  uint64_t seed = 1;                 // the generator's seed (ransac_sampling.h): same seed, same result
};

struct RigidRansacResult {
  bool ok = false;
  std::string failure;  // one line when !ok
  Eigen::Isometry3d target_from_source = Eigen::Isometry3d::Identity();
  std::vector<uint8_t> inlier_mask;  // 1 per inlier pair of the final refit, size N
  int inlier_count = 0;
  int iterations = 0;                // samples drawn (degenerate ones included)
  double rms_error_m = 0;            // over the final inliers
};

// RANSAC (Fischler and Bolles 1981) over minimal sets of 3 pairs, scored by the inlier count (ties
// keep the earlier sample), adaptive iteration count (ransac_sampling.h), then align_rigid on the
// best sample's inliers and the inliers of that refit (refit again while the set grows, at most 3
// times). Throws std::invalid_argument for parameters out of range (the message names the parameter,
// the expected range and the value); degenerate data give ok = false.
RigidRansacResult align_rigid_ransac(const std::vector<Eigen::Vector3d>& source_m,
                                     const std::vector<Eigen::Vector3d>& target_m, const RigidRansacParameters& parameters);

}  // namespace lpstereo::arm::localization
