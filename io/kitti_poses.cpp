#include "io/kitti_poses.h"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

#include "dag/atomic_file.h"

namespace lpstereo::io {

std::vector<Eigen::Isometry3d> read_kitti_poses(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw PoseFileError(path + ": cannot open the pose file");
  std::vector<Eigen::Isometry3d> poses;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;  // blank (a trailing newline)
    std::istringstream numbers(line);
    double value[12];
    int count = 0;
    double extra = 0;
    while (count < 12 && numbers >> value[count]) ++count;
    const bool more = static_cast<bool>(numbers >> extra);
    if (count != 12 || more) {
      throw PoseFileError(path + ":" + std::to_string(line_number) + ": expected 12 numbers (a 3x4 pose, row-major), got " +
                          (more ? std::string("more") : std::to_string(count)));
    }
    Eigen::Matrix<double, 3, 4> matrix;
    for (int i = 0; i < 12; ++i) {
      if (!std::isfinite(value[i])) {
        throw PoseFileError(path + ":" + std::to_string(line_number) + ": expected finite numbers, got " + std::to_string(value[i]));
      }
      matrix(i / 4, i % 4) = value[i];
    }
    const Eigen::Matrix3d rotation = matrix.leftCols<3>();
    const double orthogonality_error = (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (orthogonality_error > 1e-3 || rotation.determinant() < 0) {
      throw PoseFileError(path + ":" + std::to_string(line_number) + ": expected a rotation in the first 3 columns (R^T R = I, det 1), got |R^T R - I| " +
                          std::to_string(orthogonality_error) + ", det " + std::to_string(rotation.determinant()));
    }
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = rotation;
    pose.translation() = matrix.col(3);
    poses.push_back(pose);
  }
  return poses;
}

void write_kitti_poses(const std::string& path, const std::vector<Eigen::Isometry3d>& poses) {
  std::ostringstream text;
  text << std::setprecision(std::numeric_limits<double>::max_digits10);
  for (const Eigen::Isometry3d& pose : poses) {
    const Eigen::Matrix<double, 3, 4> matrix = pose.matrix().topRows<3>();
    for (int i = 0; i < 12; ++i) text << matrix(i / 4, i % 4) << (i < 11 ? ' ' : '\n');
  }
  write_file_atomically(path, text.str());
}

}  // namespace lpstereo::io
