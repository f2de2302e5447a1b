// rgb888_to_luma: packed 24-bit colour camera frames (RGB888 'RGB3', BGR888 'BGR3':
// io/camera/pixel_format.h) to u8 luma with the BT.601 weights, bit for bit what OpenCV's
// cv::cvtColor(COLOR_RGB2GRAY / COLOR_BGR2GRAY) gives on 8-bit images.
//
// Input format: three bytes per pixel, R G B (order "rgb") or B G R (order "bgr"), no padding
// between pixels. A 3-byte pixel has no element type, so the input is a u8 plane of 3 W bytes per
// row (element = one byte) read with PortAccess::whole: the tile body finds the tile's pixels at
// bytes [3 tile_x, 3 (tile_x + tile_width)) of each of its rows and reads no other byte;
// `source_rect` reports exactly that rectangle, [3 x0, 3 x1) x [y0, y1), so the simulator charges
// the DMA of the tile's own bytes (no halo). prepare refuses an input width that is not a
// multiple of 3.
//
// Arithmetic (u8 output, exact, no saturation needed):
//   Y = (9798 R + 19235 G + 3735 B + 2^14) >> 15
// The Q15 weights are OpenCV's for the 8-bit path (modules/imgproc/src/color_rgb.simd.hpp,
// RGB2Gray<uchar>: RY15 9798, GY15 19235, BY15 3735, gray_shift 15, which asserts they sum to
// 1 << shift; its scalar tail is CV_DESCALE, i.e. + 2^14 then >> 15, and its vector body the same
// dot product): 0.299, 0.587 and 0.114 times 2^15, rounded so that they sum to exactly 2^15
// (0.114 x 2^15 = 3735.55 is taken down). OpenCV 4.6 on this machine agrees with the formula on all 2^24
// colours (tests/kernels/rgb888_to_luma_test.cpp); the Q14 weights (4899, 9617, 1868) >> 14 differ
// from it on 43,864 of them.
// Bound: the weights sum to 2^15, so the sum is at most 255 x 2^15 + 2^14 = 8,372,224 < 2^23
// (s32 lanes hold it) and Y <= floor((255 x 2^15 + 2^14) / 2^15) = 255: the u8 result never
// saturates (checked at white, 255 255 255, and black).
//
// Ports: input "input" u8 of 3 W x H (whole access, see above); output "output" u8 W x H.
// Parameter "order" (string, required): "rgb" or "bgr". The kernel never reads outside the
// plane, so no border mode changes anything; replicate is declared.
//
// Vector schedule (one chunk = B::kLanesU8 = L output pixels = 4 quarters of L / 4 s32 lanes): the
// contract has no 3-way de-interleave (NEON's vld3, an x86 byte shuffle), so the three bytes of a
// pixel come in by gather: per quarter, the byte offsets of its pixels (3 i from the row's first
// pixel) clamped to the tile's last pixel (min: lanes past the tile read that pixel, never a byte
// past it; their results are not stored), three gather_u8 (bytes 0, 1, 2 of each pixel, zero-
// extended to s32 lanes), three s32 mullo by the weights of those byte positions (R and B swap
// with the order), three adds (with the rounding 2^14) and a shift right by 15; the offsets then
// advance by 3 L / 4. Per half chunk one s32 -> u16 narrow, per chunk one u16 -> u8 narrow (no lane
// saturates: every value is 0 .. 255) and one store (store_clipped, kernels/row_access.h).
// Op count (closed form, checked by tests/kernels/rgb888_to_luma_test.cpp), per chunk:
//   gather   12   (quarter: 3)
//   multiply 12   (quarter: 3 mullo)
//   arith    20   (quarter: 1 clamp min, 3 adds, 1 offset advance)
//   shift     4   (quarter: 1)
//   permute   3   (2 narrows to u16, 1 narrow to u8)
//   store     1
// and per tile: load 1 (the lane offset table), permute 6 (broadcasts: the last pixel's offset,
// the offset step, three weights, the rounding). Chunks per tile row: ceil(tile_width / L).
// Limits: rows under 2^31 bytes (byte offsets are s32 lanes).
#include <cstdint>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

// BT.601 luma weights in Q15, OpenCV's 8-bit ones (see the header comment); they sum to 2^15.
constexpr int32_t kRedWeightQ15 = 9798;
constexpr int32_t kGreenWeightQ15 = 19235;
constexpr int32_t kBlueWeightQ15 = 3735;
constexpr int kWeightShift = 15;
static_assert(kRedWeightQ15 + kGreenWeightQ15 + kBlueWeightQ15 == 1 << kWeightShift, "the weights must sum to 1.0");

// Lane i holds 3 i: the byte offset of pixel i of a quarter from the quarter's first pixel.
alignas(64) constexpr int32_t kLaneByteOffset[16] = {0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 33, 36, 39, 42, 45};

struct Rgb888ToLumaParams {
  int red_byte = 0;  // 0 for rgb, 2 for bgr: the byte of a pixel holding red (blue is the other end)
};

template <class B>
void rgb888_to_luma_body(const TileArgs& args) {
  using VS32 = typename B::VS32;
  using VU16 = typename B::VU16;
  constexpr int kLanes = B::kLanesU8;
  constexpr int kQuarter = B::kLanesU32;
  static_assert(kQuarter <= 16, "the lane offset table holds 16 lanes");
  const PlaneView& source = args.inputs[0];  // the whole plane, 3 bytes per pixel
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const bool red_first = static_cast<const Rgb888ToLumaParams*>(args.params)->red_byte == 0;

  const VS32 lane_offsets = B::load(kLaneByteOffset);
  const VS32 last_pixel = B::set1_s32(3 * (width - 1));
  const VS32 quarter_step = B::set1_s32(3 * kQuarter);
  const VS32 first_weight = B::set1_s32(red_first ? kRedWeightQ15 : kBlueWeightQ15);
  const VS32 green_weight = B::set1_s32(kGreenWeightQ15);
  const VS32 third_weight = B::set1_s32(red_first ? kBlueWeightQ15 : kRedWeightQ15);
  const VS32 rounding = B::set1_s32(1 << (kWeightShift - 1));

  for (int y = 0; y < destination.height; ++y) {
    const uint8_t* pixels = plane_row<const uint8_t>(source, args.tile_y + y) + 3 * static_cast<ptrdiff_t>(args.tile_x);
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    VS32 offsets = lane_offsets;
    // The luma of the next quarter's pixels (s32 lanes, 0 .. 255); advances the offsets.
    auto quarter = [&]() {
      const VS32 clamped = B::min(offsets, last_pixel);
      offsets = B::add(offsets, quarter_step);
      const VS32 first = B::as_s32(B::gather_u8(pixels, clamped));
      const VS32 green = B::as_s32(B::gather_u8(pixels + 1, clamped));
      const VS32 third = B::as_s32(B::gather_u8(pixels + 2, clamped));
      const VS32 sum = B::add(B::add(B::mullo(first, first_weight), B::mullo(green, green_weight)),
                              B::add(B::mullo(third, third_weight), rounding));
      return B::template shr<kWeightShift>(sum);
    };
    for (int x = 0; x < width; x += kLanes) {
      const VS32 q0 = quarter();
      const VS32 q1 = quarter();
      const VU16 low = B::narrow_sat_u16(q0, q1);
      const VS32 q2 = quarter();
      const VS32 q3 = quarter();
      const VU16 high = B::narrow_sat_u16(q2, q3);
      store_clipped<B>(out_row, x, width, B::narrow_sat_u8(low, high));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(rgb888_to_luma, rgb888_to_luma_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/param_choice.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(rgb888_to_luma)

namespace lpstereo::kernels {
namespace {

void rgb888_to_luma_counting(const TileArgs& args) { rgb888_to_luma_body<simd::Counting>(args); }

void rgb888_to_luma_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                              const void* params, BorderMode /*border_mode*/, uint32_t /*border_value*/) {
  const int red_byte = static_cast<const Rgb888ToLumaParams*>(params)->red_byte;
  const int blue_byte = 2 - red_byte;
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  for (int y = 0; y < destination.height; ++y) {
    const uint8_t* bytes = plane_row<const uint8_t>(source, y);
    for (int x = 0; x < destination.width; ++x) {
      const uint8_t* pixel = bytes + 3 * x;
      const int32_t sum = kRedWeightQ15 * pixel[red_byte] + kGreenWeightQ15 * pixel[1] + kBlueWeightQ15 * pixel[blue_byte];
      plane_row<uint8_t>(destination, y)[x] = static_cast<uint8_t>((sum + (1 << (kWeightShift - 1))) >> kWeightShift);
    }
  }
}

PreparedKernel rgb888_to_luma_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"order"});
  const std::string order = param_choice(params, "order", {"rgb", "bgr"});
  const PlaneShape& input = input_shapes.at(0);
  if (input.width % 3 != 0) {
    throw KernelError("input 'input': expected a width in bytes that is a multiple of 3 (3 bytes per pixel), got " +
                      std::to_string(input.width));
  }
  auto prepared = std::make_shared<Rgb888ToLumaParams>();
  prepared->red_byte = order == "rgb" ? 0 : 2;
  return PreparedKernel{prepared, {PlaneShape{input.width / 3, input.height}}};
}

KernelDescriptor make_rgb888_to_luma() {
  KernelDescriptor descriptor;
  descriptor.name = "rgb888_to_luma";
  descriptor.summary = "packed 24-bit RGB/BGR to u8 luma, (9798 R + 19235 G + 3735 B + 2^14) >> 15 as cv::cvtColor";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = rgb888_to_luma_prepare;
  // The tile's own pixels: 3 bytes each, the same rows.
  descriptor.source_rect = [](int /*input_index*/, const PixelRect& output_tile, const PlaneShape& /*input_shape*/,
                              const void* /*params*/) {
    return PixelRect{3 * output_tile.x0, output_tile.y0, 3 * output_tile.x1, output_tile.y1};
  };
  descriptor.counting = rgb888_to_luma_counting;
  descriptor.reference = rgb888_to_luma_reference;
  LPSTEREO_FILL_NATIVE_TABLE(rgb888_to_luma)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(rgb888_to_luma, lpstereo::kernels::make_rgb888_to_luma);
#endif
