#include "io/image_io.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>  // the IMREAD_* flag values only (imgcodecs is the module's)
#include <opencv2/imgproc.hpp>

#include "dag/atomic_file.h"
#include "io/codec_module.h"
#include "io/image_codecs_module.h"
#include "io/png_codec.h"

namespace lpstereo::io {
namespace {

void* image_codecs_symbol(const char* symbol) {
#if defined(LPSTEREO_IMAGE_CODECS_BUILD_PATH)
  const char* build_path = LPSTEREO_IMAGE_CODECS_BUILD_PATH;
#else
  const char* build_path = nullptr;
#endif
  const CodecModule module{"liblpstereo_image_codecs.so", "LPSTEREO_IMAGE_CODECS", build_path,
                           "images other than PNG (OpenCV imgcodecs)"};
  try {
    return codec_module_symbol(module, symbol);
  } catch (const std::runtime_error& error) {
    throw ImageError(error.what());
  }
}

bool is_png_name(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  return extension == ".png";
}

// A codec's message names the temporary file it wrote; the user's is the destination.
std::string naming_destination(std::string reason, const std::string& temporary, const std::string& path) {
  if (reason.rfind(temporary, 0) == 0) reason = path + reason.substr(temporary.size());
  return reason;
}

}  // namespace

void require_regular_file(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) throw ImageError(path + ": no such file");
  if (!std::filesystem::is_regular_file(path, error)) throw ImageError(path + ": not a regular file");
}

cv::Mat decode_image(const std::string& path, int flags) {
  require_regular_file(path);
  if (has_png_signature(path)) return decode_png(path, flags);
  const auto decode = reinterpret_cast<DecodeImageFunction>(image_codecs_symbol(kDecodeImageSymbol));
  cv::Mat image;
  char error[1024] = {};
  if (!decode(path.c_str(), flags, &image, error, sizeof error)) throw ImageError(error);
  return image;
}

Plane read_luma_u8(const std::string& path) { return luma_u8(decode_image(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR), path); }

Plane luma_u8(cv::Mat image, const std::string& path) {
  if (image.channels() == 3) {
    cv::cvtColor(image, image, cv::COLOR_BGR2GRAY);  // BT.601 luma weights
  } else if (image.channels() == 4) {
    cv::cvtColor(image, image, cv::COLOR_BGRA2GRAY);
  } else if (image.channels() != 1) {
    throw ImageError(path + ": expected 1, 3 or 4 channels, got " + std::to_string(image.channels()));
  }
  if (image.depth() == CV_16U) {
    image.convertTo(image, CV_8U, 1.0 / 256.0);
  } else if (image.depth() != CV_8U) {
    throw ImageError(path + ": expected 8- or 16-bit samples, got OpenCV depth " + std::to_string(image.depth()));
  }
  return mat_to_plane(image, {ElementType::u8, 0});
}

cv::Mat plane_to_mat(const Plane& plane) {
  int type = CV_8UC1;
  switch (plane.element_size()) {
    case 1: type = CV_8UC1; break;
    case 2: type = plane.format().type == ElementType::s16 ? CV_16SC1 : CV_16UC1; break;
    case 4: type = plane.format().type == ElementType::s32 ? CV_32SC1 : CV_32SC1; break;
    case 8: type = CV_8UC(8); break;
    default: throw ImageError("plane_to_mat: unsupported element size " + std::to_string(plane.element_size()));
  }
  cv::Mat wrapped(plane.height(), plane.width(), type, plane.view().origin, static_cast<size_t>(plane.stride_bytes()));
  return wrapped.clone();
}

Plane mat_to_plane(const cv::Mat& mat, BufferFormat format) {
  if (mat.empty()) throw ImageError("mat_to_plane: empty image");
  if (static_cast<int>(mat.elemSize()) != element_bytes(format.type)) {
    throw ImageError("mat_to_plane: element size " + std::to_string(mat.elemSize()) + " does not match format " +
                     format_name(format));
  }
  Plane plane(mat.cols, mat.rows, format);
  for (int y = 0; y < mat.rows; ++y) {
    std::memcpy(plane.row<uint8_t>(y), mat.ptr(y), static_cast<size_t>(mat.cols) * mat.elemSize());
  }
  return plane;
}

void write_image(const std::string& path, const cv::Mat& image) {
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension.empty()) throw ImageError(path + ": no file extension to choose the image format");
  if (is_png_name(path)) {
    write_file_atomically_with(path, extension, [&](const std::string& temporary) {
      try {
        return encode_png(temporary, image);
      } catch (const ImageError& error) {
        throw ImageError(naming_destination(error.what(), temporary, path));
      }
    });
    return;
  }
  const auto encode = reinterpret_cast<EncodeImageFunction>(image_codecs_symbol(kEncodeImageSymbol));
  write_file_atomically_with(path, extension, [&](const std::string& temporary) {
    char error[1024] = {};
    if (encode(temporary.c_str(), &image, error, sizeof error)) return true;
    throw ImageError(naming_destination(error, temporary, path));
  });
}

}  // namespace lpstereo::io
