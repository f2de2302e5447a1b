// median3x3: the median of each pixel's 3x3 neighbourhood, u8 -> u8.
//
// Ports: input "input" u8 (window, halo 1 on every side), output "output" u8 of the same size.
// Border modes: replicate and constant (the executor fills the halo; outside pixels of the constant
// mode take the low byte of border_value). No parameters. Exact: the output is one of the nine input
// values, so there is no rounding and no saturation.
//
// Vector schedule (one chunk = B::kLanesU8 pixels of an output row): the 3x3 selection network of
// kernels/median3x3_window.h (shared with median3x3_s16), nine loads and 30 min/max ops a chunk.
// Op count per chunk (closed form, checked by tests/kernels/median3x3_test.cpp):
//   load  = 9
//   arith = 30   (min and max)
//   store = 1
// and nothing else: per tile, ceil(tile_width / L) chunks per row (L = B::kLanesU8), no broadcasts.
#include <algorithm>
#include <array>

#include "kernels/median3x3_window.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

template <class B>
void median3x3_body(const TileArgs& args) {
  median3x3_tile<B, uint8_t>(args, [](const typename B::VU8& /*centre*/, const typename B::VU8& median) { return median; });
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(median3x3, median3x3_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(median3x3)

namespace lpstereo::kernels {
namespace {

void median3x3_counting(const TileArgs& args) { median3x3_body<simd::Counting>(args); }

// Scalar reference: gathers the nine window values (border applied here) and sorts them.
void median3x3_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                         const void* /*params*/, BorderMode border_mode, uint32_t border_value) {
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  auto pixel = [&](int x, int y) { return reference_pixel_u8(source, x, y, border_mode, border_value); };
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) {
      std::array<uint8_t, 9> window{};
      int index = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) window[index++] = pixel(x + dx, y + dy);
      }
      std::sort(window.begin(), window.end());
      plane_row<uint8_t>(destination, y)[x] = window[4];
    }
  }
}

KernelDescriptor make_median3x3() {
  KernelDescriptor descriptor;
  descriptor.name = "median3x3";
  descriptor.summary = "median of the 3x3 neighbourhood (min/max selection network)";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.halo = {1, 1, 1, 1};
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = [](const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
    check_param_names(params, {});
    return PreparedKernel{nullptr, {input_shapes.at(0)}};
  };
  descriptor.counting = median3x3_counting;
  descriptor.reference = median3x3_reference;
  LPSTEREO_FILL_NATIVE_TABLE(median3x3)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(median3x3, lpstereo::kernels::make_median3x3);
#endif
