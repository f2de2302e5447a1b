// Building remap_q5 maps (dag/format.h) for the remap_bilinear kernel.
//
// The table format: per output pixel (x, y), dx = source_x - x and dy = source_y - y as int16 in
// Q10.5 (value / 32 = pixels, 5 fraction bits, range -1024 .. +1023.96875 px), interleaved dx, dy
// (4 bytes a pixel; a row may be padded). The kernel interpolates with 5-bit fractions, i.e.
// bilinear weights (32 - fx)(32 - fy) ... summing to 1024, rounded once at the end
// (kernels/remap_bilinear.cpp).
//
// Error bound: the table holds each source position within 1/64 px (round to nearest 1/32 px), so
// against exact bilinear interpolation at the float position the output is off by at most
// 0.5 grey level (the final rounding) plus the position error times the local image gradient,
// |g| / 64 per axis (|g| in grey levels per px: 1 grey level at an edge of 64 levels per px). Against
// OpenCV's cv::remap(INTER_LINEAR) on 8-bit images with the same float maps the bits are identical:
// OpenCV rounds mapx * 32 to nearest (ties to even) as make_remap_q5_from_float does, and its 15-bit
// weights are 32 times ours.
//
// Camera calibration code (OpenCV's initUndistortRectifyMap with CV_32FC1 maps) gives absolute
// float source coordinates; make_remap_q5_from_float converts those. make_synthetic_rectification_map
// generates a plausible map with no calibration file (tools, tests, benchmarks).
//
// Pure C++ (no OpenCV), so the library builds for the target with no extra packages.
#pragma once

#include <cstddef>
#include <vector>

#include "dag/plane.h"

namespace lpstereo {

// Converts absolute float source coordinates to a remap_q5 map of width x height.
// map_x[y * stride_elements + x] is the source column of output pixel (x, y), map_y likewise the
// source row (OpenCV's CV_32FC1 map convention; stride_elements is in floats, >= width).
// Each source position is rounded to the nearest 1/32 px, ties to even (as cv::remap does), so the
// map reproduces each source position within 1/64 px.
// Throws std::invalid_argument naming the pixel, the axis, the allowed range and the actual value
// when a delta is not finite or falls outside Q10.5, and for bad sizes.
Plane make_remap_q5_from_float(const float* map_x, const float* map_y, int width, int height,
                               ptrdiff_t stride_elements);

// A synthetic rectification: the map a rectifying homography plus lens undistortion would give,
// reduced to an in-plane rotation, a zoom and one radial term about the image centre.
// For output pixel (x, y), with c = ((width - 1) / 2, (height - 1) / 2) and f = focal_px:
//   (u, v) = scale * R(rotation_rad) * ((x, y) - c) / f        normalized coordinates (unitless)
//   source = c + f * (1 + k1 * (u^2 + v^2)) * (u, v)            pixels
struct SyntheticRectification {
  double rotation_rad = 0.01;  // in-plane rotation, radians (|value| <= 0.2)
  double scale = 0.98;         // zoom: < 1 samples a smaller source area (magnifies); 0.5 .. 2
  double k1 = -0.05;           // radial distortion coefficient on f-normalized radius squared; |k1| <= 1
  double focal_px = 0;         // focal length in pixels; 0 = max(width, height)
};

// The absolute float maps of SyntheticRectification (row stride = width), as OpenCV's remap takes them.
void make_synthetic_rectification_float(int width, int height, const SyntheticRectification& model,
                                        std::vector<float>& map_x, std::vector<float>& map_y);

// The same map as remap_q5 (make_remap_q5_from_float of the float maps).
Plane make_synthetic_rectification_map(int width, int height, const SyntheticRectification& model = {});

}  // namespace lpstereo
