// The host simulator: report keys, scaling, data-obliviousness of the per-shape op counts, the
// trace, determinism, budgets, and target-file validation.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>

#include "host_sim/report.h"
#include "host_sim/simulator.h"
#include "host_sim/target.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::random_plane;

const char* kPipeline = R"({
  "name": "pipeline",
  "inputs": [{"name": "left", "format": "u8"}, {"name": "right", "format": "u8"}],
  "nodes": [
    {"name": "census_left", "kernel": "census5x5", "inputs": {"input": "left"}, "outputs": {"output": "left_census"}},
    {"name": "census_right", "kernel": "census5x5", "inputs": {"input": "right"}, "outputs": {"output": "right_census"}},
    {"name": "match", "kernel": "census_wta_disparity", "inputs": {"left": "left_census", "right": "right_census"},
     "outputs": {"disparity": "disparity"}, "params": {"num_disparities": 32}},
    {"name": "exposure", "task": "exposure_statistics", "inputs": {"image": "left"}, "outputs": {"statistics": "stats"}}
  ],
  "outputs": ["disparity", "stats"]
})";

host_sim::Target cv1_class() { return host_sim::load_target_file(std::string(LPSTEREO_SOURCE_DIR) + "/targets/cv1-class.json"); }

struct Profiled {
  Graph graph;
  host_sim::ProfileReport report;
};

host_sim::ProfileReport profile(int width, int height, const host_sim::Target& target, host_sim::ProfileOptions options = {}) {
  Graph graph(parse_graph_spec(kPipeline, "pipeline.json"));
  VerifyOptions verify_options;
  verify_options.frame_width = width;
  verify_options.frame_height = height;
  verify_options.memory = target.memory_budget();
  graph.verify(verify_options);
  const Plane left = random_plane(width, height, {ElementType::u8, 0}, 0, 7);
  const Plane right = random_plane(width, height, {ElementType::u8, 0}, 0, 8);
  return host_sim::profile_graph(graph, target, {{"left", &left}, {"right", &right}}, options);
}

TEST(Simulator, ReportHasEveryDocumentedKey) {
  const nlohmann::json json = host_sim::report_json(profile(640, 360, cv1_class()));
  for (const char* key : {"target", "width", "height", "fps_target", "frame_ms", "fps", "fits_budget", "sram_budget_bytes",
                          "sram_peak_bytes", "dram_budget_bytes", "dram_peak_bytes", "dram_bytes_per_frame",
                          "dram_bandwidth_gbps", "dram_bandwidth_limit_gbps", "nodes", "model", "latency_ms",
                          "max_latency_ms", "frames_in_flight", "bottleneck", "dram_in_flight_bytes", "engines"}) {
    EXPECT_TRUE(json.contains(key)) << key;
  }
  EXPECT_EQ(json["model"], "op-level, cycle-approximate");
  ASSERT_EQ(json["nodes"].size(), 4u);
  for (const nlohmann::json& node : json["nodes"]) {
    for (const char* key : {"name", "kind", "engine", "cycles", "ms", "share", "dram_bytes", "sram_peak_bytes", "ops"}) {
      EXPECT_TRUE(node.contains(key)) << node["name"] << " " << key;
    }
    EXPECT_TRUE(node["kind"] == "vector" || node["kind"] == "arm");
    EXPECT_GT(node["cycles"].get<double>(), 0) << node["name"];
  }
  EXPECT_EQ(json["nodes"][0]["ops"]["load"].get<uint64_t>() > 0, true);
  // One load per engine track: vector engine, DMA, the ARM cores (this graph uses no unit).
  ASSERT_EQ(json["engines"].size(), 2u + 4u);
  for (const nlohmann::json& engine : json["engines"]) {
    EXPECT_GE(engine["load_percent"].get<double>(), 0.0);
    EXPECT_LE(engine["load_percent"].get<double>(), 100.0 + 1e-9) << engine["name"];
  }
}

TEST(Simulator, DoublingTheWidthDoublesVectorCycles) {
  const host_sim::Target target = cv1_class();
  const host_sim::ProfileReport narrow = profile(960, 432, target);
  const host_sim::ProfileReport wide = profile(1920, 432, target);
  const double ratio = wide.vector_cycles_per_frame / narrow.vector_cycles_per_frame;
  EXPECT_NEAR(ratio, 2.0, 0.1) << narrow.vector_cycles_per_frame << " -> " << wide.vector_cycles_per_frame;
}

TEST(Simulator, CountingOncePerTileShapeEqualsCountingEveryTile) {
  // The kernels are data-oblivious: every tile of a shape has the same counted ops.
  host_sim::Target target = cv1_class();
  target.memory.sram_bytes = 128 * 1024;  // many tiles
  host_sim::ProfileOptions every;
  every.count_every_tile = true;
  const host_sim::ProfileReport once = profile(500, 203, target);
  const host_sim::ProfileReport all = profile(500, 203, target, every);
  ASSERT_EQ(once.nodes.size(), all.nodes.size());
  for (size_t i = 0; i < once.nodes.size(); ++i) {
    EXPECT_EQ(once.nodes[i].ops, all.nodes[i].ops) << once.nodes[i].name;
    EXPECT_GT(once.nodes[i].kind == "vector" ? once.nodes[i].tiles : 2u, 1u) << once.nodes[i].name;
  }
  EXPECT_DOUBLE_EQ(once.frame_ms, all.frame_ms);
}

TEST(Simulator, IsDeterministic) {
  const host_sim::ProfileReport first = profile(640, 200, cv1_class());
  const host_sim::ProfileReport second = profile(640, 200, cv1_class());
  EXPECT_EQ(host_sim::report_json(first).dump(), host_sim::report_json(second).dump());
}

TEST(Simulator, TraceIsChromeTraceJsonWithOneTrackPerEngine) {
  const host_sim::ProfileReport report = profile(640, 200, cv1_class());
  const nlohmann::json trace = nlohmann::json::parse(host_sim::chrome_trace_json(report));
  ASSERT_TRUE(trace.contains("traceEvents"));
  std::set<std::string> tracks;
  int complete_events = 0;
  double vector_end_us = 0, arm_start_us = 1e30;
  for (const nlohmann::json& event : trace["traceEvents"]) {
    ASSERT_TRUE(event.contains("ph") && event.contains("pid") && event.contains("tid"));
    if (event["ph"] == "M" && event["name"] == "thread_name") tracks.insert(event["args"]["name"].get<std::string>());
    if (event["ph"] == "X") {
      ++complete_events;
      ASSERT_TRUE(event["ts"].is_number() && event["dur"].is_number());
      EXPECT_GT(event["dur"].get<double>(), 0);
      if (event["tid"] == 0) vector_end_us = std::max(vector_end_us, event["ts"].get<double>() + event["dur"].get<double>());
      if (event["tid"].get<int>() >= 2) arm_start_us = std::min(arm_start_us, event["ts"].get<double>());
    }
  }
  EXPECT_TRUE(tracks.count("vector engine") && tracks.count("DMA") && tracks.count("ARM core 0") && tracks.count("ARM core 3"));
  EXPECT_GT(complete_events, 4 * 4);
  // The ARM task runs while the vector engine is still busy (overlap across engines).
  EXPECT_LT(arm_start_us, vector_end_us);
}

TEST(Simulator, ReportsTimeAndBandwidthOverBudget) {
  host_sim::ProfileOptions options;
  options.fps_target = 100000;
  const host_sim::ProfileReport report = profile(640, 360, cv1_class(), options);
  EXPECT_FALSE(report.fits_budget);
  ASSERT_FALSE(report.over_budget.empty());
  EXPECT_NE(report.over_budget[0].find("frame time "), std::string::npos) << report.over_budget[0];
  EXPECT_NE(report.over_budget[0].find("over by "), std::string::npos);
  bool bandwidth = false;
  for (const std::string& line : report.over_budget) bandwidth = bandwidth || line.find("DRAM bandwidth") != std::string::npos;
  EXPECT_TRUE(bandwidth);
  const host_sim::ProfileReport relaxed = profile(640, 360, cv1_class());
  EXPECT_TRUE(relaxed.fits_budget) << (relaxed.over_budget.empty() ? "" : relaxed.over_budget[0]);
}

TEST(Simulator, FrameTimeFollowsTheTargetClock) {
  host_sim::Target slow = cv1_class();
  host_sim::Target fast = cv1_class();
  fast.vector.clock_mhz *= 2;
  fast.dma.bandwidth_gbps *= 2;
  fast.dma.setup_ns /= 2;
  fast.arm.clock_mhz *= 2;
  const double slow_ms = profile(640, 360, slow).frame_ms;
  const double fast_ms = profile(640, 360, fast).frame_ms;
  EXPECT_NEAR(slow_ms / fast_ms, 2.0, 0.02);
}

// The steady state cannot hide a bottleneck. One 160 ms ARM task (the exposure statistics, which
// read only the input) beside a 20 ms vector stage on 4 ARM cores, DMA made free. With K frames in
// flight, frame f enters when frame f - K has left, and each frame takes the task's 160 ms from
// entering to leaving (the task starts on entry: the cores are never all busy, as K <= 4 frames
// hold at most K tasks, or else the cores are the bound). So K frames leave every 160 ms: the period
// is 160 / K ms, and never below the cores' 160 / 4 = 40 ms nor the vector stage's 20 ms:
// max(160 / K, 40) ms. The simulator before frames in flight read 20 ms here.
// (The period is the back-to-back run's; the latency is at the camera's rate, here 10 fps.)
TEST(Simulator, SteadyStateHonoursFramesInFlightAndTheBusiestEngine) {
  host_sim::Target target = cv1_class();
  target.arm.cores = 4;
  target.dma.bandwidth_gbps = 1e6;
  target.dma.setup_ns = 0;
  const host_sim::ProfileReport measured = profile(640, 360, target);
  double vector_ms = 0, arm_ms = 0;
  for (const host_sim::NodeProfile& node : measured.nodes) (node.kind == "vector" ? vector_ms : arm_ms) += node.ms;
  ASSERT_GT(vector_ms, 0);
  ASSERT_GT(arm_ms, 0);
  for (double& cycles : target.vector.op_cycles) cycles *= 20.0 / vector_ms;
  target.vector.tile_overhead_cycles *= 20.0 / vector_ms;
  target.arm.cycles_per_scalar_op *= 160.0 / arm_ms;
  target.arm.cycles_per_dram_byte *= 160.0 / arm_ms;
  for (int frames_in_flight : {1, 2, 3, 4, 8}) {
    host_sim::ProfileOptions options;
    options.frames_in_flight = frames_in_flight;
    options.fps_target = 10;
    const host_sim::ProfileReport report = profile(640, 360, target, options);
    double stage_ms = 0, task_ms = 0;
    for (const host_sim::NodeProfile& node : report.nodes) (node.kind == "vector" ? stage_ms : task_ms) += node.ms;
    EXPECT_NEAR(stage_ms, 20.0, 0.2);
    EXPECT_NEAR(task_ms, 160.0, 1.6);
    const double expected_ms = std::max(160.0 / frames_in_flight, 40.0);
    EXPECT_NEAR(report.frame_ms, expected_ms, 0.02 * expected_ms) << frames_in_flight << " frames in flight";
    EXPECT_GE(report.frame_ms, 40.0 * (1 - 1e-9));
    EXPECT_EQ(report.frames_in_flight, frames_in_flight);
    EXPECT_GE(report.frames_simulated, 4 * frames_in_flight + 4);
    // At the camera's 100 ms a frame enters on arrival (or, K = 1, when the one before has left) and
    // leaves with its task: 160 ms, whatever K.
    EXPECT_NEAR(report.latency_ms, 160.0, 2.0) << frames_in_flight;
    // Loads: the busiest core runs one 160 ms task per 4 frames at most; the vector engine 20 ms a frame.
    ASSERT_FALSE(report.engines.empty());
    EXPECT_EQ(report.engines[0].name, "vector engine");
    EXPECT_NEAR(report.engines[0].busy_ms, 20.0, 0.2);
    EXPECT_NEAR(report.engines[0].load_percent, 100.0 * 20.0 / std::max(expected_ms, 100.0), 1.0);
    double cores_busy_ms = 0;
    for (const host_sim::EngineLoad& engine : report.engines) {
      if (engine.name.rfind("ARM core", 0) == 0) cores_busy_ms += engine.busy_ms;
    }
    EXPECT_NEAR(cores_busy_ms, 160.0, 1.6);
  }
}

TEST(Simulator, LatencyAndInFlightCapacityAreBudgets) {
  host_sim::ProfileOptions options;
  options.max_latency_ms = 1e-3;
  const host_sim::ProfileReport late = profile(640, 360, cv1_class(), options);
  EXPECT_FALSE(late.fits_budget);
  ASSERT_FALSE(late.over_budget.empty());
  EXPECT_EQ(late.over_budget.back().rfind("latency ", 0), 0u) << late.over_budget.back();
  host_sim::Target small = cv1_class();
  const host_sim::ProfileReport one = profile(640, 360, small);
  EXPECT_GT(one.dram_in_flight_bytes, one.dram_peak_bytes);  // more than one frame in flight on cv1-class
  // A DRAM that holds one frame but not every frame in flight.
  small.memory.dram_bytes = one.dram_peak_bytes;
  const host_sim::ProfileReport full = profile(640, 360, small);
  EXPECT_FALSE(full.fits_budget);
  EXPECT_EQ(full.over_budget.back().rfind("DRAM capacity ", 0), 0u) << full.over_budget.back();
}

TEST(TargetMustFail, NumbersNeedTheirReasonAndRange) {
  const std::string base = R"({"name": "t", "vector": {"clock_mhz": CLOCK}})";
  auto message = [&](const std::string& clock) {
    std::string json = base;
    json.replace(json.find("CLOCK"), 5, clock);
    try {
      host_sim::parse_target(json, "t.json");
    } catch (const host_sim::TargetError& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  EXPECT_EQ(message("800"), "t.json: at $.vector.clock_mhz: expected {\"value\": number, \"why\": \"source or reason\"}, got 800");
  EXPECT_EQ(message(R"({"value": 800, "why": ""})"), "t.json: at $.vector.clock_mhz.why: every number needs its source or reason");
  EXPECT_EQ(message(R"({"value": -5, "why": "a good reason"})"),
            "t.json: at $.vector.clock_mhz.value: expected a number in [1, 100000], got -5");
  EXPECT_THROW(host_sim::parse_target("{\"name\": ", "t.json"), host_sim::TargetError);
}

TEST(TargetMustFail, UnknownTargetNameSaysWhereItLooked) {
  try {
    host_sim::load_target("cv9-imaginary");
    FAIL() << "expected TargetError";
  } catch (const host_sim::TargetError& error) {
    EXPECT_EQ(std::string(error.what()).rfind("no target named 'cv9-imaginary' (searched ", 0), 0u) << error.what();
  }
  EXPECT_THROW(host_sim::load_target("/nonexistent/target.json"), host_sim::TargetError);
}

TEST(Targets, ShippedTargetsLoadWithTheirDocumentedNumbers) {
  const host_sim::Target cv1 = cv1_class();
  EXPECT_EQ(cv1.name, "cv1-class");
  const host_sim::Target tda4vm = host_sim::load_target_file(std::string(LPSTEREO_SOURCE_DIR) + "/targets/tda4vm-c7x.json");
  EXPECT_EQ(tda4vm.vector.clock_mhz, 1000);
  EXPECT_EQ(tda4vm.vector.vector_bits, 512);
  EXPECT_EQ(tda4vm.memory.sram_bytes, 512u * 1024u);
  EXPECT_NEAR(tda4vm.memory.dram_bandwidth_gbps, 17.1, 1e-9);
  EXPECT_EQ(tda4vm.arm.cores, 2);
}

// docs/target-numbers.md has one row per number of each shipped target, with the file's value:
// "| `path` | value | kind | reason |", the path without "$." and ".value".
TEST(Targets, EveryNumberHasItsRowInTheDocsWithTheFilesValue) {
  std::ifstream docs(std::string(LPSTEREO_SOURCE_DIR) + "/docs/target-numbers.md");
  ASSERT_TRUE(docs.good());
  std::map<std::string, std::map<std::string, std::string>> rows;  // target -> path -> value
  std::string target, line;
  auto without_spaces = [](std::string text) {
    text.erase(std::remove(text.begin(), text.end(), ' '), text.end());
    return text;
  };
  while (std::getline(docs, line)) {
    if (line.rfind("## ", 0) == 0) target = line.substr(3);
    if (line.rfind("| `", 0) != 0) continue;
    const size_t path_end = line.find("` |", 3);
    const size_t value_end = line.find(" |", path_end + 3);
    ASSERT_NE(value_end, std::string::npos) << line;
    const std::string path = line.substr(3, path_end - 3);
    EXPECT_EQ(rows[target].count(path), 0u) << target << " " << path << " twice";
    rows[target][path] = without_spaces(line.substr(path_end + 3, value_end - path_end - 3));
  }
  for (const char* name : {"cv1-class", "tda4vm-c7x"}) {
    std::ifstream file(std::string(LPSTEREO_SOURCE_DIR) + "/targets/" + name + ".json");
    const nlohmann::json document = nlohmann::json::parse(file);
    size_t numbers = 0;
    std::function<void(const nlohmann::json&, const std::string&)> walk = [&](const nlohmann::json& node, const std::string& path) {
      if (!node.is_object()) return;
      if (node.contains("value") && node.contains("why")) {
        ++numbers;
        ASSERT_TRUE(rows[name].count(path)) << name << ": no row for `" << path << "` in docs/target-numbers.md";
        EXPECT_EQ(rows[name][path], without_spaces(node.at("value").dump())) << name << " " << path;
        return;
      }
      for (const auto& item : node.items()) walk(item.value(), path.empty() ? item.key() : path + "." + item.key());
    };
    walk(document, "");
    EXPECT_EQ(rows[name].size(), numbers) << name << ": rows for numbers the file does not have";
    EXPECT_GT(numbers, 40u) << name;
  }
}

}  // namespace
}  // namespace lpstereo
