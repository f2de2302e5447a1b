#include "io/disparity_io.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/image_io.h"

namespace lpstereo::io {

void write_kitti_disparity_png(const std::string& path, const Plane& disparity_q4, int min_disparity_px) {
  if (disparity_q4.format().type != ElementType::s16 || disparity_q4.format().fraction_bits != 4) {
    throw ImageError(path + ": expected s16q4 disparity, got " + format_name(disparity_q4.format()));
  }
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
  cv::Mat kitti = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (kitti.empty()) throw ImageError(path + ": cannot decode (missing, unreadable or corrupt)");
  if (kitti.type() != CV_16UC1) throw ImageError(path + ": expected a 16-bit single-channel KITTI disparity PNG");
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
