// lpstereo points as a user meets it: a rendered pair of a fronto-parallel plane with a Middlebury
// calib.txt (rectified already) comes back as a PLY cloud at the plane's depth, with the left
// image's colours, in both encodings and with Middlebury's doffs; bad input gives one line, a
// non-zero exit and no file.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/synthetic_scene.h"
#include "tests/support/cli_runner.h"
#include "tests/support/ply_reader.h"
#include "tests/support/scratch_directory.h"

namespace {

namespace fs = std::filesystem;
using lpstereo::testing::Result;
using lpstereo::testing::count_lines;
using lpstereo::testing::run;

class PointsCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_points_cli"};
};

constexpr int kWidth = 192, kHeight = 128;

// A colour texture (the scene's value noise per channel) and its view shifted left by `shift_px`:
// a fronto-parallel plane with disparity shift_px in every pixel.
void write_pair(const std::string& left_path, const std::string& right_path, int shift_px) {
  cv::Mat left(kHeight, kWidth, CV_8UC3), right(kHeight, kWidth, CV_8UC3);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      for (int c = 0; c < 3; ++c) {
        auto grey = [&](int x) {
          return cv::saturate_cast<uint8_t>(lpstereo::io::synthetic_texture_grey(x, v, 11u + static_cast<uint32_t>(c), 128.0));
        };
        left.at<cv::Vec3b>(v, u)[c] = grey(u);
        right.at<cv::Vec3b>(v, u)[c] = grey(u + shift_px);
      }
    }
  }
  ASSERT_TRUE(cv::imwrite(left_path, left));
  ASSERT_TRUE(cv::imwrite(right_path, right));
}

void write_middlebury(const std::string& file, double doffs_px, int width = kWidth) {
  std::ofstream(file) << "cam0=[700 0 96.5; 0 700 64.25; 0 0 1]\ncam1=[700 0 " << 96.5 + doffs_px
                      << "; 0 700 64.25; 0 0 1]\ndoffs=" << doffs_px << "\nbaseline=120\nwidth=" << width
                      << "\nheight=" << kHeight << "\nndisp=64\n";
}

double median_z(const lpstereo::testing::PlyFile& file) {
  std::vector<double> depths;
  for (const auto& vertex : file.vertices) depths.push_back(vertex.z);
  std::nth_element(depths.begin(), depths.begin() + static_cast<ptrdiff_t>(depths.size() / 2), depths.end());
  return depths[depths.size() / 2];
}

TEST_F(PointsCli, WritesTheCloudOfARenderedPlaneAtItsDepth) {
  write_pair(path("l.png"), path("r.png"), 20);  // d = 20 px: Z = 700 px * 0.12 m / 20 px = 4.2 m
  write_middlebury(path("calib.txt"), 0.0);
  const Result binary = run("points " + path("l.png") + " " + path("r.png") + " --calib " + path("calib.txt") + " -o " +
                            path("cloud.ply"));
  ASSERT_EQ(binary.exit_code, 0) << binary.err;
  EXPECT_NE(binary.out.find("camera frame"), std::string::npos) << binary.out;
  const lpstereo::testing::PlyFile cloud = lpstereo::testing::read_ply(path("cloud.ply"));
  EXPECT_EQ(cloud.format, "binary_little_endian");
  EXPECT_GT(cloud.vertices.size(), kWidth * kHeight * 6 / 10);  // the left 64 columns cannot be matched
  EXPECT_LT(cloud.vertices.size(), kWidth * kHeight);            // only valid points
  EXPECT_NEAR(median_z(cloud), 4.2, 0.042);
  // Colours: some vertex is not grey (the image is in colour and its channels differ).
  EXPECT_TRUE(std::any_of(cloud.vertices.begin(), cloud.vertices.end(),
                          [](const auto& vertex) { return vertex.red != vertex.green || vertex.green != vertex.blue; }));

  const Result ascii = run("points " + path("l.png") + " " + path("r.png") + " --calib " + path("calib.txt") + " -o " +
                           path("cloud_ascii.ply") + " --ascii");
  ASSERT_EQ(ascii.exit_code, 0) << ascii.err;
  const lpstereo::testing::PlyFile ascii_cloud = lpstereo::testing::read_ply(path("cloud_ascii.ply"));
  EXPECT_EQ(ascii_cloud.format, "ascii");
  ASSERT_EQ(ascii_cloud.vertices.size(), cloud.vertices.size());
  for (size_t i = 0; i < cloud.vertices.size(); ++i) {
    ASSERT_EQ(ascii_cloud.vertices[i].z, cloud.vertices[i].z) << i;
    ASSERT_EQ(ascii_cloud.vertices[i].red, cloud.vertices[i].red) << i;
  }
}

// Middlebury's doffs: the same pair with doffs = 10 px is a plane at f B / (d + doffs) = 2.8 m; a
// vehicle mount 1.5 m up (level) puts it 2.8 m ahead (vehicle x).
TEST_F(PointsCli, UsesTheDisparityOffsetAndTheVehicleMount) {
  write_pair(path("l.png"), path("r.png"), 20);
  write_middlebury(path("calib.txt"), 10.0);
  const Result result = run("points " + path("l.png") + " " + path("r.png") + " --calib " + path("calib.txt") + " -o " +
                            path("cloud.ply") + " --position-m 0 0 1.5");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const lpstereo::testing::PlyFile cloud = lpstereo::testing::read_ply(path("cloud.ply"));
  ASSERT_FALSE(cloud.vertices.empty());
  EXPECT_NE(cloud.comments.at(0).find("vehicle frame (x forward, y left, z up)"), std::string::npos);
  std::vector<double> ahead;
  for (const auto& vertex : cloud.vertices) ahead.push_back(vertex.x);
  std::nth_element(ahead.begin(), ahead.begin() + static_cast<ptrdiff_t>(ahead.size() / 2), ahead.end());
  EXPECT_NEAR(ahead[ahead.size() / 2], 2.8, 0.028);
}

TEST_F(PointsCli, BadInputGivesOneLineAndNoFile) {
  write_pair(path("l.png"), path("r.png"), 20);
  write_middlebury(path("calib.txt"), 0.0);
  write_middlebury(path("other_size.txt"), 0.0, 320);
  cv::imwrite(path("small.png"), cv::Mat(kHeight, 100, CV_8UC1, cv::Scalar(50)));
  struct Bad {
    std::string arguments, needle;
  };
  const std::string pair = path("l.png") + " " + path("r.png");
  for (const Bad& bad : std::vector<Bad>{
           {pair + " --calib " + path("missing.txt"), "missing.txt"},
           {pair + " --calib " + path("other_size.txt"), "320x128"},
           {path("l.png") + " " + path("small.png") + " --calib " + path("calib.txt"), "image sizes differ"},
           {path("nothing.png") + " " + path("r.png") + " --calib " + path("calib.txt"), "nothing.png"},
       }) {
    const Result result = run("points " + bad.arguments + " -o " + path("cloud.ply"));
    EXPECT_EQ(result.exit_code, 1) << bad.arguments;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(bad.needle), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(path("cloud.ply"))) << bad.arguments;
  }
  // A folder that does not exist: the write fails, nothing is left.
  const Result unwritable = run("points " + pair + " --calib " + path("calib.txt") + " -o " + path("no/cloud.ply"));
  EXPECT_EQ(unwritable.exit_code, 1);
  EXPECT_EQ(count_lines(unwritable.err), 1) << unwritable.err;
  EXPECT_FALSE(fs::exists(path("no")));
  // --calib is required; angles without a position are refused.
  const Result no_calibration = run("points " + pair + " -o " + path("cloud.ply"));
  EXPECT_EQ(no_calibration.exit_code, 2);
  EXPECT_EQ(count_lines(no_calibration.err), 1) << no_calibration.err;
  const Result angles_only = run("points " + pair + " --calib " + path("calib.txt") + " -o " + path("cloud.ply") + " --pitch-rad 0.1");
  EXPECT_EQ(angles_only.exit_code, 2);
  EXPECT_NE(angles_only.err.find("--position-m"), std::string::npos) << angles_only.err;
  EXPECT_FALSE(fs::exists(path("cloud.ply")));
  // The search range, checked as `lpstereo disparity` checks it: a non-positive count is usage (2),
  // a range the image cannot hold is input (1).
  const std::string calibrated = "points " + pair + " --calib " + path("calib.txt") + " -o " + path("cloud.ply");
  const Result no_range = run(calibrated + " --num-disp 0");
  EXPECT_EQ(no_range.exit_code, 2) << no_range.err;
  EXPECT_EQ(no_range.err.rfind("lpstereo: --num-disp: expected a positive number, got 0", 0), 0u) << no_range.err;
  const Result too_wide = run(calibrated + " --min-disp 100 --num-disp 120");
  EXPECT_EQ(too_wide.exit_code, 1) << too_wide.err;
  EXPECT_EQ(count_lines(too_wide.err), 1) << too_wide.err;
  EXPECT_NE(too_wide.err.find("--min-disp + --num-disp: expected at most"), std::string::npos) << too_wide.err;
  EXPECT_FALSE(fs::exists(path("cloud.ply")));
}

}  // namespace
