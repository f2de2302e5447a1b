// Disparity accuracy against ground truth, in pixels at the image's resolution.
//
// Regions: "nonocc" = pixels with ground truth that are visible in both views (the set's nonocc
// mask); "all" = every pixel with ground truth. Each metric is computed twice:
//   dense: after the KITTI fill (io::fill_invalid_kitti), every ground-truth pixel of the region
//          counts (a map with no valid pixel at all counts as disparity 0 everywhere);
//   valid: only the region's ground-truth pixels the method produced (not invalid before the fill).
// Metrics over the counted pixels, error = |estimate - ground truth| in pixels:
//   bad-N: % with error > N px (N = 1, 2, 4); D1 (KITTI 2015): % with error > 3 px AND > 5 % of the
//   ground truth; EPE: mean error in px. Density: % of the region's ground-truth pixels the method
//   produced. A metric over no pixel is NaN.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "dag/plane.h"

namespace lpstereo::io {

struct ErrorMetrics {
  int64_t pixels = 0;       // pixels counted
  double bad1_pct = 0;      // % with error > 1 px
  double bad2_pct = 0;      // % with error > 2 px
  double bad4_pct = 0;      // % with error > 4 px
  double d1_pct = 0;        // % with error > 3 px and > 5 % of the ground truth
  double epe_px = 0;        // mean absolute error, px
};

struct RegionMetrics {
  int64_t ground_truth_pixels = 0;  // pixels of the region with ground truth
  double density_pct = 0;           // % of those the method produced
  ErrorMetrics dense;               // after fill, every ground-truth pixel
  ErrorMetrics valid;               // the produced pixels only
};

struct DisparityMetrics {
  bool has_nonocc = false;  // false: the set has no occlusion mask; `nonocc` is then all NaN
  RegionMetrics nonocc;
  RegionMetrics all;
};

// estimate_q4: s16 Q4 left-view disparity with `invalid_q4` for pixels the method did not produce.
// ground_truth_px: CV_32FC1, non-finite = no ground truth. nonocc_mask: CV_8UC1, 255 = non-occluded,
// or empty when the set has none. Sizes must agree (std::invalid_argument naming both sizes).
DisparityMetrics evaluate_disparity(const Plane& estimate_q4, int16_t invalid_q4, const cv::Mat& ground_truth_px,
                                    const cv::Mat& nonocc_mask);

}  // namespace lpstereo::io
