// PNG files read and written with libpng directly. PNG is what stereo pairs, ground truth and every
// picture lpstereo writes come in; OpenCV's imgcodecs, which decodes it as well, pulls in GDAL,
// GDCM, Poppler, OpenEXR and about eighty more shared libraries, and loading them cost every
// lpstereo process 0.18 s and 42 MB of resident memory before the first pixel. Other formats go
// through the image codecs module (io/image_codecs_module.h), loaded only when one is met.
//
// The flags and the result are imread's (cv::IMREAD_UNCHANGED, IMREAD_GRAYSCALE, IMREAD_COLOR,
// IMREAD_ANYDEPTH | IMREAD_ANYCOLOR), with the same rules, so the bits are those cv::imread gives:
//   the file's own type: grey 1 channel; RGB and palette 3 (4 with a tRNS chunk); grey + alpha and
//   RGBA 4; 16-bit samples stay 16-bit (CV_16U), 1, 2 and 4-bit samples become 8-bit.
//   IMREAD_UNCHANGED keeps it. Otherwise: without IMREAD_ANYDEPTH 16-bit samples keep their high
//   byte; with IMREAD_COLOR, or IMREAD_ANYCOLOR and more than one channel, the result is 3-channel
//   BGR (alpha dropped, grey replicated), else 1 channel (colour converted by libpng with weights
//   0.299, 0.587, 0.114, as cv::imread does).
// Writing: CV_8U or CV_16U, 1, 3 (BGR) or 4 (BGRA) channels, with cv::imwrite's default settings
// (zlib level 1, run-length strategy, the Sub filter on every row): fast to write, and the same
// file cv::imwrite writes.
#pragma once

#include <string>

#include <opencv2/core.hpp>

namespace lpstereo::io {

// True when the file starts with the PNG signature (false when it cannot be read).
bool has_png_signature(const std::string& path);

// Decodes a PNG file (see above for `flags`). Throws ImageError naming the file and libpng's reason
// when the file is not a PNG, is truncated or corrupt, or is larger than 2^30 pixels.
cv::Mat decode_png(const std::string& path, int flags);

// Writes `image` to `path` as PNG (not atomically: write_image in io/image_io.h is the atomic
// wrapper); false when the file cannot be created or written (as cv::imwrite). Throws ImageError
// naming the file for an image PNG cannot hold (element type, channel count) or libpng's failure.
[[nodiscard]] bool encode_png(const std::string& path, const cv::Mat& image);

}  // namespace lpstereo::io
