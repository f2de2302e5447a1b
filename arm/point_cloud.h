// Disparity to 3D on the ARM side: the disparity_to_points kernel run over a disparity map, the
// camera-to-vehicle transform, and point clouds in PLY (docs/geometry.md "Disparity to 3D").
//
// Frames (all right-handed, metres):
//   camera (optical) frame   x right, y down, z forward, origin at the left camera's centre
//                            (DESIGN.md §4; what the kernel outputs, in millimetres);
//   vehicle frame            x forward, y left, z up (ISO 8855, ROS REP 103 "base_link").
// A camera mounted level and looking forward sees the vehicle's x along its z, the vehicle's y
// along its -x and the vehicle's z along its -y: the fixed axis change C (optical_to_body()). The
// mount's angles then rotate that level camera within the vehicle frame:
//   p_vehicle = R C p_camera + T,   R = Rz(yaw) Ry(pitch) Rx(roll)
// (intrinsic z-y'-x'' Tait-Bryan angles, roll applied first: ISO 8855 / aerospace yaw-pitch-roll,
// the same product as ROS tf's setRPY and Eigen's AngleAxis chain). Right-hand rule about the
// vehicle axes: positive roll lowers the right side (+x forward), positive pitch lowers the nose
// (a camera looking 5 degrees down has pitch_rad = +0.0873), positive yaw turns left. T is the
// camera centre in the vehicle frame (a camera 1.5 m above the ground origin: T = (0, 0, 1.5)).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dag/plane.h"
#include "dag/tile_executor.h"

namespace lpstereo::arm {

// The kernel's parameters, from a rectified calibration: baseline and focal length of the
// rectified pair, principal point of the rectified left view, and the matcher's disparity range
// (min_disparity sets the invalid marker, DESIGN.md §4).
struct TriangulationParameters {
  double baseline_m = 0;
  double focal_px = 0;
  double u0_px = 0;
  double v0_px = 0;
  int min_disparity = 0;
  int num_disparities = 64;
  double disparity_offset_px = 0;  // Middlebury doffs: Z = f B / (d + doffs); 0 for every other source
};

// The kernel's three planes: s32 millimetres, kernels::kNoPointMm where there is no point.
struct CameraPoints {
  Plane x_mm, y_mm, z_mm;
};

// Runs disparity_to_points over an s16 Q4 disparity map. Throws KernelError for parameters out of
// the kernel's range (message names the parameter, the expected range and the value).
CameraPoints triangulate(const Plane& disparity_q4, const TriangulationParameters& parameters,
                         KernelBackend backend = KernelBackend::native);

// Rx(roll), Ry(pitch), Rz(yaw) multiplied as Rz * Ry * Rx.
Eigen::Matrix3d rotation_zyx(double roll_rad, double pitch_rad, double yaw_rad);
// C: optical frame (x right, y down, z forward) -> level body frame (x forward, y left, z up).
Eigen::Matrix3d optical_to_body();

struct CameraMount {
  double roll_rad = 0;
  double pitch_rad = 0;
  double yaw_rad = 0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // T: camera centre in the vehicle frame
};

class CameraToVehicle {
 public:
  explicit CameraToVehicle(const CameraMount& mount);
  Eigen::Vector3d apply(const Eigen::Vector3d& camera_m) const { return rotation_ * camera_m + translation_m_; }
  const Eigen::Matrix3d& rotation() const { return rotation_; }  // R C
  const Eigen::Vector3d& translation_m() const { return translation_m_; }
  // The same transform as an isometry (the obstacle methods' vehicle_from_camera).
  Eigen::Isometry3d vehicle_from_camera() const {
    Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
    transform.linear() = rotation_;
    transform.translation() = translation_m_;
    return transform;
  }

 private:
  Eigen::Matrix3d rotation_;
  Eigen::Vector3d translation_m_;
};

// The left image, for point colours: 1 channel (grey) or 3 (R, G, B in that byte order).
struct ColourImageView {
  const uint8_t* data = nullptr;
  ptrdiff_t stride_bytes = 0;
  int width = 0;
  int height = 0;
  int channels = 1;
};
ColourImageView grey_view(const Plane& grey_u8);

struct CloudPoint {
  float x_m = 0, y_m = 0, z_m = 0;
  uint8_t red = 0, green = 0, blue = 0;
  bool operator==(const CloudPoint&) const = default;
};

struct PointCloud {
  std::vector<CloudPoint> points;
  std::string frame;  // "camera" (x right, y down, z forward) or "vehicle" (x forward, y left, z up)
};

// The valid points of `points` in row order, in metres, each with the colour of its pixel in
// `colours` (same size as the planes), in the camera frame or through `to_vehicle` when given.
// Throws std::invalid_argument naming the plane and both sizes when sizes differ.
PointCloud collect_points(const CameraPoints& points, const ColourImageView& colours,
                          const CameraToVehicle* to_vehicle = nullptr);

enum class PlyEncoding { binary_little_endian, ascii };

// The PLY file (Turk's format as meshlab, CloudCompare, Open3D and PCL read it): vertex elements of
// float x, y, z (metres) and uchar red, green, blue; a comment names the frame.
std::string ply_bytes(const PointCloud& cloud, PlyEncoding encoding);
// Writes ply_bytes atomically (dag/atomic_file.h): a failure leaves no file. Throws FileWriteError.
void write_ply(const std::string& path, const PointCloud& cloud, PlyEncoding encoding);

}  // namespace lpstereo::arm
