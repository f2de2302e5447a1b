// Graph specs and verify(): the named phases, the errors they must give (each naming node, port,
// expected and actual), delayed edges, DOT export.
#include <gtest/gtest.h>

#include <string>

#include "dag/graph.h"

namespace lpstereo {
namespace {

GraphSpec spec_from(const std::string& json) { return parse_graph_spec(json, "test.json"); }

VerifyOptions options_for(int width, int height, size_t sram_bytes = 0, size_t dram_bytes = 0) {
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  options.memory.target_name = "test-target";
  options.memory.sram_bytes = sram_bytes;
  options.memory.dram_bytes = dram_bytes;
  return options;
}

// The message of the VerifyError verify() throws (empty if none).
std::string verify_error(const std::string& json, const VerifyOptions& options) {
  try {
    Graph graph(spec_from(json));
    graph.verify(options);
  } catch (const VerifyError& error) {
    return error.what();
  }
  return "";
}

const char* kCensusPair = R"({
  "name": "pair",
  "inputs": [{"name": "left", "format": "u8"}, {"name": "right", "format": "u8"}],
  "nodes": [
    {"name": "census_left", "kernel": "census5x5", "inputs": {"input": "left"}, "outputs": {"output": "left_census"}},
    {"name": "census_right", "kernel": "census5x5", "inputs": {"input": "right"}, "outputs": {"output": "right_census"}},
    {"name": "match", "kernel": "census_wta_disparity", "inputs": {"left": "left_census", "right": "right_census"},
     "outputs": {"disparity": "disparity"}, "params": {"num_disparities": 16}}
  ],
  "outputs": ["disparity"]
})";

TEST(GraphVerify, AcceptsAValidGraphAndOrdersItTopologically) {
  Graph graph(spec_from(kCensusPair));
  graph.verify(options_for(320, 240));
  ASSERT_TRUE(graph.verified());
  ASSERT_EQ(graph.order().size(), 3u);
  EXPECT_EQ(graph.nodes()[graph.order().back()].spec.name, "match");
  const BufferInfo& disparity = graph.buffers()[graph.buffer_index("disparity")];
  EXPECT_EQ(format_name(disparity.format), "s16q4");  // propagated to the virtual buffer
  EXPECT_EQ(disparity.shape, (PlaneShape{320, 240}));
}

const char* kTwoCounterLoop = R"({
  "name": "loop", "inputs": [],
  "nodes": [
    {"name": "counter_a", "task": "test_frame_counter", "inputs": {"previous": BACK_EDGE}, "outputs": {"count": "a"}},
    {"name": "counter_b", "task": "test_frame_counter", "inputs": {"previous": "a"}, "outputs": {"count": "b"}}
  ]})";

std::string two_counter_loop(const std::string& back_edge) {
  std::string json = kTwoCounterLoop;
  json.replace(json.find("BACK_EDGE"), 9, back_edge);
  return json;
}

TEST(GraphVerifyMustFail, CycleWithoutDelayedEdgeNamesTheNodes) {
  const std::string message = verify_error(two_counter_loop("\"b\""), options_for(64, 64));
  EXPECT_NE(message.find("verify phase 1 (topological order): cycle not broken by a delayed edge: "
                         "'counter_a' -> 'counter_b' -> 'counter_a'"),
            std::string::npos)
      << message;
  const std::string self = verify_error(R"({"name": "self", "inputs": [],
    "nodes": [{"name": "counter", "task": "test_frame_counter", "inputs": {"previous": "count"}, "outputs": {"count": "count"}}]})",
                                        options_for(64, 64));
  EXPECT_NE(self.find("'counter' -> 'counter'"), std::string::npos) << self;
}

TEST(GraphVerify, DelayedEdgeBreaksACycle) {
  Graph graph(spec_from(two_counter_loop(R"({"buffer": "b", "delayed": true})")));
  graph.verify(options_for(64, 64));
  ASSERT_EQ(graph.order().size(), 2u);
  EXPECT_EQ(graph.nodes()[graph.order()[0]].spec.name, "counter_a");
  EXPECT_TRUE(graph.buffers()[graph.buffer_index("b")].read_delayed);
}

TEST(GraphVerifyMustFail, TwoWritersNameBothWriters) {
  const std::string message = verify_error(R"({
    "name": "two", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [
      {"name": "writer_a", "kernel": "census5x5", "inputs": {"input": "image"}, "outputs": {"output": "signature"}},
      {"name": "writer_b", "kernel": "census5x5", "inputs": {"input": "image"}, "outputs": {"output": "signature"}}
    ]})", options_for(64, 64));
  EXPECT_NE(message.find("verify phase 3 (single writer)"), std::string::npos) << message;
  EXPECT_NE(message.find("buffer 'signature' has 2 writers: node 'writer_a' port 'output' and node 'writer_b' port 'output'"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("expected 1 writer"), std::string::npos) << message;
}

TEST(GraphVerifyMustFail, FormatMismatchNamesNodePortExpectedAndActual) {
  const std::string message = verify_error(R"({
    "name": "mismatch", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [
      {"name": "census", "kernel": "census5x5", "inputs": {"input": "image"}, "outputs": {"output": "signature"}},
      {"name": "census_again", "kernel": "census5x5", "inputs": {"input": "signature"}, "outputs": {"output": "twice"}}
    ]})", options_for(64, 64));
  EXPECT_NE(message.find("verify phase 2 (ports and formats)"), std::string::npos) << message;
  EXPECT_NE(message.find("node 'census_again' port 'input': format mismatch: expected u8, got census32"), std::string::npos)
      << message;
}

TEST(GraphVerifyMustFail, SramWorkingSetOverTheTargetNamesNodeAndBytes) {
  // A forced full-frame tile: 2 x (1024 x 1024 x (1 + 4)) bytes of tiles plus halo > 1 MiB of SRAM.
  const std::string message = verify_error(R"({
    "name": "big", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [
      {"name": "census", "kernel": "census5x5", "inputs": {"input": "image"}, "outputs": {"output": "signature"},
       "schedule": {"tile_width": 1024, "tile_height": 1024}}
    ]})", options_for(1024, 1024, 1 << 20));
  EXPECT_NE(message.find("verify phase 4 (memory placement)"), std::string::npos) << message;
  EXPECT_NE(message.find("node 'census': SRAM working set of a 1024x1024 tile is "), std::string::npos) << message;
  EXPECT_NE(message.find("target 'test-target' has 1048576 bytes of SRAM (over by "), std::string::npos) << message;
  // Its own kind, which lpstereo profile catches to report the graph anyway.
  Graph graph(spec_from(R"({
    "name": "big", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [
      {"name": "census", "kernel": "census5x5", "inputs": {"input": "image"}, "outputs": {"output": "signature"},
       "schedule": {"tile_width": 1024, "tile_height": 1024}}
    ]})"));
  EXPECT_THROW(graph.verify(options_for(1024, 1024, 1 << 20)), SramBudgetError);
}

TEST(GraphVerify, AutoTilingFitsTheSramShare) {
  Graph graph(spec_from(kCensusPair));
  VerifyOptions options = options_for(3840, 1728, 1 << 20);
  graph.verify(options);
  for (const NodeInfo& node : graph.nodes()) {
    EXPECT_LE(node.sram_working_set_bytes, static_cast<size_t>(0.75 * (1 << 20))) << node.spec.name;
    EXPECT_GE(node.tile_height, 1);
  }
  EXPECT_LE(graph.sram_peak_bytes(), size_t{1} << 20);
}

TEST(GraphVerifyMustFail, DramPeakOverTheTarget) {
  const std::string message = verify_error(kCensusPair, options_for(3840, 1728, 0, 10 << 20));
  EXPECT_NE(message.find("verify phase 4 (memory placement)"), std::string::npos) << message;
  EXPECT_NE(message.find("DRAM peak is "), std::string::npos) << message;
  EXPECT_NE(message.find("gives graphs 10485760 bytes (over by "), std::string::npos) << message;
}

TEST(GraphVerifyMustFail, UnknownKernelNamesNodeAndKernel) {
  const std::string message = verify_error(R"({
    "name": "unknown", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [{"name": "mystery", "kernel": "census11x11", "inputs": {"input": "image"}, "outputs": {"output": "x"}}]})",
                                           options_for(64, 64));
  EXPECT_NE(message.find("node 'mystery': unknown kernel 'census11x11' (known: "), std::string::npos) << message;
  EXPECT_NE(message.find("census5x5"), std::string::npos) << message;
}

TEST(GraphVerifyMustFail, UnknownPortUnconnectedPortAndMissingWriter) {
  EXPECT_NE(verify_error(R"({"name": "g", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [{"name": "n", "kernel": "census5x5", "inputs": {"source": "image"}, "outputs": {"output": "x"}}]})",
                         options_for(64, 64))
                .find("node 'n' port 'source': no such input port (expected one of: input)"),
            std::string::npos);
  EXPECT_NE(verify_error(R"({"name": "g", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [{"name": "n", "kernel": "census5x5", "inputs": {}, "outputs": {"output": "x"}}]})",
                         options_for(64, 64))
                .find("node 'n' port 'input': input not connected (expected a u8 buffer)"),
            std::string::npos);
  EXPECT_NE(verify_error(R"({"name": "g", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [{"name": "n", "kernel": "census5x5", "inputs": {"input": "nowhere"}, "outputs": {"output": "x"}}]})",
                         options_for(64, 64))
                .find("buffer 'nowhere' read by node 'n' has no writer"),
            std::string::npos);
}

TEST(GraphVerifyMustFail, BadParametersAndBorderModes) {
  const std::string message = verify_error(R"({"name": "g", "inputs": [{"name": "l", "format": "census32"}, {"name": "r", "format": "census32"}],
    "nodes": [{"name": "m", "kernel": "census_wta_disparity", "inputs": {"left": "l", "right": "r"},
               "outputs": {"disparity": "d"}, "params": {"num_disparities": 5000}}]})",
                                           options_for(64, 64));
  EXPECT_NE(message.find("node 'm' (kernel 'census_wta_disparity'): parameter 'num_disparities': expected an integer in [1, 2047], got 5000"),
            std::string::npos)
      << message;
  const std::string border = verify_error(R"({"name": "g", "inputs": [{"name": "l", "format": "census32"}, {"name": "r", "format": "census32"}],
    "nodes": [{"name": "m", "kernel": "census_wta_disparity", "inputs": {"left": "l", "right": "r"},
               "outputs": {"disparity": "d"}, "border": "constant"}]})",
                                          options_for(64, 64));
  EXPECT_NE(border.find("border mode 'constant' not supported by kernel 'census_wta_disparity'"), std::string::npos) << border;
}

TEST(GraphSpecMustFail, MalformedJsonReportsLineAndColumn) {
  try {
    parse_graph_spec("{\n  \"name\": \"x\",\n  \"nodes\": [ oops ]\n}", "broken.json");
    FAIL() << "expected GraphSpecError";
  } catch (const GraphSpecError& error) {
    EXPECT_EQ(std::string(error.what()).rfind("broken.json:3:14: malformed JSON", 0), 0u) << error.what();
  }
}

TEST(GraphSpecMustFail, SchemaErrorsNameThePath) {
  auto message = [](const std::string& json) {
    try {
      parse_graph_spec(json, "g.json");
    } catch (const GraphSpecError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  EXPECT_EQ(message(R"({"name": "g", "inputs": [], "nodes": [{"name": "n"}]})"),
            "g.json: at $.nodes[0]: expected exactly one of 'kernel' and 'task'");
  EXPECT_EQ(message(R"({"name": "g", "inputs": [{"name": "i", "format": "u9"}], "nodes": [{"name": "n", "task": "t"}]})"),
            "g.json: at $.inputs[0].format: unknown format 'u9' (u8, u16, s16q4, census32, ...)");
  EXPECT_EQ(message(R"({"name": "g", "inputs": [], "nodes": [{"name": "n", "task": "t", "colour": 1}]})").rfind(
                "g.json: at $.nodes[0]: unknown key 'colour'", 0),
            0u);
  EXPECT_EQ(message(R"({"name": "g", "inputs": [], "nodes": [{"name": "n", "task": "t"}], "budget": {"enforce": false}})"),
            "g.json: at $.budget.note: a graph not enforced must say why");
  EXPECT_NE(message("[1, 2]"), "");
}

// A constant may have its own size (a remap table whose output is not the frame's size, as a
// latitude-longitude rectification to another size): the remap output takes the table's size.
TEST(GraphVerify, AConstantOfItsOwnSizeSetsTheRemapOutputSize) {
  register_constant_generator("test_table_80x50", {ElementType::remap_q5, 0},
                              [](const nlohmann::json&, int, int) { return Plane(80, 50, {ElementType::remap_q5, 0}); });
  const std::string json = R"({
    "name": "sized", "inputs": [{"name": "source", "format": "u8"}],
    "constants": [{"name": "map", "generator": "test_table_80x50" SIZE}],
    "nodes": [{"name": "remap", "kernel": "remap_bilinear", "inputs": {"source": "source", "map": "map"}, "outputs": {"output": "out"}}],
    "outputs": ["out"]})";
  auto with_size = [&](const std::string& size) {
    std::string text = json;
    text.replace(text.find("SIZE"), 4, size);
    return text;
  };
  Graph graph(spec_from(with_size(R"(, "width": 80, "height": 50)")));
  graph.verify(options_for(320, 240));
  EXPECT_EQ(graph.buffers()[graph.buffer_index("out")].shape, (PlaneShape{80, 50}));
  EXPECT_NE(verify_error(with_size(""), options_for(320, 240)).find("gave 80x50 remap_q5, expected 320x240 remap_q5"), std::string::npos);
  try {
    spec_from(with_size(R"(, "width": -3)"));
    FAIL() << "a negative constant width accepted";
  } catch (const GraphSpecError& error) {
    EXPECT_NE(std::string(error.what()).find("at $.constants[0].width: expected an integer 0..65536 (0 = the frame size), got -3"),
              std::string::npos)
        << error.what();
  }
}

TEST(GraphDot, DrawsNodesBuffersAndDelayedEdges) {
  Graph graph(spec_from(R"({
    "name": "dot", "inputs": [{"name": "image", "format": "u8"}],
    "nodes": [
      {"name": "census", "kernel": "census5x5", "inputs": {"input": "image"}, "outputs": {"output": "signature"}},
      {"name": "match", "kernel": "census_wta_disparity",
       "inputs": {"left": "signature", "right": {"buffer": "signature", "delayed": true}}, "outputs": {"disparity": "d"}},
      {"name": "stats", "task": "exposure_statistics", "inputs": {"image": "image"}, "outputs": {"statistics": "s"}}
    ], "outputs": ["d"]})"));
  const std::string dot = graph.to_dot();
  EXPECT_EQ(dot.rfind("digraph \"dot\" {", 0), 0u);
  EXPECT_NE(dot.find("\"node:census\" [shape=box"), std::string::npos);
  EXPECT_NE(dot.find("vector: census5x5"), std::string::npos);
  EXPECT_NE(dot.find("ARM: exposure_statistics"), std::string::npos);
  EXPECT_NE(dot.find("\"node:census\" -> \"node:match\" [label=\"signature\", style=dashed"), std::string::npos) << dot;
}

TEST(Formats, ParseAndNameRoundTrip) {
  for (const char* name : {"u8", "u16", "s16q4", "s16", "s32q8", "census32", "census64", "remap_q5", "u32"}) {
    std::optional<BufferFormat> format = parse_format(name);
    ASSERT_TRUE(format.has_value()) << name;
    EXPECT_EQ(format_name(*format), std::string(name) == "s16" ? "s16q0" : name);
  }
  EXPECT_FALSE(parse_format("s16q16").has_value());
  EXPECT_FALSE(parse_format("u8q4").has_value());
  EXPECT_FALSE(parse_format("float").has_value());
}

}  // namespace
}  // namespace lpstereo
