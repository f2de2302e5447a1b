// Runs a vector kernel tile by tile on the host, the way the chip's DMA feeds it: each window input
// arrives as the tile plus the kernel's halo, with pixels outside the image filled by the border
// mode; the kernel writes its output tile in place. The scheduler (arm/) and the simulator
// (host_sim/) both go through here, so native and simulated runs cannot drift apart.
#pragma once

#include <vector>

#include "dag/plane.h"
#include "dag/zeroed_block.h"
#include "kernels/kernel.h"
#include "kernels/simd/op_class.h"

namespace lpstereo {

struct TileRect {
  int x = 0, y = 0, width = 0, height = 0;
  bool operator==(const TileRect&) const = default;
};

// Cuts a width x height plane into tiles of at most tile_width x tile_height, row-major.
std::vector<TileRect> make_tiles(int width, int height, int tile_width, int tile_height);

// One vector node bound to its planes.
struct VectorNodeBinding {
  const KernelDescriptor* kernel = nullptr;
  const void* params = nullptr;
  BorderMode border_mode = BorderMode::replicate;
  uint32_t border_value = 0;
  std::vector<PlaneView> inputs;   // full planes, in port order
  std::vector<PlaneView> outputs;  // full planes, in port order
  std::vector<Halo> input_halos;   // per input (PreparedKernel::input_halos); empty = kernel->halo
  std::vector<InputScale> input_scales;  // per input (PreparedKernel::input_scales); empty = 1/1
  uint8_t* state = nullptr;        // row-state kernels: the frame's state (KernelDescriptor::state_bytes)
  size_t state_bytes = 0;
};

// The halo of window input `input`: the prepared per-input halo if given, else the kernel's.
inline const Halo& input_halo(const KernelDescriptor& kernel, const std::vector<Halo>& input_halos, int input) {
  return input_halos.empty() ? kernel.halo : input_halos.at(static_cast<size_t>(input));
}

// The rectangle of window input `input` (halo included, not clipped) an output tile reads: the one
// place the executor, verify's working set and the simulator's DMA take it from.
PixelRect tile_input_rect(const KernelDescriptor& kernel, const std::vector<Halo>& input_halos,
                          const std::vector<InputScale>& input_scales, int input, const TileRect& tile);

// Per-worker state: halo staging buffers and scratch, reused from tile to tile.
class TileRunner {
 public:
  void run(const VectorNodeBinding& binding, const TileRect& tile, TileFunction function);

 private:
  std::vector<std::vector<uint8_t>> staging_;
  GrowingBlock scratch_;  // huge-page advised when large (sgm_8path_bands: a band of sums)
};

enum class KernelBackend { native, counting };

// Runs every tile in order on the calling thread (a row-state kernel: full-width tiles, whatever
// tile_width says, with zeroed state unless the binding brings its own). With KernelBackend::counting, adds the counted
// ops to *counts (if given). The native back end runs at the given ISA level.
void run_vector_node(const VectorNodeBinding& binding, int tile_width, int tile_height, KernelBackend backend,
                     simd::Isa isa, simd::OpCounts* counts = nullptr);

}  // namespace lpstereo
