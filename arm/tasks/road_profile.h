// The record the ARM task "road_profile" writes (arm/tasks/road_profile.cpp): one row of
// kRoadProfileWords s32 words (BufferFormat {s32, 0}), fixed layout, so a consumer (the obstacle
// stages, a delayed edge back into road_profile itself, a JSON writer) reads it without parsing.
// An all-zero record (what a delayed buffer holds before the first frame) is "no road".
#pragma once

#include <cstdint>

#include "dag/plane.h"

namespace lpstereo::arm {

// Word indices. The road line is d(v) = slope * v + intercept, d the disparity in px, v the image
// row (0 = top, y down, DESIGN.md §4).
enum RoadProfileWord : int {
  kRoadValid = 0,              // 1: a road profile (fitted this frame, or carried); 0: none
  kRoadCarried = 1,            // 1: this frame's fit was weak, the profile is the previous frame's
  kRoadConfidence = 2,         // this frame's fit confidence, 0 .. 1000 (0 when no fit)
  kRoadSlopeQ16 = 3,           // slope, px of disparity per row, Q15.16 (value / 65536)
  kRoadInterceptQ16 = 4,       // intercept, px of disparity at row 0, Q15.16
  kRoadHorizonRowQ8 = 5,       // row where the line reaches d = 0, Q23.8 (may be < 0: above the image)
  kRoadCameraHeightMm = 6,     // implied camera height above the road plane, mm
  kRoadPitchUrad = 7,          // implied pitch, micro-radians, > 0 = optical axis below the horizon
  kRoadInlierCount = 8,        // rows whose peak lies within inlier_threshold_px of the line
  kRoadPointCount = 9,         // rows with a peak (count >= min_peak_count) fed to the fit
  kRoadRmsResidualQ8 = 10,     // RMS of the inliers' residuals, px of disparity, Q8
  kRoadFramesCarried = 11,     // consecutive frames this profile has been carried (0 = fitted now)
  // A second, far segment for a road whose slope changes ahead (a climb): rows v < kRoadFarBreakRow
  // follow d = far_slope v + far_intercept instead. kRoadFarValid 0: one line for every row.
  kRoadFarValid = 12,
  kRoadFarSlopeQ16 = 13,       // Q15.16, px of disparity per row
  kRoadFarInterceptQ16 = 14,   // Q15.16, px
  kRoadFarBreakRow = 15,       // first row (from the top) that follows the near line
  kRoadFarInlierCount = 16,
  kRoadProfileWords = 17,
};

struct RoadProfile {
  bool valid = false;
  bool carried = false;
  int confidence = 0;
  double slope = 0.0;          // px / row
  double intercept_px = 0.0;
  double horizon_row = 0.0;
  int camera_height_mm = 0;
  double pitch_rad = 0.0;
  int inlier_count = 0;
  int point_count = 0;
  double rms_residual_px = 0.0;
  int frames_carried = 0;
  bool far_valid = false;
  double far_slope = 0.0;       // px / row
  double far_intercept_px = 0.0;
  int far_break_row = 0;        // rows above it (v < far_break_row) follow the far line
  int far_inlier_count = 0;
};

// The road's disparity at image row v in Q4 (px * 16) from a valid record, exactly as every consumer
// must compute it (the vldh_mask kernel, its scalar reference, the pictures): the line of the row's
// segment in Q16, d_q16 = slope_q16 v + intercept_q16 in 64 bits, rounded to Q4 half up
// ((d_q16 + 2^11) >> 12, arithmetic). |v| <= 2^20 and |words| < 2^31 keep d_q16 below 2^52.
inline int64_t road_disparity_q4_at_row(const int32_t* record, int v) {
  const bool far = record[kRoadFarValid] != 0 && v < record[kRoadFarBreakRow];
  const int64_t slope_q16 = far ? record[kRoadFarSlopeQ16] : record[kRoadSlopeQ16];
  const int64_t intercept_q16 = far ? record[kRoadFarInterceptQ16] : record[kRoadInterceptQ16];
  return (slope_q16 * v + intercept_q16 + 2048) >> 12;
}

// Decodes the record plane (kRoadProfileWords x 1, s32). Throws std::runtime_error on another shape.
RoadProfile decode_road_profile(const Plane& record);

}  // namespace lpstereo::arm
