#include "io/png_codec.h"

#include <png.h>
#include <zlib.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include <opencv2/imgcodecs.hpp>  // the IMREAD_* flag values only (nothing of imgcodecs is linked)

#include "io/image_io.h"

namespace lpstereo::io {
namespace {

// imread's limit on the pixels of one image: a header claiming more is refused before allocating.
constexpr double kMaxPixels = 1 << 30;
constexpr size_t kSignatureBytes = 8;

using File = std::unique_ptr<FILE, int (*)(FILE*)>;

// libpng reports errors through a callback that must not return: it jumps back to `jump` with the
// message kept here. Only code without C++ objects to destroy runs between the setjmp and a libpng
// call that may jump (the `guarded` bodies below), so no destructor is skipped.
struct PngFailure {
  std::jmp_buf jump;
  char message[256] = "";
};

[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* failure = static_cast<PngFailure*>(png_get_error_ptr(png));
  std::snprintf(failure->message, sizeof failure->message, "%s", message);
  std::longjmp(failure->jump, 1);
}
// Warnings (an unknown chunk, a bad CRC in an ancillary chunk, an sRGB profile libpng dislikes)
// leave the pixels intact; imread ignores them too.
void on_png_warning(png_structp, png_const_charp) {}

// Runs `body` (libpng calls only) under the failure's jump: false when libpng failed.
template <class Body>
bool guarded(PngFailure& failure, Body&& body) {
  if (setjmp(failure.jump) != 0) return false;
  body();
  return true;
}

struct ReadStruct {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~ReadStruct() { png_destroy_read_struct(&png, info != nullptr ? &info : nullptr, nullptr); }
};
struct WriteStruct {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~WriteStruct() { png_destroy_write_struct(&png, info != nullptr ? &info : nullptr); }
};

File open_file(const std::string& path, const char* mode) { return File(std::fopen(path.c_str(), mode), &std::fclose); }

}  // namespace

bool has_png_signature(const std::string& path) {
  const File file = open_file(path, "rb");
  if (!file) return false;
  png_byte signature[kSignatureBytes] = {};
  return std::fread(signature, 1, kSignatureBytes, file.get()) == kSignatureBytes && png_sig_cmp(signature, 0, kSignatureBytes) == 0;
}

cv::Mat decode_png(const std::string& path, int flags) {
  const File file = open_file(path, "rb");
  if (!file) throw ImageError(path + ": cannot open: " + std::strerror(errno));
  PngFailure failure;
  ReadStruct read;
  read.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &failure, on_png_error, on_png_warning);
  if (read.png != nullptr) read.info = png_create_info_struct(read.png);
  if (read.info == nullptr) throw ImageError(path + ": cannot decode: out of memory for libpng's state");
  auto fail = [&] { return ImageError(path + ": cannot decode as PNG: " + failure.message); };

  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, colour_type = 0;
  bool has_transparency = false;
  if (!guarded(failure, [&] {
        png_init_io(read.png, file.get());
        png_read_info(read.png, read.info);
        png_get_IHDR(read.png, read.info, &width, &height, &bit_depth, &colour_type, nullptr, nullptr, nullptr);
        has_transparency = png_get_valid(read.png, read.info, PNG_INFO_tRNS) != 0;
      })) {
    throw fail();
  }
  if (static_cast<double>(width) * height > kMaxPixels) {
    throw ImageError(path + ": " + std::to_string(width) + "x" + std::to_string(height) + " pixels is more than the 2^30 an image may have");
  }
  // The file's own type, then imread's rule for `flags` (see the header).
  int channels = 1;
  if (colour_type == PNG_COLOR_TYPE_RGB || colour_type == PNG_COLOR_TYPE_PALETTE) channels = has_transparency ? 4 : 3;
  if (colour_type == PNG_COLOR_TYPE_RGB_ALPHA || colour_type == PNG_COLOR_TYPE_GRAY_ALPHA) channels = 4;
  int depth = bit_depth == 16 ? CV_16U : CV_8U;
  if (flags != cv::IMREAD_UNCHANGED) {
    if ((flags & cv::IMREAD_ANYDEPTH) == 0) depth = CV_8U;
    channels = (flags & cv::IMREAD_COLOR) != 0 || ((flags & cv::IMREAD_ANYCOLOR) != 0 && channels > 1) ? 3 : 1;
  }
  const bool colour = channels > 1;

  cv::Mat image(static_cast<int>(height), static_cast<int>(width), CV_MAKETYPE(depth, channels));
  std::vector<png_bytep> rows(height);
  for (png_uint_32 y = 0; y < height; ++y) rows[y] = image.ptr(static_cast<int>(y));
  size_t decoded_row_bytes = 0;
  if (!guarded(failure, [&] {
        // The transformations imread asks libpng for, in its order.
        if (depth == CV_8U && bit_depth == 16) {
          png_set_strip_16(read.png);
        } else {
          png_set_swap(read.png);  // PNG's 16-bit samples are big-endian; every host we build for is little-endian
        }
        if (channels < 4) {
          png_set_strip_alpha(read.png);
        } else {
          png_set_tRNS_to_alpha(read.png);
        }
        if (colour_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(read.png);
        if ((colour_type & PNG_COLOR_MASK_COLOR) == 0 && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(read.png);
        if ((colour_type & PNG_COLOR_MASK_COLOR) != 0 && colour) {
          png_set_bgr(read.png);
        } else if (colour) {
          png_set_gray_to_rgb(read.png);
        } else {
          png_set_rgb_to_gray(read.png, 1, 0.299, 0.587);
        }
        png_set_interlace_handling(read.png);
        png_read_update_info(read.png, read.info);
        decoded_row_bytes = png_get_rowbytes(read.png, read.info);
      })) {
    throw fail();
  }
  const size_t row_bytes = image.cols * image.elemSize();
  if (decoded_row_bytes != row_bytes) {
    throw ImageError(path + ": cannot decode as PNG: libpng decodes rows of " + std::to_string(decoded_row_bytes) +
                     " bytes, expected " + std::to_string(row_bytes));
  }
  if (!guarded(failure, [&] {
        png_read_image(read.png, rows.data());
        png_read_end(read.png, nullptr);
      })) {
    throw fail();
  }
  return image;
}

bool encode_png(const std::string& path, const cv::Mat& image) {
  if (image.empty()) throw ImageError(path + ": cannot write an empty image");
  if (image.depth() != CV_8U && image.depth() != CV_16U) {
    throw ImageError(path + ": PNG holds 8- or 16-bit unsigned samples, got OpenCV depth " + std::to_string(image.depth()));
  }
  int colour_type = PNG_COLOR_TYPE_GRAY;
  switch (image.channels()) {
    case 1: colour_type = PNG_COLOR_TYPE_GRAY; break;
    case 3: colour_type = PNG_COLOR_TYPE_RGB; break;
    case 4: colour_type = PNG_COLOR_TYPE_RGB_ALPHA; break;
    default: throw ImageError(path + ": PNG takes 1, 3 or 4 channels, got " + std::to_string(image.channels()));
  }
  const File file = open_file(path, "wb");
  if (!file) return false;
  PngFailure failure;
  WriteStruct write;
  write.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &failure, on_png_error, on_png_warning);
  if (write.png != nullptr) write.info = png_create_info_struct(write.png);
  if (write.info == nullptr) throw ImageError(path + ": cannot encode: out of memory for libpng's state");
  std::vector<png_bytep> rows(static_cast<size_t>(image.rows));
  for (int y = 0; y < image.rows; ++y) rows[static_cast<size_t>(y)] = const_cast<png_bytep>(image.ptr(y));
  const int bit_depth = image.depth() == CV_16U ? 16 : 8;
  if (!guarded(failure, [&] {
        png_init_io(write.png, file.get());
        png_set_IHDR(write.png, write.info, static_cast<png_uint_32>(image.cols), static_cast<png_uint_32>(image.rows), bit_depth,
                     colour_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        png_set_filter(write.png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
        png_set_compression_level(write.png, Z_BEST_SPEED);
        png_set_compression_strategy(write.png, Z_RLE);
        png_write_info(write.png, write.info);
        if (colour_type != PNG_COLOR_TYPE_GRAY) png_set_bgr(write.png);
        if (bit_depth == 16) png_set_swap(write.png);
        png_write_image(write.png, rows.data());
        png_write_end(write.png, nullptr);
      })) {
    throw ImageError(path + ": cannot encode as PNG: " + failure.message);
  }
  return std::fflush(file.get()) == 0 && std::ferror(file.get()) == 0;
}

}  // namespace lpstereo::io
