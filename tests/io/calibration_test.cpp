// Calibration loaders and the OpenCV YAML writer, on files this test writes itself in every format
// (OpenCV YAML and XML, one file and the intrinsics/extrinsics pair, KITTI cam_to_cam / object /
// odometry, Middlebury, ROS camera_info pairs, Kalibr/Kimera sensor pairs), and the
// files that must be refused with one line. The real files in ../shared/data are checked by
// bench/geometry_eval (an evaluation, not a test).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "io/calibration.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

class Calibration : public ::testing::Test {
 protected:
  std::string write(const std::string& name, const std::string& text) {
    const std::string path = scratch_.path(name);
    std::ofstream(path) << text;
    return path;
  }
  // Expects a CalibrationError whose message is one line naming `file` and containing `needle`.
  template <class Load>
  void expect_refused(const Load& load, const std::string& file, const std::string& needle) {
    try {
      load();
      ADD_FAILURE() << "accepted; expected an error containing '" << needle << "'";
    } catch (const CalibrationError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find(file), std::string::npos) << message;
      EXPECT_NE(message.find(needle), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_calibration"};
};

// A small rotation about y and x, and T = (-0.12, 0.002, 0.001) m.
cv::Mat test_rotation() {
  cv::Mat rotation;
  cv::Rodrigues(cv::Vec3d(0.01, -0.02, 0.005), rotation);
  return rotation;
}

void write_opencv_storage(const std::string& path, bool intrinsics, bool extrinsics, const cv::Mat& rotation,
                          const cv::Mat& d1 = (cv::Mat_<double>(1, 5) << -0.28, 0.07, 0.001, -0.002, 0.0)) {
  cv::FileStorage storage(path, cv::FileStorage::WRITE);
  if (intrinsics) {
    storage << "M1" << (cv::Mat_<double>(3, 3) << 700.5, 0, 320.25, 0, 701.5, 240.75, 0, 0, 1);
    storage << "D1" << d1;
    storage << "M2" << (cv::Mat_<double>(3, 3) << 702.5, 0, 318.0, 0, 703.0, 238.0, 0, 0, 1);
    storage << "D2" << (cv::Mat_<double>(1, 5) << -0.27, 0.06, 0.0, 0.001, 0.01);
  }
  if (extrinsics) {
    storage << "R" << rotation;
    storage << "T" << (cv::Mat_<double>(3, 1) << -0.12, 0.002, 0.001);
  }
}

TEST_F(Calibration, OpenCvYamlSingleFile) {
  const std::string path = scratch_.path("stereo.yaml");
  write_opencv_storage(path, true, true, test_rotation());
  const StereoCalibration calibration = load_stereo_calibration(path);
  EXPECT_EQ(calibration.format, "opencv");
  EXPECT_FALSE(calibration.already_rectified);
  EXPECT_FALSE(calibration.rectification.has_value());
  EXPECT_DOUBLE_EQ(calibration.left.fx_px, 700.5);
  EXPECT_DOUBLE_EQ(calibration.left.fy_px, 701.5);
  EXPECT_DOUBLE_EQ(calibration.left.cx_px, 320.25);
  EXPECT_DOUBLE_EQ(calibration.right.cy_px, 238.0);
  EXPECT_DOUBLE_EQ(calibration.left.distortion[0], -0.28);
  EXPECT_DOUBLE_EQ(calibration.left.distortion[3], -0.002);  // p2 (OpenCV order k1 k2 p1 p2 k3)
  EXPECT_DOUBLE_EQ(calibration.right.distortion[4], 0.01);
  EXPECT_NEAR(calibration.baseline_m(), std::sqrt(0.12 * 0.12 + 0.002 * 0.002 + 0.001 * 0.001), 1e-12);
  EXPECT_DOUBLE_EQ(calibration.focal_px(), 700.5);
  EXPECT_NEAR(calibration.rotation[2], test_rotation().at<double>(0, 2), 1e-15);
}

TEST_F(Calibration, OpenCvXmlIntrinsicsExtrinsicsPairInEitherOrder) {
  const std::string intrinsics = scratch_.path("intrinsics.xml");
  const std::string extrinsics = scratch_.path("extrinsics.xml");
  write_opencv_storage(intrinsics, true, false, test_rotation(), (cv::Mat_<double>(1, 4) << -0.2, 0.05, 0.0, 0.0));
  write_opencv_storage(extrinsics, false, true, test_rotation());
  for (const auto& [first, second] : {std::pair{intrinsics, extrinsics}, std::pair{extrinsics, intrinsics}}) {
    const StereoCalibration calibration = load_stereo_calibration(first, second);
    EXPECT_DOUBLE_EQ(calibration.left.fx_px, 700.5);
    EXPECT_DOUBLE_EQ(calibration.left.distortion[0], -0.2);
    EXPECT_DOUBLE_EQ(calibration.left.distortion[4], 0.0);
    EXPECT_NEAR(calibration.baseline_m(), 0.1200208, 1e-6);
  }
  expect_refused([&] { load_stereo_calibration(intrinsics); }, "intrinsics.xml", "no extrinsics R T");
  expect_refused([&] { load_stereo_calibration(extrinsics); }, "extrinsics.xml", "no intrinsics");
}

TEST_F(Calibration, WriterRoundTripsWithRectificationAndImageSize) {
  StereoCalibration calibration;
  calibration.left = {640, 480, 500.0, 501.0, 319.5, 239.5, LensModel::pinhole, {0.1, -0.05, 0.001, 0.002, 0.003}};
  calibration.right = {640, 480, 502.0, 503.0, 321.5, 241.5, LensModel::pinhole, {0.11, -0.04, 0.0, 0.0, 0.0}};
  calibration.rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  calibration.translation_m = {-0.25, 0, 0};
  StereoRectification rectification;
  rectification.p1 = {480, 0, 310, 0, 0, 480, 235, 0, 0, 0, 1, 0};
  rectification.p2 = {480, 0, 310, -120, 0, 480, 235, 0, 0, 0, 1, 0};
  rectification.q = {1, 0, 0, -310, 0, 1, 0, -235, 0, 0, 0, 480, 0, 0, 4, 0};
  calibration.rectification = rectification;
  calibration.source = "memory";
  const std::string path = scratch_.path("out.yaml");
  write_opencv_yaml(path, calibration, "RMS reprojection error 0.2 px\nrow alignment 0.1 px");
  const StereoCalibration back = load_stereo_calibration(path);
  EXPECT_EQ(back.left.width_px, 640);
  EXPECT_EQ(back.right.height_px, 480);
  EXPECT_EQ(back.left.distortion, calibration.left.distortion);
  EXPECT_EQ(back.right.distortion, calibration.right.distortion);
  EXPECT_DOUBLE_EQ(back.right.fy_px, 503.0);
  ASSERT_TRUE(back.rectification.has_value());
  EXPECT_EQ(back.rectification->p2, rectification.p2);
  EXPECT_EQ(back.rectification->q, rectification.q);
  EXPECT_DOUBLE_EQ(back.focal_px(), 480.0);
  EXPECT_DOUBLE_EQ(back.baseline_m(), 0.25);
  std::ifstream file(path);
  std::string first_lines((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  EXPECT_NE(first_lines.find("# RMS reprojection error 0.2 px\n"), std::string::npos);
  // Equidistant lenses keep their model and four coefficients.
  calibration.left.lens = calibration.right.lens = LensModel::equidistant;
  calibration.left.distortion = {0.01, -0.02, 0.003, -0.004, 0};
  write_opencv_yaml(path, calibration);
  const StereoCalibration fisheye = load_stereo_calibration(path);
  EXPECT_EQ(fisheye.left.lens, LensModel::equidistant);
  EXPECT_EQ(fisheye.left.distortion, calibration.left.distortion);
}

TEST_F(Calibration, KittiCamToCam) {
  const std::string path = write("calib_cam_to_cam.txt",
                                 "calib_time: 09-Jan-2012 13:57:47\n"
                                 "corner_dist: 9.950000e-02\n"
                                 "S_rect_02: 1.242000e+03 3.750000e+02\n"
                                 "R_rect_02: 1 0 0 0 1 0 0 0 1\n"
                                 "P_rect_02: 7.215377e+02 0.000000e+00 6.095593e+02 4.485728e+01 0.000000e+00 7.215377e+02 "
                                 "1.728540e+02 2.163791e-01 0.000000e+00 0.000000e+00 1.000000e+00 2.745884e-03\n"
                                 "S_rect_03: 1.242000e+03 3.750000e+02\n"
                                 "P_rect_03: 7.215377e+02 0.000000e+00 6.095593e+02 -3.395242e+02 0.000000e+00 7.215377e+02 "
                                 "1.728540e+02 2.199936e+00 0.000000e+00 0.000000e+00 1.000000e+00 2.729905e-03\n");
  const StereoCalibration calibration = load_stereo_calibration(path);
  EXPECT_EQ(calibration.format, "kitti_cam_to_cam");
  EXPECT_TRUE(calibration.already_rectified);
  EXPECT_EQ(calibration.left.width_px, 1242);
  EXPECT_EQ(calibration.left.height_px, 375);
  EXPECT_DOUBLE_EQ(calibration.focal_px(), 721.5377);
  EXPECT_NEAR(calibration.baseline_m(), (44.85728 + 339.5242) / 721.5377, 1e-9);
  EXPECT_DOUBLE_EQ(calibration.translation_m[0], -calibration.baseline_m());
}

TEST_F(Calibration, KittiObjectAndOdometry) {
  const std::string p = "7.070912e+02 0 6.018873e+02 ";
  const std::string rest = " 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n";
  const std::string object = write("object.txt", "P0: " + p + "0" + rest + "P1: " + p + "-3.798145e+02" + rest + "P2: " + p +
                                                     "4.6e+01" + rest + "P3: " + p + "-3.4e+02" + rest +
                                                     "R0_rect: 1 0 0 0 1 0 0 0 1\n");
  const StereoCalibration object_calibration = load_stereo_calibration(object);
  EXPECT_EQ(object_calibration.format, "kitti_object");  // P2/P3 (colour cameras) win over P0/P1
  EXPECT_NEAR(object_calibration.baseline_m(), 386.0 / 707.0912, 1e-9);
  const std::string named = write("odometry.txt", "P0: " + p + "0" + rest + "P1: " + p + "-3.798145e+02" + rest);
  const std::string bare = write("odometry_bare.txt", p + "0" + rest + p + "-3.798145e+02" + rest);
  for (const std::string& path : {named, bare}) {
    const StereoCalibration calibration = load_stereo_calibration(path);
    EXPECT_EQ(calibration.format, "kitti_odometry");
    EXPECT_NEAR(calibration.baseline_m(), 379.8145 / 707.0912, 1e-12);
    EXPECT_DOUBLE_EQ(calibration.focal_px(), 707.0912);
    EXPECT_EQ(calibration.left.width_px, 0);  // the file does not say
  }
  expect_refused([&] { load_stereo_calibration(write("p2only.txt", "P2: " + p + "0" + rest)); }, "p2only.txt",
                 "not a calibration file");
  expect_refused([&] { load_stereo_calibration(write("short.txt", "P0: 1 2 3\nP1: 1 2 3\n")); }, "short.txt",
                 "expected 12 numbers");
  expect_refused([&] { load_stereo_calibration(write("negative.txt", "P0: -7 0 6 0 0 -7 1 0 0 0 1 0\nP1: -7 0 6 -1 0 -7 1 0 0 0 1 0\n")); },
                 "negative.txt", "positive focal");
  expect_refused([&] { load_stereo_calibration(write("unequal.txt", "P0: 7 0 6 0 0 7 1 0 0 0 1 0\nP1: 8 0 6 -1 0 7 1 0 0 0 1 0\n")); },
                 "unequal.txt", "not a rectified pair");
}

TEST_F(Calibration, Middlebury) {
  const std::string path = write("calib.txt",
                                 "cam0=[999.421 0 294.182; 0 999.421 252.932; 0 0 1]\n"
                                 "cam1=[999.421 0 326.96; 0 999.421 252.932; 0 0 1]\n"
                                 "doffs=32.778\nbaseline=193.001\nwidth=741\nheight=497\nndisp=70\nisint=0\nvmin=7\nvmax=65\n");
  const StereoCalibration calibration = load_stereo_calibration(path);
  EXPECT_EQ(calibration.format, "middlebury");
  EXPECT_TRUE(calibration.already_rectified);
  EXPECT_DOUBLE_EQ(calibration.baseline_m(), 0.193001);
  EXPECT_DOUBLE_EQ(calibration.focal_px(), 999.421);
  EXPECT_DOUBLE_EQ(calibration.disparity_offset_px, 32.778);
  EXPECT_EQ(calibration.num_disparities, 70);
  EXPECT_EQ(calibration.left.width_px, 741);
  expect_refused([&] { load_stereo_calibration(write("nobaseline.txt", "cam0=[1 0 2; 0 1 3; 0 0 1]\ncam1=[1 0 2; 0 1 3; 0 0 1]\n")); },
                 "nobaseline.txt", "missing baseline");
  expect_refused([&] { load_stereo_calibration(write("badcam.txt", "cam0=[1 0 2; 0 1]\ncam1=[1 0 2; 0 1 3; 0 0 1]\nbaseline=1\n")); },
                 "badcam.txt", "cam0: expected a 3x3 matrix");
  expect_refused([&] { load_stereo_calibration(write("zerof.txt", "cam0=[0 0 2; 0 0 3; 0 0 1]\ncam1=[0 0 2; 0 0 3; 0 0 1]\nbaseline=1\n")); },
                 "zerof.txt", "positive focal");
}

std::string ros_camera(const std::string& name, const std::string& k, const std::string& d, const std::string& r,
                       const std::string& p, bool with_size = true) {
  return std::string(with_size ? "image_width: 640\nimage_height: 480\n" : "") + "camera_name: " + name +
         "\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [" + k +
         "]\ndistortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [" + d +
         "]\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [" + r + "]\nprojection_matrix:\n  rows: 3\n  cols: 4\n  data: [" +
         p + "]\n";
}

TEST_F(Calibration, RosCameraInfoPairs) {
  const std::string identity = "1, 0, 0, 0, 1, 0, 0, 0, 1";
  // Already rectified (no distortion, identity rectification, P = K [I | t]).
  const std::string left = write("left.yaml", ros_camera("left", "500, 0, 320, 0, 500, 240, 0, 0, 1", "0, 0, 0, 0, 0", identity,
                                                         "500, 0, 320, 0, 0, 500, 240, 0, 0, 0, 1, 0"));
  const std::string right = write("right.yaml", ros_camera("right", "500, 0, 320, 0, 500, 240, 0, 0, 1", "0, 0, 0, 0, 0", identity,
                                                           "500, 0, 320, -60, 0, 500, 240, 0, 0, 0, 1, 0"));
  const StereoCalibration rectified = load_stereo_calibration(left, right);
  EXPECT_EQ(rectified.format, "ros_camera_info");
  EXPECT_TRUE(rectified.already_rectified);
  EXPECT_DOUBLE_EQ(rectified.baseline_m(), 0.12);
  EXPECT_DOUBLE_EQ(rectified.translation_m[0], -0.12);
  EXPECT_EQ(rectified.left.width_px, 640);
  // Raw cameras with their rectification: R = R2^T R1, T = R2^T (P2(0,3) / fx, 0, 0).
  cv::Mat r1, r2;
  cv::Rodrigues(cv::Vec3d(0, 0.01, 0), r1);
  cv::Rodrigues(cv::Vec3d(0, -0.01, 0), r2);
  auto text = [](const cv::Mat& m) {
    std::string out;
    for (int i = 0; i < 9; ++i) out += (i ? ", " : "") + std::to_string(m.at<double>(i / 3, i % 3));
    return out;
  };
  const std::string raw_left = write("raw_left.yaml", ros_camera("left", "505, 0, 322, 0, 506, 241, 0, 0, 1", "-0.1, 0.02, 0, 0, 0",
                                                                 text(r1), "480, 0, 330, 0, 0, 480, 240, 0, 0, 0, 1, 0"));
  const std::string raw_right = write("raw_right.yaml", ros_camera("right", "504, 0, 318, 0, 505, 239, 0, 0, 1", "-0.1, 0.02, 0, 0, 0",
                                                                   text(r2), "480, 0, 330, -96, 0, 480, 240, 0, 0, 0, 1, 0"));
  const StereoCalibration raw = load_stereo_calibration(raw_left, raw_right);
  EXPECT_FALSE(raw.already_rectified);
  ASSERT_TRUE(raw.rectification.has_value());
  EXPECT_NEAR(raw.baseline_m(), 0.2, 1e-9);
  EXPECT_DOUBLE_EQ(raw.focal_px(), 480);
  EXPECT_NEAR(raw.rectification->q[14], 1 / 0.2, 1e-9);  // -1 / Tx
  const cv::Mat expected_r = r2.t() * r1;
  EXPECT_NEAR(raw.rotation[2], expected_r.at<double>(0, 2), 1e-6);
  EXPECT_NEAR(raw.translation_m[2], cv::Mat(r2.t() * cv::Mat(cv::Vec3d(-0.2, 0, 0))).at<double>(2), 1e-6);
  // Refused: no image size; a single camera file; a left/right mix of formats.
  const std::string no_size = write("nosize.yaml", ros_camera("left", "500, 0, 320, 0, 500, 240, 0, 0, 1", "0, 0, 0, 0, 0", identity,
                                                              "500, 0, 320, 0, 0, 500, 240, 0, 0, 0, 1, 0", false));
  expect_refused([&] { load_stereo_calibration(no_size, right); }, "nosize.yaml", "missing image_width");
  expect_refused([&] { load_stereo_calibration(left); }, "left.yaml", "describes one camera");
}

std::string kimera_camera(const std::string& t_bs, const std::string& intrinsics, const std::string& model,
                          const std::string& coefficients, const std::string& camera_model = "pinhole") {
  return "%YAML:1.0\n# General sensor definitions.\ncamera_id: test\nT_BS:\n  cols: 4\n  rows: 4\n  data: [" + t_bs +
         "]\nrate_hz: 25\nresolution: [752, 480]\ncamera_model: " + camera_model + "\nintrinsics: [" + intrinsics +
         "] #fu, fv, cu, cv\ndistortion_model: " + model + "\ndistortion_coefficients: [" + coefficients + "]\n";
}

TEST_F(Calibration, KalibrSensorPair) {
  // As in the MYNT EYE files: both cameras rotated the same way in the body, 0.12 m apart.
  const std::string left = write("left_sensor.yaml", kimera_camera("0, -1, 0, 0,  1, 0, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1",
                                                                   "366.163,365.631,380.573,225.950", "equidistant",
                                                                   "-0.020476443,-0.007108226,0.002180580,-0.001192386"));
  const std::string right = write("right_sensor.yaml", kimera_camera("0, -1, 0, 0,  1, 0, 0, 0.12,  0, 0, 1, 0,  0, 0, 0, 1",
                                                                     "367.032,366.632,379.304,236.659", "equidistant",
                                                                     "-0.019659843,-0.005079736,-0.001357391,0.000419038"));
  const StereoCalibration calibration = load_stereo_calibration(left, right);
  EXPECT_EQ(calibration.format, "kalibr");
  EXPECT_EQ(calibration.left.lens, LensModel::equidistant);
  EXPECT_DOUBLE_EQ(calibration.left.distortion[3], -0.001192386);
  EXPECT_EQ(calibration.left.width_px, 752);
  EXPECT_DOUBLE_EQ(calibration.right.fx_px, 367.032);
  // Right camera 0.12 m along body y = camera x: T = (-0.12, 0, 0).
  EXPECT_NEAR(calibration.translation_m[0], -0.12, 1e-12);
  EXPECT_NEAR(calibration.baseline_m(), 0.12, 1e-12);
}

// Mei's unified model from the files that carry it: a Kalibr/Kimera "omni" sensor pair (intrinsics
// [xi, gamma1, gamma2, cu, cv], radtan k1 k2 p1 p2), opencv_contrib's omnidir stereo file (K, D, xi
// per camera, extrinsic_parameters = rvec, tvec), and our own YAML (lens_model: mei, xi1, xi2).
TEST_F(Calibration, MeiFromKalibrOmniOmnidirAndOurYaml) {
  const std::string left = write("left_omni.yaml", kimera_camera("0, -1, 0, 0,  1, 0, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1",
                                                                 "1.21, 771.5, 772.25, 376.5, 240.5", "radtan",
                                                                 "-0.21, 0.08, 0.0007, -0.0004", "omni"));
  const std::string right = write("right_omni.yaml", kimera_camera("0, -1, 0, 0,  1, 0, 0, 0.11,  0, 0, 1, 0,  0, 0, 0, 1",
                                                                   "1.19, 768.0, 769.0, 380.0, 238.0", "radtan",
                                                                   "-0.2, 0.07, 0.0001, 0.0002", "omni"));
  const StereoCalibration kalibr = load_stereo_calibration(left, right);
  EXPECT_EQ(kalibr.left.lens, LensModel::mei);
  EXPECT_DOUBLE_EQ(kalibr.left.xi, 1.21);
  EXPECT_DOUBLE_EQ(kalibr.left.fx_px, 771.5);
  EXPECT_DOUBLE_EQ(kalibr.right.cy_px, 238.0);
  EXPECT_DOUBLE_EQ(kalibr.right.distortion[1], 0.07);
  EXPECT_NEAR(kalibr.baseline_m(), 0.11, 1e-12);

  auto write_omnidir = [&](const std::string& name, double skew, double xi2) {
    const std::string file = scratch_.path(name);
    cv::FileStorage storage(file, cv::FileStorage::WRITE);
    storage << "flags" << 0;
    storage << "camera_matrix_1" << (cv::Mat_<double>(3, 3) << 560, skew, 330, 0, 561, 250, 0, 0, 1);
    storage << "distortion_coefficients_1" << (cv::Mat_<double>(1, 4) << -0.3, 0.1, 0.001, 0.002);
    storage << "xi_1" << 0.95;
    storage << "camera_matrix_2" << (cv::Mat_<double>(3, 3) << 562, 0, 328, 0, 563, 251, 0, 0, 1);
    storage << "distortion_coefficients_2" << (cv::Mat_<double>(1, 4) << -0.29, 0.09, 0.0, 0.001);
    storage << "xi_2" << xi2;
    storage << "extrinsic_parameters" << (cv::Mat_<double>(1, 6) << 0.01, -0.02, 0.005, -0.2, 0.001, 0.002);
    storage << "rms" << 0.3;
    return file;
  };
  const StereoCalibration cv_omnidir = load_stereo_calibration(write_omnidir("omni_stereo.yaml", 0, 0.97));
  EXPECT_EQ(cv_omnidir.format, "opencv_omnidir");
  EXPECT_EQ(cv_omnidir.right.lens, LensModel::mei);
  EXPECT_DOUBLE_EQ(cv_omnidir.right.xi, 0.97);
  EXPECT_DOUBLE_EQ(cv_omnidir.left.distortion[0], -0.3);
  EXPECT_EQ(cv_omnidir.left.distortion[4], 0.0);
  const cv::Mat rotation = test_rotation();
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(cv_omnidir.rotation[static_cast<size_t>(i)], rotation.at<double>(i / 3, i % 3), 1e-12);
  EXPECT_NEAR(cv_omnidir.baseline_m(), std::sqrt(0.04 + 0.000001 + 0.000004), 1e-12);

  // Our writer keeps the model, xi and k5 (Mei's toolbox's sixth-order term).
  StereoCalibration with_k5 = cv_omnidir;
  with_k5.left.distortion[4] = 0.002;
  const std::string ours = scratch_.path("mei.yaml");
  write_opencv_yaml(ours, with_k5);
  const StereoCalibration back = load_stereo_calibration(ours);
  EXPECT_EQ(back.left.lens, LensModel::mei);
  EXPECT_DOUBLE_EQ(back.left.xi, 0.95);
  EXPECT_DOUBLE_EQ(back.right.xi, 0.97);
  EXPECT_EQ(back.left.distortion, with_k5.left.distortion);

  // Refusals, one line naming the file: skew, a negative xi, omni with 4 intrinsics or with
  // equidistant distortion, a ROS file claiming Mei (ROS has no xi), a mei YAML without xi.
  expect_refused([&] { load_stereo_calibration(write_omnidir("skew.yaml", 0.5, 0.97)); }, "skew.yaml",
                 "camera_matrix_1: skew s = 0.5");
  expect_refused([&] { load_stereo_calibration(write_omnidir("negative_xi.yaml", 0, -0.5)); }, "negative_xi.yaml",
                 "right camera: Mei's xi must be finite and >= 0, got -0.5");
  const std::string four = write("four.yaml", kimera_camera("1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1", "771.5, 772.25, 376.5, 240.5",
                                                            "radtan", "0, 0, 0, 0", "omni"));
  expect_refused([&] { load_stereo_calibration(four, right); }, "four.yaml", "intrinsics: expected 5 numbers, got 4");
  const std::string equidistant = write("omni_equidistant.yaml", kimera_camera("1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1",
                                                                               "1.2, 771.5, 772.25, 376.5, 240.5", "equidistant",
                                                                               "0, 0, 0, 0", "omni"));
  expect_refused([&] { load_stereo_calibration(equidistant, right); }, "omni_equidistant.yaml",
                 "distortion_model 'equidistant' with camera_model omni: expected radtan or none");
  std::string no_xi;
  {
    std::ifstream file(ours);
    no_xi.assign(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
  }
  no_xi.erase(no_xi.find("xi1:"), no_xi.find('\n', no_xi.find("xi1:")) - no_xi.find("xi1:") + 1);
  expect_refused([&] { load_stereo_calibration(write("no_xi.yaml", no_xi)); }, "no_xi.yaml", "missing xi1");
  const std::string ros = write("ros_mei.yaml", "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [500, 0, 320, 0, 500, 240, 0, 0, 1]\n"
                                                "distortion_model: mei\nimage_width: 640\nimage_height: 480\n");
  expect_refused([&] { load_stereo_calibration(ros, ros); }, "ros_mei.yaml", "ROS camera_info has no xi");
}

TEST_F(Calibration, RefusesInconsistentOrCorruptFiles) {
  const std::string scaled = scratch_.path("scaled_r.yaml");
  write_opencv_storage(scaled, true, true, test_rotation() * 1.1);
  expect_refused([&] { load_stereo_calibration(scaled); }, "scaled_r.yaml", "R is not a rotation");
  const std::string reflection = scratch_.path("reflection.yaml");
  write_opencv_storage(reflection, true, true, (cv::Mat_<double>(3, 3) << -1, 0, 0, 0, 1, 0, 0, 0, 1));
  expect_refused([&] { load_stereo_calibration(reflection); }, "reflection.yaml", "det -1");

  const std::string negative = scratch_.path("negative_f.yaml");
  {
    cv::FileStorage storage(negative, cv::FileStorage::WRITE);
    storage << "M1" << (cv::Mat_<double>(3, 3) << -700, 0, 320, 0, 700, 240, 0, 0, 1) << "D1" << cv::Mat::zeros(1, 5, CV_64F);
    storage << "M2" << (cv::Mat_<double>(3, 3) << 700, 0, 320, 0, 700, 240, 0, 0, 1) << "D2" << cv::Mat::zeros(1, 5, CV_64F);
    storage << "R" << cv::Mat::eye(3, 3, CV_64F) << "T" << (cv::Mat_<double>(3, 1) << -0.1, 0, 0);
  }
  expect_refused([&] { load_stereo_calibration(negative); }, "negative_f.yaml", "left camera: expected positive focal lengths");

  const std::string no_t = scratch_.path("no_t.yaml");
  {
    cv::FileStorage storage(no_t, cv::FileStorage::WRITE);
    storage << "M1" << cv::Mat::eye(3, 3, CV_64F) << "D1" << cv::Mat::zeros(1, 5, CV_64F);
    storage << "M2" << cv::Mat::eye(3, 3, CV_64F) << "D2" << cv::Mat::zeros(1, 5, CV_64F) << "R" << cv::Mat::eye(3, 3, CV_64F);
  }
  expect_refused([&] { load_stereo_calibration(no_t); }, "no_t.yaml", "missing T");
  const std::string zero_t = scratch_.path("zero_t.yaml");
  {
    cv::FileStorage storage(zero_t, cv::FileStorage::WRITE);
    storage << "M1" << cv::Mat::eye(3, 3, CV_64F) << "D1" << cv::Mat::zeros(1, 5, CV_64F);
    storage << "M2" << cv::Mat::eye(3, 3, CV_64F) << "D2" << cv::Mat::zeros(1, 5, CV_64F) << "R" << cv::Mat::eye(3, 3, CV_64F);
    storage << "T" << cv::Mat::zeros(3, 1, CV_64F);
  }
  expect_refused([&] { load_stereo_calibration(zero_t); }, "zero_t.yaml", "no baseline");
  const std::string rational = scratch_.path("rational.yaml");
  write_opencv_storage(rational, true, true, test_rotation(), (cv::Mat_<double>(1, 8) << 0.1, 0, 0, 0, 0, 0.5, 0, 0));
  expect_refused([&] { load_stereo_calibration(rational); }, "rational.yaml", "not supported");

  // Truncated and corrupt files, an empty file, a missing file, text that is no calibration.
  std::string text;
  {
    std::ifstream file(scaled);
    text.assign(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
  }
  const std::string truncated = write("truncated.yaml", text.substr(0, text.find("data: [") + 12));
  expect_refused([&] { load_stereo_calibration(truncated); }, "truncated.yaml", "");
  expect_refused([&] { load_stereo_calibration(write("corrupt.yaml", "%YAML:1.0\nM1: [1, 2\n")); }, "corrupt.yaml", "cannot parse");
  expect_refused([&] { load_stereo_calibration(write("empty.txt", "")); }, "empty.txt", "empty file");
  expect_refused([&] { load_stereo_calibration(scratch_.path("missing.yaml")); }, "missing.yaml", "cannot open");
  expect_refused([&] { load_stereo_calibration(write("words.txt", "hello world\n")); }, "words.txt", "not a calibration file");
  // The writer validates too.
  StereoCalibration bad;
  bad.source = "in memory";
  expect_refused([&] { write_opencv_yaml(scratch_.path("never.yaml"), bad); }, "in memory", "positive focal");
  EXPECT_FALSE(std::ifstream(scratch_.path("never.yaml")).good());
}

}  // namespace
}  // namespace lpstereo::io
