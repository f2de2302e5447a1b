// lpstereo obstacles3d as a user meets it: a rendered lineup at 15 m (lpstereo synth, 640x288),
// copied to a 3-frame sequence of a static camera, run with each method: one parseable JSON line
// per frame with every field of issue 10's schema, the lineup's box (0.40 x 0.43 x 0.30 m) reported
// near its true position with its height above the road, the pictures per frame with --view; the grid
// methods report no tracks, the voxel method a static track from the third frame (acceptance 3).
// A single frame, and textureless frames (empty clouds, odometry failing), say on stderr that the
// camera is assumed static; the empty clouds are in each frame's status. An unknown method, a voxel size of
// 0 or below, and a missing first frame give one line, a non-zero exit and no output file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace {

namespace fs = std::filesystem;
using lpstereo::testing::Result;
using lpstereo::testing::run;

constexpr int kFrames = 3;
constexpr double kLineupM = 15.0;

std::vector<nlohmann::json> read_lines(const std::string& file) {
  std::ifstream stream(file);
  std::vector<nlohmann::json> lines;
  std::string line;
  while (std::getline(stream, line)) lines.push_back(nlohmann::json::parse(line));  // throws when not JSON
  return lines;
}

int line_count(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

class Obstacles3dCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  // The lineup at 15 m (hfov 60 deg, baseline 0.30 m, camera 1.5 m high, noise 1) as frames 0..2 of a
  // static camera: seq/left_00000i.png, seq/right_00000i.png, seq/calib.yaml, seq/objects.json.
  static const std::string& sequence() {
    static lpstereo::testing::ScratchDirectory scratch{"lpstereo_obstacles3d_cli_seq"};
    static std::string folder;
    if (folder.empty()) {
      const std::string render = scratch.path("render");
      const Result result = lpstereo::testing::render_lineup_15m(render);
      EXPECT_EQ(result.exit_code, 0) << result.err;
      folder = scratch.path("seq");
      fs::create_directories(folder);
      char name[32];
      for (int frame = 0; frame < kFrames; ++frame) {
        for (const char* view : {"left", "right"}) {
          std::snprintf(name, sizeof name, "/%s_%06d.png", view, frame);
          fs::copy_file(render + "/" + view + ".png", folder + name, fs::copy_options::overwrite_existing);
        }
      }
      fs::copy_file(render + "/calib.yaml", folder + "/calib.yaml", fs::copy_options::overwrite_existing);
      fs::copy_file(render + "/objects.json", folder + "/objects.json", fs::copy_options::overwrite_existing);
    }
    return folder;
  }
  static std::string sequence_flags() {
    const std::string& seq = sequence();
    return "--left " + seq + "/left_%06d.png --right " + seq + "/right_%06d.png --calib " + seq + "/calib.yaml --num-disp 64";
  }
  static nlohmann::json box_truth() {
    std::ifstream stream(sequence() + "/objects.json");
    const nlohmann::json scene = nlohmann::json::parse(stream);  // kept: a range-for over a temporary's member dangles
    for (const nlohmann::json& object : scene.at("objects")) {
      if (object.at("class") == "box") return object;
    }
    ADD_FAILURE() << "no box in the lineup";
    return {};
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_obstacles3d_cli"};
};

void expect_schema(const nlohmann::json& obstacle) {
  for (const char* key : {"id", "track_id", "bbox_px", "position_m", "size_m", "min_height_m", "max_height_m", "velocity_mps", "moving"}) {
    ASSERT_TRUE(obstacle.contains(key)) << key << " in " << obstacle.dump();
  }
  EXPECT_EQ(obstacle.at("bbox_px").size(), 4u);
  EXPECT_EQ(obstacle.at("position_m").size(), 3u);
  EXPECT_EQ(obstacle.at("size_m").size(), 3u);
  EXPECT_EQ(obstacle.at("velocity_mps").size(), 3u);
  EXPECT_TRUE(obstacle.at("moving").is_boolean());
  EXPECT_LE(obstacle.at("min_height_m").get<double>(), obstacle.at("max_height_m").get<double>());
  EXPECT_LE(obstacle.at("bbox_px")[0].get<int>(), obstacle.at("bbox_px")[2].get<int>());
  EXPECT_LE(obstacle.at("bbox_px")[1].get<int>(), obstacle.at("bbox_px")[3].get<int>());
}

bool boxes_overlap(const nlohmann::json& a, const nlohmann::json& b) {
  return a[0].get<int>() <= b[2].get<int>() && b[0].get<int>() <= a[2].get<int>() && a[1].get<int>() <= b[3].get<int>() &&
         b[1].get<int>() <= a[3].get<int>();
}

// The obstacle that is the box: its pixel box overlaps the box's true one and it is the tallest of
// those (the box's neighbours in the lineup, the can and the tape roll, are lower than it); null
// when none overlaps.
nlohmann::json the_box(const nlohmann::json& obstacles, const nlohmann::json& truth) {
  nlohmann::json best;
  for (const nlohmann::json& obstacle : obstacles) {
    if (!boxes_overlap(obstacle.at("bbox_px"), truth.at("bbox_px"))) continue;
    if (best.is_null() || obstacle.at("max_height_m").get<double>() > best.at("max_height_m").get<double>()) best = obstacle;
  }
  return best;
}

// Bounds from the scene: the box is 0.40 m wide, 0.43 m high, 0.30 m long, its base centre at
// (-0.6, 1.5, 15) m in the camera frame. Its points lie on its visible faces; the obstacle's position
// is the centre of their bounding box, the midpoint of the extreme points, so each axis is off by at
// most half the object's extent plus the stereo error of an extreme point. At 15 m (f = 320 / tan
// 30 deg = 554.3 px, B = 0.3 m, sigma_d 0.25 px): sigma_Z = Z^2 sigma_d / (f B) = 0.34 m, sigma_X =
// Z sigma_u / f = 0.014 m (sigma_u 0.5 px); the extremes of a few hundred points reach about 4 sigma,
// and the lateral cells of the grids add their half width (0.2 m for the cartesian grid):
// x within 0.20 + 0.06 + 0.2 -> 0.5 m, z within 0.15 + 1.36 -> 1.5 m. Its top is 0.43 m above the
// flat road; the terrain fit's error and the trimmed extremes within 0.15 m.
void expect_the_box(const nlohmann::json& obstacles, const nlohmann::json& truth, const std::string& method) {
  const nlohmann::json box = the_box(obstacles, truth);
  ASSERT_FALSE(box.is_null()) << method << ": no obstacle on the box's pixels " << truth.at("bbox_px").dump();
  EXPECT_NEAR(box.at("position_m")[0].get<double>(), truth.at("position_m")[0].get<double>(), 0.5) << method << " " << box.dump();
  EXPECT_NEAR(box.at("position_m")[2].get<double>(), truth.at("position_m")[2].get<double>(), 1.5) << method << " " << box.dump();
  EXPECT_NEAR(box.at("max_height_m").get<double>(), truth.at("size_m").at("h").get<double>(), 0.15) << method << " " << box.dump();
  EXPECT_GE(box.at("min_height_m").get<double>(), 0.2) << method << " " << box.dump();  // --obstacle-height-m: candidates only
}

class Obstacles3dGridMethods : public Obstacles3dCli, public ::testing::WithParamInterface<const char*> {};

TEST_P(Obstacles3dGridMethods, OneLinePerFrameAndTheBoxWithoutTracks) {
  const std::string method = GetParam();
  const std::string output = path("tracks.jsonl");
  const std::string view = path("view");
  const Result result = run("obstacles3d " + sequence_flags() + " --method " + method + " -o " + output + " --view " + view);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("3 frames (0 .. 2)"), std::string::npos) << result.out;
  const std::vector<nlohmann::json> lines = read_lines(output);
  ASSERT_EQ(lines.size(), static_cast<size_t>(kFrames));
  const nlohmann::json truth = box_truth();
  for (int frame = 0; frame < kFrames; ++frame) {
    const nlohmann::json& line = lines[static_cast<size_t>(frame)];
    EXPECT_EQ(line.at("frame").get<int>(), frame);
    EXPECT_TRUE(line.at("status").is_string());
    // The same pair three times: the odometry finds the identity, so frames 1 and 2 have ego-motion.
    EXPECT_EQ(line.at("ego_motion").get<bool>(), frame > 0) << line.at("status");
    // The view check: a textured scene matches nearly everywhere, the view is not degraded.
    EXPECT_GE(line.at("disparity_invalid_share").get<double>(), 0.0);
    EXPECT_LT(line.at("disparity_invalid_share").get<double>(), 0.10);
    EXPECT_FALSE(line.at("view_degraded").get<bool>());
    for (const nlohmann::json& obstacle : line.at("obstacles")) {
      expect_schema(obstacle);
      EXPECT_EQ(obstacle.at("track_id").get<int>(), -1);  // the grids do not track
      EXPECT_FALSE(obstacle.at("moving").get<bool>());
      for (int axis = 0; axis < 3; ++axis) EXPECT_EQ(obstacle.at("velocity_mps")[axis].get<double>(), 0.0);
    }
    expect_the_box(line.at("obstacles"), truth, method + " frame " + std::to_string(frame));
    char name[32];
    for (const char* kind : {"top", "overlay", "grid"}) {
      std::snprintf(name, sizeof name, "/%s_%06d.png", kind, frame);
      EXPECT_FALSE(cv::imread(view + name).empty()) << view + name;
    }
    std::snprintf(name, sizeof name, "/overlay_%06d.png", frame);
    EXPECT_EQ(cv::imread(view + name).cols, 640);
  }
}

INSTANTIATE_TEST_SUITE_P(Methods, Obstacles3dGridMethods, ::testing::Values("polar", "cartesian", "coldisp", "stixels"));

TEST_F(Obstacles3dCli, VoxelsReportAStaticTrackFromTheThirdFrame) {
  const std::string output = path("tracks.jsonl");
  const std::string view = path("view");
  const Result result = run("obstacles3d " + sequence_flags() + " --method voxels --voxel-m 0.25 -o " + output + " --view " + view);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::vector<nlohmann::json> lines = read_lines(output);
  ASSERT_EQ(lines.size(), static_cast<size_t>(kFrames));
  for (int frame = 0; frame < kFrames; ++frame) {
    const nlohmann::json& line = lines[static_cast<size_t>(frame)];
    EXPECT_EQ(line.at("frame").get<int>(), frame);
    // Tracks are reported once they have been associated in acceptance_frames (3) frames.
    if (frame < 2) {
      EXPECT_TRUE(line.at("obstacles").empty()) << line.dump();
    }
    for (const nlohmann::json& obstacle : line.at("obstacles")) {
      expect_schema(obstacle);
      EXPECT_GE(obstacle.at("track_id").get<int>(), 1);
      EXPECT_FALSE(obstacle.at("moving").get<bool>()) << obstacle.dump();  // a static scene
    }
    char name[32];
    std::snprintf(name, sizeof name, "/top_%06d.png", frame);
    EXPECT_FALSE(cv::imread(view + name).empty()) << view + name;
  }
  expect_the_box(lines[2].at("obstacles"), box_truth(), "voxels frame 2");
  // The same pair three times: the box's cluster does not move, so its filtered ground velocity is
  // far below the 1 m/s "moving" threshold.
  const nlohmann::json box = the_box(lines[2].at("obstacles"), box_truth());
  ASSERT_FALSE(box.is_null());
  double speed_squared = 0;
  for (int axis = 0; axis < 3; ++axis) speed_squared += std::pow(box.at("velocity_mps")[axis].get<double>(), 2);
  EXPECT_LT(std::sqrt(speed_squared), 0.5) << box.dump();
}

TEST_F(Obstacles3dCli, ASingleFrameSaysTheCameraIsAssumedStatic) {
  const std::string output = path("one.jsonl");
  const Result result = run("obstacles3d " + sequence_flags() + " --frames 1 --method polar -o " + output);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("static camera assumed"), std::string::npos) << result.err;
  EXPECT_EQ(read_lines(output).size(), 1u);
}

// The lineup's camera is 1.5 m high with no pitch or roll (render_lineup_15m): without mount flags
// the command finds it from the first frame's ground plane. A plane fitted to a few thousand road
// points with 0.34 m depth noise at 15 m (but far less near the camera) is within a few centimetres
// and a fraction of a degree; 5 cm and 1 degree leave room without hiding a wrong sign or axis.
TEST_F(Obstacles3dCli, TheMountIsEstimatedFromTheGroundWhenNotGiven) {
  const std::string output = path("estimated.jsonl");
  const Result result = run("obstacles3d " + sequence_flags() + " --frames 1 --method polar -o " + output);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const size_t at = result.out.find("camera mount estimated: ");
  ASSERT_NE(at, std::string::npos) << result.out;
  double height_m = 0, pitch_deg = 0, roll_deg = 0;
  ASSERT_EQ(std::sscanf(result.out.c_str() + at, "camera mount estimated: %lf m high, pitch %lf deg, roll %lf deg", &height_m,
                        &pitch_deg, &roll_deg),
            3)
      << result.out;
  EXPECT_NEAR(height_m, 1.5, 0.05);
  EXPECT_NEAR(pitch_deg, 0.0, 1.0);
  EXPECT_NEAR(roll_deg, 0.0, 1.0);
}

TEST_F(Obstacles3dCli, AnOdometryDropoutIsBridgedWithTheLastIncrementAndSaysSo) {
  // Frames 0-1 the lineup (the odometry finds the identity: valid), frame 2 a uniform grey pair (no
  // features: the odometry fails), frame 3 the lineup again. Frame 2 gets the last valid increment
  // (arm/obstacles3d/ego_motion.h), not a static camera, and its status and stderr say so.
  const std::string folder = path("dropout");
  fs::create_directories(folder);
  const cv::Mat grey(288, 640, CV_8UC1, cv::Scalar(128));
  char name[32];
  for (int frame = 0; frame < 4; ++frame) {
    for (const char* view : {"left", "right"}) {
      std::snprintf(name, sizeof name, "/%s_%06d.png", view, frame);
      if (frame == 2) {
        ASSERT_TRUE(cv::imwrite(folder + name, grey));
      } else {
        fs::copy_file(sequence() + "/" + view + "_000000.png", folder + name, fs::copy_options::overwrite_existing);
      }
    }
  }
  const std::string output = path("dropout.jsonl");
  const Result result = run("obstacles3d --left " + folder + "/left_%06d.png --right " + folder + "/right_%06d.png --calib " + sequence() +
                            "/calib.yaml --num-disp 64 --camera-height-m 1.5 --method polar -o " + output);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("frame 2 (0 odometry inliers): odometry failed: last increment applied (dropout 1 of at most 5)"), std::string::npos)
      << result.err;
  EXPECT_EQ(result.err.find("static camera assumed"), std::string::npos) << result.err;
  const std::vector<nlohmann::json> lines = read_lines(output);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_TRUE(lines[2].at("ego_motion").get<bool>());
  EXPECT_NE(lines[2].at("status").get<std::string>().find("odometry failed: last increment applied (dropout 1 of at most 5)"), std::string::npos)
      << lines[2].dump();
  EXPECT_NE(lines[1].at("status").get<std::string>().find("ego-motion applied"), std::string::npos) << lines[1].dump();
  EXPECT_NE(result.out.find("(2 bridged with the last increment, 0 without ego-motion"), std::string::npos) << result.out;
}

TEST_F(Obstacles3dCli, TexturelessFramesGiveEmptyCloudsAndAStaticCamera) {
  // Two uniform grey pairs: no disparity (no texture to match: every cost ties, and the matcher's
  // uniqueness check rejects a tie, kernels/sgm_core.h), so an empty cloud per frame, and the view
  // check flags both frames (every disparity invalid); no features for the odometry, so frame 1 has
  // no ego-motion: stderr says the camera is assumed static. With the mount given the status says
  // "empty cloud"; without it, that the mount is unknown (no ground to estimate it from), and there
  // are no candidates either way.
  const std::string folder = path("flat");
  fs::create_directories(folder);
  const cv::Mat grey(288, 640, CV_8UC1, cv::Scalar(128));
  char name[32];
  for (int frame = 0; frame < 2; ++frame) {
    for (const char* view : {"left", "right"}) {
      std::snprintf(name, sizeof name, "/%s_%06d.png", view, frame);
      ASSERT_TRUE(cv::imwrite(folder + name, grey));
    }
  }
  for (const std::string mount_flags : {" --camera-height-m 1.5", ""}) {
    const std::string output = path("flat.jsonl");
    const Result result = run("obstacles3d --left " + folder + "/left_%06d.png --right " + folder + "/right_%06d.png --calib " +
                              sequence() + "/calib.yaml --method voxels -o " + output + mount_flags);
    ASSERT_EQ(result.exit_code, 0) << result.err;
    EXPECT_NE(result.err.find("static camera assumed"), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("frame 0: view degraded: 100.0 % of the disparities invalid"), std::string::npos) << result.err;
    const std::vector<nlohmann::json> lines = read_lines(output);
    ASSERT_EQ(lines.size(), 2u);
    for (const nlohmann::json& line : lines) {
      EXPECT_EQ(line.at("disparity_invalid_share").get<double>(), 1.0) << line.dump();
      EXPECT_TRUE(line.at("view_degraded").get<bool>()) << line.dump();
    }
    const char* const expected_status = mount_flags.empty() ? "camera mount unknown" : "empty cloud";
    for (const nlohmann::json& line : lines) {
      EXPECT_NE(line.at("status").get<std::string>().find(expected_status), std::string::npos) << line.dump();
      EXPECT_TRUE(line.at("obstacles").empty());
      EXPECT_FALSE(line.at("ego_motion").get<bool>());
    }
  }
}

TEST_F(Obstacles3dCli, AViewNearerThanTheSearchRangeIsFlaggedDegraded) {
  // A random texture seen 100 px apart by the two cameras (right(x - 100) = left(x)), searched with
  // 64 disparities: nothing in the range matches, the left-right check rejects most of what the
  // matcher returns, and the view check (arm/obstacles3d/disparity_coverage.h) flags both frames.
  const std::string folder = path("near");
  fs::create_directories(folder);
  cv::Mat texture(288, 740, CV_8UC1);
  cv::RNG random(7);
  random.fill(texture, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0);
  char name[32];
  for (int frame = 0; frame < 2; ++frame) {
    std::snprintf(name, sizeof name, "/left_%06d.png", frame);
    ASSERT_TRUE(cv::imwrite(folder + name, texture(cv::Rect(0, 0, 640, 288))));
    std::snprintf(name, sizeof name, "/right_%06d.png", frame);
    ASSERT_TRUE(cv::imwrite(folder + name, texture(cv::Rect(100, 0, 640, 288))));
  }
  const std::string output = path("near.jsonl");
  const Result result = run("obstacles3d --left " + folder + "/left_%06d.png --right " + folder + "/right_%06d.png --calib " + sequence() +
                            "/calib.yaml --num-disp 64 --camera-height-m 1.5 --method polar -o " + output);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::vector<nlohmann::json> lines = read_lines(output);
  ASSERT_EQ(lines.size(), 2u);
  for (const nlohmann::json& line : lines) {
    EXPECT_GE(line.at("disparity_invalid_share").get<double>(), 0.10) << line.dump();
    EXPECT_TRUE(line.at("view_degraded").get<bool>()) << line.dump();
  }
  // Said once on stderr, counted in the summary.
  EXPECT_NE(result.err.find("frame 0: view degraded: "), std::string::npos) << result.err;
  EXPECT_EQ(result.err.find("frame 1: view degraded"), std::string::npos) << result.err;
  EXPECT_NE(result.out.find("view degraded in 2 (>= 10 % of the disparities invalid)"), std::string::npos) << result.out;
}

void expect_one_line_failure(const Result& result, int exit_code, const std::string& words, const std::string& output) {
  EXPECT_EQ(result.exit_code, exit_code) << result.err;
  EXPECT_EQ(line_count(result.err), 1) << result.err;
  EXPECT_NE(result.err.find(words), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(output));
}

TEST_F(Obstacles3dCli, BadMethodVoxelSizeAndMissingFilesGiveOneLine) {
  const std::string output = path("bad.jsonl");
  expect_one_line_failure(run("obstacles3d " + sequence_flags() + " --method octree -o " + output), 2, "--method", output);
  expect_one_line_failure(run("obstacles3d " + sequence_flags() + " --method voxels --voxel-m 0 -o " + output), 2, "--voxel-m", output);
  expect_one_line_failure(run("obstacles3d " + sequence_flags() + " --method voxels --voxel-m -0.25 -o " + output), 2, "--voxel-m",
                          output);
  const std::string missing = path("nothing");
  expect_one_line_failure(run("obstacles3d --left " + missing + "/left_%06d.png --right " + missing + "/right_%06d.png --calib " +
                              sequence() + "/calib.yaml -o " + output),
                          1, "nothing", output);
}

}  // namespace
