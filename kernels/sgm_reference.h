// Semi-global matching (Hirschmueller 2008) as plain scalar C++ over whole images: the reference the
// SGM vector kernels (kernels/sgm_4path.cpp, kernels/sgm_8path.cpp) are tested against bit for bit.
// Written for clarity, not speed: it holds the whole W x H x D cost volume and one volume per path
// in 32-bit integers, with no saturation, so the tests can also check that the kernels' 16-bit
// arithmetic never overflows (the bound is in kernels/sgm_core.h).
//
// Definitions (the kernels implement exactly these):
//   C(x, y, d)  = popcount(left(x, y) XOR right(clamp(x - d, 0, W - 1), y)), the Hamming distance of
//                 the census signatures (replicate border on the right view), d in
//                 [min_disparity, min_disparity + num_disparities).
//   L_r(p, d)   = C(p, d) + min(L_r(p - r, d), L_r(p - r, d - 1) + P1, L_r(p - r, d + 1) + P1,
//                               m_r(p - r) + P2) - m_r(p - r),   m_r(q) = min_d L_r(q, d);
//                 neighbours d +- 1 outside the range are left out; at the image border (p - r
//                 outside the image) L_r(p, d) = C(p, d).
//   S(p, d)     = sum of L_r(p, d) over the paths.
//   best        = argmin_d S (ties: the smallest d).
//   uniqueness  : invalid when some d with |d - best| > 1 has S(d) * (100 - U) <= S(best) * 100
//                 (OpenCV's uniquenessRatio, except that a tie is ambiguous: OpenCV keeps a
//                 pixel whose costs are all 0, as in a texture-less view).
//   sub-pixel   : for min_disparity < best < max disparity, a = S(best - 1) - S(best),
//                 c = S(best + 1) - S(best), q = (16 |a - c| + (a + c)) / (2 (a + c)) (integer
//                 division, so q = round-half-up of 8 |a - c| / (a + c), 0 <= q <= 8), offset = q if
//                 a >= c else -q: the parabola vertex in 1/16 px, |offset| <= 0.5 px.
//   output      : best * 16 + offset (s16 Q4), invalid = (min_disparity - 1) * 16.
//   LR check    : D_R(xr) = argmin_d S(xr + d, d) over d with 0 <= xr + d < W (ties: smallest d);
//                 a valid left pixel with integer disparity dl = best and 0 <= x - dl < W that has
//                 a D_R(x - dl) is invalidated when |dl - D_R(x - dl)| > lr_max_diff.
#pragma once

#include <cstdint>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "kernels/kernel.h"
#include "kernels/sgm_core.h"

namespace lpstereo::kernels {

// The previous pixel of a path: p - r = (x + dx, y + dy).
struct SgmPathDirection {
  int dx = 0;
  int dy = 0;
};

// The single-pass (and forward) paths: from the left, top-left, top, top-right.
inline constexpr SgmPathDirection kSgmForwardPaths[4] = {{-1, 0}, {-1, -1}, {0, -1}, {1, -1}};
// The backward pass: from the right, bottom-right, bottom, bottom-left.
inline constexpr SgmPathDirection kSgmBackwardPaths[4] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}};

// A W x H x D volume of 32-bit values, index (y * W + x) * D + (d - min_disparity).
struct SgmVolume {
  int width = 0, height = 0, disparities = 0;
  std::vector<int32_t> values;
  int32_t& at(int x, int y, int d_index) { return values[(static_cast<size_t>(y) * width + x) * disparities + d_index]; }
  int32_t at(int x, int y, int d_index) const {
    return values[(static_cast<size_t>(y) * width + x) * disparities + d_index];
  }
};

// The census Hamming cost volume. word_bytes: 4 (census32) or 8 (census64).
SgmVolume sgm_reference_costs(const PlaneView& left, const PlaneView& right, int word_bytes, int min_disparity,
                              int num_disparities);

// Adds L_r of one path direction to `sum` (same shape as `cost`). Returns the largest L_r(p, d).
int32_t sgm_reference_add_path(const SgmVolume& cost, int p1, int p2, SgmPathDirection direction, SgmVolume& sum);

// The path costs L_r of one direction over the whole volume.
SgmVolume sgm_reference_path(const SgmVolume& cost, int p1, int p2, SgmPathDirection direction);

// Winner takes all, uniqueness, sub-pixel and LR check on the summed volume: s16 Q4 output.
void sgm_reference_select(const SgmVolume& sum, const SgmParams& params, const PlaneView& output);

// The kernel-level references: sgm_4path (inputs left, right census), sgm_8path_forward (output: the
// sums S(x, y, d) at row y, element x * D + (min_disparity + D - 1 - d), the kernels' reversed lane
// order), sgm_8path_backward (inputs left, right, forward sums).
void sgm_reference(SgmPass pass, int word_bytes, const std::vector<PlaneView>& inputs,
                   const std::vector<PlaneView>& outputs, const SgmParams& params);

// 8-path SGM over the whole image (the 8 paths summed, then the selection): what sgm_8path_forward +
// sgm_8path_backward and sgm_8path_bands compute.
void sgm_reference_8path(int word_bytes, const PlaneView& left, const PlaneView& right, const PlaneView& output,
                         const SgmParams& params);

// The descriptor of an SGM kernel (ports, halos, state, scratch, parameters, reference); the caller
// fills the native table and registers it.
KernelDescriptor sgm_descriptor(SgmPass pass, int word_bytes, const char* name, TileFunction counting);
// The descriptor of sgm_8path_bands (census32: word_bytes 4, census64: 8).
KernelDescriptor sgm_bands_descriptor(int word_bytes, const char* name, TileFunction counting);

}  // namespace lpstereo::kernels
