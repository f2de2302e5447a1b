// Test helper: hand-built disparity planes for the tests of arm/terrain_points.h's image rules (the
// near side of a discontinuity, the occluder test, the far side of an edge), in the disparity
// engine's format: s16 Q4 (disparity x 16, rounded), invalid = (min_disparity - 1) x 16, here with
// min_disparity 0.
#pragma once

#include <cmath>
#include <cstdint>

#include "dag/plane.h"

namespace lpstereo::arm::testing {

constexpr int16_t kInvalidQ4 = -16;  // (min_disparity - 1) * 16 with min_disparity 0

inline Plane disparity_plane(int width, int height) { return Plane(width, height, BufferFormat{ElementType::s16}); }

// A disparity in px as Q4; a negative one is the invalid value.
inline int16_t q4(double px) { return px < 0 ? kInvalidQ4 : static_cast<int16_t>(std::lround(16 * px)); }

}  // namespace lpstereo::arm::testing
