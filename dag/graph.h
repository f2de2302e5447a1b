// The processing graph: vector-kernel nodes and ARM tasks wired through typed buffers.
//
// A graph comes from a JSON spec (graphs/*.json, format in docs/graph-format.md) or is built in C++
// as a GraphSpec. verify() runs the named phases of DESIGN.md §2; every error is a VerifyError whose
// message starts with the phase and names node, port, expected and actual:
//   1 "topological order"       a cycle not broken by a delayed edge is an error naming the nodes
//   2 "ports and formats"       unknown kernels/ports, unbound ports, format mismatches; output
//                               shapes and formats propagate to the (virtual) buffers
//   3 "single writer"           one producer per buffer
//   4 "memory placement"        tile schedule per vector node; SRAM working set and DRAM peak
//                               checked against the target's capacity
//   5 "node init"               constants generated (rectification maps); no frame data read
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dag/arm_task.h"
#include "dag/format.h"
#include "dag/plane.h"
#include "dag/tile_executor.h"
#include "kernels/kernel.h"

namespace lpstereo {

// A graph that cannot be built or verified. what() = "<phase>: <details>".
class VerifyError : public std::runtime_error {
 public:
  VerifyError(std::string phase, const std::string& details)
      : std::runtime_error(phase + ": " + details), phase_(std::move(phase)) {}
  const std::string& phase() const { return phase_; }

 private:
  std::string phase_;
};

// Verify phase 4's refusal of a node whose tile working set exceeds the target's SRAM: a kind of
// its own, so that a profile can still report what such a graph would cost.
class SramBudgetError : public VerifyError {
 public:
  using VerifyError::VerifyError;
};

// A malformed graph file: what() = "FILE:LINE:COLUMN: ..." for syntax errors, "FILE: at PATH: ..."
// for a value of the wrong kind.
class GraphSpecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct InputBinding {
  std::string buffer;
  bool delayed = false;  // the consumer sees the value the producer wrote in the previous frame
};

struct NodeSpec {
  std::string name;
  std::string kernel;                               // vector kernel name, or
  std::string task;                                 // ARM task name (exactly one of the two)
  std::map<std::string, InputBinding> inputs;       // port -> buffer
  std::map<std::string, std::string> outputs;       // port -> buffer
  nlohmann::json params = nlohmann::json::object();
  BorderMode border_mode = BorderMode::replicate;
  uint32_t border_value = 0;
  int tile_width = 0;   // schedule; 0 = chosen in phase 4
  int tile_height = 0;
  // Which engine runs the node: empty for the default (a kernel on the vector engine, a task on the
  // ARM cores), or the name of one of the target's fixed-function units (UnitLimits). A unit node
  // names a kernel: on the host it runs that kernel, which is the unit's bit-exact functional model;
  // on a target, verify() checks it against the unit's limits and the simulator times it by the
  // unit's throughput instead of the counted vector ops.
  std::string engine;
};

struct GraphInputSpec {
  std::string name;
  BufferFormat format;
};

// A frame-constant buffer made at init by a named generator (e.g. a rectification map).
struct ConstantSpec {
  std::string name;
  std::string generator;
  nlohmann::json params = nlohmann::json::object();
  // The plane's size when it is not the frame's (0 = the frame size): a remap table whose output
  // differs from its source, e.g. a latitude-longitude rectification to another size.
  int width = 0;
  int height = 0;
};

struct GraphSpec {
  std::string name;
  std::string description;
  std::vector<GraphInputSpec> inputs;
  std::vector<ConstantSpec> constants;
  std::vector<NodeSpec> nodes;
  std::vector<std::string> outputs;
  // false for graphs not meant to fit the 4K budget: profiled and reported, never enforced.
  bool enforce_budget = true;
  std::string budget_note;  // why a graph is not enforced
  // The stereo camera the graph is sized for ("camera" in the file; 0 = not given): the profile
  // turns its matchers' disparity ranges into the near and far limits of the depth they cover.
  double camera_baseline_m = 0;
  double camera_hfov_deg = 0;
};

GraphSpec parse_graph_spec(const std::string& json_text, const std::string& source_name);
GraphSpec load_graph_spec(const std::string& path);

// Constant generators: name -> function(params, frame width, frame height) -> plane.
using ConstantGenerator = std::function<Plane(const nlohmann::json& params, int frame_width, int frame_height)>;
void register_constant_generator(const std::string& name, BufferFormat format, ConstantGenerator generator);

enum class MemoryRegion { dram, sram };

struct BufferInfo {
  std::string name;
  BufferFormat format;
  PlaneShape shape;
  int producer_node = -1;          // -1: graph input or constant
  int producer_port = -1;
  bool is_graph_input = false;
  bool is_constant = false;
  bool is_graph_output = false;
  bool read_delayed = false;       // some consumer reads it one frame late: kept for two frames
  std::vector<int> consumer_nodes;
  MemoryRegion region = MemoryRegion::dram;
  // Produced by a unit node and read only by nodes on the same unit (a stereo unit's census
  // stage): it streams inside the unit and takes no DRAM (set by phase 4 on a target with units).
  bool unit_local = false;
  size_t bytes() const { return static_cast<size_t>(shape.width) * shape.height * element_bytes(format.type); }
};

struct NodeInfo {
  NodeSpec spec;
  const KernelDescriptor* kernel = nullptr;   // vector node
  const ArmTaskDescriptor* task = nullptr;    // ARM task
  PreparedKernel prepared;
  std::vector<int> input_buffers;             // in descriptor port order
  std::vector<bool> input_delayed;
  std::vector<int> output_buffers;            // in descriptor port order
  int tile_width = 0, tile_height = 0;        // phase 4
  size_t sram_working_set_bytes = 0;          // phase 4: double-buffered tiles + scratch
  bool is_vector() const { return kernel != nullptr; }
  bool on_unit() const { return kernel != nullptr && !spec.engine.empty(); }
};

// A fixed-function unit of the target as verify() sees it (host_sim/target.h reads it from the
// target file's "units"): the kernels it runs and the limits a node bound to it must respect.
struct UnitLimits {
  std::string name;                    // the key a node's "engine" names
  std::string kind;                    // "stereo", "warp" or "scaler"
  std::vector<std::string> functions;  // kernels whose bit-exact model the unit runs
  int max_width = 0, max_height = 0;   // of every plane the node reads or writes
  std::vector<int> search_ranges;      // stereo: the num_disparities values it offers
  int census_width = 0, census_height = 0;  // stereo: its census window
  int p1_max = 0, p2_max = 0;          // stereo: largest SGM penalties
  size_t local_memory_bytes = 0;       // on-unit memory, which holds a node's row state
};

// What verify() checks capacity against (from the target; host_sim/target.h fills it).
struct MemoryBudget {
  std::string target_name = "host";
  size_t sram_bytes = 0;        // on-chip memory for vector tiles and scratch; 0 = unlimited
  size_t dram_bytes = 0;        // DRAM available to the graph's buffers; 0 = unlimited
  double sram_tile_share = 0.75;  // share of SRAM a node's double-buffered tiles may take when auto-tiling
  // A target's fixed-function units. With check_units false (the host), a unit node runs its
  // functional model whatever its engine names; with it true, a node naming a unit the target
  // lacks, or beyond the unit's limits, is refused in phase 4.
  bool check_units = false;
  std::vector<UnitLimits> units;
};

struct VerifyOptions {
  int frame_width = 0;     // shape of every graph input
  int frame_height = 0;
  MemoryBudget memory;
};

class Graph {
 public:
  explicit Graph(GraphSpec spec);

  // Runs phases 1-5. Throws VerifyError. May be called again with other options.
  void verify(const VerifyOptions& options);
  bool verified() const { return verified_; }

  const GraphSpec& spec() const { return spec_; }
  const std::vector<NodeInfo>& nodes() const { return nodes_; }
  const std::vector<BufferInfo>& buffers() const { return buffers_; }
  const std::vector<int>& order() const { return order_; }  // node indices, topological
  int buffer_index(const std::string& name) const;          // -1 if none
  const Plane& constant_data(int buffer) const { return constants_.at(buffer); }
  size_t sram_peak_bytes() const { return sram_peak_bytes_; }
  size_t dram_peak_bytes() const { return dram_peak_bytes_; }
  const VerifyOptions& options() const { return options_; }

  // Graphviz DOT, vector nodes and ARM tasks in different colours, delayed edges dashed.
  std::string to_dot() const;

 private:
  void phase_topological_order();
  void phase_ports_and_formats();
  void phase_single_writer();
  void phase_memory_placement();
  void phase_node_init();
  void check_unit_node(const NodeInfo& node) const;  // phase 4: a unit node against its unit's limits

  GraphSpec spec_;
  VerifyOptions options_;
  bool verified_ = false;
  std::vector<NodeInfo> nodes_;
  std::vector<BufferInfo> buffers_;
  std::map<std::string, int> buffer_by_name_;
  std::vector<std::string> extra_writers_;  // "buffer: node.port" for phase 3
  std::vector<int> order_;
  std::map<int, Plane> constants_;
  size_t sram_peak_bytes_ = 0;
  size_t dram_peak_bytes_ = 0;
};

// Why `unit` cannot run `node` (a verified graph's node and buffers): the first limit it breaks,
// naming the limit and the actual value, or "" when the unit can run it. verify() phase 4 refuses
// a node bound to a unit with this text; a caller choosing where a node runs asks it first.
std::string unit_refusal(const UnitLimits& unit, const NodeInfo& node, const std::vector<BufferInfo>& buffers);

// Bytes of row state a vector node keeps across the tiles of a frame (KernelDescriptor::state_bytes
// for its output size); 0 for nodes without row state and for ARM tasks.
size_t row_state_bytes(const NodeInfo& node, const std::vector<BufferInfo>& buffers);

// A vector node's kernel, prepared parameters, border and halos, ready for its planes to be added.
VectorNodeBinding vector_node_binding(const NodeInfo& node);

// SRAM bytes a vector node needs for an output tile of tile_width x tile_height: every window
// input with its halo, every whole input's source rectangle, every output, each double-buffered,
// plus the kernel's scratch and its row state (kept in SRAM for the whole frame).
size_t tile_working_set_bytes(const NodeInfo& node, const std::vector<BufferInfo>& buffers, int tile_width,
                              int tile_height);

// The graph of `spec`, verified for frames of width x height against `memory` (the engines that build
// their graph in C++ and run it at one size: arm::DisparityEngine, arm::ObstacleDetector). Throws
// VerifyError.
std::unique_ptr<Graph> make_verified_graph(GraphSpec spec, int width, int height, const MemoryBudget& memory);

}  // namespace lpstereo
