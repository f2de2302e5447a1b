// Disparity files: KITTI PNG, PFM and raw s16 written then read back equal; the KITTI fill; and bad
// files refused with one message naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "io/disparity_io.h"
#include "io/image_io.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

namespace fs = std::filesystem;
constexpr float kInf = std::numeric_limits<float>::infinity();

class DisparityFiles : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  void write_bytes(const std::string& name, const std::string& bytes) const {
    std::ofstream(path(name), std::ios::binary) << bytes;
  }
  testing::ScratchDirectory scratch_{"lpstereo_disparity_io"};
};

// An odd-sized s16q4 map with fractional values, negative values, zeros and invalid pixels.
Plane random_q4(int width, int height, int min_disparity_px, uint32_t seed, bool allow_negative) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> value(allow_negative ? -64 * 16 : 0, 200 * 16 + 15);
  std::uniform_int_distribution<int> percent(0, 99);
  Plane plane(width, height, {ElementType::s16, 4});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      plane.at<int16_t>(x, y) = percent(random) < 10 ? invalid_disparity_q4(min_disparity_px) : static_cast<int16_t>(value(random));
    }
  }
  plane.at<int16_t>(0, 0) = 0;
  return plane;
}

void expect_equal_q4(const Plane& expected, const Plane& actual) {
  ASSERT_EQ(actual.width(), expected.width());
  ASSERT_EQ(actual.height(), expected.height());
  int mismatches = 0;
  for (int y = 0; y < expected.height(); ++y) {
    for (int x = 0; x < expected.width(); ++x) {
      if (expected.at<int16_t>(x, y) != actual.at<int16_t>(x, y) && ++mismatches <= 5) {
        ADD_FAILURE() << "at (" << x << ", " << y << "): expected " << expected.at<int16_t>(x, y) << ", got "
                      << actual.at<int16_t>(x, y);
      }
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST_F(DisparityFiles, KittiPngRoundTripIsExactForNonNegativeQ4) {
  const Plane written = random_q4(37, 23, 0, 1, false);
  write_kitti_disparity_png(path("d.png"), written, 0);
  expect_equal_q4(written, read_kitti_disparity_png(path("d.png")));
  // The float reader gives value / 256 exactly, +inf where 0.
  const cv::Mat px = read_kitti_disparity_png_px(path("d.png"));
  EXPECT_EQ(px.at<float>(0, 1), written.at<int16_t>(1, 0) == -16 ? kInf : written.at<int16_t>(1, 0) / 16.0f);
}

TEST_F(DisparityFiles, PfmRoundTripIsExactAndKeepsInfinity) {
  for (int min_disparity_px : {0, -40}) {
    const Plane written = random_q4(41, 19, min_disparity_px, 2, true);
    const cv::Mat px = disparity_q4_to_px(written, min_disparity_px);
    EXPECT_EQ(px.at<float>(0, 0), 0.0f);
    write_pfm(path("d.pfm"), px);
    const cv::Mat read = read_pfm(path("d.pfm"));
    ASSERT_EQ(read.size(), px.size());
    for (int y = 0; y < px.rows; ++y) {
      for (int x = 0; x < px.cols; ++x) {
        ASSERT_TRUE(read.at<float>(y, x) == px.at<float>(y, x)) << x << "," << y << " min " << min_disparity_px;
      }
    }
    expect_equal_q4(written, disparity_px_to_q4(read, min_disparity_px));
  }
}

TEST_F(DisparityFiles, PfmRowsAreBottomToTopAndScaleSignSelectsEndianness) {
  // 2x2, rows stored bottom first: bottom row (1, 2), top row (3, +inf); once little-, once big-endian.
  const float samples[4] = {1.0f, 2.0f, 3.0f, kInf};
  for (bool little : {true, false}) {
    std::string bytes = std::string("Pf\n2 2\n") + (little ? "-1.0\n" : "1.0\n");
    for (float sample : samples) {
      char raw[4];
      std::memcpy(raw, &sample, 4);  // this host is little-endian (x86-64, aarch64)
      if (!little) std::reverse(raw, raw + 4);
      bytes.append(raw, 4);
    }
    write_bytes("e.pfm", bytes);
    const cv::Mat read = read_pfm(path("e.pfm"));
    EXPECT_EQ(read.at<float>(1, 0), 1.0f) << (little ? "little" : "big");
    EXPECT_EQ(read.at<float>(1, 1), 2.0f);
    EXPECT_EQ(read.at<float>(0, 0), 3.0f);
    EXPECT_EQ(read.at<float>(0, 1), kInf);
  }
  // The writer: little-endian, scale -1, bottom row first.
  write_pfm(path("w.pfm"), read_pfm(path("e.pfm")));
  std::ifstream file(path("w.pfm"), std::ios::binary);
  const std::string content((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  ASSERT_EQ(content.size(), std::string("Pf\n2 2\n-1\n").size() + 16);
  EXPECT_EQ(content.rfind("Pf\n2 2\n-1\n", 0), 0u);
  float first = 0;
  std::memcpy(&first, content.data() + 10, 4);
  EXPECT_EQ(first, 1.0f);
}

TEST_F(DisparityFiles, S16RawRoundTripAndLayout) {
  const Plane written = random_q4(33, 17, -8, 3, true);
  write_s16_raw(path("d.s16"), written);
  EXPECT_EQ(fs::file_size(path("d.s16")), 2u * 33 * 17);
  expect_equal_q4(written, read_s16_raw(path("d.s16"), 33, 17));
  // Little-endian, row-major, no header: sample (1, 0) is bytes 2..3.
  std::ifstream file(path("d.s16"), std::ios::binary);
  unsigned char bytes[4];
  file.read(reinterpret_cast<char*>(bytes), 4);
  EXPECT_EQ(static_cast<int16_t>(bytes[2] | (bytes[3] << 8)), written.at<int16_t>(1, 0));
}

void expect_error(const std::function<void()>& action, const std::string& expected_start) {
  try {
    action();
    ADD_FAILURE() << "no error; expected one starting with: " << expected_start;
  } catch (const ImageError& error) {
    EXPECT_EQ(std::string(error.what()).rfind(expected_start, 0), 0u) << error.what();
    EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos) << error.what();
  }
}

TEST_F(DisparityFiles, BadFilesGiveOneMessageNamingTheFile) {
  write_bytes("garbage.png", "not a png");
  write_bytes("garbage.pfm", "P6\n2 2\n255\n");
  write_bytes("colour.pfm", "PF\n2 2\n-1\n");
  write_bytes("noscale.pfm", "Pf\n2 2\nx\n");
  write_bytes("truncated.pfm", std::string("Pf\n4 3\n-1\n") + std::string(20, '\0'));
  write_bytes("odd.s16", std::string(7, '\0'));
  cv::imwrite(path("eight_bit.png"), cv::Mat(4, 4, CV_8UC1, cv::Scalar(9)));
  expect_error([&] { read_kitti_disparity_png(path("missing.png")); }, path("missing.png") + ": no such file");
  expect_error([&] { read_kitti_disparity_png(path("garbage.png")); }, path("garbage.png") + ": cannot decode");
  expect_error([&] { read_kitti_disparity_png(path("eight_bit.png")); },
               path("eight_bit.png") + ": expected a 16-bit single-channel KITTI disparity PNG, got 1 channel(s) of 8-bit");
  expect_error([&] { read_pfm(path("missing.pfm")); }, path("missing.pfm") + ": no such file");
  expect_error([&] { read_pfm(path("garbage.pfm")); }, path("garbage.pfm") + ": expected a PFM file starting with \"Pf\", got \"P6\"");
  expect_error([&] { read_pfm(path("colour.pfm")); }, path("colour.pfm") + ": expected a greyscale PFM");
  expect_error([&] { read_pfm(path("noscale.pfm")); }, path("noscale.pfm") + ": corrupt PFM header: expected a non-zero scale");
  expect_error([&] { read_pfm(path("truncated.pfm")); },
               path("truncated.pfm") + ": truncated PFM: expected 48 bytes of float data for 4x3, got 20");
  expect_error([&] { read_s16_raw(path("odd.s16"), 2, 2); }, path("odd.s16") + ": s16 raw: expected 8 bytes for 2x2, got 7");
  expect_error([&] { read_s16_raw(path("missing.s16"), 2, 2); }, path("missing.s16") + ": no such file");
  // Writers leave nothing behind when the folder does not exist.
  EXPECT_THROW(write_pfm(path("no/dir/x.pfm"), cv::Mat(2, 2, CV_32FC1, cv::Scalar(1))), std::exception);
  EXPECT_THROW(write_s16_raw(path("no/dir/x.s16"), Plane(2, 2, {ElementType::s16, 4})), std::exception);
}

// One row through the fill, with -16 (min disparity 0) as the invalid value; values in Q4.
std::vector<int16_t> filled_row(const std::vector<int16_t>& row) {
  Plane plane(static_cast<int>(row.size()), 1, {ElementType::s16, 4});
  for (size_t x = 0; x < row.size(); ++x) plane.at<int16_t>(static_cast<int>(x), 0) = row[x];
  fill_invalid_kitti(plane, -16);
  std::vector<int16_t> result(row.size());
  for (size_t x = 0; x < row.size(); ++x) result[x] = plane.at<int16_t>(static_cast<int>(x), 0);
  return result;
}

TEST(KittiFill, InteriorGapsTakeTheLowerNeighbourAndEndsExtrapolate) {
  constexpr int16_t I = -16;
  EXPECT_EQ(filled_row({I, I, 80, I, I, 32, 48, I, 160, I}),
            (std::vector<int16_t>{80, 80, 80, 32, 32, 32, 48, 48, 160, 160}));
  EXPECT_EQ(filled_row({I, 0, I, 16}), (std::vector<int16_t>{0, 0, 0, 16}));  // 0 px is a valid value here
  EXPECT_EQ(filled_row({I, I, I}), (std::vector<int16_t>{I, I, I}));           // nothing to fill from
}

TEST(KittiFill, ColumnsExtrapolateUpAndDownButInteriorEmptyRowsStayInvalid) {
  constexpr int16_t I = -16;
  Plane plane(3, 4, {ElementType::s16, 4});
  const int16_t rows[4][3] = {{I, I, I}, {10, I, 30}, {I, I, I}, {I, 50, I}};
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 3; ++x) plane.at<int16_t>(x, y) = rows[y][x];
  }
  fill_invalid_kitti(plane, I);
  // As in the devkit, the column pass only extrapolates above the first and below the last valid
  // pixel of each column; an empty row between two filled rows stays invalid.
  const int16_t expected[4][3] = {{10, 10, 30}, {10, 10, 30}, {I, I, I}, {50, 50, 50}};
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 3; ++x) EXPECT_EQ(plane.at<int16_t>(x, y), expected[y][x]) << x << "," << y;
  }
}

}  // namespace
}  // namespace lpstereo::io
