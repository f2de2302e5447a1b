#include "io/stereo_datasets.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "io/disparity_io.h"
#include "io/image_io.h"

namespace lpstereo::io {

namespace fs = std::filesystem;

namespace {

constexpr float kNoTruth = std::numeric_limits<float>::infinity();
constexpr int kKittiRangePx = 128;

std::string join(const std::string& directory, const std::string& name) { return (fs::path(directory) / name).string(); }

std::string size_text(const cv::Size& size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

void require_directory(const std::string& directory) {
  std::error_code error;
  if (!fs::is_directory(directory, error)) throw ImageError(directory + ": no such data folder");
}

void require_size(const std::string& path, const cv::Size& actual, const Plane& left) {
  if (actual.width != left.width() || actual.height != left.height()) {
    throw ImageError(path + ": expected " + std::to_string(left.width()) + "x" + std::to_string(left.height()) +
                     " (the left view's size), got " + size_text(actual));
  }
}

std::string read_text(const std::string& path) {
  require_regular_file(path);
  std::ifstream file(path);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

// "key=value" lines (Middlebury calib.txt, drange.txt).
std::map<std::string, std::string> read_key_values(const std::string& path) {
  std::map<std::string, std::string> values;
  std::istringstream text(read_text(path));
  std::string line;
  while (std::getline(text, line)) {
    const size_t equals = line.find('=');
    if (equals == std::string::npos) continue;
    std::string value = line.substr(equals + 1);
    while (!value.empty() && (value.back() == '\r' || value.back() == ' ')) value.pop_back();
    values[line.substr(0, equals)] = value;
  }
  return values;
}

int positive_int(const std::string& path, const std::string& what, const std::string& text) {
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (end == text.c_str() || value <= 0 || value > 4096) {
    throw ImageError(path + ": " + what + ": expected a positive integer, got \"" + text + "\"");
  }
  return static_cast<int>(value);
}

int key_int(const std::string& path, const std::map<std::string, std::string>& values, const std::string& key) {
  const auto found = values.find(key);
  if (found == values.end()) throw ImageError(path + ": expected a line \"" + key + "=<integer>\", found none");
  return positive_int(path, key, found->second);
}

// A grey 8-bit PNG (palette PNGs are expanded through their palette) divided by `divisor`;
// 0 = no ground truth.
cv::Mat read_scaled_u8_ground_truth(const std::string& path, double divisor) {
  const cv::Mat encoded = decode_image(path, cv::IMREAD_GRAYSCALE);
  cv::Mat truth_px(encoded.size(), CV_32FC1);
  for (int y = 0; y < encoded.rows; ++y) {
    for (int x = 0; x < encoded.cols; ++x) {
      const uint8_t value = encoded.at<uint8_t>(y, x);
      truth_px.at<float>(y, x) = value == 0 ? kNoTruth : static_cast<float>(value / divisor);
    }
  }
  return truth_px;
}

// A grey mask, 255 = in.
cv::Mat read_mask(const std::string& path, const Plane& left) {
  cv::Mat mask = decode_image(path, cv::IMREAD_GRAYSCALE);
  require_size(path, mask.size(), left);
  cv::Mat binary = (mask == 255);
  return binary;
}

void set_range(StereoPair& pair, int ndisp_from_set, const std::string& source) {
  pair.min_disparity_px = 0;
  pair.num_disparities = search_range_px(ndisp_from_set, pair.ground_truth_px);
  pair.range_source = source + " = " + std::to_string(ndisp_from_set);
  if (pair.num_disparities != ndisp_from_set) {
    pair.range_source += ", raised to cover the ground truth and rounded up to a multiple of 16";
  }
}

std::string leaf_name(const std::string& directory) {
  const fs::path path = fs::path(directory).lexically_normal();
  return (path.has_filename() ? path.filename() : path.parent_path().filename()).string();
}

// A pair with its views read from `directory` (which must exist); the caller adds truth and range.
StereoPair pair_with_views(const std::string& collection, const std::string& name, const std::string& directory,
                           const std::string& left_name, const std::string& right_name) {
  require_directory(directory);
  StereoPair pair;
  pair.collection = collection;
  pair.name = name;
  pair.left = read_luma_u8(join(directory, left_name));
  pair.right = read_luma_u8(join(directory, right_name));
  return pair;
}

// `truth_px` read from `path`, checked against the left view's size.
cv::Mat sized_like_left(const std::string& path, const cv::Mat& truth_px, const Plane& left) {
  require_size(path, truth_px.size(), left);
  return truth_px;
}

}  // namespace

std::string shared_data_directory(const std::string& explicit_directory) {
  if (!explicit_directory.empty()) return explicit_directory;
  if (const char* environment = std::getenv("LPSTEREO_SHARED_DATA"); environment != nullptr && *environment != '\0') {
    return environment;
  }
  return "../shared/data";
}

int search_range_px(int ndisp_from_set, const cv::Mat& ground_truth_px) {
  double largest_px = 0;
  for (int y = 0; y < ground_truth_px.rows; ++y) {
    const float* row = ground_truth_px.ptr<float>(y);
    for (int x = 0; x < ground_truth_px.cols; ++x) {
      if (std::isfinite(row[x])) largest_px = std::max(largest_px, static_cast<double>(row[x]));
    }
  }
  const int needed = std::max(ndisp_from_set, static_cast<int>(std::lround(largest_px)) + 1);
  return (needed + 15) / 16 * 16;
}

cv::Mat nonocc_from_left_right(const cv::Mat& left_ground_truth_px, const cv::Mat& right_ground_truth_px,
                               double max_difference_px) {
  cv::Mat mask(left_ground_truth_px.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < left_ground_truth_px.rows; ++y) {
    for (int x = 0; x < left_ground_truth_px.cols; ++x) {
      const float d = left_ground_truth_px.at<float>(y, x);
      if (!std::isfinite(d)) continue;
      const long right_x = std::lround(x - d);
      if (right_x < 0 || right_x >= right_ground_truth_px.cols) continue;
      const float right_d = right_ground_truth_px.at<float>(y, static_cast<int>(right_x));
      if (std::isfinite(right_d) && std::abs(right_d - d) <= max_difference_px) mask.at<uint8_t>(y, x) = 255;
    }
  }
  return mask;
}

StereoPair load_middlebury2003_scene(const std::string& scene_directory) {
  StereoPair pair = pair_with_views("middlebury2003", leaf_name(scene_directory), scene_directory, "imL.png", "imR.png");
  const std::string info_path = join(scene_directory, "info.txt");
  std::istringstream info(read_text(info_path));
  std::string divisor_text, ndisp_text;
  info >> divisor_text >> ndisp_text;
  const int divisor = positive_int(info_path, "line 1 (ground-truth divisor)", divisor_text);
  const int ndisp = positive_int(info_path, "line 2 (ndisp)", ndisp_text);
  const std::string truth_path = join(scene_directory, "groundtruth.png");
  pair.ground_truth_px = sized_like_left(truth_path, read_scaled_u8_ground_truth(truth_path, divisor), pair.left);
  const cv::Mat evaluated = read_mask(join(scene_directory, "all.png"), pair.left);
  pair.ground_truth_px.setTo(cv::Scalar(kNoTruth), evaluated == 0);
  pair.nonocc_mask = read_mask(join(scene_directory, "nonocc.png"), pair.left);
  set_range(pair, ndisp, "info.txt ndisp");
  return pair;
}

StereoPair load_middlebury2005_scene(const std::string& scene_directory) {
  StereoPair pair = pair_with_views("middlebury2005", leaf_name(scene_directory), scene_directory, "view1.png", "view5.png");
  const std::string left_truth_path = join(scene_directory, "disp1.png");
  const std::string right_truth_path = join(scene_directory, "disp5.png");
  // Half size: value / 2.
  pair.ground_truth_px = sized_like_left(left_truth_path, read_scaled_u8_ground_truth(left_truth_path, 2.0), pair.left);
  const cv::Mat right_truth_px =
      sized_like_left(right_truth_path, read_scaled_u8_ground_truth(right_truth_path, 2.0), pair.left);
  pair.nonocc_mask = nonocc_from_left_right(pair.ground_truth_px, right_truth_px);
  const std::string range_path = join(scene_directory, "drange.txt");
  set_range(pair, key_int(range_path, read_key_values(range_path), "dmax"), "drange.txt dmax");
  return pair;
}

StereoPair load_middlebury2014_scene(const std::string& scene_directory) {
  StereoPair pair = pair_with_views("middlebury2014", leaf_name(scene_directory), scene_directory, "im0.png", "im1.png");
  const std::string truth_path = join(scene_directory, "disp0GT.pfm");
  pair.ground_truth_px = sized_like_left(truth_path, read_pfm(truth_path), pair.left);
  pair.nonocc_mask = read_mask(join(scene_directory, "mask0nocc.png"), pair.left);
  const std::string calib_path = join(scene_directory, "calib.txt");
  set_range(pair, key_int(calib_path, read_key_values(calib_path), "ndisp"), "calib.txt ndisp");
  return pair;
}

StereoPair load_kitti2015_frame(const std::string& kitti_directory, const std::string& frame) {
  const std::string file = frame + "_10.png";
  StereoPair pair = pair_with_views("kitti2015", frame, kitti_directory, "image_2/" + file, "image_3/" + file);
  const std::string truth_path = join(kitti_directory, "disp_occ_0/" + file);
  pair.ground_truth_px = sized_like_left(truth_path, read_kitti_disparity_png_px(truth_path), pair.left);
  set_range(pair, kKittiRangePx, "KITTI customary range (the set gives none)");
  return pair;
}

std::vector<StereoPair> load_middlebury_pairs(const std::string& data_directory) {
  require_directory(data_directory);
  std::vector<StereoPair> pairs;
  for (const char* scene : {"tsukuba", "venus", "teddy", "cones"}) {
    pairs.push_back(load_middlebury2003_scene(join(data_directory, std::string("middlebury2003/") + scene)));
  }
  for (const char* scene : {"Reindeer", "Cloth3", "Wood2"}) {
    pairs.push_back(load_middlebury2005_scene(join(data_directory, std::string("middlebury2005/") + scene)));
  }
  pairs.push_back(load_middlebury2014_scene(join(data_directory, "middlebury2014/Motorcycle")));
  return pairs;
}

std::vector<StereoPair> load_kitti_pairs(const std::string& data_directory) {
  require_directory(data_directory);
  return {load_kitti2015_frame(join(data_directory, "kitti2015"), "000046")};
}

}  // namespace lpstereo::io
