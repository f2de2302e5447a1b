// ARM task "road_profile": the road's line in the V-disparity image (kernels/v_disparity.cpp), with
// the camera height and pitch it implies, a per-frame confidence, and the previous frame's profile
// carried over a delayed edge when this frame's fit is weak. Record layout: arm/tasks/road_profile.h.
//
// Model (Labayrade, Aubert, Tarel 2002, "Real time obstacle detection in stereovision on non flat
// road geometry through v-disparity representation", IEEE IV, §3; thesis 003 §4.2.1). A camera at
// height h above a flat road, pitched down by theta, focal f (px), principal row v0, baseline B: a
// road point at camera depth z_c has y_c = (h - z_c sin theta) / cos theta, so with v - v0 = f y_c /
// z_c and d = f B / z_c:
//     d(v) = (B / h) ((v - v0) cos theta + f sin theta)                         (Labayrade eq. 6)
// a straight line in (v, d): slope a = (B / h) cos theta, zero at the horizon row
// v_h = v0 - f tan theta, intercept b = -a v_h. From a fitted line the camera follows:
//     theta = atan((v0 - v_h) / f),   h = B cos theta / a.
// Plausibility gate: a > 0 (disparity grows towards the bottom of the image), h in
// [min_camera_height_mm, max_camera_height_mm], |theta| <= max_abs_pitch_mrad. A wall (one disparity
// on every row: a vertical line in V-disparity, a ~ 0, h -> infinity), the sky (d ~ 0) or an empty
// map never pass it, so they give confidence 0 and no road.
//
// Steps, per frame:
//   1. per row v the strongest bin (the first of equal maxima) with count >= min_peak_count: the
//      point (v, bin + min_disparity + 0.5), the bin's centre (the kernel floors d, so the centre is
//      the unbiased estimate of a disparity spread over the bin);
//   2. RANSAC (Fischler and Bolles 1981) over point pairs drawn by a fixed LCG (seed parameter, so
//      frames and tests are deterministic): ransac_iterations candidates; a candidate whose implied
//      camera fails the plausibility gate below is skipped (otherwise the many rows of a far wall or
//      the sky, one disparity each, outvote the road with a near-vertical line that the gate then
//      refuses, and the frame is lost); the others are scored by the number of points within
//      inlier_threshold_px; ties keep the first;
//   3. least squares d = a v + b on the best candidate's inliers, then the inliers of the LS line
//      (a second LS on them when the set changed), the RMS residual;
//   4. confidence = 1000 * min(1, inliers / road rows) * min(1, inliers / full_confidence_inliers),
//      road rows = the points below the fitted horizon (rows above it cannot show road: a sky or a
//      far background there says nothing against the fit); 0 when fewer than min_inliers or the gate
//      refuses the line;
//   5. confidence >= min_confidence: write the fitted profile, with step 6. Otherwise, if the delayed input
//      "previous" holds a valid profile carried fewer than max_carried_frames times, write it again
//      with carried = 1 and frames_carried + 1 (and this frame's confidence); else valid = 0.
//   6. a second segment for a road that climbs ahead (the issue's "piecewise profile for non-flat
//      roads"): a climb is convex in V-disparity, so the other segment's rows have their peaks above
//      the main line; RANSAC over those points (fit_second_segment below has the rules), least squares,
//      at least min_far_inliers rows on its side of the crossing and min_inliers of the main line's on
//      the other. The steeper line is the near segment (the record's slope, intercept, horizon, camera
//      height and pitch, recomputed from it), the other the far one, used for rows above the crossing
//      (kRoadFar* words; road_disparity_q4_at_row in road_profile.h is the per-row profile every
//      consumer uses). A road that falls away ahead (a crest) is concave: its far rows lie below the
//      line, where they are free space anyway, and no second segment is fitted.
//
// Ports: "v_disparity" u16 (num_bins x image height, kernels/v_disparity.cpp), "previous" s32 (this
// task's own output read over a delayed edge; kRoadProfileWords x 1, all zero before the first
// frame), output "profile" s32 kRoadProfileWords x 1. The previous record's shape is checked in run,
// not prepare: verify() prepares a node in a delayed loop once with a guessed frame-size shape.
//
// Parameters (units in the names): min_disparity (px, the V-disparity's bin 0; default 0),
// focal_px (> 0, required), baseline_m (> 0, required), principal_row_px (default: (height - 1) / 2),
// min_peak_count (px, default 20), ransac_iterations (default 200), inlier_threshold_px (default 1.0),
// min_inliers (rows, default 20), full_confidence_inliers (rows, default 100), min_confidence
// (0 .. 1000, default 300), min_camera_height_mm (default 300), max_camera_height_mm (default 4000),
// max_abs_pitch_mrad (default 250), max_carried_frames (default 5), min_far_inliers (rows, default
// 40), max_road_slope_mrad (the far segment's pitch may exceed max_abs_pitch_mrad by this, default
// 175), seed (default 1).
//
// Counted work (deterministic, ArmWork), with N bins, H rows, P points, K iterations, I inliers:
//   scalar_ops   = 3 N H (peak scan: load, compare, select) + 12 K (pair draw, line) + 16 per
//                  candidate from two distinct rows (the gate) + 4 P per candidate the gate passes
//                  (per point a multiply-add, an absolute value, a compare, a count) + 8 P per inlier
//                  pass (LS sums and recount; two passes when a line was found) + 2 P (road rows,
//                  when a line was fitted) + 64 (gate, record); with a written fit, step 6 adds 3 P
//                  (points above the line) and, with A >= min_far_inliers of them, 12 K + 16 per
//                  candidate from two rows + 5 A per candidate passing its gate + 13 A (refit) + 2 I;
//   memory_bytes = 2 N H (the V-disparity plane) + 2 * 4 kRoadProfileWords (previous and output).
#include "arm/tasks/road_profile.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "dag/arm_task.h"

namespace lpstereo::arm {

RoadProfile decode_road_profile(const Plane& record) {
  if (record.width() != kRoadProfileWords || record.height() != 1 || record.format().type != ElementType::s32) {
    throw std::runtime_error("road profile record: expected " + std::to_string(int(kRoadProfileWords)) + "x1 s32, got " +
                             std::to_string(record.width()) + "x" + std::to_string(record.height()) + " " +
                             format_name(record.format()));
  }
  const int32_t* word = record.row<const int32_t>(0);
  RoadProfile profile;
  profile.valid = word[kRoadValid] != 0;
  profile.carried = word[kRoadCarried] != 0;
  profile.confidence = word[kRoadConfidence];
  profile.slope = word[kRoadSlopeQ16] / 65536.0;
  profile.intercept_px = word[kRoadInterceptQ16] / 65536.0;
  profile.horizon_row = word[kRoadHorizonRowQ8] / 256.0;
  profile.camera_height_mm = word[kRoadCameraHeightMm];
  profile.pitch_rad = word[kRoadPitchUrad] * 1e-6;
  profile.inlier_count = word[kRoadInlierCount];
  profile.point_count = word[kRoadPointCount];
  profile.rms_residual_px = word[kRoadRmsResidualQ8] / 256.0;
  profile.frames_carried = word[kRoadFramesCarried];
  profile.far_valid = word[kRoadFarValid] != 0;
  profile.far_slope = word[kRoadFarSlopeQ16] / 65536.0;
  profile.far_intercept_px = word[kRoadFarInterceptQ16] / 65536.0;
  profile.far_break_row = word[kRoadFarBreakRow];
  profile.far_inlier_count = word[kRoadFarInlierCount];
  return profile;
}

namespace {

struct RoadProfileParams {
  int min_disparity = 0;
  double focal_px = 0.0;
  double baseline_m = 0.0;
  double principal_row_px = 0.0;
  int min_peak_count = 20;
  int ransac_iterations = 200;
  double inlier_threshold_px = 1.0;
  int min_inliers = 20;
  int full_confidence_inliers = 100;
  int min_confidence = 300;
  int min_camera_height_mm = 300;
  int max_camera_height_mm = 4000;
  int max_abs_pitch_mrad = 250;
  int max_carried_frames = 5;
  int min_far_inliers = 40;
  int max_road_slope_mrad = 175;
  uint32_t seed = 1;
};

double required_positive(const nlohmann::json& params, const char* name) {
  if (!params.contains(name)) throw KernelError(std::string("parameter '") + name + "': expected a number > 0, got none");
  const double value = param_double(params, name, 0.0, 0.0, 1e9);
  if (!(value > 0.0)) throw KernelError(std::string("parameter '") + name + "': expected a number > 0, got " + std::to_string(value));
  return value;
}

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"min_disparity", "focal_px", "baseline_m", "principal_row_px", "min_peak_count",
                             "ransac_iterations", "inlier_threshold_px", "min_inliers", "full_confidence_inliers",
                             "min_confidence", "min_camera_height_mm", "max_camera_height_mm", "max_abs_pitch_mrad",
                             "max_carried_frames", "min_far_inliers", "max_road_slope_mrad", "seed"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (v_disparity, previous), got " + std::to_string(input_shapes.size()));
  }
  const PlaneShape& histogram = input_shapes[0];
  auto prepared = std::make_shared<RoadProfileParams>();
  RoadProfileParams& p = *prepared;
  p.min_disparity = param_int(params, "min_disparity", 0, -2047, 2047);
  p.focal_px = required_positive(params, "focal_px");
  p.baseline_m = required_positive(params, "baseline_m");
  p.principal_row_px = param_double(params, "principal_row_px", (histogram.height - 1) / 2.0, -1e6, 1e6);
  p.min_peak_count = param_int(params, "min_peak_count", 20, 1, 65535);
  p.ransac_iterations = param_int(params, "ransac_iterations", 200, 1, 100000);
  p.inlier_threshold_px = param_double(params, "inlier_threshold_px", 1.0, 0.01, 100.0);
  p.min_inliers = param_int(params, "min_inliers", 20, 2, 1 << 20);
  p.full_confidence_inliers = param_int(params, "full_confidence_inliers", 100, 1, 1 << 20);
  p.min_confidence = param_int(params, "min_confidence", 300, 0, 1000);
  p.min_camera_height_mm = param_int(params, "min_camera_height_mm", 300, 1, 1000000);
  p.max_camera_height_mm = param_int(params, "max_camera_height_mm", 4000, p.min_camera_height_mm, 1000000);
  p.max_abs_pitch_mrad = param_int(params, "max_abs_pitch_mrad", 250, 0, 1570);
  p.max_carried_frames = param_int(params, "max_carried_frames", 5, 0, 1 << 20);
  p.min_far_inliers = param_int(params, "min_far_inliers", 40, 2, 1 << 20);
  p.max_road_slope_mrad = param_int(params, "max_road_slope_mrad", 175, 0, 1570);
  p.seed = static_cast<uint32_t>(param_int(params, "seed", 1, 0, 0x7FFFFFFF));
  return PreparedKernel{prepared, {{kRoadProfileWords, 1}}};
}

struct Point {
  double v, d;
};

struct Line {
  double slope = 0.0, intercept = 0.0;
  double at(double v) const { return slope * v + intercept; }
};

// The camera a road line implies (Labayrade eq. 6 inverted, see the header) and the plausibility gate.
struct ImpliedCamera {
  double horizon_row = 0.0, pitch_rad = 0.0, height_m = 0.0;
  bool plausible = false;
};

ImpliedCamera implied_camera(const Line& line, const RoadProfileParams& p) {
  ImpliedCamera camera;
  if (!(line.slope > 0.0)) return camera;
  camera.horizon_row = -line.intercept / line.slope;
  camera.pitch_rad = std::atan((p.principal_row_px - camera.horizon_row) / p.focal_px);
  camera.height_m = p.baseline_m * std::cos(camera.pitch_rad) / line.slope;
  const double height_mm = camera.height_m * 1000.0;
  camera.plausible = height_mm >= p.min_camera_height_mm && height_mm <= p.max_camera_height_mm &&
                     std::abs(camera.pitch_rad) * 1000.0 <= p.max_abs_pitch_mrad;
  return camera;
}

// Least squares d = a v + b; false when the rows do not determine a slope.
bool least_squares(const std::vector<Point>& points, const std::vector<int>& indices, Line& line) {
  double sv = 0, sd = 0, svv = 0, svd = 0;
  for (int i : indices) {
    sv += points[i].v;
    sd += points[i].d;
    svv += points[i].v * points[i].v;
    svd += points[i].v * points[i].d;
  }
  const double n = static_cast<double>(indices.size());
  const double denominator = n * svv - sv * sv;
  if (indices.size() < 2 || denominator <= 0.0) return false;
  line.slope = (n * svd - sv * sd) / denominator;
  line.intercept = (sd - line.slope * sv) / n;
  return true;
}

std::vector<int> inliers_of(const std::vector<Point>& points, const Line& line, double threshold) {
  std::vector<int> inliers;
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    if (std::abs(points[i].d - line.at(points[i].v)) <= threshold) inliers.push_back(i);
  }
  return inliers;
}

int32_t round_to_s32(double value) {
  return static_cast<int32_t>(std::llround(std::clamp(value, -2147483648.0, 2147483647.0)));
}

// Step 6: a second segment for a road whose slope changes ahead (a climb; see the header). The
// profile of a climb is convex in V-disparity: whichever segment the main fit found, the rows of the
// other one have their peaks ABOVE the main line. So the points: rows whose peak lies above the main
// line by more than inlier_threshold_px. A candidate second line must differ in slope from the main
// one by a factor in [1/2, 2] without being equal (a vertical structure in V-disparity, an obstacle or
// a wall, has slope ~ 0 and is refused; a 2 degree climb from 20 m ahead of a camera 1.5 m high is
// 0.68, 5 degrees 0.46), with an implied pitch within max_abs_pitch_mrad +
// max_road_slope_mrad; it is scored by its points within the threshold on its side of the crossing
// row v_b: above it (v < v_b) when it is the less steep (the far part), below it when it is the
// steeper (the near part). The steeper of the two is then the near segment, the other the far one.
struct TwoSegments {
  bool valid = false;
  Line near, far;
  int break_row = 0;          // rows v < break_row follow the far line
  int second_inlier_count = 0;
};

TwoSegments fit_second_segment(const std::vector<Point>& points, const Line& main, const std::vector<int>& main_inliers,
                               const RoadProfileParams& p, uint64_t& ops) {
  TwoSegments result;
  std::vector<Point> above;
  for (const Point& point : points) {
    if (point.d - main.at(point.v) > p.inlier_threshold_px) above.push_back(point);
  }
  ops += 3ull * points.size();
  const int count = static_cast<int>(above.size());
  if (count < p.min_far_inliers) return result;
  const double max_pitch_rad = (p.max_abs_pitch_mrad + p.max_road_slope_mrad) / 1000.0;
  auto crossing_row = [&](const Line& second) { return (second.intercept - main.intercept) / (main.slope - second.slope); };
  auto acceptable = [&](const Line& second) {
    if (!(second.slope >= main.slope / 2.0 && second.slope <= main.slope * 2.0)) return false;
    if (std::abs(second.slope - main.slope) < 1e-3 * main.slope) return false;
    const double pitch_rad = std::atan((p.principal_row_px + second.intercept / second.slope) / p.focal_px);
    return std::abs(pitch_rad) <= max_pitch_rad;
  };
  // Whether row v lies on the second line's side of the crossing row (computed once per line).
  auto on_its_side = [&](const Line& second, double crossing, double v) {
    return second.slope < main.slope ? v < crossing + 1.0 : v > crossing - 1.0;
  };
  auto second_inliers = [&](const Line& second) {
    const double crossing = crossing_row(second);
    std::vector<int> inliers;
    for (int i = 0; i < count; ++i) {
      if (on_its_side(second, crossing, above[i].v) && std::abs(above[i].d - second.at(above[i].v)) <= p.inlier_threshold_px) {
        inliers.push_back(i);
      }
    }
    return inliers;
  };
  uint32_t state = (p.seed + 1u) * 2654435761u + 1u;
  auto draw = [&]() {
    state = state * 1664525u + 1013904223u;  // the LCG of step 2
    return static_cast<int>((uint64_t{state >> 8} * static_cast<uint64_t>(count)) >> 24);
  };
  Line best;
  size_t best_score = 0;
  for (int iteration = 0; iteration < p.ransac_iterations; ++iteration) {
    const int i = draw();
    const int j = draw();
    ops += 12;
    if (above[i].v == above[j].v) continue;
    Line candidate;
    candidate.slope = (above[j].d - above[i].d) / (above[j].v - above[i].v);
    candidate.intercept = above[i].d - candidate.slope * above[i].v;
    ops += 16;
    if (!acceptable(candidate)) continue;
    const size_t score = second_inliers(candidate).size();
    ops += 5ull * count;
    if (score > best_score) {
      best_score = score;
      best = candidate;
    }
  }
  if (best_score < static_cast<size_t>(p.min_far_inliers)) return result;
  std::vector<int> inliers = second_inliers(best);
  Line second;
  if (!least_squares(above, inliers, second) || !acceptable(second)) return result;
  inliers = second_inliers(second);
  ops += 13ull * count;
  // The main line must keep min_inliers of its own support on its side of the crossing.
  const double crossing = crossing_row(second);
  int main_support = 0;
  for (int i : main_inliers) main_support += on_its_side(second, crossing, points[i].v) ? 0 : 1;
  ops += main_inliers.size();
  if (static_cast<int>(inliers.size()) < p.min_far_inliers || main_support < p.min_inliers) return result;
  // A road surface covers the rows on its side of the crossing one after the other: the second
  // line's inliers must fill at least half of the rows from the crossing to the farthest of them.
  // Lines through the vertical segments of obstacles (their rows near the horizon, where the road's
  // disparity is below the V-disparity's range) pick up scattered rows: 51 of 200 on a 1920x864
  // lineup, which made the objects "road".
  double span_rows = 0;
  for (int i : inliers) span_rows = std::max(span_rows, std::abs(above[i].v - crossing));
  ops += inliers.size();
  if (static_cast<double>(inliers.size()) < 0.5 * span_rows) return result;
  result.valid = true;
  result.near = second.slope > main.slope ? second : main;
  result.far = second.slope > main.slope ? main : second;
  result.break_row = static_cast<int>(std::ceil(crossing));
  result.second_inlier_count = static_cast<int>(inliers.size());
  return result;
}

void run(const ArmTaskArgs& args) {
  const auto& p = *static_cast<const RoadProfileParams*>(args.params);
  const Plane& histogram = *args.inputs.at(0);
  const Plane& previous = *args.inputs.at(1);
  Plane& output = *args.outputs.at(0);
  if (previous.width() != kRoadProfileWords || previous.height() != 1) {
    throw KernelError("input 'previous': expected the " + std::to_string(int(kRoadProfileWords)) +
                      "x1 road profile record (this task's own output, delayed), got " + std::to_string(previous.width()) + "x" +
                      std::to_string(previous.height()));
  }
  const int bins = histogram.width();
  const int rows = histogram.height();
  uint64_t ops = 0;

  // 1. Per-row peaks.
  std::vector<Point> points;
  for (int v = 0; v < rows; ++v) {
    const uint16_t* row = histogram.row<const uint16_t>(v);
    int best = 0;
    for (int b = 1; b < bins; ++b) best = row[b] > row[best] ? b : best;
    if (row[best] >= p.min_peak_count) points.push_back({double(v), best + p.min_disparity + 0.5});
  }
  ops += 3ull * bins * rows;
  const int point_count = static_cast<int>(points.size());

  // 2. RANSAC over pairs, deterministic.
  Line best_line;
  int best_score = 0;
  if (point_count >= 2) {
    uint32_t state = p.seed * 2654435761u + 1u;
    auto draw = [&]() {
      state = state * 1664525u + 1013904223u;  // Numerical Recipes LCG
      return static_cast<int>((uint64_t{state >> 8} * static_cast<uint64_t>(point_count)) >> 24);
    };
    for (int iteration = 0; iteration < p.ransac_iterations; ++iteration) {
      const int i = draw();
      const int j = draw();
      ops += 12;
      if (points[i].v == points[j].v) continue;
      Line candidate;
      candidate.slope = (points[j].d - points[i].d) / (points[j].v - points[i].v);
      candidate.intercept = points[i].d - candidate.slope * points[i].v;
      // A road's disparity grows towards the bottom, and only a plausible camera is a road: without
      // the gate, the many rows of a far wall or the sky (one disparity: a near-vertical line in
      // V-disparity) outvote the road and the frame is lost to a candidate refused afterwards.
      ops += 16;
      if (!implied_camera(candidate, p).plausible) continue;
      int score = 0;
      for (const Point& point : points) score += std::abs(point.d - candidate.at(point.v)) <= p.inlier_threshold_px ? 1 : 0;
      ops += 4ull * point_count;
      if (score > best_score) {
        best_score = score;
        best_line = candidate;
      }
    }
  }

  // 3. Least squares on the inliers, once more if the LS line's inliers differ.
  Line line;
  std::vector<int> inliers;
  bool fitted = false;
  if (best_score >= 2) {
    inliers = inliers_of(points, best_line, p.inlier_threshold_px);
    fitted = least_squares(points, inliers, line);
    ops += 8ull * point_count;
    if (fitted) {
      std::vector<int> refined = inliers_of(points, line, p.inlier_threshold_px);
      ops += 8ull * point_count;
      Line refit;
      if (refined != inliers && least_squares(points, refined, refit)) {
        line = refit;
        inliers = std::move(refined);
      }
    }
  }
  const int inlier_count = fitted ? static_cast<int>(inliers.size()) : 0;

  // 4. Gate and confidence.
  double camera_height_m = 0.0, pitch_rad = 0.0, horizon_row = 0.0, rms = 0.0;
  bool plausible = false;
  int road_rows = 0;  // rows with a peak below the fitted horizon: the rows that could show road
  if (fitted && line.slope > 0.0 && inlier_count >= p.min_inliers) {
    const ImpliedCamera camera = implied_camera(line, p);
    horizon_row = camera.horizon_row;
    pitch_rad = camera.pitch_rad;
    camera_height_m = camera.height_m;
    plausible = camera.plausible;
    double squares = 0.0;
    for (int i : inliers) squares += std::pow(points[i].d - line.at(points[i].v), 2);
    rms = std::sqrt(squares / inlier_count);
    for (const Point& point : points) road_rows += point.v > horizon_row ? 1 : 0;
    ops += 2ull * point_count;
  }
  int confidence = 0;
  if (plausible && road_rows > 0) {
    const double ratio = std::min(1.0, static_cast<double>(inlier_count) / road_rows);
    const double support = std::min(1.0, static_cast<double>(inlier_count) / p.full_confidence_inliers);
    confidence = static_cast<int>(std::lround(1000.0 * ratio * support));
  }
  ops += 64;

  // 5. The record: this frame's fit, the carried previous one, or none.
  int32_t* word = output.row<int32_t>(0);
  std::fill(word, word + kRoadProfileWords, 0);
  const int32_t* last = previous.row<const int32_t>(0);
  if (plausible && confidence >= p.min_confidence) {
    word[kRoadValid] = 1;
    word[kRoadConfidence] = confidence;
    word[kRoadSlopeQ16] = round_to_s32(line.slope * 65536.0);
    word[kRoadInterceptQ16] = round_to_s32(line.intercept * 65536.0);
    word[kRoadHorizonRowQ8] = round_to_s32(horizon_row * 256.0);
    word[kRoadCameraHeightMm] = round_to_s32(camera_height_m * 1000.0);
    word[kRoadPitchUrad] = round_to_s32(pitch_rad * 1e6);
    word[kRoadInlierCount] = inlier_count;
    word[kRoadPointCount] = point_count;
    word[kRoadRmsResidualQ8] = round_to_s32(rms * 256.0);
    const TwoSegments segments = fit_second_segment(points, line, inliers, p, ops);
    const ImpliedCamera near_camera = segments.valid ? implied_camera(segments.near, p) : ImpliedCamera{};
    if (near_camera.plausible) {  // the camera stands on the near segment: its height and pitch
      word[kRoadSlopeQ16] = round_to_s32(segments.near.slope * 65536.0);
      word[kRoadInterceptQ16] = round_to_s32(segments.near.intercept * 65536.0);
      word[kRoadHorizonRowQ8] = round_to_s32(near_camera.horizon_row * 256.0);
      word[kRoadCameraHeightMm] = round_to_s32(near_camera.height_m * 1000.0);
      word[kRoadPitchUrad] = round_to_s32(near_camera.pitch_rad * 1e6);
      word[kRoadFarValid] = 1;
      word[kRoadFarSlopeQ16] = round_to_s32(segments.far.slope * 65536.0);
      word[kRoadFarInterceptQ16] = round_to_s32(segments.far.intercept * 65536.0);
      word[kRoadFarBreakRow] = segments.break_row;
      word[kRoadFarInlierCount] = segments.second_inlier_count;
    }
  } else if (last[kRoadValid] != 0 && last[kRoadFramesCarried] < p.max_carried_frames) {
    std::memcpy(word, last, sizeof(int32_t) * kRoadProfileWords);
    word[kRoadCarried] = 1;
    word[kRoadFramesCarried] = last[kRoadFramesCarried] + 1;
    word[kRoadConfidence] = confidence;
  } else {
    word[kRoadConfidence] = confidence;
    word[kRoadInlierCount] = inlier_count;
    word[kRoadPointCount] = point_count;
  }
  if (args.work != nullptr) {
    args.work->scalar_ops += ops;
    args.work->memory_bytes += 2ull * bins * rows + 2ull * 4 * kRoadProfileWords;
  }
}

ArmTaskDescriptor make_road_profile() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "road_profile";
  descriptor.summary =
      "road line in V-disparity (RANSAC + least squares), implied camera height and pitch gated, confidence, weak fits carry the previous frame";
  descriptor.ports = {{"v_disparity", PortDirection::input, {ElementType::u16, 0}, PortAccess::whole},
                      {"previous", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"profile", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(road_profile, lpstereo::arm::make_road_profile);
