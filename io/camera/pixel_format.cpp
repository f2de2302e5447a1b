#include "io/camera/pixel_format.h"

#include <linux/videodev2.h>

#include <cctype>
#include <stdexcept>
#include <string>

namespace lpstereo::io {

std::string_view pixel_format_name(CameraPixelFormat format) {
  switch (format) {
    case CameraPixelFormat::grey: return "GREY";
    case CameraPixelFormat::yuyv: return "YUYV";
    case CameraPixelFormat::uyvy: return "UYVY";
    case CameraPixelFormat::nv12: return "NV12";
    case CameraPixelFormat::rgb888: return "RGB888";
    case CameraPixelFormat::bgr888: return "BGR888";
  }
  return "?";
}

uint32_t pixel_format_fourcc(CameraPixelFormat format) {
  switch (format) {
    case CameraPixelFormat::grey: return V4L2_PIX_FMT_GREY;
    case CameraPixelFormat::yuyv: return V4L2_PIX_FMT_YUYV;
    case CameraPixelFormat::uyvy: return V4L2_PIX_FMT_UYVY;
    case CameraPixelFormat::nv12: return V4L2_PIX_FMT_NV12;
    case CameraPixelFormat::rgb888: return V4L2_PIX_FMT_RGB24;
    case CameraPixelFormat::bgr888: return V4L2_PIX_FMT_BGR24;
  }
  return 0;
}

std::optional<CameraPixelFormat> pixel_format_from_fourcc(uint32_t fourcc) {
  for (CameraPixelFormat format : kCameraPixelFormatPreference) {
    if (pixel_format_fourcc(format) == fourcc) return format;
  }
  return std::nullopt;
}

std::optional<CameraPixelFormat> pixel_format_from_name(std::string_view name) {
  for (CameraPixelFormat format : kCameraPixelFormatPreference) {
    const std::string_view known = pixel_format_name(format);
    if (known.size() != name.size()) continue;
    bool same = true;
    for (size_t i = 0; i < name.size(); ++i) {
      same = same && std::toupper(static_cast<unsigned char>(name[i])) == known[i];
    }
    if (same) return format;
  }
  return std::nullopt;
}

int pixel_format_bytes_per_pixel(CameraPixelFormat format) {
  switch (format) {
    case CameraPixelFormat::grey:
    case CameraPixelFormat::nv12: return 1;
    case CameraPixelFormat::yuyv:
    case CameraPixelFormat::uyvy: return 2;
    case CameraPixelFormat::rgb888:
    case CameraPixelFormat::bgr888: return 3;
  }
  return 1;
}

size_t pixel_format_min_buffer_bytes(CameraPixelFormat format, int width, int height, size_t bytes_per_line) {
  if (width <= 0 || height <= 0) return 0;
  const size_t rows = static_cast<size_t>(height);
  const size_t row_bytes = static_cast<size_t>(width) * static_cast<size_t>(pixel_format_bytes_per_pixel(format));
  const size_t luma_bytes = (rows - 1) * bytes_per_line + row_bytes;
  if (format != CameraPixelFormat::nv12) return luma_bytes;
  // NV12: the interleaved chroma plane follows the Y plane with the same stride, height / 2 rows (rounded up).
  return rows * bytes_per_line + ((rows + 1) / 2 - 1) * bytes_per_line + row_bytes;
}

}  // namespace lpstereo::io
