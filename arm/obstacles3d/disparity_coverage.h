// Whether this frame's stereo view can be trusted: the share of the disparity map's pixels without a
// valid disparity, and a "view degraded" flag when it is large (issue 10: the chain says when its
// obstacles are not a measurement of anything, as it says when the ego-motion is missing).
//
// Why: a surface nearer than the search range reaches (f B / (min_disparity + num_disparities): 2.6 m
// for the preset sequences' 64 px at f = 554 px, B = 0.30 m) has no match inside the range. The
// matcher returns wrong disparities there, the left-right check and the speckle filter reject most of
// them, and what passes gives false obstacles: 80-87 % of the floating sequences' false positives come
// from such frames (docs/obstacles3d.md, "Where floating's false positives come from"). The rejected
// ones raise the invalid share from the 1.7 % of a typical frame (the median over the preset
// sequences) to 3.5-96 %. Any other failure of the matcher that its checks reject raises it too, so
// the flag says "degraded", not why. A texture-less view (a uniform grey pair: every cost ties) is
// all invalid since the uniqueness check rejects ties (kernels/sgm_core.h), so it is flagged with an
// invalid share of 1 (tests/tools/obstacles3d_cli_test.cpp); before that it got disparity 0, valid
// everywhere. Not caught: a wrong view the matcher does not reject.
//
// The threshold, measured (bench/obstacles3d_eval prints it per sequence; the truth: at least 1 % of
// the image's pixels belong to an object nearer than the range, eval::view_partly_nearer_than_range):
// 0.10 on the 12 preset sequences (urban, country, mining, floating, seeds 1-3, 300 frames each)
// flags 51 of the 58 such frames and 1 of the 3542 others (floating seed 2 frame 58, 19 % invalid).
// The misses are the first or last frame of a near passage, with a few per cent of the view nearer
// than the range (floating seed 1 frame 57: 7.2 % nearer, 6.3 % invalid). docs/obstacles3d.md, "The
// view check".
//
// On the chip (graphs/obstacles3d-stixels*.json) the per-pixel count is the vector engine's: a
// v_disparity node with one bin just below the map's range counts each row's invalid pixels, and the
// ARM task "disparity_coverage" (arm/tasks/disparity_coverage.cpp) sums the rows and applies
// coverage_of_invalid_count, the same rule as here.
//
// Counted work (ArmWork): per pixel 1 compare and 1 add (2 scalar ops) and the 2 bytes read.
#pragma once

#include <cstdint>

#include "dag/arm_task.h"
#include "dag/plane.h"

namespace lpstereo::arm::obstacles3d {

struct DisparityCoverageParameters {
  double degraded_invalid_share = 0.10;  // in (0, 1]: at or above it the view is degraded
  // Throws std::invalid_argument "degraded_invalid_share: expected (0, 1], got <value>".
  void validate() const;
};

struct DisparityCoverage {
  int64_t pixels = 0;          // width x height of the map
  int64_t invalid_pixels = 0;  // pixels holding the engine's invalid value
  double invalid_share = 0;    // invalid_pixels / pixels; 0 for an empty map
  bool degraded = false;       // invalid_share >= degraded_invalid_share (an empty map: degraded)
};

// disparity_q4: the engine's s16 map (disparity in Q4, arm/disparity_engine.h); invalid_q4 its
// invalid value (DisparityEngine::invalid_disparity_q4()). Throws std::invalid_argument when the
// map is not s16 or the parameters are out of range.
DisparityCoverage disparity_coverage(const Plane& disparity_q4, int16_t invalid_q4, const DisparityCoverageParameters& parameters,
                                     ArmWork* work = nullptr);

// The rule alone, from counts already made (the chip's per-row counts summed): invalid_share and
// degraded as above. Throws std::invalid_argument when the parameters are out of range or the
// counts are not 0 <= invalid_pixels <= pixels.
DisparityCoverage coverage_of_invalid_count(int64_t invalid_pixels, int64_t pixels, const DisparityCoverageParameters& parameters);

}  // namespace lpstereo::arm::obstacles3d
