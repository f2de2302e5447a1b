// Pictures of the 3D obstacle representations (issue 10 deliverables 1 and 2): OpenCV lives here,
// the grids and stixels (arm/obstacles3d/) need none. All pictures are CV_8UC3 BGR.
//
// Occupancy grid (occupancy_grid_picture): the top view of the grid with each cell's probability as
// grey (P = 0 white, 0.5 mid grey = unknown, 1 black), the clusters' convex hulls drawn over it in a
// colour by distance (red near, through yellow and green, to blue at the grid's far edge: the
// thesis' "red means close"), each obstacle's index written beside its hull.
//   cartesian: metric top view, x (lateral) to the right, z (depth) up;
//   polar:     the same metric top view, the fan of cells drawn in place (outside it dark blue);
//   column_disparity: the (u, d) plane, u to the right, d down (near at the bottom), cells as pixels
//     scaled by `scale`.
// Augmented stixels: stixel_image_overlay draws every stixel's points on the left image in the colour
// of the stixel's distance (the image dimmed below), stixel_top_view the polar fan with each stixel's
// cell filled in that colour, a hanging stixel (free space under it, free_below_m >= 0.3 m) only
// outlined, and each stixel obstacle's index (its heights are on the overlay).
#pragma once

#include <opencv2/core.hpp>

#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/occupancy_grid.h"

namespace lpstereo::io {

// BGR colour for a distance: red at 0, blue at far_m and beyond.
cv::Scalar distance_colour(double distance_m, double far_m);

// pixels_per_metre for the cartesian and polar views (> 0), pixels per cell for column_disparity;
// colour_far_m: the distance drawn blue (0: the grid's far edge, for column_disparity the depth of
// its smallest nonzero disparity row, f B / max(row_min, row_cell)).
cv::Mat occupancy_grid_picture(const arm::obstacles3d::OccupancyGrid& grid, double scale = 8.0, double colour_far_m = 0);

// `image` CV_8UC1 or CV_8UC3 (BGR), the left image of the frame whose points built the stixels.
cv::Mat stixel_image_overlay(const cv::Mat& image, const arm::obstacles3d::AugmentedStixels& stixels,
                             const std::vector<arm::obstacles3d::ObstaclePoint>& points);
cv::Mat stixel_top_view(const arm::obstacles3d::AugmentedStixels& stixels, double pixels_per_metre = 8.0);

}  // namespace lpstereo::io
