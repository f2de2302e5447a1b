// The values of the obstacle mask the vldh_mask kernel writes (kernels/vldh_mask.cpp) and the
// advanced_u_disparity kernel reads (kernels/advanced_u_disparity.cpp): one u8 per pixel
// (BufferFormat {u8, 0}), three states, so that the AUD grid can reward obstacle pixels and penalise
// free space (thesis 003 §4.2.3) and ignore pixels that say nothing.
#pragma once

#include <cstdint>

namespace lpstereo::kernels {

enum ObstacleMaskValue : uint8_t {
  kMaskNoVote = 0,    // invalid disparity, outside the region that can hold obstacles, or no road
  kMaskFree = 1,      // a valid disparity the road profile explains, or not a vertical structure
  kMaskObstacle = 2,  // a vertical structure standing above the road profile (VLDH, thesis 003 eq. 4.1)
};

}  // namespace lpstereo::kernels
