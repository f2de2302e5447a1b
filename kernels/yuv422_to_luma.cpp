// yuv422_to_luma: packed 4:2:2 camera frames (YUYV, UYVY: io/camera/pixel_format.h) to u8 luma.
//
// Input format: a YUYV row is the bytes Y0 U0 Y1 V0 Y2 U1 ..., a UYVY row U0 Y0 V0 Y1 U1 Y2 ...: two
// bytes per pixel, the luma of pixel x at byte 2x (YUYV) or 2x + 1 (UYVY), the chroma shared by a
// pixel pair in the other byte. The kernel takes such a row as a u16 plane of width W (one element
// per pixel: the byte pair as it lies in memory), so on this little-endian host the first byte is
// the element's low half: luma = element & 0xFF (YUYV) or element >> 8 (UYVY). No arithmetic on the
// values: output (x, y) is the luma byte itself, exact, nothing to round or saturate. The chroma is
// dropped (the graphs take luma only).
//
// Ports: input "input" u16 (the packed pairs), window access, no halo; output "output" u8, the
// input's size. Parameter "order" (string, required): "yuyv" (luma in the low byte) or "uyvy" (luma
// in the high byte). The border mode is never used (no halo), replicate is declared.
//
// Vector schedule (one chunk = B::kLanesU8 = L output pixels = two halves of L / 2 u16 lanes): per
// half one u16 load and, for yuyv, an and with 0x00FF (for uyvy a logical shift right by 8), which
// leaves the luma byte in each u16 lane (0 .. 255); the saturating u16 -> u8 narrow then packs the
// two halves (no lane saturates) and one store writes the chunk. The loads of the last chunk of a
// row read only the row's W elements (load_clipped, kernels/row_access.h): the last row of a camera
// buffer may end at the image's last byte.
// Op count (closed form, checked by tests/kernels/yuv422_to_luma_test.cpp), per chunk:
//   yuyv: load 2, logic 2, permute 1 (narrow), store 1; per tile permute 1 (the 0x00FF broadcast)
//   uyvy: load 2, shift 2, permute 1 (narrow), store 1; nothing per tile
// Chunks per tile row: ceil(tile_width / L).
#include <bit>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

static_assert(std::endian::native == std::endian::little, "a YUYV byte pair read as one u16 lane has Y in the low half");

struct Yuv422ToLumaParams {
  bool luma_in_high_byte = false;  // uyvy
};

// Rows of the tile, each u16 half chunk turned into its luma (u16 lanes 0 .. 255) by `luma_of`.
template <class B, class LumaOf>
void yuv422_rows(const TileArgs& args, const LumaOf& luma_of) {
  constexpr int kLanes = B::kLanesU8;
  constexpr int kHalf = B::kLanesU16;
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  for (int y = 0; y < destination.height; ++y) {
    const uint16_t* pairs = plane_row<const uint16_t>(source, y);
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    for (int x = 0; x < width; x += kLanes) {
      const int second = x + kHalf < width ? x + kHalf : width;  // no pointer past the row
      const auto low = luma_of(load_clipped<B>(pairs, x, width));
      const auto high = luma_of(load_clipped<B>(pairs, second, width));
      store_clipped<B>(out_row, x, width, B::narrow_sat_u8(low, high));
    }
  }
}

template <class B>
void yuv422_to_luma_body(const TileArgs& args) {
  using VU16 = typename B::VU16;
  if (static_cast<const Yuv422ToLumaParams*>(args.params)->luma_in_high_byte) {
    yuv422_rows<B>(args, [](const VU16& pairs) { return B::template shr<8>(pairs); });
  } else {
    const VU16 low_byte = B::set1_u16(0x00FF);
    yuv422_rows<B>(args, [&low_byte](const VU16& pairs) { return B::bit_and(pairs, low_byte); });
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(yuv422_to_luma, yuv422_to_luma_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/param_choice.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(yuv422_to_luma)

namespace lpstereo::kernels {
namespace {

void yuv422_to_luma_counting(const TileArgs& args) { yuv422_to_luma_body<simd::Counting>(args); }

// Reads the camera bytes themselves (byte 2x or 2x + 1 of the row), not the u16 values, so it does
// not share the kernel's little-endian reading.
void yuv422_to_luma_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                              const void* params, BorderMode /*border_mode*/, uint32_t /*border_value*/) {
  const int luma_byte = static_cast<const Yuv422ToLumaParams*>(params)->luma_in_high_byte ? 1 : 0;
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  for (int y = 0; y < destination.height; ++y) {
    const uint8_t* bytes = plane_row<const uint8_t>(source, y);
    for (int x = 0; x < destination.width; ++x) plane_row<uint8_t>(destination, y)[x] = bytes[2 * x + luma_byte];
  }
}

PreparedKernel yuv422_to_luma_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"order"});
  const std::string order = param_choice(params, "order", {"yuyv", "uyvy"});
  auto prepared = std::make_shared<Yuv422ToLumaParams>();
  prepared->luma_in_high_byte = order == "uyvy";
  return PreparedKernel{prepared, {input_shapes.at(0)}};
}

KernelDescriptor make_yuv422_to_luma() {
  KernelDescriptor descriptor;
  descriptor.name = "yuv422_to_luma";
  descriptor.summary = "packed 4:2:2 (u16 byte pairs) to u8 luma: the low byte (order yuyv) or the high byte (uyvy)";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u16, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = yuv422_to_luma_prepare;
  descriptor.counting = yuv422_to_luma_counting;
  descriptor.reference = yuv422_to_luma_reference;
  LPSTEREO_FILL_NATIVE_TABLE(yuv422_to_luma)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(yuv422_to_luma, lpstereo::kernels::make_yuv422_to_luma);
#endif
