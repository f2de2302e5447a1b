// arm::pixels_on_far_side (arm/terrain_points.h): the far side under a nearer surface's lower edge
// is flagged rows_above_px deep, across invalid rows; ground, objects standing on it, surfaces seen
// above a nearer one and the near surface's own fattened bottom row never are; beside a nearer
// object's side edge, the measured ramp columns_beside_px wide; a random map agrees
// with the rule read pixel by pixel, and bands of rows with the whole image; off (0 rows) flags
// nothing; bad tests and row ranges throw naming the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "arm/terrain_points.h"
#include "tests/arm/terrain/disparity_planes.h"

namespace lpstereo::arm {
namespace {

using testing::disparity_plane;
using testing::kInvalidQ4;
using testing::q4;

// Six columns of 30 rows, read from the top (row 0) down; disparities in px, -1 invalid. Jump 2 px,
// 6 rows.
TEST(PixelsOnFarSide, HandBuiltColumns) {
  const int height = 30;
  Plane disparity = disparity_plane(6, height);
  const auto ground = [](int v) { return 2.0 + 0.2 * v; };  // 0.2 px a row: baseline / camera height
  for (int v = 0; v < height; ++v) {
    // 0: ground only
    disparity.at<int16_t>(0, v) = q4(ground(v));
    // 1: a board on poles (20 px, rows 10-14) over the farther road; its bottom row fattened (19.5 px, row 15)
    disparity.at<int16_t>(1, v) = q4(v < 10 ? 0.5 : v < 15 ? 20.0 : v == 15 ? 19.5 : ground(v));
    // 2: the same with two invalid rows (16-17) between the board and the road
    disparity.at<int16_t>(2, v) = q4(v < 10 ? 0.5 : v < 15 ? 20.0 : v == 15 ? 19.5 : v < 18 ? -1.0 : ground(v));
    // 3: the road under the board read too near, decaying over the rows (SGM's smoothness): the ramp
    disparity.at<int16_t>(3, v) = q4(v < 10 ? 0.5 : v < 16 ? 20.0 : v < 22 ? ground(v) + 0.5 * (22 - v) : ground(v));
    // 4: a sign (3 px, rows 0-9) seen above a nearer board (20 px, rows 10-19) standing on the road
    disparity.at<int16_t>(4, v) = q4(v < 10 ? 3.0 : v < 20 ? 20.0 : std::max(20.0, ground(v)));
    // 5: a box (9 px, rows 20-25) standing on the ground, whose foot meets the ground at row 25
    disparity.at<int16_t>(5, v) = q4(v >= 20 && v < 26 ? 9.0 : ground(v));
  }
  const std::vector<uint8_t> flags = pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.rows_above_px = 6, .columns_beside_px = 0, .jump_px = 2.0});
  const auto expected = [](int u, int v) {
    switch (u) {
      case 1: return v >= 16 && v <= 21;  // 6 rows under the board's last row (the fattened row 15 is within 2 px)
      case 2: return v >= 18 && v <= 21;  // across the invalid rows, within 6 rows of row 15
      case 3: return v >= 16 && v <= 21;  // the whole ramp, however it decays
      default: return false;              // ground, a surface seen above a nearer one, a box on the ground
    }
  };
  for (int u = 0; u < 6; ++u) {
    for (int v = 0; v < height; ++v) EXPECT_EQ(flags[static_cast<size_t>(v) * 6 + u] != 0, expected(u, v)) << "column " << u << " row " << v;
  }
}

// One row of 30 columns, read from the left: floating seed 1 frame 44, row 245, as measured: board 4
// (true 8.7 px) and the ramp the matcher makes of it beside a pedestrian (9.0 .. 12.2 px, columns
// 4-12), the pedestrian (12.8 px, columns 13-19), then the ground beyond (3 px). Jump 2 px.
TEST(PixelsOnFarSide, RowBesideANearerObject) {
  const double row_px[30] = {8.7,  8.7,  8.7,  8.7,  9.0,  9.1,  9.3, 9.4, 9.9, 10.1, 11.0, 11.6, 12.2, 12.8, 12.8,
                             12.8, 12.8, 12.8, 12.8, 12.8, 3.0,  3.0, 3.0, 3.0, 3.0,  3.0,  3.0,  3.0,  3.0,  3.0};
  Plane disparity = disparity_plane(30, 1);
  for (int u = 0; u < 30; ++u) disparity.at<int16_t>(u, 0) = q4(row_px[u]);
  // 3 columns: of the ramp only 10.1 px (2.1 px under 12.2 three columns on); the ground's first three.
  const std::vector<uint8_t> three = pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.rows_above_px = 0, .columns_beside_px = 3});
  // 6 columns: the ramp from 9.1 px on, up to 10.1 (9.0 is exactly 2 px under 11.0, not more); 11.0
  // and up lie within 2 px of the pedestrian; the ground's first six.
  const std::vector<uint8_t> six = pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.rows_above_px = 0, .columns_beside_px = 6});
  for (int u = 0; u < 30; ++u) {
    EXPECT_EQ(three[static_cast<size_t>(u)] != 0, u == 9 || (u >= 20 && u <= 22)) << "3 columns, column " << u;
    EXPECT_EQ(six[static_cast<size_t>(u)] != 0, (u >= 5 && u <= 9) || (u >= 20 && u <= 25)) << "6 columns, column " << u;
  }
}

TEST(PixelsOnFarSide, AgreesWithTheRuleReadPixelByPixel) {
  std::mt19937 random(11);
  std::uniform_int_distribution<int> value(-1, 60);  // -1: invalid; else 0 .. 59 px in steps of 1 px
  const int width = 21, height = 19;
  for (const FarSideTest test :
       {FarSideTest{.rows_above_px = 1, .columns_beside_px = 0, .jump_px = 2.0}, FarSideTest{.rows_above_px = 4, .columns_beside_px = 0, .jump_px = 3.5},
        FarSideTest{.rows_above_px = 25, .columns_beside_px = 0, .jump_px = 10.0}, FarSideTest{.rows_above_px = 0, .columns_beside_px = 2, .jump_px = 3.5},
        FarSideTest{.rows_above_px = 3, .columns_beside_px = 30, .jump_px = 20.0}}) {
    Plane disparity = disparity_plane(width, height);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) disparity.at<int16_t>(u, v) = q4(value(random));
    const std::vector<uint8_t> flags = pixels_on_far_side(disparity, kInvalidQ4, test);
    int flagged = 0;
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const int16_t d = disparity.at<int16_t>(u, v);
        bool under = false;
        const auto nearer = [&](int uu, int vv) {
          const int16_t other = disparity.at<int16_t>(uu, vv);
          return d > kInvalidQ4 && other > kInvalidQ4 && (other - d) / 16.0 > test.jump_px;
        };
        for (int k = 1; k <= test.rows_above_px && v - k >= 0; ++k) under = under || nearer(u, v - k);
        for (int k = -test.columns_beside_px; k <= test.columns_beside_px; ++k) under = under || (u + k >= 0 && u + k < width && nearer(u + k, v));
        EXPECT_EQ(flags[static_cast<size_t>(v) * width + u] != 0, under)
            << u << "," << v << " rows " << test.rows_above_px << " columns " << test.columns_beside_px;
        flagged += under ? 1 : 0;
      }
    }
    EXPECT_GT(flagged, 0);
    EXPECT_LT(flagged, width * height);
    // Bands of rows (as the candidates' threads take them) give the whole image's flags.
    std::vector<uint8_t> banded;
    for (const auto& [first_row, end_row] : {std::pair{0, 0}, std::pair{0, 7}, std::pair{7, 13}, std::pair{13, height}}) {
      const std::vector<uint8_t> band = pixels_on_far_side(disparity, kInvalidQ4, test, first_row, end_row);
      ASSERT_EQ(band.size(), static_cast<size_t>(width) * (end_row - first_row));
      banded.insert(banded.end(), band.begin(), band.end());
    }
    EXPECT_EQ(banded, flags);
  }
}

TEST(PixelsOnFarSide, OffFlagsNothing) {
  Plane disparity = disparity_plane(3, 4);
  for (int v = 0; v < 4; ++v)
    for (int u = 0; u < 3; ++u) disparity.at<int16_t>(u, v) = q4(v == 0 ? 40.0 : 1.0);
  const std::vector<uint8_t> by_default = pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{});  // 6 rows, 6 columns
  EXPECT_EQ(std::count(by_default.begin(), by_default.end(), 1), 9);  // rows 1-3 under the 40 px row 0
  const std::vector<uint8_t> flags = pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.rows_above_px = 0, .columns_beside_px = 0});
  ASSERT_EQ(flags.size(), 12u);
  for (uint8_t flag : flags) EXPECT_EQ(flag, 0);
}

TEST(PixelsOnFarSide, BadTestsThrowNamingTheField) {
  const auto message = [](const std::function<void()>& call) {
    try {
      call();
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("no throw");
  };
  Plane disparity = disparity_plane(4, 4);
  EXPECT_EQ(message([&] { pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.rows_above_px = -1}); }),
            "rows_above_px: expected in [0, 64], got -1");
  EXPECT_EQ(message([&] { pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.rows_above_px = 65}); }),
            "rows_above_px: expected in [0, 64], got 65");
  EXPECT_EQ(message([&] { pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.columns_beside_px = -2}); }),
            "columns_beside_px: expected in [0, 64], got -2");
  EXPECT_EQ(message([&] { pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{.rows_above_px = 6, .jump_px = 0.0}); }),
            "jump_px: expected a finite value > 0, got 0");
  EXPECT_EQ(message([&] { pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{}, 3, 2); }),
            "rows: expected 0 <= first_row <= end_row <= 4, got 3 and 2");
  EXPECT_EQ(message([&] { pixels_on_far_side(disparity, kInvalidQ4, FarSideTest{}, 0, 5); }),
            "rows: expected 0 <= first_row <= end_row <= 4, got 0 and 5");
  Plane bytes(4, 4, BufferFormat{ElementType::u8});
  EXPECT_EQ(message([&] { pixels_on_far_side(bytes, kInvalidQ4, FarSideTest{.rows_above_px = 6}); }),
            "disparity_q4: expected an s16 plane");
}

}  // namespace
}  // namespace lpstereo::arm
