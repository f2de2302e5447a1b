#include "host_sim/simulator.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>
#include <sstream>

#include "arm/scheduler.h"
#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "kernels/simd/isa.h"

namespace lpstereo::host_sim {

namespace {

// What one tile of a vector node costs.
struct TileCost {
  double compute_ns = 0;
  double compute_cycles = 0;
  double dma_in_ns = 0;
  double dma_out_ns = 0;
  uint64_t dma_in_bytes = 0;
  uint64_t dma_out_bytes = 0;
};

double compute_cycles(const simd::OpCounts& counts, const Target& target) {
  const double split = std::ceil(static_cast<double>(8 * simd::kCountingVectorBytes) / target.vector.vector_bits);
  double cycles = target.vector.tile_overhead_cycles;
  for (int op = 0; op < simd::kOpClassCount; ++op) {
    cycles += static_cast<double>(counts.by_class[op]) * split * target.vector.op_cycles[op];
  }
  return cycles;
}

double dma_ns(uint64_t bytes, const Target& target) {
  if (bytes == 0) return 0;
  return target.dma.setup_ns + static_cast<double>(bytes) / target.dma.bandwidth_gbps;  // GB/s = bytes/ns
}

// Bytes a tile's DMA brings in: the in-image part of each window input's tile + halo (the border
// fill is generated in SRAM), and the source rectangle of each whole input.
uint64_t tile_input_bytes(const NodeInfo& node, const std::vector<BufferInfo>& buffers, const TileRect& tile) {
  uint64_t bytes = 0;
  int input = 0;
  for (const PortSpec& port : node.kernel->ports) {
    if (port.direction != PortDirection::input) continue;
    const BufferInfo& buffer = buffers[node.input_buffers[input]];
    const uint64_t element_size = static_cast<uint64_t>(element_bytes(port.format.type));
    PixelRect rect;
    if (port.access == PortAccess::whole) {
      rect = {0, 0, buffer.shape.width, buffer.shape.height};
      if (node.kernel->source_rect) {
        rect = node.kernel->source_rect(input, PixelRect{tile.x, tile.y, tile.x + tile.width, tile.y + tile.height},
                                        buffer.shape, node.prepared.params.get());
      }
    } else {
      rect = tile_input_rect(*node.kernel, node.prepared.input_halos, node.prepared.input_scales, input, tile);
    }
    rect.x0 = std::clamp(rect.x0, 0, buffer.shape.width);
    rect.x1 = std::clamp(rect.x1, 0, buffer.shape.width);
    rect.y0 = std::clamp(rect.y0, 0, buffer.shape.height);
    rect.y1 = std::clamp(rect.y1, 0, buffer.shape.height);
    bytes += static_cast<uint64_t>(std::max(0, rect.x1 - rect.x0)) * std::max(0, rect.y1 - rect.y0) * element_size;
    ++input;
  }
  return bytes;
}

uint64_t tile_output_bytes(const NodeInfo& node, const TileRect& tile) {
  uint64_t bytes = 0;
  for (const PortSpec& port : node.kernel->ports) {
    if (port.direction == PortDirection::output) {
      bytes += static_cast<uint64_t>(tile.width) * tile.height * static_cast<uint64_t>(element_bytes(port.format.type));
    }
  }
  return bytes;
}

struct NodeCosts {
  std::vector<TileCost> tiles;  // vector nodes
  double arm_ns = 0;            // ARM tasks
  double arm_cycles = 0;
  simd::OpCounts ops;
};

}  // namespace

ProfileReport profile_graph(const Graph& graph, const Target& target, const std::map<std::string, const Plane*>& inputs,
                            const ProfileOptions& options) {
  if (!graph.verified()) throw std::logic_error("profile_graph: graph '" + graph.spec().name + "' is not verified");
  const int frames = std::max(3, options.frames);

  // 1. One native frame: real data in every buffer, and the ARM tasks' counted work.
  arm::FrameRunner runner(graph, options.worker_threads);
  runner.process(inputs);
  const arm::FramePlan& plan = runner.plan();
  const std::vector<BufferInfo>& buffers = graph.buffers();
  auto plane_of = [&](int buffer) -> const Plane& {
    if (buffers[buffer].is_graph_input) return *inputs.at(buffers[buffer].name);
    if (buffers[buffer].is_constant) return graph.constant_data(buffer);
    return runner.buffer(buffers[buffer].name);
  };

  // 2. Costs per node: counted ops per tile (once per tile shape and edge position), DMA bytes per tile.
  std::vector<NodeCosts> costs(plan.dispatches.size());
  for (size_t d = 0; d < plan.dispatches.size(); ++d) {
    const arm::Dispatch& dispatch = plan.dispatches[d];
    const NodeInfo& node = graph.nodes()[dispatch.node];
    NodeCosts& node_costs = costs[d];
    if (dispatch.engine == arm::Engine::arm) {
      const ArmWork& work = runner.arm_work()[dispatch.node];
      node_costs.arm_cycles = static_cast<double>(work.scalar_ops) * target.arm.cycles_per_scalar_op +
                              static_cast<double>(work.memory_bytes) * target.arm.cycles_per_dram_byte;
      node_costs.arm_ns = node_costs.arm_cycles / (target.arm.clock_mhz * 1e-3);
      continue;
    }
    VectorNodeBinding binding = vector_node_binding(node);
    for (int input : node.input_buffers) binding.inputs.push_back(plane_of(input).view());
    // Counting writes its output into scratch planes, so the native results stay untouched.
    std::vector<Plane> scratch_outputs;
    for (int output : node.output_buffers) {
      scratch_outputs.emplace_back(buffers[output].shape.width, buffers[output].shape.height, buffers[output].format);
      binding.outputs.push_back(scratch_outputs.back().view());
    }
    std::vector<uint8_t> state(row_state_bytes(node, buffers), 0);
    if (!state.empty()) {
      binding.state = state.data();
      binding.state_bytes = state.size();
    }
    TileRunner tile_runner;
    // Tiles of one shape cost the same (data-oblivious kernels); the first row and column of tiles
    // are keyed apart, since a kernel may start its state or its border work there.
    std::map<std::tuple<int, int, bool, bool>, simd::OpCounts> counts_by_shape;
    for (const TileRect& tile : dispatch.tiles) {
      simd::OpCounts tile_counts;
      const auto key = std::make_tuple(tile.width, tile.height, tile.x == 0, tile.y == 0);
      auto cached = counts_by_shape.find(key);
      if (cached != counts_by_shape.end() && !options.count_every_tile) {
        tile_counts = cached->second;
      } else {
        simd::CountingScope scope(tile_counts);
        tile_runner.run(binding, tile, node.kernel->counting);
        counts_by_shape.emplace(key, tile_counts);
      }
      TileCost cost;
      cost.compute_cycles = compute_cycles(tile_counts, target);
      cost.compute_ns = cost.compute_cycles / (target.vector.clock_mhz * 1e-3);
      cost.dma_in_bytes = tile_input_bytes(node, buffers, tile);
      cost.dma_out_bytes = tile_output_bytes(node, tile);
      cost.dma_in_ns = dma_ns(cost.dma_in_bytes, target);
      cost.dma_out_ns = dma_ns(cost.dma_out_bytes, target);
      node_costs.tiles.push_back(cost);
      node_costs.ops += tile_counts;
    }
  }

  // 3. The timeline: frames back to back, each engine serving requests in plan order.
  ProfileReport report;
  report.tracks = {"vector engine", "DMA"};
  for (int core = 0; core < target.arm.cores; ++core) report.tracks.push_back("ARM core " + std::to_string(core));
  double vector_free = 0, dma_free = 0;
  std::vector<double> core_free(static_cast<size_t>(target.arm.cores), 0.0);
  std::vector<std::vector<double>> dispatch_end(static_cast<size_t>(frames), std::vector<double>(plan.dispatches.size(), 0));
  std::vector<double> frame_start(static_cast<size_t>(frames), 0), frame_end(static_cast<size_t>(frames), 0);
  for (int frame = 0; frame < frames; ++frame) {
    bool first_dispatch = true;
    for (size_t d = 0; d < plan.dispatches.size(); ++d) {
      const arm::Dispatch& dispatch = plan.dispatches[d];
      const NodeInfo& node = graph.nodes()[dispatch.node];
      double ready = 0;
      for (int before : dispatch.after) ready = std::max(ready, dispatch_end[frame][before]);
      if (frame > 0) {
        for (int before : dispatch.after_previous_frame) ready = std::max(ready, dispatch_end[frame - 1][before]);
      }
      double end = ready;
      if (dispatch.engine == arm::Engine::arm) {
        auto core = std::min_element(core_free.begin(), core_free.end());
        const double start = std::max(ready, *core);
        end = start + costs[d].arm_ns;
        *core = end;
        report.trace.push_back({node.spec.name, 2 + static_cast<int>(core - core_free.begin()), start * 1e-3,
                                costs[d].arm_ns * 1e-3, frame, node.spec.name});
        if (first_dispatch) frame_start[frame] = start;
      } else {
        const std::vector<TileCost>& tiles = costs[d].tiles;
        std::vector<double> compute_end(tiles.size(), 0);
        auto dma_in = [&](size_t i) {
          // Slot reuse: tile i's input buffer is the one tile i-2 computed from.
          double start = std::max(ready, dma_free);
          if (i >= 2) start = std::max(start, compute_end[i - 2]);
          dma_free = start + tiles[i].dma_in_ns;
          if (tiles[i].dma_in_ns > 0) {
            report.trace.push_back({node.spec.name + " in", 1, start * 1e-3, tiles[i].dma_in_ns * 1e-3, frame, node.spec.name});
          }
          if (first_dispatch && i == 0) frame_start[frame] = start;
          return dma_free;
        };
        double in_end = tiles.empty() ? ready : dma_in(0);
        for (size_t i = 0; i < tiles.size(); ++i) {
          const double start = std::max(in_end, vector_free);
          compute_end[i] = start + tiles[i].compute_ns;
          vector_free = compute_end[i];
          report.trace.push_back({node.spec.name, 0, start * 1e-3, tiles[i].compute_ns * 1e-3, frame, node.spec.name});
          if (i + 1 < tiles.size()) in_end = dma_in(i + 1);  // prefetch before this tile's write-back
          const double out_start = std::max(compute_end[i], dma_free);
          dma_free = out_start + tiles[i].dma_out_ns;
          report.trace.push_back({node.spec.name + " out", 1, out_start * 1e-3, tiles[i].dma_out_ns * 1e-3, frame, node.spec.name});
          end = std::max(end, dma_free);
        }
      }
      dispatch_end[frame][d] = end;
      frame_end[frame] = std::max(frame_end[frame], end);
      first_dispatch = false;
    }
  }
  const double period_ns = (frame_end[frames - 1] - frame_end[0]) / (frames - 1);

  // 4. The report.
  report.graph = graph.spec().name;
  report.target = target.name;
  report.isa = std::string(simd::isa_name(simd::active_isa()));
  report.width = graph.options().frame_width;
  report.height = graph.options().frame_height;
  report.fps_target = options.fps_target;
  report.frame_ms = period_ns * 1e-6;
  report.latency_ms = (frame_end[frames - 1] - frame_start[frames - 1]) * 1e-6;
  report.fps = report.frame_ms > 0 ? 1000.0 / report.frame_ms : 0;
  report.frames_simulated = frames;
  report.enforce_budget = graph.spec().enforce_budget;
  report.budget_note = graph.spec().budget_note;
  report.sram_budget_bytes = target.memory.sram_bytes;
  report.sram_peak_bytes = graph.sram_peak_bytes();
  report.dram_budget_bytes = target.memory.dram_bytes;
  report.dram_peak_bytes = graph.dram_peak_bytes();
  for (size_t d = 0; d < plan.dispatches.size(); ++d) {
    const arm::Dispatch& dispatch = plan.dispatches[d];
    const NodeInfo& node = graph.nodes()[dispatch.node];
    NodeProfile profile;
    profile.name = node.spec.name;
    profile.kind = dispatch.engine == arm::Engine::vector ? "vector" : "arm";
    profile.implementation = node.kernel ? node.kernel->name : node.task->name;
    if (dispatch.engine == arm::Engine::vector) {
      profile.tile_width = node.tile_width;
      profile.tile_height = node.tile_height;
      profile.tiles = dispatch.tiles.size();
      double compute_ns = 0, transfer_ns = 0;
      for (const TileCost& tile : costs[d].tiles) {
        profile.cycles += tile.compute_cycles;
        compute_ns += tile.compute_ns;
        transfer_ns += tile.dma_in_ns + tile.dma_out_ns;
        profile.dram_bytes += tile.dma_in_bytes + tile.dma_out_bytes;
      }
      profile.ms = compute_ns * 1e-6;
      profile.dma_ms = transfer_ns * 1e-6;
      profile.sram_peak_bytes = node.sram_working_set_bytes;
      profile.ops = costs[d].ops;
      report.vector_cycles_per_frame += profile.cycles;
    } else {
      profile.cycles = costs[d].arm_cycles;
      profile.ms = costs[d].arm_ns * 1e-6;
      profile.arm_work = runner.arm_work()[dispatch.node];
      profile.dram_bytes = profile.arm_work.memory_bytes;
    }
    profile.share = report.frame_ms > 0 ? profile.ms / report.frame_ms : 0;
    report.dram_bytes_per_frame += profile.dram_bytes;
    report.nodes.push_back(profile);
  }
  report.dram_bandwidth_gbps = static_cast<double>(report.dram_bytes_per_frame) * options.fps_target * 1e-9;
  report.dram_bandwidth_limit_gbps = target.dram_bandwidth_limit_gbps();
  const double budget_ms = 1000.0 / options.fps_target;
  std::ostringstream line;
  if (report.frame_ms > budget_ms * (1 + 1e-9)) {
    line.str("");
    line.precision(3);
    line << std::fixed << "frame time " << report.frame_ms << " ms > " << budget_ms << " ms budget at " << options.fps_target
         << " fps (over by " << report.frame_ms - budget_ms << " ms, " << report.fps << " fps reached)";
    report.over_budget.push_back(line.str());
  }
  if (report.dram_bandwidth_gbps > report.dram_bandwidth_limit_gbps) {
    line.str("");
    line.precision(3);
    line << std::fixed << "DRAM bandwidth " << report.dram_bandwidth_gbps << " GB/s > " << report.dram_bandwidth_limit_gbps
         << " GB/s usable on " << target.name << " (over by " << report.dram_bandwidth_gbps - report.dram_bandwidth_limit_gbps
         << " GB/s)";
    report.over_budget.push_back(line.str());
  }
  report.fits_budget = report.over_budget.empty();
  return report;
}

}  // namespace lpstereo::host_sim
