// The scoring rules of bench/obstacles3d_eval; the header has each rule and why.
#include "eval/obstacles3d_scoring.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace lpstereo::eval {

namespace o3 = arm::obstacles3d;

ObstacleGate gate_of(const io::SynthObjectTruth& object, const o3::StereoErrorModel& error_model) {
  const double z = object.position_m[2];
  return {1.0 + object.object.width_m / 2, std::max(1.0, 3 * error_model.depth_sigma_m(std::max(z, 0.1))) + object.object.length_m / 2};
}

bool in_gate(const o3::Obstacle3d& obstacle, const io::SynthObjectTruth& object, const ObstacleGate& gate) {
  return std::abs(obstacle.position_m.x() - object.position_m[0]) <= gate.lateral_m &&
         std::abs(obstacle.position_m.z() - object.position_m[2]) <= gate.depth_m;
}

bool is_floating(io::SynthClass object_class) {
  return object_class == io::SynthClass::board_on_poles || object_class == io::SynthClass::hanging_sign ||
         object_class == io::SynthClass::ball_on_post;
}

namespace {

int64_t count_of(const std::vector<int64_t>& counts, int id) {
  return id >= 0 && static_cast<size_t>(id) < counts.size() ? counts[static_cast<size_t>(id)] : 0;
}

}  // namespace

int64_t MeasurablePixels::measurable_of(int id) const { return count_of(measurable, id); }
int64_t MeasurablePixels::in_range_of(int id) const { return count_of(in_range, id); }
int64_t MeasurablePixels::lower_edge_of(int id) const { return count_of(lower_edge, id); }

void LowerEdgeProbe::add_part(const io::SynthObjectTruth& object) {
  if (!is_floating(object.object.object_class) || object.id < 0) return;
  const size_t id = static_cast<size_t>(object.id);
  if (parts.size() <= id) parts.resize(id + 1u);
  const double half_width_m = object.object.width_m / 2;
  parts[id] = {true, object.object.x_m - half_width_m, object.object.x_m + half_width_m, object.min_height_m};
}

double LowerEdgeProbe::height_above_true_ground_m(const Eigen::Vector3d& road_m) const {
  return camera_height_m - road_m.y() - ground->height_m(road_m.x(), road_m.z());
}

MeasurablePixels measurable_pixels(const io::StereoSynthScene& scene, int min_disparity, int num_disparities, const LowerEdgeProbe* probe) {
  MeasurablePixels counts;
  const double max_disparity = min_disparity + num_disparities - 1;
  const int width = scene.object_ids.cols;
  std::vector<double> smallest_match_right(static_cast<size_t>(width) + 1);
  for (int v = 0; v < scene.object_ids.rows; ++v) {
    // smallest_match_right[u]: min over u' >= u of u' - d(u') (+inf: none finite).
    smallest_match_right[static_cast<size_t>(width)] = std::numeric_limits<double>::infinity();
    for (int u = width - 1; u >= 0; --u) {
      const double d = scene.disparity_px.at<float>(v, u);
      smallest_match_right[static_cast<size_t>(u)] =
          std::min(smallest_match_right[static_cast<size_t>(u) + 1], std::isfinite(d) ? u - d : std::numeric_limits<double>::infinity());
    }
    for (int u = 0; u < width; ++u) {
      const uint16_t id = scene.object_ids.at<uint16_t>(v, u);
      if (id == 0) continue;
      const double d = scene.disparity_px.at<float>(v, u);
      if (std::isfinite(d) && d > max_disparity) ++counts.nearer_than_range;
      if (!std::isfinite(d) || d < min_disparity || d > max_disparity || u - d < 0) continue;
      if (counts.in_range.size() <= id) {
        counts.in_range.resize(id + 1u, 0), counts.measurable.resize(id + 1u, 0), counts.lower_edge.resize(id + 1u, 0);
      }
      ++counts.in_range[id];
      if (smallest_match_right[static_cast<size_t>(u) + 1] < u - d - 0.5) continue;
      ++counts.measurable[id];
      if (probe == nullptr || id >= probe->parts.size() || !probe->parts[id].hanging) continue;
      const LowerEdgeProbe::Part& part = probe->parts[id];
      const double depth_m = probe->focal_px * probe->baseline_m / d;
      const Eigen::Vector3d road = probe->road_from_camera *
                                   Eigen::Vector3d((u - probe->cx_px) * depth_m / probe->focal_px, (v - probe->cy_px) * depth_m / probe->focal_px, depth_m);
      const double height_m = probe->height_above_true_ground_m(road);
      if (road.x() >= part.x_min_m && road.x() <= part.x_max_m && height_m >= part.edge_m && height_m <= part.edge_m + kLowerEdgeBandM) {
        ++counts.lower_edge[id];
      }
    }
  }
  return counts;
}

bool view_partly_nearer_than_range(const MeasurablePixels& pixels, int64_t image_pixels) {
  return image_pixels > 0 && static_cast<double>(pixels.nearer_than_range) >= kNearerThanRangeShare * static_cast<double>(image_pixels);
}

bool lower_edge_seen(int64_t lower_edge_pixels, const io::SynthObjectTruth& object, double focal_px) {
  const double band_pixels = object.object.width_m * kLowerEdgeBandM * focal_px * focal_px / (object.distance_m * object.distance_m);
  return static_cast<double>(lower_edge_pixels) >= std::max(kLowerEdgeMinPixels, kLowerEdgeMinShare * band_pixels);
}

bool HangingObjectScore::within_tolerance() const { return scored != nullptr && std::abs(error_m) <= kLowerEdgeToleranceM; }

HangingObjectScore score_hanging_object(const std::vector<o3::Obstacle3d>& obstacles, const io::SynthObjectTruth& object,
                                        const ObstacleGate& gate) {
  HangingObjectScore score;
  const double probe_height_m = object.min_height_m + kHangingPartProbeM;
  const o3::Obstacle3d* hanging_part_report = nullptr;
  for (const o3::Obstacle3d& obstacle : obstacles) {
    if (!in_gate(obstacle, object, gate)) continue;
    if (!score.highest_lower_edge || obstacle.min_height_m > score.highest_lower_edge->min_height_m) score.highest_lower_edge = &obstacle;
    if (obstacle.min_height_m <= probe_height_m && obstacle.max_height_m >= probe_height_m &&
        (!hanging_part_report || obstacle.min_height_m > hanging_part_report->min_height_m)) {
      hanging_part_report = &obstacle;
    }
  }
  if (score.highest_lower_edge == nullptr) return score;
  score.scored = hanging_part_report ? hanging_part_report : score.highest_lower_edge;
  score.scored_spans_probe = hanging_part_report != nullptr;
  score.error_m = score.scored->min_height_m - object.min_height_m;
  score.highest_lower_edge_error_m = score.highest_lower_edge->min_height_m - object.min_height_m;
  if (object.object.object_class == io::SynthClass::ball_on_post) return score;
  score.free_space_checked = true;
  const double inner_m = object.object.width_m / 2 - kPostMarginM;
  for (const o3::Obstacle3d& obstacle : obstacles) {
    if (in_gate(obstacle, object, gate) && std::abs(obstacle.position_m.x() - object.position_m[0]) <= inner_m &&
        obstacle.min_height_m < object.min_height_m - kLowerEdgeToleranceM) {
      score.under = &obstacle;
      break;
    }
  }
  return score;
}

int object_shown(const o3::Obstacle3d& obstacle, const cv::Mat& object_ids) {
  const int u0 = std::max(obstacle.bbox_px[0], 0), v0 = std::max(obstacle.bbox_px[1], 0);
  const int u1 = std::min(obstacle.bbox_px[2], object_ids.cols - 1), v1 = std::min(obstacle.bbox_px[3], object_ids.rows - 1);
  if (u0 > u1 || v0 > v1) return 0;
  std::vector<int64_t> pixels;
  for (int v = v0; v <= v1; ++v) {
    const uint16_t* row = object_ids.ptr<uint16_t>(v);
    for (int u = u0; u <= u1; ++u) {
      if (row[u] == 0) continue;
      if (pixels.size() <= row[u]) pixels.resize(row[u] + 1u, 0);
      ++pixels[row[u]];
    }
  }
  int shown = 0;
  for (size_t id = 1; id < pixels.size(); ++id) {
    if (pixels[id] > (shown == 0 ? 0 : pixels[static_cast<size_t>(shown)])) shown = static_cast<int>(id);
  }
  return shown;
}

const o3::Obstacle3d* moving_scored_obstacle(const std::vector<o3::Obstacle3d>& obstacles, const io::SynthObjectTruth& object,
                                             const ObstacleGate& gate, const cv::Mat& object_ids) {
  const o3::Obstacle3d* nearest = nullptr;
  const o3::Obstacle3d* nearest_shown = nullptr;
  double nearest_m = std::numeric_limits<double>::infinity(), nearest_shown_m = nearest_m;
  for (const o3::Obstacle3d& obstacle : obstacles) {
    if (!in_gate(obstacle, object, gate)) continue;
    const double distance_m = std::hypot(obstacle.position_m.x() - object.position_m[0], obstacle.position_m.z() - object.position_m[2]);
    if (distance_m < nearest_m) nearest_m = distance_m, nearest = &obstacle;
    if (distance_m < nearest_shown_m && object_shown(obstacle, object_ids) == object.id) nearest_shown_m = distance_m, nearest_shown = &obstacle;
  }
  return nearest_shown != nullptr ? nearest_shown : nearest;
}

void CountedRuns::next_frame(const std::vector<int>& counted_ids) {
  std::unordered_map<int, int> next;
  for (const int id : counted_ids) {
    const auto previous = runs_.find(id);
    next[id] = (previous == runs_.end() ? 0 : previous->second) + 1;
  }
  runs_ = std::move(next);
}

int CountedRuns::frames_in_row(int id) const {
  const auto run = runs_.find(id);
  return run == runs_.end() ? 0 : run->second;
}

}  // namespace lpstereo::eval
