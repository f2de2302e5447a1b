// lpstereo synth as a user meets it: a small lineup folder with every file, readable back; bad
// values give one line and exit 2; an unwritable folder gives one line, exit 1 and nothing behind.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/calibration.h"
#include "io/disparity_io.h"
#include "io/kitti_poses.h"
#include "io/stereo_synth.h"
#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace {

namespace fs = std::filesystem;
using lpstereo::testing::Result;
using lpstereo::testing::count_lines;
using lpstereo::testing::run;

class SynthCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  // The JSON file at `name` under the scratch folder.
  nlohmann::json json_file(const std::string& name) const {
    std::ifstream file(path(name));
    return nlohmann::json::parse(file);
  }
  int entries() const {
    int count = 0;
    for (const auto& entry : fs::directory_iterator(scratch_.root())) {
      (void)entry;
      ++count;
    }
    return count;
  }
  // Each (arguments, the option the one-line message must name): exit 2, one line, no folder.
  template <size_t N>
  void expect_usage_errors(const std::pair<std::string, std::string> (&cases)[N]) {
    for (const auto& [arguments, named] : cases) {
      SCOPED_TRACE(arguments);
      const Result result = run("synth -o " + path("bad") + " " + arguments);
      EXPECT_EQ(result.exit_code, 2) << result.err;
      EXPECT_EQ(count_lines(result.err), 1) << result.err;
      EXPECT_NE(result.err.find(named), std::string::npos) << result.err;
      EXPECT_FALSE(fs::exists(path("bad")));
    }
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_synth_cli"};
};

TEST_F(SynthCli, LineupFolderReadsBack) {
  const Result result = run("synth -o " + path("scene") +
                            " --width 320 --height 160 --hfov-deg 60 --baseline-m 0.3 --camera-height-m 1.5 --lineup 10 "
                            "--noise-sigma 1 --gain 1.05 --offset -3 --colour");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("rendered in"), std::string::npos) << result.out;
  for (const char* name : {"left.png", "right.png", "left_colour.png", "right_colour.png", "disparity.png", "object_ids.png",
                           "objects.json", "ground.json", "calib.yaml", "calib_cam_to_cam.txt"}) {
    EXPECT_TRUE(fs::is_regular_file(path("scene") + "/" + name)) << name;
  }
  const nlohmann::json json = json_file("scene/objects.json");
  ASSERT_EQ(json["objects"].size(), 6u);
  EXPECT_EQ(json["objects"][3]["class"], "tape_roll");
  EXPECT_NEAR(json["objects"][3]["size_m"]["h"].get<double>(), 0.07, 1e-12);
  for (const auto& object : json["objects"]) {
    EXPECT_NEAR(object["distance_m"].get<double>(), 10, 1e-9);
    EXPECT_GT(object["visible_pixels"].get<int>(), 0) << object["class"];
  }
  const lpstereo::io::StereoCalibration kitti = lpstereo::io::load_stereo_calibration(path("scene") + "/calib_cam_to_cam.txt");
  EXPECT_NEAR(kitti.baseline_m(), 0.3, 1e-9);
  EXPECT_NEAR(kitti.focal_px(), json["focal_px"].get<double>(), 1e-6);
  const cv::Mat disparity = lpstereo::io::read_kitti_disparity_png_px(path("scene") + "/disparity.png");
  // The bottom row is road about 5.2 m ahead: d = f B / Z = 277.1 * 0.3 * 0.287 / 1.5 = 15.9 px.
  EXPECT_NEAR(disparity.at<float>(159, 5), 277.128 * 0.3 * (79.5 / 277.128) / 1.5, 0.01);
  EXPECT_EQ(entries(), 1);
}

// The surface and the lenses reach the scene and its record; the sequence takes them too.
TEST_F(SynthCli, SurfaceAndLensesReachTheSceneAndItsRecord) {
  const Result result = run("synth -o " + path("asphalt") + " --width 96 --height 64 --samples 1 --surface asphalt --vignetting 0.25 "
                            "--blur-px 0.5");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("surface asphalt"), std::string::npos) << result.out;
  const nlohmann::json json = json_file("asphalt/objects.json");
  EXPECT_EQ(json["road_surface"], "asphalt");
  EXPECT_DOUBLE_EQ(json["vignetting"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(json["right_vignetting"].get<double>(), 0.25 * lpstereo::io::kRightVignettingRatio);
  EXPECT_DOUBLE_EQ(json["blur_sigma_px"].get<double>(), 0.5);
  const Result sequence = run("synth --sequence urban --frames 2 --width 96 --height 64 --samples 1 --surface asphalt --blur-px 0.5 -o " +
                              path("sequence"));
  ASSERT_EQ(sequence.exit_code, 0) << sequence.err;
  const nlohmann::json sequence_json = json_file("sequence/sequence.json");
  EXPECT_EQ(sequence_json["road_surface"], "asphalt");
  EXPECT_DOUBLE_EQ(sequence_json["blur_sigma_px"].get<double>(), 0.5);
  // --real-camera: io::use_real_camera_pair, an option given beside it wins.
  ASSERT_EQ(run("synth -o " + path("real") + " --width 96 --height 64 --samples 1 --real-camera --blur-px 0.2").exit_code, 0);
  const nlohmann::json real = json_file("real/objects.json");
  EXPECT_DOUBLE_EQ(real["noise_sigma"].get<double>(), 2);
  EXPECT_DOUBLE_EQ(real["right_gain"].get<double>(), 1.08);
  EXPECT_DOUBLE_EQ(real["right_offset"].get<double>(), -5);
  EXPECT_DOUBLE_EQ(real["vignetting"].get<double>(), 0.3);
  EXPECT_DOUBLE_EQ(real["blur_sigma_px"].get<double>(), 0.2);
  EXPECT_EQ(real["road_surface"], "textured");
  const std::pair<std::string, std::string> cases[] = {
      {"--surface gravel", "--surface: expected textured or asphalt, got 'gravel'"},
      {"--vignetting 0.9", "--vignetting: expected"},
      {"--blur-px -1", "--blur-px: expected"},
      {"--flight --surface asphalt", "--surface"},
      {"--flight --real-camera", "--real-camera"},
  };
  expect_usage_errors(cases);
}

TEST_F(SynthCli, EmptySceneHasNoObjects) {
  const Result result = run("synth -o " + path("empty") + " --width 64 --height 32 --empty --slope-deg 2");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(json_file("empty/objects.json")["objects"].size(), 0u);
  const cv::Mat ids = cv::imread(path("empty") + "/object_ids.png", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(cv::countNonZero(ids), 0);
}

TEST_F(SynthCli, BadValuesGiveOneLineAndExit2) {
  for (const std::string arguments : {"--hfov-deg 0", "--baseline-m -1", "--width 8", "--noise-sigma -2", "--lineup -5",
                                      "--slope-deg 30", "--samples 9", "--pitch-deg 40", "--width abc", "--lineup 20 --empty"}) {
    SCOPED_TRACE(arguments);
    const Result result = run("synth -o " + path("bad") + " " + arguments);
    EXPECT_EQ(result.exit_code, 2) << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_FALSE(fs::exists(path("bad")));
  }
  const Result hfov = run("synth -o " + path("bad") + " --hfov-deg 200");
  EXPECT_NE(hfov.err.find("hfov-deg"), std::string::npos) << hfov.err;
  EXPECT_NE(hfov.err.find("200"), std::string::npos) << hfov.err;
}

TEST_F(SynthCli, HeightFieldGroundWithRollWritesItsTruth) {
  const Result result = run("synth -o " + path("field") + " --width 96 --height 48 --samples 1 --ground ditch-u+berm --berm-height-m 1.1 "
                            "--hills-amplitude-m 0.3 --roll-deg 2");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("ditch-u+berm"), std::string::npos) << result.out;
  const nlohmann::json ground = json_file("field/ground.json");
  EXPECT_EQ(ground["ditch"]["shape"], "U");
  EXPECT_NEAR(ground["ditch"]["depth_m"].get<double>(), 0.6, 1e-12);       // the kind's default,
  EXPECT_NEAR(ground["berm"]["height_m"].get<double>(), 1.1, 1e-12);       // replaced by its option,
  EXPECT_NEAR(ground["hills"]["amplitude_m"].get<double>(), 0.3, 1e-12);   // or added by an option alone
  EXPECT_NEAR(ground["roll_rad"].get<double>(), 2 * 3.14159265358979323846 / 180, 1e-12);
}

TEST_F(SynthCli, BadGroundOrRollGivesOneLineAndExit2) {
  for (const std::string arguments : {"--ground volcano", "--ground hills+", "--roll-deg 40", "--ditch-width-m 0 --ground ditch",
                                      "--rough-amplitude-m -1", "--flight --ground hills", "--flight --roll-deg 1"}) {
    SCOPED_TRACE(arguments);
    const Result result = run("synth -o " + path("bad") + " --width 64 --height 32 " + arguments);
    EXPECT_EQ(result.exit_code, 2) << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_FALSE(fs::exists(path("bad")));
  }
  EXPECT_NE(run("synth -o " + path("bad") + " --ground volcano").err.find("volcano"), std::string::npos);
  EXPECT_NE(run("synth -o " + path("bad") + " --ditch-width-m 0 --ground ditch").err.find("ditch-width-m"), std::string::npos);
}

TEST_F(SynthCli, UnwritableFolderGivesOneLineAndExit1) {
  std::ofstream(path("file")) << "not a folder";
  const Result result = run("synth --width 64 --height 32 -o " + path("file") + "/scene");
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find(path("file")), std::string::npos) << result.err;
  EXPECT_EQ(entries(), 1);  // only the file itself: no temporary folder left
}

TEST_F(SynthCli, FlightFolderReadsBack) {
  // 6 frames over the flight with a quarter turn at each corner: frame 0 on the pad, frame 5 back on it.
  const Result result = run("synth --flight -o " + path("flight") +
                            " --width 64 --height 48 --frames 6 --yaw corners:90 --noise 1 --samples 1 --disparity --seed 3");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("ms per frame"), std::string::npos) << result.out;
  const std::string folder = path("flight") + "/";
  for (const char* name : {"left/000000.png", "left/000005.png", "right/000005.png", "disparity/000005.png", "poses.txt", "times.txt",
                           "heights.txt", "calib.txt", "calib.yaml", "flight.json"}) {
    EXPECT_TRUE(fs::is_regular_file(folder + name)) << name;
  }
  EXPECT_FALSE(fs::exists(folder + "left/000006.png"));
  const std::vector<Eigen::Isometry3d> poses = lpstereo::io::read_kitti_poses(folder + "poses.txt");
  ASSERT_EQ(poses.size(), 6u);
  EXPECT_TRUE(poses.front().matrix().isIdentity(1e-12));
  EXPECT_TRUE(poses.back().matrix().isIdentity(1e-9));  // landed where it took off, turned 4 x 90 degrees
  std::ifstream heights_file(folder + "heights.txt");
  std::vector<double> heights;
  for (double h = 0; heights_file >> h;) heights.push_back(h);
  ASSERT_EQ(heights.size(), 6u);
  EXPECT_NEAR(heights.front(), 0.4, 1e-12);
  EXPECT_NEAR(heights.back(), 0.4, 1e-12);
  for (size_t i = 0; i < 6; ++i) EXPECT_NEAR(poses[i].translation().z(), 0.4 - heights[i], 1e-9) << i;  // z = down

  const lpstereo::io::StereoCalibration odometry = lpstereo::io::load_stereo_calibration(folder + "calib.txt");
  EXPECT_EQ(odometry.format, "kitti_odometry");
  EXPECT_NEAR(odometry.baseline_m(), 0.10, 1e-9);
  EXPECT_NEAR(odometry.focal_px(), 32.0, 1e-9);  // 64 px at the default 90 degrees: 32 / tan 45
  EXPECT_NEAR(lpstereo::io::load_stereo_calibration(folder + "calib.yaml").baseline_m(), 0.10, 1e-9);

  std::ifstream json_file(folder + "flight.json");
  const nlohmann::json json = nlohmann::json::parse(json_file);
  ASSERT_EQ(json["waypoints_m"].size(), 4u);
  EXPECT_NEAR(json["waypoints_m"][0][0].get<double>(), 3.0, 1e-12);
  EXPECT_NEAR(json["waypoints_m"][0][2].get<double>(), 2.0, 1e-12);
  EXPECT_NEAR(json["pad"]["size_m"].get<double>(), 1.0, 1e-12);
  EXPECT_EQ(json["frames"], 6);

  // Exact disparity at the last frame (on the pad, 0.4 m): f B / h = 32 * 0.1 / 0.4 = 8 px.
  const cv::Mat disparity = lpstereo::io::read_kitti_disparity_png_px(folder + "disparity/000005.png");
  EXPECT_NEAR(disparity.at<float>(20, 30), 8.0, 1.0 / 256);
  EXPECT_EQ(entries(), 1);
}

TEST_F(SynthCli, FlightIntoAnUnwritableFolderGivesOneLineAndExit1) {
  std::ofstream(path("file")) << "not a folder";
  const Result result = run("synth --flight --frames 2 --width 16 --height 16 -o " + path("file") + "/flight");
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find(path("file")), std::string::npos) << result.err;
  EXPECT_EQ(entries(), 1);  // no temporary folder left
}

TEST_F(SynthCli, FlightBadOptionsGiveOneLineAndExit2) {
  const std::pair<std::string, std::string> cases[] = {
      {"--flight --yaw spin", "--yaw"},
      {"--flight --yaw corners:90,90", "--yaw"},
      {"--flight --yaw continuous:abc", "--yaw"},
      {"--flight --yaw corners:500", "--yaw"},
      {"--flight --side-m 0.5", "--side-m"},
      {"--flight --frames 1", "--frames"},
      {"--flight --start-height-m 3", "--start-height-m"},
      {"--flight --lineup 10", "--lineup"},
      {"--flight --pitch-deg 5", "--pitch-deg"},
      {"--flight --focal-px 100 --hfov-deg 60", "--focal-px"},
      {"--fps 10", "--fps"},
      {"--flight --frames 5 --fps 3", "--"},
  };
  expect_usage_errors(cases);
}

TEST_F(SynthCli, SequenceFolderReadsBack) {
  const Result result = run("synth --sequence floating --frames 3 --fps 5 --camera-speed-mps 4 --seed 2 --width 96 --height 64 "
                            "--samples 1 --colour -o " + path("sequence"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("ms per frame"), std::string::npos) << result.out;
  for (const char* name : {"left/000002.png", "right/000002.png", "left_colour/000000.png", "right_colour/000001.png",
                           "disparity/000002.png", "object_ids/000002.png", "poses.txt", "truth.jsonl", "calib.yaml",
                           "calib_cam_to_cam.txt", "sequence.json"}) {
    EXPECT_TRUE(fs::is_regular_file(path("sequence") + "/" + name)) << name;
  }
  const std::vector<Eigen::Isometry3d> poses = lpstereo::io::read_kitti_poses(path("sequence") + "/poses.txt");
  ASSERT_EQ(poses.size(), 3u);
  // 4 m/s at 5 fps: 0.8 m forward a frame (no yaw: along the camera's level z).
  EXPECT_NEAR(poses[2].translation().norm(), 1.6, 1e-6);
  std::ifstream file(path("sequence") + "/truth.jsonl");
  std::string line;
  int frames = 0;
  bool floating = false;
  while (std::getline(file, line)) {
    const nlohmann::json json = nlohmann::json::parse(line);
    EXPECT_EQ(json["frame"].get<int>(), frames++);
    for (const auto& object : json["objects"]) floating = floating || object["class"] == "hanging_sign";
  }
  EXPECT_EQ(frames, 3);
  EXPECT_TRUE(floating);
}

TEST_F(SynthCli, SequenceBadOptionsGiveOneLineAndExit2) {
  const std::pair<std::string, std::string> cases[] = {
      {"--sequence harbour", "--sequence"},
      {"--sequence urban --fps 0", "--fps"},
      {"--sequence urban --frames 0", "--frames"},
      {"--sequence urban --camera-speed-mps 100", "--camera-speed-mps"},
      {"--sequence urban --camera-yaw-rate-deg-s 90", "--camera-yaw-rate-deg-s"},
      {"--sequence urban --lineup 10", "--lineup"},
      {"--sequence urban --flight", "--sequence"},
      {"--sequence urban --yaw none", "--yaw"},
      {"--camera-speed-mps 3", "--camera-speed-mps"},
  };
  expect_usage_errors(cases);
}

}  // namespace
