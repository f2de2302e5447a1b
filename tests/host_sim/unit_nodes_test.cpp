// Nodes bound to a target's fixed-function units: verify() against the unit's limits (each refusal
// names node, unit, limit and actual value), the unit's own timeline, rate and DRAM traffic in the
// simulator, the unit's internal stage kept out of DRAM, and target files whose units lack a number.
#include <gtest/gtest.h>

#include <set>

#include "arm/scheduler.h"
#include "host_sim/report.h"
#include "host_sim/simulator.h"
#include "host_sim/target.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::random_plane;

// Census and SGM on the stereo unit, the exposure statistics on the ARM side. Replaced in the
// must-fail cases: CENSUS (kernel), ENGINE (of the matcher), RANGE, P1.
const char* kStereoOnUnit = R"({
  "name": "stereo-unit",
  "inputs": [{"name": "left", "format": "u8"}, {"name": "right", "format": "u8"}],
  "nodes": [
    {"name": "census_left", "kernel": "CENSUS", "engine": "stereo", "inputs": {"input": "left"}, "outputs": {"output": "left_census"}},
    {"name": "census_right", "kernel": "CENSUS", "engine": "stereo", "inputs": {"input": "right"}, "outputs": {"output": "right_census"}},
    {"name": "match", "kernel": "sgm_4path", "engine": "ENGINE", "inputs": {"left": "left_census", "right": "right_census"},
     "outputs": {"disparity": "disparity"}, "params": {"num_disparities": RANGE, "p1": P1, "p2": 45}},
    {"name": "exposure", "task": "exposure_statistics", "inputs": {"image": "left"}, "outputs": {"statistics": "stats"}}
  ],
  "outputs": ["disparity", "stats"]
})";

std::string graph_text(const std::string& census = "census5x5", int range = 64, int p1 = 5, const std::string& engine = "stereo") {
  std::string text = kStereoOnUnit;
  auto replace_all = [&](const std::string& from, const std::string& to) {
    for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) text.replace(at, from.size(), to);
  };
  replace_all("CENSUS", census);
  replace_all("ENGINE", engine);
  replace_all("RANGE", std::to_string(range));
  replace_all("P1", std::to_string(p1));
  return text;
}

host_sim::FixedFunctionUnit stereo_unit() {
  host_sim::FixedFunctionUnit unit;
  unit.limits.name = "stereo";
  unit.limits.kind = "stereo";
  unit.limits.functions = {"census5x5", "sgm_4path"};
  unit.limits.max_width = 1024;
  unit.limits.max_height = 512;
  unit.limits.search_ranges = {64, 128};
  unit.limits.census_width = 5;
  unit.limits.census_height = 5;
  unit.limits.p1_max = 127;
  unit.limits.p2_max = 255;
  unit.limits.local_memory_bytes = 1 << 20;
  unit.clock_mhz = 500;
  unit.pixels_per_cycle = 0.5;
  unit.setup_us = 10;
  unit.dram_bytes_per_pixel = 4;
  unit.reference_search_range = 128;
  unit.search_range_scaling = 1;
  return unit;
}

host_sim::Target target_with_unit() {
  host_sim::Target target = host_sim::load_target_file(std::string(LPSTEREO_SOURCE_DIR) + "/targets/cv1-class.json");
  target.units = {stereo_unit()};
  return target;
}

Graph verified(const std::string& text, const host_sim::Target& target, int width, int height) {
  Graph graph(parse_graph_spec(text, "stereo-unit.json"));
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  options.memory = target.memory_budget();
  graph.verify(options);
  return graph;
}

std::string verify_error(const std::string& text, const host_sim::Target& target, int width = 640, int height = 360) {
  try {
    verified(text, target, width, height);
  } catch (const VerifyError& error) {
    return error.what();
  }
  return "";
}

TEST(UnitNodes, TheUnitRunsTheMatcherAtItsRateOnItsOwnTrack) {
  const host_sim::Target target = target_with_unit();
  const Graph graph = verified(graph_text(), target, 640, 360);
  const Plane left = random_plane(640, 360, {ElementType::u8, 0}, 0, 7);
  const Plane right = random_plane(640, 360, {ElementType::u8, 0}, 0, 8);
  const host_sim::ProfileReport report = host_sim::profile_graph(graph, target, {{"left", &left}, {"right", &right}}, {});
  ASSERT_EQ(report.nodes.size(), 4u);
  // 640 x 360 pixels at 0.5 a cycle, range 64 of the reference 128 (time proportional), 500 MHz, plus 10 us.
  const double match_ms = 0.010 + 640.0 * 360.0 / 0.5 * (64.0 / 128.0) / 500e6 * 1e3;
  for (const host_sim::NodeProfile& node : report.nodes) {
    if (node.name == "exposure") continue;
    EXPECT_EQ(node.kind, "unit") << node.name;
    EXPECT_EQ(node.engine, "stereo") << node.name;
    if (node.name == "match") {
      EXPECT_NEAR(node.ms, match_ms, 1e-9);
      EXPECT_EQ(node.dram_bytes, 4u * 640u * 360u);
    } else {
      // The census stage streams inside the unit: its rate is the matcher's, its traffic none.
      EXPECT_EQ(node.ms, 0) << node.name;
      EXPECT_EQ(node.dram_bytes, 0u) << node.name;
    }
  }
  EXPECT_EQ(report.vector_cycles_per_frame, 0);
  const auto unit_load = std::find_if(report.engines.begin(), report.engines.end(),
                                      [](const host_sim::EngineLoad& engine) { return engine.name == "unit stereo (stereo)"; });
  ASSERT_NE(unit_load, report.engines.end());
  EXPECT_NEAR(unit_load->busy_ms, match_ms, 1e-6);
  EXPECT_NEAR(unit_load->load_percent, 100.0 * match_ms / std::max(report.frame_ms, 1000.0 / 30), 1e-3);
  const nlohmann::json trace = nlohmann::json::parse(host_sim::chrome_trace_json(report));
  std::set<std::string> tracks;
  for (const nlohmann::json& event : trace["traceEvents"]) {
    if (event["ph"] == "M" && event["name"] == "thread_name") tracks.insert(event["args"]["name"].get<std::string>());
  }
  EXPECT_TRUE(tracks.count("unit stereo (stereo)"));
  // The census planes stay in the unit: less DRAM than the same graph on the vector engine.
  const Graph on_vector = verified(graph_text("census5x5", 64, 5, "vector"), target, 640, 360);
  EXPECT_EQ(on_vector.dram_peak_bytes() - graph.dram_peak_bytes(), 2u * 640u * 360u * 4u);
}

// A median after the matcher on the same unit (TI's SDE has one): the matcher becomes an internal
// stage, the median carries the job's time at the matcher's search range and its DRAM traffic.
TEST(UnitNodes, AMedianOnTheUnitCarriesItsMatchersJob) {
  host_sim::Target target = target_with_unit();
  target.units[0].limits.functions.push_back("median3x3_s16");
  std::string text = graph_text();
  const std::string match_end = R"("params": {"num_disparities": 64, "p1": 5, "p2": 45}},)";
  ASSERT_NE(text.find(match_end), std::string::npos);
  text.replace(text.find(R"({"disparity": "disparity"})"), 26, R"({"disparity": "raw"})");
  text.insert(text.find(match_end) + match_end.size(),
              R"({"name": "median", "kernel": "median3x3_s16", "engine": "stereo", "inputs": {"input": "raw"},
                  "outputs": {"output": "disparity"}, "params": {"invalid_q4": -16}},)");
  const Graph graph = verified(text, target, 640, 360);
  const Plane left = random_plane(640, 360, {ElementType::u8, 0}, 0, 7);
  const Plane right = random_plane(640, 360, {ElementType::u8, 0}, 0, 8);
  const host_sim::ProfileReport report = host_sim::profile_graph(graph, target, {{"left", &left}, {"right", &right}}, {});
  const double job_ms = 0.010 + 640.0 * 360.0 / 0.5 * (64.0 / 128.0) / 500e6 * 1e3;  // at the matcher's range 64
  for (const host_sim::NodeProfile& node : report.nodes) {
    if (node.name == "median") {
      EXPECT_NEAR(node.ms, job_ms, 1e-9);
      EXPECT_EQ(node.dram_bytes, 4u * 640u * 360u);
    } else if (node.name != "exposure") {
      EXPECT_EQ(node.ms, 0) << node.name;
      EXPECT_EQ(node.dram_bytes, 0u) << node.name;
    }
  }
}

TEST(UnitNodes, TheFunctionalModelGivesTheKernelsBits) {
  const host_sim::Target target = target_with_unit();
  const Graph on_unit = verified(graph_text(), target, 333, 97);
  Graph on_host(parse_graph_spec(graph_text(), "stereo-unit.json"));  // the host ignores engines
  VerifyOptions host;
  host.frame_width = 333;
  host.frame_height = 97;
  on_host.verify(host);
  const Graph on_vector = verified(graph_text("census5x5", 64, 5, "vector"), target, 333, 97);
  const Plane left = random_plane(333, 97, {ElementType::u8, 0}, 0, 3);
  const Plane right = random_plane(333, 97, {ElementType::u8, 0}, 0, 4);
  auto disparity = [&](const Graph& graph) {
    arm::FrameRunner runner(graph, 2);
    runner.process({{"left", &left}, {"right", &right}});
    const Plane& plane = runner.buffer("disparity");
    std::vector<int16_t> values;
    for (int y = 0; y < plane.height(); ++y) {
      for (int x = 0; x < plane.width(); ++x) values.push_back(plane.at<int16_t>(x, y));
    }
    return values;
  };
  const std::vector<int16_t> unit_bits = disparity(on_unit);
  EXPECT_EQ(unit_bits, disparity(on_vector));
  EXPECT_EQ(unit_bits, disparity(on_host));
  EXPECT_GT(std::count_if(unit_bits.begin(), unit_bits.end(), [](int16_t value) { return value >= 0; }), 333 * 97 / 4);
}

TEST(UnitNodesMustFail, EachLimitIsNamedWithItsValue) {
  const host_sim::Target target = target_with_unit();
  EXPECT_EQ(verify_error(graph_text(), target, 1100, 360),
            "verify phase 4 (memory placement): node 'census_left' on unit 'stereo': buffer 'left' is 1100x360, the unit's "
            "limit is 1024x512");
  EXPECT_EQ(verify_error(graph_text("census5x5", 96), target),
            "verify phase 4 (memory placement): node 'match' on unit 'stereo': search range (num_disparities) 96 is not one "
            "the unit offers (64, 128)");
  host_sim::Target strict = target;
  strict.units[0].limits.p1_max = 4;
  EXPECT_EQ(verify_error(graph_text(), strict),
            "verify phase 4 (memory placement): node 'match' on unit 'stereo': penalties p1 5, p2 45, the unit's limits are "
            "p1 <= 4, p2 <= 255");
  host_sim::Target wider_census = target;
  wider_census.units[0].limits.census_width = 7;
  wider_census.units[0].limits.census_height = 7;
  EXPECT_EQ(verify_error(graph_text(), wider_census),
            "verify phase 4 (memory placement): node 'census_left' on unit 'stereo': census window 5x5, the unit's is 7x7");
  host_sim::Target matcher_only = target;
  matcher_only.units[0].limits.functions = {"sgm_4path"};
  EXPECT_EQ(verify_error(graph_text(), matcher_only),
            "verify phase 4 (memory placement): node 'census_left' on unit 'stereo': kernel 'census5x5' is not one of its "
            "functions (sgm_4path)");
  host_sim::Target small = target;
  small.units[0].limits.local_memory_bytes = 1024;
  EXPECT_EQ(verify_error(graph_text(), small).rfind("verify phase 4 (memory placement): node 'match' on unit 'stereo': row "
                                                    "state of ", 0), 0u)
      << verify_error(graph_text(), small);
  host_sim::Target none = target;
  none.units.clear();
  EXPECT_EQ(verify_error(graph_text(), none),
            "verify phase 4 (memory placement): node 'census_left': engine 'stereo': target 'cv1-class' has no such unit (its "
            "units: none)");
  // A unit node without its programmed values.
  std::string unprogrammed = graph_text();
  unprogrammed.replace(unprogrammed.find(", \"p1\": 5"), 9, "");
  EXPECT_EQ(verify_error(unprogrammed, target),
            "verify phase 4 (memory placement): node 'match' on unit 'stereo': parameter 'p1' must be given as an integer (a "
            "unit is programmed with explicit values)");
}

TEST(UnitNodesMustFail, GraphFilesBindUnitsToKernelsOnly) {
  auto spec_error = [](const std::string& node) {
    const std::string text = R"({"name": "g", "inputs": [{"name": "left", "format": "u8"}], "nodes": [)" + node +
                             R"(], "outputs": ["stats"]})";
    try {
      parse_graph_spec(text, "g.json");
    } catch (const GraphSpecError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  const std::string task = R"({"name": "exposure", "task": "exposure_statistics", "engine": "ENGINE", "inputs": {"image": "left"},
                               "outputs": {"statistics": "stats"}})";
  auto with = [&](const std::string& engine) { return std::string(task).replace(task.find("ENGINE"), 6, engine); };
  EXPECT_EQ(spec_error(with("stereo")), "g.json: at $.nodes[0].engine: a fixed-function unit ('stereo') runs a kernel, this node has a task");
  EXPECT_EQ(spec_error(with("vector")), "g.json: at $.nodes[0].engine: 'vector' runs kernels, this node has a task");
  EXPECT_EQ(spec_error(with("arm")), "");
}

TEST(TargetUnitsMustFail, AUnitNeedsEveryNumberAndItsReason) {
  const std::string base = host_sim::load_target_file(std::string(LPSTEREO_SOURCE_DIR) + "/targets/cv1-class.json").name;
  ASSERT_EQ(base, "cv1-class");
  std::ifstream file(std::string(LPSTEREO_SOURCE_DIR) + "/targets/cv1-class.json");
  nlohmann::json document = nlohmann::json::parse(file);
  auto message = [](const nlohmann::json& edited) {
    try {
      host_sim::parse_target(edited.dump(), "t.json");
    } catch (const host_sim::TargetError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  nlohmann::json unit = {{"kind", "stereo"}, {"functions", {"sgm_4path"}}, {"output_format", "s16 Q4"}};
  for (const char* key : {"clock_mhz", "pixels_per_cycle", "setup_us", "dram_bytes_per_pixel", "max_width", "max_height",
                          "local_memory_bytes", "reference_search_range", "search_range_scaling", "p1_max", "p2_max"}) {
    unit[key] = {{"value", 1}, {"why", "a reason for the test"}};
  }
  unit["search_ranges"] = {{"value", {64, 128}}, {"why", "a reason for the test"}};
  unit["census_window"] = {{"value", {5, 5}}, {"why", "a reason for the test"}};
  document["units"] = {{"probe", unit}};
  EXPECT_EQ(message(document), "");
  nlohmann::json missing = document;
  missing["units"]["probe"].erase("p2_max");
  EXPECT_EQ(message(missing), "t.json: at $.units.probe: missing key 'p2_max'");
  nlohmann::json unreasoned = document;
  unreasoned["units"]["probe"]["clock_mhz"]["why"] = "";
  EXPECT_EQ(message(unreasoned), "t.json: at $.units.probe.clock_mhz.why: every number needs its source or reason");
  nlohmann::json ranges = document;
  ranges["units"]["probe"]["search_ranges"]["value"] = {64, "x"};
  EXPECT_EQ(message(ranges), "t.json: at $.units.probe.search_ranges.value: expected a list of integers in [1, 4096], got [64,\"x\"]");
  nlohmann::json kind = document;
  kind["units"]["probe"]["kind"] = "isp";
  EXPECT_EQ(message(kind), "t.json: at $.units.probe.kind: expected \"stereo\", \"warp\" or \"scaler\", got \"isp\"");
  nlohmann::json no_pipeline = document;
  no_pipeline.erase("pipeline");
  EXPECT_EQ(message(no_pipeline), "t.json: at $: missing section 'pipeline'");
}

}  // namespace
}  // namespace lpstereo
