// Pictures of the occupancy grids and the augmented stixels (obstacles3d_pictures.h).
#include "io/obstacles3d_pictures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace lpstereo::io {
namespace {

using arm::obstacles3d::GridKind;
using arm::obstacles3d::OccupancyGrid;
using arm::obstacles3d::OccupancyGridParameters;

const cv::Scalar kOutsideColour(60, 30, 20);  // dark blue: outside the grid's fan

// The metric top view's extent (camera x to the right, z up) for cartesian and polar grids.
struct TopView {
  double x_min = 0, x_max = 0, z_min = 0, z_max = 0, pixels_per_metre = 1;
  cv::Size size() const {
    return {std::max(1, static_cast<int>(std::ceil((x_max - x_min) * pixels_per_metre))),
            std::max(1, static_cast<int>(std::ceil((z_max - z_min) * pixels_per_metre)))};
  }
  cv::Point2d pixel(double x_m, double z_m) const {
    return {(x_m - x_min) * pixels_per_metre, (z_max - z_m) * pixels_per_metre};
  }
  double x_of(int column) const { return x_min + (column + 0.5) / pixels_per_metre; }
  double z_of(int row) const { return z_max - (row + 0.5) / pixels_per_metre; }
};

TopView top_view_of(const OccupancyGridParameters& parameters, double pixels_per_metre) {
  if (!(pixels_per_metre > 0)) throw std::invalid_argument("pixels_per_metre: expected > 0, got " + std::to_string(pixels_per_metre));
  TopView view;
  view.pixels_per_metre = pixels_per_metre;
  if (parameters.kind == GridKind::cartesian) {
    view.x_min = parameters.column_min, view.x_max = parameters.column_max;
    view.z_min = parameters.row_min, view.z_max = parameters.row_max;
  } else {  // polar: the fan's bounding box
    const double range = parameters.row_max;
    view.x_min = std::min(0.0, range * std::sin(parameters.column_min));
    view.x_max = std::max(0.0, range * std::sin(parameters.column_max));
    view.z_min = 0;
    view.z_max = range;
  }
  return view;
}

// Grey of a probability: 1 black, 0.5 mid grey, 0 white.
cv::Vec3b probability_grey(float probability) {
  const auto grey = static_cast<uint8_t>(std::lround(255.0 * (1.0 - probability)));
  return {grey, grey, grey};
}

// The metric top view's background: each pixel takes its cell's probability.
cv::Mat metric_background(const OccupancyGrid& grid, const TopView& view) {
  cv::Mat picture(view.size(), CV_8UC3, kOutsideColour);
  for (int row = 0; row < picture.rows; ++row) {
    for (int column = 0; column < picture.cols; ++column) {
      const Eigen::Vector2d coordinates = grid.grid_coordinates_of(view.x_of(column), view.z_of(row));
      int cell_row = 0, cell_column = 0;
      if (grid.cell_of(coordinates(0), coordinates(1), &cell_row, &cell_column))
        picture.at<cv::Vec3b>(row, column) = probability_grey(grid.probability(cell_row, cell_column));
    }
  }
  return picture;
}

// The polygon of a polar cell in the top view: its two arcs sampled, in pixels.
std::vector<cv::Point> polar_cell_polygon(const TopView& view, double angle_min, double angle_max, double range_min,
                                          double range_max) {
  constexpr int kArcSamples = 4;
  std::vector<cv::Point> polygon;
  for (int k = 0; k <= kArcSamples; ++k) {
    const double angle = angle_min + (angle_max - angle_min) * k / kArcSamples;
    polygon.push_back(view.pixel(range_max * std::sin(angle), range_max * std::cos(angle)));
  }
  for (int k = kArcSamples; k >= 0; --k) {
    const double angle = angle_min + (angle_max - angle_min) * k / kArcSamples;
    polygon.push_back(view.pixel(range_min * std::sin(angle), range_min * std::cos(angle)));
  }
  return polygon;
}

double far_distance_m(const OccupancyGridParameters& parameters) {
  if (parameters.kind == GridKind::column_disparity) {
    const double smallest_disparity = std::max(parameters.row_min, parameters.row_cell);
    return parameters.error_model.focal_px * parameters.error_model.baseline_m / smallest_disparity;
  }
  return parameters.row_max;
}

}  // namespace

cv::Scalar distance_colour(double distance_m, double far_m) {
  const double fraction = std::clamp(far_m > 0 ? distance_m / far_m : 0.0, 0.0, 1.0);
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(fraction * 120.0, 255, 255));  // OpenCV hue 0 red .. 120 blue
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b colour = bgr.at<cv::Vec3b>(0, 0);
  return {static_cast<double>(colour[0]), static_cast<double>(colour[1]), static_cast<double>(colour[2])};
}

cv::Mat occupancy_grid_picture(const OccupancyGrid& grid, double scale, double colour_far_m) {
  const OccupancyGridParameters& parameters = grid.parameters();
  const double far_m = colour_far_m > 0 ? colour_far_m : far_distance_m(parameters);
  cv::Mat picture;
  std::function<cv::Point2d(const Eigen::Vector2d&)> to_pixel;
  TopView view;
  if (parameters.kind == GridKind::column_disparity) {
    if (!(scale > 0)) throw std::invalid_argument("scale: expected > 0 pixels per cell, got " + std::to_string(scale));
    const int pixels = std::max(1, static_cast<int>(std::lround(scale)));
    picture = cv::Mat(grid.rows() * pixels, grid.columns() * pixels, CV_8UC3);
    for (int row = 0; row < picture.rows; ++row)
      for (int column = 0; column < picture.cols; ++column)
        picture.at<cv::Vec3b>(row, column) = probability_grey(grid.probability(row / pixels, column / pixels));
    to_pixel = [&parameters, pixels](const Eigen::Vector2d& ud) {
      return cv::Point2d((ud(0) - parameters.column_min) / parameters.column_cell * pixels,
                         (ud(1) - parameters.row_min) / parameters.row_cell * pixels);
    };
  } else {
    view = top_view_of(parameters, scale);
    picture = metric_background(grid, view);
    to_pixel = [&view](const Eigen::Vector2d& xz) { return view.pixel(xz(0), xz(1)); };
  }
  for (size_t index = 0; index < grid.clusters().size(); ++index) {
    const arm::obstacles3d::GridCluster& cluster = grid.clusters()[index];
    // Distance of the cluster: the mean of its cells' centres.
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (int cell : cluster.cells) {
      const int row = cell / grid.columns(), column = cell % grid.columns();
      centre += grid.camera_xz_of(parameters.column_min + (column + 0.5) * parameters.column_cell,
                                  parameters.row_min + (row + 0.5) * parameters.row_cell);
    }
    centre /= static_cast<double>(cluster.cells.size());
    const cv::Scalar colour = distance_colour(centre.norm(), far_m);
    std::vector<cv::Point> polygon;
    for (const Eigen::Vector2d& vertex : cluster.hull) polygon.push_back(to_pixel(vertex));
    if (polygon.empty()) continue;
    cv::polylines(picture, polygon, true, colour, 1, cv::LINE_AA);
    if (cluster.obstacle_index >= 0) {
      const cv::Rect box = cv::boundingRect(polygon);
      cv::putText(picture, std::to_string(cluster.obstacle_index), {box.x + box.width + 2, box.y + 8},
                  cv::FONT_HERSHEY_PLAIN, 0.8, colour, 1, cv::LINE_AA);
    }
  }
  return picture;
}

cv::Mat stixel_image_overlay(const cv::Mat& image, const arm::obstacles3d::AugmentedStixels& stixels,
                             const std::vector<arm::obstacles3d::ObstaclePoint>& points) {
  cv::Mat picture;
  if (image.type() == CV_8UC1) {
    cv::cvtColor(image, picture, cv::COLOR_GRAY2BGR);
  } else if (image.type() == CV_8UC3) {
    picture = image.clone();
  } else {
    throw std::invalid_argument("image: expected CV_8UC1 or CV_8UC3, got type " + std::to_string(image.type()));
  }
  picture *= 0.5;
  const double far_m = stixels.parameters().grid.row_max;
  for (const arm::obstacles3d::AugmentedStixel& stixel : stixels.stixels()) {
    const cv::Scalar colour = distance_colour(stixel.mean_range_m, far_m);
    const cv::Vec3b pixel(static_cast<uint8_t>(colour[0]), static_cast<uint8_t>(colour[1]), static_cast<uint8_t>(colour[2]));
    for (int k = 0; k < stixel.point_count; ++k) {
      const arm::obstacles3d::ObstaclePoint& point =
          points[static_cast<size_t>(stixels.point_indices()[static_cast<size_t>(stixel.first_point + k)])];
      if (point.u_px < picture.cols && point.v_px < picture.rows) picture.at<cv::Vec3b>(point.v_px, point.u_px) = pixel;
    }
  }
  for (const arm::obstacles3d::Obstacle3d& obstacle : stixels.obstacles()) {
    if (obstacle.bbox_px[0] < 0) continue;
    const cv::Scalar colour = distance_colour(obstacle.position_m.norm(), far_m);
    cv::rectangle(picture, cv::Point(obstacle.bbox_px[0], obstacle.bbox_px[1]),
                  cv::Point(obstacle.bbox_px[2], obstacle.bbox_px[3]), colour, 1);
    char label[64];
    std::snprintf(label, sizeof label, "%d: %.1f-%.1f m", obstacle.id, obstacle.min_height_m, obstacle.max_height_m);
    cv::putText(picture, label, {obstacle.bbox_px[0], std::max(10, obstacle.bbox_px[1] - 3)}, cv::FONT_HERSHEY_PLAIN,
                0.9, colour, 1, cv::LINE_AA);
  }
  return picture;
}

cv::Mat stixel_top_view(const arm::obstacles3d::AugmentedStixels& stixels, double pixels_per_metre) {
  const OccupancyGrid& grid = stixels.grid();
  const TopView view = top_view_of(grid.parameters(), pixels_per_metre);
  cv::Mat picture = metric_background(grid, view);
  const double far_m = grid.parameters().row_max;
  constexpr double kHangingClearanceM = 0.3;
  for (const arm::obstacles3d::AugmentedStixel& stixel : stixels.stixels()) {
    const cv::Scalar colour = distance_colour(stixel.mean_range_m, far_m);
    const std::vector<cv::Point> polygon =
        polar_cell_polygon(view, stixel.angle_min_rad, stixel.angle_max_rad, stixel.range_min_m, stixel.range_max_m);
    if (stixel.free_below_m() >= kHangingClearanceM) {
      cv::polylines(picture, polygon, true, colour, 1, cv::LINE_8);  // hanging: free space under it
    } else {
      cv::fillConvexPoly(picture, polygon, colour, cv::LINE_8);
    }
  }
  for (const arm::obstacles3d::Obstacle3d& obstacle : stixels.obstacles()) {
    const cv::Point2d centre = view.pixel(obstacle.position_m.x(), obstacle.position_m.z());
    const std::string label = std::to_string(obstacle.id);  // heights are on the image overlay
    cv::putText(picture, label, cv::Point(static_cast<int>(centre.x) + 6, static_cast<int>(centre.y)),
                cv::FONT_HERSHEY_PLAIN, 0.8, cv::Scalar(0, 200, 255), 1, cv::LINE_AA);
  }
  cv::putText(picture, "filled: stixel on the ground; outline: hanging (free below)", {4, 12}, cv::FONT_HERSHEY_PLAIN,
              0.8, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return picture;
}

}  // namespace lpstereo::io
