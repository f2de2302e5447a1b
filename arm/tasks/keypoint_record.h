// The keypoint list the feature stage passes along (written by the ARM task that selects Harris
// corners after non-maximum suppression, read by the BRIEF kernel, obstacle feature validation and
// the localization work): one row of kKeypointWords s32 words per keypoint (BufferFormat {s32, 0}),
// a plane of kKeypointWords x max_keypoints; rows with kKeypointValid = 0 are unused and come after
// the used ones.
#pragma once

#include <cstdint>

namespace lpstereo::arm {

enum KeypointWord : int {
  kKeypointValid = 0,     // 1: a keypoint; 0: unused row
  kKeypointXPx = 1,       // image column, px
  kKeypointYPx = 2,       // image row, px
  kKeypointResponse = 3,  // Harris response at the corner (format: kernels/harris_response.cpp)
  kKeypointWords = 4,
};

}  // namespace lpstereo::arm
