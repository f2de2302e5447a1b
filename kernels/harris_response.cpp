// harris_response: the Harris corner response (C. Harris, M. Stephens, "A combined corner and edge
// detector", Alvey Vision Conference 1988; thesis 003 §3.5, fig. 3.7), in fixed point, u8 -> s32.
//
// Ports: input "image" u8 (window, halo r = 1 + window_size / 2 on every side: 2 or 3), output
//   "response" s32 (Q format below) of the same size.
// Parameters: window_size (3 or 5, default 3: the box window the gradient products are summed
//   over), k_numerator (default 3) and k_shift (0 .. 8, default 6): k = k_numerator / 2^k_shift
//   (default 3/64 = 0.047, inside Harris' usual 0.04 .. 0.06), 1 <= k_numerator <= 2^k_shift (k <= 1).
//
// Steps, per pixel (x, y), in integers:
//   1. Sobel 3x3 gradients (s16, exact): Ix = sum over dy of w(dy) (I(x+1, y+dy) - I(x-1, y+dy)),
//      Iy likewise down the column, w = (1, 2, 1). |Ix|, |Iy| <= 4 * 255 = 1020.
//   2. products Ix^2, Iy^2, Ix Iy (s32, exact): |each| <= 1020^2 = 1,040,400.
//   3. box sums over the window_size^2 window centred on (x, y): Sxx, Syy, Sxy (s32, exact):
//      |each| <= n 1,040,400 with n = 9 or 25: 9,363,600 or 26,010,000, far inside s32.
//   4. scaled to 15 bits: a = Sxx >> s, c = Syy >> s, b = Sxy >> s (arithmetic shift: floor),
//      s = 9 (window 3) or 11 (window 5), so 0 <= a, c <= A and -(A + 1) <= b <= A with
//      A = 18,288 (9,363,600 >> 9) or 12,700 (26,010,000 >> 11).
//   5. det = a c - b^2, t = a + c, R = det - k_numerator ((t t) >> k_shift).
// No-overflow proof (window 3, the larger A; window 5 is smaller in every line):
//   a c <= A^2 = 334,450,944; b^2 <= (A + 1)^2 = 334,487,521; t <= 2A = 36,576, t t <= 1,337,803,776
//   < 2^31 - 1 = 2,147,483,647; k_numerator ((t t) >> k_shift) <= t t because k_numerator <= 2^k_shift;
//   so -1,672,291,297 <= R <= 334,450,944: every intermediate and R fit s32, nothing saturates.
//   tests/kernels/harris_response_test.cpp recomputes R in 64 bits on 0/255 checkerboards, stripes
//   and corners (the extreme gradients) and checks the bound and the kernel's bits.
// Output format: s32, 0 fraction bits, in units of 2^(2 s) (Sobel gradient)^4 (the Sobel gradient
//   is 8 times the intensity derivative per pixel); > 0 at corners, < 0 along edges, ~0 on flat areas.
//   Thresholds (harris_nms) are in the same units, so they depend on window_size.
// Border rule: a pixel whose footprint (its window of Sobel 3x3 neighbourhoods, (2r + 1)^2 pixels)
//   leaves the image, i.e. x < r, y < r, x >= W - r or y >= H - r, gets R = 0. The response never
//   depends on a pixel outside the image, so it is the same for every border mode (both are
//   accepted; the executor's halo is read but masked out).
//
// Vector schedule, per tile (w = window_size, h = w / 2, E = tile_height + 2h rows of gradients,
// L8 / L16 / L32 = B::kLanesU8 / U16 / U32):
//   per tile, the column mask (-1 where r <= x < W - r) into scratch, chunks of L32 columns: 1
//     broadcast, 1 add (lane index), 2 compares, 1 and, 1 store.
//   A1. per gradient row, chunks of L8 pixels over columns [-h, tile_width + h): 8 u8 loads (rows
//       y-1, y+1 at columns x-1, x, x+1; row y at x-1, x+1), each widened to two s16 halves (16
//       permutes); per half Ix, Iy (5 arith and 2 shifts each) widened to two s32 quarters each
//       (4 permutes), 6 mullo (the three products of two quarters), 6 stores to three product
//       rows in scratch.
//   A2. the first 2h gradient rows only, chunks of L32 over [0, tile_width): per product w loads at
//       x, x+1 .. x+2h and w - 1 adds (the horizontal box sum), one store into a ring of w rows
//       (slot: gradient row mod w).
//   B.  every further gradient row gives output row y = e - 2h, chunks of L32: per product the
//       horizontal sum as in A2 (w loads, w - 1 adds), stored into the ring (1 store), plus the
//       ring's other w - 1 rows (w - 1 loads, w - 1 adds); 3 shifts (>> s); 4 mullo (a c, b b,
//       t t, k_numerator x); 3 arith (det, t, R); 1 shift (>> k_shift); the border mask: 1 load
//       (column mask) and 2 ands (row mask, R); 1 store. Per output row 1 broadcast (row mask).
// Op count per tile (closed form, checked by tests/kernels/harris_response_test.cpp), with
// C1 = ceil((tile_width + 2h) / L8), C2 = ceil(tile_width / L32), T = tile_height:
//   load     = 1 + E C1 8 + 2h C2 3w + T C2 (3w + 3(w - 1) + 1)      (1: the lane index table)
//   store    = C2 + E C1 12 + 2h C2 3 + T C2 4
//   arith    = C2 + E C1 20 + 2h C2 3(w - 1) + T C2 (6(w - 1) + 3)
//   shift    = E C1 8 + T C2 4
//   multiply = E C1 12 + T C2 4
//   permute  = 3 + C2 + E C1 24 + T                  (3: bounds and k_numerator; T: row masks)
//   compare  = 2 C2
//   logic    = C2 + T C2 2
// On cv1-class (0.25 cycle per load, store, multiply, permute; 0.125 per arith, shift, compare,
// logic) that is about 0.85 cycle a pixel with window 3 (5.66 M cycles at 3840 x 1728).
// Scratch: 4 bytes x (3 round_up(tile_width + 2h, 64) + (3 w + 1) round_up(tile_width, 64)).
#include <algorithm>
#include <string>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

struct HarrisResponseParams {
  int window_size = 3;
  int k_numerator = 3;
  int k_shift = 6;
};

constexpr int kMaxLanesU32 = 16;  // the widest back end's s32 lanes (512-bit)
constexpr int kRowAlign = 64;     // product and ring rows are rounded up to this many elements

alignas(64) constexpr int32_t kLaneIndexS32[kMaxLanesU32] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};

constexpr int round_up(int value, int multiple) { return (value + multiple - 1) / multiple * multiple; }

// The sum shift s of step 4 for a window size.
constexpr int sum_shift(int window_size) { return window_size == 3 ? 9 : 11; }

// v >> shift for a shift known at run time (0 .. 8); one shift op.
template <class B>
typename B::VS32 shift_right(const typename B::VS32& v, int shift) {
  switch (shift) {
    case 0: return B::template shr<0>(v);
    case 1: return B::template shr<1>(v);
    case 2: return B::template shr<2>(v);
    case 3: return B::template shr<3>(v);
    case 4: return B::template shr<4>(v);
    case 5: return B::template shr<5>(v);
    case 6: return B::template shr<6>(v);
    case 7: return B::template shr<7>(v);
    default: return B::template shr<8>(v);
  }
}

template <class B, int kWindow>
void harris_response_tile(const TileArgs& args) {
  using VU8 = typename B::VU8;
  using VS16 = typename B::VS16;
  using VS32 = typename B::VS32;
  constexpr int kLanes8 = B::kLanesU8;
  constexpr int kLanes16 = B::kLanesU16;
  constexpr int kLanes32 = B::kLanesU32;
  constexpr int kHalf = kWindow / 2;
  constexpr int kRadius = kHalf + 1;
  constexpr int kSumShift = sum_shift(kWindow);
  static_assert(kLanes32 <= kMaxLanesU32);

  const auto& params = *static_cast<const HarrisResponseParams*>(args.params);
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int height = destination.height;
  const int readable_end = width + kRadius;
  const int product_width = width + 2 * kHalf;  // product columns [-h, width + h)
  const int product_stride = round_up(product_width, kRowAlign);
  const int ring_stride = round_up(width, kRowAlign);
  int32_t* products[3];
  for (int p = 0; p < 3; ++p) products[p] = reinterpret_cast<int32_t*>(args.scratch) + p * product_stride;
  int32_t* ring = reinterpret_cast<int32_t*>(args.scratch) + 3 * product_stride;  // [product][slot][column]
  auto ring_row = [&](int product, int slot) { return ring + (product * kWindow + slot) * ring_stride; };
  int32_t* column_mask = ring + 3 * kWindow * ring_stride;  // -1 where r <= x < W - r, else 0

  const VS32 lane_index = B::load(kLaneIndexS32);
  const VS32 low_bound = B::set1_s32(kRadius - 1);                  // x > r - 1
  const VS32 high_bound = B::set1_s32(args.image_width - kRadius);  // x < W - r
  const VS32 k_numerator = B::set1_s32(params.k_numerator);
  for (int x = 0; x < width; x += kLanes32) {
    const VS32 column = B::add(B::set1_s32(args.tile_x + x), lane_index);
    store_clipped<B>(column_mask, x, width, B::bit_and(B::cmpgt(column, low_bound), B::cmplt(column, high_bound)));
  }

  // The horizontal box sum of product p at columns [x, x + L32) of the current product row.
  auto horizontal_sum = [&](int p, int x) {
    VS32 sum = load_clipped<B>(products[p], x, product_width);
    for (int j = 1; j < kWindow; ++j) sum = B::add(sum, load_clipped<B>(products[p], x + j, product_width));
    return sum;
  };

  for (int e = 0; e < height + 2 * kHalf; ++e) {
    const int gradient_row = e - kHalf;  // tile-relative image row of this row of gradients
    const uint8_t* rows[3] = {plane_row<const uint8_t>(source, gradient_row - 1), plane_row<const uint8_t>(source, gradient_row),
                              plane_row<const uint8_t>(source, gradient_row + 1)};
    // A1: gradients and their products, L8 columns a chunk (two s16 halves, four s32 quarters).
    for (int c = -kHalf; c < width + kHalf; c += kLanes8) {
      VS16 taps[2][3][3];  // [half][row][dx + 1]; the centre tap taps[h][1][1] is not used
      for (int row = 0; row < 3; ++row) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (row == 1 && dx == 0) continue;
          const VU8 bytes = load_clipped<B>(rows[row], c + dx, readable_end);
          taps[0][row][dx + 1] = B::as_s16(B::widen_lo(bytes));
          taps[1][row][dx + 1] = B::as_s16(B::widen_hi(bytes));
        }
      }
      for (int half = 0; half < 2; ++half) {
        const auto& t = taps[half];
        const VS16 gradient_x = B::sub(B::add(B::add(t[0][2], t[2][2]), B::template shl<1>(t[1][2])),
                                       B::add(B::add(t[0][0], t[2][0]), B::template shl<1>(t[1][0])));
        const VS16 gradient_y = B::sub(B::add(B::add(t[2][0], t[2][2]), B::template shl<1>(t[2][1])),
                                       B::add(B::add(t[0][0], t[0][2]), B::template shl<1>(t[0][1])));
        const VS32 x_quarters[2] = {B::widen_lo(gradient_x), B::widen_hi(gradient_x)};
        const VS32 y_quarters[2] = {B::widen_lo(gradient_y), B::widen_hi(gradient_y)};
        for (int quarter = 0; quarter < 2; ++quarter) {
          const int column = c + kHalf + half * kLanes16 + quarter * kLanes32;
          store_clipped<B>(products[0], column, product_width, B::mullo(x_quarters[quarter], x_quarters[quarter]));
          store_clipped<B>(products[1], column, product_width, B::mullo(y_quarters[quarter], y_quarters[quarter]));
          store_clipped<B>(products[2], column, product_width, B::mullo(x_quarters[quarter], y_quarters[quarter]));
        }
      }
    }
    const int slot = e % kWindow;
    if (e < 2 * kHalf) {
      // A2 (the first 2h rows): horizontal box sums into the ring.
      for (int x = 0; x < width; x += kLanes32) {
        for (int p = 0; p < 3; ++p) store_clipped<B>(ring_row(p, slot), x, width, horizontal_sum(p, x));
      }
      continue;
    }
    // B: this row's horizontal sums (kept in the ring for the next rows) plus the ring's other
    // w - 1 rows give the box sums; then the response and the border mask.
    const int y = e - 2 * kHalf;
    const int image_y = args.tile_y + y;
    const bool row_inside = image_y >= kRadius && image_y < args.image_height - kRadius;
    const VS32 row_mask = B::set1_s32(row_inside ? -1 : 0);
    int32_t* out_row = plane_row<int32_t>(destination, y);
    for (int x = 0; x < width; x += kLanes32) {
      VS32 sums[3];
      for (int p = 0; p < 3; ++p) {
        const VS32 newest = horizontal_sum(p, x);
        store_clipped<B>(ring_row(p, slot), x, width, newest);
        sums[p] = newest;
        for (int s = 0; s < kWindow; ++s) {
          if (s != slot) sums[p] = B::add(sums[p], load_clipped<B>(ring_row(p, s), x, width));
        }
      }
      const VS32 a = B::template shr<kSumShift>(sums[0]);
      const VS32 c = B::template shr<kSumShift>(sums[1]);
      const VS32 b = B::template shr<kSumShift>(sums[2]);
      const VS32 determinant = B::sub(B::mullo(a, c), B::mullo(b, b));
      const VS32 trace = B::add(a, c);
      const VS32 trace_term = B::mullo(k_numerator, shift_right<B>(B::mullo(trace, trace), params.k_shift));
      const VS32 response = B::sub(determinant, trace_term);
      const VS32 inside = B::bit_and(load_clipped<B>(column_mask, x, width), row_mask);
      store_clipped<B>(out_row, x, width, B::bit_and(response, inside));
    }
  }
}

template <class B>
void harris_response_body(const TileArgs& args) {
  const auto& params = *static_cast<const HarrisResponseParams*>(args.params);
  if (params.window_size == 3) {
    harris_response_tile<B, 3>(args);
  } else {
    harris_response_tile<B, 5>(args);
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(harris_response, harris_response_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(harris_response)

namespace lpstereo::kernels {
namespace {

void harris_response_counting(const TileArgs& args) { harris_response_body<simd::Counting>(args); }

// Scalar reference: the steps of the header per pixel, reading only pixels inside the image.
void harris_response_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                               const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const HarrisResponseParams*>(params_pointer);
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  const int half = params.window_size / 2;
  const int radius = half + 1;
  const int shift = sum_shift(params.window_size);
  auto pixel = [&](int x, int y) -> int32_t { return plane_row<const uint8_t>(source, y)[x]; };
  for (int y = 0; y < destination.height; ++y) {
    int32_t* out_row = plane_row<int32_t>(destination, y);
    for (int x = 0; x < destination.width; ++x) {
      if (x < radius || y < radius || x >= destination.width - radius || y >= destination.height - radius) {
        out_row[x] = 0;
        continue;
      }
      int32_t sum_xx = 0, sum_yy = 0, sum_xy = 0;
      for (int v = y - half; v <= y + half; ++v) {
        for (int u = x - half; u <= x + half; ++u) {
          const int32_t gradient_x = (pixel(u + 1, v - 1) + 2 * pixel(u + 1, v) + pixel(u + 1, v + 1)) -
                                     (pixel(u - 1, v - 1) + 2 * pixel(u - 1, v) + pixel(u - 1, v + 1));
          const int32_t gradient_y = (pixel(u - 1, v + 1) + 2 * pixel(u, v + 1) + pixel(u + 1, v + 1)) -
                                     (pixel(u - 1, v - 1) + 2 * pixel(u, v - 1) + pixel(u + 1, v - 1));
          sum_xx += gradient_x * gradient_x;
          sum_yy += gradient_y * gradient_y;
          sum_xy += gradient_x * gradient_y;
        }
      }
      const int32_t a = sum_xx >> shift, c = sum_yy >> shift, b = sum_xy >> shift;
      const int32_t trace = a + c;
      out_row[x] = a * c - b * b - params.k_numerator * ((trace * trace) >> params.k_shift);
    }
  }
}

PreparedKernel harris_response_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"window_size", "k_numerator", "k_shift"});
  if (input_shapes.size() != 1) throw KernelError("inputs: expected 1 (image), got " + std::to_string(input_shapes.size()));
  auto prepared = std::make_shared<HarrisResponseParams>();
  prepared->window_size = param_int(params, "window_size", 3, 3, 5);
  if (prepared->window_size != 3 && prepared->window_size != 5) {
    throw KernelError("parameter 'window_size': expected 3 or 5, got " + std::to_string(prepared->window_size));
  }
  prepared->k_shift = param_int(params, "k_shift", 6, 0, 8);
  prepared->k_numerator = param_int(params, "k_numerator", 3, 1, 1 << prepared->k_shift);
  const int radius = prepared->window_size / 2 + 1;
  PreparedKernel result{prepared, {input_shapes[0]}};
  result.input_halos = {Halo{radius, radius, radius, radius}};
  return result;
}

KernelDescriptor make_harris_response() {
  KernelDescriptor descriptor;
  descriptor.name = "harris_response";
  descriptor.summary =
      "Harris corner response in fixed point: Sobel gradients, box-summed products (3x3 or 5x5), R = det - k trace^2 (s32, 0 at the border)";
  descriptor.ports = {{"image", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"response", PortDirection::output, {ElementType::s32, 0}, PortAccess::window}};
  descriptor.halo = {3, 3, 3, 3};  // window 5; window 3 prepares a halo of 2
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = harris_response_prepare;
  descriptor.scratch_bytes = [](int tile_width, int, const void* params_pointer) {
    const auto& params = *static_cast<const HarrisResponseParams*>(params_pointer);
    const int half = params.window_size / 2;
    return sizeof(int32_t) * (3 * static_cast<size_t>(round_up(tile_width + 2 * half, kRowAlign)) +
                              (3 * static_cast<size_t>(params.window_size) + 1) * round_up(tile_width, kRowAlign));
  };
  descriptor.counting = harris_response_counting;
  descriptor.reference = harris_response_reference;
  LPSTEREO_FILL_NATIVE_TABLE(harris_response)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(harris_response, lpstereo::kernels::make_harris_response);
#endif
