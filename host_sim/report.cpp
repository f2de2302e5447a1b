#include "host_sim/report.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace lpstereo::host_sim {

namespace {
std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}
std::string mebibytes(double bytes) { return fixed(bytes / (1024.0 * 1024.0), 2) + " MiB"; }
}  // namespace

nlohmann::json report_json(const ProfileReport& report) {
  nlohmann::json json;
  json["graph"] = report.graph;
  json["target"] = report.target;
  json["isa"] = report.isa;
  json["width"] = report.width;
  json["height"] = report.height;
  json["fps_target"] = report.fps_target;
  json["frame_ms"] = report.frame_ms;
  json["latency_ms"] = report.latency_ms;
  json["max_latency_ms"] = report.max_latency_ms;
  json["fps"] = report.fps;
  json["frames_in_flight"] = report.frames_in_flight;
  json["bottleneck"] = report.bottleneck;
  if (report.disparity_far_m > 0) {
    json["disparity_near_m"] = report.disparity_near_m;
    json["disparity_far_m"] = report.disparity_far_m;
  }
  json["fits_budget"] = report.fits_budget;
  json["enforce_budget"] = report.enforce_budget;
  if (!report.budget_note.empty()) json["budget_note"] = report.budget_note;
  json["over_budget"] = report.over_budget;
  json["sram_budget_bytes"] = report.sram_budget_bytes;
  json["sram_peak_bytes"] = report.sram_peak_bytes;
  json["dram_budget_bytes"] = report.dram_budget_bytes;
  json["dram_peak_bytes"] = report.dram_peak_bytes;
  json["dram_in_flight_bytes"] = report.dram_in_flight_bytes;
  json["dram_bytes_per_frame"] = report.dram_bytes_per_frame;
  json["dram_bandwidth_gbps"] = report.dram_bandwidth_gbps;
  json["dram_bandwidth_limit_gbps"] = report.dram_bandwidth_limit_gbps;
  json["vector_cycles_per_frame"] = report.vector_cycles_per_frame;
  json["frames_simulated"] = report.frames_simulated;
  json["engines"] = nlohmann::json::array();
  for (const EngineLoad& engine : report.engines) {
    json["engines"].push_back({{"name", engine.name}, {"busy_ms", engine.busy_ms}, {"load_percent", engine.load_percent}});
  }
  json["nodes"] = nlohmann::json::array();
  for (const NodeProfile& node : report.nodes) {
    nlohmann::json entry;
    entry["name"] = node.name;
    entry["kind"] = node.kind;
    entry["engine"] = node.engine;
    entry["implementation"] = node.implementation;
    entry["cycles"] = node.cycles;
    entry["ms"] = node.ms;
    entry["share"] = node.share;
    entry["dram_bytes"] = node.dram_bytes;
    entry["sram_peak_bytes"] = node.sram_peak_bytes;
    nlohmann::json ops = nlohmann::json::object();
    if (node.kind == "vector") {
      for (int op = 0; op < simd::kOpClassCount; ++op) ops[std::string(simd::kOpClassNames[op])] = node.ops.by_class[op];
      entry["tile_width"] = node.tile_width;
      entry["tile_height"] = node.tile_height;
      entry["tiles"] = node.tiles;
      entry["dma_ms"] = node.dma_ms;
    } else if (node.kind == "unit") {
      entry["tile_width"] = node.tile_width;
      entry["tile_height"] = node.tile_height;
    } else {
      ops["arm_scalar"] = node.arm_work.scalar_ops;
      ops["arm_dram_bytes"] = node.arm_work.memory_bytes;
    }
    entry["ops"] = ops;
    json["nodes"].push_back(entry);
  }
  json["model"] = kModelDescription;
  return json;
}

std::string chrome_trace_json(const ProfileReport& report) {
  // Chrome trace event format: complete events ("ph": "X") in microseconds; one thread per engine.
  nlohmann::json events = nlohmann::json::array();
  events.push_back({{"name", "process_name"}, {"ph", "M"}, {"pid", 1}, {"tid", 0},
                    {"args", {{"name", report.target + " (simulated): " + report.graph}}}});
  for (size_t track = 0; track < report.tracks.size(); ++track) {
    events.push_back({{"name", "thread_name"}, {"ph", "M"}, {"pid", 1}, {"tid", static_cast<int>(track)},
                      {"args", {{"name", report.tracks[track]}}}});
    events.push_back({{"name", "thread_sort_index"}, {"ph", "M"}, {"pid", 1}, {"tid", static_cast<int>(track)},
                      {"args", {{"sort_index", static_cast<int>(track)}}}});
  }
  for (const TraceEvent& event : report.trace) {
    if (event.duration_us <= 0) continue;
    events.push_back({{"name", event.name}, {"cat", event.node}, {"ph", "X"}, {"pid", 1}, {"tid", event.track},
                      {"ts", event.start_us}, {"dur", event.duration_us}, {"args", {{"frame", event.frame}}}});
  }
  nlohmann::json trace = {{"traceEvents", events}, {"displayTimeUnit", "ms"},
                          {"otherData", {{"model", kModelDescription}, {"target", report.target}, {"graph", report.graph}}}};
  return trace.dump() + "\n";
}

std::string report_table(const ProfileReport& report) {
  std::ostringstream out;
  char line[256];
  out << "graph " << report.graph << " on " << report.target << " at " << report.width << "x" << report.height << ", "
      << fixed(report.fps_target, 1) << " fps target (model: " << kModelDescription << ", ops counted on " << report.isa
      << " data)\n";
  std::snprintf(line, sizeof(line), "%-22s %-13s %-16s %14s %9s %9s %7s %12s %12s\n", "node", "engine", "implementation",
                "cycles", "ms", "dma ms", "share", "DRAM bytes", "SRAM bytes");
  out << line;
  for (const NodeProfile& node : report.nodes) {
    std::snprintf(line, sizeof(line), "%-22s %-13s %-16s %14.0f %9.3f %9.3f %6.1f%% %12llu %12zu\n", node.name.c_str(),
                  node.engine.c_str(), node.implementation.c_str(), node.cycles, node.ms, node.dma_ms, 100.0 * node.share,
                  static_cast<unsigned long long>(node.dram_bytes), node.sram_peak_bytes);
    out << line;
  }
  out << "engine loads at " << fixed(std::max(report.frame_ms, 1000.0 / report.fps_target), 3) << " ms a frame:";
  for (const EngineLoad& engine : report.engines) out << " " << engine.name << " " << fixed(engine.load_percent, 1) << "%;";
  out << " bottleneck " << report.bottleneck << "\n";
  if (report.disparity_far_m > 0) {
    out << "disparity covers " << fixed(report.disparity_near_m, 2) << " m to " << fixed(report.disparity_far_m, 1)
        << " m (one pixel of disparity)\n";
  }
  out << "frame " << fixed(report.frame_ms, 3) << " ms (" << fixed(report.fps, 1) << " fps), latency "
      << fixed(report.latency_ms, 3) << " ms with " << report.frames_in_flight << " frames in flight; SRAM peak " << mebibytes(static_cast<double>(report.sram_peak_bytes)) << " of "
      << mebibytes(static_cast<double>(report.sram_budget_bytes)) << "; DRAM peak "
      << mebibytes(static_cast<double>(report.dram_peak_bytes)) << " of "
      << mebibytes(static_cast<double>(report.dram_budget_bytes)) << " (" << mebibytes(static_cast<double>(report.dram_in_flight_bytes))
      << " in flight); DRAM traffic "
      << mebibytes(static_cast<double>(report.dram_bytes_per_frame)) << "/frame = " << fixed(report.dram_bandwidth_gbps, 2)
      << " GB/s of " << fixed(report.dram_bandwidth_limit_gbps, 2) << " GB/s usable\n";
  if (report.fits_budget) {
    out << "fits the budget\n";
  } else {
    for (const std::string& reason : report.over_budget) out << "OVER BUDGET: " << reason << "\n";
  }
  return out.str();
}

std::string report_markdown(const ProfileReport& report) {
  std::ostringstream out;
  const char* verdict = report.fits_budget ? "fits" : (report.enforce_budget ? "**OVER BUDGET**" : "over budget (not enforced)");
  out << "### " << report.graph << " on " << report.target << " at " << report.width << "x" << report.height << ": "
      << verdict << "\n\n";
  out << "| frame ms | fps | target fps | latency ms (frames in flight) | SRAM peak | DRAM in flight | DRAM GB/s (limit) |\n"
         "|---:|---:|---:|---:|---:|---:|---:|\n";
  out << "| " << fixed(report.frame_ms, 3) << " | " << fixed(report.fps, 1) << " | " << fixed(report.fps_target, 1) << " | "
      << fixed(report.latency_ms, 3) << " (" << report.frames_in_flight << ") | "
      << mebibytes(static_cast<double>(report.sram_peak_bytes)) << " / "
      << mebibytes(static_cast<double>(report.sram_budget_bytes)) << " | "
      << mebibytes(static_cast<double>(report.dram_in_flight_bytes)) << " / "
      << mebibytes(static_cast<double>(report.dram_budget_bytes)) << " | " << fixed(report.dram_bandwidth_gbps, 2) << " ("
      << fixed(report.dram_bandwidth_limit_gbps, 2) << ") |\n\n";
  if (report.disparity_far_m > 0) {
    out << "Disparity covers " << fixed(report.disparity_near_m, 2) << " m to " << fixed(report.disparity_far_m, 1)
        << " m (the far limit at one pixel of disparity).\n\n";
  }
  out << "| engine | busy ms a frame | load |\n|---|---:|---:|\n";
  for (const EngineLoad& engine : report.engines) {
    out << "| " << engine.name << (engine.name == report.bottleneck ? " (bottleneck)" : "") << " | "
        << fixed(engine.busy_ms, 3) << " | " << fixed(engine.load_percent, 1) << "% |\n";
  }
  out << "\n";
  out << "| node | engine | implementation | cycles | ms | share | DRAM MiB |\n|---|---|---|---:|---:|---:|---:|\n";
  for (const NodeProfile& node : report.nodes) {
    out << "| " << node.name << " | " << node.engine << " | " << node.implementation << " | " << fixed(node.cycles, 0) << " | "
        << fixed(node.ms, 3) << " | " << fixed(100.0 * node.share, 1) << "% | "
        << fixed(static_cast<double>(node.dram_bytes) / (1024.0 * 1024.0), 2) << " |\n";
  }
  for (const std::string& reason : report.over_budget) out << "\n- over: " << reason;
  if (!report.enforce_budget && !report.budget_note.empty()) out << "\n- not enforced: " << report.budget_note;
  out << "\n\n_Model: " << kModelDescription << "._\n";
  return out.str();
}

}  // namespace lpstereo::host_sim
