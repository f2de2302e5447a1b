// arm/point_cloud: the rotation convention (R = Rz Ry Rx, against the textbook matrices and known
// quarter turns), the optical-to-vehicle axis change, a pitched camera seeing the ground at z = 0,
// collect_points (valid points only, colours, sizes), and PLY files read back by an independent
// reader in both encodings, written atomically.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include <Eigen/LU>  // determinant()

#include "arm/point_cloud.h"
#include "dag/atomic_file.h"
#include "kernels/disparity_to_points.h"
#include "tests/support/ply_reader.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::arm {
namespace {

constexpr double kQuarterTurn = std::numbers::pi / 2;

::testing::AssertionResult near(const Eigen::Vector3d& expected, const Eigen::Vector3d& actual, double tolerance = 1e-12) {
  if ((expected - actual).norm() <= tolerance) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "expected (" << expected.transpose() << "), got (" << actual.transpose() << ")";
}

// The elementary rotations as printed in every robotics text (e.g. Siciliano et al., "Robotics",
// eq. 2.6-2.8), written out here so the test does not reuse the code under test's Eigen calls.
Eigen::Matrix3d rx(double a) {
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return m;
}
Eigen::Matrix3d ry(double a) {
  Eigen::Matrix3d m;
  m << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  return m;
}
Eigen::Matrix3d rz(double a) {
  Eigen::Matrix3d m;
  m << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return m;
}

TEST(PointCloud, RotationIsRzRyRxOfTheTextbookMatrices) {
  const double roll = 0.3, pitch = -0.7, yaw = 2.1;
  const Eigen::Matrix3d rotation = rotation_zyx(roll, pitch, yaw);
  EXPECT_LE((rotation - rz(yaw) * ry(pitch) * rx(roll)).cwiseAbs().maxCoeff(), 1e-12);
  // Not the other order (the test can tell them apart with these angles).
  EXPECT_GT((rotation - rx(roll) * ry(pitch) * rz(yaw)).cwiseAbs().maxCoeff(), 0.1);
  EXPECT_LE((rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(rotation.determinant(), 1.0, 1e-12);
}

TEST(PointCloud, QuarterTurnsAboutEachVehicleAxis) {
  const Eigen::Vector3d forward = Eigen::Vector3d::UnitX(), left = Eigen::Vector3d::UnitY(), up = Eigen::Vector3d::UnitZ();
  EXPECT_TRUE(near(left, rotation_zyx(0, 0, kQuarterTurn) * forward));   // positive yaw turns left
  EXPECT_TRUE(near(-up, rotation_zyx(0, kQuarterTurn, 0) * forward));    // positive pitch lowers the nose
  EXPECT_TRUE(near(up, rotation_zyx(kQuarterTurn, 0, 0) * left));        // positive roll lifts the left side
  // Roll first: roll 90 then yaw 90 takes left to up (the roll) and keeps it there (yaw is about up).
  EXPECT_TRUE(near(up, rotation_zyx(kQuarterTurn, 0, kQuarterTurn) * left));
  // Yaw last: pitch 90 then yaw 90 takes forward to down, which yaw leaves alone; left goes to -forward.
  EXPECT_TRUE(near(-up, rotation_zyx(0, kQuarterTurn, kQuarterTurn) * forward));
  EXPECT_TRUE(near(-forward, rotation_zyx(0, kQuarterTurn, kQuarterTurn) * left));
}

TEST(PointCloud, LevelCameraAxesInTheVehicleFrame) {
  CameraMount mount;
  mount.position_m = Eigen::Vector3d(1.2, -0.3, 1.5);
  const CameraToVehicle transform(mount);
  // Optical z (forward) -> vehicle x; optical x (right) -> vehicle -y; optical y (down) -> vehicle -z.
  EXPECT_TRUE(near(mount.position_m + Eigen::Vector3d(4, 0, 0), transform.apply({0, 0, 4})));
  EXPECT_TRUE(near(mount.position_m + Eigen::Vector3d(0, -2, 0), transform.apply({2, 0, 0})));
  EXPECT_TRUE(near(mount.position_m + Eigen::Vector3d(0, 0, -1.5), transform.apply({0, 1.5, 0})));
  EXPECT_NEAR(transform.rotation().determinant(), 1.0, 1e-12);  // a rotation, not a reflection
}

// A camera 1.5 m up, pitched down 10 degrees and yawed 30 degrees left: the point on its optical
// axis at range h / sin(10 deg) lies on the ground (vehicle z = 0), straight ahead of the camera
// along the yawed direction.
TEST(PointCloud, PitchedCameraSeesTheGroundAtZeroHeight) {
  CameraMount mount;
  mount.pitch_rad = 10.0 * std::numbers::pi / 180.0;
  mount.yaw_rad = 30.0 * std::numbers::pi / 180.0;
  mount.position_m = Eigen::Vector3d(0, 0, 1.5);
  const CameraToVehicle transform(mount);
  const double range_m = 1.5 / std::sin(mount.pitch_rad);
  const Eigen::Vector3d ground = transform.apply({0, 0, range_m});
  const double ahead_m = range_m * std::cos(mount.pitch_rad);
  EXPECT_TRUE(near(Eigen::Vector3d(ahead_m * std::cos(mount.yaw_rad), ahead_m * std::sin(mount.yaw_rad), 0), ground, 1e-9));
}

CameraPoints small_points() {
  const BufferFormat millimetres{ElementType::s32, 0};
  CameraPoints points{Plane(3, 2, millimetres), Plane(3, 2, millimetres), Plane(3, 2, millimetres)};
  const int32_t values[6][3] = {{1000, -500, 4000}, {kernels::kNoPointMm, kernels::kNoPointMm, kernels::kNoPointMm},
                                {-250, 125, 2500},  {0, 1500, 3000},
                                {kernels::kNoPointMm, kernels::kNoPointMm, kernels::kNoPointMm}, {7, -7, 123456}};
  for (int i = 0; i < 6; ++i) {
    points.x_mm.at<int32_t>(i % 3, i / 3) = values[i][0];
    points.y_mm.at<int32_t>(i % 3, i / 3) = values[i][1];
    points.z_mm.at<int32_t>(i % 3, i / 3) = values[i][2];
  }
  return points;
}

TEST(PointCloud, CollectsValidPointsInMetresWithTheirColours) {
  const CameraPoints points = small_points();
  Plane grey(3, 2, {ElementType::u8, 0});
  for (int i = 0; i < 6; ++i) grey.at<uint8_t>(i % 3, i / 3) = static_cast<uint8_t>(10 * (i + 1));
  const PointCloud cloud = collect_points(points, grey_view(grey));
  ASSERT_EQ(cloud.points.size(), 4u);
  EXPECT_EQ(cloud.frame, "camera");
  EXPECT_EQ(cloud.points[0], (CloudPoint{1.0f, -0.5f, 4.0f, 10, 10, 10}));
  EXPECT_EQ(cloud.points[1], (CloudPoint{-0.25f, 0.125f, 2.5f, 30, 30, 30}));
  EXPECT_EQ(cloud.points[3], (CloudPoint{0.007f, -0.007f, 123.456f, 60, 60, 60}));

  // RGB colours, and the vehicle frame.
  std::vector<uint8_t> rgb(3 * 2 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<uint8_t>(i);
  CameraMount mount;
  mount.position_m = Eigen::Vector3d(0, 0, 1.5);
  const CameraToVehicle transform(mount);
  const PointCloud vehicle = collect_points(points, {rgb.data(), 9, 3, 2, 3}, &transform);
  ASSERT_EQ(vehicle.points.size(), 4u);
  EXPECT_EQ(vehicle.frame, "vehicle");
  // Pixel (0, 1): camera (0, 1.5, 3) -> vehicle (3, 0, 0): a ground point 1.5 m below the camera.
  EXPECT_EQ(vehicle.points[2], (CloudPoint{3.0f, 0.0f, 0.0f, 9, 10, 11}));
}

TEST(PointCloudMustFail, RefusesPlanesAndImagesOfDifferentSizes) {
  const CameraPoints points = small_points();
  Plane grey(4, 2, {ElementType::u8, 0});
  try {
    collect_points(points, grey_view(grey));
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "collect_points: colour image size: expected 3x2 (the z plane's), got 4x2");
  }
  Plane wrong(3, 2, {ElementType::s16, 4});
  EXPECT_THROW(grey_view(wrong), std::invalid_argument);
}

PointCloud sample_cloud() {
  PointCloud cloud;
  cloud.frame = "camera";
  for (int i = 0; i < 50; ++i) {
    cloud.points.push_back({0.001f * static_cast<float>(i * 37 - 900), -1.0f / static_cast<float>(i + 3),
                            12.345f + static_cast<float>(i), static_cast<uint8_t>(i), static_cast<uint8_t>(255 - i),
                            static_cast<uint8_t>(i * 5)});
  }
  return cloud;
}

TEST(PointCloud, PlyRoundTripsInBothEncodings) {
  testing::ScratchDirectory scratch("point_cloud_test");
  const PointCloud cloud = sample_cloud();
  for (PlyEncoding encoding : {PlyEncoding::binary_little_endian, PlyEncoding::ascii}) {
    const std::string path = scratch.path(encoding == PlyEncoding::ascii ? "ascii.ply" : "binary.ply");
    write_ply(path, cloud, encoding);
    const testing::PlyFile file = testing::read_ply(path);
    EXPECT_EQ(file.format, encoding == PlyEncoding::ascii ? "ascii" : "binary_little_endian");
    ASSERT_EQ(file.comments.size(), 1u);
    EXPECT_NE(file.comments[0].find("camera frame (x right, y down, z forward)"), std::string::npos);
    ASSERT_EQ(file.vertices.size(), cloud.points.size());
    for (size_t i = 0; i < cloud.points.size(); ++i) {
      const CloudPoint& point = cloud.points[i];
      const testing::PlyVertex& vertex = file.vertices[i];
      // Exact in both encodings: ASCII holds each float's round-trip decimal form.
      EXPECT_EQ(vertex.x, point.x_m) << i;
      EXPECT_EQ(vertex.y, point.y_m) << i;
      EXPECT_EQ(vertex.z, point.z_m) << i;
      EXPECT_EQ(vertex.red, point.red) << i;
      EXPECT_EQ(vertex.green, point.green) << i;
      EXPECT_EQ(vertex.blue, point.blue) << i;
    }
  }
  // An empty cloud is a valid file with no vertices.
  write_ply(scratch.path("empty.ply"), PointCloud{}, PlyEncoding::binary_little_endian);
  EXPECT_TRUE(testing::read_ply(scratch.path("empty.ply")).vertices.empty());
}

TEST(PointCloudMustFail, AFailedWriteLeavesNoFile) {
  testing::ScratchDirectory scratch("point_cloud_test");
  const std::string path = scratch.path("missing-folder/cloud.ply");
  EXPECT_THROW(write_ply(path, sample_cloud(), PlyEncoding::ascii), FileWriteError);
  EXPECT_FALSE(std::filesystem::exists(scratch.path("missing-folder")));
  // Over an existing file: replaced whole.
  write_ply(scratch.path("cloud.ply"), sample_cloud(), PlyEncoding::ascii);
  write_ply(scratch.path("cloud.ply"), PointCloud{}, PlyEncoding::ascii);
  EXPECT_TRUE(testing::read_ply(scratch.path("cloud.ply")).vertices.empty());
  size_t files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(scratch.root())) ++files;
  EXPECT_EQ(files, 1u);  // no temporary left behind
}

}  // namespace
}  // namespace lpstereo::arm
