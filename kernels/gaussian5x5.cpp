// gaussian5x5: 5x5 binomial smoothing (the Gaussian of sigma = 1 as the binomial kernel
// [1 4 6 4 1] / 16 in each direction), u8 -> u8. The low-pass brief256 expects before it compares
// single pixels (Calonder et al., ECCV 2010, §4.1: smoothing makes BRIEF robust to noise);
// graphs/features.json feeds brief256 from it.
//
// Ports: input "input" u8 (window, halo 2 on every side), output "output" u8 of the same size.
// Border modes: replicate and constant (the executor fills the halo; constant pixels take the low
// byte of border_value). No parameters.
// Fixed point: out = (sum over the 5x5 window of w(dx) w(dy) I + 128) >> 8, w = (1, 4, 6, 4, 1):
//   the exact weighted sum rounded half up. The column sums v = sum w(dy) I <= 16 x 255 = 4080 and
//   the full sum <= 256 x 255 = 65,280 (+ 128 = 65,408) fit u16, so every step is exact in u16
//   lanes and the result is <= 255: no saturation anywhere (tests/kernels/gaussian5x5_test.cpp
//   runs the all-255 image and 0/255 checkerboards).
//
// Vector schedule, per output row (L8 = B::kLanesU8, L16 = L8 / 2):
//   vertical, chunks of L8 columns over [-2, tile_width + 2): 5 u8 loads (rows y-2 .. y+2), each
//     widened to two u16 halves (10 permutes); per half (r0 + r4) + ((r1 + r3) << 2) + (r2 << 2) +
//     (r2 << 1): 5 adds and 3 shifts; 2 stores into a u16 scratch row;
//   horizontal, chunks of L8 output pixels: per half 5 loads from the scratch row (columns x-2 ..
//     x+2), the same 5 adds and 3 shifts, + 128 (1 add) and >> 8 (1 shift); the halves narrowed to
//     u8 (1 permute), 1 store.
// Op count (closed form, checked by tests/kernels/gaussian5x5_test.cpp), per tile row with
// Cv = ceil((tile_width + 4) / L8) and Ch = ceil(tile_width / L8):
//   load = 5 Cv + 10 Ch, permute = 10 Cv + Ch, arith = 10 Cv + 12 Ch, shift = 6 Cv + 8 Ch,
//   store = 2 Cv + Ch;  and per tile 1 permute (the broadcast of 128).
// Scratch: 2 bytes x (round_up(tile_width + 4, 64) + 64): one row of column sums.
#include <string>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int round_up(int value, int multiple) { return (value + multiple - 1) / multiple * multiple; }

// (a + e) + ((b + d) << 2) + (c << 2) + (c << 1): the binomial [1 4 6 4 1]; 5 adds, 3 shifts.
template <class B>
typename B::VU16 binomial5(const typename B::VU16& a, const typename B::VU16& b, const typename B::VU16& c,
                           const typename B::VU16& d, const typename B::VU16& e) {
  const typename B::VU16 outer = B::add(a, e);
  const typename B::VU16 inner = B::template shl<2>(B::add(b, d));
  const typename B::VU16 centre = B::add(B::template shl<2>(c), B::template shl<1>(c));
  return B::add(B::add(outer, inner), centre);
}

template <class B>
void gaussian5x5_body(const TileArgs& args) {
  using VU8 = typename B::VU8;
  using VU16 = typename B::VU16;
  constexpr int kLanes8 = B::kLanesU8;
  constexpr int kLanes16 = B::kLanesU16;
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int readable_end = width + 2;
  const int column_sums_width = width + 4;  // columns [-2, width + 2)
  uint16_t* column_sums = reinterpret_cast<uint16_t*>(args.scratch);
  const VU16 half = B::set1_u16(128);

  for (int y = 0; y < destination.height; ++y) {
    const uint8_t* rows[5];
    for (int dy = -2; dy <= 2; ++dy) rows[dy + 2] = plane_row<const uint8_t>(source, y + dy);
    for (int c = -2; c < width + 2; c += kLanes8) {
      VU16 low[5], high[5];
      for (int r = 0; r < 5; ++r) {
        const VU8 bytes = load_clipped<B>(rows[r], c, readable_end);
        low[r] = B::widen_lo(bytes);
        high[r] = B::widen_hi(bytes);
      }
      store_clipped<B>(column_sums, c + 2, column_sums_width, binomial5<B>(low[0], low[1], low[2], low[3], low[4]));
      store_clipped<B>(column_sums, c + 2 + kLanes16, column_sums_width, binomial5<B>(high[0], high[1], high[2], high[3], high[4]));
    }
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    for (int x = 0; x < width; x += kLanes8) {
      VU16 halves[2];
      for (int part = 0; part < 2; ++part) {
        VU16 taps[5];
        // Scratch column x + dx + 2 holds the column sum of image column x + dx.
        for (int dx = 0; dx < 5; ++dx) taps[dx] = load_clipped<B>(column_sums, x + part * kLanes16 + dx, column_sums_width);
        halves[part] = B::template shr<8>(B::add(binomial5<B>(taps[0], taps[1], taps[2], taps[3], taps[4]), half));
      }
      store_clipped<B>(out_row, x, width, B::narrow_sat_u8(halves[0], halves[1]));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(gaussian5x5, gaussian5x5_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(gaussian5x5)

namespace lpstereo::kernels {
namespace {

void gaussian5x5_counting(const TileArgs& args) { gaussian5x5_body<simd::Counting>(args); }

// Scalar reference: the 25 weighted pixels (border applied here), rounded half up.
void gaussian5x5_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs, const void*,
                           BorderMode border_mode, uint32_t border_value) {
  static constexpr int kWeights[5] = {1, 4, 6, 4, 1};
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) {
      int sum = 0;
      for (int dy = -2; dy <= 2; ++dy) {
        for (int dx = -2; dx <= 2; ++dx) {
          sum += kWeights[dx + 2] * kWeights[dy + 2] * reference_pixel_u8(source, x + dx, y + dy, border_mode, border_value);
        }
      }
      plane_row<uint8_t>(destination, y)[x] = static_cast<uint8_t>((sum + 128) >> 8);
    }
  }
}

KernelDescriptor make_gaussian5x5() {
  KernelDescriptor descriptor;
  descriptor.name = "gaussian5x5";
  descriptor.summary = "5x5 binomial smoothing (Gaussian, sigma 1), exact in u16, rounded half up";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.halo = {2, 2, 2, 2};
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = [](const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
    check_param_names(params, {});
    if (input_shapes.size() != 1) throw KernelError("inputs: expected 1 (input), got " + std::to_string(input_shapes.size()));
    return PreparedKernel{nullptr, {input_shapes.at(0)}};
  };
  descriptor.scratch_bytes = [](int tile_width, int, const void*) {
    return sizeof(uint16_t) * (static_cast<size_t>(round_up(tile_width + 4, 64)) + 64);
  };
  descriptor.counting = gaussian5x5_counting;
  descriptor.reference = gaussian5x5_reference;
  LPSTEREO_FILL_NATIVE_TABLE(gaussian5x5)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(gaussian5x5, lpstereo::kernels::make_gaussian5x5);
#endif
