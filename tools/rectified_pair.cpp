#include "tools/rectified_pair.h"

#include "io/calibration.h"
#include "io/image_io.h"
#include "tools/command_error.h"

namespace lpstereo::tools {

io::RectifiedGeometry rectified_geometry(const std::vector<std::string>& calibration_files, int width, int height) {
  if (calibration_files.empty() || calibration_files.size() > 2) {
    throw CommandError(kExitUsage, "--calib: give one calibration file, or two (intrinsics + extrinsics, or left + right)");
  }
  const io::StereoCalibration calibration = calibration_files.size() == 1
                                                ? io::load_stereo_calibration(calibration_files[0])
                                                : io::load_stereo_calibration(calibration_files[0], calibration_files[1]);
  // The geometry of the rectified views, as `lpstereo rectify` made them (and checked against the
  // image size: a calibration for another size is refused here with its own line).
  return io::compute_rectification_maps(calibration, width, height).geometry;
}

RectifiedPair read_rectified_pair(const std::string& left_path, const std::string& right_path,
                                  const std::vector<std::string>& calibration_files) {
  if (calibration_files.size() > 2) {
    throw CommandError(kExitUsage, "--calib: give one calibration file, or two (intrinsics + extrinsics, or left + right)");
  }
  RectifiedPair pair;
  pair.left = io::read_luma_u8(left_path);
  pair.right = io::read_luma_u8(right_path);
  if (pair.left.width() != pair.right.width() || pair.left.height() != pair.right.height()) {
    throw CommandError(kExitInput, "image sizes differ: left " + left_path + " is " + std::to_string(pair.left.width()) + "x" +
                                       std::to_string(pair.left.height()) + ", right " + right_path + " is " +
                                       std::to_string(pair.right.width()) + "x" + std::to_string(pair.right.height()));
  }
  pair.geometry = rectified_geometry(calibration_files, pair.left.width(), pair.left.height());
  return pair;
}

}  // namespace lpstereo::tools
