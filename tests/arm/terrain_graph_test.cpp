// graphs/terrain.json is graphs/disparity.json's nodes followed by graphs/terrain-from-disparity.json's
// (the discontinuity filter, disparity_to_points, point_cell_binning, terrain_estimate), and the
// binning node's parameters are what arm::binning_params gives for the files' mount (a level camera
// 1.65 m up) and the task's grid (34 m x 22 m from the camera's foot, 0.5 m cells), the filter's are
// `lpstereo terrain`'s (arm::DiscontinuityFilter) on the map's invalid value: a change to one
// without the other fails here. Both files verify at 3840x1728; the from-disparity graph's filtered
// map is the host function's on the native and the counting back end.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "arm/point_cloud.h"
#include "arm/scheduler.h"
#include "arm/terrain_points.h"
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

TEST(TerrainGraph, FileHoldsTheDisparityGraphAndTheTerrainNodes) {
  const GraphSpec file = load_graph_spec(kSource + "/graphs/terrain.json");
  const GraphSpec disparity = load_graph_spec(kSource + "/graphs/disparity.json");
  const GraphSpec terrain_part = load_graph_spec(kSource + "/graphs/terrain-from-disparity.json");
  ASSERT_EQ(file.nodes.size(), disparity.nodes.size() + terrain_part.nodes.size());
  for (size_t i = 0; i < file.nodes.size(); ++i) {
    const NodeSpec& expected = i < disparity.nodes.size() ? disparity.nodes[i] : terrain_part.nodes[i - disparity.nodes.size()];
    const NodeSpec& actual = file.nodes[i];
    EXPECT_EQ(actual.name, expected.name);
    EXPECT_EQ(actual.kernel, expected.kernel) << expected.name;
    EXPECT_EQ(actual.task, expected.task) << expected.name;
    EXPECT_EQ(actual.params, expected.params) << expected.name;
    EXPECT_EQ(actual.outputs, expected.outputs) << expected.name;
    ASSERT_EQ(actual.inputs.size(), expected.inputs.size()) << expected.name;
    for (const auto& [port, binding] : expected.inputs) EXPECT_EQ(actual.inputs.at(port).buffer, binding.buffer) << expected.name;
  }
}

TEST(TerrainGraph, BinningParametersAreTheMountsAndTheTasksGrid) {
  const GraphSpec spec = load_graph_spec(kSource + "/graphs/terrain-from-disparity.json");
  const nlohmann::json& task = node_named(spec, "terrain_estimate").params;
  arm::terrain::TerrainGridSpec grid;
  grid.forward_min_m = task.at("forward_min_m");
  grid.forward_max_m = task.at("forward_max_m");
  grid.lateral_min_m = task.at("lateral_min_m");
  grid.lateral_max_m = task.at("lateral_max_m");
  grid.cell_m = task.at("cell_m");
  arm::CameraMount level;
  level.position_m = Eigen::Vector3d(0, 0, 1.65);
  EXPECT_EQ(node_named(spec, "point_cell_binning").params, arm::binning_params(arm::CameraToVehicle(level), grid));
}

TEST(TerrainGraph, TheDiscontinuityFilterIsTheTerrainCommandsOnTheMapsInvalidValue) {
  const GraphSpec spec = load_graph_spec(kSource + "/graphs/terrain-from-disparity.json");
  const NodeSpec& edges = node_named(spec, "edges");
  const NodeSpec& points = node_named(spec, "disparity_to_points");
  EXPECT_EQ(edges.kernel, "discontinuity_near_side");
  EXPECT_EQ(edges.inputs.at("input").buffer, "disparity");
  EXPECT_EQ(points.inputs.at("disparity").buffer, edges.outputs.at("output"));
  const arm::DiscontinuityFilter filter;
  EXPECT_EQ(edges.params.at("radius_px").get<int>(), filter.radius_px);
  EXPECT_EQ(edges.params.at("jump_q4").get<int>(), static_cast<int>(std::ceil(16 * filter.jump_px)));
  EXPECT_EQ(edges.params.at("invalid_q4").get<int>(), 16 * (points.params.at("min_disparity").get<int>() - 1));
}

TEST(TerrainGraph, TheGraphsFilteredMapIsTheHostFunctions) {
  const int width = 193, height = 121;
  Graph graph(load_graph_spec(kSource + "/graphs/terrain-from-disparity.json"));
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  graph.verify(options);
  // A ground ramp (disparity growing down the rows), nearer blocks 6 px up, a few invalid pixels.
  Plane disparity(width, height, {ElementType::s16, 4});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      int value = 40 + 3 * y + ((x / 23 + y / 17) % 5 == 0 ? 96 : 0);
      if ((x * 7 + y * 3) % 29 == 0) value = -16;
      disparity.at<int16_t>(x, y) = static_cast<int16_t>(value);
    }
  }
  Plane host = disparity.clone();
  const arm::DiscontinuityFilter filter;
  const int64_t dropped = arm::invalidate_near_side_of_discontinuities(host, -16, filter.radius_px, filter.jump_px);
  ASSERT_GT(dropped, 500);
  for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
    arm::FrameRunner runner(graph, 2, backend);
    runner.process({{"disparity", &disparity}});
    const Plane& filtered = runner.buffer("disparity_terrain");
    int64_t differing = 0;
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) differing += filtered.at<int16_t>(x, y) != host.at<int16_t>(x, y) ? 1 : 0;
    }
    EXPECT_EQ(differing, 0);
  }
}

TEST(TerrainGraph, BothFilesVerifyAt4K) {
  for (const char* name : {"/graphs/terrain.json", "/graphs/terrain-from-disparity.json"}) {
    Graph graph(load_graph_spec(kSource + name));
    VerifyOptions options;
    options.frame_width = 3840;
    options.frame_height = 1728;
    EXPECT_NO_THROW(graph.verify(options)) << name;
  }
}

}  // namespace
}  // namespace lpstereo
