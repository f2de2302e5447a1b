// Stereo rectification maps from a calibration (io/calibration.h), in floating point with OpenCV's
// calib3d, then quantised to the remap kernel's fixed-point table (remap_q5, dag/remap_table.h).
//
//   already rectified (KITTI, Middlebury, ...)    identity maps
//   the file has R1 R2 P1 P2                       cv::initUndistortRectifyMap with them
//   otherwise, pinhole (k1 k2 p1 p2 k3)            cv::stereoRectify (CALIB_ZERO_DISPARITY, alpha 0:
//                                                  every output pixel comes from inside the source)
//   otherwise, equidistant                         cv::fisheye::stereoRectify (balance 0)
//
// The rectified views share the focal length, cy and (CALIB_ZERO_DISPARITY) cx; the right camera
// sits baseline_m along +x of the left one, so disparity d = x_left - x_right = f B / Z.
//
// Refused with a CalibrationError (one line): an image size that differs from the calibration's, a
// rectification under which less than half of a view's output pixels come from inside its source
// image (a calibration for another camera or size), and a map the Q10.5 table cannot hold.
//
// Latitude-longitude rectification (compute_latlong_maps; thesis 003 §2.3.2, eq. 2.17-2.22, after
// [68]) for wide and fisheye lenses of any model in io/spherical.h, where a pinhole rectification
// would stretch the periphery without bound. Both cameras are rotated so that the baseline is the
// x axis (the epipoles are the poles); each output row is one epipolar plane (a meridian, the planes
// turning about the baseline) and each output column one angle within that plane:
//   rectified frame   x = baseline direction (left centre to right centre), z = the mean of the two
//                     optical axes made orthogonal to x, y = z cross x (down); R1, R2 rotate each
//                     camera's frame into it, as stereoRectify's R1, R2 do.
//   output pixel      psi = (column - cx) / f, the angle within the epipolar plane from the forward
//   (column, row)     direction towards +x (+-90 degrees are the epipoles); beta = (row - cy) / f,
//                     the plane's angle about the baseline (0 contains z, positive downwards);
//                     ray = (sin psi, cos psi sin beta, cos psi cos beta), on the unit sphere.
//   scale             f = width / hfov_rad pixels per radian on both axes, cx = (width - 1) / 2,
//                     cy = (height - 1) / 2: the columns span hfov, the rows span height / f.
//   disparity         a point seen by both cameras lies in one epipolar plane, so on one row in both
//                     views, and column_left - column_right = f (psi_left - psi_right) = f d with d
//                     the spherical disparity (thesis eq. 2.24); psi_left = theta_left - pi / 2 in
//                     the angles of io/spherical.h, so range = spherical_range_m(b, pi / 2 + psi, d).
// Refused besides: hfov outside (0, 180] degrees or rows spanning more than 180 degrees (a meridian
// runs from pole to pole), and an output ray at or beyond a camera model's limit
// (max_incidence_rad: beyond it the lens model has no image).
#pragma once

#include <optional>

#include <opencv2/core.hpp>

#include "dag/graph.h"
#include "dag/plane.h"
#include "io/calibration.h"

namespace lpstereo::io {

enum class RectifiedProjection {
  pinhole,  // rows are epipolar lines of a pinhole image; d = x_left - x_right = f B / Z
  latlong,  // rows are epipolar planes, columns angles within them (see above)
};

struct RectifiedGeometry {
  RectifiedProjection projection = RectifiedProjection::pinhole;
  double focal_px = 0;             // rectified focal length (fx = fy), pixels; latlong: pixels per radian
  double cx_left_px = 0;           // principal point of the rectified left view
  double cx_right_px = 0;          // ... of the right view (same as left unless the file says so)
  double cy_px = 0;
  double baseline_m = 0;
  // The rotations from each camera's frame to the rectified one (X_rect = r1 X_left,
  // X_rect_right = r2 X_right), as stereoRectify's R1 and R2; identity for rectified files.
  Matrix3 r1 = kIdentity3, r2 = kIdentity3;
};

struct RectificationMaps {
  int width = 0, height = 0;     // output size, pixels (the source size, except for latlong)
  cv::Mat left_x, left_y;        // CV_32FC1 absolute source coordinates, as cv::remap takes them
  cv::Mat right_x, right_y;
  RectifiedGeometry geometry;
  double left_inside = 1;        // share of output pixels whose source lies inside the source image
  double right_inside = 1;
};

// width x height: the size of the images (the calibration's, when it names one, must match).
RectificationMaps compute_rectification_maps(const StereoCalibration& calibration, int width, int height);

struct LatLongOptions {
  double hfov_rad = 3.14159265358979323846;  // the angle each row spans, (0, pi]; pi = epipole to epipole
  int width = 0;                             // output size, pixels; 0 = the source image's
  int height = 0;
};

// Latitude-longitude maps of a pair whose images are width x height (see the top of this file).
RectificationMaps compute_latlong_maps(const StereoCalibration& calibration, int width, int height, const LatLongOptions& options);

// The range (distance from the left camera centre, metres) of a lat-long rectified left pixel in
// column column_left_px with disparity disparity_px (column_left - column_right): thesis eq. 2.34
// through spherical_range_m, with theta_left = pi / 2 + (column_left - cx) / f and d = disparity / f.
double latlong_range_m(const RectifiedGeometry& geometry, double column_left_px, double disparity_px);

// A float map (CV_32FC1 x and y) as the kernel's remap_q5 table. Throws CalibrationError naming
// the view when a displacement does not fit Q10.5.
Plane rectification_table(const cv::Mat& map_x, const cv::Mat& map_y, const std::string& view);

// Registers the constant generator "calibration_rectification" (remap_q5): params
//   {"calibration": "FILE" or ["FILE1", "FILE2"], "view": "left" | "right"}
// builds the view's rectification table from the calibration at the graph's frame size; with
//   "model": "latlong", "hfov_deg": DEG, "width": W, "height": H (0 = frame size)
// the lat-long table (W x H, the remap output's size) instead.
void register_calibration_rectification_generator();

// The graph that rectifies a pair through the remap_bilinear kernel with calibration_rectification
// tables: inputs "left" and "right" (u8), outputs "left_rectified" and "right_rectified"; lat-long
// tables when `latlong` is given.
GraphSpec rectification_graph_spec(const std::vector<std::string>& calibration_files,
                                   const std::optional<LatLongOptions>& latlong = std::nullopt);

}  // namespace lpstereo::io
