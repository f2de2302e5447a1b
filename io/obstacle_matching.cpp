#include "io/obstacle_matching.h"

#include <cmath>

namespace lpstereo::io {

bool detection_matches(const DetectedBox& detection, const SynthObjectTruth& object, const MatchRule& rule) {
  if (object.visible_pixels <= 0) return false;
  const int tolerance = rule.bbox_tolerance_px;
  const bool overlap = detection.bbox_px[0] - tolerance <= object.bbox_px[2] &&
                       object.bbox_px[0] <= detection.bbox_px[2] + tolerance &&
                       detection.bbox_px[1] - tolerance <= object.bbox_px[3] &&
                       object.bbox_px[1] <= detection.bbox_px[3] + tolerance;
  const double allowed_m = rule.distance_fraction * object.distance_m + rule.distance_slack_m;
  return overlap && std::abs(detection.distance_m - object.distance_m) <= allowed_m;
}

FrameScore score_frame(const std::vector<SynthObjectTruth>& objects, const std::vector<DetectedBox>& detections,
                       const MatchRule& rule) {
  FrameScore score;
  score.detection_of_object.assign(objects.size(), -1);
  std::vector<bool> detection_used(detections.size(), false);
  for (size_t object = 0; object < objects.size(); ++object) {
    for (size_t detection = 0; detection < detections.size(); ++detection) {
      if (!detection_matches(detections[detection], objects[object], rule)) continue;
      if (score.detection_of_object[object] < 0) score.detection_of_object[object] = static_cast<int>(detection);
      detection_used[detection] = true;
    }
  }
  for (size_t detection = 0; detection < detections.size(); ++detection) {
    if (!detection_used[detection] && detections[detection].distance_m <= rule.false_positive_range_m) {
      score.false_detections.push_back(static_cast<int>(detection));
    }
  }
  return score;
}

std::map<std::string, double> detection_range_by_class(
    const std::map<std::string, std::map<double, bool>>& detected) {
  std::map<std::string, double> range;
  for (const auto& [object_class, by_distance] : detected) {
    double reached = 0;
    for (const auto& [distance_m, all_detected] : by_distance) {
      if (!all_detected) break;
      reached = distance_m;
    }
    range[object_class] = reached;
  }
  return range;
}

}  // namespace lpstereo::io
