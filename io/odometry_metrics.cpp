#include "io/odometry_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace lpstereo::io {

namespace {

constexpr double kDegreesPerRadian = 180.0 / 3.14159265358979323846;
constexpr double kKittiLongestLength_m = 800;
constexpr double kAutomaticSpacingUnit_m = 5;

std::string metres_text(double metres) {
  std::ostringstream text;
  text.precision(4);
  text << metres << " m";
  return text.str();
}

// The relative pose error of one segment, as the devkit: E = (Pe_i^-1 Pe_j)^-1 (Pg_i^-1 Pg_j).
SegmentError segment_error(const std::vector<Eigen::Isometry3d>& estimate, const std::vector<Eigen::Isometry3d>& ground_truth,
                           int first_frame, int last_frame, double length_m) {
  const Eigen::Isometry3d estimate_motion = estimate[first_frame].inverse() * estimate[last_frame];
  const Eigen::Isometry3d true_motion = ground_truth[first_frame].inverse() * ground_truth[last_frame];
  const Eigen::Isometry3d error = estimate_motion.inverse() * true_motion;
  SegmentError segment;
  segment.first_frame = first_frame;
  segment.last_frame = last_frame;
  segment.length_m = length_m;
  segment.translation_error_m = error.translation().norm();
  segment.rotation_error_rad = rotation_angle_rad(error.linear());
  return segment;
}

}  // namespace

std::vector<double> kitti_segment_lengths_m() { return {100, 200, 300, 400, 500, 600, 700, 800}; }

std::vector<double> automatic_segment_lengths_m(double path_length_m) {
  if (path_length_m > kKittiLongestLength_m) return kitti_segment_lengths_m();
  const double tenths = std::round(path_length_m / 10 / kAutomaticSpacingUnit_m);
  const double spacing_m = kAutomaticSpacingUnit_m * std::max(1.0, tenths);
  std::vector<double> lengths_m;
  for (int k = 1; k * spacing_m <= path_length_m; ++k) lengths_m.push_back(k * spacing_m);
  return lengths_m;
}

std::vector<double> trajectory_distances_m(const std::vector<Eigen::Isometry3d>& poses) {
  std::vector<double> distances_m;
  distances_m.reserve(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    distances_m.push_back(i == 0 ? 0.0 : distances_m.back() + (poses[i].translation() - poses[i - 1].translation()).norm());
  }
  return distances_m;
}

double rotation_angle_rad(const Eigen::Matrix3d& rotation) {
  // cos = (trace - 1) / 2 and sin = |vee(R - R^T)| / 2 (Rodrigues); atan2 keeps the precision that
  // acos loses near 0 and near pi.
  const double cosine = (rotation.trace() - 1) / 2;
  const Eigen::Vector3d axis_times_sine(rotation(2, 1) - rotation(1, 2), rotation(0, 2) - rotation(2, 0),
                                        rotation(1, 0) - rotation(0, 1));
  return std::atan2(axis_times_sine.norm() / 2, cosine);
}

OdometryErrors evaluate_odometry(const std::vector<Eigen::Isometry3d>& estimate,
                                 const std::vector<Eigen::Isometry3d>& ground_truth, const OdometrySettings& settings) {
  if (estimate.size() != ground_truth.size()) {
    throw OdometryEvaluationError("expected as many estimated poses as ground-truth poses (one per frame), got " +
                                  std::to_string(estimate.size()) + " estimated and " + std::to_string(ground_truth.size()) +
                                  " ground-truth poses");
  }
  if (ground_truth.empty()) throw OdometryEvaluationError("expected at least one pose, got none");
  if (settings.step_frames <= 0) {
    throw OdometryEvaluationError("step: expected a positive number of frames, got " + std::to_string(settings.step_frames));
  }
  for (size_t k = 0; k < settings.segment_lengths_m.size(); ++k) {
    const double length_m = settings.segment_lengths_m[k];
    if (!(length_m > 0) || !std::isfinite(length_m)) {
      throw OdometryEvaluationError("segment length: expected a positive number of metres, got " + std::to_string(length_m));
    }
    if (std::count(settings.segment_lengths_m.begin(), settings.segment_lengths_m.begin() + k, length_m) > 0) {
      throw OdometryEvaluationError("segment length: expected each length once, got " + metres_text(length_m) + " twice");
    }
  }

  OdometryErrors result;
  result.frames = static_cast<int>(ground_truth.size());
  result.step_frames = settings.step_frames;
  const std::vector<double> distances_m = trajectory_distances_m(ground_truth);
  result.ground_truth_path_m = distances_m.back();
  result.estimate_path_m = trajectory_distances_m(estimate).back();
  const std::vector<double> lengths_m =
      settings.segment_lengths_m.empty() ? automatic_segment_lengths_m(result.ground_truth_path_m) : settings.segment_lengths_m;
  if (lengths_m.empty()) {
    throw OdometryEvaluationError("the ground truth's path is " + metres_text(result.ground_truth_path_m) + " over " +
                                  std::to_string(result.frames) + " frame(s): expected at least " +
                                  metres_text(kAutomaticSpacingUnit_m) + " for the shortest automatic segment length");
  }

  // The devkit's loop: first frames in steps, every length from each (segments ordered by first frame).
  for (int first = 0; first < result.frames; first += settings.step_frames) {
    for (double length_m : lengths_m) {
      const auto last = std::lower_bound(distances_m.begin() + first, distances_m.end(), distances_m[first] + length_m);
      if (last == distances_m.end()) continue;
      result.segments.push_back(
          segment_error(estimate, ground_truth, first, static_cast<int>(last - distances_m.begin()), length_m));
    }
  }
  if (result.segments.empty()) {
    const double longest_m = *std::max_element(lengths_m.begin(), lengths_m.end());
    const double shortest_m = *std::min_element(lengths_m.begin(), lengths_m.end());
    throw OdometryEvaluationError("the ground truth's path is " + metres_text(result.ground_truth_path_m) + " over " +
                                  std::to_string(result.frames) + " frame(s): no segment of " + metres_text(shortest_m) +
                                  (longest_m > shortest_m ? " to " + metres_text(longest_m) : std::string()) +
                                  " fits (expected a path at least as long as the shortest segment length)");
  }

  const double nan = std::numeric_limits<double>::quiet_NaN();
  double translation_sum = 0, rotation_sum = 0;
  for (double length_m : lengths_m) {
    LengthErrors summary;
    summary.length_m = length_m;
    double translation = 0, rotation = 0;
    for (const SegmentError& segment : result.segments) {
      if (segment.length_m != length_m) continue;
      ++summary.segments;
      translation += segment.translation_error_m / length_m;
      rotation += segment.rotation_error_rad / length_m;
    }
    summary.translation_error_pct = summary.segments > 0 ? 100 * translation / summary.segments : nan;
    summary.rotation_error_deg_per_m = summary.segments > 0 ? kDegreesPerRadian * rotation / summary.segments : nan;
    translation_sum += translation;
    rotation_sum += rotation;
    result.per_length.push_back(summary);
  }
  const double segment_count = static_cast<double>(result.segments.size());
  result.translation_error_pct = 100 * translation_sum / segment_count;
  result.rotation_error_deg_per_m = kDegreesPerRadian * rotation_sum / segment_count;

  const Eigen::Isometry3d& estimate_end = estimate.back();
  const Eigen::Isometry3d& true_end = ground_truth.back();
  result.end_point_error_m = (estimate_end.translation() - true_end.translation()).norm();
  result.end_point_error_pct = result.ground_truth_path_m > 0 ? 100 * result.end_point_error_m / result.ground_truth_path_m : nan;
  result.end_rotation_error_deg = kDegreesPerRadian * rotation_angle_rad(estimate_end.linear().transpose() * true_end.linear());
  double squared_sum_m2 = 0;
  for (size_t i = 0; i < ground_truth.size(); ++i) {
    squared_sum_m2 += (estimate[i].translation() - ground_truth[i].translation()).squaredNorm();
  }
  result.ate_rmse_m = std::sqrt(squared_sum_m2 / static_cast<double>(ground_truth.size()));
  return result;
}

}  // namespace lpstereo::io
