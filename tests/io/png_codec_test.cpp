// PNG read and written with libpng (io/png_codec.h) against OpenCV's imread and imwrite, the codec
// it replaces: every PNG colour type and bit depth (written here with libpng, as other tools write
// them: palettes with and without transparency, grey with a tRNS chunk, 1/2/4-bit grey, Adam7
// interlacing), every imread flag lpstereo uses, at odd sizes; the files it writes byte for byte;
// bad files refused with one message naming the file; other formats through the codecs module.
#include <gtest/gtest.h>

#include <png.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "dag/atomic_file.h"
#include "io/image_io.h"
#include "io/png_codec.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

constexpr int kWidth = 37;
constexpr int kHeight = 11;

// What a test file holds: its IHDR fields and optional chunks.
struct PngKind {
  int colour_type;
  int bit_depth;
  bool transparency;  // a tRNS chunk (palette: per-entry alpha; grey / RGB: one transparent value)
  bool interlaced;
  std::string name() const {
    return "colour type " + std::to_string(colour_type) + ", " + std::to_string(bit_depth) + " bits" +
           (transparency ? ", tRNS" : "") + (interlaced ? ", Adam7" : "");
  }
};

int channels_of(int colour_type) {
  switch (colour_type) {
    case PNG_COLOR_TYPE_GRAY_ALPHA: return 2;
    case PNG_COLOR_TYPE_RGB: return 3;
    case PNG_COLOR_TYPE_RGB_ALPHA: return 4;
    default: return 1;  // grey, palette indices
  }
}

// Writes a kWidth x kHeight PNG of random samples with libpng (no transformations: the bytes are
// the file's). Returns false when libpng refuses the kind. Everything is prepared before the setjmp,
// so nothing it guards is modified after it (a longjmp would leave such a variable indeterminate).
bool write_test_png(const std::string& path, const PngKind& kind, uint32_t seed) {
  const int channels = channels_of(kind.colour_type);
  const size_t row_bytes = (static_cast<size_t>(kWidth) * channels * kind.bit_depth + 7) / 8;
  std::vector<png_byte> pixels(row_bytes * kHeight);
  std::mt19937 random(seed);
  for (png_byte& byte : pixels) byte = static_cast<png_byte>(random());
  const int palette_entries = kind.bit_depth == 8 ? 200 : 1 << std::min(kind.bit_depth, 8);
  if (kind.colour_type == PNG_COLOR_TYPE_PALETTE && kind.bit_depth == 8) {
    for (png_byte& byte : pixels) byte = static_cast<png_byte>(byte % palette_entries);
  }
  std::vector<png_bytep> rows(kHeight);
  for (int y = 0; y < kHeight; ++y) rows[static_cast<size_t>(y)] = pixels.data() + row_bytes * y;
  std::vector<png_color> palette;
  std::vector<png_byte> alphas;
  for (int i = 0; i < palette_entries; ++i) {
    palette.push_back({static_cast<png_byte>(random()), static_cast<png_byte>(random()), static_cast<png_byte>(random())});
    alphas.push_back(static_cast<png_byte>(random()));
  }
  png_color_16 transparent{};
  const int maximum = (1 << std::min(kind.bit_depth, 16)) - 1;
  transparent.gray = transparent.red = transparent.green = transparent.blue = static_cast<png_uint_16>(pixels[0] & maximum);

  FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) return false;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_write_struct(&png, &info);
    std::fclose(file);
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, kWidth, kHeight, kind.bit_depth, kind.colour_type, kind.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (kind.colour_type == PNG_COLOR_TYPE_PALETTE) {
    png_set_PLTE(png, info, palette.data(), palette_entries);
    if (kind.transparency) png_set_tRNS(png, info, alphas.data(), palette_entries, nullptr);
  } else if (kind.transparency) {
    png_set_tRNS(png, info, nullptr, 0, &transparent);
  }
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return std::fclose(file) == 0;
}

class PngCodec : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  testing::ScratchDirectory scratch_{"lpstereo_png_codec"};
};

void expect_same_image(const cv::Mat& actual, const cv::Mat& expected, const std::string& what) {
  ASSERT_FALSE(expected.empty()) << what;
  ASSERT_EQ(actual.type(), expected.type()) << what;
  ASSERT_EQ(actual.size(), expected.size()) << what;
  for (int y = 0; y < expected.rows; ++y) {
    ASSERT_EQ(std::memcmp(actual.ptr(y), expected.ptr(y), expected.cols * expected.elemSize()), 0) << what << ", row " << y;
  }
}

std::string file_bytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

TEST_F(PngCodec, DecodesEveryColourTypeAndDepthAsImreadDoes) {
  std::vector<PngKind> kinds;
  for (int depth : {1, 2, 4, 8, 16}) kinds.push_back({PNG_COLOR_TYPE_GRAY, depth, false, false});
  for (int depth : {1, 2, 4, 8}) kinds.push_back({PNG_COLOR_TYPE_PALETTE, depth, false, false});
  for (int depth : {8, 16}) {
    kinds.push_back({PNG_COLOR_TYPE_GRAY_ALPHA, depth, false, false});
    kinds.push_back({PNG_COLOR_TYPE_RGB, depth, false, false});
    kinds.push_back({PNG_COLOR_TYPE_RGB_ALPHA, depth, false, false});
    kinds.push_back({PNG_COLOR_TYPE_GRAY, depth, true, false});
    kinds.push_back({PNG_COLOR_TYPE_RGB, depth, true, false});
  }
  kinds.push_back({PNG_COLOR_TYPE_PALETTE, 8, true, false});
  kinds.push_back({PNG_COLOR_TYPE_PALETTE, 4, true, true});
  kinds.push_back({PNG_COLOR_TYPE_RGB, 16, false, true});
  kinds.push_back({PNG_COLOR_TYPE_GRAY, 1, false, true});
  const int flag_sets[] = {cv::IMREAD_UNCHANGED, cv::IMREAD_GRAYSCALE, cv::IMREAD_COLOR, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR,
                           cv::IMREAD_ANYDEPTH, cv::IMREAD_ANYCOLOR};
  uint32_t seed = 1;
  for (const PngKind& kind : kinds) {
    const std::string file = path("kind.png");
    ASSERT_TRUE(write_test_png(file, kind, seed++)) << kind.name();
    ASSERT_TRUE(has_png_signature(file));
    for (const int flags : flag_sets) {
      const std::string what = kind.name() + ", imread flags " + std::to_string(flags);
      expect_same_image(decode_png(file, flags), cv::imread(file, flags), what);
      expect_same_image(decode_image(file, flags), cv::imread(file, flags), what + " (decode_image)");
    }
  }
}

TEST_F(PngCodec, WritesTheFilesImwriteWrites) {
  std::mt19937 random(7);
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3, CV_16UC4}) {
    cv::Mat image(kHeight, kWidth, type);
    cv::randu(image, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
    // A view into a wider matrix: rows with padding between them, as planes have.
    cv::Mat wide(kHeight, kWidth + 5, type);
    image.copyTo(wide(cv::Rect(0, 0, kWidth, kHeight)));
    const cv::Mat view = wide(cv::Rect(0, 0, kWidth, kHeight));
    const std::string ours = path("ours.png"), theirs = path("theirs.png");
    ASSERT_TRUE(encode_png(ours, view));
    ASSERT_TRUE(cv::imwrite(theirs, image));
    const std::string what = "type " + std::to_string(type);
    EXPECT_EQ(file_bytes(ours), file_bytes(theirs)) << what;
    expect_same_image(decode_png(ours, cv::IMREAD_UNCHANGED), image, what + ", read back");
    write_image(path("atomic.png"), view);
    EXPECT_EQ(file_bytes(path("atomic.png")), file_bytes(theirs)) << what;
  }
}

TEST_F(PngCodec, RefusesWhatPngCannotHoldNamingTheFile) {
  const std::string file = path("x.png");
  for (const int type : {CV_8SC1, CV_16SC1, CV_32FC1, CV_8UC2}) {
    try {
      (void)encode_png(file, cv::Mat(3, 3, type, cv::Scalar(0)));
      ADD_FAILURE() << "type " << type << " written";
    } catch (const ImageError& error) {
      EXPECT_EQ(std::string(error.what()).rfind(file + ": PNG ", 0), 0u) << error.what();
    }
  }
  EXPECT_THROW((void)encode_png(file, cv::Mat()), ImageError);
  EXPECT_FALSE(encode_png(path("no_such_directory/x.png"), cv::Mat(3, 3, CV_8UC1, cv::Scalar(0))));
  EXPECT_THROW(write_image(path("no_such_directory/x.png"), cv::Mat(3, 3, CV_8UC1, cv::Scalar(0))), FileWriteError);
}

TEST_F(PngCodec, RefusesTruncatedAndCorruptFilesNamingThem) {
  const std::string whole = path("whole.png");
  ASSERT_TRUE(write_test_png(whole, {PNG_COLOR_TYPE_RGB, 8, false, false}, 3));
  const std::string bytes = file_bytes(whole);
  const std::string cases[][2] = {{"header_only.png", bytes.substr(0, 40)},
                                  {"half.png", bytes.substr(0, bytes.size() / 2)},
                                  {"signature_only.png", bytes.substr(0, 8)},
                                  {"flipped.png", bytes.substr(0, 60) + std::string(1, static_cast<char>(bytes[60] ^ 0x5A)) + bytes.substr(61)}};
  for (const auto& [name, content] : cases) {
    std::ofstream(path(name), std::ios::binary) << content;
    try {
      decode_image(path(name), cv::IMREAD_COLOR);
      ADD_FAILURE() << name << " decoded";
    } catch (const ImageError& error) {
      const std::string message = error.what();
      EXPECT_EQ(message.rfind(path(name) + ": cannot decode as PNG: ", 0), 0u) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
  EXPECT_FALSE(has_png_signature(path("no_such.png")));
}

TEST_F(PngCodec, OtherFormatsGoThroughTheCodecsModule) {
  cv::Mat image(kHeight, kWidth, CV_8UC3);
  cv::randu(image, 0, 256);
  write_image(path("picture.ppm"), image);
  expect_same_image(decode_image(path("picture.ppm"), cv::IMREAD_COLOR), cv::imread(path("picture.ppm"), cv::IMREAD_COLOR), "PPM");
  expect_same_image(decode_image(path("picture.ppm"), cv::IMREAD_COLOR), image, "PPM read back");
  try {
    write_image(path("picture.unknown_extension"), image);
    ADD_FAILURE() << "written with no encoder";
  } catch (const ImageError& error) {
    EXPECT_EQ(std::string(error.what()).rfind(path("picture.unknown_extension") + ": cannot encode", 0), 0u) << error.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path("picture.unknown_extension")));
}

}  // namespace
}  // namespace lpstereo::io
