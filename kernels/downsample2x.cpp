// downsample2x: 2x2 box average, u8 -> u8 at half size (the pyramid for the half-resolution pass).
//
// Output (x, y) = (a + b + c + d + 2) >> 2 of the input pixels (2x, 2y), (2x+1, 2y), (2x, 2y+1),
// (2x+1, 2y+1): the rounded mean, halves rounded up, exact (no saturation: the sum is at most 1022).
// Output size ceil(W / 2) x ceil(H / 2): with an odd width or height the last output column or row
// reads one column or row past the image, which takes the last one (border mode replicate, the only
// mode: the rule above does not depend on a border value). On even sizes this equals
// cv::resize(..., INTER_AREA) at scale 1/2 (tests/kernels/downsample2x_test.cpp checks it).
//
// Ports: input "input" u8, window access with input_scales {2/1} and no halo: the output tile
// [x0, x1) x [y0, y1) reads the input [2 x0, 2 x1) x [2 y0, 2 y1) (dag/tile_executor.h,
// tile_input_rect); output "output" u8. No parameters.
//
// Vector schedule (one chunk = B::kLanesU8 = L output pixels of a row, 2 L input bytes of each of
// its two input rows): each input row is two u8 loads viewed as u16 lanes (free reinterpret), so
// lane i holds the pixel pair (2i, 2i+1) as low and high byte; per half chunk, even bytes come from
// an and with 0x00FF and odd bytes from a logical shift right by 8, four u16 adds make
// a + b + c + d + 2, a shift right by 2 the mean; a saturating narrow packs the two halves to u8.
// Op count per chunk (closed form, checked by tests/kernels/downsample2x_test.cpp):
//   load    = 4
//   logic   = 4   (2 halves x 2 ands)
//   shift   = 6   (2 halves x (2 shifts by 8 + 1 shift by 2))
//   arith   = 8   (2 halves x 4 adds)
//   permute = 1   (narrow)
//   store   = 1
// and per tile 2 broadcasts (permute: the 0x00FF mask and the rounding 2).
#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

template <class B>
void downsample2x_body(const TileArgs& args) {
  using VU16 = typename B::VU16;
  constexpr int kLanes = B::kLanesU8;
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int readable_end = source.width;  // 2 x the tile width (the executor replicates a missing last column)
  const VU16 low_bytes = B::set1_u16(0x00FF);
  const VU16 two = B::set1_u16(2);

  for (int y = 0; y < destination.height; ++y) {
    const uint8_t* top = plane_row<const uint8_t>(source, 2 * y);
    const uint8_t* bottom = plane_row<const uint8_t>(source, 2 * y + 1);
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    for (int x = 0; x < width; x += kLanes) {
      VU16 means[2];
      for (int half = 0; half < 2; ++half) {
        const int column = 2 * x + half * kLanes;
        const int clipped = column < readable_end ? column : readable_end;  // no pointer past the row
        const VU16 upper = B::as_u16(load_clipped<B>(top, clipped, readable_end));
        const VU16 lower = B::as_u16(load_clipped<B>(bottom, clipped, readable_end));
        const VU16 even = B::add(B::bit_and(upper, low_bytes), B::bit_and(lower, low_bytes));
        const VU16 odd = B::add(B::template shr<8>(upper), B::template shr<8>(lower));
        means[half] = B::template shr<2>(B::add(B::add(even, odd), two));
      }
      store_clipped<B>(out_row, x, width, B::narrow_sat_u8(means[0], means[1]));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(downsample2x, downsample2x_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(downsample2x)

namespace lpstereo::kernels {
namespace {

void downsample2x_counting(const TileArgs& args) { downsample2x_body<simd::Counting>(args); }

void downsample2x_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                            const void* /*params*/, BorderMode border_mode, uint32_t border_value) {
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  auto pixel = [&](int x, int y) -> int { return reference_pixel_u8(source, x, y, border_mode, border_value); };
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) {
      const int sum = pixel(2 * x, 2 * y) + pixel(2 * x + 1, 2 * y) + pixel(2 * x, 2 * y + 1) + pixel(2 * x + 1, 2 * y + 1);
      plane_row<uint8_t>(destination, y)[x] = static_cast<uint8_t>((sum + 2) >> 2);
    }
  }
}

PreparedKernel downsample2x_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {});
  const PlaneShape& input = input_shapes.at(0);
  PreparedKernel prepared{nullptr, {PlaneShape{(input.width + 1) / 2, (input.height + 1) / 2}}};
  prepared.input_scales = {InputScale{2, 1}};
  return prepared;
}

KernelDescriptor make_downsample2x() {
  KernelDescriptor descriptor;
  descriptor.name = "downsample2x";
  descriptor.summary = "2x2 box average to half size, (a+b+c+d+2)>>2, odd sizes replicate the last column/row";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = downsample2x_prepare;
  descriptor.counting = downsample2x_counting;
  descriptor.reference = downsample2x_reference;
  LPSTEREO_FILL_NATIVE_TABLE(downsample2x)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(downsample2x, lpstereo::kernels::make_downsample2x);
#endif
