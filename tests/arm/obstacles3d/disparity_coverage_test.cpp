// The view check (arm/obstacles3d/disparity_coverage.h): the invalid share counted over the map's
// pixels and not its padding, the threshold's boundary, the counted work, and bad input.
#include "arm/obstacles3d/disparity_coverage.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace lpstereo::arm::obstacles3d {
namespace {

constexpr int16_t kInvalidQ4 = -16;  // (min_disparity - 1) * 16 with min_disparity 0

// An odd-sized s16 map in a padded buffer: every pixel valid (disparity 5 px), the padding filled
// with the invalid value so that a count reaching past the row's width would show.
Plane padded_map(int width, int height) {
  Plane map(width, height, BufferFormat{ElementType::s16, 4}, 4 * 64);
  for (int y = 0; y < height; ++y) {
    int16_t* row = map.row<int16_t>(y);
    for (int x = 0; x < 4 * 64 / 2; ++x) row[x] = x < width ? int16_t{5 * 16} : kInvalidQ4;
  }
  return map;
}

TEST(DisparityCoverage, CountsTheInvalidPixelsOfTheMapNotOfItsPadding) {
  Plane map = padded_map(37, 11);  // 407 pixels
  DisparityCoverageParameters parameters;
  ArmWork work;
  DisparityCoverage coverage = disparity_coverage(map, kInvalidQ4, parameters, &work);
  EXPECT_EQ(coverage.pixels, 407);
  EXPECT_EQ(coverage.invalid_pixels, 0);
  EXPECT_FALSE(coverage.degraded);
  EXPECT_EQ(work.scalar_ops, 2u * 407);
  EXPECT_EQ(work.memory_bytes, 2u * 407);
  // A block of 5 x 8 = 40 pixels invalid, and one pixel with a valid negative-looking value that is
  // not the invalid one (disparity -0.5 px is not produced, but only the exact value counts).
  for (int y = 2; y < 7; ++y) {
    for (int x = 29; x < 37; ++x) map.at<int16_t>(x, y) = kInvalidQ4;
  }
  map.at<int16_t>(0, 0) = -8;
  coverage = disparity_coverage(map, kInvalidQ4, parameters, nullptr);
  EXPECT_EQ(coverage.invalid_pixels, 40);
  EXPECT_DOUBLE_EQ(coverage.invalid_share, 40.0 / 407.0);
  EXPECT_FALSE(coverage.degraded);  // 9.8 % < 10 %
}

TEST(DisparityCoverage, TheViewIsDegradedFromTheThresholdOn) {
  Plane map = padded_map(10, 10);
  for (int x = 0; x < 10; ++x) map.at<int16_t>(x, 0) = kInvalidQ4;  // 10 of 100: exactly 10 %
  DisparityCoverageParameters parameters;
  EXPECT_TRUE(disparity_coverage(map, kInvalidQ4, parameters).degraded);
  parameters.degraded_invalid_share = 0.11;
  EXPECT_FALSE(disparity_coverage(map, kInvalidQ4, parameters).degraded);
  parameters.degraded_invalid_share = 1.0;  // only a map with no valid pixel at all
  for (int y = 0; y < 10; ++y) {
    for (int x = 0; x < 10; ++x) map.at<int16_t>(x, y) = kInvalidQ4;
  }
  const DisparityCoverage all_invalid = disparity_coverage(map, kInvalidQ4, parameters);
  EXPECT_DOUBLE_EQ(all_invalid.invalid_share, 1.0);
  EXPECT_TRUE(all_invalid.degraded);
}

TEST(DisparityCoverage, BadInputNamesTheThing) {
  const Plane map = padded_map(8, 4);
  for (const double share : {0.0, -0.1, 1.5}) {
    DisparityCoverageParameters parameters;
    parameters.degraded_invalid_share = share;
    try {
      disparity_coverage(map, kInvalidQ4, parameters);
      ADD_FAILURE() << "no error for " << share;
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("degraded_invalid_share: expected (0, 1], got"), std::string::npos) << error.what();
    }
  }
  const Plane bytes(8, 4, BufferFormat{ElementType::u8});
  EXPECT_THROW(disparity_coverage(bytes, kInvalidQ4, DisparityCoverageParameters{}), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
