// remap_bilinear: fixed-point rectification remap with bilinear interpolation, u8 source -> u8.
//
// Ports:
//   input 0 "source" u8, PortAccess::whole: the kernel sees the full source plane and applies the
//     border mode itself (taps may land anywhere, so no halo can be declared).
//   input 1 "map" remap_q5 (dag/format.h), window access, halo 0: per output pixel (x, y) two int16,
//     dx = source_x - x and dy = source_y - y in Q10.5 (1/32 px, -1024 .. +1023.96875 px),
//     interleaved dx, dy. dag/remap_table.h builds maps from OpenCV-style float maps.
//   output "output" u8, the size of the map (the source may have another size).
// Parameter: max_displacement_px (int, default 64, 0 .. 1024): the largest |dx| or |dy| in pixels the
//   graph's maps are assumed to have. It is NOT a limit on the map (the kernel cannot see the map in
//   prepare, and the tile body and the reference are exact for any map): it sizes the source window
//   `source_rect` reports, i.e. the bytes the simulator charges DMA for per output tile. A map that
//   displaces further still gives the right output on the host, but the simulated DMA is then low.
//
// Arithmetic (the reference and every back end give the same bits; so does OpenCV's cv::remap with
// INTER_LINEAR on 8-bit images, which quantises positions to 1/32 px (INTER_BITS = 5) and uses the
// weights 32 w below in 15 bits: (32 S + 2^14) >> 15 = (S + 512) >> 10 exactly):
//   X = 32 x + dx, Y = 32 y + dy               source position in Q5 (s32)
//   ix = X >> 5, fx = X & 31 (floor division for negative X); iy, fy likewise
//   taps p00 = S(ix, iy), p10 = S(ix + 1, iy), p01 = S(ix, iy + 1), p11 = S(ix + 1, iy + 1)
//   weights w00 = (32 - fx)(32 - fy), w10 = fx (32 - fy), w01 = (32 - fx) fy, w11 = fx fy (sum 1024)
//   out = (w00 p00 + w10 p10 + w01 p01 + w11 p11 + 512) >> 10   (round half up; always 0 .. 255)
//   S(u, v) outside the plane: replicate clamps u and v to the plane separately for each tap;
//   constant reads border_value (its low byte).
// Range: the weighted sum reaches 255 * 1024 = 261120, which u16 lanes cannot hold (the Q4 kernel
//   this replaces summed to 255 * 256 and interpolated in u16), so the interpolation runs in s32.
//
// Vector schedule (one chunk = B::kLanesU8 output pixels = 4 quarters of B::kLanesU32 pixels):
//   per quarter, in s32 lanes: one load of the map as s32 lanes (a (dx, dy) pair is one 32-bit lane,
//     dx in the low half; dx = (lane << 16) >> 16, dy = lane >> 16, arithmetic). This replaces the
//     widen_lo/widen_hi of an s16 vector, which would leave dx and dy in alternate lanes with no
//     contract op to de-interleave them. Then positions, floor and fraction, the four tap coordinates
//     clamped to the plane, row offsets by mullo with the stride, and four gather_u8. Constant
//     border: a tap is inside when clamping left its coordinates unchanged (cmpeq), and a select puts
//     border_value in the other lanes. Then three lerps in s32 lanes,
//     top = 32 p00 + fx (p10 - p00), bottom = 32 p01 + fx (p11 - p01) (both 0 .. 8160),
//     sum = 32 top + fy (bottom - top) (0 .. 261120), which is the weighted sum above exactly
//     (expand it); out = (sum + 512) >> 10.
//   per half (two quarters): narrow s32 -> u16; per chunk: narrow the two halves to u8 and store.
// Op count (closed form, checked by tests/kernels/remap_bilinear_test.cpp):
//   per chunk, replicate border:
//     load 4, gather 16, store 1,
//     arith 96     (quarter: 2 positions, 1 column step, 2 "+1", 8 clamp min/max, 4 offset adds,
//                   3 lerp subs, 3 lerp adds, 1 rounding add = 24)
//     shift 36     (quarter: 2 to split dx, 1 for dy, 2 floors, 3 x32, 1 >>10 = 9)
//     logic 8      (quarter: 2 fraction ands)
//     multiply 20  (quarter: 2 row offsets, 3 lerps; all s32 mullo)
//     permute 3    (half: 1 narrow to u16; chunk: 1 narrow to u8)
//   constant border adds per chunk: compare 16 (4 a quarter), logic 32 (4 mask ands, 4 selects a
//     quarter);
//   per output row: permute 1 (broadcast of the row's Q5 y);
//   per tile: load 1 (the lane-index table), arith 1, permute 10 (broadcasts).
//   Chunks per tile row: ceil(tile_width / B::kLanesU8); the last chunk of a row does the full work
//   (map lanes past the row read as 0, their taps are clamped into the plane) and stores partially.
// Limits: source planes under 2 GiB (row offsets are s32 lanes); x, y < 2^25 (Q5 positions in s32).
#include <algorithm>
#include <bit>
#include <cstdint>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

static_assert(std::endian::native == std::endian::little, "a remap_q5 pair read as one s32 lane has dx in the low half");

// Lane i holds 32 i: the Q5 x offset of lane i from the first pixel of a quarter.
alignas(64) constexpr int32_t kLaneOffsetQ5[16] = {0, 32, 64, 96, 128, 160, 192, 224, 256, 288, 320, 352, 384, 416, 448, 480};

// The four taps of one quarter (s32 lanes hold u8 values).
template <class B>
struct QuarterTaps {
  typename B::VU32 p00, p10, p01, p11;
  typename B::VS32 fx, fy;
};

template <class B>
typename B::VS32 clamp_lanes(const typename B::VS32& value, const typename B::VS32& low, const typename B::VS32& high) {
  return B::min(B::max(value, low), high);
}

template <class B>
void remap_bilinear_body(const TileArgs& args) {
  using VS32 = typename B::VS32;
  using VU32 = typename B::VU32;
  using VU16 = typename B::VU16;
  constexpr int kQuarter = B::kLanesU32;
  constexpr int kChunk = B::kLanesU8;
  static_assert(kQuarter <= 16, "kLaneOffsetQ5 covers 16 s32 lanes");

  const PlaneView& source = args.inputs[0];
  const PlaneView& map = args.inputs[1];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int height = destination.height;
  const bool constant_border = args.border_mode == BorderMode::constant;

  const VS32 lane_offset_q5 = B::load(kLaneOffsetQ5);
  const VS32 fraction_mask = B::set1_s32(31);
  const VS32 one = B::set1_s32(1);
  const VS32 zero = B::set1_s32(0);
  const VS32 last_x = B::set1_s32(source.width - 1);
  const VS32 last_y = B::set1_s32(source.height - 1);
  const VS32 stride_bytes = B::set1_s32(static_cast<int32_t>(source.stride_bytes));
  const VS32 quarter_step_q5 = B::set1_s32(kQuarter * 32);
  const VS32 tile_start_q5 = B::add(lane_offset_q5, B::set1_s32(args.tile_x * 32));
  const VS32 rounding = B::set1_s32(512);
  const VU32 border = B::set1_u32(args.border_value & 0xFFu);

  // One lerp in s32 lanes: 32 a + f (b - a), exact (see the header comment).
  auto lerp = [](const VS32& a, const VS32& b, const VS32& fraction) {
    return B::add(B::template shl<5>(a), B::mullo(B::sub(b, a), fraction));
  };
  // The output values (0 .. 255 in s32 lanes) of the quarter whose pixels start at `column`;
  // advances x_q5 by a quarter.
  auto quarter = [&](const int32_t* map_row, int column, const VS32& y_q5, VS32& x_q5) {
    const VS32 pair = load_clipped<B>(map_row, column < width ? column : width, width);
    const VS32 dx = B::template shr<16>(B::template shl<16>(pair));
    const VS32 dy = B::template shr<16>(pair);
    const VS32 position_x = B::add(x_q5, dx);
    const VS32 position_y = B::add(y_q5, dy);
    x_q5 = B::add(x_q5, quarter_step_q5);
    const VS32 x0 = B::template shr<5>(position_x);
    const VS32 y0 = B::template shr<5>(position_y);
    const VS32 fx = B::bit_and(position_x, fraction_mask);
    const VS32 fy = B::bit_and(position_y, fraction_mask);
    const VS32 x1 = B::add(x0, one);
    const VS32 y1 = B::add(y0, one);
    const VS32 x0_in = clamp_lanes<B>(x0, zero, last_x);
    const VS32 x1_in = clamp_lanes<B>(x1, zero, last_x);
    const VS32 y0_in = clamp_lanes<B>(y0, zero, last_y);
    const VS32 y1_in = clamp_lanes<B>(y1, zero, last_y);
    const VS32 row0 = B::mullo(y0_in, stride_bytes);
    const VS32 row1 = B::mullo(y1_in, stride_bytes);
    VU32 p00 = B::gather_u8(source.origin, B::add(row0, x0_in));
    VU32 p10 = B::gather_u8(source.origin, B::add(row0, x1_in));
    VU32 p01 = B::gather_u8(source.origin, B::add(row1, x0_in));
    VU32 p11 = B::gather_u8(source.origin, B::add(row1, x1_in));
    if (constant_border) {
      const VS32 x0_inside = B::cmpeq(x0_in, x0);
      const VS32 x1_inside = B::cmpeq(x1_in, x1);
      const VS32 y0_inside = B::cmpeq(y0_in, y0);
      const VS32 y1_inside = B::cmpeq(y1_in, y1);
      p00 = B::select(B::as_u32(B::bit_and(x0_inside, y0_inside)), p00, border);
      p10 = B::select(B::as_u32(B::bit_and(x1_inside, y0_inside)), p10, border);
      p01 = B::select(B::as_u32(B::bit_and(x0_inside, y1_inside)), p01, border);
      p11 = B::select(B::as_u32(B::bit_and(x1_inside, y1_inside)), p11, border);
    }
    const VS32 top = lerp(B::as_s32(p00), B::as_s32(p10), fx);
    const VS32 bottom = lerp(B::as_s32(p01), B::as_s32(p11), fx);
    return B::template shr<10>(B::add(lerp(top, bottom, fy), rounding));
  };

  for (int y = 0; y < height; ++y) {
    const int32_t* map_row = plane_row<const int32_t>(map, y);  // one (dx, dy) pair per 32 bits
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    const VS32 y_q5 = B::set1_s32((args.tile_y + y) * 32);
    VS32 x_q5 = tile_start_q5;
    for (int x = 0; x < width; x += kChunk) {
      VU16 halves[2];
      for (int half = 0; half < 2; ++half) {
        const int column = x + 2 * half * kQuarter;
        const VS32 lo = quarter(map_row, column, y_q5, x_q5);
        const VS32 hi = quarter(map_row, column + kQuarter, y_q5, x_q5);
        halves[half] = B::narrow_sat_u16(lo, hi);
      }
      store_clipped<B>(out_row, x, width, B::narrow_sat_u8(halves[0], halves[1]));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(remap_bilinear, remap_bilinear_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(remap_bilinear)

namespace lpstereo::kernels {
namespace {

struct RemapBilinearParams {
  int max_displacement_px = 64;  // DMA window assumption for source_rect, see the header comment
};

void remap_bilinear_counting(const TileArgs& args) { remap_bilinear_body<simd::Counting>(args); }

// Scalar reference: the formulas of the header comment, one pixel at a time.
void remap_bilinear_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                              const void* /*params*/, BorderMode border_mode, uint32_t border_value) {
  const PlaneView& source = inputs[0];
  const PlaneView& map = inputs[1];
  const PlaneView& destination = outputs[0];
  auto pixel = [&](int x, int y) -> int { return reference_pixel_u8(source, x, y, border_mode, border_value); };
  for (int y = 0; y < destination.height; ++y) {
    const int16_t* map_row = plane_row<const int16_t>(map, y);
    for (int x = 0; x < destination.width; ++x) {
      const int position_x = 32 * x + map_row[2 * x];
      const int position_y = 32 * y + map_row[2 * x + 1];
      const int x0 = position_x >> 5;  // arithmetic shift: floor division by 32
      const int y0 = position_y >> 5;
      const int fx = position_x & 31;
      const int fy = position_y & 31;
      const int sum = (32 - fx) * (32 - fy) * pixel(x0, y0) + fx * (32 - fy) * pixel(x0 + 1, y0) +
                      (32 - fx) * fy * pixel(x0, y0 + 1) + fx * fy * pixel(x0 + 1, y0 + 1);
      plane_row<uint8_t>(destination, y)[x] = static_cast<uint8_t>((sum + 512) >> 10);
    }
  }
}

KernelDescriptor make_remap_bilinear() {
  KernelDescriptor descriptor;
  descriptor.name = "remap_bilinear";
  descriptor.summary = "rectification remap: bilinear, 5-bit fractions (as cv::remap), map of Q10.5 displacements (remap_q5)";
  descriptor.ports = {{"source", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"map", PortDirection::input, {ElementType::remap_q5, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.halo = {0, 0, 0, 0};
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = [](const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
    check_param_names(params, {"max_displacement_px"});
    if (input_shapes.size() != 2) {
      throw KernelError("inputs: expected 2 (source, map), got " + std::to_string(input_shapes.size()));
    }
    auto prepared = std::make_shared<RemapBilinearParams>();
    prepared->max_displacement_px = param_int(params, "max_displacement_px", 64, 0, 1024);
    return PreparedKernel{prepared, {input_shapes[1]}};
  };
  // The source pixels an output tile may read if no map entry displaces by more than
  // max_displacement_px: the tile grown by that much (and one more column and row on the right and
  // bottom for the second bilinear tap), clipped to the plane. A tile whose box falls entirely
  // outside still reads the nearest edge pixels (replicate), so the box keeps at least one pixel.
  descriptor.source_rect = [](int input_index, const PixelRect& output_tile, const PlaneShape& input_shape,
                              const void* params) {
    if (input_index != 0) return output_tile;
    const int margin = static_cast<const RemapBilinearParams*>(params)->max_displacement_px;
    PixelRect box;
    box.x0 = std::clamp(output_tile.x0 - margin, 0, input_shape.width - 1);
    box.y0 = std::clamp(output_tile.y0 - margin, 0, input_shape.height - 1);
    box.x1 = std::clamp(output_tile.x1 + margin + 1, box.x0 + 1, input_shape.width);
    box.y1 = std::clamp(output_tile.y1 + margin + 1, box.y0 + 1, input_shape.height);
    return box;
  };
  descriptor.counting = remap_bilinear_counting;
  descriptor.reference = remap_bilinear_reference;
  LPSTEREO_FILL_NATIVE_TABLE(remap_bilinear)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(remap_bilinear, lpstereo::kernels::make_remap_bilinear);
#endif
