// Issue 5's acceptance check, "a plane at known distance, rendered, matched and triangulated, comes
// back within 1 % of its distance": a rectified pair of a textured plane rendered here (known focal
// length, baseline, principal point), matched by arm::DisparityEngine with its defaults,
// triangulated by the disparity_to_points kernel (arm::triangulate). Two planes: fronto-parallel at
// 2.05 m, and the ground 1.5 m below a level camera (depth varying with the row), which also goes
// through the camera-to-vehicle transform and must come out at vehicle z = 0. Prints the measured
// errors and densities.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "arm/disparity_engine.h"
#include "arm/point_cloud.h"
#include "io/synthetic_scene.h"
#include "kernels/disparity_to_points.h"

namespace lpstereo::arm {
namespace {

constexpr int kWidth = 512;
constexpr int kHeight = 384;
constexpr double kFocalPx = 700.0;
constexpr double kBaselineM = 0.12;
constexpr double kU0Px = 255.8;  // principal point of both rectified views, off the pixel grid on purpose
constexpr double kV0Px = 191.3;

// What a left or right pixel sees: the texture coordinates (s, t) of the surface point on the ray
// through (u, v) from the camera `camera_x_m` to the right of the left camera.
using SurfaceAt = std::function<void(double u, double v, double camera_x_m, double& s, double& t)>;

// Renders one view: each pixel is the mean of 4 x 4 samples of the texture (a sensor integrates
// over its pixel; without it the right view, shifted by a fraction of a pixel, would alias).
Plane render_view(const SurfaceAt& surface, double camera_x_m) {
  Plane view(kWidth, kHeight, {ElementType::u8, 0});
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      double sum = 0;
      for (int i = 0; i < 16; ++i) {
        double s = 0, t = 0;
        surface(u - 0.375 + 0.25 * (i % 4), v - 0.375 + 0.25 * (i / 4), camera_x_m, s, t);
        sum += io::synthetic_texture_grey(s, t, 7, 128.0);
      }
      view.at<uint8_t>(u, v) = static_cast<uint8_t>(std::clamp(std::lround(sum / 16), 0L, 255L));
    }
  }
  return view;
}

double median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  const auto middle = values.begin() + static_cast<ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

TriangulationParameters triangulation(const DisparityEngine& engine) {
  return {kBaselineM, kFocalPx, kU0Px, kV0Px, engine.parameters().min_disparity, engine.parameters().num_disparities};
}

// Fronto-parallel plane Z = 2.05 m: disparity f B / Z = 40.98 px everywhere. Texture coordinates in
// pixels of the left view at that distance: s = f X / Z, t = f Y / Z.
TEST(PlaneTriangulation, FrontoParallelPlaneComesBackWithinOnePercent) {
  const double distance_m = 2.05;
  const SurfaceAt plane = [&](double u, double v, double camera_x_m, double& s, double& t) {
    const double x_m = (u - kU0Px) * distance_m / kFocalPx + camera_x_m;  // the ray's point on the plane
    s = x_m * kFocalPx / distance_m;
    t = (v - kV0Px);
  };
  const Plane left = render_view(plane, 0.0), right = render_view(plane, kBaselineM);
  DisparityEngine engine(kWidth, kHeight, DisparityParameters{});
  const Plane& disparity = engine.compute(left, right);
  const CameraPoints points = triangulate(disparity, triangulation(engine));

  std::vector<double> depths_m, lateral_errors_m;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const int32_t z_mm = points.z_mm.at<int32_t>(u, v);
      if (z_mm == kernels::kNoPointMm) continue;
      depths_m.push_back(1e-3 * z_mm);
      // x should be (u - u0) Z / f at the measured Z.
      lateral_errors_m.push_back(1e-3 * points.x_mm.at<int32_t>(u, v) - (u - kU0Px) * 1e-3 * z_mm / kFocalPx);
    }
  }
  const double density = static_cast<double>(depths_m.size()) / (kWidth * kHeight);
  const double median_depth_m = median(depths_m);
  const double error = median_depth_m / distance_m - 1.0;
  std::printf("fronto-parallel plane at %.3f m (d = %.3f px): median z %.4f m (error %+.3f %%), density %.1f %%, "
              "median x error %.2f mm\n",
              distance_m, kFocalPx * kBaselineM / distance_m, median_depth_m, 100 * error, 100 * density,
              1e3 * median(lateral_errors_m));
  EXPECT_LT(std::abs(error), 0.01) << "median z " << median_depth_m << " m, true " << distance_m << " m";
  // The matcher cannot match the left 41 + columns (outside the right view) nor the first
  // num_disparities columns' search; everything else is textured and should be valid.
  EXPECT_GT(density, 0.80);
  EXPECT_LT(std::abs(median(lateral_errors_m)), 0.002);
}

// The ground 1.5 m below a level camera (y down: the plane Y = 1.5 m), beyond Z = 30 m a
// fronto-parallel wall. On the ground Z = f h / (v - v0), so each row has its own depth. Texture
// coordinates: s = f X / Z, t = f h / Z (pixel-sized cells at every distance, as a painted road).
TEST(PlaneTriangulation, GroundPlaneComesBackWithinOnePercentAndAtVehicleHeightZero) {
  const double height_m = 1.5, wall_m = 30.0;
  const SurfaceAt scene = [&](double u, double v, double camera_x_m, double& s, double& t) {
    const double below = v - kV0Px;
    const double depth_m = below > kFocalPx * height_m / wall_m ? kFocalPx * height_m / below : wall_m;
    const double x_m = (u - kU0Px) * depth_m / kFocalPx + camera_x_m;
    s = x_m * kFocalPx / depth_m;
    t = depth_m < wall_m ? kFocalPx * height_m / depth_m : 1000.0 + below;
  };
  const Plane left = render_view(scene, 0.0), right = render_view(scene, kBaselineM);
  DisparityEngine engine(kWidth, kHeight, DisparityParameters{});
  const Plane& disparity = engine.compute(left, right);
  const CameraPoints points = triangulate(disparity, triangulation(engine));
  CameraMount mount;
  mount.position_m = Eigen::Vector3d(0, 0, height_m);
  const CameraToVehicle to_vehicle(mount);

  // Rows at least 60 below the principal point: the ground from 1.5 m / tan to 17.5 m (d >= 4.8 px).
  std::vector<double> relative_errors, heights_m;
  int ground_pixels = 0;
  for (int v = static_cast<int>(std::ceil(kV0Px + 60)); v < kHeight; ++v) {
    const double true_depth_m = kFocalPx * height_m / (v - kV0Px);
    for (int u = 0; u < kWidth; ++u) {
      ++ground_pixels;
      const int32_t z_mm = points.z_mm.at<int32_t>(u, v);
      if (z_mm == kernels::kNoPointMm) continue;
      relative_errors.push_back(1e-3 * z_mm / true_depth_m - 1.0);
      const Eigen::Vector3d camera_m(1e-3 * points.x_mm.at<int32_t>(u, v), 1e-3 * points.y_mm.at<int32_t>(u, v), 1e-3 * z_mm);
      heights_m.push_back(to_vehicle.apply(camera_m).z());
    }
  }
  const double density = static_cast<double>(relative_errors.size()) / ground_pixels;
  std::vector<double> absolute_errors(relative_errors.size());
  std::transform(relative_errors.begin(), relative_errors.end(), absolute_errors.begin(), [](double e) { return std::abs(e); });
  const double median_error = median(relative_errors), median_height_m = median(heights_m);
  std::printf("ground plane 1.5 m below the camera, %.1f .. 17.5 m: median relative z error %+.3f %%, median |error| "
              "%.3f %%, density %.1f %%, median vehicle z %+.1f mm\n",
              kFocalPx * height_m / (kHeight - 1 - kV0Px), 100 * median_error, 100 * median(absolute_errors), 100 * density,
              1e3 * median_height_m);
  EXPECT_LT(std::abs(median_error), 0.01);
  EXPECT_LT(median(absolute_errors), 0.015);
  EXPECT_GT(density, 0.90);
  EXPECT_LT(std::abs(median_height_m), 0.01 * height_m);
}

}  // namespace
}  // namespace lpstereo::arm
