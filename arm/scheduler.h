// The ARM-side frame scheduler. Per frame it dispatches vector nodes to the vector engine and runs
// ARM tasks on the ARM cores, in dependency order, honouring delayed edges. One plan drives both
// runs, so they cannot drift apart:
//   - FrameRunner: the native run on the host; worker threads take the tiles of ready vector nodes
//     and the ready ARM tasks, so independent nodes and tiles run in parallel;
//   - host_sim::simulate(): the simulated run on a target, which walks the same plan over a timeline
//     of the target's vector engine, DMA engine and ARM cores.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "dag/arm_task.h"
#include "dag/graph.h"
#include "dag/plane.h"
#include "dag/tile_executor.h"
#include "dag/zeroed_block.h"

namespace lpstereo::arm {

// unit: a kernel node bound to one of the target's fixed-function units; natively it runs tile by
// tile as a vector node does (its kernel is the unit's functional model).
enum class Engine { vector, arm, unit };

struct Dispatch {
  int node = -1;
  Engine engine = Engine::vector;
  std::vector<int> after;                 // dispatches of the same frame that must finish first
  std::vector<int> after_previous_frame;  // dispatches of the previous frame (delayed edges)
  std::vector<TileRect> tiles;            // vector and unit nodes: the output tiles, in DMA order
  bool runs_tiles() const { return engine != Engine::arm; }
};

struct FramePlan {
  std::vector<Dispatch> dispatches;  // in topological order; index = position
};

// The per-frame plan of a verified graph.
FramePlan plan_frame(const Graph& graph);

// A frame input or its shape does not match the graph: names the input, expected and actual.
class FrameInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The worker threads a FrameRunner built with `worker_threads` starts: the value itself when
// positive, else one per hardware thread (at least 1).
int resolved_worker_threads(int worker_threads);

// Runs a verified graph natively, frame after frame. Buffers are allocated once; delayed buffers
// have two slots that alternate each frame.
class FrameRunner {
 public:
  // worker_threads 0 = one per hardware thread. KernelBackend::counting runs the vector nodes on
  // the counting back end (same bits, slower): what `--backend counting` and the golden tests use.
  FrameRunner(const Graph& graph, int worker_threads = 0, KernelBackend backend = KernelBackend::native);
  ~FrameRunner();
  FrameRunner(const FrameRunner&) = delete;
  FrameRunner& operator=(const FrameRunner&) = delete;

  // The memory a FrameRunner of `graph` with `worker_threads` (0 = one per hardware thread) will
  // hold, computed before allocating anything: every non-input buffer (x 2 slots when read delayed),
  // every row state, and each worker's scratch for the largest tile of any vector node, each as
  // dag/zeroed_block.h lays it out. Not in it: the halo staging of tiles at the image's edges (a
  // few rows), the threads' stacks, and what ARM tasks allocate themselves.
  static size_t planned_bytes(const Graph& graph, int worker_threads);

  // Processes one frame. Reads every graph input from `inputs` (by input name) on every call.
  void process(const std::map<std::string, const Plane*>& inputs);

  // The buffer's value after the last process() (delayed buffers: this frame's value).
  const Plane& buffer(const std::string& name) const;
  // ARM work each node counted in the last frame (zero for vector nodes), by node index.
  const std::vector<ArmWork>& arm_work() const { return arm_work_; }
  const FramePlan& plan() const { return plan_; }
  int64_t frames_processed() const { return frame_index_; }

 private:
  struct Pool;
  const Plane& slot(int buffer, int64_t frame) const;
  void enqueue_locked(int dispatch);  // with the pool's mutex held
  void run_dispatch_item(int dispatch, size_t first_tile, size_t tile_count, TileRunner& runner);

  const Graph& graph_;
  KernelBackend backend_;
  FramePlan plan_;
  std::vector<std::vector<Plane>> slots_;  // per buffer: 1 slot, or 2 for delayed buffers
  std::vector<const Plane*> input_planes_;
  std::vector<ArmWork> arm_work_;
  struct NodeState {
    ZeroedBlock block;  // dag/zeroed_block.h: huge-page advised when large
    size_t bytes = 0;
  };
  std::vector<NodeState> node_state_;  // per node: row state of row-state kernels
  int64_t frame_index_ = 0;
  std::unique_ptr<Pool> pool_;
};

}  // namespace lpstereo::arm
