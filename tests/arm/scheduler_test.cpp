// The ARM-side scheduler's native run: same bits as running each node alone, with any number of
// worker threads; delayed edges; inputs re-read every frame; refused inputs.
#include <gtest/gtest.h>

#include "arm/scheduler.h"
#include "dag/tile_executor.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::planes_equal;
using testing::random_plane;

const char* kPipeline = R"({
  "name": "pipeline",
  "inputs": [{"name": "left", "format": "u8"}, {"name": "right", "format": "u8"}],
  "nodes": [
    {"name": "census_left", "kernel": "census5x5", "inputs": {"input": "left"}, "outputs": {"output": "left_census"},
     "schedule": {"tile_width": 96, "tile_height": 16}},
    {"name": "census_right", "kernel": "census5x5", "inputs": {"input": "right"}, "outputs": {"output": "right_census"}},
    {"name": "match", "kernel": "census_wta_disparity", "inputs": {"left": "left_census", "right": "right_census"},
     "outputs": {"disparity": "disparity"}, "params": {"num_disparities": 24, "max_cost_bits": 10}},
    {"name": "exposure", "task": "exposure_statistics", "inputs": {"image": "left"}, "outputs": {"statistics": "stats"}}
  ],
  "outputs": ["disparity", "stats"]
})";

Graph verified_pipeline(int width, int height) {
  Graph graph(parse_graph_spec(kPipeline, "pipeline.json"));
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  options.memory.sram_bytes = 256 * 1024;  // forces several tiles per node
  graph.verify(options);
  return graph;
}

// Runs each node alone, in order, one tile covering the whole image, on the scalar level.
Plane expected_disparity(const Plane& left, const Plane& right, const Graph& graph) {
  auto run = [&](const std::string& node_name, std::vector<PlaneView> inputs, const Plane& output) {
    for (const NodeInfo& node : graph.nodes()) {
      if (node.spec.name != node_name) continue;
      VectorNodeBinding binding = vector_node_binding(node);
      binding.inputs = inputs;
      binding.outputs = {output.view()};
      run_vector_node(binding, output.width(), output.height(), KernelBackend::native, simd::Isa::scalar);
    }
  };
  Plane left_census(left.width(), left.height(), {ElementType::census32, 0});
  Plane right_census(left.width(), left.height(), {ElementType::census32, 0});
  Plane disparity(left.width(), left.height(), {ElementType::s16, 4});
  run("census_left", {left.view()}, left_census);
  run("census_right", {right.view()}, right_census);
  run("match", {left_census.view(), right_census.view()}, disparity);
  return disparity;
}

// Two frame counters in a loop closed by a delayed edge: a(f) = b(f - 1) + 1, b(f) = a(f) + 1.
Graph verified_counter_loop() {
  Graph graph(parse_graph_spec(R"({
    "name": "loop", "inputs": [],
    "nodes": [
      {"name": "counter_a", "task": "test_frame_counter", "inputs": {"previous": {"buffer": "b", "delayed": true}}, "outputs": {"count": "a"}},
      {"name": "counter_b", "task": "test_frame_counter", "inputs": {"previous": "a"}, "outputs": {"count": "b"}}
    ]})", "loop.json"));
  VerifyOptions options;
  options.frame_width = 8;
  options.frame_height = 8;
  graph.verify(options);
  return graph;
}

TEST(FrameRunner, SameBitsAsEachNodeAloneForAnyThreadCount) {
  const Graph graph = verified_pipeline(331, 123);
  const Plane left = random_plane(331, 123, {ElementType::u8, 0}, 0, 21);
  const Plane right = random_plane(331, 123, {ElementType::u8, 0}, 0, 22);
  const Plane expected = expected_disparity(left, right, graph);
  for (int threads : {1, 2, 5}) {
    arm::FrameRunner runner(graph, threads);
    runner.process({{"left", &left}, {"right", &right}});
    EXPECT_TRUE(planes_equal(expected, runner.buffer("disparity"))) << threads << " threads";
    EXPECT_GT(runner.buffer("stats").at<uint32_t>(3, 0), 0u) << "exposure statistics counted no samples";
  }
}

TEST(FrameRunner, ReReadsItsInputsEveryFrame) {
  const Graph graph = verified_pipeline(200, 50);
  const Plane left_a = random_plane(200, 50, {ElementType::u8, 0}, 0, 1);
  const Plane right_a = random_plane(200, 50, {ElementType::u8, 0}, 0, 2);
  const Plane left_b = random_plane(200, 50, {ElementType::u8, 0}, 0, 3);
  const Plane right_b = random_plane(200, 50, {ElementType::u8, 0}, 0, 4);
  arm::FrameRunner runner(graph, 2);
  runner.process({{"left", &left_a}, {"right", &right_a}});
  EXPECT_TRUE(planes_equal(expected_disparity(left_a, right_a, graph), runner.buffer("disparity")));
  runner.process({{"left", &left_b}, {"right", &right_b}});
  EXPECT_TRUE(planes_equal(expected_disparity(left_b, right_b, graph), runner.buffer("disparity")));
  EXPECT_EQ(runner.frames_processed(), 2);
}

TEST(FrameRunner, DelayedEdgeReadsThePreviousFrame) {
  const Graph graph = verified_counter_loop();
  arm::FrameRunner runner(graph, 2);
  for (uint32_t frame = 1; frame <= 5; ++frame) {
    runner.process({});
    // a(f) = b(f - 1) + 1, b(f) = a(f) + 1, b(0) reads the zero-initialised slot.
    EXPECT_EQ(runner.buffer("a").at<uint32_t>(0, 0), 2 * frame - 1) << "frame " << frame;
    EXPECT_EQ(runner.buffer("b").at<uint32_t>(0, 0), 2 * frame) << "frame " << frame;
  }
}

TEST(FrameRunnerMustFail, RefusesMissingMismatchedAndUnknownInputs) {
  const Graph graph = verified_pipeline(64, 32);
  const Plane good = random_plane(64, 32, {ElementType::u8, 0}, 0, 1);
  const Plane narrow = random_plane(63, 32, {ElementType::u8, 0}, 0, 1);
  const Plane wide_format = random_plane(64, 32, {ElementType::u16, 0}, 0, 1);
  arm::FrameRunner runner(graph, 1);
  auto message = [&](const std::map<std::string, const Plane*>& inputs) {
    try {
      runner.process(inputs);
    } catch (const arm::FrameInputError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  EXPECT_EQ(message({{"left", &good}}), "graph 'pipeline' input 'right': missing");
  EXPECT_EQ(message({{"left", &good}, {"right", &narrow}}), "graph 'pipeline' input 'right': expected 64x32 u8, got 63x32 u8");
  EXPECT_EQ(message({{"left", &wide_format}, {"right", &good}}),
            "graph 'pipeline' input 'left': expected 64x32 u8, got 64x32 u16");
  EXPECT_EQ(message({{"left", &good}, {"right", &good}, {"middle", &good}}),
            "graph 'pipeline': 'middle' is not an input of the graph");
}

TEST(FramePlan, DelayedEdgesOrderFramesNotNodes) {
  const Graph graph = verified_counter_loop();
  const arm::FramePlan plan = arm::plan_frame(graph);
  ASSERT_EQ(plan.dispatches.size(), 2u);
  EXPECT_TRUE(plan.dispatches[0].after.empty());
  EXPECT_EQ(plan.dispatches[0].after_previous_frame, std::vector<int>{1});  // waits for last frame's b
  EXPECT_EQ(plan.dispatches[1].after, std::vector<int>{0});
  EXPECT_EQ(plan.dispatches[1].after_previous_frame, std::vector<int>{0});  // b's slot is read by a one frame late
}

}  // namespace
}  // namespace lpstereo
