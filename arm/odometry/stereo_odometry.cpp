#include "arm/odometry/stereo_odometry.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>

#include <Eigen/Dense>

#include "arm/scheduler.h"
#include "arm/tasks/keypoint_record.h"
#include "kernels/brief_hamming.h"
#include "kernels/brief_pattern.h"

namespace lpstereo::arm {

namespace {

static_assert(kernels::kBriefWords == 8, "OdometryFeature holds 8 descriptor words (BRIEF-256)");

void check(bool ok, const char* name, const std::string& expected, double actual) {
  if (!ok) {
    char text[64];
    std::snprintf(text, sizeof text, "%g", actual);
    throw std::invalid_argument(std::string("odometry parameter '") + name + "': expected " + expected + ", got " + text);
  }
}

// One observation of the motion: the point triangulated at t-1 (camera t-1, metres) and where it is
// seen at t in the left and the right view (px).
struct CircleMatch {
  Eigen::Vector3d point_previous;
  Eigen::Vector2d left_px, right_px;
};

Eigen::Vector3d triangulate(const StereoOdometryParameters& p, const Eigen::Vector2d& left_px, const Eigen::Vector2d& right_px) {
  // Rectified pair (DESIGN.md §4): Z = f B / d, X = (u - cx) Z / f, Y = (v - cy) Z / f; the row is the
  // mean of the two views' rows.
  const double disparity_px = left_px.x() - right_px.x();
  const double depth_m = p.focal_px * p.baseline_m / disparity_px;
  const double row_px = 0.5 * (left_px.y() + right_px.y());
  return {(left_px.x() - p.principal_point_x_px) * depth_m / p.focal_px, (row_px - p.principal_point_y_px) * depth_m / p.focal_px,
          depth_m};
}

Eigen::Vector3d triangulate(const StereoOdometryParameters& p, const OdometryFeature& left, const OdometryFeature& right) {
  return triangulate(p, Eigen::Vector2d(left.x_px, left.y_px), Eigen::Vector2d(right.x_px, right.y_px));
}

// Projection of a camera-frame point into the left (right = false) or right view.
Eigen::Vector2d project(const StereoOdometryParameters& p, const Eigen::Vector3d& point, bool right) {
  const double x = right ? point.x() - p.baseline_m : point.x();
  return {p.focal_px * x / point.z() + p.principal_point_x_px, p.focal_px * point.y() / point.z() + p.principal_point_y_px};
}

constexpr double kMinDepthM = 1e-3;  // a point must stay in front of the camera

// Reprojection error of one match under `motion` (points t-1 -> t): the larger of the left and the
// right image error, px; +inf behind the camera.
double reprojection_error(const StereoOdometryParameters& p, const Eigen::Isometry3d& motion, const CircleMatch& match,
                          double* left_error, double* right_error) {
  const Eigen::Vector3d point = motion * match.point_previous;
  if (!(point.z() > kMinDepthM)) return std::numeric_limits<double>::infinity();
  const double el = (project(p, point, false) - match.left_px).norm();
  const double er = (project(p, point, true) - match.right_px).norm();
  if (left_error) *left_error = el;
  if (right_error) *right_error = er;
  return std::max(el, er);
}

// Gauss-Newton on the 6-DoF motion minimising the squared reprojection errors in both images at t
// (libviso2's estimator; left-multiplicative update T <- exp([w]x, v) T, Jacobian dP/dw = -[P]x,
// dP/dv = I, pinhole derivatives du/dP = f (1/Z, 0, -X/Z^2), dv/dP = f (0, 1/Z, -Y/Z^2), the right
// view with X - B). Returns false when the system is singular or a point falls behind the camera.
bool gauss_newton(const StereoOdometryParameters& p, const std::vector<CircleMatch>& matches, const std::vector<int>& used,
                  int iterations, Eigen::Isometry3d& motion, StereoOdometryStatistics& counts) {
  for (int iteration = 0; iteration < iterations; ++iteration) {
    counts.gauss_newton_point_steps += static_cast<int64_t>(used.size());
    ++counts.gauss_newton_solves;
    Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> gradient = Eigen::Matrix<double, 6, 1>::Zero();
    for (int index : used) {
      const CircleMatch& match = matches[static_cast<size_t>(index)];
      const Eigen::Vector3d point = motion * match.point_previous;
      if (!(point.z() > kMinDepthM)) return false;
      Eigen::Matrix<double, 3, 6> point_jacobian;
      point_jacobian.leftCols<3>() << 0, point.z(), -point.y(), -point.z(), 0, point.x(), point.y(), -point.x(), 0;
      point_jacobian.rightCols<3>().setIdentity();
      const double inverse_z = 1.0 / point.z();
      for (int view = 0; view < 2; ++view) {
        const double x = view == 0 ? point.x() : point.x() - p.baseline_m;
        Eigen::Matrix<double, 2, 3> projection_jacobian;
        projection_jacobian << p.focal_px * inverse_z, 0, -p.focal_px * x * inverse_z * inverse_z, 0, p.focal_px * inverse_z,
            -p.focal_px * point.y() * inverse_z * inverse_z;
        const Eigen::Matrix<double, 2, 6> jacobian = projection_jacobian * point_jacobian;
        const Eigen::Vector2d observed = view == 0 ? match.left_px : match.right_px;
        const Eigen::Vector2d residual = observed - project(p, point, view == 1);
        normal += jacobian.transpose() * jacobian;
        gradient += jacobian.transpose() * residual;
      }
    }
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(normal);
    if (solver.info() != Eigen::Success) return false;
    const Eigen::Matrix<double, 6, 1> step = solver.solve(gradient);
    if (!step.allFinite()) return false;
    Eigen::Isometry3d update = Eigen::Isometry3d::Identity();
    const double angle = step.head<3>().norm();
    if (angle > 0) update.linear() = Eigen::AngleAxisd(angle, step.head<3>() / angle).toRotationMatrix();
    update.translation() = step.tail<3>();
    motion = update * motion;
    if (step.norm() < 1e-10) break;
  }
  return true;
}

std::vector<int> inliers_of(const StereoOdometryParameters& p, const std::vector<CircleMatch>& matches,
                            const Eigen::Isometry3d& motion, StereoOdometryStatistics& counts) {
  counts.reprojection_tests += static_cast<int64_t>(matches.size());
  std::vector<int> inliers;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (reprojection_error(p, motion, matches[i], nullptr, nullptr) <= p.inlier_threshold_px) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

}  // namespace

void StereoOdometryParameters::validate() const {
  check(focal_px > 0 && std::isfinite(focal_px), "focal_px", "a number > 0", focal_px);
  check(baseline_m > 0 && std::isfinite(baseline_m), "baseline_m", "a number > 0", baseline_m);
  check(std::isfinite(principal_point_x_px), "principal_point_x_px", "a finite number", principal_point_x_px);
  check(std::isfinite(principal_point_y_px), "principal_point_y_px", "a finite number", principal_point_y_px);
  check(harris_threshold >= 0, "harris_threshold", ">= 0", harris_threshold);
  check(cell_size_px >= 8, "cell_size_px", ">= 8", cell_size_px);
  check(per_cell_k >= 1, "per_cell_k", ">= 1", per_cell_k);
  check(max_keypoints >= 3, "max_keypoints", ">= 3", max_keypoints);
  check(border_px >= 16, "border_px", ">= 16 (brief256's 31 x 31 patch)", border_px);
  check(max_hamming_distance >= 0 && max_hamming_distance <= 256, "max_hamming_distance", "0 .. 256", max_hamming_distance);
  check(ratio_test > 0 && ratio_test <= 1, "ratio_test", "in (0, 1]", ratio_test);
  check(epipolar_tolerance_px >= 0, "epipolar_tolerance_px", ">= 0", epipolar_tolerance_px);
  check(min_disparity_px > 0, "min_disparity_px", "> 0 (points in front of the rig)", min_disparity_px);
  check(max_disparity_px > min_disparity_px, "max_disparity_px", "> min_disparity_px", max_disparity_px);
  check(predicted_radius_px > 0, "predicted_radius_px", "> 0", predicted_radius_px);
  check(search_radius_px > 0, "search_radius_px", "> 0", search_radius_px);
  check(ransac_iterations >= 1, "ransac_iterations", ">= 1", ransac_iterations);
  check(gauss_newton_iterations >= 1, "gauss_newton_iterations", ">= 1", gauss_newton_iterations);
  check(inlier_threshold_px > 0, "inlier_threshold_px", "> 0", inlier_threshold_px);
  check(min_inliers >= 3, "min_inliers", ">= 3 (a minimal set)", min_inliers);
}

std::string StereoOdometryParameters::summary() const {
  char text[640];
  std::snprintf(text, sizeof text,
                "f %.3f px, c (%.2f, %.2f) px, B %.4f m; Harris > %d, %d per %d px cell, <= %d per view; Hamming <= %d, ratio %.2f; "
                "epipolar +-%.2f px, disparity %.1f .. %.1f px; temporal radius %.0f px (predicted) / %.0f px; RANSAC %d x 3 points, "
                "Gauss-Newton %d, inlier %.2f px, >= %d inliers",
                focal_px, principal_point_x_px, principal_point_y_px, baseline_m, harris_threshold, per_cell_k, cell_size_px,
                max_keypoints, max_hamming_distance, ratio_test, epipolar_tolerance_px, min_disparity_px, max_disparity_px,
                predicted_radius_px, search_radius_px, ransac_iterations, gauss_newton_iterations, inlier_threshold_px, min_inliers);
  return text;
}

std::vector<int> match_features(const std::vector<OdometryFeature>& queries, const std::vector<Eigen::Vector2d>& centres,
                                const std::vector<OdometryFeature>& candidates, const MatchWindow& window,
                                int max_hamming_distance, double ratio_test, int64_t* hamming_distances) {
  if (window.kind == MatchWindow::Kind::radius && centres.size() != queries.size()) {
    throw std::invalid_argument("match_features: expected one radius-window centre per query (" + std::to_string(queries.size()) +
                                "), got " + std::to_string(centres.size()));
  }
  std::vector<int> result(queries.size(), -1);
  int64_t comparisons = 0;
  if (candidates.empty()) return result;
  // Candidates bucketed in 16 x 16 px cells, so a query visits only the cells its window covers.
  constexpr double kCellPx = 16.0;
  double max_x = 0, max_y = 0;
  for (const OdometryFeature& c : candidates) {
    max_x = std::max(max_x, c.x_px);
    max_y = std::max(max_y, c.y_px);
  }
  const int columns = static_cast<int>(max_x / kCellPx) + 1, rows = static_cast<int>(max_y / kCellPx) + 1;
  std::vector<std::vector<int>> cells(static_cast<size_t>(columns) * static_cast<size_t>(rows));
  for (size_t i = 0; i < candidates.size(); ++i) {
    const int cx = std::max(0, static_cast<int>(candidates[i].x_px / kCellPx));
    const int cy = std::max(0, static_cast<int>(candidates[i].y_px / kCellPx));
    cells[static_cast<size_t>(cy) * static_cast<size_t>(columns) + static_cast<size_t>(cx)].push_back(static_cast<int>(i));
  }
  for (size_t q = 0; q < queries.size(); ++q) {
    const OdometryFeature& query = queries[q];
    double x0, x1, y0, y1;
    Eigen::Vector2d centre(query.x_px, query.y_px);
    if (window.kind == MatchWindow::Kind::epipolar) {
      x0 = query.x_px - window.max_disparity_px;
      x1 = query.x_px - window.min_disparity_px;
      y0 = query.y_px - window.epipolar_tolerance_px;
      y1 = query.y_px + window.epipolar_tolerance_px;
    } else {
      centre = centres[q];
      if (!centre.allFinite()) continue;
      x0 = centre.x() - window.radius_px;
      x1 = centre.x() + window.radius_px;
      y0 = centre.y() - window.radius_px;
      y1 = centre.y() + window.radius_px;
    }
    if (x1 < 0 || y1 < 0) continue;
    const int cx0 = std::max(0, static_cast<int>(std::floor(x0 / kCellPx)));
    const int cx1 = std::min(columns - 1, static_cast<int>(std::floor(x1 / kCellPx)));
    const int cy0 = std::max(0, static_cast<int>(std::floor(y0 / kCellPx)));
    const int cy1 = std::min(rows - 1, static_cast<int>(std::floor(y1 / kCellPx)));
    int best = std::numeric_limits<int>::max(), second = std::numeric_limits<int>::max(), best_index = -1;
    const double radius_sq = window.radius_px * window.radius_px;
    for (int cy = cy0; cy <= cy1; ++cy) {
      for (int cx = cx0; cx <= cx1; ++cx) {
        for (int index : cells[static_cast<size_t>(cy) * static_cast<size_t>(columns) + static_cast<size_t>(cx)]) {
          const OdometryFeature& c = candidates[static_cast<size_t>(index)];
          if (window.kind == MatchWindow::Kind::epipolar) {
            if (c.x_px < x0 || c.x_px > x1 || c.y_px < y0 || c.y_px > y1) continue;
          } else if ((Eigen::Vector2d(c.x_px, c.y_px) - centre).squaredNorm() > radius_sq) {
            continue;
          }
          const int distance = kernels::brief_hamming_distance(query.descriptor, c.descriptor);
          ++comparisons;
          if (distance < best) {
            second = best;
            best = distance;
            best_index = index;
          } else if (distance < second) {
            second = distance;
          }
        }
      }
    }
    if (best_index < 0 || best > max_hamming_distance) continue;
    if (second != std::numeric_limits<int>::max() && !(best < ratio_test * second)) continue;
    result[q] = best_index;
  }
  if (hamming_distances) *hamming_distances += comparisons;
  return result;
}

GraphSpec StereoOdometry::graph_spec(const StereoOdometryParameters& p) {
  p.validate();
  GraphSpec spec;
  spec.name = "stereo-odometry-features";
  spec.description = "Harris corners + BRIEF-256 of both views (graphs/features.json's nodes per view) for the stereo odometry";
  spec.inputs = {{"left", {ElementType::u8, 0}}, {"right", {ElementType::u8, 0}}};
  for (const std::string view : {"left", "right"}) {
    spec.nodes.push_back({.name = view + "_harris_response",
                          .kernel = "harris_response",
                          .inputs = {{"image", {view, false}}},
                          .outputs = {{"response", view + "_harris"}},
                          .params = {{"window_size", 3}, {"k_numerator", 3}, {"k_shift", 6}}});
    spec.nodes.push_back({.name = view + "_harris_nms",
                          .kernel = "harris_nms",
                          .inputs = {{"response", {view + "_harris", false}}},
                          .outputs = {{"corners", view + "_corners"}},
                          .params = {{"radius", 1}, {"threshold", p.harris_threshold}}});
    spec.nodes.push_back({.name = view + "_select_keypoints",
                          .task = "select_keypoints",
                          .inputs = {{"corners", {view + "_corners", false}}, {"response", {view + "_harris", false}}},
                          .outputs = {{"keypoints", view + "_keypoints"}},
                          .params = {{"cell_size_px", p.cell_size_px},
                                     {"per_cell_k", p.per_cell_k},
                                     {"max_keypoints", p.max_keypoints},
                                     {"border_px", p.border_px}}});
    spec.nodes.push_back({.name = view + "_smooth",
                          .kernel = "gaussian5x5",
                          .inputs = {{"input", {view, false}}},
                          .outputs = {{"output", view + "_smoothed"}}});
    spec.nodes.push_back({.name = view + "_brief256",
                          .kernel = "brief256",
                          .inputs = {{"image", {view + "_smoothed", false}}, {"keypoints", {view + "_keypoints", false}}},
                          .outputs = {{"descriptors", view + "_descriptors"}},
                          .params = {{"yaw_sector", 0}}});
    spec.outputs.push_back(view + "_keypoints");
    spec.outputs.push_back(view + "_descriptors");
    spec.outputs.push_back(view + "_harris");
  }
  return spec;
}

StereoOdometry::StereoOdometry(int width, int height, const StereoOdometryParameters& parameters, int worker_threads)
    : parameters_(parameters), width_(width), height_(height) {
  graph_ = make_verified_graph(graph_spec(parameters), width, height, MemoryBudget{});
  runner_ = std::make_unique<FrameRunner>(*graph_, worker_threads);
}

StereoOdometry::~StereoOdometry() = default;

std::vector<OdometryFeature> StereoOdometry::extract(const std::string& view) const {
  const Plane& keypoints = runner_->buffer(view + "_keypoints");
  const Plane& descriptors = runner_->buffer(view + "_descriptors");
  const Plane& response = runner_->buffer(view + "_harris");
  std::vector<OdometryFeature> features;
  features.reserve(static_cast<size_t>(keypoints.height()));
  // Sub-pixel: the vertex of the parabola through the response at x - 1, x, x + 1 (and likewise in
  // y), clamped to half a pixel; the corner is a strict 3x3 maximum, so the curvature is negative.
  const auto vertex = [](double before, double at, double after) {
    const double curvature = before - 2.0 * at + after;
    if (!(curvature < 0)) return 0.0;
    return std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5);
  };
  for (int row = 0; row < keypoints.height(); ++row) {
    const int32_t* word = keypoints.row<const int32_t>(row);
    if (word[kKeypointValid] == 0) break;  // used rows come first
    const int x = word[kKeypointXPx], y = word[kKeypointYPx];
    OdometryFeature feature;
    feature.x_px = x;
    feature.y_px = y;
    if (x >= 1 && y >= 1 && x + 1 < response.width() && y + 1 < response.height()) {
      const double at = response.at<int32_t>(x, y);
      feature.x_px += vertex(response.at<int32_t>(x - 1, y), at, response.at<int32_t>(x + 1, y));
      feature.y_px += vertex(response.at<int32_t>(x, y - 1), at, response.at<int32_t>(x, y + 1));
    }
    const uint32_t* descriptor = descriptors.row<const uint32_t>(row);
    std::copy(descriptor, descriptor + kernels::kBriefWords, feature.descriptor);
    features.push_back(feature);
  }
  return features;
}

StereoOdometryFrame StereoOdometry::process(const Plane& left, const Plane& right) {
  const StereoOdometryParameters& p = parameters_;
  runner_->process({{"left", &left}, {"right", &right}});
  std::vector<OdometryFeature> left_features = extract("left");
  std::vector<OdometryFeature> right_features = extract("right");

  StereoOdometryFrame frame;
  StereoOdometryStatistics& s = frame.statistics;
  s.left_features = static_cast<int>(left_features.size());
  s.right_features = static_cast<int>(right_features.size());

  // Leg 1, left t -> right t (stereo).
  MatchWindow stereo_window;
  stereo_window.kind = MatchWindow::Kind::epipolar;
  stereo_window.epipolar_tolerance_px = p.epipolar_tolerance_px;
  stereo_window.min_disparity_px = p.min_disparity_px;
  stereo_window.max_disparity_px = p.max_disparity_px;
  const std::vector<int> stereo = match_features(left_features, {}, right_features, stereo_window, p.max_hamming_distance, p.ratio_test,
                                                &s.hamming_distances);
  for (int r : stereo) s.stereo_matches += r >= 0 ? 1 : 0;

  std::vector<CircleMatch> circle;
  if (has_previous_) {
    s.predicted = has_velocity_;
    MatchWindow temporal_window;
    temporal_window.kind = MatchWindow::Kind::radius;
    temporal_window.radius_px = has_velocity_ ? p.predicted_radius_px : p.search_radius_px;
    const Eigen::Isometry3d backward = velocity_.inverse();  // points t -> t-1 under constant velocity

    // Leg 2, right t -> right t-1: the right features of stereo matches, searched around their
    // predicted position at t-1.
    std::vector<OdometryFeature> right_queries;
    std::vector<Eigen::Vector2d> right_centres;
    std::vector<int> right_query_left;  // the left t feature each query belongs to
    for (size_t i = 0; i < stereo.size(); ++i) {
      if (stereo[i] < 0) continue;
      const OdometryFeature& r = right_features[static_cast<size_t>(stereo[i])];
      Eigen::Vector2d centre(r.x_px, r.y_px);
      if (has_velocity_) {
        const Eigen::Vector3d point = backward * triangulate(p, left_features[i], r);
        centre = point.z() > kMinDepthM ? project(p, point, true) : Eigen::Vector2d(r.x_px, r.y_px);
      }
      right_queries.push_back(r);
      right_centres.push_back(centre);
      right_query_left.push_back(static_cast<int>(i));
    }
    const std::vector<int> right_temporal =
        match_features(right_queries, right_centres, previous_right_, temporal_window, p.max_hamming_distance, p.ratio_test,
                       &s.hamming_distances);

    // Leg 3, right t-1 -> left t-1: frame t-1's stereo matches, inverted.
    std::vector<int> previous_left_of_right(previous_right_.size(), -1);
    for (size_t i = 0; i < previous_stereo_.size(); ++i) {
      if (previous_stereo_[i] >= 0) previous_left_of_right[static_cast<size_t>(previous_stereo_[i])] = static_cast<int>(i);
    }

    // Leg 4, left t-1 -> left t: the left features of frame t-1's stereo matches, searched around
    // their predicted position at t.
    std::vector<OdometryFeature> left_queries;
    std::vector<Eigen::Vector2d> left_centres;
    std::vector<int> left_query_index(previous_left_.size(), -1);
    for (size_t i = 0; i < previous_stereo_.size(); ++i) {
      if (previous_stereo_[i] < 0) continue;
      const OdometryFeature& l = previous_left_[i];
      Eigen::Vector2d centre(l.x_px, l.y_px);
      if (has_velocity_) {
        const Eigen::Vector3d point = velocity_ * triangulate(p, l, previous_right_[static_cast<size_t>(previous_stereo_[i])]);
        centre = point.z() > kMinDepthM ? project(p, point, false) : Eigen::Vector2d(l.x_px, l.y_px);
      }
      left_query_index[i] = static_cast<int>(left_queries.size());
      left_queries.push_back(l);
      left_centres.push_back(centre);
    }
    const std::vector<int> left_temporal =
        match_features(left_queries, left_centres, left_features, temporal_window, p.max_hamming_distance, p.ratio_test,
                       &s.hamming_distances);

    // The circle closes when leg 4 returns to the feature leg 1 started from.
    for (size_t q = 0; q < right_queries.size(); ++q) {
      const int previous_right = right_temporal[q];
      if (previous_right < 0) continue;
      const int previous_left = previous_left_of_right[static_cast<size_t>(previous_right)];
      if (previous_left < 0) continue;
      const int query = left_query_index[static_cast<size_t>(previous_left)];
      if (query < 0 || left_temporal[static_cast<size_t>(query)] != right_query_left[q]) continue;
      const OdometryFeature& l_now = left_features[static_cast<size_t>(right_query_left[q])];
      const OdometryFeature& r_now = right_queries[q];
      CircleMatch match;
      match.point_previous = triangulate(p, previous_left_[static_cast<size_t>(previous_left)],
                                         previous_right_[static_cast<size_t>(previous_right)]);
      match.left_px = {l_now.x_px, l_now.y_px};
      match.right_px = {r_now.x_px, r_now.y_px};
      circle.push_back(match);
    }
  }
  s.circle_matches = static_cast<int>(circle.size());

  // RANSAC over minimal sets of 3 circle matches, each solved by Gauss-Newton from the identity
  // (libviso2), then the best set's inliers refined twice.
  Eigen::Isometry3d motion = Eigen::Isometry3d::Identity();  // points t-1 -> t
  std::vector<int> inliers;
  if (static_cast<int>(circle.size()) >= std::max(3, p.min_inliers)) {
    std::mt19937 random(p.ransac_seed + static_cast<uint32_t>(frame_index_));
    std::uniform_int_distribution<int> pick(0, static_cast<int>(circle.size()) - 1);
    for (int iteration = 0; iteration < p.ransac_iterations; ++iteration) {
      std::vector<int> sample;
      while (sample.size() < 3) {
        const int index = pick(random);
        if (std::find(sample.begin(), sample.end(), index) == sample.end()) sample.push_back(index);
      }
      Eigen::Isometry3d candidate = Eigen::Isometry3d::Identity();
      if (!gauss_newton(p, circle, sample, p.gauss_newton_iterations, candidate, s)) continue;
      std::vector<int> candidate_inliers = inliers_of(p, circle, candidate, s);
      if (candidate_inliers.size() > inliers.size()) {
        inliers = std::move(candidate_inliers);
        motion = candidate;
      }
    }
    for (int refinement = 0; refinement < 2 && static_cast<int>(inliers.size()) >= 3; ++refinement) {
      Eigen::Isometry3d refined = motion;
      if (!gauss_newton(p, circle, inliers, p.gauss_newton_iterations, refined, s)) break;
      std::vector<int> refined_inliers = inliers_of(p, circle, refined, s);
      if (refined_inliers.size() < 3) break;
      motion = refined;
      inliers = std::move(refined_inliers);
    }
  }

  s.inliers = static_cast<int>(inliers.size());
  s.valid = has_previous_ && s.inliers >= p.min_inliers;
  if (s.valid) {
    double squared = 0;
    s.reprojection_tests += static_cast<int64_t>(inliers.size());
    for (int index : inliers) {
      double el = 0, er = 0;
      reprojection_error(p, motion, circle[static_cast<size_t>(index)], &el, &er);
      squared += el * el + er * er;
    }
    s.reprojection_rms_px = std::sqrt(squared / (2.0 * static_cast<double>(inliers.size())));
    s.confidence = static_cast<double>(s.inliers) / static_cast<double>(s.circle_matches);
    frame.increment = motion.inverse();
    velocity_ = motion;
    // Step 5: each circle's own motion over the frame.
    std::vector<char> is_inlier(circle.size(), 0);
    for (int index : inliers) is_inlier[static_cast<size_t>(index)] = 1;
    frame.feature_motions.reserve(circle.size());
    for (size_t i = 0; i < circle.size(); ++i) {
      FeatureMotion feature;
      feature.left_px = circle[i].left_px;
      feature.disparity_px = circle[i].left_px.x() - circle[i].right_px.x();
      feature.position_m = triangulate(p, circle[i].left_px, circle[i].right_px);
      feature.displacement_m = feature.position_m - motion * circle[i].point_previous;
      feature.inlier = is_inlier[i] != 0;
      frame.feature_motions.push_back(feature);
    }
    s.feature_motions = static_cast<int64_t>(circle.size());
    has_velocity_ = true;
  } else if (!has_previous_) {
    s.valid = true;  // frame 0 defines the first pose: nothing to estimate
    s.confidence = 1.0;
  } else {
    has_velocity_ = false;  // the next frame searches without a prediction
  }
  pose_ = pose_ * frame.increment;
  frame.pose = pose_;
  const auto count = [](int64_t items) { return static_cast<uint64_t>(items); };
  s.work.scalar_ops = count(s.hamming_distances) * kOdometryWorkHammingOps +
                      count(s.gauss_newton_point_steps) * kOdometryWorkPointStepOps +
                      count(s.gauss_newton_solves) * kOdometryWorkSolveOps + count(s.reprojection_tests) * kOdometryWorkReprojectionOps +
                      count(s.feature_motions) * kOdometryWorkFeatureMotionOps;
  s.work.memory_bytes = count(s.hamming_distances) * kOdometryWorkHammingBytes +
                        count(s.gauss_newton_point_steps + s.reprojection_tests) * kOdometryWorkPointBytes +
                        count(s.feature_motions) * kOdometryWorkFeatureMotionBytes;

  previous_left_ = std::move(left_features);
  previous_right_ = std::move(right_features);
  previous_stereo_ = stereo;
  has_previous_ = true;
  ++frame_index_;
  return frame;
}

}  // namespace lpstereo::arm
