// graphs/obstacles3d-stixels.json is graphs/terrain.json's nodes followed by the augmented_stixels
// task, graphs/obstacles3d-stixels-from-disparity.json is graphs/terrain-from-disparity.json's
// followed by the same node; the task's area and surface are the terrain task's and its camera is
// the disparity_to_points node's (a change to one without the other fails here); both verify at
// 3840x1728.
#include <gtest/gtest.h>

#include <string>

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
  const GraphSpec prefix = load_graph_spec(kSource + "/graphs/" + prefix_name);
  ASSERT_EQ(file.nodes.size(), prefix.nodes.size() + 1) << file_name;
  for (size_t i = 0; i < prefix.nodes.size(); ++i) {
    const NodeSpec& expected = prefix.nodes[i];
    const NodeSpec& actual = file.nodes[i];
    EXPECT_EQ(actual.name, expected.name) << file_name;
    EXPECT_EQ(actual.kernel, expected.kernel) << expected.name;
    EXPECT_EQ(actual.task, expected.task) << expected.name;
    EXPECT_EQ(actual.params, expected.params) << expected.name;
    EXPECT_EQ(actual.outputs, expected.outputs) << expected.name;
  }
  const NodeSpec& stixels = file.nodes.back();
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

}  // namespace
}  // namespace lpstereo
