// Disparity files and views. In the pipeline disparity is s16 Q4 (value / 16 = pixels) with one
// invalid value, (min_disparity - 1) * 16 (DESIGN.md §4). For evaluation, disparity in pixels is a
// CV_32FC1 matrix with +inf (any non-finite value) = invalid, as in Middlebury's PFM files.
//
// Files (every reader throws ImageError naming the file, what it expected and what it found;
// every writer writes atomically: temporary name, then rename):
//   KITTI PNG: 16-bit grey, disparity x 256, 0 = invalid, valid values clamped to >= 1.
//   PFM:       Middlebury float PFM: "Pf\n<width> <height>\n<scale>\n", then width x height float32
//              samples, rows from the BOTTOM row to the top; scale < 0 = little-endian samples,
//              scale > 0 = big-endian; |scale| is ignored; +inf = invalid. Written little-endian
//              with scale -1. "PF" (3-channel) files are refused.
//   s16 raw:   no header: width x height int16 samples, little-endian, rows top to bottom, no row
//              padding (file size = 2 x width x height bytes); the s16 Q4 values themselves
//              (value / 16 = pixels, invalid = (min_disparity - 1) * 16). Reading needs the size.
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

// Float pixels (CV_32FC1, +inf invalid) from s16q4 and back (to the nearest 1/16 px; non-finite,
// or values outside the s16 Q4 range, become invalid_disparity_q4(min_disparity_px)).
cv::Mat disparity_q4_to_px(const Plane& disparity_q4, int min_disparity_px);
Plane disparity_px_to_q4(const cv::Mat& disparity_px, int min_disparity_px);

// KITTI PNG read as float pixels (value / 256, 0 -> +inf): the exact ground-truth values.
cv::Mat read_kitti_disparity_png_px(const std::string& path);

void write_pfm(const std::string& path, const cv::Mat& disparity_px);
cv::Mat read_pfm(const std::string& path);

void write_s16_raw(const std::string& path, const Plane& disparity_q4);
Plane read_s16_raw(const std::string& path, int width, int height);

// The KITTI development kit's interpolateBackground (devkit_stereo_flow, io_disp.h), on s16q4 in
// place: along each row, a run of invalid pixels between two valid ones takes the LOWER of the two
// (the background); runs touching the row's ends take the nearest valid value; then, per column,
// pixels above the column's first and below its last valid pixel take that value (an empty row
// between two valid rows stays invalid, exactly as in the devkit). A map with no valid pixel stays
// as it is. Used for dense evaluation ("--fill").
void fill_invalid_kitti(Plane& disparity_q4, int16_t invalid_q4);

// Colour view: 0 .. max_disparity_px through the Turbo colour map, invalid pixels black.
cv::Mat colorize_disparity(const Plane& disparity_q4, int min_disparity_px, int max_disparity_px);

}  // namespace lpstereo::io
