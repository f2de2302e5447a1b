#include "io/disparity_io.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dag/atomic_file.h"
#include "io/image_io.h"

namespace lpstereo::io {

namespace {

cv::Mat read_kitti_u16(const std::string& path) {
  cv::Mat kitti = decode_image(path, cv::IMREAD_UNCHANGED);
  if (kitti.type() != CV_16UC1) {
    throw ImageError(path + ": expected a 16-bit single-channel KITTI disparity PNG, got " + std::to_string(kitti.channels()) +
                     " channel(s) of " + std::to_string(8 * kitti.elemSize1()) + "-bit samples");
  }
  return kitti;
}

void require_q4(const std::string& path, const Plane& disparity_q4) {
  if (disparity_q4.format().type != ElementType::s16 || disparity_q4.format().fraction_bits != 4) {
    throw ImageError(path + ": expected s16q4 disparity, got " + format_name(disparity_q4.format()));
  }
}

void require_px(const std::string& what, const cv::Mat& disparity_px) {
  if (disparity_px.type() != CV_32FC1 || disparity_px.empty()) {
    throw ImageError(what + ": expected a non-empty CV_32FC1 disparity map in pixels, got OpenCV type " +
                     std::to_string(disparity_px.type()) + " of " + std::to_string(disparity_px.cols) + "x" +
                     std::to_string(disparity_px.rows));
  }
}

}  // namespace

void write_kitti_disparity_png(const std::string& path, const Plane& disparity_q4, int min_disparity_px) {
  require_q4(path, disparity_q4);
  const int16_t invalid = invalid_disparity_q4(min_disparity_px);
  cv::Mat kitti(disparity_q4.height(), disparity_q4.width(), CV_16UC1);
  for (int y = 0; y < disparity_q4.height(); ++y) {
    const int16_t* in = disparity_q4.row<int16_t>(y);
    uint16_t* out = kitti.ptr<uint16_t>(y);
    for (int x = 0; x < disparity_q4.width(); ++x) {
      if (in[x] == invalid || in[x] < 0) {
        out[x] = 0;
      } else {
        out[x] = static_cast<uint16_t>(std::clamp(static_cast<int>(in[x]) * 16, 1, 65535));  // x16 (Q4) -> x256
      }
    }
  }
  write_image(path, kitti);
}

Plane read_kitti_disparity_png(const std::string& path) {
  const cv::Mat kitti = read_kitti_u16(path);
  Plane disparity(kitti.cols, kitti.rows, {ElementType::s16, 4});
  for (int y = 0; y < kitti.rows; ++y) {
    const uint16_t* in = kitti.ptr<uint16_t>(y);
    int16_t* out = disparity.row<int16_t>(y);
    for (int x = 0; x < kitti.cols; ++x) {
      out[x] = in[x] == 0 ? invalid_disparity_q4(0) : static_cast<int16_t>(std::min(32767, (in[x] + 8) / 16));
    }
  }
  return disparity;
}

cv::Mat read_kitti_disparity_png_px(const std::string& path) {
  const cv::Mat kitti = read_kitti_u16(path);
  cv::Mat disparity_px(kitti.rows, kitti.cols, CV_32FC1);
  for (int y = 0; y < kitti.rows; ++y) {
    const uint16_t* in = kitti.ptr<uint16_t>(y);
    float* out = disparity_px.ptr<float>(y);
    for (int x = 0; x < kitti.cols; ++x) {
      out[x] = in[x] == 0 ? std::numeric_limits<float>::infinity() : static_cast<float>(in[x]) / 256.0f;
    }
  }
  return disparity_px;
}

cv::Mat disparity_q4_to_px(const Plane& disparity_q4, int min_disparity_px) {
  require_q4("disparity_q4_to_px", disparity_q4);
  const int16_t invalid = invalid_disparity_q4(min_disparity_px);
  cv::Mat disparity_px(disparity_q4.height(), disparity_q4.width(), CV_32FC1);
  for (int y = 0; y < disparity_q4.height(); ++y) {
    const int16_t* in = disparity_q4.row<int16_t>(y);
    float* out = disparity_px.ptr<float>(y);
    for (int x = 0; x < disparity_q4.width(); ++x) {
      out[x] = in[x] == invalid ? std::numeric_limits<float>::infinity() : static_cast<float>(in[x]) / 16.0f;
    }
  }
  return disparity_px;
}

Plane disparity_px_to_q4(const cv::Mat& disparity_px, int min_disparity_px) {
  require_px("disparity_px_to_q4", disparity_px);
  const int16_t invalid = invalid_disparity_q4(min_disparity_px);
  Plane disparity_q4(disparity_px.cols, disparity_px.rows, {ElementType::s16, 4});
  for (int y = 0; y < disparity_px.rows; ++y) {
    const float* in = disparity_px.ptr<float>(y);
    int16_t* out = disparity_q4.row<int16_t>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      const double q4 = std::nearbyint(static_cast<double>(in[x]) * 16.0);
      out[x] = std::isfinite(in[x]) && q4 >= -32768.0 && q4 <= 32767.0 ? static_cast<int16_t>(q4) : invalid;
    }
  }
  return disparity_q4;
}

namespace {

bool host_is_little_endian() {
  const uint16_t probe = 1;
  uint8_t first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

// Reads the whole file; missing or unreadable -> ImageError naming it.
std::string read_file_bytes(const std::string& path) {
  require_regular_file(path);
  std::ifstream file(path, std::ios::binary);
  if (!file) throw ImageError(path + ": cannot open for reading");
  std::ostringstream content;
  content << file.rdbuf();
  return content.str();
}

}  // namespace

void write_pfm(const std::string& path, const cv::Mat& disparity_px) {
  require_px(path, disparity_px);
  std::string content = "Pf\n" + std::to_string(disparity_px.cols) + " " + std::to_string(disparity_px.rows) + "\n-1\n";
  const size_t header = content.size();
  content.resize(header + 4 * disparity_px.total());
  char* out = content.data() + header;
  const bool swap = !host_is_little_endian();
  for (int y = disparity_px.rows - 1; y >= 0; --y) {  // bottom row first
    const float* row = disparity_px.ptr<float>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      char bytes[4];
      std::memcpy(bytes, &row[x], 4);
      if (swap) std::reverse(bytes, bytes + 4);
      std::memcpy(out, bytes, 4);
      out += 4;
    }
  }
  write_file_atomically(path, content);
}

cv::Mat read_pfm(const std::string& path) {
  const std::string content = read_file_bytes(path);
  std::istringstream header(content);
  std::string magic;
  long long width = 0, height = 0;
  double scale = 0;
  header >> magic;
  if (magic == "PF") throw ImageError(path + ": expected a greyscale PFM (\"Pf\"), got a colour PFM (\"PF\")");
  if (magic != "Pf") throw ImageError(path + ": expected a PFM file starting with \"Pf\", got \"" + magic.substr(0, 16) + "\"");
  if (!(header >> width >> height) || width <= 0 || height <= 0 || width > 65536 || height > 65536) {
    throw ImageError(path + ": corrupt PFM header: expected \"<width> <height>\" in 1..65536");
  }
  if (!(header >> scale) || scale == 0 || !std::isfinite(scale)) {
    throw ImageError(path + ": corrupt PFM header: expected a non-zero scale (negative = little-endian)");
  }
  if (header.get() == std::char_traits<char>::eof()) throw ImageError(path + ": truncated PFM: no data after the header");
  const size_t data_offset = static_cast<size_t>(header.tellg());
  const size_t expected_bytes = static_cast<size_t>(width) * static_cast<size_t>(height) * 4;
  const size_t actual_bytes = content.size() - data_offset;
  if (actual_bytes < expected_bytes) {
    throw ImageError(path + ": truncated PFM: expected " + std::to_string(expected_bytes) + " bytes of float data for " +
                     std::to_string(width) + "x" + std::to_string(height) + ", got " + std::to_string(actual_bytes));
  }
  const bool swap = (scale < 0) != host_is_little_endian();
  cv::Mat disparity_px(static_cast<int>(height), static_cast<int>(width), CV_32FC1);
  const char* in = content.data() + data_offset;
  for (int y = disparity_px.rows - 1; y >= 0; --y) {
    float* row = disparity_px.ptr<float>(y);
    for (int x = 0; x < disparity_px.cols; ++x) {
      char bytes[4];
      std::memcpy(bytes, in, 4);
      if (swap) std::reverse(bytes, bytes + 4);
      std::memcpy(&row[x], bytes, 4);
      in += 4;
    }
  }
  return disparity_px;
}

void write_s16_raw(const std::string& path, const Plane& disparity_q4) {
  require_q4(path, disparity_q4);
  std::string content(2 * static_cast<size_t>(disparity_q4.width()) * static_cast<size_t>(disparity_q4.height()), '\0');
  size_t offset = 0;
  for (int y = 0; y < disparity_q4.height(); ++y) {
    const int16_t* row = disparity_q4.row<int16_t>(y);
    for (int x = 0; x < disparity_q4.width(); ++x) {
      const auto bits = static_cast<uint16_t>(row[x]);
      content[offset++] = static_cast<char>(bits & 0xFF);
      content[offset++] = static_cast<char>(bits >> 8);
    }
  }
  write_file_atomically(path, content);
}

Plane read_s16_raw(const std::string& path, int width, int height) {
  if (width <= 0 || height <= 0) {
    throw ImageError(path + ": s16 raw size: expected a positive width and height, got " + std::to_string(width) + "x" +
                     std::to_string(height));
  }
  const std::string content = read_file_bytes(path);
  const size_t expected_bytes = 2 * static_cast<size_t>(width) * static_cast<size_t>(height);
  if (content.size() != expected_bytes) {
    throw ImageError(path + ": s16 raw: expected " + std::to_string(expected_bytes) + " bytes for " + std::to_string(width) +
                     "x" + std::to_string(height) + ", got " + std::to_string(content.size()));
  }
  Plane disparity_q4(width, height, {ElementType::s16, 4});
  size_t offset = 0;
  for (int y = 0; y < height; ++y) {
    int16_t* row = disparity_q4.row<int16_t>(y);
    for (int x = 0; x < width; ++x) {
      const auto low = static_cast<uint8_t>(content[offset++]);
      const auto high = static_cast<uint8_t>(content[offset++]);
      row[x] = static_cast<int16_t>(static_cast<uint16_t>(low | (high << 8)));
    }
  }
  return disparity_q4;
}

void fill_invalid_kitti(Plane& disparity_q4, int16_t invalid_q4) {
  require_q4("fill_invalid_kitti", disparity_q4);
  const int width = disparity_q4.width();
  const int height = disparity_q4.height();
  auto valid = [&](int x, int y) { return disparity_q4.at<int16_t>(x, y) != invalid_q4; };
  for (int y = 0; y < height; ++y) {
    int16_t* row = disparity_q4.row<int16_t>(y);
    int first_valid = -1, last_valid = -1;
    for (int x = 0; x < width; ++x) {
      if (!valid(x, y)) continue;
      if (last_valid >= 0 && x - last_valid > 1) {
        const int16_t background = std::min(row[last_valid], row[x]);  // the lower neighbour
        std::fill(row + last_valid + 1, row + x, background);
      }
      if (first_valid < 0) first_valid = x;
      last_valid = x;
    }
    if (first_valid < 0) continue;  // no valid pixel in this row: the column pass below
    std::fill(row, row + first_valid, row[first_valid]);
    std::fill(row + last_valid + 1, row + width, row[last_valid]);
  }
  for (int x = 0; x < width; ++x) {
    int top = 0;
    while (top < height && !valid(x, top)) ++top;
    if (top == height) continue;
    for (int y = 0; y < top; ++y) disparity_q4.at<int16_t>(x, y) = disparity_q4.at<int16_t>(x, top);
    int bottom = height - 1;
    while (!valid(x, bottom)) --bottom;
    for (int y = bottom + 1; y < height; ++y) disparity_q4.at<int16_t>(x, y) = disparity_q4.at<int16_t>(x, bottom);
  }
}

cv::Mat colorize_disparity(const Plane& disparity_q4, int min_disparity_px, int max_disparity_px) {
  const int16_t invalid = invalid_disparity_q4(min_disparity_px);
  const double range_q4 = std::max(1, max_disparity_px - min_disparity_px) * 16.0;
  cv::Mat grey(disparity_q4.height(), disparity_q4.width(), CV_8UC1);
  cv::Mat invalid_mask(disparity_q4.height(), disparity_q4.width(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < disparity_q4.height(); ++y) {
    const int16_t* in = disparity_q4.row<int16_t>(y);
    for (int x = 0; x < disparity_q4.width(); ++x) {
      if (in[x] == invalid) {
        invalid_mask.at<uint8_t>(y, x) = 255;
        grey.at<uint8_t>(y, x) = 0;
        continue;
      }
      const double t = (in[x] - min_disparity_px * 16.0) / range_q4;
      grey.at<uint8_t>(y, x) = static_cast<uint8_t>(std::clamp(std::lround(255.0 * t), 0L, 255L));
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), invalid_mask);
  return colour;
}

}  // namespace lpstereo::io
