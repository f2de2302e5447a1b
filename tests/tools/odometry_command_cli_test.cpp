// lpstereo odometry end to end: a short rendered sequence with a known trajectory
// (tests/support/moving_room.h) written as PNG files with a KITTI odometry calib.txt, the trajectory
// read back in the KITTI pose format and compared with the truth; bad input (no first frame, patterns
// without a frame number, a missing or unreadable calibration, bad tuning values) gives one line, the
// documented exit code and no output file.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/image_io.h"
#include "io/kitti_poses.h"
#include "tests/support/cli_runner.h"
#include "tests/support/moving_room.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo {
namespace {

namespace fs = std::filesystem;
using testing::Result;
using testing::count_lines;
using testing::run;
namespace room = testing::moving_room;

class OdometryCli : public ::testing::Test {
 protected:
  OdometryCli() : scratch_("lpstereo_odometry_cli") {}
  std::string path(const std::string& name) const { return scratch_.path(name); }

  // Frames 0 .. frames - 1 of the moving room into folder/left_%06d.png, right_%06d.png, and a KITTI
  // odometry calib.txt (P0, P1: P1(0,3) = -f B).
  void write_sequence(const std::string& folder, int frames) const {
    fs::create_directories(folder);
    for (int frame = 0; frame < frames; ++frame) {
      for (bool right : {false, true}) {
        char name[48];
        std::snprintf(name, sizeof name, "/%s_%06d.png", right ? "right" : "left", frame);
        ASSERT_TRUE(cv::imwrite(folder + name, io::plane_to_mat(room::render(room::true_pose(frame), right))));
      }
    }
    std::ofstream calib(folder + "/calib.txt");
    for (double tx : {0.0, -room::kFocalPx * room::kBaselineM}) {
      calib << "P" << (tx == 0.0 ? 0 : 1) << ": " << room::kFocalPx << " 0 " << room::kCxPx << " " << tx << " 0 " << room::kFocalPx
            << " " << room::kCyPx << " 0 0 0 1 0\n";
    }
  }

 private:
  testing::ScratchDirectory scratch_;
};

TEST_F(OdometryCli, WritesTheTrajectoryOfARenderedSequence) {
  constexpr int kFrames = 4;
  const std::string folder = path("room");
  write_sequence(folder, kFrames);
  const std::string output = path("trajectory.txt"), stats = path("stats.jsonl");
  const Result result = run("odometry --left '" + folder + "/left_%06d.png' --right '" + folder + "/right_%06d.png' --calib " +
                            folder + "/calib.txt -o " + output + " --stats " + stats + " --max-disparity 120");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("4 frames (0 .. 3), 0 invalid"), std::string::npos) << result.out;
  const std::vector<Eigen::Isometry3d> poses = io::read_kitti_poses(output);
  ASSERT_EQ(poses.size(), static_cast<size_t>(kFrames));
  EXPECT_TRUE(poses[0].isApprox(Eigen::Isometry3d::Identity()));
  for (int frame = 1; frame < kFrames; ++frame) {
    EXPECT_LT((poses[frame].translation() - room::true_pose(frame).translation()).norm(), 0.02 * frame) << "frame " << frame;
  }
  std::ifstream stats_file(stats);
  std::string line;
  int stats_lines = 0;
  while (std::getline(stats_file, line)) {
    const nlohmann::json record = nlohmann::json::parse(line);
    EXPECT_EQ(record.at("frame"), stats_lines);
    EXPECT_TRUE(record.at("valid").get<bool>());
    if (stats_lines > 0) {
      EXPECT_GT(record.at("inliers").get<int>(), 20);
    }
    ++stats_lines;
  }
  EXPECT_EQ(stats_lines, kFrames);
}

TEST_F(OdometryCli, BadInputGivesOneLineAndNoFile) {
  const std::string folder = path("room");
  write_sequence(folder, 2);
  std::ofstream(path("garbage.txt")) << "this is not a calibration\n";
  const std::string output = path("trajectory.txt");
  const std::string patterns = " --left '" + folder + "/left_%06d.png' --right '" + folder + "/right_%06d.png'";
  const std::string calib = " --calib " + folder + "/calib.txt";
  const auto expect_refused = [&](const Result& result, int exit_code, const std::string& needle) {
    EXPECT_EQ(result.exit_code, exit_code) << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(needle), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(output));
  };
  // No first frame: files that do not exist, and --first past the end.
  expect_refused(run("odometry --left '" + folder + "/nothing_%06d.png' --right '" + folder + "/right_%06d.png'" + calib + " -o " +
                     output),
                 1, "nothing_000000.png");
  expect_refused(run("odometry" + patterns + calib + " -o " + output + " --first 5"), 1, "frame 5");
  // A pattern without a frame number.
  expect_refused(run("odometry --left " + folder + "/left_000000.png --right '" + folder + "/right_%06d.png'" + calib + " -o " +
                     output),
                 2, "--left");
  // A missing calibration file and one that is not a calibration.
  expect_refused(run("odometry" + patterns + " --calib " + path("missing.txt") + " -o " + output), 1, "missing.txt");
  expect_refused(run("odometry" + patterns + " --calib " + path("garbage.txt") + " -o " + output), 1, "garbage.txt");
  // A tuning value out of range names the parameter.
  expect_refused(run("odometry" + patterns + calib + " -o " + output + " --ratio 2"), 2, "ratio_test");
  // --calib is required.
  expect_refused(run("odometry" + patterns + " -o " + output), 2, "--calib");
}

}  // namespace
}  // namespace lpstereo
