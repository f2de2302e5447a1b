// disparity_fuse_multires: fuses a full-resolution far-range disparity map with a half-resolution
// one into one full-resolution s16 Q4 map. This is what lets 3840x1728 fit the chip: the
// full-resolution pass searches only the far range (small disparities), the half-resolution pass
// reaches the large disparities (near objects) at a quarter of the pixels and half the steps.
//
// Inputs:
//   "full" s16q4, the output's size: disparity searched over the far range
//     [min_far, min_far + num_far) full-resolution pixels; invalid = (min_far - 1) * 16.
//   "half" s16q4, ceil(W / 2) x ceil(H / 2), input_scales {1/2}: disparity in half-resolution pixels
//     searched over [min_near, min_near + num_near); invalid = (min_near - 1) * 16.
// A value counts as valid when it is above its map's invalid value (a matcher never writes below).
// Upsampling: nearest. Output (x, y) reads half pixel (x / 2, y / 2) and doubles it (x2: a
// half-resolution pixel is two full-resolution ones). Nearest, not bilinear: interpolating
// disparity across a depth edge invents surfaces that are in neither map, and an invalid neighbour
// would have no value to interpolate with.
// Fusion rule, with top = (min_far + num_far - 1 - margin_px) * 16, the largest far-range value
// trusted (margin_px drops the top steps of the far search, where a pixel whose true disparity
// lies beyond the range can settle):
//   1. the near value 2 N when N is valid and 2 N > top: the half-resolution pass places the pixel
//      beyond the far range, where the full-resolution pass cannot see it;
//   2. else the full value F when F is valid and F <= top (finer steps, full resolution), unless N
//      is invalid and the pixel lies in the left band, x / 2 < min_near + num_near - 1 (below);
//   3. else invalid.
// The left band: at half column h the half-resolution pass searched only up to h (the match of a
// larger disparity lies left of the right image), so there a pixel nearer than its column allows
// has no match in either pass, and the full-resolution pass, whose search the column cuts short as
// well, returns a valid-looking value for it. Where the half-resolution pass found no value in the
// band, the far value is therefore not taken. Measured with `lpstereo eval middlebury|kitti
// --multires on --multires-far F` (8 Middlebury pairs, KITTI 2015 000046; all pixels, after the
// KITTI fill / valid pixels only): Middlebury bad-2 F = 64: 8.10 / 4.01 -> 6.87 / 3.68 %, EPE 2.37
// -> 1.44 px, density 89.3 -> 88.8 %; F = 32: 9.99 / 5.63 -> 8.09 / 4.89 %; KITTI bad-2 F = 64:
// 7.09 / 4.22 -> 6.78 / 4.18 %, D1 3.66 -> 3.33 %; F = 32: 7.84 / 5.09 -> 7.34 / 4.88 %. (One
// full-resolution pass over the whole range: Middlebury 6.63 / 3.31 %, KITTI 7.16 / 4.17 %.) Why it
// matters beyond the benchmarks: a board 1.6 m ahead of the floating sequence's camera (105.8 px)
// in the left border of the image (columns 52-77) was read 23-36 px by the full-resolution pass,
// 313 points 4-5 m farther than the board, which lifted the terrain fitted under them
// (docs/obstacles3d.md, "The near guard").
// The half-resolution pass decides "near or far", so it should search the far range too (the
// graphs run it over the whole range: graphs/disparity-multires-wta.json). Measured on the
// synthetic scene with the unaggregated census WTA (tests/arm/multires_graph_test.cpp): a matcher
// whose true disparity lies outside its range returns a valid-looking value anywhere in the range,
// not at its edge, so neither pass can say "out of my range" by itself; with a half-resolution pass
// over the near range only, or with the far value tried first, the fusion lost to one
// full-resolution pass over the whole range; with this rule and a whole-range half pass it wins.
// Output: s16 Q4, invalid = (min_far - 1) * 16; every valid output is above it. 2 N fits s16 for
// every near-range value (min_near + num_near - 1 <= 1023); a half value outside [-16384, 16383],
// which no matcher produces, wraps modulo 2^16.
//
// Ports: "full", "half" (window access, no halo), output "fused" s16q4. Tiles start at even
// columns (block_width 2) so that the upsampling phase is the same in every tile. Border mode:
// replicate (no input rect leaves its plane).
//
// Vector schedule: one chunk = 2 K output pixels of a row (K = B::kLanesU16), K half pixels. The
// near candidate (2 N, or the output invalid value) is duplicated to full resolution with two zips;
// the far candidate (F, or the output invalid value) is below every near candidate taken (<= top <
// 2 N), so the rule is one max. A chunk whose first half column lies in the left band also builds
// the band's refusal mask (half columns from a lane ramp, compared with the band's end, and-not N
// valid, zipped to full resolution) and clears the far candidate's mask with it.
// Op count per chunk (closed form, checked by tests/kernels/disparity_fuse_multires_test.cpp):
//   load    = 3   (1 half, 2 full)
//   shift   = 1   (2 N)
//   compare = 6   (N > invalid, 2N > top; per full vector F > invalid, F > top)
//   logic   = 6   (and, select for the near candidate; per full vector andnot, select)
//   arith   = 2   (per full vector the max)
//   permute = 2   (zip_lo, zip_hi: each half pixel twice)
//   store   = 2
// plus per chunk starting in the left band: permute 3 (the first half column broadcast, two zips),
// arith 1 (+ the lane ramp), compare 1 (band end > half column), logic 3 (andnot N valid; per full
// vector andnot); and per tile 1 load (the lane ramp) and 5 broadcasts (permute: the two input
// invalid values, top, the output invalid value, the band's end).
#include <cstdint>
#include <string>
#include <vector>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int kMaxLanesU16 = 32;  // the widest back end's 16-bit lanes (512-bit; the counting back end)
alignas(64) constexpr int16_t kLaneIndexS16[kMaxLanesU16] = {0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11, 12, 13, 14, 15,
                                                             16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 31};

struct FuseParams {
  int min_far, num_far;    // full-resolution pixels
  int min_near, num_near;  // half-resolution pixels
  int margin_px;           // full-resolution pixels at the top of the far range not trusted
  int16_t far_invalid_q4, near_invalid_q4, top_q4, output_invalid_q4;
  int16_t left_band_half_columns;  // min_near + num_near - 1: half columns below it are in the left band
};

template <class B>
void disparity_fuse_multires_body(const TileArgs& args) {
  using VS16 = typename B::VS16;
  constexpr int kHalfLanes = B::kLanesU16;
  const auto& params = *static_cast<const FuseParams*>(args.params);
  const PlaneView& full = args.inputs[0];
  const PlaneView& half = args.inputs[1];
  const PlaneView& output = args.outputs[0];
  const int width = output.width;
  const int half_width = half.width;
  const VS16 near_invalid = B::set1_s16(params.near_invalid_q4);
  const VS16 far_invalid = B::set1_s16(params.far_invalid_q4);
  const VS16 top = B::set1_s16(params.top_q4);
  const VS16 output_invalid = B::set1_s16(params.output_invalid_q4);
  static_assert(kHalfLanes <= kMaxLanesU16, "the lane ramp covers every back end's 16-bit lanes");
  const VS16 lane_index = B::load(kLaneIndexS16);
  const VS16 left_band_end = B::set1_s16(params.left_band_half_columns);
  const int tile_half_x = args.tile_x / 2;  // tiles start at even columns (block_width 2)

  for (int y = 0; y < output.height; ++y) {
    const int half_y = ((args.tile_y + y) >> 1) - (args.tile_y >> 1);
    const int16_t* full_row = plane_row<const int16_t>(full, y);
    const int16_t* half_row = plane_row<const int16_t>(half, half_y);
    int16_t* out_row = plane_row<int16_t>(output, y);
    for (int x = 0; x < width; x += 2 * kHalfLanes) {
      const VS16 near = load_clipped<B>(half_row, x / 2, half_width);
      const VS16 near_doubled = B::template shl<1>(near);
      const VS16 near_valid = B::cmpgt(near, near_invalid);
      const VS16 near_ok = B::bit_and(near_valid, B::cmpgt(near_doubled, top));
      const auto near_value = B::as_u16(B::select(near_ok, near_doubled, output_invalid));
      const VS16 upsampled[2] = {B::as_s16(B::zip_lo(near_value, near_value)), B::as_s16(B::zip_hi(near_value, near_value))};
      // Rule 2's exception: N invalid in the left band refuses the far value (all ones = refuse).
      const int first_half_column = tile_half_x + x / 2;
      const bool in_left_band = first_half_column < params.left_band_half_columns;
      VS16 refuse_far[2] = {near_valid, near_valid};  // read only in the band, where they are set below
      if (in_left_band) {
        const VS16 half_column = B::add(B::set1_s16(static_cast<int16_t>(first_half_column)), lane_index);
        const auto refuse = B::as_u16(B::bit_andnot(near_valid, B::cmpgt(left_band_end, half_column)));
        refuse_far[0] = B::as_s16(B::zip_lo(refuse, refuse));
        refuse_far[1] = B::as_s16(B::zip_hi(refuse, refuse));
      }
      for (int part = 0; part < 2; ++part) {
        const int column = x + part * kHalfLanes < width ? x + part * kHalfLanes : width;  // no pointer past the row
        const VS16 far = load_clipped<B>(full_row, column, width);
        VS16 far_ok = B::bit_andnot(B::cmpgt(far, top), B::cmpgt(far, far_invalid));
        if (in_left_band) far_ok = B::bit_andnot(refuse_far[part], far_ok);
        const VS16 far_value = B::select(far_ok, far, output_invalid);
        store_clipped<B>(out_row, column, width, B::max(upsampled[part], far_value));
      }
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(disparity_fuse_multires, disparity_fuse_multires_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(disparity_fuse_multires)

namespace lpstereo::kernels {
namespace {

void disparity_fuse_multires_counting(const TileArgs& args) { disparity_fuse_multires_body<simd::Counting>(args); }

void disparity_fuse_multires_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                       const void* params_pointer, BorderMode /*border_mode*/, uint32_t /*border_value*/) {
  const auto& params = *static_cast<const FuseParams*>(params_pointer);
  const PlaneView& full = inputs[0];
  const PlaneView& half = inputs[1];
  const PlaneView& output = outputs[0];
  for (int y = 0; y < output.height; ++y) {
    for (int x = 0; x < output.width; ++x) {
      const int far = plane_row<const int16_t>(full, y)[x];
      const int near = plane_row<const int16_t>(half, y / 2)[x / 2];
      const int near_doubled = static_cast<int16_t>(2 * near);  // wraps as the vector shift does (see the header)
      int fused = params.output_invalid_q4;
      if (near > params.near_invalid_q4 && near_doubled > params.top_q4) {
        fused = near_doubled;
      } else if (far > params.far_invalid_q4 && far <= params.top_q4 &&
                 (near > params.near_invalid_q4 || x / 2 >= params.left_band_half_columns)) {
        fused = far;
      }
      plane_row<int16_t>(output, y)[x] = static_cast<int16_t>(fused);
    }
  }
}

std::string shape_text(const PlaneShape& shape) { return std::to_string(shape.width) + "x" + std::to_string(shape.height); }

PreparedKernel disparity_fuse_multires_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"min_far", "num_far", "min_near", "num_near", "margin_px"});
  auto prepared = std::make_shared<FuseParams>();
  prepared->min_far = param_int(params, "min_far", 0, -2047, 2046);
  prepared->num_far = param_int(params, "num_far", 64, 1, 2047 - prepared->min_far);
  prepared->min_near = param_int(params, "min_near", 0, -1022, 1022);
  prepared->num_near = param_int(params, "num_near", 64, 1, 1023 - prepared->min_near);
  prepared->margin_px = param_int(params, "margin_px", 1, 0, prepared->num_far - 1);
  const int top = prepared->min_far + prepared->num_far - 1 - prepared->margin_px;
  const int near_top = 2 * (prepared->min_near + prepared->num_near - 1);
  if (near_top <= top) {
    throw KernelError("parameters 'min_near' + 'num_near': expected a near range reaching beyond the trusted far range (2 x " +
                      std::to_string(prepared->min_near + prepared->num_near - 1) + " > " + std::to_string(top) +
                      " full-resolution px), got " + std::to_string(near_top));
  }
  prepared->far_invalid_q4 = static_cast<int16_t>((prepared->min_far - 1) * 16);
  prepared->near_invalid_q4 = static_cast<int16_t>((prepared->min_near - 1) * 16);
  prepared->top_q4 = static_cast<int16_t>(top * 16);
  prepared->output_invalid_q4 = prepared->far_invalid_q4;
  prepared->left_band_half_columns = static_cast<int16_t>(prepared->min_near + prepared->num_near - 1);
  const PlaneShape& full = input_shapes.at(0);
  const PlaneShape expected_half{(full.width + 1) / 2, (full.height + 1) / 2};
  if (!(input_shapes.at(1) == expected_half)) {
    throw KernelError("port 'half': expected half of the full-resolution " + shape_text(full) + " (" +
                      shape_text(expected_half) + "), got " + shape_text(input_shapes[1]));
  }
  PreparedKernel result{prepared, {full}};
  result.input_scales = {InputScale{1, 1}, InputScale{1, 2}};
  return result;
}

KernelDescriptor make_disparity_fuse_multires() {
  KernelDescriptor descriptor;
  descriptor.name = "disparity_fuse_multires";
  descriptor.summary = "fuse full-resolution far-range and half-resolution s16 Q4 disparity (nearest upsampling; the half pass decides near or far)";
  descriptor.ports = {{"full", PortDirection::input, {ElementType::s16, 4}, PortAccess::window},
                      {"half", PortDirection::input, {ElementType::s16, 4}, PortAccess::window},
                      {"fused", PortDirection::output, {ElementType::s16, 4}, PortAccess::window}};
  descriptor.block_width = 2;
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = disparity_fuse_multires_prepare;
  descriptor.counting = disparity_fuse_multires_counting;
  descriptor.reference = disparity_fuse_multires_reference;
  LPSTEREO_FILL_NATIVE_TABLE(disparity_fuse_multires)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(disparity_fuse_multires, lpstereo::kernels::make_disparity_fuse_multires);
#endif
