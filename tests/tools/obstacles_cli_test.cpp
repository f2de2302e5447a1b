// lpstereo obstacles as a user meets it: a rendered lineup (lpstereo synth) gives a road near the
// true camera height and the lineup's larger objects at their distance in their ground-truth boxes,
// JSON with every field of issue 6, and the four pictures; a wall, an upside-down pair and an
// all-invalid disparity map give no road (confidence 0) and no obstacle, exit 0; missing files, a
// calibration without a baseline, sizes that differ and a bad --num-disp give one line, a non-zero
// exit and no output file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/synthetic_scene.h"
#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace {

namespace fs = std::filesystem;
using lpstereo::testing::Result;
using lpstereo::testing::run;

int lines(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

nlohmann::json read_json(const std::string& file) {
  std::ifstream stream(file);
  return nlohmann::json::parse(stream);
}

class ObstaclesCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  // A 640x288 lineup at 15 m (hfov 60 deg, baseline 0.30 m, camera 1.5 m high, noise 1), rendered once.
  const std::string& lineup() {
    static std::string folder;
    if (folder.empty() || !fs::exists(folder)) {
      folder = path("lineup");
      const Result result = run("synth -o " + folder +
                                " --width 640 --height 288 --hfov-deg 60 --baseline-m 0.30 --camera-height-m 1.5 "
                                "--noise-sigma 1 --lineup 15");
      EXPECT_EQ(result.exit_code, 0) << result.err;
    }
    return folder;
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_obstacles_cli"};
};

// A Middlebury calib.txt for a rectified pair: focal 700 px, baseline 120 mm.
void write_middlebury(const std::string& file, int width, int height, const std::string& baseline_mm = "120") {
  std::ofstream(file) << "cam0=[700 0 " << (width - 1) / 2.0 << "; 0 700 " << (height - 1) / 2.0 << "; 0 0 1]\ncam1=[700 0 "
                      << (width - 1) / 2.0 << "; 0 700 " << (height - 1) / 2.0 << "; 0 0 1]\ndoffs=0\nbaseline="
                      << baseline_mm << "\nwidth=" << width << "\nheight=" << height << "\nndisp=64\n";
}

bool boxes_overlap(const nlohmann::json& a, const nlohmann::json& b, int tolerance_px) {
  return a[0].get<int>() <= b[2].get<int>() + tolerance_px && b[0].get<int>() <= a[2].get<int>() + tolerance_px &&
         a[1].get<int>() <= b[3].get<int>() + tolerance_px && b[1].get<int>() <= a[3].get<int>() + tolerance_px;
}

TEST_F(ObstaclesCli, LineupGivesTheRoadAndTheObjectsAtTheirDistance) {
  const std::string scene = lineup();
  const std::string output = path("obstacles.json");
  const Result result = run("obstacles " + scene + "/left.png " + scene + "/right.png --calib " + scene + "/calib.yaml -o " +
                            output + " --num-disp 48 --threads 2 --overlay " + path("overlay.png") + " --grid " +
                            path("grid.png") + " --mask " + path("mask.png") + " --vdisp " + path("vdisp.png"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("obstacles; road: camera height"), std::string::npos) << result.out;
  const nlohmann::json json = read_json(output);
  EXPECT_EQ(json.at("width"), 640);
  EXPECT_EQ(json.at("height"), 288);
  const nlohmann::json& road = json.at("road");
  ASSERT_TRUE(road.at("valid").get<bool>());
  EXPECT_NEAR(road.at("camera_height_m").get<double>(), 1.5, 0.05);
  EXPECT_NEAR(road.at("pitch_rad").get<double>(), 0.0, 0.01);
  EXPECT_GT(road.at("confidence").get<int>(), 500);
  for (const char* key : {"slope_px_per_row", "intercept_px", "horizon_row_px", "inlier_rows", "rms_residual_px", "carried"}) {
    EXPECT_TRUE(road.contains(key)) << key;
  }
  const nlohmann::json& obstacles = json.at("obstacles");
  ASSERT_FALSE(obstacles.empty());
  for (const nlohmann::json& obstacle : obstacles) {
    for (const char* key : {"id", "bbox_px", "disparity", "distance_m", "position_m", "width_m", "height_m", "pixels", "features",
                            "track_id", "velocity_mps"}) {
      EXPECT_TRUE(obstacle.contains(key)) << key;
    }
    EXPECT_EQ(obstacle.at("bbox_px").size(), 4u);
    EXPECT_EQ(obstacle.at("position_m").size(), 3u);
    // z of the position is the distance, and distance = f B / disparity, f = (W / 2) / tan(hfov / 2);
    // "disparity" is the mean rounded to 1/16 px, the distance comes from the unrounded mean: the
    // relative difference is at most (1/32) / d (and 0.5 mm of the distance's own rounding).
    const double distance_m = obstacle.at("distance_m").get<double>();
    const double disparity_px = obstacle.at("disparity").get<double>();
    EXPECT_DOUBLE_EQ(obstacle.at("position_m")[2].get<double>(), distance_m);
    const double f_b = 640 / 2.0 / std::tan(30.0 * M_PI / 180.0) * 0.30;
    EXPECT_NEAR(distance_m, f_b / disparity_px, distance_m * (1.0 / 32.0) / (disparity_px - 1.0 / 32.0) + 0.0005);
    EXPECT_TRUE(obstacle.at("track_id").is_null());
  }
  // The match: bounding boxes overlap (2 px tolerance) and the distance within 10 % + 0.5 m.
  // At 640 px the tape roll (0.07 m: 3 rows at 15 m) is below what this resolution resolves.
  const nlohmann::json truth = read_json(scene + "/objects.json").at("objects");
  for (const nlohmann::json& object : truth) {
    const std::string name = object.at("class");
    if (name == "tape_roll") continue;
    bool found = false;
    for (const nlohmann::json& obstacle : obstacles) {
      found = found || (boxes_overlap(obstacle.at("bbox_px"), object.at("bbox_px"), 2) &&
                        std::abs(obstacle.at("distance_m").get<double>() - 15.0) <= 0.1 * 15.0 + 0.5);
    }
    EXPECT_TRUE(found) << name << " at 15 m not detected";
  }
  // Pictures.
  const cv::Mat overlay = cv::imread(path("overlay.png"), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(overlay.cols, 640);
  EXPECT_EQ(overlay.rows, 288);
  EXPECT_EQ(overlay.channels(), 3);
  const cv::Mat mask = cv::imread(path("mask.png"), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(mask.cols, 640);
  EXPECT_EQ(mask.rows, 288);
  EXPECT_FALSE(cv::imread(path("grid.png")).empty());
  const cv::Mat vdisp = cv::imread(path("vdisp.png"));
  EXPECT_EQ(vdisp.rows, 288);
}

void expect_no_road(const Result& result, const std::string& output) {
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("no road found"), std::string::npos) << result.out;
  const nlohmann::json json = read_json(output);
  EXPECT_FALSE(json.at("road").at("valid").get<bool>());
  EXPECT_EQ(json.at("road").at("confidence"), 0);
  EXPECT_FALSE(json.at("road").contains("slope_px_per_row"));  // never a made-up road
  EXPECT_TRUE(json.at("obstacles").empty());
}

TEST_F(ObstaclesCli, AWallGivesNoRoadAndNoObstacle) {
  // A fronto-parallel textured wall filling the view: disparity 12 px everywhere.
  constexpr int kWidth = 256, kHeight = 160, kShift = 12;
  cv::Mat left(kHeight, kWidth, CV_8UC1), right(kHeight, kWidth, CV_8UC1);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      left.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(lpstereo::io::synthetic_texture_grey(u, v, 5u, 128.0));
      right.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(lpstereo::io::synthetic_texture_grey(u + kShift, v, 5u, 128.0));
    }
  }
  ASSERT_TRUE(cv::imwrite(path("wall_left.png"), left));
  ASSERT_TRUE(cv::imwrite(path("wall_right.png"), right));
  write_middlebury(path("wall_calib.txt"), kWidth, kHeight);
  expect_no_road(run("obstacles " + path("wall_left.png") + " " + path("wall_right.png") + " --calib " + path("wall_calib.txt") +
                     " -o " + path("wall.json") + " --num-disp 32 --threads 2"),
                 path("wall.json"));
}

TEST_F(ObstaclesCli, AnUpsideDownPairGivesNoRoad) {
  // The lineup upside down (both views flipped vertically, still rectified): the road's disparity
  // now shrinks towards the bottom, which no upright camera sees.
  const std::string scene = lineup();
  for (const char* view : {"left", "right"}) {
    cv::Mat image = cv::imread(scene + "/" + view + ".png", cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(image.empty());
    cv::flip(image, image, 0);
    ASSERT_TRUE(cv::imwrite(path(std::string("flipped_") + view + ".png"), image));
  }
  expect_no_road(run("obstacles " + path("flipped_left.png") + " " + path("flipped_right.png") + " --calib " + scene +
                     "/calib.yaml -o " + path("flipped.json") + " --num-disp 48 --threads 2"),
                 path("flipped.json"));
}

TEST_F(ObstaclesCli, AnAllInvalidDisparityMapGivesNoRoad) {
  // A textured left view and a black right one: nothing matches, the engine leaves every pixel
  // invalid (its census costs tie over the whole range, uniqueness refuses them all).
  constexpr int kWidth = 192, kHeight = 128;
  cv::Mat left(kHeight, kWidth, CV_8UC1);
  cv::randu(left, 0, 256);
  const cv::Mat black(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  ASSERT_TRUE(cv::imwrite(path("grey_left.png"), left));
  ASSERT_TRUE(cv::imwrite(path("grey_right.png"), black));
  write_middlebury(path("grey_calib.txt"), kWidth, kHeight);
  const Result result = run("obstacles " + path("grey_left.png") + " " + path("grey_right.png") + " --calib " +
                            path("grey_calib.txt") + " -o " + path("grey.json") + " --num-disp 32 --threads 2");
  expect_no_road(result, path("grey.json"));
  EXPECT_NE(result.out.find("disparity density 0.0 %"), std::string::npos) << result.out;
}

TEST_F(ObstaclesCli, BadInputGivesOneLineAndNoFile) {
  const std::string scene = lineup();
  const std::string pair = scene + "/left.png " + scene + "/right.png";
  const std::string output = path("bad.json");
  // A missing image.
  Result result = run("obstacles " + path("missing.png") + " " + scene + "/right.png --calib " + scene + "/calib.yaml -o " + output);
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_EQ(lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("missing.png"), std::string::npos) << result.err;
  // A missing calibration.
  result = run("obstacles " + pair + " --calib " + path("missing.yaml") + " -o " + output);
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_EQ(lines(result.err), 1) << result.err;
  // A calibration without a baseline.
  write_middlebury(path("no_baseline.txt"), 640, 288, "0");
  result = run("obstacles " + pair + " --calib " + path("no_baseline.txt") + " -o " + output);
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_EQ(lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("baseline"), std::string::npos) << result.err;
  // Views of different sizes.
  const cv::Mat small(100, 100, CV_8UC1, cv::Scalar(0));
  ASSERT_TRUE(cv::imwrite(path("small.png"), small));
  result = run("obstacles " + scene + "/left.png " + path("small.png") + " --calib " + scene + "/calib.yaml -o " + output);
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.err.find("image sizes differ"), std::string::npos) << result.err;
  // Bad usage.
  result = run("obstacles " + pair + " --calib " + scene + "/calib.yaml -o " + output + " --num-disp 0");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(lines(result.err), 1) << result.err;
  result = run("obstacles " + pair + " -o " + output);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_FALSE(fs::exists(output));
}

}  // namespace
