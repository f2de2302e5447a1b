#include "host_sim/target.h"

#include <cmath>
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

// The value of {"value": ..., "why": "source or reason"} at object[key]; `shape` names what the value
// must be in the message for an entry of the wrong form.
const nlohmann::json& reasoned_value(const nlohmann::json& object, const std::string& key, const std::string& source,
                                     const std::string& path, const char* shape) {
  const std::string here = path + "." + key;
  if (!object.is_object() || !object.contains(key)) fail(source, path, "missing key '" + key + "'");
  const nlohmann::json& entry = object.at(key);
  if (!entry.is_object() || !entry.contains("value") || !entry.contains("why")) {
    fail(source, here, std::string("expected {\"value\": ") + shape + ", \"why\": \"source or reason\"}, got " + entry.dump());
  }
  if (!entry.at("why").is_string() || entry.at("why").get<std::string>().size() < 8) {
    fail(source, here + ".why", "every number needs its source or reason");
  }
  return entry.at("value");
}

// Reads {"value": N, "why": "..."} at object[key]; the value must lie in [min_value, max_value].
double number(const nlohmann::json& object, const std::string& key, const std::string& source, const std::string& path,
              double min_value, double max_value) {
  const nlohmann::json& value = reasoned_value(object, key, source, path, "number");
  if (!value.is_number() || value.get<double>() < min_value || value.get<double>() > max_value) {
    std::ostringstream range;
    range << "expected a number in [" << min_value << ", " << max_value << "], got " << value.dump();
    fail(source, path + "." + key + ".value", range.str());
  }
  return value.get<double>();
}

// Reads {"value": [integers], "why": "..."} at object[key]: `count` integers (0: one or more), each in
// [min_value, max_value].
std::vector<int> integer_list(const nlohmann::json& object, const std::string& key, const std::string& source,
                              const std::string& path, size_t count, int min_value, int max_value) {
  const std::string here = path + "." + key;
  const nlohmann::json& value = reasoned_value(object, key, source, path, "[integers]");
  const bool size_ok = value.is_array() && (count == 0 ? !value.empty() : value.size() == count);
  std::vector<int> list;
  for (size_t i = 0; size_ok && i < value.size(); ++i) {
    if (!value[i].is_number_integer() || value[i].get<int64_t>() < min_value || value[i].get<int64_t>() > max_value) break;
    list.push_back(value[i].get<int>());
  }
  if (!size_ok || list.size() != value.size()) {
    std::ostringstream expected;
    expected << "expected " << (count == 0 ? std::string("a list of") : std::to_string(count)) << " integers in ["
             << min_value << ", " << max_value << "], got " << value.dump();
    fail(source, here + ".value", expected.str());
  }
  return list;
}

std::string plain_string(const nlohmann::json& object, const char* key, const std::string& source, const std::string& path) {
  if (!object.contains(key) || !object.at(key).is_string() || object.at(key).get<std::string>().empty()) {
    fail(source, path, std::string("missing string '") + key + "'");
  }
  return object.at(key).get<std::string>();
}

FixedFunctionUnit parse_unit(const std::string& unit_name, const nlohmann::json& entry, const std::string& source) {
  const std::string path = "$.units." + unit_name;
  if (!entry.is_object()) fail(source, path, "expected an object");
  FixedFunctionUnit unit;
  UnitLimits& limits = unit.limits;
  limits.name = unit_name;
  limits.kind = plain_string(entry, "kind", source, path);
  if (limits.kind != "stereo" && limits.kind != "warp" && limits.kind != "scaler") {
    fail(source, path + ".kind", "expected \"stereo\", \"warp\" or \"scaler\", got \"" + limits.kind + "\"");
  }
  if (!entry.contains("functions") || !entry.at("functions").is_array() || entry.at("functions").empty()) {
    fail(source, path, "missing 'functions' (the kernels whose functional model the unit runs)");
  }
  for (const nlohmann::json& function : entry.at("functions")) {
    if (!function.is_string()) fail(source, path + ".functions", "expected kernel names, got " + function.dump());
    limits.functions.push_back(function.get<std::string>());
  }
  if (entry.contains("description") && entry.at("description").is_string()) unit.description = entry.at("description");
  unit.output_format = plain_string(entry, "output_format", source, path);
  unit.clock_mhz = number(entry, "clock_mhz", source, path, 1, 1e5);
  unit.pixels_per_cycle = number(entry, "pixels_per_cycle", source, path, 1e-3, 1e3);
  unit.setup_us = number(entry, "setup_us", source, path, 0, 1e6);
  unit.dram_bytes_per_pixel = number(entry, "dram_bytes_per_pixel", source, path, 0, 1e3);
  limits.max_width = static_cast<int>(number(entry, "max_width", source, path, 1, 65536));
  limits.max_height = static_cast<int>(number(entry, "max_height", source, path, 1, 65536));
  limits.local_memory_bytes = static_cast<size_t>(number(entry, "local_memory_bytes", source, path, 0, 1e12));
  if (limits.kind == "stereo") {
    unit.reference_search_range = static_cast<int>(number(entry, "reference_search_range", source, path, 1, 4096));
    unit.search_range_scaling = number(entry, "search_range_scaling", source, path, 0, 1);
    limits.search_ranges = integer_list(entry, "search_ranges", source, path, 0, 1, 4096);
    const std::vector<int> census = integer_list(entry, "census_window", source, path, 2, 1, 31);
    limits.census_width = census[0];
    limits.census_height = census[1];
    limits.p1_max = static_cast<int>(number(entry, "p1_max", source, path, 0, 65535));
    limits.p2_max = static_cast<int>(number(entry, "p2_max", source, path, 0, 65535));
  }
  return unit;
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
  budget.check_units = true;
  for (const FixedFunctionUnit& unit : units) budget.units.push_back(unit.limits);
  return budget;
}

const FixedFunctionUnit* Target::unit(const std::string& unit_name) const {
  for (const FixedFunctionUnit& candidate : units) {
    if (candidate.limits.name == unit_name) return &candidate;
  }
  return nullptr;
}

double FixedFunctionUnit::busy_ns(double pixels, int search_range) const {
  double cycles = pixels / pixels_per_cycle;
  if (limits.kind == "stereo" && search_range_scaling > 0) {
    cycles *= std::pow(static_cast<double>(search_range) / reference_search_range, search_range_scaling);
  }
  return setup_us * 1e3 + cycles / (clock_mhz * 1e-3);
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
  const nlohmann::json& pipeline = section(document, "pipeline", source);
  target.frames_in_flight = static_cast<int>(number(pipeline, "frames_in_flight", source, "$.pipeline", 1, 16));
  if (document.contains("units")) {
    const nlohmann::json& units = document.at("units");
    if (!units.is_object()) fail(source, "$.units", "expected an object {unit name: unit}");
    for (const auto& item : units.items()) {
      if (item.key() == "vector" || item.key() == "arm" || item.key().empty()) {
        fail(source, "$.units." + item.key(), "a unit name must not be empty nor a default engine's ('vector', 'arm')");
      }
      target.units.push_back(parse_unit(item.key(), item.value(), source));
    }
  }
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
