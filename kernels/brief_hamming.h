// Hamming distance between two BRIEF-256 descriptors (kernels/brief256.cpp: 8 u32 words each), the
// matching metric of binary descriptors (Calonder et al., ECCV 2010): the number of differing bits,
// 0 .. 256, by popcount of the XOR. Plain C++ for the ARM side (matchers, keyframe lookup); the
// vector matcher uses the simd popcount of the same XOR.
#pragma once

#include <bit>
#include <cstdint>

#include "kernels/brief_pattern.h"

namespace lpstereo::kernels {

inline int brief_hamming_distance(const uint32_t* a, const uint32_t* b) {
  int distance = 0;
  for (int word = 0; word < kBriefWords; ++word) distance += std::popcount(a[word] ^ b[word]);
  return distance;
}

}  // namespace lpstereo::kernels
