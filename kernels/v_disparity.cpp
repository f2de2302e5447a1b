// v_disparity: per image row, the histogram of integer disparities (the "V-disparity" image of
// Labayrade, Aubert, Tarel 2002, "Real time obstacle detection in stereovision on non flat road
// geometry through v-disparity representation", IEEE IV; thesis 003 ch. 4 §4.2.1), s16q4 -> u16.
//
// Parameters: min_disparity (int, px, the disparity map's: its invalid value is
//   (min_disparity - 1) * 16, DESIGN.md §4) and num_bins (int, 1 .. 2048; min_disparity + num_bins
//   - 1 <= 2047, the largest integer part of an s16 Q4 value).
// Ports: input "disparity" s16q4, PortAccess::whole (the tile reads whole input rows: a histogram
//   row is a reduction across the row; source_rect reports the tile's rows, all columns); output
//   "histogram" u16 (Q0 counts) of num_bins x the input's height.
// Output format: histogram(b, v) = the number of pixels of row v with floor(d / 16) - min_disparity
//   == b, d the Q4 value (floor = arithmetic shift right by 4, towards -inf), SATURATED at 65535
//   (a count never wraps and is never 8-bit). The invalid value (min_disparity - 1) * 16 lands in
//   bin -1 and values above the last bin or below the first land outside: none of them is counted.
//   min_disparity must therefore be the map's own (a larger one would only drop near-zero bins; a
//   smaller one would count the invalid marker as a disparity). One use does that on purpose: with
//   min_disparity one below the map's and num_bins 1, the one bin holds only the invalid value (the
//   smallest valid Q4 value is the map's min_disparity x 16), so the output is each row's count of
//   invalid pixels: the view check of graphs/obstacles3d-stixels*.json (arm/tasks/disparity_coverage.cpp).
// Width: at most kMaxWidthPx = 65535 * 8 = 524,280 px per row, refused in prepare: the per-lane
//   counts below are u16 and a back end with 8 u16 lanes (SSE4.2, NEON, scalar) puts at most
//   ceil(W / 8) <= 65535 pixels of a row in one lane, so no lane count wraps; the sums over lanes
//   are u32 (<= W < 2^31) and narrowed with saturation. tests/kernels/v_disparity_test.cpp runs a
//   row of exactly kMaxWidthPx pixels of one bin (65535 in every SSE lane: no wrap, output 65535).
//
// Vector schedule. The contract has gather but no scatter, so a pixel cannot increment "its" bin.
// Instead, per bin, compare-and-count over the row: with L = B::kLanesU16 lanes,
//   1. per pass of G = 8 bins (8 accumulators and 8 keys held in registers) over the row, per chunk
//      of L pixels: load, k = d >> 4 (arithmetic), the tail chunk's lanes past the row forced to
//      min_disparity - 1 (no bin) by a select with a per-tile lane mask; then per bin of the pass
//      m = cmpeq(k, min_disparity + b) and acc_b = acc_b - m (a true lane is all ones = -1, so the
//      lane's count grows by one). After the row, the 8 accumulators go to scratch, bin-major
//      (scratch[b L + lane]).
//   2. the merge across lanes, a transpose by gather: for a block of L output bins, two halves of
//      L/2 bins (u32 lanes), sum_i = sum over lanes l of scratch[(b0 + i) L + l], i.e. L gathers with
//      offsets i L from base b0 L + l and L - 1 u32 adds; narrow_sat_u16 of the two halves gives L
//      bins saturated at 65535; one store (partial at the last block).
// Cost per row (G = 8, bins8 = num_bins rounded up to 8, binsL = rounded up to L, C = ceil(W / L),
// t = 1 if W % L != 0 else 0):
//   load    = C bins8 / 8                 (the row once per pass)
//   shift   = C bins8 / 8
//   logic   = t bins8 / 8                 (the tail select)
//   compare = C bins8
//   arith   = C bins8 + (binsL / L) 2 (L - 1)
//   permute = bins8 + binsL / L           (8 key broadcasts per pass; one narrow per block)
//   store   = bins8 + binsL / L           (accumulators to scratch; one output store per block)
//   gather  = (binsL / L) 2 L
// and per tile: load 2 (lane index tables), permute 3 (tail length, no-bin value, zero),
// compare 1 (tail mask), shift 1 (gather offsets i L). Bins past num_bins: the passes count up to
// bins8 (keys past the last bin are ordinary values, their counts are never stored to the output);
// the merge of the last block also sums scratch rows between bins8 and binsL, which hold whatever
// the scratch held (stale, never uninitialised memory outside it) and go only to lanes that
// store_partial leaves unwritten.
// On cv1-class (0.125 cycle per compare/arith, 0.25 per load, 1 per gather) at 3840 x 1728 and 128
// bins: about 4,900 cycles a row, 8.5 M cycles (10.6 ms at 800 MHz) a frame; compare-and-count in
// u8 lanes (64 pixels per op, u8 counts flushed to u16 every 255 chunks) would about halve it.
// So about 2 C num_bins ops per row: 640 px, 64 bins, L = 32: 20 x 64 x 2 = 2560 compare+arith
// against 128 gathers, 126 adds and 74 stores for the merge. Scratch: binsL L u16.
#include <algorithm>
#include <bit>
#include <string>

#include "kernels/kernel.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int kMaxWidthPx = 65535 * 8;  // see the header: no u16 lane count can wrap
constexpr int kBinsPerPass = 8;         // G above
constexpr int kMaxLanesU16 = 32;        // the widest back end's u16 lanes (512-bit), sizes scratch

struct VDisparityParams {
  int min_disparity = 0;  // px, the disparity map's
  int num_bins = 0;
};

alignas(64) constexpr uint16_t kLaneIndexU16[kMaxLanesU16] = {0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10,
                                                             11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21,
                                                             22, 23, 24, 25, 26, 27, 28, 29, 30, 31};
alignas(64) constexpr int32_t kLaneIndexS32[kMaxLanesU16 / 2] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};

constexpr int round_up(int value, int multiple) { return (value + multiple - 1) / multiple * multiple; }

template <class B>
void v_disparity_body(const TileArgs& args) {
  using VU16 = typename B::VU16;
  using VS16 = typename B::VS16;
  using VS32 = typename B::VS32;
  using VU32 = typename B::VU32;
  constexpr int kLanes = B::kLanesU16;
  constexpr int kHalf = B::kLanesU32;
  constexpr int kLanesLog2 = std::countr_zero(static_cast<unsigned>(kLanes));
  static_assert(kLanes <= kMaxLanesU16 && std::has_single_bit(static_cast<unsigned>(kLanes)));

  const auto& params = *static_cast<const VDisparityParams*>(args.params);
  const PlaneView& source = args.inputs[0];  // whole plane
  const PlaneView& destination = args.outputs[0];
  const int width = source.width;
  const int num_bins = params.num_bins;
  const int full_chunks = width / kLanes;
  const int tail = width % kLanes;
  const int passes = (num_bins + kBinsPerPass - 1) / kBinsPerPass;
  const int blocks = (num_bins + kLanes - 1) / kLanes;
  uint16_t* lane_counts = reinterpret_cast<uint16_t*>(args.scratch);  // bin-major, round_up(bins, L) x L

  const VU16 tail_mask = B::cmpgt(B::set1_u16(static_cast<uint16_t>(tail)), B::load(kLaneIndexU16));
  const VS16 no_bin = B::set1_s16(static_cast<int16_t>(params.min_disparity - 1));
  const VU16 zero = B::set1_u16(0);
  const VS32 bin_offsets = B::template shl<kLanesLog2>(B::load(kLaneIndexS32));  // lane i: i L

  for (int y = 0; y < destination.height; ++y) {
    const int16_t* row = plane_row<const int16_t>(source, args.tile_y + y);
    // 1. Per-lane counts, G bins per pass over the row.
    for (int pass = 0; pass < passes; ++pass) {
      const int first_bin = pass * kBinsPerPass;
      VS16 keys[kBinsPerPass];
      VU16 counts[kBinsPerPass];
      for (int j = 0; j < kBinsPerPass; ++j) {
        keys[j] = B::set1_s16(static_cast<int16_t>(params.min_disparity + first_bin + j));
        counts[j] = zero;
      }
      auto count_chunk = [&](const VS16& integer_part) {
        for (int j = 0; j < kBinsPerPass; ++j) {
          counts[j] = B::sub(counts[j], B::as_u16(B::cmpeq(integer_part, keys[j])));
        }
      };
      for (int chunk = 0; chunk < full_chunks; ++chunk) {
        count_chunk(B::template shr<4>(B::load(row + chunk * kLanes)));
      }
      if (tail > 0) {
        const VS16 integer_part = B::template shr<4>(B::load_partial(row + full_chunks * kLanes, tail));
        count_chunk(B::select(B::as_s16(tail_mask), integer_part, no_bin));
      }
      for (int j = 0; j < kBinsPerPass; ++j) B::store(lane_counts + (first_bin + j) * kLanes, counts[j]);
    }
    // 2. The merge across lanes: a transpose by gather, u32 sums, saturating narrow.
    uint16_t* out_row = plane_row<uint16_t>(destination, y);
    for (int block = 0; block < blocks; ++block) {
      VS32 sums[2];
      for (int half = 0; half < 2; ++half) {
        const uint16_t* base = lane_counts + (block * kLanes + half * kHalf) * kLanes;
        VU32 sum = B::gather_u16(base, bin_offsets);
        for (int lane = 1; lane < kLanes; ++lane) sum = B::add(sum, B::gather_u16(base + lane, bin_offsets));
        sums[half] = B::as_s32(sum);
      }
      const VU16 histogram = B::narrow_sat_u16(sums[0], sums[1]);
      const int bins_here = std::min(kLanes, num_bins - block * kLanes);
      if (bins_here == kLanes) {
        B::store(out_row + block * kLanes, histogram);
      } else {
        B::store_partial(out_row + block * kLanes, histogram, bins_here);
      }
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(v_disparity, v_disparity_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(v_disparity)

namespace lpstereo::kernels {
namespace {

void v_disparity_counting(const TileArgs& args) { v_disparity_body<simd::Counting>(args); }

// Scalar reference: one pass over each row, one increment per pixel, saturating at 65535.
void v_disparity_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                           const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const VDisparityParams*>(params_pointer);
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  std::vector<uint32_t> counts(static_cast<size_t>(params.num_bins));
  for (int y = 0; y < source.height; ++y) {
    std::fill(counts.begin(), counts.end(), 0u);
    const int16_t* row = plane_row<const int16_t>(source, y);
    for (int x = 0; x < source.width; ++x) {
      const int bin = (row[x] >> 4) - params.min_disparity;  // floor(d / 16): >> is arithmetic in C++20
      if (bin >= 0 && bin < params.num_bins) ++counts[static_cast<size_t>(bin)];
    }
    uint16_t* out_row = plane_row<uint16_t>(destination, y);
    for (int b = 0; b < params.num_bins; ++b) out_row[b] = static_cast<uint16_t>(std::min<uint32_t>(counts[static_cast<size_t>(b)], 65535u));
  }
}

PreparedKernel v_disparity_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"min_disparity", "num_bins"});
  if (input_shapes.size() != 1) throw KernelError("inputs: expected 1 (disparity), got " + std::to_string(input_shapes.size()));
  auto prepared = std::make_shared<VDisparityParams>();
  prepared->min_disparity = param_int(params, "min_disparity", 0, -2047, 2047);
  prepared->num_bins = param_int(params, "num_bins", 128, 1, 2047 - prepared->min_disparity + 1);
  const PlaneShape& input = input_shapes[0];
  if (input.width > kMaxWidthPx) {
    throw KernelError("input 'disparity': expected a width of at most " + std::to_string(kMaxWidthPx) +
                      " px (u16 per-lane counts, see kernels/v_disparity.cpp), got " + std::to_string(input.width));
  }
  return PreparedKernel{prepared, {{prepared->num_bins, input.height}}};
}

KernelDescriptor make_v_disparity() {
  KernelDescriptor descriptor;
  descriptor.name = "v_disparity";
  descriptor.summary =
      "V-disparity: per row, u16 histogram of integer disparities of an s16q4 map (bin = floor(d/16) - min_disparity), saturating";
  descriptor.ports = {{"disparity", PortDirection::input, {ElementType::s16, 4}, PortAccess::whole},
                      {"histogram", PortDirection::output, {ElementType::u16, 0}, PortAccess::window}};
  descriptor.halo = {0, 0, 0, 0};
  descriptor.border_modes = {BorderMode::replicate};  // no pixel outside the image is ever read
  descriptor.full_width_tiles = true;                 // an output row is one reduction over an input row
  descriptor.prepare = v_disparity_prepare;
  descriptor.scratch_bytes = [](int, int, const void* params_pointer) {
    const auto& params = *static_cast<const VDisparityParams*>(params_pointer);
    return static_cast<size_t>(round_up(params.num_bins, kMaxLanesU16)) * kMaxLanesU16 * sizeof(uint16_t);
  };
  // The tile's rows, every column.
  descriptor.source_rect = [](int, const PixelRect& output_tile, const PlaneShape& input_shape, const void*) {
    return PixelRect{0, output_tile.y0, input_shape.width, output_tile.y1};
  };
  descriptor.counting = v_disparity_counting;
  descriptor.reference = v_disparity_reference;
  LPSTEREO_FILL_NATIVE_TABLE(v_disparity)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(v_disparity, lpstereo::kernels::make_v_disparity);
#endif
