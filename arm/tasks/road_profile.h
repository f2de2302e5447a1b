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
  kRoadProfileWords = 12,
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
};

// Decodes the record plane (kRoadProfileWords x 1, s32). Throws std::runtime_error on another shape.
RoadProfile decode_road_profile(const Plane& record);

}  // namespace lpstereo::arm
