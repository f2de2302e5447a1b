// Camera models as maps between pixels and rays on the unit sphere, and spherical stereo range.
//
// One pair of functions serves the three lens models of io/calibration.h, so that the
// latitude-longitude rectification (io/rectification.h) can ask any camera where a ray lands:
//
//   pinhole      (x, y) = (X / Z, Y / Z), then OpenCV's radial-tangential distortion
//                (k1 k2 p1 p2 k3); rays with Z <= 0 are not imaged.
//   equidistant  theta = angle from the optical axis, theta_d = theta (1 + k1 theta^2 + k2 theta^4
//                + k3 theta^6 + k4 theta^8), (x, y) = theta_d (X, Y) / |(X, Y)| (cv::fisheye,
//                Kalibr "equidistant", Kannala-Brandt); defined past 90 degrees.
//   mei          Mei and Rives 2007 (thesis 003 §2.2.1, eq. 2.5-2.14): the ray on the unit sphere
//                X_s = X / |X| (2.5) is seen from a centre shifted by xi along the axis (2.6) and
//                projected, m_u = (X_s / (Z_s + xi), Y_s / (Z_s + xi)) (2.7); then the radial factor
//                L = 1 + k1 rho^2 + k2 rho^4 + k5 rho^6 (2.12) and the tangential terms of p1 p2 (2.14,
//                OpenCV's form) give m_d (2.8). cv::omnidir and Kalibr "omni" are this model without k5.
//   all          pixel = (fx x_d + cx, fy y_d + cy); for mei fx, fy are gamma1, gamma2 (2.10).
//
// The unprojection inverts the distortion by Gauss-Newton on the normalised plane (OpenCV's
// undistortPoints uses a fixed-point iteration; Newton converges on the strong distortion of wide
// lenses too) and then lifts to the sphere: pinhole (x, y, 1) / norm, equidistant by Newton on
// theta_d(theta), mei by eq. 2.11 (the inverse of h).
#pragma once

#include <array>
#include <optional>

#include "io/calibration.h"

namespace lpstereo::io {

using Pixel = std::array<double, 2>;  // x, y in pixels (pixel centres at integers)

// The largest angle between the optical axis and a ray the model images one to one, radians:
//   pinhole      pi / 2 (Z > 0);
//   equidistant  the first theta where theta_d(theta) stops increasing, at most pi;
//   mei          the image of the sphere folds where d r / d theta = 0 with r = sin theta /
//                (cos theta + xi): cos theta = -1 / xi for xi > 1; for xi <= 1 the projection
//                centre must stay behind the point, cos theta > -xi. So arccos(-min(xi, 1 / xi)).
// The distortion polynomial of pinhole and mei is not searched for a turning point.
double max_incidence_rad(const CameraModel& camera);

// The pixel where the ray (camera frame, any positive length) lands, or nullopt when the ray is
// at or beyond max_incidence_rad or the distortion does not give a finite position.
std::optional<Pixel> project_ray(const CameraModel& camera, const Vector3& ray);
// The same with the camera's max_incidence_rad computed once by the caller (a map projects a ray
// per output pixel; the equidistant limit is a search).
std::optional<Pixel> project_ray(const CameraModel& camera, const Vector3& ray, double max_incidence_rad);

// The unit ray of pixel (x_px, y_px), or nullopt when no ray within the model's limit lands there
// (e.g. beyond the rim of a mei image with xi > 1, or where the undistortion does not converge).
std::optional<Vector3> unproject_pixel(const CameraModel& camera, double x_px, double y_px);

// Spherical disparity to range, thesis 003 eq. 2.34 (after Shigang Li): two cameras whose centres
// are baseline_m apart see a point P; in the epipolar plane through P, theta is the angle of a ray
// from the baseline, measured from the direction pointing from the right camera to the left one
// (the left epipole side), so that the disparity d = theta_left - theta_right is positive. The
// distance from the left camera centre to P is (law of sines in the triangle left, right, P)
//   rho_left = b sin(theta_left - d) / sin(d) = b sin(theta_right) / sin(d).
// Returns +infinity for d = 0 (a point at infinity) and NaN for d < 0, d >= theta_left or
// theta_left outside (0, pi) (no triangle).
double spherical_range_m(double baseline_m, double theta_left_rad, double disparity_rad);

}  // namespace lpstereo::io
