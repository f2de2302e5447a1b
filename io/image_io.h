// Reading frames and writing images. PNG is read and written with libpng (io/png_codec.h); the other
// formats (PGM/PPM, JPEG, TIFF, ...) are OpenCV's, in a module loaded when one is met
// (io/image_codecs_module.h). Colour inputs become 8-bit luma with BT.601 weights.
#pragma once

#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "dag/plane.h"

namespace lpstereo::io {

// A missing, unreadable, corrupt or unsuitable image; what() names the file and the problem.
class ImageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws ImageError "<path>: no such file" / "not a regular file" unless `path` is a regular file.
void require_regular_file(const std::string& path);

// Decodes an image file with OpenCV `flags`; a missing, corrupt or undecodable file throws
// ImageError naming it.
cv::Mat decode_image(const std::string& path, int flags);

// Reads an image file as 8-bit luma. 16-bit images are scaled to 8 bits (value >> 8).
Plane read_luma_u8(const std::string& path);
// A decoded image (or video frame) as 8-bit luma, as read_luma_u8 converts it; `path` names it in
// the ImageError for a channel count or depth it cannot take.
Plane luma_u8(cv::Mat image, const std::string& path);

// Copies between planes and OpenCV matrices (same element size; the plane keeps its own stride).
cv::Mat plane_to_mat(const Plane& plane);
Plane mat_to_plane(const cv::Mat& mat, BufferFormat format);

// Writes an image atomically (temporary name, then rename): nothing half-written on failure.
void write_image(const std::string& path, const cv::Mat& image);

}  // namespace lpstereo::io
