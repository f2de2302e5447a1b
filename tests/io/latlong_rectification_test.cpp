// Latitude-longitude rectification (io/rectification.h, compute_latlong_maps): a point seen by both
// raw cameras lands on one row of both lat-long views, where the float maps point at its raw
// projections; a synthetic spherical pair (a textured plane rendered through Mei's model for both
// cameras) rectified by the fixed-point kernel and matched by the disparity engine, unchanged, gives
// the range at the image centre within 1 %; and the refusals (field of view over 180 degrees or over
// a lens model's limit, sizes).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "arm/disparity_engine.h"
#include "arm/scheduler.h"
#include "dag/graph.h"
#include "io/calibration.h"
#include "io/image_io.h"
#include "io/rectification.h"
#include "io/spherical.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A Mei pair 0.3 m apart with a small relative rotation, 480x360 images (about 140 degrees across).
StereoCalibration mei_pair() {
  StereoCalibration calibration;
  calibration.left = {480, 360, 380, 381, 241.5, 178.5, LensModel::mei, {-0.06, 0.01, 0.0006, -0.0004, 0}, 0.9};
  calibration.right = {480, 360, 378, 379, 238.0, 181.0, LensModel::mei, {-0.05, 0.008, -0.0003, 0.0005, 0}, 0.92};
  cv::Matx33d rotation;
  cv::Rodrigues(cv::Vec3d(0.01, -0.03, 0.006), rotation);
  std::copy(rotation.val, rotation.val + 9, calibration.rotation.begin());
  calibration.translation_m = {-0.3, 0.004, -0.002};
  calibration.source = "mei pair";
  return calibration;
}

StereoCalibration equidistant_pair() {
  StereoCalibration calibration;
  calibration.left = {480, 360, 150, 150.5, 239, 181, LensModel::equidistant, {-0.02, -0.007, 0.002, -0.001, 0}};
  calibration.right = {480, 360, 151, 151, 241, 179, LensModel::equidistant, {-0.019, -0.005, -0.001, 0.0004, 0}};
  cv::Matx33d rotation;
  cv::Rodrigues(cv::Vec3d(-0.004, 0.02, -0.003), rotation);
  std::copy(rotation.val, rotation.val + 9, calibration.rotation.begin());
  calibration.translation_m = {-0.12, -0.001, 0.0001};
  calibration.source = "equidistant pair";
  return calibration;
}

cv::Vec3d rotate(const Matrix3& r, const cv::Vec3d& v) { return cv::Matx33d(r.data()) * v; }

// Bilinear sample of a float map at a non-integer position.
double sample(const cv::Mat& map, double x, double y) {
  cv::Mat value;
  cv::getRectSubPix(map, {1, 1}, cv::Point2f(static_cast<float>(x), static_cast<float>(y)), value, CV_32F);
  return value.at<float>(0, 0);
}

// The lat-long pixel of a direction in the rectified frame (the inverse of the header's formulas).
cv::Point2d latlong_pixel(const RectifiedGeometry& geometry, const cv::Vec3d& direction) {
  const cv::Vec3d unit = cv::normalize(direction);
  const double psi = std::asin(unit[0]);
  const double beta = std::atan2(unit[1], unit[2]);
  return {geometry.cx_left_px + geometry.focal_px * psi, geometry.cy_px + geometry.focal_px * beta};
}

TEST(LatLongRectification, APointLandsOnOneRowWhereTheMapsSeeIt) {
  for (const StereoCalibration& calibration : {mei_pair(), equidistant_pair()}) {
    LatLongOptions options;
    options.hfov_rad = 150 * kPi / 180;
    const RectificationMaps maps = compute_latlong_maps(calibration, 480, 360, options);
    const RectifiedGeometry& geometry = maps.geometry;
    ASSERT_EQ(geometry.projection, RectifiedProjection::latlong);
    EXPECT_NEAR(geometry.focal_px, 480 / options.hfov_rad, 1e-9);
    EXPECT_NEAR(geometry.baseline_m, calibration.baseline_m(), 1e-12);
    const cv::Matx33d r(calibration.rotation.data());
    const cv::Vec3d t(calibration.translation_m.data());
    int checked = 0;
    for (const cv::Vec3d& point : {cv::Vec3d(0.1, -0.2, 2.0), cv::Vec3d(-1.5, 0.6, 1.2), cv::Vec3d(1.2, 0.3, 1.0),
                                   cv::Vec3d(0.4, 0.8, 1.6), cv::Vec3d(-0.3, -0.5, 8.0), cv::Vec3d(-0.9, -0.7, 1.1)}) {
      // Where the rectified views see the point: the left centre is the rectified origin, the
      // right centre sits baseline_m along x.
      const cv::Vec3d in_rectified = rotate(geometry.r1, point);
      const cv::Point2d left = latlong_pixel(geometry, in_rectified);
      const cv::Point2d right = latlong_pixel(geometry, in_rectified - cv::Vec3d(geometry.baseline_m, 0, 0));
      // One row: the right view's rectified frame is the left one's, moved along the baseline.
      const cv::Vec3d right_in_rectified = rotate(geometry.r2, r * point + t);
      EXPECT_NEAR(latlong_pixel(geometry, right_in_rectified).y, left.y, 1e-9);
      EXPECT_NEAR(latlong_pixel(geometry, right_in_rectified).x, right.x, 1e-9);
      EXPECT_NEAR(left.y, right.y, 1e-9);
      // The maps there point at the raw projections of the point.
      const auto left_raw = project_ray(calibration.left, {point[0], point[1], point[2]});
      const cv::Vec3d in_right = r * point + t;
      const auto right_raw = project_ray(calibration.right, {in_right[0], in_right[1], in_right[2]});
      ASSERT_TRUE(left_raw && right_raw);
      auto inside = [](const Pixel& pixel) { return pixel[0] >= 1 && pixel[1] >= 1 && pixel[0] <= 478 && pixel[1] <= 358; };
      if (!inside(*left_raw) || !inside(*right_raw)) continue;  // the maps hold a border position there
      EXPECT_NEAR(sample(maps.left_x, left.x, left.y), (*left_raw)[0], 0.05) << calibration.source << " " << point;
      EXPECT_NEAR(sample(maps.left_y, left.x, left.y), (*left_raw)[1], 0.05) << calibration.source << " " << point;
      EXPECT_NEAR(sample(maps.right_x, right.x, right.y), (*right_raw)[0], 0.05) << calibration.source << " " << point;
      EXPECT_NEAR(sample(maps.right_y, right.x, right.y), (*right_raw)[1], 0.05) << calibration.source << " " << point;
      // Disparity in columns is the spherical disparity times f; it gives the range back.
      EXPECT_GT(left.x - right.x, 0);
      EXPECT_NEAR(latlong_range_m(geometry, left.x, left.x - right.x), cv::norm(point), 1e-9 * cv::norm(point));
      ++checked;
    }
    EXPECT_GE(checked, 4) << calibration.source;
  }
}

// What a camera at `centre_m` (left frame) with rotation camera_from_left sees of the plane
// z = plane_z_m (left frame) covered by `texture` (metres_per_texel, wrapping).
cv::Mat render_plane(const CameraModel& camera, const cv::Matx33d& camera_from_left, const cv::Vec3d& centre_m, double plane_z_m,
                     const cv::Mat& texture, double metres_per_texel) {
  cv::Mat map_x(camera.height_px, camera.width_px, CV_32FC1, cv::Scalar(-1e6)), map_y = map_x.clone();
  for (int y = 0; y < camera.height_px; ++y) {
    for (int x = 0; x < camera.width_px; ++x) {
      const auto ray = unproject_pixel(camera, x, y);
      if (!ray) continue;
      const cv::Vec3d direction = camera_from_left.t() * cv::Vec3d((*ray)[0], (*ray)[1], (*ray)[2]);
      if (direction[2] <= 0.05) continue;
      const cv::Vec3d hit = centre_m + ((plane_z_m - centre_m[2]) / direction[2]) * direction;
      map_x.at<float>(y, x) = static_cast<float>(hit[0] / metres_per_texel + texture.cols / 2.0);
      map_y.at<float>(y, x) = static_cast<float>(hit[1] / metres_per_texel + texture.rows / 2.0);
    }
  }
  cv::Mat image;
  cv::remap(texture, image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_WRAP);
  return image;
}

TEST(LatLongRectification, SyntheticMeiPairGivesTheRangeAtTheCentreWithinOnePercent) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_latlong");
  const StereoCalibration calibration = mei_pair();
  cv::Mat noise(1024, 1024, CV_8UC1);
  cv::RNG rng(11);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat texture;
  cv::GaussianBlur(noise, texture, cv::Size(0, 0), 1.2);
  cv::normalize(texture, texture, 0, 255, cv::NORM_MINMAX);
  const double plane_z_m = 1.6, metres_per_texel = 0.004;
  const cv::Matx33d r(calibration.rotation.data());
  const cv::Vec3d t(calibration.translation_m.data());
  const cv::Mat left = render_plane(calibration.left, cv::Matx33d::eye(), {0, 0, 0}, plane_z_m, texture, metres_per_texel);
  const cv::Mat right = render_plane(calibration.right, r, -(r.t() * t), plane_z_m, texture, metres_per_texel);

  // Rectify through the graph lpstereo rectify runs (calibration file -> generator -> remap kernel).
  const std::string file = scratch.path("mei.yaml");
  write_opencv_yaml(file, calibration);
  LatLongOptions options;
  options.hfov_rad = 120 * kPi / 180;
  const RectificationMaps maps = compute_latlong_maps(load_stereo_calibration(file), 480, 360, options);
  register_calibration_rectification_generator();
  Graph graph(rectification_graph_spec({file}, options));
  VerifyOptions verify;
  verify.frame_width = 480;
  verify.frame_height = 360;
  graph.verify(verify);
  arm::FrameRunner runner(graph);
  const Plane left_plane = mat_to_plane(left, {ElementType::u8, 0});
  const Plane right_plane = mat_to_plane(right, {ElementType::u8, 0});
  runner.process({{"left", &left_plane}, {"right", &right_plane}});
  const Plane& left_rectified = runner.buffer("left_rectified");
  const Plane& right_rectified = runner.buffer("right_rectified");
  ASSERT_EQ(left_rectified.width(), 480);

  arm::DisparityParameters parameters;
  parameters.num_disparities = 96;
  arm::DisparityEngine engine(480, 360, parameters);
  const Plane& disparity = engine.compute(left_rectified, right_rectified);
  const RectifiedGeometry& geometry = maps.geometry;
  std::vector<double> errors;
  const int cx = static_cast<int>(geometry.cx_left_px), cy = static_cast<int>(geometry.cy_px);
  for (int y = cy - 7; y <= cy + 7; ++y) {
    for (int x = cx - 7; x <= cx + 7; ++x) {
      const int16_t value = disparity.row<int16_t>(y)[x];
      if (value <= engine.invalid_disparity_q4()) continue;
      // The true range of this left pixel: its ray (rectified frame) to the plane.
      const double psi = (x - geometry.cx_left_px) / geometry.focal_px, beta = (y - geometry.cy_px) / geometry.focal_px;
      const cv::Vec3d ray = cv::Matx33d(geometry.r1.data()).t() *
                            cv::Vec3d(std::sin(psi), std::cos(psi) * std::sin(beta), std::cos(psi) * std::cos(beta));
      const double true_range_m = plane_z_m / ray[2];
      errors.push_back(latlong_range_m(geometry, x, value / 16.0) / true_range_m - 1);
    }
  }
  ASSERT_GE(errors.size(), 200u) << "valid disparities in the 15x15 centre patch";
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  std::printf("synthetic Mei pair, plane at %.2f m, baseline %.3f m: range at the centre (15x15, %zu valid) median error %+.3f %%, "
              "spread %+.3f .. %+.3f %%\n",
              plane_z_m, geometry.baseline_m, errors.size(), 100 * median, 100 * errors.front(), 100 * errors.back());
  EXPECT_LT(std::abs(median), 0.01);
}

TEST(LatLongRectification, RefusesFieldsOfViewBeyondTheLimitsAndBadSizes) {
  auto message = [](const StereoCalibration& calibration, int width, int height, const LatLongOptions& options) -> std::string {
    try {
      compute_latlong_maps(calibration, width, height, options);
    } catch (const CalibrationError& error) {
      return error.what();
    }
    return "accepted";
  };
  LatLongOptions wide;
  wide.hfov_rad = 200 * kPi / 180;
  EXPECT_NE(message(mei_pair(), 480, 360, wide).find("field of view 200.00 deg: expected (0, 180]"), std::string::npos)
      << message(mei_pair(), 480, 360, wide);
  LatLongOptions tall;
  tall.hfov_rad = 60 * kPi / 180;
  tall.width = 200;
  tall.height = 700;
  EXPECT_NE(message(mei_pair(), 480, 360, tall).find("rows would span 210.00 deg"), std::string::npos)
      << message(mei_pair(), 480, 360, tall);
  // An equidistant polynomial that turns at about 60 degrees (k1 = -0.3: 1 - 0.9 theta^2 = 0).
  StereoCalibration turning = equidistant_pair();
  turning.left.distortion = turning.right.distortion = {-0.3, 0, 0, 0, 0};
  LatLongOptions half;
  half.hfov_rad = kPi;
  const std::string limit = message(turning, 480, 360, half);
  EXPECT_NE(limit.find("from the left camera's axis; its equidistant model images at most 60."), std::string::npos) << limit;
  EXPECT_NE(limit.find("lower --hfov-deg"), std::string::npos) << limit;
  // A Mei camera with xi = 0 images up to 90 degrees; 180 degrees across asks for more once the
  // cameras are rotated against the rectified frame.
  StereoCalibration pinhole_like = mei_pair();
  pinhole_like.left.xi = pinhole_like.right.xi = 0;
  EXPECT_NE(message(pinhole_like, 480, 360, half).find("model images at most 90.00 deg"), std::string::npos)
      << message(pinhole_like, 480, 360, half);
  EXPECT_NE(message(mei_pair(), 640, 480, half).find("calibration is for 480x360 images, the images are 640x480"), std::string::npos);
  StereoCalibration mixed = mei_pair();
  mixed.right.lens = LensModel::equidistant;
  EXPECT_NE(message(mixed, 480, 360, half).find("lens models differ (mei, equidistant)"), std::string::npos);
  // Mei has no pinhole rectification here: the message names the lat-long one.
  try {
    compute_rectification_maps(mei_pair(), 480, 360);
    FAIL() << "pinhole rectification of a Mei pair accepted";
  } catch (const CalibrationError& error) {
    EXPECT_NE(std::string(error.what()).find("--model latlong"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace lpstereo::io
