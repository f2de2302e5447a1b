// liblpstereo_image_codecs.so: OpenCV's imread / imwrite behind io/image_codecs_module.h, loaded
// only when an image that is not a PNG is read or written (see the header for why).
#include <cstdio>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "io/image_codecs_module.h"

extern "C" __attribute__((visibility("default"))) bool lpstereo_decode_image(const char* path, int flags, cv::Mat* image, char* error,
                                                                            size_t error_bytes) {
  try {
    *image = cv::imread(path, flags);
  } catch (const cv::Exception& exception) {
    std::snprintf(error, error_bytes, "%s: cannot decode: %s", path, exception.what());
    return false;
  }
  if (image->empty()) {
    std::snprintf(error, error_bytes, "%s: cannot decode (unreadable, corrupt or not an image)", path);
    return false;
  }
  return true;
}

extern "C" __attribute__((visibility("default"))) bool lpstereo_encode_image(const char* path, const cv::Mat* image, char* error,
                                                                            size_t error_bytes) {
  try {
    if (cv::imwrite(path, *image)) return true;
    std::snprintf(error, error_bytes, "%s: cannot encode (no encoder for this extension, or the write failed)", path);
  } catch (const cv::Exception& exception) {
    std::snprintf(error, error_bytes, "%s: cannot encode: %s", path, exception.what());
  }
  return false;
}
