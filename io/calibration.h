// Stereo calibration: one internal type in SI units, the loaders for the files users arrive with,
// and a writer for OpenCV YAML (DESIGN.md §4).
//
// Conventions (OpenCV calib3d's, which ROS, KITTI and Middlebury files are converted to):
//   - camera frame: x right, y down, z forward, metres;
//   - the extrinsics map the left camera frame into the right one: X_right = R X_left + T, so a
//     right camera B metres to the right of the left one has T = (-B, 0, 0);
//   - intrinsics in pixels, principal point in pixel coordinates (pixel centres at integers);
//   - pinhole lens distortion in OpenCV's order (k1, k2, p1, p2, k3); equidistant (fisheye)
//     distortion as cv::fisheye and Kalibr's "equidistant": theta_d = theta (1 + k1 theta^2 +
//     k2 theta^4 + k3 theta^6 + k4 theta^8); Mei's unified (omnidirectional) model as cv::omnidir,
//     Kalibr's "omni" and Mei's toolbox: xi, then radial-tangential distortion on the plane of
//     the shifted projection (k1, k2, p1, p2, k5), see io/spherical.h.
//
// Loaders (load_stereo_calibration picks one by the file's content, never by its name):
//   OpenCV FileStorage, YAML or XML  M1 D1 M2 D2 (intrinsics) and R T (extrinsics), optionally
//                                    R1 R2 P1 P2 Q and image_width/image_height; one file or the
//                                    intrinsics + extrinsics pair of OpenCV's stereo_calib sample
//   KITTI calib_cam_to_cam.txt       P_rect_02, P_rect_03 (and S_rect_02 for the image size)
//   KITTI object calib               P2, P3 ("P2: ..." lines)
//   KITTI odometry calib             P0, P1 ("P0: ..." lines, or two bare lines of 12 numbers)
//   Middlebury calib.txt             cam0, cam1, doffs, baseline (mm), width, height, ndisp
//   ROS camera_info YAML pair        left and right files (camera_matrix, distortion_model,
//                                    distortion_coefficients, rectification_matrix,
//                                    projection_matrix, image_width, image_height)
//   Kalibr/Kimera sensor YAML pair   left and right files (camera_model pinhole: intrinsics
//                                    [fu fv cu cv]; camera_model omni: [xi gamma1 gamma2 cu cv];
//                                    distortion_model radtan|equidistant|none, resolution, T_BS)
//   OpenCV omnidir stereo file       camera_matrix_1 distortion_coefficients_1 xi_1, ..._2, and
//                                    extrinsic_parameters (rvec, tvec), as opencv_contrib's
//                                    omni_stereo_calibration sample writes it; or M1 D1 M2 D2 R T
//                                    with lens_model: mei and xi1, xi2 (what write_opencv_yaml writes)
// KITTI and Middlebury describe rectified views: already_rectified is set, and the baseline comes
// from the projection matrices (KITTI: B = -(P_right[0,3] - P_left[0,3]) / P_right[0,0]).
//
// Every loader validates what it read (validate_calibration) and refuses an inconsistent file with
// a CalibrationError whose what() is one line naming the file and what is wrong.
#pragma once

#include <array>
#include <optional>
#include <stdexcept>
#include <string>

namespace lpstereo::io {

class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

using Matrix3 = std::array<double, 9>;    // row-major 3x3
using Matrix34 = std::array<double, 12>;  // row-major 3x4
using Matrix4 = std::array<double, 16>;   // row-major 4x4
using Vector3 = std::array<double, 3>;

constexpr Matrix3 kIdentity3 = {1, 0, 0, 0, 1, 0, 0, 0, 1};

enum class LensModel {
  pinhole,      // radial-tangential distortion (OpenCV plumb_bob / Kalibr radtan): k1 k2 p1 p2 k3
  equidistant,  // cv::fisheye / Kalibr equidistant / Kannala-Brandt: k1 k2 k3 k4
  mei,          // Mei's unified model (cv::omnidir, Kalibr omni): xi, then k1 k2 p1 p2 k5 radtan
};

// "pinhole", "equidistant", "mei": for messages.
const char* lens_name(LensModel lens);

struct CameraModel {
  int width_px = 0;   // image size the intrinsics belong to; 0 = the file did not say
  int height_px = 0;
  double fx_px = 0;   // focal lengths, pixels (> 0); for mei the generalised focal lengths
  double fy_px = 0;   // gamma1, gamma2 of Mei's model (focal length times the mirror/lens factor)
  double cx_px = 0;   // principal point, pixels
  double cy_px = 0;
  LensModel lens = LensModel::pinhole;
  // pinhole: k1 k2 p1 p2 k3 (unitless, on the normalised image plane); equidistant: k1 k2 k3 k4 0;
  // mei: k1 k2 p1 p2 k5 (Mei's toolbox names the sixth-order radial term k5; cv::omnidir has none).
  std::array<double, 5> distortion{};
  // mei only: xi, the distance from the unit sphere's centre to the projection centre (unitless;
  // 0 = pinhole, 1 = parabolic mirror; fisheye lenses calibrate to about 0.5 .. 2).
  double xi = 0;

  bool has_distortion() const;
};

// What OpenCV's stereoRectify gives, when a file carries it: rectifying rotations and the
// projection matrices of the rectified views, and the disparity-to-depth matrix Q.
struct StereoRectification {
  Matrix3 r1 = kIdentity3, r2 = kIdentity3;
  Matrix34 p1{}, p2{};
  Matrix4 q{};
};

struct StereoCalibration {
  CameraModel left, right;
  Matrix3 rotation = kIdentity3;  // R: X_right = R X_left + T
  Vector3 translation_m{};        // T, metres
  // True when the files describe views that are rectified already (KITTI, Middlebury, a ROS pair
  // whose rectification matrices are the identity): rows are epipolar lines, no distortion, and
  // rectification is the identity map.
  bool already_rectified = false;
  std::optional<StereoRectification> rectification;
  // Middlebury doffs: x difference of the principal points of the rectified views (right - left),
  // pixels; depth Z = f B / (d + doffs). 0 for every other source.
  double disparity_offset_px = 0;
  int num_disparities = 0;  // a disparity range the file suggests (Middlebury ndisp); 0 = none
  std::string format;       // "opencv", "opencv_omnidir", "kitti_cam_to_cam", "kitti_object",
                            // "kitti_odometry", "middlebury", "ros_camera_info", "kalibr"
  std::string source;       // the file(s) it was read from

  double baseline_m() const;  // |T|
  // The focal length of the rectified views in pixels: P1(0,0) when the file has a rectification,
  // else the left camera's fx.
  double focal_px() const;
};

// One calibration file (OpenCV stereo file with intrinsics and extrinsics, KITTI, Middlebury).
StereoCalibration load_stereo_calibration(const std::string& path);
// Two files: OpenCV intrinsics + extrinsics (either order), ROS camera_info left + right, or
// Kalibr/Kimera sensor YAML left + right.
StereoCalibration load_stereo_calibration(const std::string& first_path, const std::string& second_path);

// Writes OpenCV FileStorage YAML (M1 D1 M2 D2 R T, R1 R2 P1 P2 Q when present, image_width and
// image_height when known, for equidistant lenses "lens_model: equidistant", for Mei's model
// "lens_model: mei" with xi1 and xi2), atomically.
// load_stereo_calibration reads it back. `comments` lines (e.g. RMS error) go in as YAML comments.
void write_opencv_yaml(const std::string& path, const StereoCalibration& calibration, const std::string& comments = "");

// The checks every loader runs: focal lengths > 0 and finite, finite principal points and
// distortion, xi finite and >= 0 (mei), R orthonormal (|R R^T - I| <= 1e-4 per element) with det +1, T finite and non-zero,
// image sizes non-negative and equal for both views when both are known. Throws CalibrationError
// "<source>: <what is wrong>".
void validate_calibration(const StereoCalibration& calibration);

}  // namespace lpstereo::io
