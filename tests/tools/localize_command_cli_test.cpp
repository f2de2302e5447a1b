// lpstereo localize end to end on a short flight written by `lpstereo synth --flight` (small images):
// the trajectory (KITTI poses, one line per frame, frame 0 the identity), the keyframe database, the
// per-frame filter log; the database loaded back as the map of a second run; a sequence with a
// missing frame read up to the gap as `lpstereo odometry` reads it; bad input (a corrupt database, no
// first frame, a pattern without a frame number, a bad calibration) gives one line, the documented
// exit code and no trajectory.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "io/kitti_poses.h"
#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo {
namespace {

namespace fs = std::filesystem;
using testing::Result;
using testing::count_lines;
using testing::run;

class LocalizeCli : public ::testing::Test {
 protected:
  LocalizeCli() : scratch_("lpstereo_localize_cli") {}
  std::string path(const std::string& name) const { return scratch_.path(name); }

  // A 1 m square at 1 m, 240x180, 5 fps (about 50 frames; the tests use the first few).
  std::string write_flight() const {
    const std::string folder = path("flight");
    const Result result = run("synth --flight -o " + folder +
                              " --width 240 --height 180 --side-m 1 --altitude-m 1 --fps 5 --samples 1 --noise 2 --seed 5");
    EXPECT_EQ(result.exit_code, 0) << result.err;
    return folder;
  }
  static std::string sequence(const std::string& folder) {
    return " --left '" + folder + "/left/%06d.png' --right '" + folder + "/right/%06d.png' --calib " + folder + "/calib.txt";
  }

 private:
  testing::ScratchDirectory scratch_;
};

TEST_F(LocalizeCli, WritesTrajectoryDatabaseAndLogThenUsesTheDatabaseAsMap) {
  const std::string folder = write_flight();
  constexpr int kFrames = 12;
  const std::string output = path("trajectory.txt"), database = path("keyframes.bin"), log = path("filter.jsonl");
  const Result result = run("localize" + sequence(folder) + " -o " + output + " --keyframes " + database + " --log " + log +
                            " --frames " + std::to_string(kFrames));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("12 frames (0 .. 11)"), std::string::npos) << result.out;
  const std::vector<Eigen::Isometry3d> poses = io::read_kitti_poses(output);
  ASSERT_EQ(poses.size(), static_cast<size_t>(kFrames));
  EXPECT_TRUE(poses[0].isApprox(Eigen::Isometry3d::Identity()));
  // The ground truth of the same frames (synth's poses.txt): the estimate follows the take-off.
  const std::vector<Eigen::Isometry3d> truth = io::read_kitti_poses(folder + "/poses.txt");
  for (int frame = 0; frame < kFrames; ++frame) {
    EXPECT_LT((poses[static_cast<size_t>(frame)].translation() - truth[static_cast<size_t>(frame)].translation()).norm(), 0.05)
        << "frame " << frame;
  }
  ASSERT_TRUE(fs::exists(database));
  std::ifstream log_file(log);
  std::string line;
  int log_lines = 0;
  while (std::getline(log_file, line)) {
    const nlohmann::json record = nlohmann::json::parse(line);
    EXPECT_EQ(record.at("frame"), log_lines);
    EXPECT_EQ(record.at("state").size(), 4u);
    EXPECT_EQ(record.at("covariance").size(), 16u);
    EXPECT_GT(record.at("position_sigma_m").get<double>(), 0.0);
    ++log_lines;
  }
  EXPECT_EQ(log_lines, kFrames);

  // Second run: the database is the map (at least the first keyframe, stored at take-off).
  const Result again = run("localize" + sequence(folder) + " -o " + output + " --keyframes " + database + " --frames 3");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.out.find("map " + database), std::string::npos) << again.out;
}

TEST_F(LocalizeCli, MissingFrameEndsTheSequenceLikeOdometry) {
  const std::string folder = write_flight();
  fs::remove(folder + "/right/000006.png");
  const std::string output = path("trajectory.txt");
  const Result result = run("localize" + sequence(folder) + " -o " + output + " --keyframes " + path("db.bin"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("6 frames (0 .. 5)"), std::string::npos) << result.out;
  EXPECT_EQ(io::read_kitti_poses(output).size(), 6u);
}

TEST_F(LocalizeCli, BadInputGivesOneLineAndNoFile) {
  const std::string folder = write_flight();
  const std::string output = path("trajectory.txt");
  const auto expect_refused = [&](const Result& result, int exit_code, const std::string& needle) {
    EXPECT_EQ(result.exit_code, exit_code) << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(needle), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(output));
  };
  // A corrupt keyframe database: not one at all, and a real one with a flipped byte (checksum).
  std::ofstream(path("garbage.bin")) << "this is not a keyframe database, but long enough to have a header";
  expect_refused(run("localize" + sequence(folder) + " -o " + output + " --keyframes " + path("garbage.bin")), 1, "garbage.bin");
  const std::string good = path("good.bin");
  ASSERT_EQ(run("localize" + sequence(folder) + " -o " + path("first.txt") + " --keyframes " + good + " --frames 3").exit_code, 0);
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_GT(bytes.size(), 40u);
  bytes[30] = static_cast<char>(bytes[30] ^ 0x5A);
  std::ofstream(path("flipped.bin"), std::ios::binary) << bytes;
  expect_refused(run("localize" + sequence(folder) + " -o " + output + " --keyframes " + path("flipped.bin")), 1, "flipped.bin");
  // No first frame, a pattern without a frame number, a missing calibration.
  expect_refused(run("localize --left '" + folder + "/left/x%06d.png' --right '" + folder + "/right/%06d.png' --calib " + folder +
                     "/calib.txt -o " + output + " --keyframes " + path("db.bin")),
                 1, "x000000.png");
  expect_refused(run("localize --left " + folder + "/left/000000.png --right '" + folder + "/right/%06d.png' --calib " + folder +
                     "/calib.txt -o " + output + " --keyframes " + path("db.bin")),
                 2, "--left");
  expect_refused(run("localize --left '" + folder + "/left/%06d.png' --right '" + folder + "/right/%06d.png' --calib " +
                     path("missing.txt") + " -o " + output + " --keyframes " + path("db.bin")),
                 1, "missing.txt");
  // --keyframes is required.
  expect_refused(run("localize" + sequence(folder) + " -o " + output), 2, "--keyframes");
}

}  // namespace
}  // namespace lpstereo
