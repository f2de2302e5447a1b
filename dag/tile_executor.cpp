#include "dag/tile_executor.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#include "kernels/simd/emulated.h"

namespace lpstereo {

std::vector<TileRect> make_tiles(int width, int height, int tile_width, int tile_height) {
  if (tile_width <= 0 || tile_height <= 0) {
    throw std::invalid_argument("tile size: expected > 0, got " + std::to_string(tile_width) + "x" +
                                std::to_string(tile_height));
  }
  std::vector<TileRect> tiles;
  for (int y = 0; y < height; y += tile_height) {
    for (int x = 0; x < width; x += tile_width) {
      tiles.push_back({x, y, std::min(tile_width, width - x), std::min(tile_height, height - y)});
    }
  }
  return tiles;
}

PixelRect tile_input_rect(const KernelDescriptor& kernel, const std::vector<Halo>& input_halos,
                          const std::vector<InputScale>& input_scales, int input, const TileRect& tile) {
  const InputScale scale = input_scales.empty() ? InputScale{} : input_scales.at(static_cast<size_t>(input));
  return window_input_rect(input_halo(kernel, input_halos, input), scale, tile.x, tile.y, tile.width, tile.height);
}

namespace {

// Copies rectangle [x0, x0 + width) x [y0, y0 + height) of `source` into `destination` (row pitch
// width * element_size), filling outside pixels per the border mode.
void stage_with_border(const PlaneView& source, int element_size, int x0, int y0, int width, int height,
                       BorderMode border_mode, uint32_t border_value, uint8_t* destination) {
  uint8_t constant[8] = {};
  for (int byte = 0; byte < element_size && byte < 4; ++byte) constant[byte] = static_cast<uint8_t>(border_value >> (8 * byte));
  const size_t row_bytes = static_cast<size_t>(width) * element_size;
  for (int row = 0; row < height; ++row) {
    uint8_t* out = destination + row * row_bytes;
    int source_y = y0 + row;
    const bool row_outside = source_y < 0 || source_y >= source.height;
    if (row_outside && border_mode == BorderMode::constant) {
      for (int column = 0; column < width; ++column) std::memcpy(out + column * element_size, constant, element_size);
      continue;
    }
    source_y = std::clamp(source_y, 0, source.height - 1);
    const uint8_t* in = source.origin + static_cast<ptrdiff_t>(source_y) * source.stride_bytes;
    // Inside columns in one copy, outside columns one element at a time.
    const int inside_begin = std::clamp(-x0, 0, width);
    const int inside_end = std::clamp(source.width - x0, 0, width);
    if (inside_end > inside_begin) {
      std::memcpy(out + inside_begin * element_size, in + static_cast<ptrdiff_t>(x0 + inside_begin) * element_size,
                  static_cast<size_t>(inside_end - inside_begin) * element_size);
    }
    for (int column = 0; column < width; ++column) {
      if (column >= inside_begin && column < inside_end) continue;
      const uint8_t* value = constant;
      if (border_mode == BorderMode::replicate) {
        const int source_x = std::clamp(x0 + column, 0, source.width - 1);
        value = in + static_cast<ptrdiff_t>(source_x) * element_size;
      }
      std::memcpy(out + column * element_size, value, element_size);
    }
  }
}

}  // namespace

void TileRunner::run(const VectorNodeBinding& binding, const TileRect& tile, TileFunction function) {
  const KernelDescriptor& kernel = *binding.kernel;
  TileArgs args;
  args.params = binding.params;
  args.tile_x = tile.x;
  args.tile_y = tile.y;
  args.border_mode = binding.border_mode;
  args.border_value = binding.border_value;
  args.image_width = binding.outputs.empty() ? 0 : binding.outputs[0].width;
  args.image_height = binding.outputs.empty() ? 0 : binding.outputs[0].height;

  int input_index = 0;
  int output_index = 0;
  if (staging_.size() < binding.inputs.size()) staging_.resize(binding.inputs.size());
  for (const PortSpec& port : kernel.ports) {
    const int element_size = element_bytes(port.format.type);
    if (port.direction == PortDirection::output) {
      const PlaneView& plane = binding.outputs[output_index];
      args.outputs[output_index++] = PlaneView{
          plane.origin + static_cast<ptrdiff_t>(tile.y) * plane.stride_bytes + static_cast<ptrdiff_t>(tile.x) * element_size,
          plane.stride_bytes, tile.width, tile.height};
      continue;
    }
    const PlaneView& plane = binding.inputs[input_index];
    if (port.access == PortAccess::whole) {
      args.inputs[input_index++] = plane;
      continue;
    }
    const Halo& halo = input_halo(kernel, binding.input_halos, input_index);
    const PixelRect rect = tile_input_rect(kernel, binding.input_halos, binding.input_scales, input_index, tile);
    const int x0 = rect.x0;
    const int y0 = rect.y0;
    const int staged_width = rect.x1 - rect.x0;
    const int staged_height = rect.y1 - rect.y0;
    // The input tile itself (halo excluded), in input coordinates.
    const int input_x = x0 + halo.left;
    const int input_y = y0 + halo.top;
    const int input_width = staged_width - halo.left - halo.right;
    const int input_height = staged_height - halo.top - halo.bottom;
    const bool inside = x0 >= 0 && y0 >= 0 && x0 + staged_width <= plane.width && y0 + staged_height <= plane.height;
    if (inside) {
      // The halo exists in the image: read it in place, as a DMA of the same rectangle would.
      args.inputs[input_index] = PlaneView{
          plane.origin + static_cast<ptrdiff_t>(input_y) * plane.stride_bytes + static_cast<ptrdiff_t>(input_x) * element_size,
          plane.stride_bytes, input_width, input_height};
    } else {
      std::vector<uint8_t>& staging = staging_[input_index];
      const size_t pitch = static_cast<size_t>(staged_width) * element_size;
      staging.resize(pitch * staged_height);
      stage_with_border(plane, element_size, x0, y0, staged_width, staged_height, binding.border_mode,
                        binding.border_value, staging.data());
      args.inputs[input_index] = PlaneView{staging.data() + halo.top * pitch + static_cast<size_t>(halo.left) * element_size,
                                           static_cast<ptrdiff_t>(pitch), input_width, input_height};
    }
    ++input_index;
  }
  args.input_count = input_index;
  args.output_count = output_index;

  const size_t scratch_bytes = kernel.scratch_bytes ? kernel.scratch_bytes(tile.width, tile.height, binding.params) : 0;
  scratch_.reserve(scratch_bytes);
  args.scratch = scratch_bytes > 0 ? scratch_.data() : nullptr;
  args.scratch_bytes = scratch_bytes;
  args.state = binding.state;
  args.state_bytes = binding.state_bytes;
  function(args);
}

void run_vector_node(const VectorNodeBinding& binding, int tile_width, int tile_height, KernelBackend backend,
                     simd::Isa isa, simd::OpCounts* counts) {
  const PlaneView& output = binding.outputs.at(0);
  // A row-state kernel keeps its state for the frame: full-width tiles, zeroed state, in order.
  VectorNodeBinding with_state = binding;
  std::vector<uint8_t> state;
  if (binding.kernel->state_bytes && binding.state == nullptr) {
    state.assign(binding.kernel->state_bytes(output.width, output.height, binding.params), 0);
    with_state.state = state.data();
    with_state.state_bytes = state.size();
    tile_width = output.width;
  }
  if (binding.kernel->full_width_tiles) tile_width = output.width;  // the kernel works along whole rows
  const int block_height = std::max(1, binding.kernel->block_height);
  tile_height = (tile_height + block_height - 1) / block_height * block_height;  // whole blocks (sgm_8path_bands: bands)
  TileRunner runner;
  simd::OpCounts local;
  simd::CountingScope scope(local);
  const TileFunction function =
      backend == KernelBackend::counting ? binding.kernel->counting : binding.kernel->native_for(isa);
  std::vector<TileRect> tiles = make_tiles(output.width, output.height, tile_width, tile_height);
  if (with_state.state != nullptr && binding.kernel->rows_bottom_up) std::reverse(tiles.begin(), tiles.end());
  for (const TileRect& tile : tiles) runner.run(with_state, tile, function);
  if (counts != nullptr) *counts += local;
}

}  // namespace lpstereo
