// Scoring an obstacle detector against the ground truth of a synthetic scene (io/stereo_synth.h):
// the matching rule of issue 6's range test, the false-positive count, and the detection range per
// object class over a distance sweep. Plain data in, plain data out: the detector's own record types
// stay in arm/, this file knows only boxes and distances.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "io/stereo_synth.h"

namespace lpstereo::io {

// What the scoring needs of one detection.
struct DetectedBox {
  int bbox_px[4] = {0, 0, 0, 0};  // x0, y0, x1, y1 inclusive, left image
  double distance_m = 0;          // camera-frame depth the detector reports
};

struct MatchRule {
  int bbox_tolerance_px = 2;          // boxes match when they overlap after growing the detection by this
  double distance_fraction = 0.10;    // ... and |distance - true distance| <= fraction * true + slack
  double distance_slack_m = 0.5;
  double false_positive_range_m = 150;  // a detection matching no object counts as false only this near
};

// True when `detection` matches `object` under `rule` (an object that is not visible never matches).
bool detection_matches(const DetectedBox& detection, const SynthObjectTruth& object, const MatchRule& rule);

struct FrameScore {
  std::vector<int> detection_of_object;  // per truth object: index of the first matching detection, -1 = missed
  std::vector<int> false_detections;     // indices of the detections matching no object, within
                                         // false_positive_range_m, ascending
  int false_positives() const { return static_cast<int>(false_detections.size()); }
};

FrameScore score_frame(const std::vector<SynthObjectTruth>& objects, const std::vector<DetectedBox>& detections,
                       const MatchRule& rule);

// The range test's figure: for each class, the largest swept distance D such that at every swept
// distance <= D every object of the class was detected in every frame; 0 when the class was missed
// at the nearest distance. `detected[class][distance]` holds whether all of the class's objects were
// detected in all frames at that distance (distances ascending, as swept).
std::map<std::string, double> detection_range_by_class(
    const std::map<std::string, std::map<double, bool>>& detected);

}  // namespace lpstereo::io
