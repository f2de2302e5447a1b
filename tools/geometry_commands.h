// The camera sub-commands of lpstereo:
//   rectify LEFT RIGHT --calib C [--calib C2] -o DIR [--model pinhole|latlong] [--hfov-deg D] [--size WxH]
//       rectifies a pair through the fixed-point remap kernel (graph with calibration_rectification
//       tables); writes DIR/left.png and DIR/right.png. --model latlong: latitude-longitude
//       rectification (rows = epipolar planes, columns = angle within them, hfov D degrees, output
//       WxH), for fisheye and Mei (omnidirectional) calibrations
//   check-rectification LEFT RIGHT [--detector akaze|orb] [--json F]
//       vertical offset |y_left - y_right| of matched features (epipolar-consistent matches only):
//       median and 95th percentile, pixels
//   calibrate --board COLSxROWS --square-m S IMAGE_LIST -o calib.yaml
//       OpenCV stereo calibration from chessboard pairs (COLSxROWS inner corners); IMAGE_LIST is
//       OpenCV's stereo_calib.xml form (imagelist of alternating left/right paths) or a text file of
//       "LEFT RIGHT" lines, paths relative to the list file
#pragma once

#include <CLI/CLI.hpp>

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dag/graph.h"
#include "dag/plane.h"
#include "io/calibration.h"
#include "io/rectification.h"

namespace lpstereo::arm {
class FrameRunner;
}

namespace lpstereo::tools {

// A calibration (--calib: one file, or two) checked against width x height images.
struct CalibrationForImages {
  io::StereoCalibration calibration;
  io::RectificationMaps maps;
};

// Loads the calibration and computes its rectification maps and fixed-point tables for the images'
// size, so that a calibration that does not fit them fails with one line before any pixel is
// touched: io::CalibrationError naming the file and both sizes ("calibration is for 320x240
// images, the images are 160x120"), a view that maps outside its source, a map the Q10.5 table
// cannot hold; CommandError for the wrong number of files or an OpenCV failure.
// latlong: latitude-longitude maps (fisheye and Mei pairs) instead of pinhole rectification.
CalibrationForImages load_calibration_for(const std::vector<std::string>& calibration_files, int width, int height,
                                          const std::optional<io::LatLongOptions>& latlong = std::nullopt);

// Both views rectified through the fixed-point remap kernel (io::rectification_graph_spec: the
// remap_bilinear graph with calibration_rectification tables), as `lpstereo rectify` and
// `lpstereo disparity --calib C --rectify` do. Call load_calibration_for first for its checks.
struct RectifiedViews {
  Plane left, right;  // u8, the input size
};
// The same rectification for a stream of pairs (`lpstereo run`): the graph is built and verified
// once for width x height views, then rectify() runs it on each pair.
class ViewRectifier {
 public:
  ViewRectifier(const std::vector<std::string>& calibration_files, int width, int height,
                const std::optional<io::LatLongOptions>& latlong = std::nullopt, int worker_threads = 0);
  ~ViewRectifier();
  ViewRectifier(const ViewRectifier&) = delete;
  ViewRectifier& operator=(const ViewRectifier&) = delete;
  // The rectified left and right views (u8, the input size), valid until the next call.
  std::pair<const Plane&, const Plane&> rectify(const Plane& left, const Plane& right);

 private:
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<arm::FrameRunner> runner_;
};

RectifiedViews rectify_views(const Plane& left, const Plane& right, const std::vector<std::string>& calibration_files,
                             const std::optional<io::LatLongOptions>& latlong = std::nullopt);

class GeometryCommands {
 public:
  explicit GeometryCommands(CLI::App& app);
  // True when one of these sub-commands was given; run() then runs it (throws CommandError).
  bool selected() const;
  int run() const;

 private:
  CLI::App* rectify_ = nullptr;
  CLI::App* check_ = nullptr;
  CLI::App* calibrate_ = nullptr;
  std::string left_, right_, output_, model_ = "pinhole", size_;
  double hfov_deg_ = 180;
  std::vector<std::string> calibration_files_;
  std::string check_left_, check_right_, detector_ = "akaze", json_path_;
  std::string board_, image_list_, calibration_output_;
  double square_m_ = 0;
};

}  // namespace lpstereo::tools
