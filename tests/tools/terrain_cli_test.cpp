// lpstereo terrain as a user meets it: a rendered lineup (lpstereo synth: a flat road, camera 1.5 m
// high, objects at 15 m) gives a known terrain whose JSON has every part issue 9 names (the spline
// with its frame, degrees, knots and control points; the cost grid; surface_grid in the camera frame
// with y_m rows of x_m columns, near the camera height on the road; the obstacle points), the map,
// overlay and PLY files, with the mount given or estimated from the ground plane; the discontinuity
// filter drops the objects' edge pixels (and gives them back as points when it is off). A wall filling the
// view and a texture-less pair give "known": false with a reason, one line on stderr and exit 4; bad
// flags exit 2 and missing files exit 1, each with one line and no output file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/synthetic_scene.h"
#include "tests/support/cli_runner.h"
#include "tests/support/json_file.h"
#include "tests/support/ply_reader.h"
#include "tests/support/scratch_directory.h"

namespace {

namespace fs = std::filesystem;
using lpstereo::testing::Result;
using lpstereo::testing::count_lines;
using lpstereo::testing::read_json_file;
using lpstereo::testing::run;

class TerrainCli : public lpstereo::testing::LineupCliTest {
 protected:
  TerrainCli() : LineupCliTest("lpstereo_terrain_cli") {}
};

// A Middlebury calib.txt for a rectified pair: focal 700 px, baseline 120 mm.
void write_middlebury(const std::string& file, int width, int height) {
  std::ofstream(file) << "cam0=[700 0 " << (width - 1) / 2.0 << "; 0 700 " << (height - 1) / 2.0 << "; 0 0 1]\ncam1=[700 0 "
                      << (width - 1) / 2.0 << "; 0 700 " << (height - 1) / 2.0 << "; 0 0 1]\ndoffs=0\nbaseline=120\nwidth="
                      << width << "\nheight=" << height << "\nndisp=64\n";
}

// The schema of terrain.json (tools/terrain_command.h) for a known terrain of n0 x n1 control points,
// degree `degree`, on a forward_cells x lateral_cells grid.
void expect_known_schema(const nlohmann::json& json, int n0, int n1, int degree, int forward_cells, int lateral_cells) {
  EXPECT_TRUE(json.at("known").get<bool>());
  EXPECT_TRUE(json.at("reason").is_null());
  const nlohmann::json& spline = json.at("spline");
  EXPECT_EQ(spline.at("frame"), "vehicle");
  EXPECT_EQ(spline.at("degree_forward"), degree);
  EXPECT_EQ(spline.at("degree_lateral"), degree);
  ASSERT_EQ(spline.at("control_z_m").size(), static_cast<size_t>(n0));
  for (const auto& row : spline.at("control_z_m")) {
    ASSERT_EQ(row.size(), static_cast<size_t>(n1));
    for (const auto& value : row) EXPECT_TRUE(value.is_number());
  }
  // Clamped knots: n + degree + 1 of them, the first degree + 1 equal, non-decreasing.
  for (const auto& [name, count] : std::vector<std::pair<std::string, int>>{{"knots_forward_m", n0}, {"knots_lateral_m", n1}}) {
    const std::vector<double> knots = spline.at(name).get<std::vector<double>>();
    ASSERT_EQ(knots.size(), static_cast<size_t>(count + degree + 1)) << name;
    EXPECT_TRUE(std::is_sorted(knots.begin(), knots.end())) << name;
    EXPECT_EQ(knots[0], knots[static_cast<size_t>(degree)]) << name;
  }
  const nlohmann::json& cost = json.at("cost_grid");
  EXPECT_EQ(cost.at("frame"), "vehicle");
  ASSERT_EQ(cost.at("cost").size(), static_cast<size_t>(forward_cells));
  EXPECT_EQ(cost.at("cost")[0].size(), static_cast<size_t>(lateral_cells));
  EXPECT_EQ(cost.at("forward_m").size(), static_cast<size_t>(forward_cells));
  EXPECT_EQ(cost.at("lateral_m").size(), static_cast<size_t>(lateral_cells));
  const nlohmann::json& surface = json.at("surface_grid");
  EXPECT_EQ(surface.at("frame"), "camera");
  const size_t columns = surface.at("x_m").size(), rows = surface.at("z_m").size();
  EXPECT_EQ(columns, static_cast<size_t>(lateral_cells));
  EXPECT_EQ(rows, static_cast<size_t>(forward_cells));
  ASSERT_EQ(surface.at("y_m").size(), rows);
  for (const auto& row : surface.at("y_m")) {
    ASSERT_EQ(row.size(), columns);
    for (const auto& value : row) EXPECT_TRUE(value.is_null() || value.is_number());
  }
  for (const auto& point : json.at("obstacle_points_camera_m")) {
    ASSERT_EQ(point.size(), 3u);
    for (const auto& value : point) EXPECT_TRUE(value.is_number());
  }
}

// The median |y - camera height| of the known surface_grid samples within max_forward_m: the road of
// the lineup is flat, so the surface lies camera_height_m below the camera (camera y down).
double median_road_error_m(const nlohmann::json& surface, double camera_height_m, double max_forward_m, int* known_samples) {
  std::vector<double> errors;
  const std::vector<double> z_m = surface.at("z_m").get<std::vector<double>>();
  for (size_t i = 0; i < z_m.size(); ++i) {
    if (z_m[i] > max_forward_m) continue;
    for (const auto& value : surface.at("y_m")[i]) {
      if (!value.is_null()) errors.push_back(std::abs(value.get<double>() - camera_height_m));
    }
  }
  *known_samples = static_cast<int>(errors.size());
  if (errors.empty()) return 1e9;
  std::nth_element(errors.begin(), errors.begin() + static_cast<ptrdiff_t>(errors.size() / 2), errors.end());
  return errors[errors.size() / 2];
}

TEST_F(TerrainCli, LineupGivesAKnownFlatTerrainWithEveryPartOfTheJson) {
  const std::string scene = lineup();
  const std::string output = path("terrain.json");
  const Result result = run("terrain " + scene + "/left.png " + scene + "/right.png --calib " + scene + "/calib.yaml -o " + output +
                            " --num-disp 48 --threads 2 --area-m 24x16 --cell-m 0.5 --control 12x10 --degree 3 "
                            "--camera-height-m 1.5 --map " + path("map.png") + " --overlay " + path("overlay.png") +
                            " --points " + path("points.ply"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("terrain known"), std::string::npos) << result.out;
  const nlohmann::json json = read_json_file(output);
  EXPECT_EQ(json.at("width"), 640);
  EXPECT_EQ(json.at("mount").at("source"), "given");
  expect_known_schema(json, 12, 10, 3, 48, 32);
  int known_samples = 0;
  EXPECT_LT(median_road_error_m(json.at("surface_grid"), 1.5, 14.0, &known_samples), 0.10);
  EXPECT_GT(known_samples, 50);
  // The lineup's objects stand on the road at 15 m: obstacle points there, higher than the road.
  int near_objects = 0;
  for (const auto& point : json.at("obstacle_points_camera_m")) {
    near_objects += std::abs(point[2].get<double>() - 15.0) < 2.0 && point[1].get<double>() < 1.5 - 0.2;
  }
  EXPECT_GT(near_objects, 20);
  EXPECT_GT(json.at("point_counts").at("terrain").get<int>(), 1000);
  // The pictures and the cloud.
  EXPECT_FALSE(cv::imread(path("map.png")).empty());
  const cv::Mat overlay = cv::imread(path("overlay.png"));
  EXPECT_EQ(overlay.cols, 640);
  const lpstereo::testing::PlyFile cloud = lpstereo::testing::read_ply(path("points.ply"));
  int obstacle_vertices = 0, terrain_vertices = 0;
  for (const auto& vertex : cloud.vertices) {
    obstacle_vertices += vertex.red == 255 && vertex.green == 0;
    terrain_vertices += vertex.red == 0 && vertex.green == 200;
  }
  EXPECT_EQ(obstacle_vertices, static_cast<int>(json.at("obstacle_points_camera_m").size()));
  EXPECT_EQ(terrain_vertices, json.at("point_counts").at("terrain").get<int>());
  // The discontinuity filter, on by default: the near side of the objects' edges is dropped.
  const nlohmann::json& filter = json.at("discontinuity_filter");
  EXPECT_EQ(filter.at("radius_px"), 3);
  EXPECT_EQ(filter.at("jump_px"), 2.0);
  const int invalidated_px = filter.at("invalidated_px").get<int>();
  EXPECT_GT(invalidated_px, 100);
  EXPECT_NE(result.out.find(std::to_string(invalidated_px) + " edge px dropped"), std::string::npos) << result.out;
  // Off: nothing dropped, and every dropped pixel (a valid disparity more than 2 px above its
  // neighbour's, so > 0: a point) comes back as a point.
  const std::string unfiltered = path("terrain_unfiltered.json");
  const Result off = run("terrain " + scene + "/left.png " + scene + "/right.png --calib " + scene + "/calib.yaml -o " + unfiltered +
                         " --num-disp 48 --threads 2 --area-m 24x16 --cell-m 0.5 --control 12x10 --degree 3 --camera-height-m 1.5"
                         " --discontinuity-radius 0");
  ASSERT_EQ(off.exit_code, 0) << off.err;
  const nlohmann::json off_json = read_json_file(unfiltered);
  EXPECT_EQ(off_json.at("discontinuity_filter").at("invalidated_px"), 0);
  auto total_points = [](const nlohmann::json& counts) {
    return counts.at("terrain").get<int>() + counts.at("obstacle").get<int>() + counts.at("outside").get<int>();
  };
  EXPECT_EQ(total_points(off_json.at("point_counts")), total_points(json.at("point_counts")) + invalidated_px);
}

TEST_F(TerrainCli, EstimatedMountFindsTheCameraHeight) {
  const std::string scene = lineup();
  const std::string output = path("estimated.json");
  const Result result = run("terrain " + scene + "/left.png " + scene + "/right.png --calib " + scene + "/calib.yaml -o " + output +
                            " --num-disp 48 --threads 2 --area-m 24x16 --control 12x10");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const nlohmann::json json = read_json_file(output);
  EXPECT_EQ(json.at("mount").at("source"), "estimated");
  EXPECT_NEAR(json.at("mount").at("camera_height_m").get<double>(), 1.5, 0.1);
  EXPECT_NEAR(json.at("mount").at("pitch_rad").get<double>(), 0.0, 0.03);
  EXPECT_NEAR(json.at("mount").at("roll_rad").get<double>(), 0.0, 0.03);
  expect_known_schema(json, 12, 10, 3, 48, 32);
}

// Bad input data: the JSON is written with "known": false and the reason; stderr holds that one line.
void expect_unknown(const Result& result, const std::string& output, const std::string& reason_part) {
  EXPECT_EQ(result.exit_code, 4) << result.err;
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("terrain unknown"), std::string::npos) << result.err;
  ASSERT_TRUE(fs::exists(output));
  const nlohmann::json json = read_json_file(output);
  EXPECT_FALSE(json.at("known").get<bool>());
  EXPECT_NE(json.at("reason").get<std::string>().find(reason_part), std::string::npos) << json.at("reason");
  EXPECT_TRUE(json.at("spline").is_null());  // never a made-up surface
  EXPECT_TRUE(json.at("cost_grid").is_null());
  EXPECT_TRUE(json.at("obstacle_points_camera_m").empty());
  for (const auto& row : json.at("surface_grid").at("y_m")) {
    for (const auto& value : row) EXPECT_TRUE(value.is_null());
  }
}

TEST_F(TerrainCli, AWallFillingTheViewGivesUnknownTerrain) {
  // A fronto-parallel textured wall filling the view: disparity 12 px everywhere (7 m away).
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
  expect_unknown(run("terrain " + path("wall_left.png") + " " + path("wall_right.png") + " --calib " + path("wall_calib.txt") +
                     " -o " + path("wall.json") + " --num-disp 32 --threads 2"),
                 path("wall.json"), "camera mount");
  // With the mount given, the wall's points bin into one forward row of cells: no ground extent.
  expect_unknown(run("terrain " + path("wall_left.png") + " " + path("wall_right.png") + " --calib " + path("wall_calib.txt") +
                     " -o " + path("wall_given.json") + " --num-disp 32 --threads 2 --camera-height-m 1.5"),
                 path("wall_given.json"), "no ground extent");
}

TEST_F(TerrainCli, ATexturelessPairGivesTooFewCells) {
  // Uniform grey views: no disparity anywhere, so no point in any cell, even with the mount given.
  constexpr int kWidth = 160, kHeight = 96;
  const cv::Mat grey(kHeight, kWidth, CV_8UC1, cv::Scalar(128));
  ASSERT_TRUE(cv::imwrite(path("flat_left.png"), grey));
  ASSERT_TRUE(cv::imwrite(path("flat_right.png"), grey));
  write_middlebury(path("flat_calib.txt"), kWidth, kHeight);
  const Result result = run("terrain " + path("flat_left.png") + " " + path("flat_right.png") + " --calib " + path("flat_calib.txt") +
                            " -o " + path("flat.json") + " --num-disp 32 --threads 2 --camera-height-m 1.5");
  expect_unknown(result, path("flat.json"), "");
  EXPECT_EQ(read_json_file(path("flat.json")).at("grid").at("valid_cells"), 0);
}

TEST_F(TerrainCli, BadFlagsAndFilesGiveOneLineAndNoOutput) {
  const std::string scene = lineup();
  const std::string pair = scene + "/left.png " + scene + "/right.png --calib " + scene + "/calib.yaml --num-disp 48 -o " + path("bad.json");
  struct Case {
    std::string arguments, message;
    int exit_code;
  };
  const std::vector<Case> cases = {
      {pair + " --area-m 34", "--area-m: expected AxB with two numbers > 0 (e.g. 34x22), got '34'", 2},
      {pair + " --area-m 34x-2", "--area-m: expected AxB", 2},
      {pair + " --control 3x25", "--control: expected two integers in [degree + 1, 200] = [4, 200], got '3x25'", 2},
      {pair + " --pitch-deg 5", "--pitch-deg/--roll-deg need --camera-height-m", 2},
      {pair + " --area-m 90x20", "--area-m: expected at most 65x130 m", 2},
      {pair + " --discontinuity-radius -1", "--discontinuity-radius", 2},
      {pair + " --discontinuity-jump 0", "--discontinuity-jump", 2},
      {scene + "/missing.png " + scene + "/right.png --calib " + scene + "/calib.yaml -o " + path("bad.json"), "missing.png", 1},
  };
  for (const Case& bad : cases) {
    const Result result = run("terrain " + bad.arguments);
    EXPECT_EQ(result.exit_code, bad.exit_code) << bad.arguments << "\n" << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(bad.message), std::string::npos) << result.err;
    EXPECT_FALSE(fs::exists(path("bad.json"))) << bad.arguments;
  }
}

}  // namespace
