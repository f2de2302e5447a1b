// Lens models as pixel <-> unit-sphere maps (io/spherical.h): Mei's unified model against
// cv::omnidir (when Debian's opencv_contrib is there) and against its closed form, the equidistant
// and pinhole models against cv::fisheye / cv::projectPoints, round trips at many angles (past
// 90 degrees where the model allows), the models' limits, and spherical disparity to range (thesis
// 003 eq. 2.34) against the geometry of known points.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <opencv2/calib3d.hpp>
#if LPSTEREO_TEST_WITH_OMNIDIR
#include <opencv2/ccalib/omnidir.hpp>
#endif

#include "io/calibration.h"
#include "io/spherical.h"

namespace lpstereo::io {
namespace {

constexpr double kPi = 3.14159265358979323846;

CameraModel mei(double xi, std::array<double, 5> distortion = {-0.08, 0.012, 0.0008, -0.0006, 0}) {
  CameraModel camera;
  camera.lens = LensModel::mei;
  camera.width_px = 640;
  camera.height_px = 480;
  camera.fx_px = 300 * (1 + xi);  // generalised focal lengths grow with xi for the same lens
  camera.fy_px = 301 * (1 + xi);
  camera.cx_px = 322.5;
  camera.cy_px = 238.25;
  camera.distortion = distortion;
  camera.xi = xi;
  return camera;
}

CameraModel equidistant() {  // fisheye_mynteye's left camera (SOURCE.md)
  return {752, 480, 366.163, 365.631, 380.573, 225.950, LensModel::equidistant, {-0.020476443, -0.007108226, 0.002180580, -0.001192386, 0}};
}

CameraModel pinhole() { return {640, 480, 420, 421, 320, 240, LensModel::pinhole, {-0.2, 0.05, 0.001, -0.001, 0.002}}; }

// A ray at `incidence` from the optical axis, turned `azimuth` about it.
Vector3 ray_at(double incidence_rad, double azimuth_rad) {
  return {std::sin(incidence_rad) * std::cos(azimuth_rad), std::sin(incidence_rad) * std::sin(azimuth_rad), std::cos(incidence_rad)};
}

double angle_between(const Vector3& a, const Vector3& b) {
  const double cross = std::hypot(a[1] * b[2] - a[2] * b[1], std::hypot(a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]));
  return std::atan2(cross, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
}

// Mei's projection written out from the thesis' equations for one ray, without distortion:
// m_u = (X_s / (Z_s + xi), Y_s / (Z_s + xi)) (eq. 2.7), p = (gamma1 x + u0, gamma2 y + v0) (eq. 2.10).
TEST(Spherical, MeiWithoutDistortionIsTheClosedForm) {
  for (double xi : {0.0, 0.4, 1.0, 1.7}) {
    const CameraModel camera = mei(xi, {});
    for (double incidence_deg : {0.0, 10.0, 45.0, 80.0, 95.0, 110.0}) {
      const double incidence = incidence_deg * kPi / 180;
      if (incidence >= max_incidence_rad(camera)) continue;
      const Vector3 ray = ray_at(incidence, 0.7);
      const double denominator = ray[2] + xi;
      const auto pixel = project_ray(camera, {2 * ray[0], 2 * ray[1], 2 * ray[2]});  // any length
      ASSERT_TRUE(pixel) << "xi " << xi << ", " << incidence_deg << " deg";
      EXPECT_NEAR((*pixel)[0], camera.fx_px * ray[0] / denominator + camera.cx_px, 1e-9);
      EXPECT_NEAR((*pixel)[1], camera.fy_px * ray[1] / denominator + camera.cy_px, 1e-9);
    }
  }
}

// Pixel -> sphere -> pixel and sphere -> pixel -> sphere at many angles up to just inside each
// model's limit (past 90 degrees for mei with xi > 0 and for equidistant).
TEST(Spherical, RoundTripsAtManyAngles) {
  const std::vector<CameraModel> cameras = {mei(0.0), mei(0.6), mei(1.0), mei(1.6), mei(0.9, {-0.05, 0.01, 0.001, 0.0005, -0.001}),
                                            equidistant(), pinhole()};
  for (const CameraModel& camera : cameras) {
    const double limit = max_incidence_rad(camera);
    // Mei's distortion acts on the shifted plane, whose radius grows without bound toward the
    // limit for xi <= 1; the round trip is asked for up to 0.9 of the limit and 100 degrees.
    const double widest = std::min(0.9 * limit, 100 * kPi / 180);
    int checked = 0;
    for (double incidence = 0; incidence <= widest; incidence += widest / 40) {
      for (double azimuth = -kPi; azimuth < kPi; azimuth += kPi / 7) {
        const Vector3 ray = ray_at(incidence, azimuth);
        const auto pixel = project_ray(camera, ray);
        ASSERT_TRUE(pixel) << lens_name(camera.lens) << " xi " << camera.xi << " at " << incidence * 180 / kPi << " deg";
        const auto back = unproject_pixel(camera, (*pixel)[0], (*pixel)[1]);
        ASSERT_TRUE(back) << lens_name(camera.lens) << " xi " << camera.xi << " at " << incidence * 180 / kPi << " deg";
        EXPECT_LT(angle_between(ray, *back), 1e-9) << lens_name(camera.lens) << " xi " << camera.xi << " at "
                                                   << incidence * 180 / kPi << " deg";
        EXPECT_NEAR(std::hypot((*back)[0], std::hypot((*back)[1], (*back)[2])), 1.0, 1e-12);
        ++checked;
      }
    }
    EXPECT_GT(checked, 500);
  }
  // Pixels all over a Mei image (xi < 1: every pixel has a ray) come back to themselves.
  const CameraModel camera = mei(0.8);
  for (int y = 0; y < camera.height_px; y += 37) {
    for (int x = 0; x < camera.width_px; x += 41) {
      const auto ray = unproject_pixel(camera, x, y);
      ASSERT_TRUE(ray) << x << ", " << y;
      const auto pixel = project_ray(camera, *ray);
      ASSERT_TRUE(pixel);
      EXPECT_NEAR((*pixel)[0], x, 1e-7);
      EXPECT_NEAR((*pixel)[1], y, 1e-7);
    }
  }
}

TEST(Spherical, LimitsOfTheModels) {
  EXPECT_DOUBLE_EQ(max_incidence_rad(pinhole()), kPi / 2);
  EXPECT_NEAR(max_incidence_rad(mei(0.5)), 2 * kPi / 3, 1e-12);  // cos = -xi
  EXPECT_NEAR(max_incidence_rad(mei(2.0)), 2 * kPi / 3, 1e-12);  // cos = -1 / xi: the image folds
  EXPECT_NEAR(max_incidence_rad(mei(1.0)), kPi, 1e-12);
  EXPECT_NEAR(max_incidence_rad(mei(0.0)), kPi / 2, 1e-12);
  // Equidistant: where theta_d stops increasing (the MyntEye's polynomial turns near 102 degrees).
  const CameraModel fisheye = equidistant();
  const double limit = max_incidence_rad(fisheye);
  EXPECT_GT(limit, 1.6);
  EXPECT_LT(limit, 1.9);
  auto theta_d = [&](double theta) {
    const auto& k = fisheye.distortion;
    const double t2 = theta * theta;
    return theta * (1 + k[0] * t2 + k[1] * t2 * t2 + k[2] * t2 * t2 * t2 + k[3] * t2 * t2 * t2 * t2);
  };
  EXPECT_GT(theta_d(limit), theta_d(limit - 0.01));
  EXPECT_GT(theta_d(limit + 0.002), theta_d(limit + 0.02));  // falling past the limit
  // A ray at or past the limit is not imaged; a pixel beyond the rim of a xi > 1 image has no ray.
  EXPECT_FALSE(project_ray(pinhole(), ray_at(kPi / 2, 0)));
  EXPECT_FALSE(project_ray(mei(0.5), ray_at(2 * kPi / 3 + 0.01, 1)));
  EXPECT_TRUE(project_ray(mei(0.5), ray_at(2 * kPi / 3 - 0.05, 1)));
  const CameraModel folded = mei(2.0, {});
  // The rim: r = sin(theta) / (cos(theta) + xi) at cos(theta) = -1 / xi is 1 / sqrt(xi^2 - 1).
  const double rim_px = folded.fx_px / std::sqrt(3.0);
  EXPECT_TRUE(unproject_pixel(folded, folded.cx_px + 0.99 * rim_px, folded.cy_px));
  EXPECT_FALSE(unproject_pixel(folded, folded.cx_px + 1.01 * rim_px, folded.cy_px));
  EXPECT_FALSE(project_ray(mei(0.5), {0, 0, 0}));
}

TEST(Spherical, EquidistantAndPinholeAgreeWithOpenCv) {
  std::vector<cv::Point3d> points;
  for (double incidence = 0.02; incidence < 1.45; incidence += 0.07) {
    for (double azimuth = -3; azimuth < 3; azimuth += 0.5) {
      const Vector3 ray = ray_at(incidence, azimuth);
      points.emplace_back(3 * ray[0], 3 * ray[1], 3 * ray[2]);
    }
  }
  const CameraModel fisheye = equidistant();
  const cv::Matx33d k_fisheye(fisheye.fx_px, 0, fisheye.cx_px, 0, fisheye.fy_px, fisheye.cy_px, 0, 0, 1);
  std::vector<cv::Point2d> expected;
  cv::fisheye::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k_fisheye,
                             cv::Vec4d(fisheye.distortion[0], fisheye.distortion[1], fisheye.distortion[2], fisheye.distortion[3]));
  for (size_t i = 0; i < points.size(); ++i) {
    const auto pixel = project_ray(fisheye, {points[i].x, points[i].y, points[i].z});
    ASSERT_TRUE(pixel);
    EXPECT_NEAR((*pixel)[0], expected[i].x, 1e-6) << i;
    EXPECT_NEAR((*pixel)[1], expected[i].y, 1e-6) << i;
  }
  const CameraModel lens = pinhole();
  const cv::Matx33d k_pinhole(lens.fx_px, 0, lens.cx_px, 0, lens.fy_px, lens.cy_px, 0, 0, 1);
  std::vector<cv::Point3d> near_axis;
  for (const cv::Point3d& point : points) {
    if (std::hypot(point.x, point.y) < 0.8 * point.z) near_axis.push_back(point);  // within the polynomial's range
  }
  cv::projectPoints(near_axis, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k_pinhole,
                    cv::Mat(1, 5, CV_64F, const_cast<double*>(lens.distortion.data())), expected);
  for (size_t i = 0; i < near_axis.size(); ++i) {
    const auto pixel = project_ray(lens, {near_axis[i].x, near_axis[i].y, near_axis[i].z});
    ASSERT_TRUE(pixel);
    EXPECT_NEAR((*pixel)[0], expected[i].x, 1e-6) << i;
    EXPECT_NEAR((*pixel)[1], expected[i].y, 1e-6) << i;
  }
}

#if LPSTEREO_TEST_WITH_OMNIDIR
// cv::omnidir (opencv_contrib's ccalib, Mei's model with k1 k2 p1 p2) as the reference: projection
// of rays out to 100 degrees, and its undistortPoints (which returns the ray on the perspective
// plane, X_s / Z_s, after undoing the distortion and lifting to the sphere) against our unprojection.
TEST(Spherical, MeiAgreesWithCvOmnidir) {
  for (double xi : {0.3, 0.9, 1.4}) {
    const CameraModel camera = mei(xi);
    const cv::Matx33d k(camera.fx_px, 0, camera.cx_px, 0, camera.fy_px, camera.cy_px, 0, 0, 1);
    const cv::Vec4d d(camera.distortion[0], camera.distortion[1], camera.distortion[2], camera.distortion[3]);
    std::vector<cv::Vec3d> points;
    const double widest = std::min(0.9 * max_incidence_rad(camera), 100 * kPi / 180);
    for (double incidence = 0.01; incidence < widest; incidence += widest / 25) {
      for (double azimuth = -3; azimuth < 3; azimuth += 0.4) {
        const Vector3 ray = ray_at(incidence, azimuth);
        points.emplace_back(5 * ray[0], 5 * ray[1], 5 * ray[2]);
      }
    }
    std::vector<cv::Vec2d> expected;
    cv::omnidir::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, xi, d);
    std::vector<cv::Vec2d> undistorted;
    int compared = 0;
    cv::omnidir::undistortPoints(expected, undistorted, k, d, cv::Matx<double, 1, 1>(xi), cv::Matx33d::eye());
    for (size_t i = 0; i < points.size(); ++i) {
      const auto pixel = project_ray(camera, {points[i][0], points[i][1], points[i][2]});
      ASSERT_TRUE(pixel);
      EXPECT_NEAR((*pixel)[0], expected[i][0], 1e-6) << "xi " << xi << " point " << i;
      EXPECT_NEAR((*pixel)[1], expected[i][1], 1e-6) << "xi " << xi << " point " << i;
      const auto ray = unproject_pixel(camera, expected[i][0], expected[i][1]);
      ASSERT_TRUE(ray);
      if ((*ray)[2] < 0.2) continue;  // the perspective plane holds rays in front only
      // omnidir's undistortion is a 20-step fixed-point iteration: agreement to 1e-6 on the plane.
      EXPECT_NEAR((*ray)[0] / (*ray)[2], undistorted[i][0], 1e-6) << "xi " << xi << " point " << i;
      EXPECT_NEAR((*ray)[1] / (*ray)[2], undistorted[i][1], 1e-6) << "xi " << xi << " point " << i;
      ++compared;
    }
    EXPECT_GT(compared, 200) << "xi " << xi;
  }
}
#endif

// Known points in the epipolar plane: left centre at the origin, right centre at (b, 0, 0); theta is
// measured from the -x direction (away from the right camera), so theta_left > theta_right.
TEST(Spherical, SphericalDisparityGivesTheRangeOfKnownPoints) {
  const double baseline_m = 0.12;
  for (const auto& [x, z] : std::vector<std::pair<double, double>>{{0.06, 2.0}, {-1.5, 0.7}, {3.0, 0.4}, {0.5, 30.0}, {-0.2, -0.9}}) {
    const double theta_left = std::atan2(z, -x);
    const double theta_right = std::atan2(z, -(x - baseline_m));
    const double disparity = theta_left - theta_right;
    const double range = spherical_range_m(baseline_m, std::abs(theta_left), std::abs(disparity));
    EXPECT_NEAR(range, std::hypot(x, z), 1e-9 * std::hypot(x, z)) << x << ", " << z;
  }
  EXPECT_TRUE(std::isinf(spherical_range_m(0.12, 1.0, 0.0)));
  EXPECT_TRUE(std::isnan(spherical_range_m(0.12, 1.0, -0.01)));
  EXPECT_TRUE(std::isnan(spherical_range_m(0.12, 0.5, 0.6)));  // the rays diverge: no triangle
}

}  // namespace
}  // namespace lpstereo::io
