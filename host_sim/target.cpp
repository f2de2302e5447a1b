#include "host_sim/target.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#ifndef LPSTEREO_SOURCE_DIR
#define LPSTEREO_SOURCE_DIR ""
#endif
#ifndef LPSTEREO_INSTALL_DATA_DIR
#define LPSTEREO_INSTALL_DATA_DIR ""
#endif

namespace lpstereo::host_sim {

namespace {

[[noreturn]] void fail(const std::string& source, const std::string& path, const std::string& what) {
  throw TargetError(source + ": at " + path + ": " + what);
}

// Reads {"value": N, "why": "..."} at object[key]; the value must lie in [min_value, max_value].
double number(const nlohmann::json& object, const std::string& key, const std::string& source, const std::string& path,
              double min_value, double max_value) {
  const std::string here = path + "." + key;
  if (!object.is_object() || !object.contains(key)) fail(source, path, "missing key '" + key + "'");
  const nlohmann::json& entry = object.at(key);
  if (!entry.is_object() || !entry.contains("value") || !entry.contains("why")) {
    fail(source, here, "expected {\"value\": number, \"why\": \"source or reason\"}, got " + entry.dump());
  }
  if (!entry.at("why").is_string() || entry.at("why").get<std::string>().size() < 8) {
    fail(source, here + ".why", "every number needs its source or reason");
  }
  const nlohmann::json& value = entry.at("value");
  if (!value.is_number() || value.get<double>() < min_value || value.get<double>() > max_value) {
    std::ostringstream range;
    range << "expected a number in [" << min_value << ", " << max_value << "], got " << value.dump();
    fail(source, here + ".value", range.str());
  }
  return value.get<double>();
}

const nlohmann::json& section(const nlohmann::json& document, const char* key, const std::string& source) {
  if (!document.contains(key) || !document.at(key).is_object()) fail(source, "$", std::string("missing section '") + key + "'");
  return document.at(key);
}

}  // namespace

MemoryBudget Target::memory_budget() const {
  MemoryBudget budget;
  budget.target_name = name;
  budget.sram_bytes = memory.sram_bytes;
  budget.dram_bytes = memory.dram_bytes;
  budget.sram_tile_share = sram_tile_share;
  return budget;
}

Target parse_target(const std::string& json_text, const std::string& source) {
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::parse_error& error) {
    throw TargetError(source + ": malformed JSON: " + error.what());
  }
  if (!document.is_object()) fail(source, "$", "expected an object");
  Target target;
  if (!document.contains("name") || !document.at("name").is_string()) fail(source, "$", "missing string 'name'");
  target.name = document.at("name").get<std::string>();
  if (document.contains("description") && document.at("description").is_string()) {
    target.description = document.at("description").get<std::string>();
  }
  const nlohmann::json& vector = section(document, "vector", source);
  target.vector.clock_mhz = number(vector, "clock_mhz", source, "$.vector", 1, 1e5);
  target.vector.vector_bits = static_cast<int>(number(vector, "vector_bits", source, "$.vector", 64, 4096));
  if (target.vector.vector_bits % 64 != 0) fail(source, "$.vector.vector_bits", "expected a multiple of 64");
  target.vector.tile_overhead_cycles = number(vector, "tile_overhead_cycles", source, "$.vector", 0, 1e7);
  if (!vector.contains("op_cycles") || !vector.at("op_cycles").is_object()) fail(source, "$.vector", "missing 'op_cycles'");
  for (int op = 0; op < simd::kOpClassCount; ++op) {
    target.vector.op_cycles[op] =
        number(vector.at("op_cycles"), std::string(simd::kOpClassNames[op]), source, "$.vector.op_cycles", 0.01, 1e4);
  }
  const nlohmann::json& dma = section(document, "dma", source);
  target.dma.bandwidth_gbps = number(dma, "bandwidth_gbps", source, "$.dma", 0.01, 1e4);
  target.dma.setup_ns = number(dma, "setup_ns", source, "$.dma", 0, 1e6);
  const nlohmann::json& memory = section(document, "memory", source);
  target.memory.sram_bytes = static_cast<size_t>(number(memory, "sram_bytes", source, "$.memory", 1024, 1e12));
  target.memory.dram_bytes = static_cast<size_t>(number(memory, "dram_graph_bytes", source, "$.memory", 1024, 1e13));
  target.memory.dram_bandwidth_gbps = number(memory, "dram_bandwidth_gbps", source, "$.memory", 0.01, 1e4);
  target.memory.dram_usable_share = number(memory, "dram_usable_share", source, "$.memory", 0.01, 1.0);
  target.sram_tile_share = number(memory, "sram_tile_share", source, "$.memory", 0.05, 1.0);
  const nlohmann::json& arm = section(document, "arm", source);
  target.arm.cores = static_cast<int>(number(arm, "cores", source, "$.arm", 1, 256));
  target.arm.clock_mhz = number(arm, "clock_mhz", source, "$.arm", 1, 1e5);
  target.arm.cycles_per_scalar_op = number(arm, "cycles_per_scalar_op", source, "$.arm", 0.01, 1e3);
  target.arm.cycles_per_dram_byte = number(arm, "cycles_per_dram_byte", source, "$.arm", 0, 1e3);
  return target;
}

Target load_target_file(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw TargetError(path + ": cannot open target file");
  std::ostringstream text;
  text << file.rdbuf();
  return parse_target(text.str(), path);
}

std::vector<std::string> data_directories() {
  std::vector<std::string> directories;
  if (const char* configured = std::getenv("LPSTEREO_DATA_DIR"); configured != nullptr && *configured != '\0') {
    directories.emplace_back(configured);
  }
  if (*LPSTEREO_SOURCE_DIR != '\0') directories.emplace_back(LPSTEREO_SOURCE_DIR);
  if (*LPSTEREO_INSTALL_DATA_DIR != '\0') directories.emplace_back(LPSTEREO_INSTALL_DATA_DIR);
  return directories;
}

std::string find_data_file(const std::string& folder, const std::string& name_or_path) {
  namespace fs = std::filesystem;
  const bool looks_like_path = name_or_path.find('/') != std::string::npos ||
                               (name_or_path.size() > 5 && name_or_path.substr(name_or_path.size() - 5) == ".json");
  if (looks_like_path) return name_or_path;  // the loader reports a missing file with its path
  std::string searched;
  for (const std::string& directory : data_directories()) {
    const fs::path candidate = fs::path(directory) / folder / (name_or_path + ".json");
    std::error_code error;
    if (fs::is_regular_file(candidate, error)) return candidate.string();
    searched += (searched.empty() ? "" : ", ") + (fs::path(directory) / folder).string();
  }
  throw TargetError("no " + folder.substr(0, folder.size() - 1) + " named '" + name_or_path + "' (searched " +
                    (searched.empty() ? std::string("nothing: set LPSTEREO_DATA_DIR") : searched) + ")");
}

Target load_target(const std::string& name_or_path) { return load_target_file(find_data_file("targets", name_or_path)); }

}  // namespace lpstereo::host_sim
