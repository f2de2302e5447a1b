// The record the ARM task "disparity_coverage" writes (arm/tasks/disparity_coverage.cpp): the view
// check of one frame, fixed layout u32 words (BufferFormat {u32, 0}), so a consumer reads it without
// parsing.
#pragma once

#include <cstdint>

namespace lpstereo::arm {

enum CoverageRecordWord : int {
  kCoverageInvalidPixels = 0,    // pixels of the map holding the invalid value
  kCoveragePixels = 1,           // W x H of the map
  kCoverageInvalidPer65536 = 2,  // floor(65536 x invalid / pixels), 0 .. 65536 (0 for an empty map)
  kCoverageDegraded = 3,         // 1: the share is at or above degraded_invalid_share (or the map is empty)
  kCoverageWords = 4,
};

// floor(65536 x invalid_pixels / pixels) in integers (invalid_pixels <= pixels < 2^32: the product
// < 2^48, no overflow in 64 bits); 0 when pixels is 0.
inline uint32_t coverage_share_per_65536(int64_t invalid_pixels, int64_t pixels) {
  return pixels > 0 ? static_cast<uint32_t>((static_cast<uint64_t>(invalid_pixels) << 16) / static_cast<uint64_t>(pixels)) : 0u;
}

}  // namespace lpstereo::arm
