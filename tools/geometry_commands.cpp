#include "tools/geometry_commands.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <tuple>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "arm/scheduler.h"
#include "dag/atomic_file.h"
#include "dag/graph.h"
#include "io/calibration.h"
#include "io/image_io.h"
#include "io/rectification.h"
#include "io/row_alignment.h"
#include "tools/command_error.h"

namespace lpstereo::tools {

namespace {

namespace fs = std::filesystem;

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

void require_same_size(const std::string& left_path, const cv::Size& left, const std::string& right_path, const cv::Size& right) {
  if (left != right) {
    throw CommandError(kExitInput, "image sizes differ: left " + left_path + " is " + size_text(left.width, left.height) +
                                       ", right " + right_path + " is " + size_text(right.width, right.height));
  }
}

io::StereoCalibration load_calibration(const std::vector<std::string>& files) {
  if (files.empty() || files.size() > 2) {
    throw CommandError(kExitUsage, "--calib: give one calibration file, or two (intrinsics + extrinsics, or left + right)");
  }
  return files.size() == 1 ? io::load_stereo_calibration(files[0]) : io::load_stereo_calibration(files[0], files[1]);
}

// ---- rectify ----

// "AxB" (or "AXB") with both numbers in [low, high]; nullopt otherwise.
std::optional<cv::Size> parse_times(const std::string& text, int low, int high) {
  int a = 0, b = 0;
  char separator = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &a, &separator, &b, &extra) != 3 || (separator != 'x' && separator != 'X') || a < low ||
      b < low || a > high || b > high) {
    return std::nullopt;
  }
  return cv::Size(a, b);
}

// --size WxH (0x0 = the input size).
cv::Size parse_output_size(const std::string& text) {
  if (text.empty()) return {0, 0};
  const std::optional<cv::Size> size = parse_times(text, 1, 8192);
  if (!size) throw CommandError(kExitUsage, "--size: expected WIDTHxHEIGHT in pixels, each 1..8192 (e.g. 752x480), got '" + text + "'");
  return *size;
}

int run_rectify(const std::string& left_path, const std::string& right_path, const std::vector<std::string>& calibration_files,
                const std::string& output_directory, const std::string& model, double hfov_deg, const std::string& size_text_option) {
  if (left_path.empty() || right_path.empty() || output_directory.empty()) {
    throw CommandError(kExitUsage, "give LEFT RIGHT --calib C -o DIR");
  }
  std::optional<io::LatLongOptions> latlong;
  if (model == "latlong") {
    if (!(hfov_deg > 0 && hfov_deg <= 180)) {
      throw CommandError(kExitUsage, "--hfov-deg: expected the lat-long horizontal field of view in degrees, (0, 180], got " +
                                         std::to_string(hfov_deg));
    }
    const cv::Size size = parse_output_size(size_text_option);
    latlong = io::LatLongOptions{hfov_deg * M_PI / 180.0, size.width, size.height};
  } else if (!size_text_option.empty()) {
    throw CommandError(kExitUsage, "--size applies to --model latlong only (a pinhole rectification keeps the input size)");
  }
  const Plane left = io::read_luma_u8(left_path);
  const Plane right = io::read_luma_u8(right_path);
  require_same_size(left_path, {left.width(), left.height()}, right_path, {right.width(), right.height()});
  const CalibrationForImages checked = load_calibration_for(calibration_files, left.width(), left.height(), latlong);
  const io::StereoCalibration& calibration = checked.calibration;
  const io::RectificationMaps& maps = checked.maps;
  const RectifiedViews rectified = rectify_views(left, right, calibration_files, latlong);
  const cv::Mat left_out = io::plane_to_mat(rectified.left);
  const cv::Mat right_out = io::plane_to_mat(rectified.right);

  std::error_code error;
  fs::create_directories(output_directory, error);
  if (!fs::is_directory(output_directory)) throw CommandError(kExitInput, output_directory + ": cannot create the output folder");
  const std::string left_file = (fs::path(output_directory) / "left.png").string();
  const std::string right_file = (fs::path(output_directory) / "right.png").string();
  io::write_image(left_file, left_out);
  io::write_image(right_file, right_out);
  std::printf("rectified %s pair (%s%s) to %s: %s %.3f px, baseline %.6f m, cx %.2f/%.2f px, cy %.2f px; %.1f %%/%.1f %% of the "
              "pixels from inside the sources; remap_bilinear with remap_q5 tables -> %s, %s\n",
              size_text(left.width(), left.height()).c_str(), calibration.format.c_str(),
              latlong                          ? ", latitude-longitude"
              : calibration.already_rectified ? ", already rectified: identity"
                                              : "",
              size_text(maps.width, maps.height).c_str(), latlong ? "focal (per radian)" : "focal", maps.geometry.focal_px,
              maps.geometry.baseline_m, maps.geometry.cx_left_px, maps.geometry.cx_right_px, maps.geometry.cy_px,
              100 * maps.left_inside, 100 * maps.right_inside, left_file.c_str(), right_file.c_str());
  return 0;
}

// ---- check-rectification ----

int run_check_rectification(const std::string& left_path, const std::string& right_path, const std::string& detector_name,
                            const std::string& json_path) {
  if (left_path.empty() || right_path.empty()) throw CommandError(kExitUsage, "give LEFT RIGHT");
  const cv::Mat left = io::plane_to_mat(io::read_luma_u8(left_path));
  const cv::Mat right = io::plane_to_mat(io::read_luma_u8(right_path));
  require_same_size(left_path, left.size(), right_path, right.size());
  io::RowAlignment alignment;
  try {
    alignment = io::measure_row_alignment(left, right, detector_name);
  } catch (const io::CalibrationError& error) {
    throw CommandError(kExitInput, left_path + " / " + right_path + ": " + error.what());
  }
  std::printf("vertical offset |y_left - y_right| of %zu matched features (%s, %zu candidate matches): median %.3f px, "
              "95th percentile %.3f px\n",
              alignment.matches, detector_name.c_str(), alignment.candidates, alignment.median_px, alignment.p95_px);
  if (!json_path.empty()) {
    const nlohmann::json report = {{"left", left_path},           {"right", right_path},
                                   {"detector", detector_name},   {"matches", alignment.matches},
                                   {"candidates", alignment.candidates}, {"median_px", alignment.median_px},
                                   {"p95_px", alignment.p95_px}};
    write_file_atomically(json_path, report.dump(2) + "\n");
  }
  return 0;
}

// ---- calibrate ----

cv::Size parse_board(const std::string& text) {
  const std::optional<cv::Size> board = parse_times(text, 2, 100);
  if (!board) throw CommandError(kExitUsage, "--board: expected COLSxROWS inner corners, each 2..100 (e.g. 9x6), got '" + text + "'");
  return *board;
}

std::vector<std::pair<std::string, std::string>> read_image_list(const std::string& list_path) {
  io::require_regular_file(list_path);
  const fs::path folder = fs::path(list_path).parent_path();
  auto resolve = [&](const std::string& name) { return fs::path(name).is_absolute() ? name : (folder / name).string(); };
  std::ifstream file(list_path);
  std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  std::vector<std::string> names;
  const size_t first = text.find_first_not_of(" \t\r\n");
  const bool storage = first != std::string::npos && (text.compare(first, 5, "<?xml") == 0 || text.compare(first, 5, "%YAML") == 0);
  std::vector<std::pair<std::string, std::string>> pairs;
  if (storage) {
    try {
      cv::FileStorage list(list_path, cv::FileStorage::READ);
      const cv::FileNode images = list["imagelist"];
      if (images.empty() || !images.isSeq()) throw CommandError(kExitInput, list_path + ": expected an 'imagelist' sequence");
      for (const cv::FileNode& name : images) names.push_back(static_cast<std::string>(name));
    } catch (const cv::Exception& exception) {
      throw CommandError(kExitInput, list_path + ": cannot parse: " + exception.err);
    }
    if (names.size() % 2 != 0) {
      throw CommandError(kExitInput, list_path + ": imagelist has " + std::to_string(names.size()) +
                                         " entries; expected alternating left and right images (an even number)");
    }
    for (size_t i = 0; i < names.size(); i += 2) pairs.emplace_back(resolve(names[i]), resolve(names[i + 1]));
  } else {
    std::istringstream lines(text);
    std::string line;
    int number = 0;
    while (std::getline(lines, line)) {
      ++number;
      std::istringstream words(line);
      std::string left, right, extra;
      if (!(words >> left) || left[0] == '#') continue;
      if (!(words >> right) || (words >> extra)) {
        throw CommandError(kExitInput, list_path + ":" + std::to_string(number) + ": expected 'LEFT RIGHT'");
      }
      pairs.emplace_back(resolve(left), resolve(right));
    }
  }
  if (pairs.empty()) throw CommandError(kExitInput, list_path + ": no image pairs");
  return pairs;
}

int run_calibrate(const std::string& board_text, double square_m, const std::string& list_path, const std::string& output_path) {
  const cv::Size board = parse_board(board_text);
  if (!(square_m > 0 && square_m < 10)) {
    throw CommandError(kExitUsage, "--square-m: expected the square size in metres, (0, 10), got " + std::to_string(square_m));
  }
  if (output_path.empty()) throw CommandError(kExitUsage, "give -o calib.yaml");
  const auto pairs = read_image_list(list_path);
  std::vector<cv::Point3f> board_points;
  for (int row = 0; row < board.height; ++row) {
    for (int column = 0; column < board.width; ++column) {
      board_points.emplace_back(static_cast<float>(column * square_m), static_cast<float>(row * square_m), 0.0f);
    }
  }
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> left_corners, right_corners;
  cv::Size image_size;
  std::string first_image;
  int skipped = 0;
  for (const auto& [left_path, right_path] : pairs) {
    std::vector<cv::Point2f> corners[2];
    bool found = true;
    for (int view = 0; view < 2; ++view) {
      const std::string& path = view == 0 ? left_path : right_path;
      const cv::Mat image = io::plane_to_mat(io::read_luma_u8(path));
      if (image_size.empty()) {
        image_size = image.size();
        first_image = path;
      } else if (image.size() != image_size) {
        throw CommandError(kExitInput, path + " is " + size_text(image.cols, image.rows) + ", " + first_image + " is " +
                                           size_text(image_size.width, image_size.height) + ": every image must have one size");
      }
      if (!found) continue;
      found = cv::findChessboardCorners(image, board, corners[view], cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      if (found) {
        cv::cornerSubPix(image, corners[view], cv::Size(11, 11), cv::Size(-1, -1),
                         cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 0.001));
      }
    }
    if (!found) {
      ++skipped;
      continue;
    }
    object_points.push_back(board_points);
    left_corners.push_back(corners[0]);
    right_corners.push_back(corners[1]);
  }
  const int used = static_cast<int>(object_points.size());
  if (used < 3) {
    throw CommandError(kExitInput, "the " + board_text + " board was found in both views of " + std::to_string(used) + " of " +
                                       std::to_string(pairs.size()) + " pairs; calibration needs at least 3");
  }
  cv::Mat m1, d1, m2, d2, r, t, e, f;
  std::vector<cv::Mat> rotations, translations;
  cv::calibrateCamera(object_points, left_corners, image_size, m1, d1, rotations, translations);
  cv::calibrateCamera(object_points, right_corners, image_size, m2, d2, rotations, translations);
  const double rms = cv::stereoCalibrate(object_points, left_corners, right_corners, m1, d1, m2, d2, image_size, r, t, e, f,
                                         cv::CALIB_USE_INTRINSIC_GUESS,
                                         cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-6));
  cv::Mat r1, r2, p1, p2, q;
  cv::stereoRectify(m1, d1, m2, d2, image_size, r, t, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 0.0, image_size);
  // Row alignment: the corners through each view's rectification; |y_left - y_right| per corner.
  double sum = 0, worst = 0;
  size_t count = 0;
  for (int i = 0; i < used; ++i) {
    std::vector<cv::Point2f> left_rectified, right_rectified;
    cv::undistortPoints(left_corners[static_cast<size_t>(i)], left_rectified, m1, d1, r1, p1);
    cv::undistortPoints(right_corners[static_cast<size_t>(i)], right_rectified, m2, d2, r2, p2);
    for (size_t k = 0; k < left_rectified.size(); ++k) {
      const double offset = std::abs(static_cast<double>(left_rectified[k].y) - right_rectified[k].y);
      sum += offset;
      worst = std::max(worst, offset);
      ++count;
    }
  }
  const double mean_offset = sum / static_cast<double>(count);

  io::StereoCalibration calibration;
  calibration.format = "opencv";
  calibration.source = output_path;
  for (auto [camera, m, d] : {std::tuple{&calibration.left, &m1, &d1}, std::tuple{&calibration.right, &m2, &d2}}) {
    camera->width_px = image_size.width;
    camera->height_px = image_size.height;
    camera->fx_px = m->at<double>(0, 0);
    camera->fy_px = m->at<double>(1, 1);
    camera->cx_px = m->at<double>(0, 2);
    camera->cy_px = m->at<double>(1, 2);
    for (int k = 0; k < 5; ++k) camera->distortion[static_cast<size_t>(k)] = d->at<double>(k);
  }
  std::copy(r.begin<double>(), r.end<double>(), calibration.rotation.begin());
  std::copy(t.begin<double>(), t.end<double>(), calibration.translation_m.begin());
  io::StereoRectification rectification;
  std::copy(r1.begin<double>(), r1.end<double>(), rectification.r1.begin());
  std::copy(r2.begin<double>(), r2.end<double>(), rectification.r2.begin());
  std::copy(p1.begin<double>(), p1.end<double>(), rectification.p1.begin());
  std::copy(p2.begin<double>(), p2.end<double>(), rectification.p2.begin());
  std::copy(q.begin<double>(), q.end<double>(), rectification.q.begin());
  calibration.rectification = rectification;
  char summary[512];
  std::snprintf(summary, sizeof(summary),
                "lpstereo calibrate: %d of %zu pairs used (%d skipped: board not found in both views), board %s, square %.6g m\n"
                "RMS reprojection error %.4f px; rectified row alignment mean %.4f px, max %.4f px\n"
                "focal %.3f / %.3f px, baseline %.6f m, image %s",
                used, pairs.size(), skipped, board_text.c_str(), square_m, rms, mean_offset, worst, calibration.left.fx_px,
                calibration.right.fx_px, calibration.baseline_m(), size_text(image_size.width, image_size.height).c_str());
  io::write_opencv_yaml(output_path, calibration, summary);
  std::printf("%s -> %s\n", summary + std::string("lpstereo calibrate: ").size(), output_path.c_str());
  return 0;
}

}  // namespace

CalibrationForImages load_calibration_for(const std::vector<std::string>& calibration_files, int width, int height,
                                          const std::optional<io::LatLongOptions>& latlong) {
  try {
    CalibrationForImages result;
    result.calibration = load_calibration(calibration_files);
    result.maps = latlong ? io::compute_latlong_maps(result.calibration, width, height, *latlong)
                          : io::compute_rectification_maps(result.calibration, width, height);
    // The fixed-point tables too, so that a map the kernel cannot take fails here, before the graph.
    io::rectification_table(result.maps.left_x, result.maps.left_y, "left");
    io::rectification_table(result.maps.right_x, result.maps.right_y, "right");
    return result;
  } catch (const cv::Exception& error) {
    throw CommandError(kExitInput, "OpenCV: " + error.err);
  }
}

ViewRectifier::ViewRectifier(const std::vector<std::string>& calibration_files, int width, int height,
                             const std::optional<io::LatLongOptions>& latlong, int worker_threads) {
  try {
    io::register_calibration_rectification_generator();
    graph_ = std::make_unique<Graph>(io::rectification_graph_spec(calibration_files, latlong));
    VerifyOptions options;
    options.frame_width = width;
    options.frame_height = height;
    graph_->verify(options);
    runner_ = std::make_unique<arm::FrameRunner>(*graph_, worker_threads);
  } catch (const cv::Exception& error) {
    throw CommandError(kExitInput, "OpenCV: " + error.err);
  }
}

ViewRectifier::~ViewRectifier() = default;

std::pair<const Plane&, const Plane&> ViewRectifier::rectify(const Plane& left, const Plane& right) {
  runner_->process({{"left", &left}, {"right", &right}});
  return {runner_->buffer("left_rectified"), runner_->buffer("right_rectified")};
}

RectifiedViews rectify_views(const Plane& left, const Plane& right, const std::vector<std::string>& calibration_files,
                             const std::optional<io::LatLongOptions>& latlong) {
  ViewRectifier rectifier(calibration_files, left.width(), left.height(), latlong);
  const auto [left_rectified, right_rectified] = rectifier.rectify(left, right);
  return {left_rectified.clone(), right_rectified.clone()};
}

GeometryCommands::GeometryCommands(CLI::App& app) {
  rectify_ = app.add_subcommand("rectify", "rectify a pair with a calibration through the fixed-point remap kernel");
  rectify_->add_option("left", left_, "left image (colour becomes BT.601 luma)");
  rectify_->add_option("right", right_, "right image, same size");
  rectify_->add_option("--calib", calibration_files_,
                       "calibration: OpenCV YAML/XML, KITTI calib, Middlebury calib.txt; give it twice for an OpenCV "
                       "intrinsics + extrinsics pair or ROS camera_info / Kalibr sensor left + right files")
      ->required();
  rectify_->add_option("-o,--output", output_, "output folder (left.png, right.png)");
  rectify_->add_option("--model", model_,
                       "pinhole: rows are epipolar lines of pinhole views (OpenCV stereoRectify); latlong: rows are "
                       "epipolar planes and columns angles within them (for fisheye and Mei calibrations)")
      ->capture_default_str()
      ->check(CLI::IsMember({"pinhole", "latlong"}));
  rectify_->add_option("--hfov-deg", hfov_deg_, "latlong: the angle a row spans, degrees, (0, 180]")->capture_default_str();
  rectify_->add_option("--size", size_, "latlong: output WIDTHxHEIGHT in pixels (default: the input size)");

  check_ = app.add_subcommand("check-rectification",
                              "vertical offset of matched features between the views (median, 95th percentile, px)");
  check_->add_option("left", check_left_, "left image");
  check_->add_option("right", check_right_, "right image, same size");
  check_->add_option("--detector", detector_, "akaze (sub-pixel keypoints) or orb")->capture_default_str()->check(
      CLI::IsMember({"akaze", "orb"}));
  check_->add_option("--json", json_path_, "also write the figures to this JSON file");

  calibrate_ = app.add_subcommand("calibrate", "stereo calibration from chessboard image pairs (OpenCV calib3d)");
  calibrate_->add_option("--board", board_, "COLSxROWS inner corners of the chessboard, e.g. 9x6")->required();
  calibrate_->add_option("--square-m", square_m_, "chessboard square size, metres")->required();
  calibrate_->add_option("image_list", image_list_,
                         "OpenCV stereo_calib.xml/yaml (imagelist of alternating left, right paths) or a text file of "
                         "'LEFT RIGHT' lines; paths relative to the list file")
      ->required();
  calibrate_->add_option("-o,--output", calibration_output_, "calibration YAML to write (M1 D1 M2 D2 R T R1 R2 P1 P2 Q)")
      ->required();
}

bool GeometryCommands::selected() const { return rectify_->parsed() || check_->parsed() || calibrate_->parsed(); }

int GeometryCommands::run() const {
  try {
    if (rectify_->parsed()) return run_rectify(left_, right_, calibration_files_, output_, model_, hfov_deg_, size_);
    if (check_->parsed()) return run_check_rectification(check_left_, check_right_, detector_, json_path_);
    return run_calibrate(board_, square_m_, image_list_, calibration_output_);
  } catch (const io::CalibrationError& error) {
    throw CommandError(kExitInput, error.what());
  } catch (const io::ImageError& error) {
    throw CommandError(kExitInput, error.what());
  } catch (const cv::Exception& error) {
    throw CommandError(kExitInput, "OpenCV: " + error.err);
  }
}

}  // namespace lpstereo::tools
