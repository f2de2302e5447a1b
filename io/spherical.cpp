#include "io/spherical.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lpstereo::io {

namespace {

constexpr double kPi = 3.14159265358979323846;

// OpenCV's radial-tangential distortion on a normalised plane (cv::projectPoints; Mei eq. 2.12 and
// 2.14 with k5 in the place of OpenCV's k3): coefficients k1 k2 p1 p2 k3.
std::array<double, 2> distort_radtan(const std::array<double, 5>& k, double x, double y) {
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  return {x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x), y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y};
}

// The undistorted point whose distortion is (xd, yd): Gauss-Newton with a forward-difference
// Jacobian from the distorted point as first guess; nullopt when it does not converge to 1e-10.
std::optional<std::array<double, 2>> undistort_radtan(const std::array<double, 5>& k, double xd, double yd) {
  double x = xd, y = yd;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const auto [fx, fy] = distort_radtan(k, x, y);
    const double ex = fx - xd, ey = fy - yd;
    if (std::hypot(ex, ey) < 1e-12) return std::array<double, 2>{x, y};
    const double h = 1e-7 * std::max(1.0, std::hypot(x, y));
    const auto [ax, ay] = distort_radtan(k, x + h, y);
    const auto [bx, by] = distort_radtan(k, x, y + h);
    const double j00 = (ax - fx) / h, j10 = (ay - fy) / h, j01 = (bx - fx) / h, j11 = (by - fy) / h;
    const double determinant = j00 * j11 - j01 * j10;
    if (!(std::abs(determinant) > 1e-12)) return std::nullopt;
    x -= (j11 * ex - j01 * ey) / determinant;
    y -= (-j10 * ex + j00 * ey) / determinant;
    if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
  }
  const auto [fx, fy] = distort_radtan(k, x, y);
  if (std::hypot(fx - xd, fy - yd) < 1e-10) return std::array<double, 2>{x, y};
  return std::nullopt;
}

// Equidistant: theta_d as a function of theta, and its derivative.
double theta_distorted(const std::array<double, 5>& k, double theta) {
  const double t2 = theta * theta;
  return theta * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}

double theta_distorted_slope(const std::array<double, 5>& k, double theta) {
  const double t2 = theta * theta;
  return 1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
}

Vector3 normalised(const Vector3& v) {
  const double length = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / length, v[1] / length, v[2] / length};
}

}  // namespace

double max_incidence_rad(const CameraModel& camera) {
  switch (camera.lens) {
    case LensModel::pinhole:
      return kPi / 2;
    case LensModel::equidistant: {
      // First turning point of theta_d on a 0.001 rad grid (the polynomial is smooth; the grid only
      // brackets the limit, a few thousandths of a radian inside it).
      for (double theta = 0.001; theta <= kPi; theta += 0.001) {
        if (!(theta_distorted_slope(camera.distortion, theta) > 0)) return theta - 0.001;
      }
      return kPi;
    }
    case LensModel::mei:
      if (!(camera.xi > 0)) return kPi / 2;
      return std::acos(-std::min(camera.xi, 1 / camera.xi));
  }
  return kPi / 2;
}

std::optional<Pixel> project_ray(const CameraModel& camera, const Vector3& ray) {
  return project_ray(camera, ray, max_incidence_rad(camera));
}

std::optional<Pixel> project_ray(const CameraModel& camera, const Vector3& ray, double limit_rad) {
  const double length = std::sqrt(ray[0] * ray[0] + ray[1] * ray[1] + ray[2] * ray[2]);
  if (!(length > 0) || !std::isfinite(length)) return std::nullopt;
  const Vector3 unit = {ray[0] / length, ray[1] / length, ray[2] / length};
  const double incidence_rad = std::atan2(std::hypot(unit[0], unit[1]), unit[2]);
  if (!(incidence_rad < limit_rad)) return std::nullopt;
  std::array<double, 2> distorted{};
  switch (camera.lens) {
    case LensModel::pinhole:
      distorted = distort_radtan(camera.distortion, unit[0] / unit[2], unit[1] / unit[2]);
      break;
    case LensModel::equidistant: {
      const double r = std::hypot(unit[0], unit[1]);
      const double theta_d = theta_distorted(camera.distortion, incidence_rad);
      distorted = r > 0 ? std::array<double, 2>{theta_d * unit[0] / r, theta_d * unit[1] / r} : std::array<double, 2>{0, 0};
      break;
    }
    case LensModel::mei: {
      // Eq. 2.6-2.7: seen from the centre shifted by xi; Z_s + xi > 0 inside the limit.
      const double denominator = unit[2] + camera.xi;
      distorted = distort_radtan(camera.distortion, unit[0] / denominator, unit[1] / denominator);
      break;
    }
  }
  const Pixel pixel = {camera.fx_px * distorted[0] + camera.cx_px, camera.fy_px * distorted[1] + camera.cy_px};
  if (!std::isfinite(pixel[0]) || !std::isfinite(pixel[1])) return std::nullopt;
  return pixel;
}

std::optional<Vector3> unproject_pixel(const CameraModel& camera, double x_px, double y_px) {
  const double xd = (x_px - camera.cx_px) / camera.fx_px;
  const double yd = (y_px - camera.cy_px) / camera.fy_px;
  switch (camera.lens) {
    case LensModel::pinhole: {
      const auto undistorted = undistort_radtan(camera.distortion, xd, yd);
      if (!undistorted) return std::nullopt;
      return normalised({(*undistorted)[0], (*undistorted)[1], 1});
    }
    case LensModel::equidistant: {
      const double theta_d = std::hypot(xd, yd);
      if (theta_d == 0) return Vector3{0, 0, 1};
      const double limit = max_incidence_rad(camera);
      if (!(theta_d < theta_distorted(camera.distortion, limit))) return std::nullopt;
      // theta_d(theta) increases on [0, limit]: Newton from theta = theta_d, kept inside it.
      double theta = std::min(theta_d, limit);
      for (int iteration = 0; iteration < 50; ++iteration) {
        const double step = (theta_distorted(camera.distortion, theta) - theta_d) / theta_distorted_slope(camera.distortion, theta);
        theta = std::clamp(theta - step, 0.0, limit);
        if (std::abs(step) < 1e-14) break;
      }
      if (!(std::abs(theta_distorted(camera.distortion, theta) - theta_d) < 1e-10)) return std::nullopt;
      const double s = std::sin(theta) / theta_d;
      return Vector3{s * xd, s * yd, std::cos(theta)};
    }
    case LensModel::mei: {
      const auto undistorted = undistort_radtan(camera.distortion, xd, yd);
      if (!undistorted) return std::nullopt;
      const auto [x, y] = *undistorted;
      // Eq. 2.11: the point of the unit sphere whose shifted projection is m_u = (x, y).
      const double r2 = x * x + y * y;
      const double discriminant = 1 + (1 - camera.xi * camera.xi) * r2;
      if (discriminant < 0) return std::nullopt;  // beyond the rim of the image of the sphere (xi > 1)
      const double factor = (camera.xi + std::sqrt(discriminant)) / (r2 + 1);
      const Vector3 unit = {factor * x, factor * y, factor - camera.xi};
      if (!(std::atan2(std::hypot(unit[0], unit[1]), unit[2]) < max_incidence_rad(camera) + 1e-9)) return std::nullopt;
      return unit;
    }
  }
  return std::nullopt;
}

double spherical_range_m(double baseline_m, double theta_left_rad, double disparity_rad) {
  if (disparity_rad == 0) return std::numeric_limits<double>::infinity();
  if (!(disparity_rad > 0) || !(disparity_rad < theta_left_rad) || !(theta_left_rad < kPi)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return baseline_m * std::sin(theta_left_rad - disparity_rad) / std::sin(disparity_rad);  // thesis eq. 2.34
}

}  // namespace lpstereo::io
