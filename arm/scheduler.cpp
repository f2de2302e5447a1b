#include "arm/scheduler.h"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <set>
#include <thread>

#include "kernels/simd/isa.h"

namespace lpstereo::arm {

FramePlan plan_frame(const Graph& graph) {
  if (!graph.verified()) throw std::logic_error("plan_frame: graph '" + graph.spec().name + "' is not verified");
  FramePlan plan;
  std::vector<int> dispatch_of(graph.nodes().size(), -1);
  for (int node_index : graph.order()) {
    dispatch_of[node_index] = static_cast<int>(plan.dispatches.size());
    const NodeInfo& node = graph.nodes()[node_index];
    const Engine engine = node.on_unit() ? Engine::unit : (node.is_vector() ? Engine::vector : Engine::arm);
    plan.dispatches.push_back(Dispatch{node_index, engine, {}, {}, {}});
  }
  const std::vector<BufferInfo>& buffers = graph.buffers();
  for (Dispatch& dispatch : plan.dispatches) {
    const NodeInfo& node = graph.nodes()[dispatch.node];
    std::set<int> after;
    std::set<int> after_previous;
    for (size_t i = 0; i < node.input_buffers.size(); ++i) {
      const BufferInfo& buffer = buffers[node.input_buffers[i]];
      if (buffer.producer_node < 0) continue;
      if (node.input_delayed[i]) {
        after_previous.insert(dispatch_of[buffer.producer_node]);  // last frame's value must exist
      } else {
        after.insert(dispatch_of[buffer.producer_node]);
      }
    }
    // A producer of a delayed buffer overwrites the slot its consumers read one frame earlier.
    for (int output : node.output_buffers) {
      const BufferInfo& buffer = buffers[output];
      if (!buffer.read_delayed) continue;
      for (int consumer : buffer.consumer_nodes) {
        if (consumer != dispatch.node) after_previous.insert(dispatch_of[consumer]);
      }
    }
    dispatch.after.assign(after.begin(), after.end());
    dispatch.after_previous_frame.assign(after_previous.begin(), after_previous.end());
    if (node.is_vector()) {
      const PlaneShape output = buffers[node.output_buffers.at(0)].shape;
      dispatch.tiles = make_tiles(output.width, output.height, node.tile_width, node.tile_height);
      if (node.kernel->state_bytes && node.kernel->rows_bottom_up) std::reverse(dispatch.tiles.begin(), dispatch.tiles.end());
    }
  }
  return plan;
}

// A fixed set of worker threads running work items of the current frame.
struct FrameRunner::Pool {
  struct Item {
    int dispatch;
    size_t first_tile;
    size_t tile_count;
  };
  std::mutex mutex;
  std::condition_variable work_ready;
  std::condition_variable frame_done;
  std::deque<Item> queue;
  std::vector<int> items_left;        // per dispatch: items not finished
  std::vector<int> dependencies_left; // per dispatch: same-frame dispatches not finished
  int dispatches_left = 0;
  bool stopping = false;
  std::exception_ptr error;
  std::vector<std::thread> threads;
};

int resolved_worker_threads(int worker_threads) {
  return worker_threads > 0 ? worker_threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

FrameRunner::FrameRunner(const Graph& graph, int worker_threads, KernelBackend backend)
    : graph_(graph), backend_(backend), plan_(plan_frame(graph)) {
  const std::vector<BufferInfo>& buffers = graph.buffers();
  slots_.resize(buffers.size());
  input_planes_.assign(buffers.size(), nullptr);
  for (size_t b = 0; b < buffers.size(); ++b) {
    const BufferInfo& buffer = buffers[b];
    if (buffer.is_graph_input || buffer.is_constant) continue;
    const int slot_count = buffer.read_delayed ? 2 : 1;
    for (int s = 0; s < slot_count; ++s) slots_[b].emplace_back(buffer.shape.width, buffer.shape.height, buffer.format);
  }
  arm_work_.assign(graph.nodes().size(), ArmWork{});
  node_state_.resize(graph.nodes().size());
  for (size_t n = 0; n < graph.nodes().size(); ++n) {
    const size_t bytes = row_state_bytes(graph.nodes()[n], buffers);
    if (bytes > 0) node_state_[n] = NodeState{ZeroedBlock(bytes), bytes};
  }
  worker_threads = resolved_worker_threads(worker_threads);
  pool_ = std::make_unique<Pool>();
  for (int t = 0; t < worker_threads; ++t) {
    pool_->threads.emplace_back([this] {
      TileRunner runner;
      std::unique_lock<std::mutex> lock(pool_->mutex);
      for (;;) {
        pool_->work_ready.wait(lock, [this] { return pool_->stopping || !pool_->queue.empty(); });
        if (pool_->stopping) return;
        const Pool::Item item = pool_->queue.front();
        pool_->queue.pop_front();
        lock.unlock();
        try {
          run_dispatch_item(item.dispatch, item.first_tile, item.tile_count, runner);
        } catch (...) {
          lock.lock();
          if (!pool_->error) pool_->error = std::current_exception();
          lock.unlock();
        }
        lock.lock();
        if (--pool_->items_left[item.dispatch] > 0) continue;
        // The dispatch is done: release the ones waiting for it.
        --pool_->dispatches_left;
        for (size_t d = 0; d < plan_.dispatches.size(); ++d) {
          const std::vector<int>& after = plan_.dispatches[d].after;
          if (std::find(after.begin(), after.end(), item.dispatch) == after.end()) continue;
          if (--pool_->dependencies_left[d] == 0) enqueue_locked(static_cast<int>(d));
        }
        if (pool_->dispatches_left == 0) pool_->frame_done.notify_all();
        pool_->work_ready.notify_all();
      }
    });
  }
}

size_t FrameRunner::planned_bytes(const Graph& graph, int worker_threads) {
  const std::vector<BufferInfo>& buffers = graph.buffers();
  size_t total = 0;
  for (const BufferInfo& buffer : buffers) {
    if (buffer.is_graph_input || buffer.is_constant) continue;
    const size_t row_bytes = static_cast<size_t>(buffer.shape.width) * static_cast<size_t>(element_bytes(buffer.format.type));
    const size_t plane_bytes = (row_bytes + 63) / 64 * 64 * static_cast<size_t>(buffer.shape.height);  // Plane's stride
    total += (buffer.read_delayed ? 2 : 1) * zeroed_block_footprint(plane_bytes);
  }
  size_t largest_scratch = 0;
  for (const NodeInfo& node : graph.nodes()) {
    total += zeroed_block_footprint(row_state_bytes(node, buffers));
    if (node.is_vector() && node.kernel->scratch_bytes) {
      largest_scratch = std::max(largest_scratch,
                                 node.kernel->scratch_bytes(node.tile_width, node.tile_height, node.prepared.params.get()));
    }
  }
  return total + static_cast<size_t>(resolved_worker_threads(worker_threads)) * zeroed_block_footprint(largest_scratch);
}

void FrameRunner::enqueue_locked(int dispatch_index) {
  const Dispatch& dispatch = plan_.dispatches[dispatch_index];
  const size_t tiles = dispatch.runs_tiles() ? dispatch.tiles.size() : 1;
  // Vector nodes go out in chunks of tiles, so every worker gets a share of a large node; a
  // row-state node goes out whole, so one worker runs its tiles top to bottom.
  const bool row_state = dispatch.runs_tiles() && graph_.nodes()[dispatch.node].kernel->state_bytes;
  const size_t chunk = row_state ? tiles : std::max<size_t>(1, tiles / (4 * pool_->threads.size()));
  int items = 0;
  for (size_t first = 0; first < tiles; first += chunk) {
    pool_->queue.push_back({dispatch_index, first, std::min(chunk, tiles - first)});
    ++items;
  }
  pool_->items_left[dispatch_index] = items;
}

FrameRunner::~FrameRunner() {
  {
    std::lock_guard<std::mutex> lock(pool_->mutex);
    pool_->stopping = true;
  }
  pool_->work_ready.notify_all();
  for (std::thread& thread : pool_->threads) thread.join();
}

const Plane& FrameRunner::slot(int buffer, int64_t frame) const {
  const BufferInfo& info = graph_.buffers()[buffer];
  if (info.is_graph_input) return *input_planes_[buffer];
  if (info.is_constant) return graph_.constant_data(buffer);
  const std::vector<Plane>& slots = slots_[buffer];
  // Frame -1 (the delayed read of the first frame) is slot 1 of 2: zeros, as allocated.
  const int64_t count = static_cast<int64_t>(slots.size());
  return slots[static_cast<size_t>(((frame % count) + count) % count)];
}

void FrameRunner::run_dispatch_item(int dispatch_index, size_t first_tile, size_t tile_count, TileRunner& runner) {
  const Dispatch& dispatch = plan_.dispatches[dispatch_index];
  const NodeInfo& node = graph_.nodes()[dispatch.node];
  auto input_plane = [&](size_t i) -> const Plane& {
    // A delayed input reads the slot written one frame earlier.
    return slot(node.input_buffers[i], node.input_delayed[i] ? frame_index_ - 1 : frame_index_);
  };
  if (dispatch.runs_tiles()) {
    VectorNodeBinding binding = vector_node_binding(node);
    for (size_t i = 0; i < node.input_buffers.size(); ++i) binding.inputs.push_back(input_plane(i).view());
    for (int output : node.output_buffers) binding.outputs.push_back(slot(output, frame_index_).view());
    NodeState& state = node_state_[dispatch.node];
    if (state.bytes > 0) {
      if (first_tile == 0) std::fill(state.block.get(), state.block.get() + state.bytes, uint8_t{0});  // a new frame
      binding.state = state.block.get();
      binding.state_bytes = state.bytes;
    }
    const TileFunction function =
        backend_ == KernelBackend::counting ? node.kernel->counting : node.kernel->native_for(simd::active_isa());
    for (size_t t = first_tile; t < first_tile + tile_count; ++t) runner.run(binding, dispatch.tiles[t], function);
    return;
  }
  ArmTaskArgs args;
  for (size_t i = 0; i < node.input_buffers.size(); ++i) args.inputs.push_back(&input_plane(i));
  for (int output : node.output_buffers) args.outputs.push_back(const_cast<Plane*>(&slot(output, frame_index_)));
  args.params = node.prepared.params.get();
  ArmWork work;
  args.work = &work;
  node.task->run(args);
  arm_work_[dispatch.node] = work;
}

void FrameRunner::process(const std::map<std::string, const Plane*>& inputs) {
  const std::vector<BufferInfo>& buffers = graph_.buffers();
  for (const GraphInputSpec& input : graph_.spec().inputs) {
    auto found = inputs.find(input.name);
    if (found == inputs.end() || found->second == nullptr || found->second->empty()) {
      throw FrameInputError("graph '" + graph_.spec().name + "' input '" + input.name + "': missing");
    }
    const int index = graph_.buffer_index(input.name);
    const Plane& plane = *found->second;
    const BufferInfo& info = buffers[index];
    if (!(plane.format() == info.format) || plane.width() != info.shape.width || plane.height() != info.shape.height) {
      throw FrameInputError("graph '" + graph_.spec().name + "' input '" + input.name + "': expected " +
                            std::to_string(info.shape.width) + "x" + std::to_string(info.shape.height) + " " +
                            format_name(info.format) + ", got " + std::to_string(plane.width()) + "x" +
                            std::to_string(plane.height()) + " " + format_name(plane.format()));
    }
    input_planes_[index] = &plane;
  }
  for (const auto& [name, plane] : inputs) {
    const int index = graph_.buffer_index(name);
    if (index < 0 || !buffers[index].is_graph_input) {
      throw FrameInputError("graph '" + graph_.spec().name + "': '" + name + "' is not an input of the graph");
    }
  }
  std::unique_lock<std::mutex> lock(pool_->mutex);
  const size_t count = plan_.dispatches.size();
  pool_->items_left.assign(count, 0);
  pool_->dependencies_left.assign(count, 0);
  pool_->dispatches_left = static_cast<int>(count);
  pool_->error = nullptr;
  // Dispatches of the previous frame have all finished (process() is synchronous), so only
  // same-frame dependencies gate the start.
  for (size_t d = 0; d < count; ++d) pool_->dependencies_left[d] = static_cast<int>(plan_.dispatches[d].after.size());
  for (size_t d = 0; d < count; ++d) {
    if (pool_->dependencies_left[d] == 0) enqueue_locked(static_cast<int>(d));
  }
  pool_->work_ready.notify_all();
  pool_->frame_done.wait(lock, [this] { return pool_->dispatches_left == 0; });
  std::exception_ptr error = pool_->error;
  lock.unlock();
  ++frame_index_;
  if (error) std::rethrow_exception(error);
}

const Plane& FrameRunner::buffer(const std::string& name) const {
  const int index = graph_.buffer_index(name);
  if (index < 0) throw std::invalid_argument("graph '" + graph_.spec().name + "': no buffer '" + name + "'");
  return slot(index, frame_index_ - 1);
}

}  // namespace lpstereo::arm
