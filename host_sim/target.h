// A simulated target, read from targets/<name>.json. Every number in the file is an object
// {"value": N, "why": "source or reason"}; the loader refuses a number without its reason.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "dag/graph.h"
#include "kernels/simd/op_class.h"

namespace lpstereo::host_sim {

struct VectorEngine {
  double clock_mhz = 0;
  int vector_bits = 0;                               // width of one vector op on the target
  std::array<double, simd::kOpClassCount> op_cycles{};  // reciprocal throughput of one target-width op, by class
  double tile_overhead_cycles = 0;                   // per tile: loop set-up, descriptor programming
};

struct DmaEngine {
  double bandwidth_gbps = 0;   // sustained DRAM <-> SRAM copy rate, GB/s (1e9 bytes/s)
  double setup_ns = 0;         // per transfer (one tile in, or one tile out)
};

struct Memory {
  size_t sram_bytes = 0;          // on-chip memory for vector tiles and scratch
  size_t dram_bytes = 0;          // DRAM the graphs may use (after OS, codecs, frame capture)
  double dram_bandwidth_gbps = 0; // peak
  double dram_usable_share = 0;   // share of peak a frame's traffic may take
};

struct ArmCores {
  int cores = 0;
  double clock_mhz = 0;
  double cycles_per_scalar_op = 0;  // average CPI of task code
  double cycles_per_dram_byte = 0;  // cost of a byte streamed from DRAM by a core
};

// A fixed-function unit (stereo engine, warp engine, scaler): its limits as verify() checks them,
// and its rate and DRAM traffic as the simulator times them. Nodes bound to it (NodeSpec::engine)
// run its functions, the project's own kernels, as its bit-exact functional model.
struct FixedFunctionUnit {
  UnitLimits limits;               // name, kind, functions, sizes, search ranges, census, penalties, local memory
  std::string description;
  std::string output_format;       // what the unit writes, as its documents say
  double clock_mhz = 0;
  double pixels_per_cycle = 0;     // processed pixels per unit clock (at reference_search_range)
  double setup_us = 0;             // per node and frame: programming the unit
  double dram_bytes_per_pixel = 0; // DRAM traffic per processed pixel (a stereo unit: both views in, disparity out)
  int reference_search_range = 0;  // stereo: the range pixels_per_cycle is given for
  double search_range_scaling = 0; // stereo: 0 = rate independent of the range, 1 = time proportional to it

  // Unit time for `pixels` processed pixels at `search_range` (ignored but for stereo units), in ns.
  double busy_ns(double pixels, int search_range) const;
};

struct Target {
  std::string name;
  std::string description;
  VectorEngine vector;
  DmaEngine dma;
  Memory memory;
  ArmCores arm;
  double sram_tile_share = 0.75;  // auto-tiling keeps a node's double-buffered tiles under this share of SRAM
  std::vector<FixedFunctionUnit> units;
  // Frames the pipeline holds at once (capture to last output): frame f starts no earlier than
  // frame f - frames_in_flight has finished ("pipeline" section).
  int frames_in_flight = 0;

  const FixedFunctionUnit* unit(const std::string& unit_name) const;  // nullptr if the target lacks it

  MemoryBudget memory_budget() const;
  double dram_bandwidth_limit_gbps() const { return memory.dram_bandwidth_gbps * memory.dram_usable_share; }
};

// A target file that is missing, malformed or lacks a value or its reason.
class TargetError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

Target parse_target(const std::string& json_text, const std::string& source_name);
Target load_target_file(const std::string& path);
// NAME (looked up as targets/NAME.json in the search directories) or a path to a .json file.
Target load_target(const std::string& name_or_path);
// Directories searched for targets/ and graphs/: LPSTEREO_DATA_DIR, the source tree the binary was
// built from, and the install prefix.
std::vector<std::string> data_directories();
// NAME or path -> the file path of a graph (graphs/NAME.json) or target; throws if not found.
std::string find_data_file(const std::string& folder, const std::string& name_or_path);

}  // namespace lpstereo::host_sim
