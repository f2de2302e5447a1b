// Camera pixel formats lpstereo captures and their conversion to the u8 luma the graphs take.
// The conversion runs vector kernels (kernels/copy_u8.cpp, kernels/yuv422_to_luma.cpp,
// kernels/rgb888_to_luma.cpp), so the simulator can charge it like any other node.
//
//   format   V4L2 fourcc   layout (per row of bytes_per_line bytes)          luma
//   GREY     'GREY'        Y0 Y1 Y2 ...                                        Y
//   YUYV     'YUYV'        Y0 U0 Y1 V0 ...  (4:2:2 packed)                     even bytes
//   UYVY     'UYVY'        U0 Y0 V0 Y1 ...  (4:2:2 packed)                     odd bytes
//   NV12     'NV12'        Y plane (height rows), then interleaved UV plane    the Y plane
//   RGB888   'RGB3'        R G B R G B ...  (libcamera's BGR888 is this order) BT.601 (as cv::cvtColor)
//   BGR888   'BGR3'        B G R B G R ...  (libcamera's RGB888 is this order) BT.601 (as cv::cvtColor)
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "dag/plane.h"

namespace lpstereo::io {

enum class CameraPixelFormat { grey, yuyv, uyvy, nv12, rgb888, bgr888 };

// The order a source picks a format in when none is requested: luma-first, cheapest to convert.
inline constexpr CameraPixelFormat kCameraPixelFormatPreference[] = {
    CameraPixelFormat::grey, CameraPixelFormat::nv12, CameraPixelFormat::yuyv,
    CameraPixelFormat::uyvy, CameraPixelFormat::rgb888, CameraPixelFormat::bgr888};

std::string_view pixel_format_name(CameraPixelFormat format);     // "GREY", "YUYV", ...
uint32_t pixel_format_fourcc(CameraPixelFormat format);           // V4L2_PIX_FMT_*
std::optional<CameraPixelFormat> pixel_format_from_fourcc(uint32_t fourcc);
std::optional<CameraPixelFormat> pixel_format_from_name(std::string_view name);  // case-insensitive
// Bytes of the first plane's row of `width` pixels without padding (GREY/NV12 1, YUYV/UYVY 2, RGB 3 per px).
int pixel_format_bytes_per_pixel(CameraPixelFormat format);
// The smallest buffer holding width x height pixels with rows of bytes_per_line bytes (NV12: both planes).
size_t pixel_format_min_buffer_bytes(CameraPixelFormat format, int width, int height, size_t bytes_per_line);

// Converts width x height pixels starting at `data` (rows bytes_per_line apart; for a side-by-side
// half, `data` points at the half's first pixel) into `luma`, which must be a u8 plane of
// width x height. Throws std::invalid_argument naming the size or stride that does not fit.
void convert_to_luma(CameraPixelFormat format, const uint8_t* data, size_t bytes_per_line, int width, int height,
                     Plane& luma);

}  // namespace lpstereo::io
