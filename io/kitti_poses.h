// Trajectories in the KITTI odometry pose format: one line per frame, 12 numbers, the 3x4 matrix
// [R | t] row-major that maps a point from the frame's left-camera coordinates into those of the
// first frame (camera frame: x right, y down, z forward, metres). KITTI's devkit, libviso2 and
// ORB-SLAM2 read and write the same format, so trajectories compare across tools.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace lpstereo::io {

// A file that is missing, has a line without exactly 12 finite numbers, or whose rotation part is
// not a rotation (|R^T R - I| > 1e-3, det R < 0): what() names the file, the line and the problem.
class PoseFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Poses of the frames in order (camera-to-first-frame rigid transforms).
std::vector<Eigen::Isometry3d> read_kitti_poses(const std::string& path);

// Writes atomically (temporary name, then rename: nothing half-written), full double precision.
void write_kitti_poses(const std::string& path, const std::vector<Eigen::Isometry3d>& poses);

}  // namespace lpstereo::io
