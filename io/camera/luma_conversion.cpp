// convert_to_luma (io/camera/pixel_format.h). Interim: plain loops, to be replaced by the vector
// kernels named in pixel_format.h.
#include <stdexcept>
#include <string>

#include "io/camera/pixel_format.h"

namespace lpstereo::io {

void convert_to_luma(CameraPixelFormat format, const uint8_t* data, size_t bytes_per_line, int width, int height,
                     Plane& luma) {
  if (luma.width() != width || luma.height() != height || luma.format().type != ElementType::u8) {
    throw std::invalid_argument("convert_to_luma: expected a u8 luma plane of " + std::to_string(width) + "x" +
                                std::to_string(height) + ", got " + std::to_string(luma.width()) + "x" +
                                std::to_string(luma.height()));
  }
  const size_t row_bytes = static_cast<size_t>(width) * static_cast<size_t>(pixel_format_bytes_per_pixel(format));
  if (bytes_per_line < row_bytes) {
    throw std::invalid_argument("convert_to_luma: " + std::string(pixel_format_name(format)) + " bytes per line " +
                                std::to_string(bytes_per_line) + " is less than a row of " + std::to_string(width) +
                                " px (" + std::to_string(row_bytes) + " bytes)");
  }
  for (int y = 0; y < height; ++y) {
    const uint8_t* source = data + static_cast<size_t>(y) * bytes_per_line;
    uint8_t* destination = luma.row<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      switch (format) {
        case CameraPixelFormat::grey:
        case CameraPixelFormat::nv12: destination[x] = source[x]; break;
        case CameraPixelFormat::yuyv: destination[x] = source[2 * x]; break;
        case CameraPixelFormat::uyvy: destination[x] = source[2 * x + 1]; break;
        case CameraPixelFormat::rgb888:
        case CameraPixelFormat::bgr888: {
          // BT.601 as cv::cvtColor's integer path: (R 4899 + G 9617 + B 1868 + 2^13) >> 14.
          const int red = source[3 * x + (format == CameraPixelFormat::rgb888 ? 0 : 2)];
          const int green = source[3 * x + 1];
          const int blue = source[3 * x + (format == CameraPixelFormat::rgb888 ? 2 : 0)];
          destination[x] = static_cast<uint8_t>((red * 4899 + green * 9617 + blue * 1868 + (1 << 13)) >> 14);
          break;
        }
      }
    }
  }
}

}  // namespace lpstereo::io
