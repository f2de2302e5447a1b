// arm::invalidate_near_side_of_discontinuities (arm/terrain_points.h): the near side of a disparity
// jump is invalidated radius_px wide, the far side and smooth ground are kept, invalid pixels are no
// jump, and a random map agrees with a brute-force reading of the rule.
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <stdexcept>

#include "arm/terrain_points.h"
#include "tests/arm/terrain/disparity_planes.h"

namespace lpstereo::arm {
namespace {

using testing::disparity_plane;
using testing::kInvalidQ4;

TEST(InvalidateNearSideOfDiscontinuities, ObjectEdgeLosesItsNearSideOnly) {
  // Background 10 px left of column 10, an object at 20 px from column 10 on: with radius 2 the
  // object's columns 10 and 11 see a background pixel 10 px lower (> 2 px): invalidated; column 12
  // is 3 px away from the background: kept; the background is never the near side: kept.
  Plane disparity = disparity_plane(20, 10);
  for (int v = 0; v < 10; ++v)
    for (int u = 0; u < 20; ++u) disparity.at<int16_t>(u, v) = static_cast<int16_t>(u < 10 ? 160 : 320);
  EXPECT_EQ(invalidate_near_side_of_discontinuities(disparity, kInvalidQ4, 2, 2.0), 20);
  for (int v = 0; v < 10; ++v) {
    for (int u = 0; u < 20; ++u) {
      const int16_t expected = u < 10 ? 160 : (u < 12 ? kInvalidQ4 : 320);
      EXPECT_EQ(disparity.at<int16_t>(u, v), expected) << u << "," << v;
    }
  }
}

TEST(InvalidateNearSideOfDiscontinuities, SmoothGroundAndInvalidNeighboursAreKept) {
  // Flat ground seen by a level camera 1.5 m up with a 0.30 m baseline: 0.2 px more disparity per
  // row (baseline / height). Radius 3: at most 0.6 px within a window, under the 2 px jump.
  Plane disparity = disparity_plane(16, 40);
  for (int v = 0; v < 40; ++v)
    for (int u = 0; u < 16; ++u) disparity.at<int16_t>(u, v) = static_cast<int16_t>(160 + (16 * v) / 5);  // 10 + 0.2 v px
  // An invalid block (occlusion) beside high disparities is no jump.
  for (int v = 0; v < 5; ++v)
    for (int u = 0; u < 4; ++u) disparity.at<int16_t>(u, v) = kInvalidQ4;
  EXPECT_EQ(invalidate_near_side_of_discontinuities(disparity, kInvalidQ4, 3, 2.0), 0);
  EXPECT_EQ(disparity.at<int16_t>(5, 39), 160 + (16 * 39) / 5);
  EXPECT_EQ(disparity.at<int16_t>(0, 0), kInvalidQ4);
}

TEST(InvalidateNearSideOfDiscontinuities, AgreesWithTheRuleReadPixelByPixel) {
  std::mt19937 random(7);
  std::uniform_int_distribution<int> value(-1, 60);  // -1: invalid; else disparity 0 .. 59 px in Q4 steps of 1 px
  const int width = 23, height = 17, radius = 2;
  const double jump_px = 3.5;
  Plane disparity = disparity_plane(width, height);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const int d = value(random);
      disparity.at<int16_t>(u, v) = static_cast<int16_t>(d < 0 ? kInvalidQ4 : 16 * d);
    }
  const Plane input = disparity.clone();
  int64_t expected_count = 0;
  std::vector<int16_t> expected(static_cast<size_t>(width) * height);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const int16_t d = input.at<int16_t>(u, v);
      bool near_side = false;
      for (int dv = -radius; dv <= radius && d > kInvalidQ4; ++dv) {
        for (int du = -radius; du <= radius; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu < 0 || vv < 0 || uu >= width || vv >= height) continue;
          const int16_t other = input.at<int16_t>(uu, vv);
          if (other > kInvalidQ4 && (d - other) / 16.0 > jump_px) near_side = true;
        }
      }
      expected[static_cast<size_t>(v) * width + u] = near_side ? kInvalidQ4 : d;
      expected_count += near_side ? 1 : 0;
    }
  }
  ASSERT_GT(expected_count, 0);
  EXPECT_EQ(invalidate_near_side_of_discontinuities(disparity, kInvalidQ4, radius, jump_px), expected_count);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) EXPECT_EQ(disparity.at<int16_t>(u, v), expected[static_cast<size_t>(v) * width + u]) << u << "," << v;
}

TEST(InvalidateNearSideOfDiscontinuities, BadParametersThrow) {
  Plane disparity = disparity_plane(4, 4);
  EXPECT_THROW(invalidate_near_side_of_discontinuities(disparity, kInvalidQ4, 0, 2.0), std::invalid_argument);
  EXPECT_THROW(invalidate_near_side_of_discontinuities(disparity, kInvalidQ4, 2, 0.0), std::invalid_argument);
  Plane bytes(4, 4, BufferFormat{ElementType::u8});
  EXPECT_THROW(invalidate_near_side_of_discontinuities(bytes, kInvalidQ4, 2, 2.0), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm
