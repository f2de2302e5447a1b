// Disparity files and views. In the pipeline disparity is s16 Q4 (value / 16 = pixels) with one
// invalid value, (min_disparity - 1) * 16 (DESIGN.md §4).
//   KITTI PNG: 16-bit, disparity x 256, 0 = invalid, valid values clamped to >= 1.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "dag/plane.h"

namespace lpstereo::io {

inline int16_t invalid_disparity_q4(int min_disparity_px) { return static_cast<int16_t>((min_disparity_px - 1) * 16); }

// KITTI 16-bit PNG from s16q4 disparity; negative disparities are written as invalid.
void write_kitti_disparity_png(const std::string& path, const Plane& disparity_q4, int min_disparity_px);
// Reads a KITTI disparity PNG into s16q4 (rounded to 1/16 px); invalid -> invalid_disparity_q4(0).
Plane read_kitti_disparity_png(const std::string& path);

// Colour view: 0 .. max_disparity_px through the Turbo colour map, invalid pixels black.
cv::Mat colorize_disparity(const Plane& disparity_q4, int min_disparity_px, int max_disparity_px);

}  // namespace lpstereo::io
