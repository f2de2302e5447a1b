// The dataset loaders on tiny scenes the test writes itself, one per encoding (palette PNG, scaled
// 8-bit PNG, PFM, KITTI 16-bit); the real data in ../shared/data is not needed.
#include <gtest/gtest.h>

#include <zlib.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "io/disparity_io.h"
#include "io/image_io.h"
#include "io/stereo_datasets.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

namespace fs = std::filesystem;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int kWidth = 24;
constexpr int kHeight = 8;

void put_u32(std::string& out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((value >> shift) & 0xFF));
}

void put_chunk(std::string& out, const std::string& type, const std::string& data) {
  put_u32(out, static_cast<uint32_t>(data.size()));
  const std::string body = type + data;
  out += body;
  put_u32(out, static_cast<uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
}

// An 8-bit palette PNG (colour type 3): pixel = index, palette entry i = `palette_grey[i]` as grey.
// OpenCV cannot write one; the Middlebury tsukuba ground truth is one.
void write_palette_png(const std::string& path, const cv::Mat& indices, const std::vector<uint8_t>& palette_grey) {
  std::string png = "\x89PNG\r\n\x1a\n";
  std::string header;
  put_u32(header, static_cast<uint32_t>(indices.cols));
  put_u32(header, static_cast<uint32_t>(indices.rows));
  header += std::string("\x08\x03\x00\x00\x00", 5);  // 8 bits, palette, deflate, filter 0, no interlace
  put_chunk(png, "IHDR", header);
  std::string palette;
  for (uint8_t grey : palette_grey) palette += std::string(3, static_cast<char>(grey));
  put_chunk(png, "PLTE", palette);
  std::string raw;
  for (int y = 0; y < indices.rows; ++y) {
    raw.push_back('\0');  // filter: none
    raw.append(reinterpret_cast<const char*>(indices.ptr<uint8_t>(y)), static_cast<size_t>(indices.cols));
  }
  uLongf compressed_size = compressBound(static_cast<uLong>(raw.size()));
  std::string compressed(compressed_size, '\0');
  ASSERT_EQ(compress(reinterpret_cast<Bytef*>(compressed.data()), &compressed_size, reinterpret_cast<const Bytef*>(raw.data()),
                     static_cast<uLong>(raw.size())),
            Z_OK);
  compressed.resize(compressed_size);
  put_chunk(png, "IDAT", compressed);
  put_chunk(png, "IEND", "");
  std::ofstream(path, std::ios::binary) << png;
}

class StereoDatasets : public ::testing::Test {
 protected:
  std::string folder(const std::string& name) const {
    fs::create_directories(root_ / name);
    return (root_ / name).string();
  }
  static std::string in(const std::string& directory, const std::string& name) { return (fs::path(directory) / name).string(); }
  static void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }
  // Colour views (BGR), so the loaders' luma conversion is exercised too.
  static void write_views(const std::string& left, const std::string& right) {
    cv::Mat view(kHeight, kWidth, CV_8UC3, cv::Scalar(10, 200, 30));
    cv::imwrite(left, view);
    cv::imwrite(right, view);
  }
  testing::ScratchDirectory scratch_{"lpstereo_datasets"};
  const fs::path& root_ = scratch_.root();
};

TEST_F(StereoDatasets, Middlebury2003DecodesThePaletteAndDividesByInfoTxt) {
  const std::string scene = folder("middlebury2003/tsukuba");
  write_views(in(scene, "imL.png"), in(scene, "imR.png"));
  write_text(in(scene, "info.txt"), "16\n15");
  // Palette index i -> grey 16 * i, so index 14 is 224 = 14 px at divisor 16; index 0 is unknown.
  cv::Mat indices(kHeight, kWidth, CV_8UC1, cv::Scalar(14));
  indices.at<uint8_t>(0, 0) = 0;
  indices.at<uint8_t>(1, 1) = 5;  // 80 / 16 = 5 px
  std::vector<uint8_t> palette;
  for (int i = 0; i < 16; ++i) palette.push_back(static_cast<uint8_t>(16 * i));
  write_palette_png(in(scene, "groundtruth.png"), indices, palette);
  cv::Mat all(kHeight, kWidth, CV_8UC1, cv::Scalar(255));
  all.at<uint8_t>(2, 2) = 0;  // outside the evaluated region
  cv::imwrite(in(scene, "all.png"), all);
  cv::Mat nonocc = all.clone();
  nonocc.at<uint8_t>(3, 3) = 0;
  cv::imwrite(in(scene, "nonocc.png"), nonocc);

  const StereoPair pair = load_middlebury2003_scene(scene);
  EXPECT_EQ(pair.name, "tsukuba");
  EXPECT_EQ(pair.left.width(), kWidth);
  EXPECT_EQ(pair.left.at<uint8_t>(0, 0), cv::saturate_cast<uint8_t>(0.299 * 30 + 0.587 * 200 + 0.114 * 10));
  EXPECT_EQ(pair.ground_truth_px.at<float>(4, 4), 14.0f);
  EXPECT_EQ(pair.ground_truth_px.at<float>(1, 1), 5.0f);
  EXPECT_EQ(pair.ground_truth_px.at<float>(0, 0), kInf);
  EXPECT_EQ(pair.ground_truth_px.at<float>(2, 2), kInf);
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(3, 3), 0);
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(4, 4), 255);
  EXPECT_EQ(pair.num_disparities, 16);  // info.txt 15, rounded up to a multiple of 16
  EXPECT_EQ(pair.range_source, "info.txt ndisp = 15, raised to cover the ground truth and rounded up to a multiple of 16");
}

TEST_F(StereoDatasets, Middlebury2005HalvesEightBitTruthAndDerivesNonoccFromBothViews) {
  const std::string scene = folder("middlebury2005/Cloth3");
  write_views(in(scene, "view1.png"), in(scene, "view5.png"));
  write_text(in(scene, "drange.txt"), "dmin=0\ndmax=128\n");
  cv::Mat left(kHeight, kWidth, CV_8UC1, cv::Scalar(8));   // 4 px
  cv::Mat right(kHeight, kWidth, CV_8UC1, cv::Scalar(8));
  left.at<uint8_t>(0, 10) = 13;                            // 6.5 px -> right x = 3.5 -> 4 (lround)
  right.at<uint8_t>(1, 6) = 20;                            // left (1, 10) at 4 px sees 10 px there: occluded
  cv::imwrite(in(scene, "disp1.png"), left);
  cv::imwrite(in(scene, "disp5.png"), right);
  const StereoPair pair = load_middlebury2005_scene(scene);
  EXPECT_EQ(pair.ground_truth_px.at<float>(0, 10), 6.5f);
  EXPECT_EQ(pair.ground_truth_px.at<float>(0, 11), 4.0f);
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(0, 11), 255);
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(1, 10), 0);   // right view disagrees by 6 px
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(0, 10), 0);   // 6.5 vs 4 at x = 4
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(0, 2), 0);    // x - d < 0: not visible in the right view
  EXPECT_EQ(pair.num_disparities, 128);
  EXPECT_EQ(pair.range_source, "drange.txt dmax = 128");
}

TEST_F(StereoDatasets, Middlebury2014ReadsPfmMaskAndCalibNdisp) {
  const std::string scene = folder("middlebury2014/Motorcycle");
  write_views(in(scene, "im0.png"), in(scene, "im1.png"));
  write_text(in(scene, "calib.txt"), "cam0=[1 0 0; 0 1 0; 0 0 1]\ndoffs=3\nbaseline=193.001\nndisp=70\nvmin=7\n");
  cv::Mat truth(kHeight, kWidth, CV_32FC1, cv::Scalar(9.25));
  truth.at<float>(7, 0) = kInf;
  write_pfm(in(scene, "disp0GT.pfm"), truth);
  cv::Mat mask(kHeight, kWidth, CV_8UC1, cv::Scalar(255));
  mask.at<uint8_t>(5, 5) = 128;  // occluded
  cv::imwrite(in(scene, "mask0nocc.png"), mask);
  const StereoPair pair = load_middlebury2014_scene(scene);
  EXPECT_EQ(pair.ground_truth_px.at<float>(0, 0), 9.25f);
  EXPECT_EQ(pair.ground_truth_px.at<float>(7, 0), kInf);
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(5, 5), 0);
  EXPECT_EQ(pair.nonocc_mask.at<uint8_t>(5, 6), 255);
  EXPECT_EQ(pair.num_disparities, 80);
}

TEST_F(StereoDatasets, Kitti2015ReadsSixteenBitTruthAndHasNoNonoccMask) {
  const std::string kitti = folder("kitti2015");
  fs::create_directories(fs::path(kitti) / "image_2");
  fs::create_directories(fs::path(kitti) / "image_3");
  fs::create_directories(fs::path(kitti) / "disp_occ_0");
  write_views(in(kitti, "image_2/000046_10.png"), in(kitti, "image_3/000046_10.png"));
  cv::Mat truth(kHeight, kWidth, CV_16UC1, cv::Scalar(0));
  truth.at<uint16_t>(3, 4) = 1247;  // 4.87109375 px
  cv::imwrite(in(kitti, "disp_occ_0/000046_10.png"), truth);
  const StereoPair pair = load_kitti2015_frame(kitti);
  EXPECT_EQ(pair.name, "000046");
  EXPECT_EQ(pair.ground_truth_px.at<float>(3, 4), 1247.0f / 256.0f);
  EXPECT_EQ(pair.ground_truth_px.at<float>(0, 0), kInf);
  EXPECT_TRUE(pair.nonocc_mask.empty());
  EXPECT_EQ(pair.num_disparities, 128);
}

TEST_F(StereoDatasets, RangeCoversTheGroundTruthWhenTheSetsFigureDoesNot) {
  cv::Mat truth(2, 2, CV_32FC1, cv::Scalar(kInf));
  truth.at<float>(0, 0) = 19.75f;  // venus: info.txt says 19
  EXPECT_EQ(search_range_px(19, truth), 32);
  EXPECT_EQ(search_range_px(64, truth), 64);
  EXPECT_EQ(search_range_px(65, truth), 80);
}

TEST_F(StereoDatasets, MissingFilesAndSizeMismatchesNameTheFile) {
  const std::string scene = folder("middlebury2014/Motorcycle");
  write_views(in(scene, "im0.png"), in(scene, "im1.png"));
  try {
    load_middlebury2014_scene(scene);
    FAIL() << "no error";
  } catch (const ImageError& error) {
    EXPECT_EQ(std::string(error.what()), in(scene, "disp0GT.pfm") + ": no such file");
  }
  write_pfm(in(scene, "disp0GT.pfm"), cv::Mat(3, 3, CV_32FC1, cv::Scalar(1)));
  try {
    load_middlebury2014_scene(scene);
    FAIL() << "no error";
  } catch (const ImageError& error) {
    EXPECT_EQ(std::string(error.what()), in(scene, "disp0GT.pfm") + ": expected 24x8 (the left view's size), got 3x3");
  }
  try {
    load_middlebury_pairs((root_ / "nowhere").string());
    FAIL() << "no error";
  } catch (const ImageError& error) {
    EXPECT_EQ(std::string(error.what()), (root_ / "nowhere").string() + ": no such data folder");
  }
}

TEST(SharedDataDirectory, FlagThenEnvironmentThenDefault) {
  ::setenv("LPSTEREO_SHARED_DATA", "/from/env", 1);
  EXPECT_EQ(shared_data_directory("/from/flag"), "/from/flag");
  EXPECT_EQ(shared_data_directory(), "/from/env");
  ::unsetenv("LPSTEREO_SHARED_DATA");
  EXPECT_EQ(shared_data_directory(), "../shared/data");
}

}  // namespace
}  // namespace lpstereo::io
