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

}  // namespace lpstereo::arm::obstacles3d::testing
