#include "io/calibration.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <tuple>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "dag/atomic_file.h"

namespace lpstereo::io {

namespace {

std::string number_text(double value) {
  std::ostringstream text;
  text.precision(10);
  text << value;
  return text.str();
}

[[noreturn]] void fail(const std::string& source, const std::string& message) {
  throw CalibrationError(source + ": " + message);
}

std::string read_text(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) fail(path, "cannot open (no such file or not readable)");
  std::ostringstream text;
  text << file.rdbuf();
  if (text.str().empty()) fail(path, "empty file");
  return text.str();
}

Matrix3 multiply(const Matrix3& a, const Matrix3& b) {
  Matrix3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[3 * i + j] += a[3 * i + k] * b[3 * k + j];
  return c;
}

Matrix3 transpose(const Matrix3& a) {
  Matrix3 t{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t[3 * i + j] = a[3 * j + i];
  return t;
}

Vector3 rotate(const Matrix3& a, const Vector3& v) {
  Vector3 r{};
  for (int i = 0; i < 3; ++i) r[i] = a[3 * i] * v[0] + a[3 * i + 1] * v[1] + a[3 * i + 2] * v[2];
  return r;
}

bool near_identity(const Matrix3& r, double tolerance) {
  for (int i = 0; i < 9; ++i) {
    if (std::abs(r[i] - kIdentity3[i]) > tolerance) return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Text formats: KITTI and Middlebury.

// "KEY: numbers" (KITTI) lines; bare lines of numbers are named "#0", "#1", ...
std::map<std::string, std::vector<double>> kitti_entries(const std::string& text, const std::string& source) {
  std::map<std::string, std::vector<double>> entries;
  std::istringstream lines(text);
  std::string line;
  int bare = 0;
  int line_number = 0;
  while (std::getline(lines, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::string key;
    std::string values = line;
    const size_t colon = line.find(':');
    if (colon != std::string::npos) {
      key = line.substr(0, colon);
      key.erase(0, key.find_first_not_of(" \t"));
      key.erase(key.find_last_not_of(" \t") + 1);
      values = line.substr(colon + 1);
    } else {
      key = "#" + std::to_string(bare++);
    }
    std::istringstream numbers(values);
    std::vector<double> parsed;
    std::string word;
    while (numbers >> word) {
      char* end = nullptr;
      const double value = std::strtod(word.c_str(), &end);
      if (end == word.c_str() || *end != '\0') {
        // calib_cam_to_cam.txt has "calib_time: 09-Jan-2012 13:57:47": not numeric, not needed.
        parsed.clear();
        break;
      }
      parsed.push_back(value);
    }
    if (!parsed.empty()) entries[key] = parsed;
    (void)source;
  }
  return entries;
}

Matrix34 projection(const std::map<std::string, std::vector<double>>& entries, const std::string& key,
                    const std::string& source) {
  auto found = entries.find(key);
  if (found == entries.end()) fail(source, "missing " + key + " (3x4 projection matrix, 12 numbers)");
  if (found->second.size() != 12) {
    fail(source, key + ": expected 12 numbers (3x4 projection matrix), got " + std::to_string(found->second.size()));
  }
  Matrix34 p{};
  std::copy(found->second.begin(), found->second.end(), p.begin());
  return p;
}

// A rectified pair from two projection matrices P = K [I | t] (KITTI): same fx, fy, cy.
StereoCalibration from_rectified_projections(const Matrix34& left, const Matrix34& right, const std::string& left_name,
                                             const std::string& right_name, const std::string& source) {
  for (const auto& [p, name] : {std::pair{&left, &left_name}, std::pair{&right, &right_name}}) {
    if (!((*p)[0] > 0) || !((*p)[5] > 0)) {
      fail(source, *name + ": expected positive focal lengths P(0,0), P(1,1), got " + number_text((*p)[0]) + ", " +
                       number_text((*p)[5]));
    }
    if ((*p)[1] != 0 || (*p)[4] != 0 || (*p)[8] != 0 || (*p)[9] != 0 || (*p)[10] != 1) {
      fail(source, *name + ": expected a rectified projection matrix [fx 0 cx tx; 0 fy cy ty; 0 0 1 tz]");
    }
  }
  auto differs = [](double a, double b) { return std::abs(a - b) > 1e-6 * std::max(1.0, std::abs(a)); };
  if (differs(left[0], right[0]) || differs(left[5], right[5]) || differs(left[6], right[6])) {
    fail(source, "not a rectified pair: " + left_name + " and " + right_name + " differ in fx, fy or cy (" +
                     number_text(left[0]) + "/" + number_text(right[0]) + ", " + number_text(left[5]) + "/" +
                     number_text(right[5]) + ", " + number_text(left[6]) + "/" + number_text(right[6]) + ")");
  }
  StereoCalibration calibration;
  for (auto [camera, p] : {std::pair{&calibration.left, &left}, std::pair{&calibration.right, &right}}) {
    camera->fx_px = (*p)[0];
    camera->fy_px = (*p)[5];
    camera->cx_px = (*p)[2];
    camera->cy_px = (*p)[6];
  }
  // P = K [I | t] with t the camera's offset from the reference camera: tx = P(0,3) / fx.
  const double baseline_m = left[3] / left[0] - right[3] / right[0];
  calibration.translation_m = {-baseline_m, 0, 0};
  calibration.already_rectified = true;
  calibration.disparity_offset_px = right[2] - left[2];
  calibration.source = source;
  return calibration;
}

StereoCalibration load_kitti(const std::string& path, const std::string& text) {
  const auto entries = kitti_entries(text, path);
  StereoCalibration calibration;
  if (entries.count("P_rect_02")) {
    calibration = from_rectified_projections(projection(entries, "P_rect_02", path), projection(entries, "P_rect_03", path),
                                              "P_rect_02", "P_rect_03", path);
    calibration.format = "kitti_cam_to_cam";
    if (auto size = entries.find("S_rect_02"); size != entries.end() && size->second.size() == 2) {
      calibration.left.width_px = calibration.right.width_px = static_cast<int>(std::lround(size->second[0]));
      calibration.left.height_px = calibration.right.height_px = static_cast<int>(std::lround(size->second[1]));
    }
  } else if (entries.count("P2") && entries.count("P3")) {
    calibration = from_rectified_projections(projection(entries, "P2", path), projection(entries, "P3", path), "P2", "P3", path);
    calibration.format = "kitti_object";
  } else if (entries.count("P0") || entries.count("#0")) {
    const bool named = entries.count("P0") > 0;
    calibration = from_rectified_projections(projection(entries, named ? "P0" : "#0", path),
                                              projection(entries, named ? "P1" : "#1", path), "P0", "P1", path);
    calibration.format = "kitti_odometry";
  } else {
    fail(path, "not a calibration file lpstereo reads (expected OpenCV YAML/XML, KITTI P_rect_02/P2/P0 lines or "
               "Middlebury cam0=)");
  }
  return calibration;
}

// cam0=[f 0 cx; 0 f cy; 0 0 1]
Matrix3 middlebury_matrix(const std::string& value, const std::string& key, const std::string& source) {
  std::string cleaned = value;
  for (char& c : cleaned) {
    if (c == '[' || c == ']' || c == ';' || c == ',') c = ' ';
  }
  std::istringstream numbers(cleaned);
  std::vector<double> parsed;
  double number = 0;
  while (numbers >> number) parsed.push_back(number);
  if (parsed.size() != 9 || !numbers.eof()) fail(source, key + ": expected a 3x3 matrix [f 0 cx; 0 f cy; 0 0 1]");
  Matrix3 m{};
  std::copy(parsed.begin(), parsed.end(), m.begin());
  return m;
}

StereoCalibration load_middlebury(const std::string& path, const std::string& text) {
  std::map<std::string, std::string> values;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const size_t equals = line.find('=');
    if (equals == std::string::npos) continue;
    std::string key = line.substr(0, equals);
    key.erase(key.find_last_not_of(" \t") + 1);
    std::string value = line.substr(equals + 1);
    value.erase(value.find_last_not_of(" \t\r") + 1);
    values[key] = value;
  }
  auto number = [&](const std::string& key, bool required) -> double {
    auto found = values.find(key);
    if (found == values.end()) {
      if (required) fail(path, "missing " + key + "=");
      return 0;
    }
    char* end = nullptr;
    const double value = std::strtod(found->second.c_str(), &end);
    if (end == found->second.c_str() || std::string(end).find_first_not_of(" \t") != std::string::npos) {
      fail(path, key + ": expected a number, got '" + found->second + "'");
    }
    return value;
  };
  for (const char* key : {"cam0", "cam1"}) {
    if (!values.count(key)) fail(path, std::string("missing ") + key + "=");
  }
  const Matrix3 cam0 = middlebury_matrix(values["cam0"], "cam0", path);
  const Matrix3 cam1 = middlebury_matrix(values["cam1"], "cam1", path);
  StereoCalibration calibration;
  for (auto [camera, k] : {std::pair{&calibration.left, &cam0}, std::pair{&calibration.right, &cam1}}) {
    camera->fx_px = (*k)[0];
    camera->fy_px = (*k)[4];
    camera->cx_px = (*k)[2];
    camera->cy_px = (*k)[5];
    camera->width_px = static_cast<int>(number("width", false));
    camera->height_px = static_cast<int>(number("height", false));
  }
  const double baseline_mm = number("baseline", true);
  if (!(baseline_mm > 0)) fail(path, "baseline: expected a positive distance in mm, got " + number_text(baseline_mm));
  calibration.translation_m = {-baseline_mm / 1000.0, 0, 0};
  calibration.disparity_offset_px = values.count("doffs") ? number("doffs", true) : cam1[2] - cam0[2];
  calibration.num_disparities = static_cast<int>(number("ndisp", false));
  calibration.already_rectified = true;
  calibration.format = "middlebury";
  calibration.source = path;
  return calibration;
}

// ---------------------------------------------------------------------------------------------
// YAML / XML through cv::FileStorage.

// Opens a FileStorage file. OpenCV's YAML reader wants a "%YAML:1.0" first line, which ROS files
// lack: YAML text without it gets it prepended.
cv::FileStorage open_storage(const std::string& path, std::string& text) {
  text = read_text(path);
  const size_t first = text.find_first_not_of(" \t\r\n");
  const bool xml = first != std::string::npos && text.compare(first, 5, "<?xml") == 0;
  std::string content = text;
  if (!xml) {
    if (text.compare(0, 5, "%YAML") == 0) {
      content = "%YAML:1.0" + text.substr(std::min(text.find('\n'), text.size()));
    } else {
      content = "%YAML:1.0\n" + text;
    }
  }
  try {
    cv::FileStorage storage(content, cv::FileStorage::READ | cv::FileStorage::MEMORY |
                                         (xml ? cv::FileStorage::FORMAT_XML : cv::FileStorage::FORMAT_YAML));
    if (!storage.isOpened()) fail(path, "cannot parse as OpenCV FileStorage YAML/XML");
    return storage;
  } catch (const cv::Exception& exception) {
    std::string message = exception.err.empty() ? exception.what() : exception.err;
    std::replace(message.begin(), message.end(), '\n', ' ');
    fail(path, "cannot parse as YAML/XML: " + message);
  }
}

// A numeric matrix from an OpenCV matrix node or a {rows, cols, data} map (ROS, Kalibr T_BS) or a
// flat sequence.
std::vector<double> read_numbers(const cv::FileNode& node, const std::string& key, const std::string& source) {
  std::vector<double> numbers;
  try {
    if (node.isMap() && !node["data"].empty() && node["dt"].empty()) {
      for (const cv::FileNode& element : node["data"]) numbers.push_back(static_cast<double>(element));
    } else if (node.isSeq()) {
      for (const cv::FileNode& element : node) numbers.push_back(static_cast<double>(element));
    } else if (node.isReal() || node.isInt()) {
      numbers.push_back(static_cast<double>(node));
    } else {
      cv::Mat matrix;
      node >> matrix;
      if (matrix.empty()) fail(source, key + ": expected a matrix");
      matrix.convertTo(matrix, CV_64F);
      numbers.assign(matrix.begin<double>(), matrix.end<double>());
    }
  } catch (const cv::Exception& exception) {
    fail(source, key + ": not a numeric matrix (" + exception.err + ")");
  }
  return numbers;
}

std::vector<double> require_numbers(const cv::FileStorage& storage, const std::string& key, size_t count,
                                    const std::string& source) {
  const cv::FileNode node = storage[key];
  if (node.empty()) fail(source, "missing " + key);
  std::vector<double> numbers = read_numbers(node, key, source);
  if (numbers.size() != count) {
    fail(source, key + ": expected " + std::to_string(count) + " numbers, got " + std::to_string(numbers.size()));
  }
  return numbers;
}

template <size_t N>
std::array<double, N> to_array(const std::vector<double>& numbers) {
  std::array<double, N> result{};
  std::copy_n(numbers.begin(), N, result.begin());
  return result;
}

void set_intrinsics(CameraModel& camera, const std::vector<double>& k, const std::string& key, const std::string& source) {
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) {
    fail(source, key + ": expected a camera matrix [fx 0 cx; 0 fy cy; 0 0 1] (no skew)");
  }
  camera.fx_px = k[0];
  camera.fy_px = k[4];
  camera.cx_px = k[2];
  camera.cy_px = k[5];
}

LensModel lens_from_name(const std::string& name, const std::string& source) {
  std::string lower = name;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower.empty() || lower == "plumb_bob" || lower == "radtan" || lower == "pinhole" || lower == "rational_polynomial") {
    return LensModel::pinhole;
  }
  if (lower == "equidistant" || lower == "fisheye" || lower == "kannala_brandt") return LensModel::equidistant;
  if (lower == "mei" || lower == "omni" || lower == "omnidir" || lower == "unified") return LensModel::mei;
  fail(source, "distortion model '" + name + "': expected plumb_bob/radtan, equidistant/fisheye or mei/omnidir");
}

// Distortion coefficients for `lens` from a list in the file's order.
void set_distortion(CameraModel& camera, const std::vector<double>& d, const std::string& key, const std::string& source) {
  camera.distortion = {};
  if (camera.lens == LensModel::equidistant) {
    if (d.size() != 4) fail(source, key + ": expected 4 equidistant coefficients k1 k2 k3 k4, got " + std::to_string(d.size()));
    std::copy(d.begin(), d.end(), camera.distortion.begin());
    return;
  }
  if (camera.lens == LensModel::mei) {
    // cv::omnidir and Kalibr omni-radtan: k1 k2 p1 p2; Mei's toolbox adds k5 (sixth-order radial).
    if (d.size() != 0 && d.size() != 4 && d.size() != 5) {
      fail(source, key + ": expected 4 or 5 Mei coefficients k1 k2 p1 p2 [k5] (or none), got " + std::to_string(d.size()));
    }
    std::copy(d.begin(), d.end(), camera.distortion.begin());
    return;
  }
  if (d.size() != 0 && d.size() != 4 && d.size() != 5 && d.size() != 8 && d.size() != 12 && d.size() != 14) {
    fail(source, key + ": expected 4, 5, 8, 12 or 14 coefficients (k1 k2 p1 p2 [k3 ...]), got " + std::to_string(d.size()));
  }
  for (size_t i = 5; i < d.size(); ++i) {
    if (d[i] != 0) fail(source, key + ": coefficient " + std::to_string(i) + " (rational/thin-prism model) is not supported");
  }
  std::copy_n(d.begin(), std::min<size_t>(d.size(), 5), camera.distortion.begin());
}

std::string read_string(const cv::FileNode& node) {
  if (node.empty() || !node.isString()) return "";
  return static_cast<std::string>(node);
}

int read_int(const cv::FileNode& node) { return node.empty() ? 0 : static_cast<int>(static_cast<double>(node)); }

// Image size: image_width/image_height, or image_size/imageSize/resolution [w, h].
void read_image_size(const cv::FileStorage& storage, CameraModel& camera, const std::string& source) {
  camera.width_px = read_int(storage["image_width"]);
  camera.height_px = read_int(storage["image_height"]);
  for (const char* key : {"image_size", "imageSize", "resolution"}) {
    const cv::FileNode node = storage[key];
    if (node.empty()) continue;
    const std::vector<double> size = read_numbers(node, key, source);
    if (size.size() != 2) fail(source, std::string(key) + ": expected [width, height]");
    camera.width_px = static_cast<int>(size[0]);
    camera.height_px = static_cast<int>(size[1]);
  }
}

bool has(const cv::FileStorage& storage, const char* key) { return !storage[key].empty(); }

// OpenCV stereo file(s): intrinsics from `intrinsics`, extrinsics from `extrinsics` (the same
// storage for a single file).
StereoCalibration load_opencv(const cv::FileStorage& intrinsics, const cv::FileStorage& extrinsics, const std::string& source) {
  StereoCalibration calibration;
  calibration.format = "opencv";
  calibration.source = source;
  std::string model = read_string(intrinsics["lens_model"]);
  if (model.empty()) model = read_string(intrinsics["distortion_model"]);
  const LensModel lens = lens_from_name(model, source);
  for (auto [camera, m, d] : {std::tuple{&calibration.left, "M1", "D1"}, std::tuple{&calibration.right, "M2", "D2"}}) {
    camera->lens = lens;
    set_intrinsics(*camera, require_numbers(intrinsics, m, 9, source), m, source);
    if (!has(intrinsics, d)) fail(source, std::string("missing ") + d);
    set_distortion(*camera, read_numbers(intrinsics[d], d, source), d, source);
    read_image_size(intrinsics, *camera, source);
  }
  if (lens == LensModel::mei) {
    calibration.left.xi = require_numbers(intrinsics, "xi1", 1, source)[0];
    calibration.right.xi = require_numbers(intrinsics, "xi2", 1, source)[0];
  }
  calibration.rotation = to_array<9>(require_numbers(extrinsics, "R", 9, source));
  calibration.translation_m = to_array<3>(require_numbers(extrinsics, "T", 3, source));
  const bool any_rectification = has(extrinsics, "R1") || has(extrinsics, "R2") || has(extrinsics, "P1") || has(extrinsics, "P2");
  if (any_rectification) {
    StereoRectification rectification;
    rectification.r1 = to_array<9>(require_numbers(extrinsics, "R1", 9, source));
    rectification.r2 = to_array<9>(require_numbers(extrinsics, "R2", 9, source));
    rectification.p1 = to_array<12>(require_numbers(extrinsics, "P1", 12, source));
    rectification.p2 = to_array<12>(require_numbers(extrinsics, "P2", 12, source));
    if (has(extrinsics, "Q")) rectification.q = to_array<16>(require_numbers(extrinsics, "Q", 16, source));
    calibration.rectification = rectification;
  }
  return calibration;
}

// opencv_contrib's omni_stereo_calibration sample: camera_matrix_1 distortion_coefficients_1 xi_1,
// the same with _2, and extrinsic_parameters = (rvec, tvec) of cv::omnidir::stereoCalibrate, which
// maps the first camera's frame into the second's (X_2 = R X_1 + T), in the units of the pattern
// size given to the calibration (metres here). The file carries no image size.
StereoCalibration load_omnidir(const cv::FileStorage& storage, const std::string& source) {
  StereoCalibration calibration;
  calibration.format = "opencv_omnidir";
  calibration.source = source;
  for (auto [camera, suffix] : {std::pair{&calibration.left, "_1"}, std::pair{&calibration.right, "_2"}}) {
    camera->lens = LensModel::mei;
    const std::string k_key = std::string("camera_matrix") + suffix;
    const std::vector<double> k = require_numbers(storage, k_key, 9, source);
    if (k[1] != 0) {
      fail(source, k_key + ": skew s = " + number_text(k[1]) + ", expected 0 (calibrate with cv::omnidir::CALIB_FIX_SKEW)");
    }
    set_intrinsics(*camera, k, k_key, source);
    const std::string d_key = std::string("distortion_coefficients") + suffix;
    if (!has(storage, d_key.c_str())) fail(source, "missing " + d_key);
    set_distortion(*camera, read_numbers(storage[d_key], d_key, source), d_key, source);
    camera->xi = require_numbers(storage, std::string("xi") + suffix, 1, source)[0];
    read_image_size(storage, *camera, source);
  }
  const std::vector<double> pose = require_numbers(storage, "extrinsic_parameters", 6, source);
  cv::Matx33d rotation;
  cv::Rodrigues(cv::Vec3d(pose[0], pose[1], pose[2]), rotation);
  std::copy(rotation.val, rotation.val + 9, calibration.rotation.begin());
  calibration.translation_m = {pose[3], pose[4], pose[5]};
  return calibration;
}

// One ROS camera_info or Kalibr/Kimera sensor file.
struct SingleCamera {
  CameraModel camera;
  std::optional<Matrix3> rectification;     // ROS rectification_matrix
  std::optional<Matrix34> projection;       // ROS projection_matrix
  std::optional<Matrix4> body_from_sensor;  // Kalibr/Kimera T_BS
};

SingleCamera load_single_camera(const cv::FileStorage& storage, const std::string& source, std::string& format) {
  SingleCamera single;
  CameraModel& camera = single.camera;
  if (has(storage, "camera_matrix")) {  // ROS camera_info
    format = "ros_camera_info";
    camera.lens = lens_from_name(read_string(storage["distortion_model"]), source);
    if (camera.lens == LensModel::mei) fail(source, "distortion_model: ROS camera_info has no xi, so no Mei (omnidir) model");
    set_intrinsics(camera, require_numbers(storage, "camera_matrix", 9, source), "camera_matrix", source);
    if (has(storage, "distortion_coefficients")) {
      set_distortion(camera, read_numbers(storage["distortion_coefficients"], "distortion_coefficients", source),
                     "distortion_coefficients", source);
    }
    read_image_size(storage, camera, source);
    if (camera.width_px <= 0 || camera.height_px <= 0) fail(source, "missing image_width/image_height (ROS camera_info)");
    if (has(storage, "rectification_matrix")) {
      single.rectification = to_array<9>(require_numbers(storage, "rectification_matrix", 9, source));
    }
    if (has(storage, "projection_matrix")) {
      single.projection = to_array<12>(require_numbers(storage, "projection_matrix", 12, source));
    }
  } else if (has(storage, "intrinsics")) {  // Kalibr / Kimera sensor YAML
    format = "kalibr";
    const std::string model = read_string(storage["camera_model"]);
    if (!model.empty() && model != "pinhole" && model != "omni") {
      fail(source, "camera_model '" + model + "': expected pinhole or omni (Mei's unified model)");
    }
    const std::string distortion_model = read_string(storage["distortion_model"]);
    if (model == "omni") {
      // Kalibr's omni camera: intrinsics [xi, gamma1, gamma2, cu, cv], radtan (k1 k2 p1 p2) or none.
      if (!distortion_model.empty() && distortion_model != "radtan" && distortion_model != "none") {
        fail(source, "distortion_model '" + distortion_model + "' with camera_model omni: expected radtan or none");
      }
      camera.lens = LensModel::mei;
      const std::vector<double> k = require_numbers(storage, "intrinsics", 5, source);
      camera.xi = k[0];
      camera.fx_px = k[1];
      camera.fy_px = k[2];
      camera.cx_px = k[3];
      camera.cy_px = k[4];
    } else {
      camera.lens = lens_from_name(distortion_model, source);
      const std::vector<double> k = require_numbers(storage, "intrinsics", 4, source);
      camera.fx_px = k[0];
      camera.fy_px = k[1];
      camera.cx_px = k[2];
      camera.cy_px = k[3];
    }
    const char* coefficients = has(storage, "distortion_coefficients") ? "distortion_coefficients" : "distortion_coeffs";
    if (has(storage, coefficients)) {
      set_distortion(camera, read_numbers(storage[coefficients], coefficients, source), coefficients, source);
    }
    read_image_size(storage, camera, source);
    if (camera.width_px <= 0 || camera.height_px <= 0) fail(source, "missing resolution: [width, height]");
    if (!has(storage, "T_BS")) fail(source, "missing T_BS (sensor-to-body transform, 4x4)");
    single.body_from_sensor = to_array<16>(require_numbers(storage, "T_BS", 16, source));
  } else {
    fail(source, "not a camera file lpstereo reads (expected ROS camera_matrix or Kalibr intrinsics)");
  }
  return single;
}

StereoCalibration load_camera_pair(const SingleCamera& left, const SingleCamera& right, const std::string& format,
                                   const std::string& source) {
  StereoCalibration calibration;
  calibration.left = left.camera;
  calibration.right = right.camera;
  calibration.format = format;
  calibration.source = source;
  if (format == "kalibr") {
    // X_body = T_BS X_sensor for each camera: X_right = T_BS_r^-1 T_BS_l X_left.
    auto rotation_of = [](const Matrix4& t) { return Matrix3{t[0], t[1], t[2], t[4], t[5], t[6], t[8], t[9], t[10]}; };
    const Matrix3 rl = rotation_of(*left.body_from_sensor);
    const Matrix3 rr = rotation_of(*right.body_from_sensor);
    const Vector3 tl = {(*left.body_from_sensor)[3], (*left.body_from_sensor)[7], (*left.body_from_sensor)[11]};
    const Vector3 tr = {(*right.body_from_sensor)[3], (*right.body_from_sensor)[7], (*right.body_from_sensor)[11]};
    calibration.rotation = multiply(transpose(rr), rl);
    calibration.translation_m = rotate(transpose(rr), {tl[0] - tr[0], tl[1] - tr[1], tl[2] - tr[2]});
    return calibration;
  }
  // ROS: X_rect_left = R1 X_left, X_rect_right = R2 X_right = X_rect_left + t with
  // t = (P2(0,3) / P2(0,0), P2(1,3) / P2(1,1), 0): X_right = R2^T R1 X_left + R2^T t.
  if (!right.projection || !left.projection) fail(source, "missing projection_matrix (needed for the baseline)");
  const Matrix3 r1 = left.rectification.value_or(kIdentity3);
  const Matrix3 r2 = right.rectification.value_or(kIdentity3);
  const Matrix34& p1 = *left.projection;
  const Matrix34& p2 = *right.projection;
  if (!(p2[0] > 0) || !(p2[5] > 0)) fail(source, "right projection_matrix: expected positive focal lengths");
  const Vector3 t = {p2[3] / p2[0], p2[7] / p2[5], 0};
  calibration.rotation = multiply(transpose(r2), r1);
  calibration.translation_m = rotate(transpose(r2), t);
  const bool identity = near_identity(r1, 1e-9) && near_identity(r2, 1e-9) && !left.camera.has_distortion() &&
                        !right.camera.has_distortion() && p1[0] == left.camera.fx_px && p1[2] == left.camera.cx_px &&
                        p1[6] == left.camera.cy_px && p2[0] == right.camera.fx_px && p2[2] == right.camera.cx_px;
  if (identity) {
    calibration.already_rectified = true;
    calibration.disparity_offset_px = right.camera.cx_px - left.camera.cx_px;
    return calibration;
  }
  StereoRectification rectification;
  rectification.r1 = r1;
  rectification.r2 = r2;
  rectification.p1 = p1;
  rectification.p2 = p2;
  // OpenCV's Q for a horizontal pair: [1 0 0 -cx; 0 1 0 -cy; 0 0 0 f; 0 0 -1/Tx (cx - cx')/Tx].
  const double tx = t[0];
  if (tx == 0) fail(source, "right projection_matrix: P(0,3) = 0, no baseline");
  rectification.q = {1, 0, 0, -p1[2], 0, 1, 0, -p1[6], 0, 0, 0, p1[0], 0, 0, -1 / tx, (p1[2] - p2[2]) / tx};
  calibration.rectification = rectification;
  return calibration;
}

StereoCalibration load_storage_file(const std::string& path, const std::string& text) {
  std::string ignored;
  cv::FileStorage storage = open_storage(path, ignored);
  (void)text;
  if (has(storage, "M1") && has(storage, "R")) return load_opencv(storage, storage, path);
  if (has(storage, "camera_matrix_1") && has(storage, "xi_1")) return load_omnidir(storage, path);
  if (has(storage, "M1")) fail(path, "has intrinsics M1 D1 M2 D2 but no extrinsics R T: give the extrinsics file too");
  if (has(storage, "R") && has(storage, "T")) fail(path, "has extrinsics R T but no intrinsics M1 D1 M2 D2: give the intrinsics file too");
  if (has(storage, "camera_matrix") || has(storage, "intrinsics")) {
    fail(path, "describes one camera: give the left and the right camera files");
  }
  fail(path, "not a stereo calibration (expected M1 D1 M2 D2 R T)");
}

bool looks_like_storage(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return false;
  if (text.compare(first, 5, "<?xml") == 0 || text.compare(first, 5, "%YAML") == 0) return true;
  // YAML without a header (ROS): a "key:" line whose value is empty or a structure/scalar, and no
  // KITTI-style line of numbers after the colon.
  return text.find("camera_matrix") != std::string::npos || text.find("intrinsics:") != std::string::npos ||
         text.find("M1:") != std::string::npos;
}

}  // namespace

const char* lens_name(LensModel lens) {
  switch (lens) {
    case LensModel::pinhole: return "pinhole";
    case LensModel::equidistant: return "equidistant";
    case LensModel::mei: return "mei";
  }
  return "unknown";
}

bool CameraModel::has_distortion() const {
  return std::any_of(distortion.begin(), distortion.end(), [](double k) { return k != 0; });
}

double StereoCalibration::baseline_m() const {
  return std::sqrt(translation_m[0] * translation_m[0] + translation_m[1] * translation_m[1] +
                   translation_m[2] * translation_m[2]);
}

double StereoCalibration::focal_px() const { return rectification ? rectification->p1[0] : left.fx_px; }

void validate_calibration(const StereoCalibration& calibration) {
  const std::string& source = calibration.source;
  for (auto [camera, name] : {std::pair{&calibration.left, "left"}, std::pair{&calibration.right, "right"}}) {
    if (!(camera->fx_px > 0) || !(camera->fy_px > 0) || !std::isfinite(camera->fx_px) || !std::isfinite(camera->fy_px)) {
      fail(source, std::string(name) + " camera: expected positive focal lengths, got fx " + number_text(camera->fx_px) +
                       " px, fy " + number_text(camera->fy_px) + " px");
    }
    if (!std::isfinite(camera->cx_px) || !std::isfinite(camera->cy_px)) {
      fail(source, std::string(name) + " camera: principal point is not finite");
    }
    for (double k : camera->distortion) {
      if (!std::isfinite(k)) fail(source, std::string(name) + " camera: distortion coefficient is not finite");
    }
    if (camera->lens == LensModel::mei && !(camera->xi >= 0 && std::isfinite(camera->xi))) {
      fail(source, std::string(name) + " camera: Mei's xi must be finite and >= 0, got " + number_text(camera->xi));
    }
    if (camera->lens != LensModel::mei && camera->xi != 0) {
      fail(source, std::string(name) + " camera: xi " + number_text(camera->xi) + " given for a " + lens_name(camera->lens) +
                       " lens (only Mei's model has xi)");
    }
    if (camera->width_px < 0 || camera->height_px < 0 || camera->width_px > 65536 || camera->height_px > 65536) {
      fail(source, std::string(name) + " camera: image size " + std::to_string(camera->width_px) + "x" +
                       std::to_string(camera->height_px) + " out of range");
    }
  }
  if (calibration.left.width_px > 0 && calibration.right.width_px > 0 &&
      (calibration.left.width_px != calibration.right.width_px || calibration.left.height_px != calibration.right.height_px)) {
    fail(source, "left and right image sizes differ: " + std::to_string(calibration.left.width_px) + "x" +
                     std::to_string(calibration.left.height_px) + " and " + std::to_string(calibration.right.width_px) + "x" +
                     std::to_string(calibration.right.height_px));
  }
  const Matrix3& r = calibration.rotation;
  const Matrix3 product = multiply(r, transpose(r));
  double worst = 0;
  for (int i = 0; i < 9; ++i) worst = std::max(worst, std::abs(product[i] - kIdentity3[i]));
  const double determinant = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) +
                             r[2] * (r[3] * r[7] - r[4] * r[6]);
  if (!(worst <= 1e-3) || !(determinant > 0)) {
    fail(source, "R is not a rotation: |R R^T - I| = " + number_text(worst) + " (at most 0.001 accepted), det " +
                     number_text(determinant));
  }
  for (double t : calibration.translation_m) {
    if (!std::isfinite(t)) fail(source, "T is not finite");
  }
  if (!(calibration.baseline_m() > 0)) fail(source, "T is zero: no baseline");
  if (calibration.rectification) {
    const StereoRectification& rectification = *calibration.rectification;
    if (!(rectification.p1[0] > 0) || !(rectification.p2[0] > 0) || !(rectification.p1[5] > 0)) {
      fail(source, "P1/P2: expected positive focal lengths");
    }
  }
}

StereoCalibration load_stereo_calibration(const std::string& path) {
  const std::string text = read_text(path);
  StereoCalibration calibration;
  if (text.find("cam0=") != std::string::npos || text.find("cam0 =") != std::string::npos) {
    calibration = load_middlebury(path, text);
  } else if (looks_like_storage(text)) {
    calibration = load_storage_file(path, text);
  } else {
    calibration = load_kitti(path, text);
  }
  validate_calibration(calibration);
  return calibration;
}

StereoCalibration load_stereo_calibration(const std::string& first_path, const std::string& second_path) {
  std::string first_text, second_text;
  cv::FileStorage first = open_storage(first_path, first_text);
  cv::FileStorage second = open_storage(second_path, second_text);
  const std::string source = first_path + " + " + second_path;
  StereoCalibration calibration;
  if (has(first, "M1") || has(second, "M1")) {
    const bool first_has_intrinsics = has(first, "M1");
    const cv::FileStorage& intrinsics = first_has_intrinsics ? first : second;
    const cv::FileStorage& extrinsics = first_has_intrinsics ? second : first;
    if (!has(extrinsics, "R")) fail(first_has_intrinsics ? second_path : first_path, "missing R (extrinsics R T expected)");
    calibration = load_opencv(intrinsics, extrinsics, source);
  } else {
    std::string first_format, second_format;
    const SingleCamera left = load_single_camera(first, first_path, first_format);
    const SingleCamera right = load_single_camera(second, second_path, second_format);
    if (first_format != second_format) fail(source, "left is " + first_format + ", right is " + second_format);
    calibration = load_camera_pair(left, right, first_format, source);
  }
  validate_calibration(calibration);
  return calibration;
}

void write_opencv_yaml(const std::string& path, const StereoCalibration& calibration, const std::string& comments) {
  validate_calibration(calibration);
  cv::FileStorage storage(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  auto matrix = [](const double* data, int rows, int cols) { return cv::Mat(rows, cols, CV_64F, const_cast<double*>(data)).clone(); };
  const bool equidistant = calibration.left.lens == LensModel::equidistant;
  const bool mei = calibration.left.lens == LensModel::mei;
  if (calibration.left.lens != LensModel::pinhole) storage << "lens_model" << lens_name(calibration.left.lens);
  if (mei) storage << "xi1" << calibration.left.xi << "xi2" << calibration.right.xi;
  if (calibration.left.width_px > 0) {
    storage << "image_width" << calibration.left.width_px << "image_height" << calibration.left.height_px;
  }
  for (auto [camera, m, d] : {std::tuple{&calibration.left, "M1", "D1"}, std::tuple{&calibration.right, "M2", "D2"}}) {
    const Matrix3 k = {camera->fx_px, 0, camera->cx_px, 0, camera->fy_px, camera->cy_px, 0, 0, 1};
    storage << m << matrix(k.data(), 3, 3);
    storage << d << matrix(camera->distortion.data(), 1, equidistant ? 4 : 5);
  }
  storage << "R" << matrix(calibration.rotation.data(), 3, 3);
  storage << "T" << matrix(calibration.translation_m.data(), 3, 1);
  if (calibration.rectification) {
    const StereoRectification& rectification = *calibration.rectification;
    storage << "R1" << matrix(rectification.r1.data(), 3, 3) << "R2" << matrix(rectification.r2.data(), 3, 3);
    storage << "P1" << matrix(rectification.p1.data(), 3, 4) << "P2" << matrix(rectification.p2.data(), 3, 4);
    storage << "Q" << matrix(rectification.q.data(), 4, 4);
  }
  std::string text = storage.releaseAndGetString();
  if (!comments.empty()) {
    std::string commented;
    std::istringstream lines(comments);
    std::string line;
    while (std::getline(lines, line)) commented += "# " + line + "\n";
    const size_t after_header = text.find('\n') + 1;
    text.insert(after_header, commented);
  }
  try {
    write_file_atomically(path, text);
  } catch (const FileWriteError& error) {
    throw CalibrationError(error.what());
  }
}

}  // namespace lpstereo::io
