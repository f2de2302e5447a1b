// A rectified stereo pair as the commands that take one read it (`lpstereo points`, `lpstereo
// obstacles`): both views as 8-bit luma, checked to be the same size, and the rectified geometry of
// the calibration (focal length, baseline, principal point), checked against the image size.
#pragma once

#include <string>
#include <vector>

#include "dag/plane.h"
#include "io/rectification.h"

namespace lpstereo::tools {

struct RectifiedPair {
  Plane left, right;
  io::RectifiedGeometry geometry;
};

// The rectified geometry of a calibration (one file, or two) for width x height views, as `lpstereo
// rectify` makes them; a calibration for another size is refused with its own line. Throws
// CommandError for more than two files, the readers' errors naming the file.
io::RectifiedGeometry rectified_geometry(const std::vector<std::string>& calibration_files, int width, int height);

// calibration_files: one file, or two (intrinsics + extrinsics, or left + right). Throws
// CommandError (one line: more than two files, sizes that differ) or the readers' errors naming the file.
RectifiedPair read_rectified_pair(const std::string& left_path, const std::string& right_path,
                                  const std::vector<std::string>& calibration_files);

}  // namespace lpstereo::tools
