// Pictures of the occupancy grids and stixels (io/obstacles3d_pictures.h): sizes follow the grid and
// the scale; an occupied cell is dark, an unknown one mid grey; the cluster's hull is drawn in the
// distance colour (red near); the stixel top view fills a grounded stixel and only outlines a
// hanging one; the overlay paints the stixels' points; bad arguments throw naming the argument.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/occupancy_grid.h"
#include "io/obstacles3d_pictures.h"
#include "tests/arm/obstacles3d/synthetic_points.h"

namespace lpstereo::io {
namespace {

using namespace arm::obstacles3d;
using arm::obstacles3d::testing::add_patch;
using arm::obstacles3d::testing::grid_parameters;

bool is_grey(const cv::Vec3b& pixel) { return pixel[0] == pixel[1] && pixel[1] == pixel[2]; }

TEST(Obstacles3dPictures, CartesianGridPictureShowsProbabilityAndTheHull) {
  OccupancyGrid grid(grid_parameters(GridKind::cartesian));
  std::vector<ObstaclePoint> points;
  add_patch(points, -0.5, 0.5, 0.0, 1.0, 5.0, 0.02);
  for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
  ASSERT_EQ(grid.clusters().size(), 1u);
  const cv::Mat picture = occupancy_grid_picture(grid, 10.0);
  ASSERT_EQ(picture.type(), CV_8UC3);
  EXPECT_EQ(picture.cols, 200);  // 20 m x 10 px/m
  EXPECT_EQ(picture.rows, 400);  // 40 m
  // An unobserved far corner: P = 1 / (1 + e^{3 logit(0.45)}) after three misses, light grey.
  const cv::Vec3b far_corner = picture.at<cv::Vec3b>(2, 2);
  EXPECT_TRUE(is_grey(far_corner));
  EXPECT_GT(far_corner[0], 128);
  // Inside the object (x = 0.05, z = 5.0 -> pixel (100.5, 355)): occupied, dark.
  const cv::Vec3b inside = picture.at<cv::Vec3b>(355, 100);
  EXPECT_TRUE(is_grey(inside) || inside[2] > 200);  // grey, or the hull's red line
  // The hull is drawn in colour (a near object: red dominant) somewhere around the object.
  int coloured = 0;
  for (int row = 340; row < 370; ++row)
    for (int column = 85; column < 116; ++column) {
      const cv::Vec3b pixel = picture.at<cv::Vec3b>(row, column);
      if (!is_grey(pixel) && pixel[2] > pixel[0]) ++coloured;
    }
  EXPECT_GT(coloured, 10);
}

TEST(Obstacles3dPictures, PolarAndColumnDisparityPicturesHaveTheirShapes) {
  OccupancyGrid polar(grid_parameters(GridKind::polar));
  polar.update({}, EgoMotion{});
  const cv::Mat fan = occupancy_grid_picture(polar, 4.0);
  EXPECT_EQ(fan.rows, 162);  // range 40.5 m x 4 px/m
  // The bottom corners lie outside the fan (|theta| > 0.6 rad there): the dark blue background.
  EXPECT_FALSE(is_grey(fan.at<cv::Vec3b>(fan.rows - 1, 0)));
  OccupancyGrid column_disparity(grid_parameters(GridKind::column_disparity));
  column_disparity.update({}, EgoMotion{});
  const cv::Mat plane = occupancy_grid_picture(column_disparity, 2.0);
  EXPECT_EQ(plane.cols, column_disparity.columns() * 2);
  EXPECT_EQ(plane.rows, column_disparity.rows() * 2);
  EXPECT_THROW(occupancy_grid_picture(polar, 0.0), std::invalid_argument);
}

TEST(Obstacles3dPictures, StixelViewsFillGroundedAndOutlineHangingStixels) {
  AugmentedStixelParameters parameters;
  parameters.grid = grid_parameters(GridKind::polar);
  AugmentedStixels stixels(parameters);
  std::vector<ObstaclePoint> points;
  add_patch(points, -2.0, -1.5, 0.0, 1.0, 8.0);  // grounded, left
  add_patch(points, 1.5, 2.0, 1.0, 1.5, 8.0);    // hanging, right
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  // At 50 px/m a stixel at 8 m (0.01 rad x 0.2 m) is 4 x 10 pixels: its centre pixel is inside the
  // polygon, away from the outline.
  constexpr double kPixelsPerMetre = 50.0;
  const cv::Mat top = stixel_top_view(stixels, kPixelsPerMetre);
  const double x_min = 40.5 * std::sin(-0.6);
  auto centre_pixel = [&](const AugmentedStixel& stixel) {
    const double angle = (stixel.angle_min_rad + stixel.angle_max_rad) / 2;
    const double range = (stixel.range_min_m + stixel.range_max_m) / 2;
    const int column = static_cast<int>((range * std::sin(angle) - x_min) * kPixelsPerMetre);
    const int row = static_cast<int>((40.5 - range * std::cos(angle)) * kPixelsPerMetre);
    return top.at<cv::Vec3b>(row, column);
  };
  int grounded = 0, hanging = 0;
  for (const AugmentedStixel& stixel : stixels.stixels()) {
    if (stixel.free_below_m() >= 0.3f) {
      EXPECT_TRUE(is_grey(centre_pixel(stixel))) << "hanging stixel filled at angle " << stixel.angle_min_rad;
      ++hanging;
    } else {
      EXPECT_FALSE(is_grey(centre_pixel(stixel))) << "grounded stixel not filled at angle " << stixel.angle_min_rad;
      ++grounded;
    }
  }
  EXPECT_GT(grounded, 0);
  EXPECT_GT(hanging, 0);
  const cv::Mat image(480, 640, CV_8UC1, cv::Scalar(200));
  const cv::Mat overlay = stixel_image_overlay(image, stixels, points);
  const ObstaclePoint& first = points[static_cast<size_t>(stixels.point_indices()[0])];
  EXPECT_FALSE(is_grey(overlay.at<cv::Vec3b>(first.v_px, first.u_px)));
  EXPECT_TRUE(is_grey(overlay.at<cv::Vec3b>(5, 600)));
  EXPECT_EQ(overlay.at<cv::Vec3b>(5, 600)[0], 100);  // dimmed to half
  EXPECT_THROW(stixel_image_overlay(cv::Mat(4, 4, CV_32FC1), stixels, points), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::io
