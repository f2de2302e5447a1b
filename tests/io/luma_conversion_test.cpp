// convert_to_luma (io/camera/pixel_format.h, io/camera/luma_conversion.cpp): every camera pixel
// format, on every native ISA level, bit-exact against the test's own scalar reference at odd sizes,
// with bytes_per_line longer than a row, for both halves of a side-by-side frame, and with buffers
// of exactly pixel_format_min_buffer_bytes that end at a guard page (an access past the caller's
// buffer faults in every build, not only under ASan); RGB/BGR also against cv::cvtColor; bad sizes,
// strides and planes refused with one line naming them.
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstring>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/camera/pixel_format.h"
#include "kernels/simd/isa.h"
#include "tests/kernels/kernel_check.h"

#ifdef LPSTEREO_TEST_WITH_OPENCV
#include <opencv2/imgproc.hpp>
#endif

namespace lpstereo::io {
namespace {

constexpr BufferFormat kU8{ElementType::u8, 0};

// `size` bytes that end exactly where an inaccessible page begins: reading one byte past the end
// faults. Filled with random bytes.
class GuardedBuffer {
 public:
  GuardedBuffer(size_t size, uint32_t seed) : size_(size) {
    const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
    const size_t data_pages = (size + page - 1) / page;
    mapping_bytes_ = (data_pages + 1) * page;
    void* mapping = mmap(nullptr, mapping_bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapping == MAP_FAILED) throw std::runtime_error("mmap of " + std::to_string(mapping_bytes_) + " bytes failed");
    mapping_ = static_cast<uint8_t*>(mapping);
    if (mprotect(mapping_ + data_pages * page, page, PROT_NONE) != 0) throw std::runtime_error("mprotect of the guard page failed");
    data_ = mapping_ + data_pages * page - size;
    std::mt19937 generator(seed);
    for (size_t i = 0; i < size; ++i) data_[i] = static_cast<uint8_t>(generator());
  }
  ~GuardedBuffer() { munmap(mapping_, mapping_bytes_); }
  GuardedBuffer(const GuardedBuffer&) = delete;
  GuardedBuffer& operator=(const GuardedBuffer&) = delete;

  uint8_t* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  uint8_t* mapping_ = nullptr;
  size_t mapping_bytes_ = 0;
  uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

// The test's own reference: the luma of pixel (x, y) from the bytes, per io/camera/pixel_format.h's
// table; RGB and BGR with OpenCV's 8-bit BT.601 weights (9798 R + 19235 G + 3735 B + 2^14) >> 15.
Plane reference_luma(CameraPixelFormat format, const uint8_t* data, size_t bytes_per_line, int width, int height) {
  Plane luma(width, height, kU8);
  for (int y = 0; y < height; ++y) {
    const uint8_t* row = data + static_cast<size_t>(y) * bytes_per_line;
    for (int x = 0; x < width; ++x) {
      int value = 0;
      switch (format) {
        case CameraPixelFormat::grey:
        case CameraPixelFormat::nv12: value = row[x]; break;
        case CameraPixelFormat::yuyv: value = row[2 * x]; break;
        case CameraPixelFormat::uyvy: value = row[2 * x + 1]; break;
        case CameraPixelFormat::rgb888: value = (9798 * row[3 * x] + 19235 * row[3 * x + 1] + 3735 * row[3 * x + 2] + 16384) >> 15; break;
        case CameraPixelFormat::bgr888: value = (9798 * row[3 * x + 2] + 19235 * row[3 * x + 1] + 3735 * row[3 * x] + 16384) >> 15; break;
      }
      luma.at<uint8_t>(x, y) = static_cast<uint8_t>(value);
    }
  }
  return luma;
}

// A luma plane with 9 bytes of padding per row, every byte 0x5A, so a write past the row shows.
Plane padded_luma(int width, int height) {
  Plane luma(width, height, kU8, width + 9);
  for (int y = 0; y < height; ++y) std::memset(luma.row<uint8_t>(y), 0x5A, static_cast<size_t>(luma.stride_bytes()));
  return luma;
}

// Converts and compares on every native ISA level this CPU has.
void expect_converts_like_reference(CameraPixelFormat format, const uint8_t* data, size_t bytes_per_line, int width, int height,
                                    const std::string& label) {
  const Plane expected = reference_luma(format, data, bytes_per_line, width, height);
  for (simd::Isa isa : simd::available_isas()) {
    simd::ActiveIsaScope scope(isa);
    Plane luma = padded_luma(width, height);
    convert_to_luma(format, data, bytes_per_line, width, height, luma);
    EXPECT_TRUE(testing::planes_equal(expected, luma)) << label << " on " << simd::isa_name(isa);
    EXPECT_TRUE(testing::padding_untouched(luma, 0x5A)) << label << " on " << simd::isa_name(isa);
  }
}

const CameraPixelFormat kFormats[] = {CameraPixelFormat::grey, CameraPixelFormat::yuyv, CameraPixelFormat::uyvy,
                                      CameraPixelFormat::nv12, CameraPixelFormat::rgb888, CameraPixelFormat::bgr888};

TEST(ConvertToLuma, EveryFormatMatchesTheReferenceAtOddSizesInExactBuffersWithLongLines) {
  for (CameraPixelFormat format : kFormats) {
    for (auto [width, height, padding] : std::vector<std::tuple<int, int, int>>{{631, 479, 13}, {65, 3, 1}, {1, 1, 0}, {17, 5, 0}, {129, 2, 64}}) {
      const size_t bytes_per_line = static_cast<size_t>(width) * static_cast<size_t>(pixel_format_bytes_per_pixel(format)) + static_cast<size_t>(padding);
      const GuardedBuffer buffer(pixel_format_min_buffer_bytes(format, width, height, bytes_per_line), 70 + static_cast<uint32_t>(width));
      expect_converts_like_reference(format, buffer.data(), bytes_per_line, width, height,
                                     std::string(pixel_format_name(format)) + " " + std::to_string(width) + "x" + std::to_string(height) +
                                         " bytes per line " + std::to_string(bytes_per_line));
    }
  }
}

// A side-by-side frame of 2 x 157 px: each half converted from its own first pixel; the right
// half's last row ends at the buffer's last byte.
TEST(ConvertToLuma, EachHalfOfASideBySideFrame) {
  const int half_width = 157, height = 31;
  for (CameraPixelFormat format : kFormats) {
    const size_t bytes_per_pixel = static_cast<size_t>(pixel_format_bytes_per_pixel(format));
    const size_t bytes_per_line = 2 * half_width * bytes_per_pixel + 6;
    const GuardedBuffer buffer(pixel_format_min_buffer_bytes(format, 2 * half_width, height, bytes_per_line), 80);
    const Plane whole = reference_luma(format, buffer.data(), bytes_per_line, 2 * half_width, height);
    for (int half = 0; half < 2; ++half) {
      const uint8_t* first_pixel = buffer.data() + static_cast<size_t>(half * half_width) * bytes_per_pixel;
      const std::string label = std::string(pixel_format_name(format)) + (half == 0 ? " left" : " right") + " half";
      expect_converts_like_reference(format, first_pixel, bytes_per_line, half_width, height, label);
      // The half's reference is the whole frame's reference, cut (the two references agree).
      Plane luma = padded_luma(half_width, height);
      convert_to_luma(format, first_pixel, bytes_per_line, half_width, height, luma);
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < half_width; ++x) {
          ASSERT_EQ(luma.at<uint8_t>(x, y), whole.at<uint8_t>(half * half_width + x, y)) << label << " x=" << x << " y=" << y;
        }
      }
    }
  }
}

// Known bytes, so the reference itself is checked: YUYV Y0 U Y1 V = 10 200 20 100; UYVY the same
// bytes give 200, 100; RGB (255, 0, 0) gives 76 (0.299 x 255 = 76.2), BGR reads it as blue: 29.
TEST(ConvertToLuma, KnownBytes) {
  const uint8_t packed[] = {10, 200, 20, 100};
  Plane luma(2, 1, kU8);
  convert_to_luma(CameraPixelFormat::yuyv, packed, 4, 2, 1, luma);
  EXPECT_EQ(luma.at<uint8_t>(0, 0), 10);
  EXPECT_EQ(luma.at<uint8_t>(1, 0), 20);
  convert_to_luma(CameraPixelFormat::uyvy, packed, 4, 2, 1, luma);
  EXPECT_EQ(luma.at<uint8_t>(0, 0), 200);
  EXPECT_EQ(luma.at<uint8_t>(1, 0), 100);
  const uint8_t red_then_grey[] = {255, 0, 0, 128, 128, 128};
  convert_to_luma(CameraPixelFormat::rgb888, red_then_grey, 6, 2, 1, luma);
  EXPECT_EQ(luma.at<uint8_t>(0, 0), 76);
  EXPECT_EQ(luma.at<uint8_t>(1, 0), 128);
  convert_to_luma(CameraPixelFormat::bgr888, red_then_grey, 6, 2, 1, luma);
  EXPECT_EQ(luma.at<uint8_t>(0, 0), 29);
  EXPECT_EQ(luma.at<uint8_t>(1, 0), 128);
}

// The message of the std::invalid_argument `convert` throws (one line), or "" if it throws none.
template <class Convert>
std::string refusal(const Convert& convert) {
  try {
    convert();
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    return message;
  }
  return "";
}

TEST(ConvertToLumaMustFail, RefusesBadSizesStridesAndPlanes) {
  const std::vector<uint8_t> bytes(3 * 64 * 8, 0);
  Plane luma(64, 8, kU8);
  // A stride shorter than a row of the format: YUYV needs 128 bytes for 64 px.
  std::string message = refusal([&] { convert_to_luma(CameraPixelFormat::yuyv, bytes.data(), 127, 64, 8, luma); });
  EXPECT_NE(message.find("YUYV"), std::string::npos) << message;
  EXPECT_NE(message.find("127"), std::string::npos) << message;
  EXPECT_NE(message.find("128"), std::string::npos) << message;
  message = refusal([&] { convert_to_luma(CameraPixelFormat::rgb888, bytes.data(), 191, 64, 8, luma); });
  EXPECT_NE(message.find("191"), std::string::npos) << message;
  // A luma plane of the wrong size or type.
  Plane small(63, 8, kU8);
  message = refusal([&] { convert_to_luma(CameraPixelFormat::grey, bytes.data(), 64, 64, 8, small); });
  EXPECT_NE(message.find("64x8"), std::string::npos) << message;
  EXPECT_NE(message.find("63x8"), std::string::npos) << message;
  Plane wide(64, 8, {ElementType::u16, 0});
  message = refusal([&] { convert_to_luma(CameraPixelFormat::grey, bytes.data(), 64, 64, 8, wide); });
  EXPECT_NE(message.find("u16"), std::string::npos) << message;
  // Empty or negative sizes, and no data.
  Plane empty(1, 1, kU8);
  message = refusal([&] { convert_to_luma(CameraPixelFormat::grey, bytes.data(), 64, 0, 8, empty); });
  EXPECT_NE(message.find("0x8"), std::string::npos) << message;
  message = refusal([&] { convert_to_luma(CameraPixelFormat::nv12, bytes.data(), 64, 64, -2, luma); });
  EXPECT_NE(message.find("64x-2"), std::string::npos) << message;
  message = refusal([&] { convert_to_luma(CameraPixelFormat::uyvy, nullptr, 128, 64, 8, luma); });
  EXPECT_NE(message.find("null"), std::string::npos) << message;
}

#ifdef LPSTEREO_TEST_WITH_OPENCV
// RGB888 and BGR888 frames in exact buffers with long lines, against cv::cvtColor on the same bytes.
TEST(ConvertToLuma, RgbAndBgrEqualOpenCvCvtColor) {
  const int width = 631, height = 479;
  const size_t bytes_per_line = 3 * width + 7;
  for (const auto& [format, code] : std::vector<std::pair<CameraPixelFormat, int>>{{CameraPixelFormat::rgb888, cv::COLOR_RGB2GRAY},
                                                                                  {CameraPixelFormat::bgr888, cv::COLOR_BGR2GRAY}}) {
    const GuardedBuffer buffer(pixel_format_min_buffer_bytes(format, width, height, bytes_per_line), 90);
    const cv::Mat frame(height, width, CV_8UC3, buffer.data(), bytes_per_line);
    cv::Mat expected;
    cv::cvtColor(frame, expected, code);
    for (simd::Isa isa : simd::available_isas()) {
      simd::ActiveIsaScope scope(isa);
      Plane luma(width, height, kU8);
      convert_to_luma(format, buffer.data(), bytes_per_line, width, height, luma);
      int differing = 0;
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) differing += luma.at<uint8_t>(x, y) != expected.at<uint8_t>(y, x);
      }
      EXPECT_EQ(differing, 0) << pixel_format_name(format) << " on " << simd::isa_name(isa) << ": pixels unlike cv::cvtColor";
    }
  }
}
#endif

}  // namespace
}  // namespace lpstereo::io
