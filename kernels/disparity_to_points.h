// The output format of the disparity_to_points kernel (kernels/disparity_to_points.cpp), for the
// code that reads its planes (arm/point_cloud.h, tests). Formats and proofs: that file's header and
// docs/geometry.md "Disparity to 3D".
//
// Three planes "x", "y", "z", each s32 with 0 fraction bits (BufferFormat{s32, 0}): the camera-frame
// point of the pixel in millimetres, camera frame x right, y down, z forward (DESIGN.md §4). A pixel
// with no point (the invalid disparity, d <= 0, d above the range) holds kNoPointMm in all three.
#pragma once

#include <cstdint>
#include <limits>

namespace lpstereo::kernels {

// The "no point" value of every coordinate plane. No point the kernel computes reaches it:
// |x|, |y| <= 2,097,152,001 < 2^31 - 2^25 and 0 <= z <= 2^31 - 1 (proofs in disparity_to_points.cpp).
inline constexpr int32_t kNoPointMm = std::numeric_limits<int32_t>::min();

// Fraction bits of the per-disparity factor W(d) = b_mm / d_q4 (mm per Q4 pixel of u - u0): 15.
inline constexpr int kPointFactorFractionBits = 15;

// Parameter limits prepare() enforces (they are what the no-overflow proofs assume).
inline constexpr double kMaxPointBaselineM = 32.0;        // W < 2^30 at d = 1/16 px
inline constexpr int kMaxPointDisparityPx = 2047;         // min_disparity + num_disparities; Q4 index + 1 fits s16
inline constexpr int kMaxPointOffsetQ4 = 65536;           // |16 u - round(16 u0)|, |16 v - round(16 v0)| <= 2^16

}  // namespace lpstereo::kernels
