// The camera commands as a user meets them: lpstereo rectify (the fixed-point kernel gives
// cv::remap's bits on the calibration's float maps), check-rectification (vertical offsets of
// matched features), calibrate (chessboard pairs rendered here with known intrinsics and pose:
// focal within 0.5 %, baseline within 1 %), and bad input: one line, exit 1, nothing written.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/calibration.h"
#include "io/disparity_io.h"
#include "io/image_io.h"
#include "io/rectification.h"
#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace {

using namespace lpstereo;
namespace fs = std::filesystem;
using lpstereo::testing::Result;
using lpstereo::testing::count_lines;
using lpstereo::testing::run;

class GeometryCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_geometry_cli"};
};

// Smooth random texture (blurred noise plus a few shapes): features for AKAZE, gradients for remap.
cv::Mat texture(int width, int height, uint32_t seed) {
  cv::Mat noise(height, width, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat image;
  cv::GaussianBlur(noise, image, cv::Size(0, 0), 1.5);
  cv::normalize(image, image, 0, 255, cv::NORM_MINMAX);
  for (int i = 0; i < 40; ++i) {
    cv::circle(image, {rng.uniform(0, width), rng.uniform(0, height)}, rng.uniform(3, 20), cv::Scalar(rng.uniform(0, 256)), -1);
  }
  return image;
}

// An unrectified OpenCV stereo calibration for width x height: distortion, a small rotation, 0.1 m.
void write_raw_calibration(const std::string& file, int width, int height, double cx_px) {
  cv::Mat rotation;
  cv::Rodrigues(cv::Vec3d(0.004, -0.01, 0.003), rotation);
  cv::FileStorage storage(file, cv::FileStorage::WRITE);
  storage << "image_width" << width << "image_height" << height;
  storage << "M1" << (cv::Mat_<double>(3, 3) << 300, 0, cx_px, 0, 301, height / 2.0, 0, 0, 1);
  storage << "D1" << (cv::Mat_<double>(1, 5) << -0.15, 0.03, 0.001, -0.0005, 0);
  storage << "M2" << (cv::Mat_<double>(3, 3) << 302, 0, cx_px + 2, 0, 302, height / 2.0 - 1, 0, 0, 1);
  storage << "D2" << (cv::Mat_<double>(1, 5) << -0.14, 0.025, 0, 0.0005, 0);
  storage << "R" << rotation << "T" << (cv::Mat_<double>(3, 1) << -0.1, 0.001, 0.0005);
}

TEST_F(GeometryCli, RectifyGivesCvRemapBitsOfTheCalibrationMaps) {
  const int width = 321, height = 243;
  ASSERT_TRUE(cv::imwrite(path("l.png"), texture(width, height, 1)));
  ASSERT_TRUE(cv::imwrite(path("r.png"), texture(width, height, 2)));
  write_raw_calibration(path("calib.yaml"), width, height, 160);
  const Result result = run("rectify " + path("l.png") + " " + path("r.png") + " --calib " + path("calib.yaml") + " -o " + path("out"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("baseline 0.100"), std::string::npos) << result.out;
  const io::RectificationMaps maps =
      io::compute_rectification_maps(io::load_stereo_calibration(path("calib.yaml")), width, height);
  for (int view = 0; view < 2; ++view) {
    const cv::Mat source = cv::imread(path(view == 0 ? "l.png" : "r.png"), cv::IMREAD_GRAYSCALE);
    cv::Mat expected;
    cv::remap(source, expected, view == 0 ? maps.left_x : maps.right_x, view == 0 ? maps.left_y : maps.right_y, cv::INTER_LINEAR,
              cv::BORDER_CONSTANT, cv::Scalar(0));
    const cv::Mat ours = cv::imread(path(view == 0 ? "out/left.png" : "out/right.png"), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(ours.type(), CV_8UC1);
    ASSERT_EQ(ours.size(), expected.size());
    EXPECT_EQ(cv::norm(ours, expected, cv::NORM_INF), 0) << "view " << view;
  }
  // An already rectified calibration (Middlebury) is the identity.
  std::ofstream(path("mb.txt")) << "cam0=[300 0 160; 0 300 121; 0 0 1]\ncam1=[300 0 170; 0 300 121; 0 0 1]\ndoffs=10\n"
                                   "baseline=100\nwidth=321\nheight=243\nndisp=32\n";
  ASSERT_EQ(run("rectify " + path("l.png") + " " + path("r.png") + " --calib " + path("mb.txt") + " -o " + path("id")).exit_code, 0);
  EXPECT_EQ(cv::norm(cv::imread(path("id/left.png"), cv::IMREAD_GRAYSCALE), cv::imread(path("l.png"), cv::IMREAD_GRAYSCALE),
                     cv::NORM_INF),
            0);
}

TEST_F(GeometryCli, RectifyRefusesBadInputWithOneLineAndWritesNothing) {
  ASSERT_TRUE(cv::imwrite(path("l.png"), texture(160, 120, 3)));
  ASSERT_TRUE(cv::imwrite(path("r.png"), texture(160, 120, 4)));
  ASSERT_TRUE(cv::imwrite(path("small.png"), texture(100, 120, 5)));
  write_raw_calibration(path("other_size.yaml"), 320, 240, 160);
  write_raw_calibration(path("outside.yaml"), 160, 120, 2000);  // principal point far right of the image
  std::ofstream(path("corrupt.yaml")) << "%YAML:1.0\nM1: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [ 1, 2\n";
  struct Bad {
    std::string arguments, needle;
  };
  const std::string pair = path("l.png") + " " + path("r.png");
  for (const Bad& bad : std::vector<Bad>{
           {pair + " --calib " + path("other_size.yaml"), "calibration is for 320x240 images, the images are 160x120"},
           {pair + " --calib " + path("outside.yaml"), "maps outside the source image"},
           {pair + " --calib " + path("corrupt.yaml"), "corrupt.yaml"},
           {pair + " --calib " + path("missing.yaml"), "missing.yaml: cannot open"},
           {path("l.png") + " " + path("small.png") + " --calib " + path("other_size.yaml"), "image sizes differ"},
       }) {
    const Result result = run("rectify " + bad.arguments + " -o " + path("out"));
    EXPECT_EQ(result.exit_code, 1) << bad.arguments;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(bad.needle), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(path("out/left.png"))) << bad.arguments;
    EXPECT_FALSE(fs::exists(path("out/right.png"))) << bad.arguments;
  }
  // --calib is required (CLI11's own exit code for a missing option, as for every sub-command).
  EXPECT_NE(run("rectify " + pair + " -o " + path("out")).exit_code, 0);
}

// A Kalibr/Kimera sensor YAML (one camera): camera_model pinhole + equidistant, or omni (Mei) +
// radtan with intrinsics [xi, gamma1, gamma2, cu, cv]; body_y_m places it along the body's y axis,
// which the camera's x axis points along (as in fisheye_mynteye).
void write_sensor_yaml(const std::string& file, const std::string& model, const std::string& intrinsics,
                       const std::string& distortion_model, const std::string& coefficients, double body_y_m, int width, int height) {
  std::ofstream(file) << "%YAML:1.0\ncamera_id: test\nT_BS:\n  cols: 4\n  rows: 4\n  data: [0.0, -1.0, 0.0, 0.0,\n"
                      << "         1.0, 0.0, 0.0, " << body_y_m << ",\n         0.0, 0.0, 1.0, 0.0,\n         0.0, 0.0, 0.0, 1.0]\n"
                      << "resolution: [" << width << ", " << height << "]\ncamera_model: " << model << "\nintrinsics: [" << intrinsics
                      << "]\ndistortion_model: " << distortion_model << "\ndistortion_coefficients: [" << coefficients << "]\n";
}

// opencv_contrib's omni_stereo_calibration output (Mei's model): K, D, xi per camera and
// extrinsic_parameters = (rvec, tvec).
void write_omnidir_stereo(const std::string& file, double xi) {
  cv::FileStorage storage(file, cv::FileStorage::WRITE);
  storage << "camera_matrix_1" << (cv::Mat_<double>(3, 3) << 300, 0, 161, 0, 301, 120, 0, 0, 1);
  storage << "distortion_coefficients_1" << (cv::Mat_<double>(1, 4) << -0.05, 0.01, 0.0005, -0.0003);
  storage << "xi_1" << xi;
  storage << "camera_matrix_2" << (cv::Mat_<double>(3, 3) << 302, 0, 159, 0, 302, 121, 0, 0, 1);
  storage << "distortion_coefficients_2" << (cv::Mat_<double>(1, 4) << -0.04, 0.008, -0.0002, 0.0004);
  storage << "xi_2" << xi;
  storage << "extrinsic_parameters" << (cv::Mat_<double>(1, 6) << 0.003, -0.01, 0.002, -0.15, 0.001, 0.0005);
}

TEST_F(GeometryCli, RectifyLatLongGivesCvRemapBitsOfTheLatLongMaps) {
  const int width = 321, height = 241;
  ASSERT_TRUE(cv::imwrite(path("l.png"), texture(width, height, 21)));
  ASSERT_TRUE(cv::imwrite(path("r.png"), texture(width, height, 22)));
  write_sensor_yaml(path("left.yaml"), "pinhole", "150, 150.5, 160, 121", "equidistant", "-0.02, -0.007, 0.002, -0.001", 0, width, height);
  write_sensor_yaml(path("right.yaml"), "pinhole", "151, 151, 161, 119", "equidistant", "-0.019, -0.005, -0.001, 0.0004", 0.12,
                    width, height);
  write_omnidir_stereo(path("omni.yaml"), 0.8);
  struct Case {
    std::vector<std::string> files;
    std::string options, needle;
    int out_width, out_height;
  };
  for (const Case& c : std::vector<Case>{
           {{path("left.yaml"), path("right.yaml")}, "--hfov-deg 150 --size 300x200", "baseline 0.120000 m", 300, 200},
           {{path("omni.yaml")}, "--hfov-deg 120", "opencv_omnidir, latitude-longitude) to 321x241", width, height},
       }) {
    std::string calib;
    for (const std::string& file : c.files) calib += " --calib " + file;
    const Result result = run("rectify " + path("l.png") + " " + path("r.png") + calib + " --model latlong " + c.options + " -o " +
                              path("ll"));
    ASSERT_EQ(result.exit_code, 0) << result.err;
    EXPECT_NE(result.out.find(c.needle), std::string::npos) << result.out;
    const io::StereoCalibration calibration = c.files.size() == 1 ? io::load_stereo_calibration(c.files[0])
                                                                   : io::load_stereo_calibration(c.files[0], c.files[1]);
    io::LatLongOptions options;
    options.hfov_rad = (c.files.size() == 1 ? 120 : 150) * M_PI / 180;
    options.width = c.out_width;
    options.height = c.out_height;
    const io::RectificationMaps maps = io::compute_latlong_maps(calibration, width, height, options);
    for (int view = 0; view < 2; ++view) {
      cv::Mat expected;
      cv::remap(cv::imread(path(view == 0 ? "l.png" : "r.png"), cv::IMREAD_GRAYSCALE), expected, view == 0 ? maps.left_x : maps.right_x,
                view == 0 ? maps.left_y : maps.right_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
      const cv::Mat ours = cv::imread(path(view == 0 ? "ll/left.png" : "ll/right.png"), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(ours.size(), cv::Size(c.out_width, c.out_height));
      EXPECT_EQ(cv::norm(ours, expected, cv::NORM_INF), 0) << "view " << view;
      EXPECT_GT(cv::countNonZero(ours), ours.total() / 2) << "view " << view;
    }
  }
}

TEST_F(GeometryCli, RectifyLatLongRefusesBadInputWithOneLine) {
  ASSERT_TRUE(cv::imwrite(path("l.png"), texture(320, 240, 23)));
  ASSERT_TRUE(cv::imwrite(path("r.png"), texture(320, 240, 24)));
  write_omnidir_stereo(path("omni.yaml"), 0.8);
  write_omnidir_stereo(path("omni0.yaml"), 0.0);  // xi = 0: a pinhole, at most 90 degrees off axis
  // An equidistant polynomial that turns at about 60 degrees off axis (k1 = -0.3).
  write_sensor_yaml(path("turn_l.yaml"), "pinhole", "150, 150, 160, 120", "equidistant", "-0.3, 0, 0, 0", 0, 320, 240);
  write_sensor_yaml(path("turn_r.yaml"), "pinhole", "150, 150, 160, 120", "equidistant", "-0.3, 0, 0, 0", 0.1, 320, 240);
  write_sensor_yaml(path("big_l.yaml"), "omni", "0.8, 270, 270, 320, 240", "radtan", "0, 0, 0, 0", 0, 640, 480);
  write_sensor_yaml(path("big_r.yaml"), "omni", "0.8, 270, 270, 320, 240", "radtan", "0, 0, 0, 0", 0.1, 640, 480);
  write_sensor_yaml(path("omni_equi.yaml"), "omni", "0.8, 270, 270, 320, 240", "equidistant", "0, 0, 0, 0", 0.1, 640, 480);
  std::ofstream(path("corrupt.yaml")) << "%YAML:1.0\ncamera_matrix_1: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [ 300, 0\n";
  std::ofstream(path("no_xi.yaml")) << "%YAML:1.0\ncamera_matrix_1: [300, 0, 160, 0, 300, 120, 0, 0, 1]\nxi_1: 0.8\n";
  struct Bad {
    std::string arguments, needle;
    int exit_code;
  };
  const std::string pair = path("l.png") + " " + path("r.png");
  const std::string omni = " --calib " + path("omni.yaml");
  for (const Bad& bad : std::vector<Bad>{
           {pair + omni + " --model latlong --hfov-deg 200", "--hfov-deg: expected the lat-long horizontal field of view in degrees, (0, 180]", 2},
           {pair + omni + " --model latlong --hfov-deg 0", "--hfov-deg", 2},
           {pair + omni + " --model latlong --size 300", "--size: expected WIDTHxHEIGHT", 2},
           {pair + omni + " --model pinhole --size 300x200", "--size applies to --model latlong only", 2},
           {pair + omni + " --model cylinder", "--model", 2},
           {pair + " --calib " + path("turn_l.yaml") + " --calib " + path("turn_r.yaml") + " --model latlong --hfov-deg 180",
            "model images at most 60.", 1},
           {pair + " --calib " + path("omni0.yaml") + " --model latlong --hfov-deg 180", "mei model images at most 90.00 deg", 1},
           {pair + omni + " --model latlong --hfov-deg 40 --size 100x500", "rows would span", 1},
           {pair + " --calib " + path("big_l.yaml") + " --calib " + path("big_r.yaml") + " --model latlong",
            "calibration is for 640x480 images, the images are 320x240", 1},
           {pair + " --calib " + path("big_l.yaml") + " --calib " + path("omni_equi.yaml") + " --model latlong",
            "distortion_model 'equidistant' with camera_model omni: expected radtan or none", 1},
           {pair + " --calib " + path("corrupt.yaml") + " --model latlong", "corrupt.yaml", 1},
           {pair + " --calib " + path("no_xi.yaml") + " --model latlong", "no_xi.yaml: missing distortion_coefficients_1", 1},
           {pair + omni, "a Mei (omnidirectional) camera has no pinhole rectification here", 1},
       }) {
    const Result result = run("rectify " + bad.arguments + " -o " + path("out"));
    EXPECT_EQ(result.exit_code, bad.exit_code) << bad.arguments << "\n" << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(bad.needle), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(path("out/left.png"))) << bad.arguments;
  }
}

// disparity --calib C --rectify: the views go through the same remap graph as `lpstereo rectify`,
// so its map is bit for bit the map of the rectified pair; --calib alone only checks the calibration.
TEST_F(GeometryCli, DisparityRectifiesWithTheCalibrationAsRectifyDoes) {
  const int width = 320, height = 240;
  ASSERT_EQ(run("disparity --synthetic --width 320 --height 240 --out-dir " + path("scene")).exit_code, 0);
  const std::string pair = path("scene/left.png") + " " + path("scene/right.png");
  write_raw_calibration(path("calib.yaml"), width, height, 160);
  {
    // The same calibration as two OpenCV files (intrinsics + extrinsics), given as --calib A,B.
    cv::FileStorage intrinsics(path("intrinsics.yml"), cv::FileStorage::WRITE);
    cv::FileStorage whole(path("calib.yaml"), cv::FileStorage::READ);
    for (const char* name : {"M1", "D1", "M2", "D2"}) intrinsics << name << whole[name].mat();
    cv::FileStorage extrinsics(path("extrinsics.yml"), cv::FileStorage::WRITE);
    for (const char* name : {"R", "T"}) extrinsics << name << whole[name].mat();
  }
  ASSERT_EQ(run("rectify " + pair + " --calib " + path("calib.yaml") + " -o " + path("rect")).exit_code, 0);
  const std::string options = " --num-disp 32 --format s16 --right-out ";
  ASSERT_EQ(run("disparity " + path("rect/left.png") + " " + path("rect/right.png") + " -o " + path("expected.s16") + options +
                path("expected_right.s16"))
                .exit_code,
            0);
  const Result rectified = run("disparity " + pair + " --calib " + path("calib.yaml") + " --rectify -o " + path("d.s16") +
                               options + path("d_right.s16"));
  ASSERT_EQ(rectified.exit_code, 0) << rectified.err;
  EXPECT_NE(rectified.out.find(", rectified with " + path("calib.yaml")), std::string::npos) << rectified.out;
  const Result two_files = run("disparity " + pair + " --calib " + path("intrinsics.yml") + "," + path("extrinsics.yml") +
                               " --rectify -o " + path("d2.s16") + options + path("d2_right.s16"));
  ASSERT_EQ(two_files.exit_code, 0) << two_files.err;
  const Result checked_only = run("disparity " + pair + " --calib " + path("calib.yaml") + " -o " + path("c.s16") + options +
                                  path("c_right.s16"));
  ASSERT_EQ(checked_only.exit_code, 0) << checked_only.err;
  ASSERT_EQ(run("disparity " + pair + " -o " + path("plain.s16") + options + path("plain_right.s16")).exit_code, 0);
  auto read = [&](const std::string& name) {
    const cv::Mat map = io::plane_to_mat(io::read_s16_raw(path(name), width, height));
    return map.clone();
  };
  for (const char* view : {"", "_right"}) {
    const std::string suffix = std::string(view) + ".s16";
    const cv::Mat expected = read("expected" + suffix);
    // The calibration is not the scene's, so "rectifying" shifts rows apart and the speckle filter
    // removes the scattered matches: this only guards against an empty map.
    EXPECT_GT(cv::countNonZero(expected != -16), width * height / 10) << "the rectified pair should still match";
    EXPECT_EQ(cv::norm(read("d" + suffix), expected, cv::NORM_INF), 0) << view;
    EXPECT_EQ(cv::norm(read("d2" + suffix), expected, cv::NORM_INF), 0) << view;
    EXPECT_EQ(cv::norm(read("c" + suffix), read("plain" + suffix), cv::NORM_INF), 0) << "--calib without --rectify " << view;
    EXPECT_GT(cv::countNonZero(read("c" + suffix) != expected), width * height / 10) << "rectification changed nothing";
  }
}

TEST_F(GeometryCli, DisparityRefusesACalibrationThatDoesNotFitTheImages) {
  ASSERT_EQ(run("disparity --synthetic --width 160 --height 120 --out-dir " + path("scene")).exit_code, 0);
  const std::string pair = path("scene/left.png") + " " + path("scene/right.png");
  write_raw_calibration(path("other_size.yaml"), 320, 240, 160);
  write_raw_calibration(path("outside.yaml"), 160, 120, 2000);  // principal point far right of the image
  struct Bad {
    std::string options, error;
    int exit_code;
  };
  for (const Bad& bad : std::vector<Bad>{
           {" --calib " + path("other_size.yaml") + " --rectify",
            "lpstereo: " + path("other_size.yaml") + ": calibration is for 320x240 images, the images are 160x120\n", 1},
           {" --calib " + path("other_size.yaml"),  // checked without --rectify too
            "lpstereo: " + path("other_size.yaml") + ": calibration is for 320x240 images, the images are 160x120\n", 1},
           {" --calib " + path("outside.yaml") + " --rectify", "maps outside the source image", 1},
           {" --calib " + path("missing.yaml") + " --rectify", "missing.yaml: cannot open", 1},
           {" --calib " + path("outside.yaml") + "," + path("outside.yaml") + "," + path("outside.yaml"),
            "lpstereo: --calib: give one calibration file, or two", 2},
       }) {
    const Result result = run("disparity " + pair + " -o " + path("d.png") + " --right-out " + path("r.png") + bad.options);
    EXPECT_EQ(result.exit_code, bad.exit_code) << bad.options << ": " << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    if (bad.error.back() == '\n') {
      EXPECT_EQ(result.err, bad.error);
    } else {
      EXPECT_NE(result.err.find(bad.error), std::string::npos) << result.err;
    }
    EXPECT_FALSE(fs::exists(path("d.png"))) << bad.options;
    EXPECT_FALSE(fs::exists(path("r.png"))) << bad.options;
  }
}

TEST_F(GeometryCli, CheckRectificationMeasuresVerticalOffsets) {
  const cv::Mat image = texture(400, 300, 6);
  cv::Mat shifted_x, shifted_xy;
  cv::warpAffine(image, shifted_x, cv::Mat(cv::Matx23d(1, 0, -9, 0, 1, 0)), image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  cv::warpAffine(image, shifted_xy, cv::Mat(cv::Matx23d(1, 0, -9, 0, 1, 2.5)), image.size(), cv::INTER_LINEAR,
                 cv::BORDER_REFLECT);
  ASSERT_TRUE(cv::imwrite(path("a.png"), image));
  ASSERT_TRUE(cv::imwrite(path("b.png"), shifted_x));
  ASSERT_TRUE(cv::imwrite(path("c.png"), shifted_xy));
  const Result aligned = run("check-rectification " + path("a.png") + " " + path("b.png") + " --json " + path("a.json"));
  ASSERT_EQ(aligned.exit_code, 0) << aligned.err;
  std::ifstream file(path("a.json"));
  const nlohmann::json report = nlohmann::json::parse(file);
  EXPECT_GE(report["matches"].get<int>(), 50);
  EXPECT_LE(report["median_px"].get<double>(), 0.1);
  const Result offset = run("check-rectification " + path("a.png") + " " + path("c.png") + " --detector orb");
  ASSERT_EQ(offset.exit_code, 0) << offset.err;
  double median = 0, p95 = 0;
  ASSERT_EQ(std::sscanf(offset.out.c_str() + offset.out.find("median"), "median %lf px, 95th percentile %lf", &median, &p95), 2)
      << offset.out;
  EXPECT_NEAR(median, 2.5, 0.5);
  // A flat image has no features: one line, exit 1.
  ASSERT_TRUE(cv::imwrite(path("flat.png"), cv::Mat(100, 100, CV_8UC1, cv::Scalar(90))));
  const Result flat = run("check-rectification " + path("flat.png") + " " + path("flat.png"));
  EXPECT_EQ(flat.exit_code, 1);
  EXPECT_EQ(count_lines(flat.err), 1) << flat.err;
  EXPECT_NE(flat.err.find("too few matched features"), std::string::npos) << flat.err;
}

// ---- chessboard pairs with known geometry ----

struct Pinhole {
  double f_px, cx_px, cy_px;
};

// Renders the view of a chessboard (COLS x ROWS inner corners, square_m) whose board frame maps into
// the camera as X_cam = R_board X_board + t_board; 3x3 supersampled, white margin of one square
// around the squares, grey background.
cv::Mat render_board(const Pinhole& camera, cv::Size image_size, const cv::Matx33d& r_board, const cv::Vec3d& t_board,
                     cv::Size board, double square_m) {
  cv::Mat image(image_size, CV_8UC1);
  const cv::Vec3d normal(r_board(0, 2), r_board(1, 2), r_board(2, 2));
  const double plane_distance = normal.dot(t_board);
  const cv::Matx33d to_board = r_board.t();
  for (int v = 0; v < image_size.height; ++v) {
    for (int u = 0; u < image_size.width; ++u) {
      double sum = 0;
      for (int sy = 0; sy < 3; ++sy) {
        for (int sx = 0; sx < 3; ++sx) {
          const cv::Vec3d ray((u + (sx - 1) / 3.0 - camera.cx_px) / camera.f_px, (v + (sy - 1) / 3.0 - camera.cy_px) / camera.f_px, 1);
          const double scale = plane_distance / normal.dot(ray);
          const cv::Vec3d on_board = to_board * (scale * ray - t_board);
          const double bx = on_board[0] / square_m, by = on_board[1] / square_m;
          double value = 128;
          if (scale > 0 && bx >= -2 && by >= -2 && bx <= board.width + 1 && by <= board.height + 1) {
            value = 255;
            if (bx >= -1 && by >= -1 && bx <= board.width && by <= board.height) {
              value = ((static_cast<int>(std::floor(bx)) + static_cast<int>(std::floor(by))) & 1) ? 255 : 20;
            }
          }
          sum += value;
        }
      }
      image.at<uint8_t>(v, u) = static_cast<uint8_t>(std::lround(sum / 9));
    }
  }
  return image;
}

TEST_F(GeometryCli, CalibrateRecoversFocalAndBaselineFromRenderedChessboards) {
  const cv::Size image_size(640, 480);
  const Pinhole camera{800, 319.5, 239.5};
  const cv::Size board(9, 6);
  const double square_m = 0.03;
  const double baseline_m = 0.1;
  cv::Matx33d r_stereo;
  cv::Rodrigues(cv::Vec3d(0.002, -0.01, 0.001), r_stereo);
  const cv::Vec3d t_stereo(-baseline_m, 0, 0);  // X_right = R X_left + T
  const cv::Vec3d board_centre(4 * square_m, 2.5 * square_m, 0);
  std::mt19937 generator(7);
  std::uniform_real_distribution<double> tilt(-0.45, 0.45), offset(-0.06, 0.06), distance(0.55, 0.8);
  std::ofstream list(path("pairs.txt"));
  std::vector<std::string> xml_names;
  const int pairs = 12;
  for (int i = 0; i < pairs + 1; ++i) {
    cv::Matx33d r_board;
    cv::Rodrigues(cv::Vec3d(tilt(generator), tilt(generator), 0.3 * tilt(generator)), r_board);
    const cv::Vec3d centre(0.05 + offset(generator), offset(generator), distance(generator));  // between the cameras
    const cv::Vec3d t_board = centre - r_board * board_centre;
    cv::Mat left = render_board(camera, image_size, r_board, t_board, board, square_m);
    cv::Mat right = render_board(camera, image_size, r_stereo * r_board, r_stereo * t_board + t_stereo, board, square_m);
    if (i == pairs) right = cv::Mat(image_size, CV_8UC1, cv::Scalar(128));  // no board: skipped
    const std::string left_name = "left" + std::to_string(i) + ".png", right_name = "right" + std::to_string(i) + ".png";
    ASSERT_TRUE(cv::imwrite(path(left_name), left));
    ASSERT_TRUE(cv::imwrite(path(right_name), right));
    list << left_name << " " << right_name << "\n";
    xml_names.push_back(left_name);
    xml_names.push_back(right_name);
  }
  list.close();
  {
    cv::FileStorage xml(path("stereo_calib.xml"), cv::FileStorage::WRITE);
    xml << "imagelist" << "[";
    for (const std::string& name : xml_names) xml << name;
    xml << "]";
  }
  for (const std::string& list_file : {path("pairs.txt"), path("stereo_calib.xml")}) {
    const Result result = run("calibrate --board 9x6 --square-m 0.03 " + list_file + " -o " + path("calib.yaml"));
    ASSERT_EQ(result.exit_code, 0) << result.err;
    EXPECT_NE(result.out.find("12 of 13 pairs used (1 skipped"), std::string::npos) << result.out;
    double rms = 0, row_mean = 0;
    ASSERT_EQ(std::sscanf(result.out.c_str() + result.out.find("RMS"), "RMS reprojection error %lf px; rectified row alignment mean %lf",
                          &rms, &row_mean),
              2)
        << result.out;
    EXPECT_LT(rms, 0.3);
    EXPECT_LT(row_mean, 0.1);
    const io::StereoCalibration calibration = io::load_stereo_calibration(path("calib.yaml"));
    EXPECT_EQ(calibration.left.width_px, 640);
    ASSERT_TRUE(calibration.rectification.has_value());
    for (const io::CameraModel* view : {&calibration.left, &calibration.right}) {
      EXPECT_NEAR(view->fx_px, camera.f_px, 0.005 * camera.f_px);
      EXPECT_NEAR(view->fy_px, camera.f_px, 0.005 * camera.f_px);
    }
    EXPECT_NEAR(calibration.baseline_m(), baseline_m, 0.01 * baseline_m);
    std::printf("calibrate (%s): focal %.3f / %.3f px (true 800), baseline %.5f m (true 0.1), RMS %.4f px, row alignment %.4f px\n",
                fs::path(list_file).filename().c_str(), calibration.left.fx_px, calibration.right.fx_px, calibration.baseline_m(),
                rms, row_mean);
  }
  // Bad usage and input: one line each.
  EXPECT_EQ(run("calibrate --board 9 --square-m 0.03 " + path("pairs.txt") + " -o " + path("x.yaml")).exit_code, 2);
  EXPECT_EQ(run("calibrate --board 9x6 --square-m -1 " + path("pairs.txt") + " -o " + path("x.yaml")).exit_code, 2);
  std::ofstream(path("few.txt")) << "left0.png right0.png\nleft12.png right12.png\n";
  const Result few = run("calibrate --board 9x6 --square-m 0.03 " + path("few.txt") + " -o " + path("x.yaml"));
  EXPECT_EQ(few.exit_code, 1);
  EXPECT_EQ(count_lines(few.err), 1) << few.err;
  EXPECT_NE(few.err.find("found in both views of 1 of 2 pairs"), std::string::npos) << few.err;
  std::ofstream(path("odd.txt")) << "left0.png\n";
  EXPECT_EQ(run("calibrate --board 9x6 --square-m 0.03 " + path("odd.txt") + " -o " + path("x.yaml")).exit_code, 1);
  EXPECT_FALSE(fs::exists(path("x.yaml")));
}

}  // namespace
