// graphs/obstacles.json is graphs/disparity.json's nodes followed by the obstacle detector's: its
// obstacle nodes must stay exactly arm::ObstacleDetector::graph_spec of the default parameters for the
// file's camera (3840x1728, hfov 60 deg: focal 3325.54 px, baseline 0.30 m) and the disparity range
// [0, 256), with the feature input "left" bound to the rectified view. A change of a detector default
// without the file (or the reverse) fails here. The file also verifies at 3840x1728.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "arm/obstacle_detector.h"
#include "dag/graph.h"

namespace lpstereo {
namespace {

const std::string kSource = LPSTEREO_SOURCE_DIR;

TEST(ObstaclesGraph, FileHoldsTheDisparityGraphAndTheDetectorsNodes) {
  const GraphSpec file = load_graph_spec(kSource + "/graphs/obstacles.json");
  const GraphSpec disparity = load_graph_spec(kSource + "/graphs/disparity.json");
  arm::ObstacleParameters parameters;
  parameters.focal_px = 3325.5375505322445;
  parameters.baseline_m = 0.30;
  const GraphSpec detector = arm::ObstacleDetector::graph_spec(parameters.for_disparity_range(0, 256));

  ASSERT_EQ(file.nodes.size(), disparity.nodes.size() + detector.nodes.size());
  for (size_t i = 0; i < disparity.nodes.size(); ++i) {
    EXPECT_EQ(file.nodes[i].name, disparity.nodes[i].name);
    EXPECT_EQ(file.nodes[i].params, disparity.nodes[i].params) << disparity.nodes[i].name;
  }
  for (size_t i = 0; i < detector.nodes.size(); ++i) {
    const NodeSpec& expected = detector.nodes[i];
    const NodeSpec& actual = file.nodes[disparity.nodes.size() + i];
    EXPECT_EQ(actual.name, expected.name);
    EXPECT_EQ(actual.kernel, expected.kernel) << expected.name;
    EXPECT_EQ(actual.task, expected.task) << expected.name;
    EXPECT_EQ(actual.params, expected.params) << expected.name;
    EXPECT_EQ(actual.outputs, expected.outputs) << expected.name;
    EXPECT_EQ(actual.tile_width, expected.tile_width) << expected.name;
    EXPECT_EQ(actual.tile_height, expected.tile_height) << expected.name;
    ASSERT_EQ(actual.inputs.size(), expected.inputs.size()) << expected.name;
    for (const auto& [port, binding] : expected.inputs) {
      const std::string buffer = binding.buffer == "left" ? "left_rectified" : binding.buffer;
      EXPECT_EQ(actual.inputs.at(port).buffer, buffer) << expected.name << "." << port;
      EXPECT_EQ(actual.inputs.at(port).delayed, binding.delayed) << expected.name << "." << port;
    }
  }
  Graph graph(file);
  VerifyOptions options;
  options.frame_width = 3840;
  options.frame_height = 1728;
  EXPECT_NO_THROW(graph.verify(options));
}

}  // namespace
}  // namespace lpstereo
