// The census matching cost, one definition for every matcher (census_wta_disparity, the SGM
// kernels): the Hamming distance between the left signature at x and the right signature at x - d,
// the right view's border replicated (column clamped to [0, W - 1]).
#pragma once

#include "kernels/kernel.h"

namespace lpstereo::kernels {

// Lane-wise Hamming distance of census signatures (u32 or u64 lanes), in the signatures' lane type.
template <class B, class Vector>
Vector census_hamming(const Vector& left, const Vector& right) {
  return B::popcount(B::bit_xor(left, right));
}

// Scalar references: C(x, y, d) of census planes of word_bytes 4 (census32) or 8 (census64).
// Out of line (baseline unit only, kernels/census_cost.cpp), like reference_pixel_u8.
int census_cost_reference(const PlaneView& left, const PlaneView& right, int word_bytes, int x, int y, int d);

}  // namespace lpstereo::kernels
