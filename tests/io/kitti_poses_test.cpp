// The KITTI pose format: exact round trips, the devkit's layout, and one-line errors naming the file
// and the line for what is not a pose.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "dag/atomic_file.h"
#include "io/kitti_poses.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

class KittiPoses : public ::testing::Test {
 protected:
  std::string file_with(const std::string& name, const std::string& text) const {
    const std::string path = scratch_.path(name);
    std::ofstream file(path, std::ios::binary);
    file << text;
    return path;
  }
  // The PoseFileError's message for reading `text`, or "(no error)".
  std::string error_reading(const std::string& text) const {
    const std::string path = file_with("bad.txt", text);
    try {
      read_kitti_poses(path);
    } catch (const PoseFileError& error) {
      return error.what();
    }
    return "(no error)";
  }
  std::string path(const std::string& name) const { return scratch_.path(name); }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_kitti_poses"};
};

constexpr const char* kIdentity = "1 0 0 0 0 1 0 0 0 0 1 0\n";

TEST_F(KittiPoses, RoundTripIsBitExact) {
  std::mt19937 random(8);
  std::uniform_real_distribution<double> uniform(-100, 100);
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < 20; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(uniform(random), uniform(random), uniform(random), uniform(random))
                        .normalized()
                        .toRotationMatrix();
    pose.translation() = Eigen::Vector3d(uniform(random), uniform(random), uniform(random)) / 7;  // not short decimals
    poses.push_back(pose);
  }
  write_kitti_poses(path("poses.txt"), poses);
  const std::vector<Eigen::Isometry3d> read = read_kitti_poses(path("poses.txt"));
  ASSERT_EQ(read.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) EXPECT_EQ(read[i].matrix(), poses[i].matrix()) << "pose " << i;
}

TEST_F(KittiPoses, ReadsTheDevkitLayoutRowMajor) {
  // [R | t] row by row: r00 r01 r02 tx r10 r11 r12 ty r20 r21 r22 tz. A quarter turn about y, then a
  // blank line, CRLF, and a last line without a newline (as the shared kitti_odometry_06 ends).
  const std::string path = file_with("poses.txt", std::string(kIdentity) + "\n0 0 1 1.5 0 1 0 -2 -1 0 0 3.25\r\n" +
                                                      "1 0 0 0 0 1 0 0 0 0 1 7");
  const std::vector<Eigen::Isometry3d> poses = read_kitti_poses(path);
  ASSERT_EQ(poses.size(), 3u);
  EXPECT_TRUE(poses[0].isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_EQ(poses[1].translation(), Eigen::Vector3d(1.5, -2, 3.25));
  EXPECT_EQ(poses[1].linear()(0, 2), 1);
  EXPECT_EQ(poses[1].linear()(2, 0), -1);
  // The camera's forward axis (z) turns to +x: a point 1 m ahead lands at x = 1 + 1.5.
  EXPECT_TRUE((poses[1] * Eigen::Vector3d(0, 0, 1)).isApprox(Eigen::Vector3d(2.5, -2, 3.25)));
  EXPECT_EQ(poses[2].translation().z(), 7);
}

TEST_F(KittiPoses, WritesTwelveNumbersPerLine) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(1, 2, 3);
  write_kitti_poses(path("one.txt"), {Eigen::Isometry3d::Identity(), pose});
  std::ifstream file(path("one.txt"));
  std::string first, second, third;
  std::getline(file, first);
  std::getline(file, second);
  EXPECT_EQ(first + "\n", kIdentity);
  EXPECT_EQ(second, "1 0 0 1 0 1 0 2 0 0 1 3");
  EXPECT_FALSE(std::getline(file, third));
}

TEST_F(KittiPoses, MalformedLinesNameTheFileAndLine) {
  const std::string file = path("bad.txt");
  EXPECT_EQ(error_reading(std::string(kIdentity) + "1 0 0 0 0 1 0 0 0 0 1\n"),
            file + ":2: expected 12 numbers (a 3x4 pose, row-major), got 11");
  EXPECT_EQ(error_reading("1 0 0 0 0 1 0 0 0 0 1 0 5\n"), file + ":1: expected 12 numbers (a 3x4 pose, row-major), got more");
  EXPECT_EQ(error_reading(std::string(kIdentity) + kIdentity + "1 0 0 x 0 1 0 0 0 0 1 0\n"),
            file + ":3: expected 12 numbers (a 3x4 pose, row-major), got 3");
  EXPECT_EQ(error_reading("1,0,0,0,0,1,0,0,0,0,1,0\n"), file + ":1: expected 12 numbers (a 3x4 pose, row-major), got 1");
  // Numbers a double cannot hold stop the line as a word does.
  EXPECT_EQ(error_reading("1 0 0 1e999 0 1 0 0 0 0 1 0\n").rfind(file + ":1: expected 12 numbers", 0), 0u);
}

TEST_F(KittiPoses, RotationPartMustBeARotation) {
  const std::string scaled = error_reading("2 0 0 0 0 2 0 0 0 0 2 0\n");
  EXPECT_EQ(scaled.rfind(path("bad.txt") + ":1: expected a rotation in the first 3 columns (R^T R = I, det 1), got |R^T R - I| 3", 0),
            0u)
      << scaled;
  const std::string mirrored = error_reading(std::string(kIdentity) + "-1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_NE(mirrored.find(":2: expected a rotation"), std::string::npos) << mirrored;
  EXPECT_NE(mirrored.find("det -1"), std::string::npos) << mirrored;
  // Printed poses carry 7 significant digits (the shared set): within the 1e-3 tolerance.
  EXPECT_EQ(error_reading("9.999995e-01 7.196824e-04 -6.870876e-04 -1.401751e-02 -7.197717e-04 9.999997e-01 -1.295633e-04 "
                          "-2.820321e-02 6.869946e-04 1.300585e-04 9.999998e-01 1.198998e+00\n"),
            "(no error)");
}

TEST_F(KittiPoses, EveryErrorIsOneLine) {
  for (const std::string& text : {std::string("1 2 3\n"), std::string("2 0 0 0 0 2 0 0 0 0 2 0\n"), std::string("a\n")}) {
    const std::string message = error_reading(text);
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_NE(message, "(no error)");
  }
}

TEST_F(KittiPoses, MissingFileAndEmptyFile) {
  try {
    read_kitti_poses(path("none.txt"));
    FAIL() << "no error for a missing file";
  } catch (const PoseFileError& error) {
    EXPECT_EQ(std::string(error.what()), path("none.txt") + ": cannot open the pose file");
  }
  EXPECT_TRUE(read_kitti_poses(file_with("empty.txt", "")).empty());  // the caller decides whether none is an error
}

TEST_F(KittiPoses, FailedWriteLeavesNothing) {
  EXPECT_THROW(write_kitti_poses(path("missing/poses.txt"), {Eigen::Isometry3d::Identity()}), FileWriteError);
  EXPECT_TRUE(std::filesystem::is_empty(scratch_.root()));
}

}  // namespace
}  // namespace lpstereo::io
