// vldh_mask: the obstacle mask of the obstacle detector (thesis 003 §4.2.2): the vertically local
// disparity histogram (VLDH) of Kakegawa et al. (thesis 003 eq. 4.1, VLDH(u, v, d) = sum over j < N
// of delta(D(u, v + j), d)) evaluated at each pixel's own disparity, restricted to the image region
// the road profile says can hold obstacles, with the points the road profile explains dropped.
// s16q4 disparity + road record -> u8 mask (values in kernels/obstacle_mask.h).
//
// Ports: input "disparity" s16q4 (window; halo window_rows - 1 rows BELOW the tile, set per node in
//   prepare as PreparedKernel::input_halos, so the kernel tiles like any window kernel); input
//   "road" s32 record of kRoadProfileWords x 1 (arm/tasks/road_profile.h; PortAccess::whole: every
//   tile reads the whole 48-byte record); output "mask" u8 of the disparity's size.
// Parameters (prepare refuses others and out-of-range values, KernelError naming the parameter):
//   min_disparity (int px, the map's, -2047 .. 2047, default 0), window_rows N (1 .. 32, default 4),
//   match_tolerance_q4 (0 .. 255, default 4), min_count (1 .. window_rows, default 3),
//   road_margin_q4 (0 .. 1023, default 8), road_margin_per_mille (0 .. 1000, default 20),
//   rows_above_horizon (0 .. 4096, default 64).
//
// Formats. Disparity D: s16 Q4 (value / 16 px); valid means D >= 16 min_disparity, so the invalid
// marker (min_disparity - 1) * 16 (DESIGN.md §4) and anything below the map's range is invalid.
// Road record words (s32): kRoadValid (1 = a road), kRoadSlopeQ16 / kRoadInterceptQ16 (Q15.16 px
// per row / px: d(v) = slope v + intercept), kRoadHorizonRowQ8 (Q23.8 row). Mask: u8, 0 / 1 / 2.
//
// Semantics for pixel (u, v), v the row in the full image, H the image height, D = D(u, v):
//   kMaskNoVote (0) if the record is not valid (kRoadValid != 1: never a made-up road), or D is
//     invalid, or v < horizon_row - rows_above_horizon (above the region that can hold obstacles).
//     The first voting row is ceil((horizon_q8 - 256 rows_above_horizon) / 256), exact in int64.
//   count = #{ j in 0 .. N-1 : v + j < H, D(u, v + j) valid, |D(u, v + j) - D| <= match_tolerance_q4 }
//     (j = 0 counts itself): eq. 4.1 at the pixel's own disparity bin, with the bin CENTRED on the
//     pixel's disparity (width 2 tolerance + 1 in Q4). A fixed quantisation of d would split an
//     obstacle whose disparity sits on a bin edge into two half-counted bins (a 1/16 px noise
//     flips pixels across the edge); a centred bin counts every pixel within the tolerance.
//     Rows past the image bottom are never counted (the halo the executor fills is not read).
//   road_q4(v) = floor((slope_q16 v + intercept_q16 + 2048) / 4096): the road's disparity in Q4,
//     Q16 -> Q4 rounded half up, exact in int64 (|slope_q16 v| < 2^31 2^16).
//   margin_q4(v) = road_margin_q4 + floor(road_margin_per_mille max(road_q4(v), 0) / 1000): a fixed
//     margin plus a share of the road disparity (disparity noise grows with disparity), int64.
//   kMaskObstacle (2) if count >= min_count and D > road_q4(v) + margin_q4(v) (the threshold is
//     clamped to the s16 range, which changes no comparison with a valid s16 D); else kMaskFree (1).
// Every value is exact integer arithmetic: no rounding but the two documented above, no saturation.
// Overflow: |D(u, v + j) - D| is taken as absdiff of the u16 values D ^ 0x8000 (order preserving,
// exact for any two s16 values, no wrap); count <= N <= 32 fits any lane; the per-row threshold is
// computed in int64 (|slope_q16 v| < 2^31 2^31 = 2^62 for v < 2^31, plus |intercept| < 2^31 and a
// margin of at most 1000 |road_q4| + 1023 < 2^61: no int64 overflow) and then clamped.
//
// Vector schedule: per output row, scalar per-row set-up (record words read once per tile, the row's
// threshold and whether the row votes: the vector engine's scalar unit, not counted), then chunks of
// L = B::kLanesU16 pixels (the last one partial: load_partial / store_partial):
//   d = D(u, v), valid = d > 16 min - 1, db = d ^ 0x8000, count = 1 (j = 0: itself)
//   for j = 1 .. J(v) - 1, J(v) = min(N, H - v): dj = D(u, v + j);
//     count -= (absdiff(dj ^ 0x8000, db) < tolerance + 1) & (dj > 16 min - 1)
//   obstacle = (count > min_count - 1) & (d > threshold(v)) & valid
//   mask16 = (0 - valid) - obstacle (0, 1 or 2), narrowed to u8 with saturation, stored (L bytes).
// Cost per chunk of a voting row (J = J(v)):
//   load    = J
//   logic   = 2 J + 1    (xor per row loaded, and per neighbour, and twice for obstacle)
//   arith   = 2 J        (absdiff and count per neighbour, 2 for the mask)
//   compare = 2 J + 1    (valid, tolerance and validity per neighbour, count and threshold)
//   permute = 1          (narrow)
//   store   = 1
// per voting row: permute 1 (broadcast of the threshold); per chunk of a row that does not vote
// (road invalid, or above the region): store 1. Per tile: permute 7 (constant broadcasts).
// On cv1-class (L = 32, 0.125 cycle per ALU op, 0.25 per load/store/permute) with N = 4: 26 ALU ops
// + 4 loads + 2 permute/store per 32 pixels, about 4.75 cycles, 0.15 cycle a pixel: at 3840 x 1728
// with every row voting 0.99 M cycles, 1.2 ms at 800 MHz (rows above the region cost a store only).
// tests/kernels/vldh_mask_test.cpp checks these counts in closed form.
#include <algorithm>
#include <cstdint>
#include <string>

#include "kernels/kernel.h"
#include "kernels/obstacle_mask.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

// The record's words this kernel reads (arm/tasks/road_profile.h; the ISA units do not include that
// header, which pulls in dag/plane.h's inline code; the baseline unit static_asserts these).
constexpr int kWordValid = 0;
constexpr int kWordSlopeQ16 = 3;
constexpr int kWordInterceptQ16 = 4;
constexpr int kWordHorizonRowQ8 = 5;
constexpr int kRecordWords = 12;

struct VldhMaskParams {
  int min_disparity = 0;
  int window_rows = 4;
  int match_tolerance_q4 = 4;
  int min_count = 3;
  int road_margin_q4 = 8;
  int road_margin_per_mille = 20;
  int rows_above_horizon = 64;
};

// What one image row needs from the road record: whether it votes, and its obstacle threshold in Q4.
struct RoadRow {
  bool votes = false;
  int16_t threshold_q4 = 0;  // road_q4(v) + margin_q4(v), clamped to the s16 range
};

struct RoadLine {
  bool valid = false;
  int64_t slope_q16 = 0, intercept_q16 = 0;
  int64_t first_row = 0;  // the first image row that can hold obstacles
};

inline RoadLine read_road_line(const PlaneView& record, const VldhMaskParams& params) {
  const int32_t* words = plane_row<const int32_t>(record, 0);
  RoadLine line;
  line.valid = words[kWordValid] == 1;
  line.slope_q16 = words[kWordSlopeQ16];
  line.intercept_q16 = words[kWordInterceptQ16];
  // ceil(x / 256) = -floor(-x / 256); >> is arithmetic (floor) on int64 in C++20.
  const int64_t first_row_q8 = int64_t{words[kWordHorizonRowQ8]} - int64_t{256} * params.rows_above_horizon;
  line.first_row = -((-first_row_q8) >> 8);
  return line;
}

inline RoadRow road_row(const RoadLine& line, const VldhMaskParams& params, int64_t row) {
  RoadRow result;
  result.votes = line.valid && row >= line.first_row;
  const int64_t road_q4 = (line.slope_q16 * row + line.intercept_q16 + 2048) >> 12;  // Q16 -> Q4, half up
  const int64_t margin_q4 = params.road_margin_q4 + params.road_margin_per_mille * std::max<int64_t>(road_q4, 0) / 1000;
  result.threshold_q4 = static_cast<int16_t>(std::clamp<int64_t>(road_q4 + margin_q4, -32768, 32767));
  return result;
}

template <class B>
void vldh_mask_body(const TileArgs& args) {
  using VU8 = typename B::VU8;
  using VU16 = typename B::VU16;
  using VS16 = typename B::VS16;
  constexpr int kLanes = B::kLanesU16;

  const auto& params = *static_cast<const VldhMaskParams*>(args.params);
  const PlaneView& disparity = args.inputs[0];  // the tile plus window_rows - 1 rows below
  const PlaneView& destination = args.outputs[0];
  const RoadLine line = read_road_line(args.inputs[1], params);
  const int width = destination.width;
  const int full_chunks = width / kLanes;
  const int tail = width % kLanes;

  const VS16 below_valid = B::set1_s16(static_cast<int16_t>(16 * params.min_disparity - 1));
  const VU16 sign_bit = B::set1_u16(0x8000);
  const VU16 tolerance_plus_one = B::set1_u16(static_cast<uint16_t>(params.match_tolerance_q4 + 1));
  const VU16 min_count_minus_one = B::set1_u16(static_cast<uint16_t>(params.min_count - 1));
  const VU16 one = B::set1_u16(1);
  const VU16 zero = B::set1_u16(0);
  const VU8 no_vote = B::set1_u8(kMaskNoVote);

  for (int y = 0; y < destination.height; ++y) {
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    const int64_t image_row = int64_t{args.tile_y} + y;
    const RoadRow road = road_row(line, params, image_row);
    if (!road.votes) {
      for (int chunk = 0; chunk < full_chunks; ++chunk) B::store_partial(out_row + chunk * kLanes, no_vote, kLanes);
      if (tail > 0) B::store_partial(out_row + full_chunks * kLanes, no_vote, tail);
      continue;
    }
    const VS16 threshold = B::set1_s16(road.threshold_q4);
    const int rows_in_window = static_cast<int>(std::min<int64_t>(params.window_rows, args.image_height - image_row));
    auto mask_chunk = [&](int x, int lanes) {
      auto load_row = [&](int j) {
        const int16_t* source = plane_row<const int16_t>(disparity, y + j) + x;
        return lanes == kLanes ? B::load(source) : B::load_partial(source, lanes);
      };
      const VS16 centre = load_row(0);
      const VS16 valid = B::cmpgt(centre, below_valid);
      const VU16 centre_biased = B::bit_xor(B::as_u16(centre), sign_bit);
      VU16 count = one;
      for (int j = 1; j < rows_in_window; ++j) {
        const VS16 neighbour = load_row(j);
        const VU16 difference = B::absdiff(B::bit_xor(B::as_u16(neighbour), sign_bit), centre_biased);
        const VU16 match = B::bit_and(B::cmpgt(tolerance_plus_one, difference), B::as_u16(B::cmpgt(neighbour, below_valid)));
        count = B::sub(count, match);
      }
      const VU16 obstacle = B::bit_and(B::bit_and(B::cmpgt(count, min_count_minus_one), B::as_u16(B::cmpgt(centre, threshold))),
                                       B::as_u16(valid));
      const VU16 mask = B::sub(B::sub(zero, B::as_u16(valid)), obstacle);  // 0, 1 (free) or 2 (obstacle)
      B::store_partial(out_row + x, B::narrow_sat_u8(mask, zero), lanes);
    };
    for (int chunk = 0; chunk < full_chunks; ++chunk) mask_chunk(chunk * kLanes, kLanes);
    if (tail > 0) mask_chunk(full_chunks * kLanes, tail);
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(vldh_mask, vldh_mask_body)

#if LPSTEREO_ISA_TU == 0
#include "arm/tasks/road_profile.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(vldh_mask)

namespace lpstereo::kernels {
namespace {

static_assert(kWordValid == arm::kRoadValid && kWordSlopeQ16 == arm::kRoadSlopeQ16 &&
              kWordInterceptQ16 == arm::kRoadInterceptQ16 && kWordHorizonRowQ8 == arm::kRoadHorizonRowQ8 &&
              kRecordWords == arm::kRoadProfileWords);

void vldh_mask_counting(const TileArgs& args) { vldh_mask_body<simd::Counting>(args); }

// Scalar reference: the semantics of the header, pixel by pixel, in plain int64 arithmetic.
void vldh_mask_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                         const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const VldhMaskParams*>(params_pointer);
  const PlaneView& disparity = inputs[0];
  const int32_t* words = plane_row<const int32_t>(inputs[1], 0);
  const PlaneView& destination = outputs[0];
  const bool road_valid = words[arm::kRoadValid] == 1;
  const double horizon_row = words[arm::kRoadHorizonRowQ8] / 256.0;  // exact: a Q8 value is a double
  const int min_valid_q4 = 16 * params.min_disparity;
  for (int v = 0; v < disparity.height; ++v) {
    const int64_t road_numerator = int64_t{words[arm::kRoadSlopeQ16]} * v + words[arm::kRoadInterceptQ16];
    // round(numerator / 4096) half up, written as a floor division of a non-negative-safe form
    int64_t road_q4 = road_numerator + 2048;
    road_q4 = road_q4 >= 0 ? road_q4 / 4096 : -((-road_q4 + 4095) / 4096);
    const int64_t margin_q4 = params.road_margin_q4 + params.road_margin_per_mille * (road_q4 > 0 ? road_q4 : 0) / 1000;
    const int64_t threshold_q4 = road_q4 + margin_q4;
    const bool row_votes = road_valid && static_cast<double>(v) >= horizon_row - params.rows_above_horizon;
    for (int u = 0; u < disparity.width; ++u) {
      const int d = plane_row<const int16_t>(disparity, v)[u];
      uint8_t value = kMaskNoVote;
      if (row_votes && d >= min_valid_q4) {
        int count = 0;
        for (int j = 0; j < params.window_rows && v + j < disparity.height; ++j) {
          const int dj = plane_row<const int16_t>(disparity, v + j)[u];
          if (dj >= min_valid_q4 && std::abs(dj - d) <= params.match_tolerance_q4) ++count;
        }
        value = count >= params.min_count && d > threshold_q4 ? kMaskObstacle : kMaskFree;
      }
      plane_row<uint8_t>(destination, v)[u] = value;
    }
  }
}

PreparedKernel vldh_mask_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"min_disparity", "window_rows", "match_tolerance_q4", "min_count", "road_margin_q4",
                             "road_margin_per_mille", "rows_above_horizon"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (disparity, road), got " + std::to_string(input_shapes.size()));
  }
  auto prepared = std::make_shared<VldhMaskParams>();
  prepared->min_disparity = param_int(params, "min_disparity", 0, -2047, 2047);
  prepared->window_rows = param_int(params, "window_rows", 4, 1, 32);
  prepared->match_tolerance_q4 = param_int(params, "match_tolerance_q4", 4, 0, 255);
  prepared->min_count = param_int(params, "min_count", 3, 1, prepared->window_rows);
  prepared->road_margin_q4 = param_int(params, "road_margin_q4", 8, 0, 1023);
  prepared->road_margin_per_mille = param_int(params, "road_margin_per_mille", 20, 0, 1000);
  prepared->rows_above_horizon = param_int(params, "rows_above_horizon", 64, 0, 4096);
  const PlaneShape& record = input_shapes[1];
  if (record.width != arm::kRoadProfileWords || record.height != 1) {
    throw KernelError("input 'road': expected a " + std::to_string(arm::kRoadProfileWords) +
                      " x 1 road profile record (arm/tasks/road_profile.h), got " + std::to_string(record.width) + " x " +
                      std::to_string(record.height));
  }
  PreparedKernel result{prepared, {input_shapes[0]}};
  result.input_halos = {Halo{0, 0, 0, prepared->window_rows - 1}, Halo{}};
  return result;
}

KernelDescriptor make_vldh_mask() {
  KernelDescriptor descriptor;
  descriptor.name = "vldh_mask";
  descriptor.summary =
      "Obstacle mask (thesis 003 eq. 4.1, VLDH of Kakegawa et al.): u8 0 no vote / 1 free / 2 obstacle from s16q4 "
      "disparity and the road profile record";
  descriptor.ports = {{"disparity", PortDirection::input, {ElementType::s16, 4}, PortAccess::window},
                      {"road", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"mask", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.halo = {0, 0, 0, 3};  // the default window_rows; prepare sets the node's own
  // Rows past the bottom are never read as data (v + j < H), so both modes give the same bits.
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = vldh_mask_prepare;
  descriptor.counting = vldh_mask_counting;
  descriptor.reference = vldh_mask_reference;
  LPSTEREO_FILL_NATIVE_TABLE(vldh_mask)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(vldh_mask, lpstereo::kernels::make_vldh_mask);
#endif
