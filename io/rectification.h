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
#pragma once

#include <opencv2/core.hpp>

#include "dag/graph.h"
#include "dag/plane.h"
#include "io/calibration.h"

namespace lpstereo::io {

struct RectifiedGeometry {
  double focal_px = 0;             // rectified focal length (fx = fy), pixels
  double cx_left_px = 0;           // principal point of the rectified left view
  double cx_right_px = 0;          // ... of the right view (same as left unless the file says so)
  double cy_px = 0;
  double baseline_m = 0;
};

struct RectificationMaps {
  int width = 0, height = 0;     // output (and source) size, pixels
  cv::Mat left_x, left_y;        // CV_32FC1 absolute source coordinates, as cv::remap takes them
  cv::Mat right_x, right_y;
  RectifiedGeometry geometry;
  double left_inside = 1;        // share of output pixels whose source lies inside the source image
  double right_inside = 1;
};

// width x height: the size of the images (the calibration's, when it names one, must match).
RectificationMaps compute_rectification_maps(const StereoCalibration& calibration, int width, int height);

// A float map (CV_32FC1 x and y) as the kernel's remap_q5 table. Throws CalibrationError naming
// the view when a displacement does not fit Q10.5.
Plane rectification_table(const cv::Mat& map_x, const cv::Mat& map_y, const std::string& view);

// Registers the constant generator "calibration_rectification" (remap_q5): params
//   {"calibration": "FILE" or ["FILE1", "FILE2"], "view": "left" | "right"}
// builds the view's rectification table from the calibration at the graph's frame size.
void register_calibration_rectification_generator();

// The graph that rectifies a pair through the remap_bilinear kernel with calibration_rectification
// tables: inputs "left" and "right" (u8), outputs "left_rectified" and "right_rectified".
GraphSpec rectification_graph_spec(const std::vector<std::string>& calibration_files);

}  // namespace lpstereo::io
