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

#include <string>
#include <vector>

namespace lpstereo::tools {

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
