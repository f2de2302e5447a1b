// graphs/obstacles3d-stixels.json is graphs/terrain.json's nodes (but its discontinuity filter: the
// host obstacle chain has none) followed by the augmented_stixels
// task and the view check (a v_disparity node counting each row's invalid disparities, the
// disparity_coverage task), graphs/obstacles3d-stixels-from-disparity.json is
// graphs/terrain-from-disparity.json's followed by the same nodes; the task's area and surface are
// the terrain task's and its camera is the disparity_to_points node's, and the counting node's one
// bin is the map's invalid value (a change to one without the other fails here); both verify at
// 3840x1728; the from-disparity graph's view check gives the host function's verdict on a map, on
// the native and the counting back end.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "arm/obstacles3d/disparity_coverage.h"
#include "arm/scheduler.h"
#include "arm/tasks/coverage_record.h"
#include "dag/graph.h"

namespace lpstereo {
namespace {

const std::string kSource = LPSTEREO_SOURCE_DIR;

const NodeSpec& node_named(const GraphSpec& spec, const std::string& name) {
  for (const NodeSpec& node : spec.nodes) {
    if (node.name == name) return node;
  }
  throw std::runtime_error("no node '" + name + "' in graph " + spec.name);
}

void expect_prefix_then_stixels(const std::string& file_name, const std::string& prefix_name) {
  const GraphSpec file = load_graph_spec(kSource + "/graphs/" + file_name);
  GraphSpec prefix = load_graph_spec(kSource + "/graphs/" + prefix_name);
  // The terrain graphs' discontinuity filter is not in the obstacle chain: the host chain
  // (lpstereo obstacles3d, bench/obstacles3d_eval) does not run it (its candidates have their own
  // rule for the far side of an edge), so the stixels and the terrain here see the median's map.
  std::erase_if(prefix.nodes, [](const NodeSpec& node) { return node.kernel == "discontinuity_near_side"; });
  for (const NodeSpec& node : file.nodes) EXPECT_NE(node.kernel, "discontinuity_near_side") << file_name;
  EXPECT_EQ(node_named(file, "disparity_to_points").inputs.at("disparity").buffer, "disparity") << file_name;
  ASSERT_EQ(file.nodes.size(), prefix.nodes.size() + 3) << file_name;
  for (size_t i = 0; i < prefix.nodes.size(); ++i) {
    const NodeSpec& expected = prefix.nodes[i];
    const NodeSpec& actual = file.nodes[i];
    EXPECT_EQ(actual.name, expected.name) << file_name;
    EXPECT_EQ(actual.kernel, expected.kernel) << expected.name;
    EXPECT_EQ(actual.task, expected.task) << expected.name;
    EXPECT_EQ(actual.params, expected.params) << expected.name;
    EXPECT_EQ(actual.outputs, expected.outputs) << expected.name;
  }
  const NodeSpec& stixels = file.nodes[prefix.nodes.size()];
  EXPECT_EQ(stixels.task, "augmented_stixels");
  EXPECT_EQ(stixels.inputs.at("terrain").buffer, "terrain");
  const nlohmann::json& terrain = node_named(file, "terrain_estimate").params;
  for (const char* name : {"forward_min_m", "forward_max_m", "lateral_min_m", "lateral_max_m", "cell_m", "degree_forward", "degree_lateral",
                           "control_forward", "control_lateral"}) {
    EXPECT_EQ(stixels.params.at(name), terrain.at(name)) << file_name << ": " << name;
  }
  const nlohmann::json& points = node_named(file, "disparity_to_points").params;
  for (const char* name : {"focal_px", "baseline_m", "u0_px"}) EXPECT_EQ(stixels.params.at(name), points.at(name)) << file_name << ": " << name;
  // The binning node's translation is the camera height the task assumes (a level camera).
  EXPECT_EQ(1000.0 * stixels.params.at("camera_height_m").get<double>(),
            node_named(file, "point_cell_binning").params.at("translation_mm")[2].get<double>());
  // The view check: one v_disparity bin at min_disparity - 1 of the map, where only the invalid
  // value (min_disparity - 1) x 16 lands (the smallest valid value is min_disparity x 16); in the
  // full graph that is the median's invalid value too.
  const NodeSpec& rows = file.nodes[prefix.nodes.size() + 1];
  const NodeSpec& check = file.nodes[prefix.nodes.size() + 2];
  EXPECT_EQ(rows.kernel, "v_disparity");
  EXPECT_EQ(rows.inputs.at("disparity").buffer, "disparity");
  EXPECT_EQ(rows.params.at("num_bins"), 1);
  EXPECT_EQ(rows.params.at("min_disparity").get<int>(), points.at("min_disparity").get<int>() - 1) << file_name;
  for (const NodeSpec& node : file.nodes) {
    if (node.kernel == "median3x3_s16") {
      EXPECT_EQ(node.params.at("invalid_q4").get<int>(), 16 * rows.params.at("min_disparity").get<int>()) << file_name;
    }
  }
  EXPECT_EQ(check.task, "disparity_coverage");
  EXPECT_EQ(check.inputs.at("invalid_rows").buffer, rows.outputs.at("histogram"));
  EXPECT_EQ(check.inputs.at("disparity").buffer, "disparity");
}

TEST(Obstacles3dStixelsGraph, FilesAreTheTerrainGraphsAndTheStixelTask) {
  expect_prefix_then_stixels("obstacles3d-stixels.json", "terrain.json");
  expect_prefix_then_stixels("obstacles3d-stixels-from-disparity.json", "terrain-from-disparity.json");
}

TEST(Obstacles3dStixelsGraph, BothFilesVerifyAt4K) {
  for (const char* name : {"/graphs/obstacles3d-stixels.json", "/graphs/obstacles3d-stixels-from-disparity.json"}) {
    Graph graph(load_graph_spec(kSource + name));
    VerifyOptions options;
    options.frame_width = 3840;
    options.frame_height = 1728;
    EXPECT_NO_THROW(graph.verify(options)) << name;
  }
}

TEST(Obstacles3dStixelsGraph, TheViewCheckGivesTheHostVerdictOnEveryBackEnd) {
  const int width = 193, height = 121;
  Graph graph(load_graph_spec(kSource + "/graphs/obstacles3d-stixels-from-disparity.json"));
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  graph.verify(options);
  // Valid disparities 2 .. 101 px (with sub-pixel steps) and the invalid value -16 on a pattern
  // (1,015 pixels) and a 43 x 60 block (2,580), 3,483 of 23,353 together (14.9 %): degraded.
  Plane disparity(width, height, {ElementType::s16, 4});
  int64_t invalid = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const bool hole = (x * 7 + y * 3) % 23 == 0 || (x >= 150 && y >= 50 && y < 110);
      disparity.at<int16_t>(x, y) = hole ? int16_t{-16} : static_cast<int16_t>(32 + (x * 13 + y * 5) % 1600);
      invalid += hole ? 1 : 0;
    }
  }
  const arm::obstacles3d::DisparityCoverage host =
      arm::obstacles3d::disparity_coverage(disparity, -16, arm::obstacles3d::DisparityCoverageParameters{});
  ASSERT_EQ(host.invalid_pixels, invalid);
  ASSERT_EQ(invalid, 3483);
  ASSERT_TRUE(host.degraded);
  for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
    arm::FrameRunner runner(graph, 2, backend);
    runner.process({{"disparity", &disparity}});
    const uint32_t* record = runner.buffer("view_check").row<const uint32_t>(0);
    EXPECT_EQ(record[arm::kCoverageInvalidPixels], static_cast<uint32_t>(invalid));
    EXPECT_EQ(record[arm::kCoveragePixels], static_cast<uint32_t>(width * height));
    EXPECT_EQ(record[arm::kCoverageInvalidPer65536], arm::coverage_share_per_65536(invalid, int64_t{width} * height));
    EXPECT_EQ(record[arm::kCoverageDegraded], 1u);
  }
}

}  // namespace
}  // namespace lpstereo
