// How well a pair is rectified, measured from the images alone: the vertical offset
// |y_left - y_right| of matched features (AKAZE with sub-pixel keypoints, or ORB), over the
// matches that pass a two-way ratio test (0.8), are mutual best matches and agree with a RANSAC
// fundamental matrix (1 px), so that a wrong match does not count against the rectification.
#pragma once

#include <cstddef>
#include <string>

#include <opencv2/core.hpp>

namespace lpstereo::io {

struct RowAlignment {
  size_t candidates = 0;  // mutual ratio-test matches
  size_t matches = 0;     // of those, epipolar-consistent: the offsets measured
  double median_px = 0;   // median |y_left - y_right|
  double p95_px = 0;      // 95th percentile (linear interpolation between order statistics)
};

// left, right: 8-bit grey images. detector: "akaze" or "orb". Throws CalibrationError when fewer
// than 8 matches remain.
RowAlignment measure_row_alignment(const cv::Mat& left, const cv::Mat& right, const std::string& detector);

}  // namespace lpstereo::io
