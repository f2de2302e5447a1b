// The output format of the point_cell_binning kernel (kernels/point_cell_binning.cpp), for the code
// that reads its planes (arm/tasks/terrain_estimate.cpp, the terrain command, tests). Formats and
// proofs: that file's header comment.
//
// Two s32 planes (BufferFormat{s32, 0}), same size as the camera-point planes of
// disparity_to_points (kernels/disparity_to_points.h):
//   "cell"    the pixel's cell of the 2.5D terrain grid, i * lateral_cells + j (i forward, j lateral,
//             the cell layout of arm/terrain/terrain_model.h TerrainGridSpec), or kNoCell when the
//             pixel has no point, the point is beyond the kernel's range, or outside the area;
//   "height"  the point's vehicle-frame z (up) in millimetres where cell >= 0, kNoPointMm elsewhere.
#pragma once

#include <cstdint>

namespace lpstereo::kernels {

inline constexpr int32_t kNoCell = -1;

// Fraction bits of the rotation parameter (camera -> vehicle, row-major R C of arm/point_cloud.h).
inline constexpr int kRotationFractionBits = 14;

// Range of the camera coordinates the kernel rotates: a point with any |coordinate| outside
// [-kBinningRangeMm - 1, kBinningRangeMm] has no cell (the no-overflow proof assumes it).
inline constexpr int32_t kBinningRangeMm = 65535;
// The largest sum of |entries| of a rotation row (Q14) the proof allows: 32767 * 65536 + 2^13 < 2^31.
// A rotation matrix row has sum |r| <= sqrt(3) 2^14 = 28378 (Cauchy-Schwarz), well inside.
inline constexpr int32_t kMaxRotationRowSumQ14 = 32767;
// |translation| and |area bounds| limits (mm): keeps every sum below 2^31 with margin.
inline constexpr int32_t kMaxBinningOffsetMm = 1 << 20;
// The area's extent along each axis (mm) and the smallest cell: (extent - 1) m < 2^31 (see the .cpp).
inline constexpr int32_t kMaxBinningExtentMm = 1 << 17;
inline constexpr int32_t kMinBinningCellMm = 16;

}  // namespace lpstereo::kernels
