// The match list the Hamming matcher (kernels/hamming_match.cpp) writes: one row of kMatchWords s32
// words per query descriptor (BufferFormat {s32, 0}), a plane of kMatchWords x query_count; row q
// answers query q (row q of the query descriptors and of the query keypoint list).
//
// Distances are Hamming distances between BRIEF-256 descriptors, 0 .. 256 bits
// (kernels/brief_hamming.h); kMatchNoDistance (257) stands for "no such train descriptor" and is
// never a real distance. Cross-checking (the train descriptor's own best query) is ARM work.
#pragma once

#include <cstdint>

namespace lpstereo::kernels {

enum MatchWord : int {
  kMatchTrainIndex = 0,      // row of the best train descriptor; kMatchNoTrain (-1) if none
  kMatchBestDistance = 1,    // its Hamming distance, 0 .. 256; kMatchNoDistance if none
  kMatchSecondDistance = 2,  // the second-best train's distance, 0 .. 256; kMatchNoDistance if none
  kMatchAccepted = 3,        // 1: passed the ratio test and max_distance; 0: rejected
  kMatchWords = 4,
};

inline constexpr int32_t kMatchNoTrain = -1;
inline constexpr int32_t kMatchNoDistance = 257;

}  // namespace lpstereo::kernels
