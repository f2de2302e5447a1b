// sparse_disparity: stereo disparity at the keypoints only (thesis 003 §3.5: the drone's localizer
// computes disparity at its features instead of densely), by census Hamming cost summed over a small
// window, searched along the keypoint's row of the right view, winner takes all, uniqueness check,
// parabola sub-pixel step.
//
// Why census and not SAD: the two cameras' exposures differ (auto-exposure runs per camera) and SAD
// of raw grey levels is biased by any gain or offset between the views; census compares each pixel
// with its window centre only, so it is invariant to monotonic changes of brightness, and it is the
// cost every dense matcher of the project uses (kernels/census_cost.h), so a sparse value can be
// compared with the dense one at the same pixel. The census planes are those of census5x5 (24 bits
// in a census32 word); the window sum makes a keypoint's cost less noisy than one pixel's.
//
// Ports (all inputs PortAccess::whole: keypoints are anywhere):
//   "left" census32, "right" census32: the two views' census planes, same size W x H;
//   "keypoints" s32, kKeypointWords (4) x N: the left view's list (arm/tasks/keypoint_record.h);
//   output "disparity" s16 Q4, N x 1 (one row): element k is keypoint row k's disparity.
// Parameters:
//   min_disparity (-2047 .. 2046, default 0), num_disparities D (1 .. min(256, 2047 - min), default
//     64): the search covers d in [min_disparity, min_disparity + D), right column x - d;
//   window_radius r (0 .. 2, default 1): the cost window is (2r + 1)^2 pixels;
//   uniqueness_percent U (0 .. 50, default 10, 0 = off).
// Cost: C(d) = sum over |u|, |v| <= r of popcount(CL(cx(x + u), cy(y + v)) xor CR(cx(x + u - d), cy(y + v))),
//   cx, cy clamping to the plane (the replicate border of kernels/census_cost.h). For a keypoint at
//   least r px inside the image this is the dense census cost (census_cost_reference) summed over the
//   window; with r = 0 it is exactly census_wta_disparity's cost. Bound: (2r + 1)^2 x 32 <= 800.
// Winner: the smallest C, ties to the smallest d (as census_wta_disparity and the SGM kernels).
// Uniqueness (the SGM kernels' rule, kernels/sgm_core.h): with S2 the smallest C(d) over
//   |d - best| > 1 (0xFFFF when there is none), the keypoint is invalid when C(best) x 100 >=
//   S2 x (100 - U) with U > 0 (a tie is ambiguous, also at C = S2 = 0); u32, C <= 800 and S2 <= 0xFFFF: no
//   overflow (0xFFFF x 50 > 800 x 100, so a keypoint without such a d is never invalidated).
// Sub-pixel (the SGM kernels' parabola, kernels/parabola_subpixel.h): a = C(best - 1) - C(best) > 0,
//   c = C(best + 1) - C(best) >= 0, q = (16 |a - c| + a + c) / (2 (a + c)) by a 4-step restoring
//   division (0 <= q <= 8), offset = -q when c > a, else +q; no step when best is the first or last
//   disparity of the range.
// Output format: s16 Q4 (value / 16 = px): (min_disparity + best) x 16 + offset, |offset| <= 8.
//   Range: d <= 2046 gives at most 2046 x 16 = 32736 (the last disparity takes no step) and
//   2045 x 16 + 8 = 32728 below it; d >= -2047 gives at least -32752 (the first takes no step), so
//   the narrow to s16 never clamps (tested at both ends).
//   Invalid = (min_disparity - 1) x 16 (DESIGN.md §4; -32768 at the bottom of the range): never a
//   valid value, the smallest of which is min_disparity x 16 (best = 0, no step; best >= 1 gives at
//   least min_disparity x 16 + 8). Invalid for an unused keypoint row (kKeypointValid == 0), a
//   keypoint outside the image (x, y read as full s32 words), or an ambiguous one (uniqueness).
//
// Vector schedule (a chunk = 2 halves of L = B::kLanesU32 keypoints, narrowed to one s16 vector):
//   per half: the records by gather_u16 (6: valid, x, y low and high halves; rows past the list
//     clamped to its last), the inside test, x and y clamped; per window row v a clamped row and two
//     row offsets (left, right planes); the left window's (2r + 1)^2 census words (2 gathers each);
//     the right strip's (2r + 1)(D + 2r) census words, gathered once and kept in scratch; per d the
//     window's costs from the strip (load, xor, popcount, add), stored in scratch, WTA; a second
//     pass over the stored costs for S2 and C(best -+ 1); sub-pixel; uniqueness; invalid select.
// Op count (closed form, checked by tests/kernels/sparse_disparity_test.cpp), counting back end
// (L = 16), A = (2r + 1)^2 window pixels, R = 2r + 1 window rows, E = D + 2r strip columns,
// per half (two halves per chunk of 32 keypoints):
//   gather   = 6 + 2 A + 2 R E                (records; left window; right strip, 2 halves a word)
//   load     = (A + 1) D                      (strip words per d and window pixel; stored costs)
//   store    = R E + D                        (strip; costs)
//   popcount = A D
//   arith    = 26 + 6 R + A + 3 E + R E + (A + 3) D
//   logic    = 19 + A + R E + (A + 4) D
//   shift    = 7 + R + A + E + R E
//   compare  = 13 + 4 D
//   multiply = 3 + 2 R
// per chunk: permute 1 (narrow to s16), store 1; per tile: load 1, arith 1, permute 27 + R
// (broadcasts). Chunks per tile: ceil(tile_width / 32).
// At N = 2048, D = 128, r = 1 (graphs/localization-features.json), profiled on cv1-class: 286,686
// cycles, 0.36 ms (the census planes it reads cost 2.38 ms a view in census5x5).
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "arm/tasks/keypoint_record.h"
#include "kernels/kernel.h"
#include "kernels/parabola_subpixel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int kMaxLanesU32 = 16;
constexpr int kMaxWindowRadius = 2;
constexpr int kMaxSparseDisparities = 256;
alignas(64) constexpr int32_t kLaneNumbers[kMaxLanesU32] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};

struct SparseDisparityParams {
  int min_disparity = 0;
  int num_disparities = 64;
  int window_radius = 1;
  int uniqueness_percent = 10;
};

constexpr int32_t invalid_disparity_q4(const SparseDisparityParams& params) { return (params.min_disparity - 1) * 16; }

template <class B>
void sparse_disparity_body(const TileArgs& args) {
  using VU32 = typename B::VU32;
  using VS32 = typename B::VS32;
  constexpr int kLanes = B::kLanesU32;
  static_assert(kLanes <= kMaxLanesU32);
  const auto& params = *static_cast<const SparseDisparityParams*>(args.params);
  const PlaneView& left = args.inputs[0];
  const PlaneView& right = args.inputs[1];
  const PlaneView& keypoints = args.inputs[2];
  const PlaneView& destination = args.outputs[0];
  const int radius = params.window_radius;
  const int window_rows = 2 * radius + 1;
  const int disparities = params.num_disparities;
  const int strip_columns = disparities + 2 * radius;
  const int max_disparity = params.min_disparity + disparities - 1;
  uint32_t* strip_words = reinterpret_cast<uint32_t*>(args.scratch);  // [v][e]: e = u - d + r + max_disparity
  uint32_t* cost_words = strip_words + static_cast<size_t>(window_rows * strip_columns) * kMaxLanesU32;  // [s]

  // Per tile: broadcasts and the first lanes' keypoint rows.
  const VS32 zero = B::set1_s32(0);
  const VU32 all_ones = B::set1_u32(0xFFFFFFFFu);
  const VS32 last_keypoint = B::set1_s32(keypoints.height - 1);
  const VS32 keypoint_stride = B::set1_s32(static_cast<int32_t>(keypoints.stride_bytes / 2));
  const VS32 left_stride = B::set1_s32(static_cast<int32_t>(left.stride_bytes / 2));
  const VS32 right_stride = B::set1_s32(static_cast<int32_t>(right.stride_bytes / 2));
  const VS32 width_px = B::set1_s32(left.width);
  const VS32 height_px = B::set1_s32(left.height);
  const VS32 last_column = B::set1_s32(left.width - 1);
  const VS32 last_row = B::set1_s32(left.height - 1);
  const VS32 minus_one = B::set1_s32(-1);
  const VU32 one = B::set1_u32(1);
  const VU32 two = B::set1_u32(2);
  const VU32 hundred = B::set1_u32(100);
  const VU32 keep_percent = B::set1_u32(static_cast<uint32_t>(100 - params.uniqueness_percent));
  // C x 100 + 1 > S2 x (100 - U) is C x 100 >= S2 x (100 - U): a tie is ambiguous. With U = 0 the
  // check is off, and C x 100 > S2 x 100 never holds (S2 >= C).
  const VU32 tie_is_ambiguous = B::set1_u32(params.uniqueness_percent > 0 ? 1u : 0u);
  const VU32 no_second = B::set1_u32(0xFFFFu);
  const VU32 last_step = B::set1_u32(static_cast<uint32_t>(disparities - 1));
  const VS32 disparity_base = B::set1_s32(params.min_disparity * 16);
  const VS32 invalid = B::set1_s32(invalid_disparity_q4(params));
  const VS32 strip_start = B::set1_s32(radius + max_disparity);
  const VS32 lane_step = B::set1_s32(kLanes);
  VS32 window_steps[2 * kMaxWindowRadius + 1];  // -r .. r
  for (int v = 0; v < window_rows; ++v) window_steps[v] = B::set1_s32(v - radius);
  VU32 bit_values[4];
  for (int bit = 0; bit < 4; ++bit) bit_values[bit] = B::set1_u32(1u << bit);
  VS32 next_rows = B::add(B::set1_s32(args.tile_x), B::load(kLaneNumbers));
  const auto* keypoint_halves = reinterpret_cast<const uint16_t*>(keypoints.origin);
  const auto* left_halves = reinterpret_cast<const uint16_t*>(left.origin);
  const auto* right_halves = reinterpret_cast<const uint16_t*>(right.origin);
  auto gather_word = [&](const uint16_t* base, const VS32& offset) {
    return B::bit_or(B::gather_u16(base, offset), B::template shl<16>(B::gather_u16(base + 1, offset)));
  };

  const int width = destination.width;
  for (int x = 0; x < width; x += 2 * kLanes) {
    VS32 result[2];
    for (int half = 0; half < 2; ++half) {
      // The records (rows past the list clamped to its last row; their lanes are not stored).
      const VS32 rows = B::min(next_rows, last_keypoint);
      next_rows = B::add(next_rows, lane_step);
      const VS32 record_offset = B::mullo(rows, keypoint_stride);
      const VU32 valid = B::bit_or(B::gather_u16(keypoint_halves + 2 * arm::kKeypointValid, record_offset),
                                   B::gather_u16(keypoint_halves + 2 * arm::kKeypointValid + 1, record_offset));
      const VS32 x_px = B::as_s32(gather_word(keypoint_halves + 2 * arm::kKeypointXPx, record_offset));
      const VS32 y_px = B::as_s32(gather_word(keypoint_halves + 2 * arm::kKeypointYPx, record_offset));
      const VS32 inside = B::bit_and(B::bit_and(B::cmpgt(x_px, minus_one), B::cmpgt(width_px, x_px)),
                                     B::bit_and(B::cmpgt(y_px, minus_one), B::cmpgt(height_px, y_px)));
      const VU32 usable = B::bit_andnot(B::cmpeq(valid, B::as_u32(zero)), B::as_u32(inside));
      const VS32 column = B::min(B::max(x_px, zero), last_column);
      const VS32 row = B::min(B::max(y_px, zero), last_row);

      VS32 left_row_offset[2 * kMaxWindowRadius + 1], right_row_offset[2 * kMaxWindowRadius + 1];
      for (int v = 0; v < window_rows; ++v) {
        const VS32 window_row = B::min(B::max(B::add(row, window_steps[v]), zero), last_row);
        left_row_offset[v] = B::mullo(window_row, left_stride);
        right_row_offset[v] = B::mullo(window_row, right_stride);
      }
      VU32 left_window[(2 * kMaxWindowRadius + 1) * (2 * kMaxWindowRadius + 1)];
      for (int u = -radius; u <= radius; ++u) {
        const VS32 element = B::template shl<1>(B::min(B::max(B::add(column, window_steps[u + radius]), zero), last_column));
        for (int v = 0; v < window_rows; ++v) {
          left_window[v * window_rows + u + radius] = gather_word(left_halves, B::add(left_row_offset[v], element));
        }
      }
      // The right strip: column index e holds x + e - r - max_disparity (e = u - d + r + max_disparity).
      VS32 strip_column = B::sub(column, strip_start);
      for (int e = 0; e < strip_columns; ++e) {
        const VS32 element = B::template shl<1>(B::min(B::max(strip_column, zero), last_column));
        for (int v = 0; v < window_rows; ++v) {
          B::store(strip_words + static_cast<size_t>(v * strip_columns + e) * kMaxLanesU32,
                   gather_word(right_halves, B::add(right_row_offset[v], element)));
        }
        strip_column = B::add(strip_column, B::as_s32(one));
      }
      // Costs, winner takes all (strict <: ties to the smallest d).
      VU32 best_cost = all_ones, best_step = B::as_u32(zero), step = B::as_u32(zero);
      for (int s = 0; s < disparities; ++s) {
        const int d = params.min_disparity + s;
        VU32 cost = B::as_u32(zero);
        bool first_term = true;
        for (int v = 0; v < window_rows; ++v) {
          for (int u = -radius; u <= radius; ++u) {
            const int e = u - d + radius + max_disparity;
            const VU32 right_word = B::load(strip_words + static_cast<size_t>(v * strip_columns + e) * kMaxLanesU32);
            const VU32 bits = B::popcount(B::bit_xor(left_window[v * window_rows + u + radius], right_word));
            cost = first_term ? bits : B::add(cost, bits);
            first_term = false;
          }
        }
        B::store(cost_words + static_cast<size_t>(s) * kMaxLanesU32, cost);
        const VU32 better = B::cmplt(cost, best_cost);
        best_cost = B::min(best_cost, cost);
        best_step = B::select(better, step, best_step);
        step = B::add(step, one);
      }
      // Second pass: S2 over |d - best| > 1 and the neighbours C(best - 1), C(best + 1).
      VU32 second = no_second, minus_cost = no_second, plus_cost = no_second;
      VU32 offset_from_best = B::sub(one, best_step);  // s - best + 1, modulo 2^32
      for (int s = 0; s < disparities; ++s) {
        const VU32 cost = B::load(cost_words + static_cast<size_t>(s) * kMaxLanesU32);
        const VU32 far = B::cmpgt(offset_from_best, two);
        second = B::min(second, B::select(far, cost, no_second));
        minus_cost = B::select(B::cmpeq(offset_from_best, B::as_u32(zero)), cost, minus_cost);
        plus_cost = B::select(B::cmpeq(offset_from_best, two), cost, plus_cost);
        offset_from_best = B::add(offset_from_best, one);
      }
      // Sub-pixel: the SGM kernels' parabola (kernels/parabola_subpixel.h).
      const VU32 a = B::sub(minus_cost, best_cost);
      const VU32 c = B::sub(plus_cost, best_cost);
      const VU32 offset = parabola_offset_q4<B>(a, c, bit_values, B::as_u32(zero));
      const VU32 interior = B::bit_and(B::cmpgt(best_step, B::as_u32(zero)), B::cmplt(best_step, last_step));
      const VS32 disparity =
          B::add(B::add(B::as_s32(B::template shl<4>(best_step)), disparity_base), B::as_s32(B::bit_and(offset, interior)));
      // Uniqueness and the invalid keypoints.
      const VU32 ambiguous =
          B::cmpgt(B::add(B::mullo(best_cost, hundred), tie_is_ambiguous), B::mullo(second, keep_percent));
      const VU32 keep = B::bit_andnot(ambiguous, usable);
      result[half] = B::select(B::as_s32(keep), disparity, invalid);
    }
    store_clipped<B>(plane_row<int16_t>(destination, 0), x, width, B::narrow_sat_s16(result[0], result[1]));
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sparse_disparity, sparse_disparity_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(sparse_disparity)

namespace lpstereo::kernels {
namespace {

void sparse_disparity_counting(const TileArgs& args) { sparse_disparity_body<simd::Counting>(args); }

// Scratch: the right strip, (2r + 1) x (D + 2r) vectors, then D cost vectors, each 16 u32 lanes.
size_t sparse_disparity_scratch(const SparseDisparityParams& params) {
  const int rows = 2 * params.window_radius + 1;
  const int columns = params.num_disparities + 2 * params.window_radius;
  return sizeof(uint32_t) * kMaxLanesU32 * static_cast<size_t>(rows * columns + params.num_disparities);
}

// Scalar reference: per keypoint, the window costs of every d, then the rules of the header.
void sparse_disparity_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const SparseDisparityParams*>(params_pointer);
  const PlaneView& left = inputs[0];
  const PlaneView& right = inputs[1];
  const PlaneView& keypoints = inputs[2];
  int16_t* out = plane_row<int16_t>(outputs[0], 0);
  auto census = [](const PlaneView& plane, int x, int y) {
    return plane_row<const uint32_t>(plane, std::clamp(y, 0, plane.height - 1))[std::clamp(x, 0, plane.width - 1)];
  };
  for (int k = 0; k < outputs[0].width; ++k) {
    const int32_t* record = plane_row<const int32_t>(keypoints, k);
    const int32_t x = record[arm::kKeypointXPx], y = record[arm::kKeypointYPx];
    out[k] = static_cast<int16_t>(invalid_disparity_q4(params));
    if (record[arm::kKeypointValid] == 0 || x < 0 || x >= left.width || y < 0 || y >= left.height) continue;
    std::vector<int> costs(static_cast<size_t>(params.num_disparities));
    int best = 0;
    for (int s = 0; s < params.num_disparities; ++s) {
      const int d = params.min_disparity + s;
      int cost = 0;
      for (int v = -params.window_radius; v <= params.window_radius; ++v) {
        for (int u = -params.window_radius; u <= params.window_radius; ++u) {
          cost += __builtin_popcount(census(left, x + u, y + v) ^ census(right, x + u - d, y + v));
        }
      }
      costs[static_cast<size_t>(s)] = cost;
      if (cost < costs[static_cast<size_t>(best)]) best = s;
    }
    const int best_cost = costs[static_cast<size_t>(best)];
    int second = 0xFFFF;
    for (int s = 0; s < params.num_disparities; ++s) {
      if (std::abs(s - best) > 1) second = std::min(second, costs[static_cast<size_t>(s)]);
    }
    if (params.uniqueness_percent > 0 && best_cost * 100 >= second * (100 - params.uniqueness_percent)) continue;
    int value = (params.min_disparity + best) * 16;
    if (best > 0 && best < params.num_disparities - 1) {
      const int a = costs[static_cast<size_t>(best - 1)] - best_cost, c = costs[static_cast<size_t>(best + 1)] - best_cost;
      const int quotient = (16 * std::abs(a - c) + a + c) / (2 * (a + c));
      value += c > a ? -quotient : quotient;
    }
    out[k] = static_cast<int16_t>(value);
  }
}

PreparedKernel sparse_disparity_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"min_disparity", "num_disparities", "window_radius", "uniqueness_percent"});
  if (input_shapes.size() != 3) {
    throw KernelError("inputs: expected 3 (left, right, keypoints), got " + std::to_string(input_shapes.size()));
  }
  auto prepared = std::make_shared<SparseDisparityParams>();
  prepared->min_disparity = param_int(params, "min_disparity", 0, -2047, 2046);
  prepared->num_disparities =
      param_int(params, "num_disparities", 64, 1, std::min(kMaxSparseDisparities, 2047 - prepared->min_disparity));
  prepared->window_radius = param_int(params, "window_radius", 1, 0, kMaxWindowRadius);
  prepared->uniqueness_percent = param_int(params, "uniqueness_percent", 10, 0, 50);
  if (!(input_shapes[0] == input_shapes[1])) {
    throw KernelError("input 'right': expected the left view's size " + std::to_string(input_shapes[0].width) + "x" +
                      std::to_string(input_shapes[0].height) + ", got " + std::to_string(input_shapes[1].width) + "x" +
                      std::to_string(input_shapes[1].height));
  }
  if (input_shapes[0].width < 1 || input_shapes[0].height < 1) {
    throw KernelError("input 'left': expected a non-empty plane, got " + std::to_string(input_shapes[0].width) + "x" +
                      std::to_string(input_shapes[0].height));
  }
  if (static_cast<int64_t>(input_shapes[0].width) * input_shapes[0].height >= (int64_t{1} << 28)) {
    throw KernelError("input 'left': expected fewer than 2^28 pixels (s32 gather offsets), got " +
                      std::to_string(static_cast<int64_t>(input_shapes[0].width) * input_shapes[0].height));
  }
  if (input_shapes[2].width != arm::kKeypointWords || input_shapes[2].height < 1) {
    throw KernelError("input 'keypoints': expected 4 words (arm/tasks/keypoint_record.h) x at least 1 row, got " +
                      std::to_string(input_shapes[2].width) + "x" + std::to_string(input_shapes[2].height));
  }
  return PreparedKernel{prepared, {{input_shapes[2].height, 1}}};
}

KernelDescriptor make_sparse_disparity() {
  KernelDescriptor descriptor;
  descriptor.name = "sparse_disparity";
  descriptor.summary =
      "disparity at the keypoints: census Hamming cost over a window along the row, WTA, uniqueness, parabola sub-pixel (s16 Q4)";
  descriptor.ports = {{"left", PortDirection::input, {ElementType::census32, 0}, PortAccess::whole},
                      {"right", PortDirection::input, {ElementType::census32, 0}, PortAccess::whole},
                      {"keypoints", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"disparity", PortDirection::output, {ElementType::s16, 4}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};  // the cost clamps to the planes itself
  descriptor.prepare = sparse_disparity_prepare;
  descriptor.scratch_bytes = [](int, int, const void* params) {
    return sparse_disparity_scratch(*static_cast<const SparseDisparityParams*>(params));
  };
  // DMA: the tile's records, and per keypoint the census words it reads: a (2r + 1) x (2r + 1)
  // window of the left plane and a (2r + 1) x (D + 2r) strip of the right one, charged as one
  // rectangle of that area (its position means nothing; the simulator clips it to the plane).
  descriptor.source_rect = [](int input, const PixelRect& output_tile, const PlaneShape& input_shape, const void* params_pointer) {
    const auto& params = *static_cast<const SparseDisparityParams*>(params_pointer);
    const int64_t keypoints = output_tile.x1 - output_tile.x0;
    if (input == 2) return PixelRect{0, output_tile.x0, input_shape.width, output_tile.x1};
    const int64_t rows = 2 * params.window_radius + 1;
    const int64_t columns = input == 0 ? rows : params.num_disparities + 2 * params.window_radius;
    const int64_t area = keypoints * rows * columns;
    const int64_t width = std::max<int64_t>(1, std::min<int64_t>(input_shape.width, area));
    return PixelRect{0, 0, static_cast<int>(width), static_cast<int>((area + width - 1) / width)};
  };
  descriptor.counting = sparse_disparity_counting;
  descriptor.reference = sparse_disparity_reference;
  LPSTEREO_FILL_NATIVE_TABLE(sparse_disparity)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sparse_disparity, lpstereo::kernels::make_sparse_disparity);
#endif
