// The image formats other than PNG (PGM/PPM, JPEG, TIFF, WebP, OpenEXR, ...) are OpenCV's imgcodecs,
// in the module liblpstereo_image_codecs.so (io/image_codecs_module.cpp), dlopen'ed the first time
// such a file is read or written (io/codec_module.h says why and where it is looked for;
// $LPSTEREO_IMAGE_CODECS names the file). PNG never loads it (io/png_codec.h).
#pragma once

#include <cstddef>

#include <opencv2/core.hpp>

namespace lpstereo::io {

// The module's entry points (extern "C", looked up by name). Each returns false with a one-line
// reason in `error` (at most error_bytes, terminated); `flags` are cv::imread's.
using DecodeImageFunction = bool (*)(const char* path, int flags, cv::Mat* image, char* error, size_t error_bytes);
using EncodeImageFunction = bool (*)(const char* path, const cv::Mat* image, char* error, size_t error_bytes);
inline constexpr const char* kDecodeImageSymbol = "lpstereo_decode_image";
inline constexpr const char* kEncodeImageSymbol = "lpstereo_encode_image";

}  // namespace lpstereo::io
