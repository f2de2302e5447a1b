// Test helper: obstacle candidate points of a level pinhole stereo camera (f = 500 px, B = 0.3 m,
// 640x480, principal point at the image centre) mounted 1.5 m above a flat road at the vehicle
// origin, so that every field of ObstaclePoint is consistent: camera (x, y, z), vehicle (z_c, -x_c,
// -y_c), height above the road = 1.5 - y_c, d = f B / z, u = u0 + f x / z, v = v0 + f y / z.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "arm/obstacles3d/obstacle_points.h"
#include "arm/obstacles3d/occupancy_grid.h"

namespace lpstereo::arm::obstacles3d::testing {

constexpr double kFocalPx = 500.0;
constexpr double kBaselineM = 0.3;
constexpr double kPrincipalUPx = 319.5;
constexpr double kPrincipalVPx = 239.5;
constexpr double kCameraHeightM = 1.5;

inline StereoErrorModel error_model() {
  StereoErrorModel model;
  model.focal_px = kFocalPx;
  model.baseline_m = kBaselineM;
  return model;
}

inline OccupancyGridParameters grid_parameters(GridKind kind) {
  OccupancyGridParameters parameters = OccupancyGridParameters::defaults(kind, 640);
  parameters.error_model = error_model();
  parameters.principal_u_px = kPrincipalUPx;
  return parameters;
}

// A point at lateral x (m, + right), height above the road (m) and depth z (m).
inline ObstaclePoint point_at(double x_m, double height_m, double z_m, uint8_t grey = 128) {
  ObstaclePoint point;
  const double y_m = kCameraHeightM - height_m;
  point.camera_m = Eigen::Vector3f(static_cast<float>(x_m), static_cast<float>(y_m), static_cast<float>(z_m));
  point.vehicle_m = Eigen::Vector3f(static_cast<float>(z_m), static_cast<float>(-x_m), static_cast<float>(height_m));
  point.height_above_ground_m = static_cast<float>(height_m);
  point.disparity_px = static_cast<float>(kFocalPx * kBaselineM / z_m);
  point.u_px = static_cast<uint16_t>(std::lround(kPrincipalUPx + kFocalPx * x_m / z_m));
  point.v_px = static_cast<uint16_t>(std::lround(kPrincipalVPx + kFocalPx * y_m / z_m));
  point.rgb = {grey, grey, grey};
  return point;
}

// A vertical rectangle of points at depth z: x in [x0, x1], heights in [h0, h1], spacing step_m.
inline void add_patch(std::vector<ObstaclePoint>& points, double x0_m, double x1_m, double h0_m, double h1_m,
                      double z_m, double step_m = 0.01) {
  const int columns = static_cast<int>(std::lround((x1_m - x0_m) / step_m));
  const int rows = static_cast<int>(std::lround((h1_m - h0_m) / step_m));
  for (int i = 0; i <= columns; ++i)
    for (int j = 0; j <= rows; ++j) points.push_back(point_at(x0_m + i * step_m, h0_m + j * step_m, z_m));
}

// A vertical surface at depth z seen over left-image columns u_first..u_last: one column of points
// per pixel column (u_px exactly u), heights h0..h1 every pixel row (z / f), noise-free.
inline void add_pixel_columns(std::vector<ObstaclePoint>& points, int u_first, int u_last, double h0_m, double h1_m, double z_m) {
  const double pixel_m = z_m / kFocalPx;
  for (int u = u_first; u <= u_last; ++u)
    for (double height = h0_m; height <= h1_m + 1e-9; height += pixel_m)
      points.push_back(point_at((u - kPrincipalUPx) * pixel_m, height, z_m));
}

// One left-image column u of a surface at depth z (x = (u - u0) z / f): points every pixel row
// (z / f) from h0 to h1, noise-free.
inline void add_pixel_column(std::vector<ObstaclePoint>& points, int u, double h0_m, double h1_m, double z_m) {
  const double pixel_m = z_m / kFocalPx;
  for (double height = h0_m; height <= h1_m + 1e-9; height += pixel_m)
    points.push_back(point_at((u - kPrincipalUPx) * pixel_m, height, z_m));
}

// A vertical plane at lateral x (a parked car's side, along the camera's axis) seen over columns
// u_first..u_last on one side of u0: each column's depth is z = f x / (u - u0).
inline void add_side_columns(std::vector<ObstaclePoint>& points, int u_first, int u_last, double x_m, double h0_m, double h1_m) {
  for (int u = u_first; u <= u_last; ++u) add_pixel_column(points, u, h0_m, h1_m, kFocalPx * x_m / (u - kPrincipalUPx));
}

// A parked car left of the camera seen at its rear-right corner, and a pedestrian touching the far
// end of its right side in the image (urban seed 3 frames 15-19 in bench/obstacles3d_eval): the rear
// (0.2-1.5 m) at 11.5 m over columns 111-189 (x from -4.8 to -3.0 m), the right side x = -3.0 m over
// columns 190-219 receding from 11.58 to 14.93 m, and the pedestrian (0.2-1.7 m) at 15 m over
// columns 220-236 (x from -2.99 to -2.51 m). No image column is empty and the range does not fall
// after the side's far end.
inline void add_car_side_and_pedestrian(std::vector<ObstaclePoint>& points, bool car = true, bool pedestrian = true) {
  if (car) {
    for (int u = 111; u <= 189; ++u) add_pixel_column(points, u, 0.2, 1.5, 11.5);
    add_side_columns(points, 190, 219, -3.0, 0.2, 1.5);
  }
  if (pedestrian)
    for (int u = 220; u <= 236; ++u) add_pixel_column(points, u, 0.2, 1.7, 15.0);
}

}  // namespace lpstereo::arm::obstacles3d::testing
