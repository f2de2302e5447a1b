// Row-state kernels (SGM-style state carried down the frame): full-width tiles in order, state
// zeroed per frame, in the tile executor, the native scheduler, verify() and the simulator.
#include <gtest/gtest.h>

#include "arm/scheduler.h"
#include "dag/graph.h"
#include "host_sim/simulator.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::planes_equal;
using testing::random_plane;

Plane reference_sums(const Plane& input, const std::string& kernel = "test_column_running_sum") {
  Plane expected(input.width(), input.height(), {ElementType::u32, 0});
  testing::kernel_named(kernel).reference({input.view()}, {expected.view()}, nullptr, BorderMode::replicate, 0);
  return expected;
}

TEST(RowState, TileExecutorCarriesStateDownTheFrameForEveryTileHeight) {
  const Plane input = random_plane(131, 77, {ElementType::u8, 0}, 150, 3);
  for (const char* name : {"test_column_running_sum", "test_column_running_sum_bottom_up"}) {
    const Plane expected = reference_sums(input, name);
    const KernelDescriptor& kernel = testing::kernel_named(name);
    for (int tile_height : {1, 5, 16, 77}) {
      for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
        Plane output(131, 77, {ElementType::u32, 0});
        VectorNodeBinding binding{&kernel, nullptr, BorderMode::replicate, 0, {input.view()}, {output.view()}};
        run_vector_node(binding, 40 /* ignored: row state needs full width */, tile_height, backend, simd::Isa::scalar);
        EXPECT_TRUE(planes_equal(expected, output)) << name << " tile height " << tile_height;
      }
    }
  }
}

TEST(RowState, SchedulerRunsBottomUpTilesInReverseOrder) {
  Graph graph(parse_graph_spec(R"({"name": "sums", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [{"name": "sums", "kernel": "test_column_running_sum_bottom_up", "inputs": {"input": "image"},
               "outputs": {"output": "sums"}, "schedule": {"tile_height": 7}}]})", "sums.json"));
  VerifyOptions options;
  options.frame_width = 150;
  options.frame_height = 50;
  graph.verify(options);
  arm::FrameRunner runner(graph, 2);
  const Plane input = random_plane(150, 50, {ElementType::u8, 0}, 0, 5);
  runner.process({{"image", &input}});
  EXPECT_TRUE(planes_equal(reference_sums(input, "test_column_running_sum_bottom_up"), runner.buffer("sums")));
  EXPECT_EQ(runner.plan().dispatches[0].tiles.front().y, 49);  // the last strip (one row) comes first
}

const char* kGraph = R"({"name": "sums", "inputs": [{"name": "image", "format": "u8"}],
  "nodes": [{"name": "sums", "kernel": "test_column_running_sum", "inputs": {"input": "image"}, "outputs": {"output": "sums"},
             "schedule": {"tile_height": 8}}], "outputs": ["sums"]})";

TEST(RowState, SchedulerRunsTheTilesInOrderAndResetsStateEachFrame) {
  Graph graph(parse_graph_spec(kGraph, "sums.json"));
  VerifyOptions options;
  options.frame_width = 200;
  options.frame_height = 61;
  graph.verify(options);
  arm::FrameRunner runner(graph, 3);
  for (uint32_t frame = 0; frame < 3; ++frame) {
    const Plane input = random_plane(200, 61, {ElementType::u8, 0}, 0, 10 + frame);
    runner.process({{"image", &input}});
    EXPECT_TRUE(planes_equal(reference_sums(input), runner.buffer("sums"))) << "frame " << frame;
  }
}

TEST(RowStateMustFail, VerifyRefusesTilesNarrowerThanTheFrame) {
  std::string json = kGraph;
  json.replace(json.find("\"tile_height\": 8"), 16, "\"tile_width\": 64, \"tile_height\": 8");
  Graph graph(parse_graph_spec(json, "sums.json"));
  VerifyOptions options;
  options.frame_width = 200;
  options.frame_height = 61;
  try {
    graph.verify(options);
    FAIL() << "expected VerifyError";
  } catch (const VerifyError& error) {
    EXPECT_STREQ(error.what(),
                 "verify phase 4 (memory placement): node 'sums': kernel 'test_column_running_sum' carries row state: "
                 "expected full-width tiles (200), got tile width 64");
  }
}

TEST(RowState, StateCountsInTheSramWorkingSetAndTheSimulatorRunsIt) {
  Graph graph(parse_graph_spec(kGraph, "sums.json"));
  VerifyOptions options;
  options.frame_width = 200;
  options.frame_height = 61;
  graph.verify(options);
  const NodeInfo& node = graph.nodes()[0];
  // double-buffered tiles (u8 in, u32 out) + 4 bytes of state per column
  EXPECT_EQ(node.sram_working_set_bytes, 2u * 200 * 8 * (1 + 4) + 4u * 200);
  host_sim::Target target;
  target.name = "unit";
  target.vector = {1000, 512, {}, 100};
  target.vector.op_cycles.fill(1.0);
  target.dma = {10, 50};
  target.memory = {1 << 20, 1 << 30, 10, 0.5};
  target.arm = {1, 1000, 1, 1};
  target.frames_in_flight = 2;
  const Plane input = random_plane(200, 61, {ElementType::u8, 0}, 0, 1);
  host_sim::ProfileOptions every;
  every.count_every_tile = true;
  const host_sim::ProfileReport once = host_sim::profile_graph(graph, target, {{"image", &input}}, {});
  const host_sim::ProfileReport all = host_sim::profile_graph(graph, target, {{"image", &input}}, every);
  EXPECT_EQ(once.nodes[0].ops, all.nodes[0].ops);
  EXPECT_EQ(once.nodes[0].tiles, 8u);
}

}  // namespace
}  // namespace lpstereo
