// copy_u8: u8 -> u8 copy of the tile, the first node of a camera graph whose frames already are
// 8-bit luma: GREY frames and the Y plane of NV12 (io/camera/pixel_format.h), copied from the
// camera's buffer (rows bytes_per_line apart, no padding after the last row) into the graph's luma
// plane. Output (x, y) = input (x, y); no arithmetic, so no format, rounding or saturation to state.
//
// Ports: input "input" u8, window access, no halo; output "output" u8, the input's size. No
// parameters; the border mode is never used (no halo), replicate is declared.
//
// Vector schedule (one chunk = B::kLanesU8 = L pixels of a row): one load, one store. The last chunk
// of a row loads and stores only the lanes inside the tile (load_clipped / store_clipped,
// kernels/row_access.h), so nothing past the row is read: the last row of a camera buffer may end
// exactly at the image's last byte.
// Op count per chunk (closed form, checked by tests/kernels/copy_u8_test.cpp):
//   load = 1, store = 1; nothing per tile. Chunks per tile row: ceil(tile_width / L).
#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

template <class B>
void copy_u8_body(const TileArgs& args) {
  constexpr int kLanes = B::kLanesU8;
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  for (int y = 0; y < destination.height; ++y) {
    const uint8_t* in_row = plane_row<const uint8_t>(source, y);
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    for (int x = 0; x < width; x += kLanes) {
      store_clipped<B>(out_row, x, width, load_clipped<B>(in_row, x, width));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(copy_u8, copy_u8_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(copy_u8)

namespace lpstereo::kernels {
namespace {

void copy_u8_counting(const TileArgs& args) { copy_u8_body<simd::Counting>(args); }

void copy_u8_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                       const void* /*params*/, BorderMode /*border_mode*/, uint32_t /*border_value*/) {
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) plane_row<uint8_t>(destination, y)[x] = plane_row<const uint8_t>(source, y)[x];
  }
}

PreparedKernel copy_u8_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {});
  return PreparedKernel{nullptr, {input_shapes.at(0)}};
}

KernelDescriptor make_copy_u8() {
  KernelDescriptor descriptor;
  descriptor.name = "copy_u8";
  descriptor.summary = "u8 copy: GREY frames and NV12's Y plane into the graph's luma plane";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = copy_u8_prepare;
  descriptor.counting = copy_u8_counting;
  descriptor.reference = copy_u8_reference;
  LPSTEREO_FILL_NATIVE_TABLE(copy_u8)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(copy_u8, lpstereo::kernels::make_copy_u8);
#endif
