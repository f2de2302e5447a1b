// Rectification maps from calibrations (io/rectification.h): identity for rectified files, the
// rectified geometry of a raw pair, rows aligned after rectification (a point seen by both raw
// cameras lands on one row), the remap_q5 table and the calibration_rectification generator in a
// graph, and the refusals (size mismatch, mapping outside the source, a table out of range).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <opencv2/calib3d.hpp>

#include "dag/graph.h"
#include "io/calibration.h"
#include "io/rectification.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

StereoCalibration raw_calibration() {
  StereoCalibration calibration;
  calibration.left = {0, 0, 420, 421, 200, 150, LensModel::pinhole, {-0.2, 0.05, 0.001, -0.001, 0}};
  calibration.right = {0, 0, 418, 419, 203, 148, LensModel::pinhole, {-0.19, 0.04, 0, 0.0005, 0}};
  cv::Matx33d rotation;
  cv::Rodrigues(cv::Vec3d(0.005, -0.02, 0.004), rotation);
  std::copy(rotation.val, rotation.val + 9, calibration.rotation.begin());
  calibration.translation_m = {-0.2, 0.002, 0.001};
  calibration.source = "raw";
  return calibration;
}

TEST(Rectification, AlreadyRectifiedIsTheIdentity) {
  StereoCalibration calibration;
  calibration.left = calibration.right = {64, 48, 100, 100, 31, 23, LensModel::pinhole, {}};
  calibration.translation_m = {-0.5, 0, 0};
  calibration.already_rectified = true;
  const RectificationMaps maps = compute_rectification_maps(calibration, 64, 48);
  EXPECT_EQ(maps.left_x.at<float>(47, 63), 63.0f);
  EXPECT_EQ(maps.right_y.at<float>(47, 63), 47.0f);
  EXPECT_DOUBLE_EQ(maps.geometry.baseline_m, 0.5);
  const Plane table = rectification_table(maps.left_x, maps.left_y, "left");
  for (int y = 0; y < 48; ++y) {
    for (int i = 0; i < 2 * 64; ++i) ASSERT_EQ(table.row<int16_t>(y)[i], 0);
  }
}

// A 3D point projected by both raw cameras (with their distortion) comes out of the rectification
// on one row: the rectified left and right pixels' y agree (here within 0.05 px), and their x
// difference gives the depth back (Z = f B / d).
TEST(Rectification, RawPairRowsAlignAndDepthComesBack) {
  const StereoCalibration calibration = raw_calibration();
  const RectificationMaps maps = compute_rectification_maps(calibration, 400, 300);
  EXPECT_NEAR(maps.geometry.baseline_m, calibration.baseline_m(), 1e-9);
  EXPECT_GT(maps.left_inside, 0.99);
  cv::Matx33d rotation(calibration.rotation.data());
  const cv::Mat k1 = (cv::Mat_<double>(3, 3) << 420, 0, 200, 0, 421, 150, 0, 0, 1);
  const cv::Mat k2 = (cv::Mat_<double>(3, 3) << 418, 0, 203, 0, 419, 148, 0, 0, 1);
  const cv::Mat d1(1, 5, CV_64F, const_cast<double*>(calibration.left.distortion.data()));
  const cv::Mat d2(1, 5, CV_64F, const_cast<double*>(calibration.right.distortion.data()));
  cv::Vec3d rvec;
  cv::Rodrigues(rotation, rvec);
  const cv::Vec3d tvec(calibration.translation_m[0], calibration.translation_m[1], calibration.translation_m[2]);
  // Finds the rectified pixel whose map points at `raw` (nearest map entry, then the local
  // Jacobian for sub-pixel precision).
  auto rectified_of = [](const cv::Mat& map_x, const cv::Mat& map_y, cv::Point2d raw) {
    double best = 1e9;
    cv::Point best_pixel;
    for (int y = 0; y < map_x.rows; ++y) {
      for (int x = 0; x < map_x.cols; ++x) {
        const double d = std::hypot(map_x.at<float>(y, x) - raw.x, map_y.at<float>(y, x) - raw.y);
        if (d < best) best = d, best_pixel = {x, y};
      }
    }
    const int x = std::clamp(best_pixel.x, 1, map_x.cols - 2), y = std::clamp(best_pixel.y, 1, map_x.rows - 2);
    const cv::Matx22d jacobian((map_x.at<float>(y, x + 1) - map_x.at<float>(y, x - 1)) / 2, (map_x.at<float>(y + 1, x) - map_x.at<float>(y - 1, x)) / 2,
                               (map_y.at<float>(y, x + 1) - map_y.at<float>(y, x - 1)) / 2, (map_y.at<float>(y + 1, x) - map_y.at<float>(y - 1, x)) / 2);
    const cv::Vec2d step = jacobian.inv() * cv::Vec2d(raw.x - map_x.at<float>(y, x), raw.y - map_y.at<float>(y, x));
    return cv::Point2d(x + step[0], y + step[1]);
  };
  for (const cv::Point3d& point : {cv::Point3d(0.3, -0.2, 3.0), cv::Point3d(-0.5, 0.3, 5.0), cv::Point3d(0.1, 0.0, 2.0)}) {
    std::vector<cv::Point2d> left_raw, right_raw;
    cv::projectPoints(std::vector<cv::Point3d>{point}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k1, d1, left_raw);
    cv::projectPoints(std::vector<cv::Point3d>{point}, rvec, tvec, k2, d2, right_raw);
    const cv::Point2d left = rectified_of(maps.left_x, maps.left_y, left_raw[0]);
    const cv::Point2d right = rectified_of(maps.right_x, maps.right_y, right_raw[0]);
    EXPECT_NEAR(left.y, right.y, 0.05) << point;
    // Depth along the rectified left camera's axis differs from the raw z by the small rectifying
    // rotation: compare within 1 %.
    const double depth = maps.geometry.focal_px * maps.geometry.baseline_m / (left.x - right.x);
    EXPECT_NEAR(depth, point.z, 0.01 * point.z) << point;
  }
}

TEST(Rectification, RefusesSizeMismatchMappingOutsideAndTablesOutOfRange) {
  StereoCalibration calibration = raw_calibration();
  calibration.left.width_px = calibration.right.width_px = 640;
  calibration.left.height_px = calibration.right.height_px = 480;
  try {
    compute_rectification_maps(calibration, 400, 300);
    FAIL() << "size mismatch accepted";
  } catch (const CalibrationError& error) {
    EXPECT_NE(std::string(error.what()).find("calibration is for 640x480 images, the images are 400x300"), std::string::npos)
        << error.what();
  }
  // Given rectification matrices whose principal point lies far outside the image.
  calibration = raw_calibration();
  StereoRectification far;
  far.p1 = {400, 0, 3000, 0, 0, 400, 150, 0, 0, 0, 1, 0};
  far.p2 = {400, 0, 3000, -80, 0, 400, 150, 0, 0, 0, 1, 0};
  calibration.rectification = far;
  try {
    compute_rectification_maps(calibration, 400, 300);
    FAIL() << "mapping outside accepted";
  } catch (const CalibrationError& error) {
    EXPECT_NE(std::string(error.what()).find("maps outside the source image"), std::string::npos) << error.what();
  }
  cv::Mat map_x(2, 2, CV_32FC1, cv::Scalar(0)), map_y(2, 2, CV_32FC1, cv::Scalar(0));
  map_x.at<float>(1, 1) = 1500;
  try {
    rectification_table(map_x, map_y, "left");
    FAIL() << "a 1499 px displacement accepted";
  } catch (const CalibrationError& error) {
    EXPECT_NE(std::string(error.what()).find("left rectification does not fit"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("pixel (1, 1)"), std::string::npos) << error.what();
  }
}

TEST(Rectification, GeneratorBuildsTheTablesInAGraph) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_rectification");
  const std::string file = scratch.path("mb.txt");
  std::ofstream(file) << "cam0=[300 0 40; 0 300 30; 0 0 1]\ncam1=[300 0 40; 0 300 30; 0 0 1]\nbaseline=120\n";
  register_calibration_rectification_generator();
  Graph graph(rectification_graph_spec({file}));
  VerifyOptions options;
  options.frame_width = 80;
  options.frame_height = 60;
  graph.verify(options);
  const Plane& table = graph.constant_data(graph.buffer_index("left_map"));
  EXPECT_EQ(table.width(), 80);
  EXPECT_EQ(table.format().type, ElementType::remap_q5);
  // A calibration the generator cannot read fails verify's node init, naming the file.
  Graph broken(rectification_graph_spec({scratch.path("missing.txt")}));
  try {
    broken.verify(options);
    FAIL() << "missing calibration accepted";
  } catch (const VerifyError& error) {
    EXPECT_NE(std::string(error.what()).find("missing.txt: cannot open"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace lpstereo::io
