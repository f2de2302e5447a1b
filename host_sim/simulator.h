// The chip on the host: runs a verified graph's frame plan (arm/scheduler.h) over a timeline of the
// target's vector engine, DMA engine, fixed-function units and ARM cores, and reports what a frame
// costs.
//
// The model (also in docs/simulator.md) is op-level and cycle-approximate, not a netlist:
//   - vector node: tile by tile, DMA in (tile + halo, or the source rectangle of a whole input),
//     compute, DMA out, double-buffered: tile i+1 streams in while tile i computes, and a tile's
//     input slot is free again when the tile two before it has finished computing;
//   - compute cycles of a tile = sum over op classes of counted ops x ceil(512 / vector_bits) x
//     op_cycles[class], plus tile_overhead_cycles; the ops are counted by running the kernel's
//     counting back end on the real tile data (once per distinct tile shape, first row and first
//     column of tiles keyed apart: the kernels are data-oblivious, which a test checks;
//     --count-every-tile counts them all);
//   - DMA time of a transfer = setup_ns + bytes / bandwidth; one DMA engine, requests in order;
//   - unit node (a kernel bound to a fixed-function unit): the whole plane on the unit's own
//     timeline, setup_us + processed pixels / pixels_per_cycle / clock (a stereo unit's time scaled
//     by its search range as its target file says), its DRAM traffic dram_bytes_per_pixel x pixels;
//     a unit's internal stage (outputs read only on the same unit, BufferInfo::unit_local) costs
//     nothing of its own: the unit's rate covers it;
//   - ARM task: counted ArmWork x the target's cycles per unit, on the earliest free ARM core;
//   - frames: at most frames_in_flight of them are in the pipeline: frame f enters no earlier than
//     frame f - frames_in_flight has finished. Each engine serves its requests in plan order. The
//     timeline runs twice: frames offered back to back (the capacity) and frames offered at the
//     camera's rate, 1000 / fps_target ms apart (what a user sees);
//   - steady state: frame_ms is the back-to-back run's mean period between frame completions over
//     the last 2 x frames_in_flight of at least 4 x frames_in_flight + 4 simulated frames, and never
//     less than the busiest engine's time per frame (the ARM tasks' total over the cores), so no
//     bottleneck can hide behind the simulation's start-up; fps = 1000 / frame_ms;
//   - latency_ms and the trace come from the camera-rate run: latency
//     is the longest time from a measured frame's entry into the pipeline to its last output.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "dag/arm_task.h"
#include "dag/graph.h"
#include "host_sim/target.h"
#include "kernels/simd/op_class.h"

namespace lpstereo::host_sim {

struct NodeProfile {
  std::string name;
  std::string kind;         // "vector", "arm" or "unit"
  std::string engine;       // the engine that runs it: "vector engine", "ARM", or the unit's name
  std::string implementation;  // kernel or task name
  int tile_width = 0, tile_height = 0;
  size_t tiles = 0;
  double cycles = 0;        // vector-engine compute cycles, ARM cycles, or unit cycles, per frame
  double dma_ms = 0;        // vector nodes: DMA engine time per frame
  double ms = 0;            // engine time per frame: cycles / clock
  double share = 0;         // ms / frame_ms
  uint64_t dram_bytes = 0;  // DRAM traffic per frame
  size_t sram_peak_bytes = 0;
  simd::OpCounts ops;       // counted vector ops per frame (vector nodes)
  ArmWork arm_work;         // counted ARM work per frame (ARM tasks)
};

// One engine's work per frame in the steady state.
struct EngineLoad {
  std::string name;          // "vector engine", "DMA", "ARM core N", "unit NAME (kind)"
  double busy_ms = 0;        // per frame
  double load_percent = 0;   // busy_ms over the frame period the camera allows: max(frame_ms, 1000 / fps_target)
};

struct TraceEvent {
  std::string name;
  int track = 0;            // index into ProfileReport::tracks
  double start_us = 0;
  double duration_us = 0;
  int frame = 0;
  std::string node;
};

struct ProfileReport {
  std::string graph;
  std::string target;
  std::string isa;          // native ISA used for the frame the counts were taken from
  int width = 0, height = 0;
  double fps_target = 30;
  double frame_ms = 0;
  double latency_ms = 0;
  double max_latency_ms = 0;     // the latency budget; 0 = none
  double fps = 0;
  int frames_in_flight = 0;
  std::string bottleneck;        // the engine with the longest busy time per frame
  // Depth the graph's matchers cover, from the graph's camera (0 when the graph names none): a
  // matcher of disparities [m, m + n) on an output s times narrower than the frame sees from
  // f B / ((m + n - 1) s) (near) to f B / (max(m, 1) s) (far: one pixel of its own disparity),
  // f = frame width / 2 / tan(hfov / 2).
  double disparity_near_m = 0;
  double disparity_far_m = 0;        // the engine with the longest busy time per frame
  bool fits_budget = false;
  bool enforce_budget = true;  // from the graph file
  std::string budget_note;
  std::vector<std::string> over_budget;  // one line per budget exceeded
  size_t sram_budget_bytes = 0, sram_peak_bytes = 0;
  size_t dram_budget_bytes = 0, dram_peak_bytes = 0;
  size_t dram_in_flight_bytes = 0;       // DRAM with every frame in flight: constants once, the rest per frame
  uint64_t dram_bytes_per_frame = 0;
  double dram_bandwidth_gbps = 0;        // demanded at fps_target
  double dram_bandwidth_limit_gbps = 0;
  double vector_cycles_per_frame = 0;
  std::vector<NodeProfile> nodes;
  std::vector<EngineLoad> engines;
  std::vector<std::string> tracks;
  std::vector<TraceEvent> trace;
  int frames_simulated = 0;
};

struct ProfileOptions {
  double fps_target = 30;
  int frames = 4;                 // simulated frames: at least this many, and at least 4 x frames_in_flight + 4
  int frames_in_flight = 0;       // 0 = the target's pipeline setting
  double max_latency_ms = 0;      // latency budget; 0 = none
  bool count_every_tile = false;  // count ops on every tile instead of once per tile shape
  int worker_threads = 0;         // for the native frame the counts come from
};

// Profiles a graph verified against `target`'s memory budget, using `inputs` as the frame.
ProfileReport profile_graph(const Graph& graph, const Target& target, const std::map<std::string, const Plane*>& inputs,
                            const ProfileOptions& options);

}  // namespace lpstereo::host_sim
