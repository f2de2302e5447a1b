#include "host_sim/simulator.h"

#include <algorithm>
#include <cmath>
#include <functional>
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
  double unit_ns = 0;           // unit nodes
  double unit_cycles = 0;
  uint64_t unit_dram_bytes = 0;
  int unit_track = -1;
  simd::OpCounts ops;
};

// Pixels a unit node processes: its largest plane (a scaler reads four input pixels per output).
double unit_pixels(const NodeInfo& node, const std::vector<BufferInfo>& buffers) {
  double pixels = 0;
  for (int b : node.input_buffers) pixels = std::max(pixels, static_cast<double>(buffers[b].shape.width) * buffers[b].shape.height);
  for (int b : node.output_buffers) pixels = std::max(pixels, static_cast<double>(buffers[b].shape.width) * buffers[b].shape.height);
  return pixels;
}

// A unit's internal stage: every output streams inside the unit to a node on the same unit.
bool internal_stage(const NodeInfo& node, const std::vector<BufferInfo>& buffers) {
  return std::all_of(node.output_buffers.begin(), node.output_buffers.end(), [&](int b) { return buffers[b].unit_local; });
}

}  // namespace

ProfileReport profile_graph(const Graph& graph, const Target& target, const std::map<std::string, const Plane*>& inputs,
                            const ProfileOptions& options) {
  if (!graph.verified()) throw std::logic_error("profile_graph: graph '" + graph.spec().name + "' is not verified");

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

  // 2. Costs per node: counted ops per tile (once per tile shape and edge position), DMA bytes per
  // tile; a unit node's time from its unit's rate.
  const int frames_in_flight = options.frames_in_flight > 0 ? options.frames_in_flight : target.frames_in_flight;
  if (frames_in_flight < 1) {
    throw std::invalid_argument("profile_graph: frames in flight: expected >= 1 (target '" + target.name + "' or the options), got " +
                                std::to_string(frames_in_flight));
  }
  const int frames = std::max({3, options.frames, 4 * frames_in_flight + 4});
  std::vector<std::string> unit_tracks;  // unit names, in order of first use
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
    if (dispatch.engine == arm::Engine::unit) {
      const FixedFunctionUnit* unit = target.unit(node.spec.engine);
      if (unit == nullptr) {
        throw std::invalid_argument("profile_graph: node '" + node.spec.name + "' runs on unit '" + node.spec.engine +
                                    "', which target '" + target.name + "' lacks");
      }
      auto track = std::find(unit_tracks.begin(), unit_tracks.end(), unit->limits.name);
      if (track == unit_tracks.end()) track = unit_tracks.insert(unit_tracks.end(), unit->limits.name);
      node_costs.unit_track = static_cast<int>(track - unit_tracks.begin());
      if (internal_stage(node, buffers)) continue;
      const double pixels = unit_pixels(node, buffers);
      // The search range of the unit's job: the node's own, or its matcher's upstream on the unit
      // (a stereo unit's median after its SGM).
      std::function<int(const NodeInfo&)> search_range_of = [&](const NodeInfo& stage) -> int {
        if (stage.spec.params.contains("num_disparities")) return stage.spec.params.at("num_disparities").get<int>();
        for (int input : stage.input_buffers) {
          const int producer = buffers[input].producer_node;
          if (producer >= 0 && graph.nodes()[producer].spec.engine == stage.spec.engine) {
            const int range = search_range_of(graph.nodes()[producer]);
            if (range > 0) return range;
          }
        }
        return 0;
      };
      const int found_range = search_range_of(node);
      const int search_range = found_range > 0 ? found_range : unit->reference_search_range;
      node_costs.unit_ns = unit->busy_ns(pixels, search_range);
      node_costs.unit_cycles = node_costs.unit_ns * unit->clock_mhz * 1e-3;
      node_costs.unit_dram_bytes = static_cast<uint64_t>(std::llround(pixels * unit->dram_bytes_per_pixel));
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

  // 3. The timeline: frames offered back to back, at most frames_in_flight in the pipeline, each
  // engine serving requests in plan order. Tracks: vector engine, DMA, the units, the ARM cores.
  ProfileReport report;
  report.tracks = {"vector engine", "DMA"};
  const int first_unit_track = static_cast<int>(report.tracks.size());
  for (const std::string& unit_name : unit_tracks) {
    report.tracks.push_back("unit " + unit_name + " (" + target.unit(unit_name)->limits.kind + ")");
  }
  const int first_core_track = static_cast<int>(report.tracks.size());
  for (int core = 0; core < target.arm.cores; ++core) report.tracks.push_back("ARM core " + std::to_string(core));
  // One run of the timeline with frame f offered at f x camera_period_ns (0: back to back); it
  // enters the pipeline when offered and when frame f - frames_in_flight has left.
  struct Timeline {
    std::vector<double> entry, end;  // per frame: when it entered the pipeline, when its last dispatch ended
    std::vector<TraceEvent> trace;
  };
  auto run_timeline = [&](double camera_period_ns) {
    Timeline timeline;
    std::vector<TraceEvent>& trace = timeline.trace;
    double vector_free = 0, dma_free = 0;
    std::vector<double> unit_free(unit_tracks.size(), 0.0);
    std::vector<double> core_free(static_cast<size_t>(target.arm.cores), 0.0);
    std::vector<std::vector<double>> dispatch_end(static_cast<size_t>(frames), std::vector<double>(plan.dispatches.size(), 0));
    std::vector<double>& frame_entry = timeline.entry;
    std::vector<double>& frame_end = timeline.end;
    frame_entry.assign(static_cast<size_t>(frames), 0);
    frame_end.assign(static_cast<size_t>(frames), 0);
    for (int frame = 0; frame < frames; ++frame) {
      const double admitted =
          std::max(frame * camera_period_ns, frame >= frames_in_flight ? frame_end[frame - frames_in_flight] : 0.0);
      frame_entry[frame] = admitted;
      for (size_t d = 0; d < plan.dispatches.size(); ++d) {
        const arm::Dispatch& dispatch = plan.dispatches[d];
        const NodeInfo& node = graph.nodes()[dispatch.node];
        double ready = admitted;
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
          trace.push_back({node.spec.name, first_core_track + static_cast<int>(core - core_free.begin()), start * 1e-3,
                           costs[d].arm_ns * 1e-3, frame, node.spec.name});
        } else if (dispatch.engine == arm::Engine::unit) {
          double& free = unit_free[static_cast<size_t>(costs[d].unit_track)];
          const double start = std::max(ready, free);
          end = start + costs[d].unit_ns;
          free = end;
          trace.push_back({node.spec.name, first_unit_track + costs[d].unit_track, start * 1e-3, costs[d].unit_ns * 1e-3, frame,
                           node.spec.name});
        } else {
          const std::vector<TileCost>& tiles = costs[d].tiles;
          std::vector<double> compute_end(tiles.size(), 0);
          auto dma_in = [&](size_t i) {
            // Slot reuse: tile i's input buffer is the one tile i-2 computed from.
            double start = std::max(ready, dma_free);
            if (i >= 2) start = std::max(start, compute_end[i - 2]);
            dma_free = start + tiles[i].dma_in_ns;
            if (tiles[i].dma_in_ns > 0) {
              trace.push_back({node.spec.name + " in", 1, start * 1e-3, tiles[i].dma_in_ns * 1e-3, frame, node.spec.name});
            }
            return dma_free;
          };
          double in_end = tiles.empty() ? ready : dma_in(0);
          for (size_t i = 0; i < tiles.size(); ++i) {
            const double start = std::max(in_end, vector_free);
            compute_end[i] = start + tiles[i].compute_ns;
            vector_free = compute_end[i];
            trace.push_back({node.spec.name, 0, start * 1e-3, tiles[i].compute_ns * 1e-3, frame, node.spec.name});
            if (i + 1 < tiles.size()) in_end = dma_in(i + 1);  // prefetch before this tile's write-back
            const double out_start = std::max(compute_end[i], dma_free);
            dma_free = out_start + tiles[i].dma_out_ns;
            trace.push_back({node.spec.name + " out", 1, out_start * 1e-3, tiles[i].dma_out_ns * 1e-3, frame, node.spec.name});
            end = std::max(end, dma_free);
          }
        }
        dispatch_end[frame][d] = end;
        frame_end[frame] = std::max(frame_end[frame], end);
      }
    }
    return timeline;
  };
  // The capacity: frames back to back, so the period is the pipeline's own. The user's view: frames
  // at the camera's rate (1000 / fps_target ms apart), whose latency and trace the report gives.
  const Timeline back_to_back = run_timeline(0);
  const std::vector<double>& frame_end = back_to_back.end;
  Timeline paced = run_timeline(1e9 / options.fps_target);
  report.trace = std::move(paced.trace);
  // The steady state: the last 2 x frames_in_flight periods (whole turns of the in-flight window).
  const int measured = 2 * frames_in_flight;
  const int first_measured = frames - measured;
  const double measured_period_ns = (frame_end[frames - 1] - frame_end[first_measured - 1]) / measured;
  // Each engine's busy time per frame over the measured frames.
  std::vector<double> busy_ns(report.tracks.size(), 0.0);
  for (const TraceEvent& event : back_to_back.trace) {
    if (event.frame >= first_measured) busy_ns[static_cast<size_t>(event.track)] += event.duration_us * 1e3 / measured;
  }
  // The bound no steady state may beat: the busiest single engine, and the ARM tasks' total over the
  // cores (frames in flight let one task of consecutive frames run on different cores).
  double arm_total_ns = 0;
  for (const NodeCosts& cost : costs) arm_total_ns += cost.arm_ns;
  double bound_ns = arm_total_ns / target.arm.cores;
  report.bottleneck = "ARM cores";
  for (int track = 0; track < first_core_track; ++track) {
    if (busy_ns[static_cast<size_t>(track)] > bound_ns) {
      bound_ns = busy_ns[static_cast<size_t>(track)];
      report.bottleneck = report.tracks[static_cast<size_t>(track)];
    }
  }
  const double period_ns = std::max(measured_period_ns, bound_ns);
  // Latency: from entering the pipeline to the frame's last output, at the camera's rate (a frame
  // the pipeline cannot take yet waits, as a capture ring holds it, and its wait does not count).
  double latency_ns = 0;
  for (int frame = first_measured; frame < frames; ++frame) {
    latency_ns = std::max(latency_ns, paced.end[frame] - paced.entry[frame]);
  }

  // 4. The report.
  report.graph = graph.spec().name;
  report.target = target.name;
  report.isa = std::string(simd::isa_name(simd::active_isa()));
  report.width = graph.options().frame_width;
  report.height = graph.options().frame_height;
  report.fps_target = options.fps_target;
  report.frame_ms = period_ns * 1e-6;
  report.latency_ms = latency_ns * 1e-6;
  report.max_latency_ms = options.max_latency_ms;
  report.fps = report.frame_ms > 0 ? 1000.0 / report.frame_ms : 0;
  report.frames_simulated = frames;
  report.frames_in_flight = frames_in_flight;
  if (graph.spec().camera_baseline_m > 0) {
    const double pi = 3.14159265358979323846;
    const double focal_px = report.width / 2.0 / std::tan(graph.spec().camera_hfov_deg * pi / 360.0);
    const double focal_baseline = focal_px * graph.spec().camera_baseline_m;
    for (const NodeInfo& node : graph.nodes()) {
      if (!node.kernel || !node.spec.params.contains("num_disparities")) continue;
      const double scale = static_cast<double>(report.width) / buffers[node.output_buffers.at(0)].shape.width;
      const int min_disparity = node.spec.params.value("min_disparity", 0);
      const int max_disparity = min_disparity + node.spec.params.at("num_disparities").get<int>() - 1;
      if (max_disparity < 1) continue;
      const double near_m = focal_baseline / (max_disparity * scale);
      const double far_m = focal_baseline / (std::max(min_disparity, 1) * scale);
      report.disparity_near_m = report.disparity_near_m > 0 ? std::min(report.disparity_near_m, near_m) : near_m;
      report.disparity_far_m = std::max(report.disparity_far_m, far_m);
    }
  }
  const double camera_period_ms = std::max(report.frame_ms, 1000.0 / options.fps_target);
  for (size_t track = 0; track < report.tracks.size(); ++track) {
    const double busy_ms = busy_ns[track] * 1e-6;
    report.engines.push_back({report.tracks[track], busy_ms, 100.0 * busy_ms / camera_period_ms});
  }
  report.enforce_budget = graph.spec().enforce_budget;
  report.budget_note = graph.spec().budget_note;
  report.sram_budget_bytes = target.memory.sram_bytes;
  report.sram_peak_bytes = graph.sram_peak_bytes();
  report.dram_budget_bytes = target.memory.dram_bytes;
  report.dram_peak_bytes = graph.dram_peak_bytes();
  // Every frame in flight holds its own buffers; the constants (remap tables) are shared.
  size_t constant_bytes = 0;
  for (const BufferInfo& buffer : buffers) constant_bytes += buffer.is_constant ? buffer.bytes() : 0;
  report.dram_in_flight_bytes = constant_bytes + static_cast<size_t>(frames_in_flight) * (report.dram_peak_bytes - constant_bytes);
  for (size_t d = 0; d < plan.dispatches.size(); ++d) {
    const arm::Dispatch& dispatch = plan.dispatches[d];
    const NodeInfo& node = graph.nodes()[dispatch.node];
    NodeProfile profile;
    profile.name = node.spec.name;
    profile.kind = dispatch.engine == arm::Engine::vector ? "vector" : (dispatch.engine == arm::Engine::unit ? "unit" : "arm");
    profile.engine = dispatch.engine == arm::Engine::vector ? "vector engine" : (dispatch.engine == arm::Engine::unit ? node.spec.engine : "ARM");
    profile.implementation = node.kernel ? node.kernel->name : node.task->name;
    if (dispatch.engine == arm::Engine::unit) {
      profile.tile_width = node.tile_width;
      profile.tile_height = node.tile_height;
      profile.cycles = costs[d].unit_cycles;
      profile.ms = costs[d].unit_ns * 1e-6;
      profile.dram_bytes = costs[d].unit_dram_bytes;
    } else if (dispatch.engine == arm::Engine::vector) {
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
  if (options.max_latency_ms > 0 && report.latency_ms > options.max_latency_ms * (1 + 1e-9)) {
    line.str("");
    line.precision(3);
    line << std::fixed << "latency " << report.latency_ms << " ms > " << options.max_latency_ms << " ms allowed (over by "
         << report.latency_ms - options.max_latency_ms << " ms, " << frames_in_flight << " frames in flight)";
    report.over_budget.push_back(line.str());
  }
  if (report.dram_budget_bytes > 0 && report.dram_in_flight_bytes > report.dram_budget_bytes) {
    line.str("");
    line << "DRAM capacity " << report.dram_in_flight_bytes << " bytes with " << frames_in_flight
         << " frames in flight > " << report.dram_budget_bytes << " bytes on " << target.name << " (over by "
         << report.dram_in_flight_bytes - report.dram_budget_bytes << ")";
    report.over_budget.push_back(line.str());
  }
  report.fits_budget = report.over_budget.empty();
  return report;
}

}  // namespace lpstereo::host_sim
