// Semi-global matching on census Hamming costs, row streaming, written once against the simd
// contract (kernels/simd/emulated.h). Shared by the kernels sgm_4path (single pass, 4 paths) and
// sgm_8path_forward / sgm_8path_backward (two passes, 8 paths). The algorithm, bit for bit, is the
// scalar reference's (kernels/sgm_reference.h).
//
// LANES ARE DISPARITIES. One pixel's costs for all D disparities sit in V = ceil(D / L) u16 vectors
// (L = u16 lanes of the back end; Dp = V L), in REVERSED order: lane j holds d = min_disparity +
// D - 1 - j, so that the right-view census words x - d of consecutive lanes are consecutive in
// memory (one load, no gather, no reversal). Lanes j >= D are padding: their cost is forced to
// 0xFFFF and saturating adds keep every path cost and sum there at 0xFFFF, so they never win a min.
// Pixels are walked one by one along the row (the left-to-right path needs its left neighbour), so
// nothing is vectorised across x and no transposes are needed.
//
// FIXED-POINT FORMATS AND THE OVERFLOW BOUND (tests/kernels/sgm_test.cpp, NoOverflowAtLargestRangeAndPenalties):
//   C      u16, the Hamming distance, unscaled: 0..Cmax, Cmax = 24 (census 5x5) or 62 (census 9x7).
//   P1, P2 u16 penalties in the same unit (Hamming bits), 0 <= P1 <= P2 <= 4000 (kSgmMaxPenalty).
//   L_r    u16 path cost, normalised by subtracting the previous pixel's minimum m (Hirschmueller):
//          L_r = C + min(L(d), L(d-1) + P1, L(d+1) + P1, m + P2) - m, and every term is >= m, so
//          0 <= L_r <= Cmax + P2 <= 4062. Intermediates: m + P2 <= 8062; L(d+-1) + P1 saturates
//          (adds) only for the 0xFFFF sentinels and padding lanes.
//   S      u16 sum of the path costs: <= 8 (Cmax + P2) <= 32496 < 2^15 for 8 paths (4 paths:
//          <= 16248), so sums never saturate and stay below the padding value 0xFFFF.
//   keys   u32 S << 16 | (d - min_disparity), min gives the lowest cost, ties to the smallest d.
//   output s16 Q4 (value / 16 = px): (min_disparity + best) * 16 + sub-pixel offset in [-8, 8];
//          invalid = (min_disparity - 1) * 16. |disparity| <= 2047 keeps it in s16.
//   Uniqueness: the pixel is kept only when S2 * (100 - U) > S * 100 in u32 (S2 <= 0xFFFF, U <= 50:
//          no overflow; a pixel with no disparity farther than 1 from the best gets S2 = 0xFFFF, and
//          0xFFFF * 50 > 32496 * 100, so it is never invalidated; that is why U is limited to 50).
//          The best must beat S2 strictly: a tie is ambiguous even at S = S2 = 0, the pixel of a
//          texture-less view (all census bits equal, every cost 0), which the former rule
//          (invalid when S2 * (100 - U) < S * 100) kept as disparity min_disparity.
//   Sub-pixel: a = S(b-1) - S(b) > 0, c = S(b+1) - S(b) >= 0, q = (16 |a - c| + a + c) / (2 (a + c))
//          by a 4-step restoring division (compare, subtract, select, shift; no divide op):
//          numerator <= 17 (a + c) < 2^21 in u32 lanes; 0 <= q <= 8, so |offset| <= 0.5 px.
//
// ROW STATE (KernelDescriptor::state_bytes): the previous row's path costs of the three paths that
// come from the previous row (top-left, top, top-right; bottom-right, bottom, bottom-left in the
// backward pass), one slot of Dp + 1 u16 per pixel (a 0xFFFF sentinel, then Dp lanes) per path.
// Each path updates its slots in place: the top path reads and writes slot x, the top-left path
// slot (x - y) mod W, the top-right path slot (x + y) mod W, so the value a pixel reads is exactly
// the one it overwrites and no second row buffer is needed. Zeroed state gives the first row
// L_r = C (min(0, ...) - 0), the path start Hirschmueller prescribes. The minima are not stored:
// each is recomputed from the slot it is consumed from. Closed form (bytes), sized for the widest
// back end: state = 3 x 2 x (W (Dp32 + 1) + 1), Dp32 = ceil(D / 32) x 32.
// At W = 3840, D = 128: 2,972,166 bytes. The single pass holds no W x H x D volume; the 8-path
// pair holds one summed volume (the forward sums in DRAM, 2 W H D bytes), never one per path.
//
// MINIMUM OVER THE LANES: the contract's min_across (log2(L) stages of one permute and one min on
// the target; phminposuw on x86, vminvq on NEON).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "kernels/census_cost.h"
#include "kernels/kernel.h"
#include "kernels/parabola_subpixel.h"
#include "kernels/row_access.h"
#include "kernels/simd/emulated.h"

namespace lpstereo::kernels {

struct SgmParams {
  int min_disparity = 0;       // pixels, may be negative
  int num_disparities = 64;    // D: the search covers [min_disparity, min_disparity + D)
  int p1 = 5;                  // penalty for a disparity change of 1 px, Hamming bits
  int p2 = 45;                 // penalty for a larger change, Hamming bits (>= p1)
  int uniqueness_percent = 0;  // 0..50, 0 = off
  int subpixel = 1;            // 1: parabola sub-pixel step; 0: integer disparities (x 16)
  int lr_max_diff = -1;        // left-right check tolerance in px; -1 = off
};

inline constexpr int kSgmMaxDisparities = 512;
inline constexpr int kSgmMaxPenalty = 4000;
inline constexpr int kSgmMaxUniquenessPercent = 50;
inline constexpr int kSgmWidestLanesU16 = 32;  // 512-bit vectors (AVX-512, counting)

enum class SgmPass {
  single,         // 4 paths, then winner takes all: sgm_4path
  forward,        // 4 paths, writes the per-pixel sums S (u16, W*D per row): sgm_8path_forward
  backward,       // the other 4 paths (rows bottom up), adds the forward sums, winner takes all: sgm_8path_backward
  backward_sums,  // the other 4 paths (rows bottom up), writes their own sums: sgm_8path_backward_sums
  row_pair_sums,     // 2 of the 4 single-pass paths (along the row, top-left), writes their sums: sgm_4path_row_pair_sums
  column_pair_sums,  // the other 2 (top, top-right), writes their sums: sgm_4path_column_pair_sums
  select,         // no paths: adds two sums planes, winner takes all: sgm_sums_select
  // The banded 8-path schedule (no W x H x D volume; kernels/sgm_8path_bands.cpp):
  forward_checkpoints,   // the 3 forward paths from the previous row, no sums: the state at each band's top
  backward_checkpoints,  // the 3 backward ones (rows bottom up): the state below each band
  forward_band,   // inside sgm_8path_bands: forward as `forward`, into the band's sums buffer (no streaming stores)
  backward_band,  // inside sgm_8path_bands: backward as `backward`, census whole, the band's forward sums
};

// Which of the four paths of a direction a pass runs: along the row, the diagonal from the previous
// row's left neighbour (the "down" diagonal slot), straight from the previous row, the other diagonal.
inline constexpr bool sgm_writes_checkpoints(SgmPass pass) {
  return pass == SgmPass::forward_checkpoints || pass == SgmPass::backward_checkpoints;
}
inline constexpr bool sgm_runs_row_path(SgmPass pass) {
  return pass != SgmPass::column_pair_sums && pass != SgmPass::select && !sgm_writes_checkpoints(pass);
}
inline constexpr bool sgm_runs_down_diagonal(SgmPass pass) { return pass != SgmPass::column_pair_sums && pass != SgmPass::select; }
inline constexpr bool sgm_runs_straight(SgmPass pass) { return pass != SgmPass::row_pair_sums && pass != SgmPass::select; }
inline constexpr bool sgm_runs_up_diagonal(SgmPass pass) { return sgm_runs_straight(pass); }
// Row-state regions: one per path from the previous row.
inline constexpr int sgm_state_regions(SgmPass pass) {
  return (sgm_runs_down_diagonal(pass) ? 1 : 0) + (sgm_runs_straight(pass) ? 1 : 0) + (sgm_runs_up_diagonal(pass) ? 1 : 0);
}

// What each pass does (the tile body branches on these at compile time).
inline constexpr bool sgm_runs_paths(SgmPass pass) { return pass != SgmPass::select; }
inline constexpr bool sgm_rows_bottom_up(SgmPass pass) {
  return pass == SgmPass::backward || pass == SgmPass::backward_sums || pass == SgmPass::backward_checkpoints ||
         pass == SgmPass::backward_band;
}
inline constexpr bool sgm_writes_sums(SgmPass pass) {
  return pass == SgmPass::forward || pass == SgmPass::backward_sums || pass == SgmPass::row_pair_sums ||
         pass == SgmPass::column_pair_sums || pass == SgmPass::forward_band;
}
inline constexpr bool sgm_selects(SgmPass pass) {
  return pass == SgmPass::single || pass == SgmPass::backward || pass == SgmPass::select || pass == SgmPass::backward_band;
}
// The passes that read the census planes whole and stage each right row with its border themselves
// (their output is not the image's size, or they run inside another kernel's tile).
inline constexpr bool sgm_stages_right_row(SgmPass pass) {
  return sgm_writes_sums(pass) || sgm_writes_checkpoints(pass) || pass == SgmPass::backward_band;
}
// The passes that add a forward sums plane (input 2) before selecting.
inline constexpr bool sgm_reads_forward_sums(SgmPass pass) { return pass == SgmPass::backward || pass == SgmPass::backward_band; }

// The banded 8-path schedule cuts the image into bands of this many rows (the last one may be
// shorter): one checkpoint row per band and direction, one band of forward sums per worker. 64
// balances the two at the sizes the engine is used at (the closed form is in
// kernels/sgm_8path_bands.cpp); it is also the default tile height, so the bands are the tiles.
inline constexpr int kSgmBandRows = 64;
inline constexpr int sgm_band_count(int height) { return (height + kSgmBandRows - 1) / kSgmBandRows; }
// A checkpoint row: the three paths from the previous row (down diagonal, straight, up diagonal), each
// W positions x D path costs (see "THE BANDED 8-PATH SCHEDULE" below for the layout), as bytes.
// Path costs are L_r <= Cmax + P2 (above) and Cmax <= the census word's bits (32 or 64): when that
// bound fits in a byte (P2 <= 223 on census32, <= 191 on census64; the defaults are 45 and 50) a
// checkpoint keeps each as one u8, exactly, else as a u16 (two bytes, the host's order): the
// checkpoints of a frame are half the size at every setting users run.
inline constexpr int sgm_checkpoint_value_bytes(const SgmParams& params, int word_bytes) {
  return 8 * word_bytes + params.p2 <= 255 ? 1 : 2;
}
inline constexpr int64_t sgm_checkpoint_row_bytes(int width, int disparities, int value_bytes) {
  return int64_t{3} * width * disparities * value_bytes;
}

inline constexpr int sgm_padded(int disparities, int lanes) { return (disparities + lanes - 1) / lanes * lanes; }

// Row state bytes (see above): one region per path from the previous row (three, or one or two for
// the path-pair passes) x (W slots of Dp32 + 1 u16, plus the last sentinel).
inline size_t sgm_state_bytes(int width, int disparities, int regions = 3) {
  const size_t slot = static_cast<size_t>(sgm_padded(disparities, kSgmWidestLanesU16)) + 1;
  return static_cast<size_t>(regions) * 2 * (static_cast<size_t>(width) * slot + 1);
}

// Scratch layout (bytes, sized for the widest back end): two u16 buffers of Dp32 + 2 (a zero
// "previous pixel" for path starts; the current pixel's sums for the sub-pixel reads of S(best - 1)
// and S(best + 1)), then u32 rows: the right-view keys (W + 2 Dp32 + 64) and four
// per-pixel records (W + 64 each: best key, second-best cost, S(best - 1), S(best + 1)) that the
// row's final pass turns into disparities 16 pixels per vector; the forward pass adds the staged
// right census row.
struct SgmScratchLayout {
  size_t u16_buffer = 0;    // elements per u16 buffer
  size_t keys_offset = 0;   // bytes
  size_t keys_count = 0;
  size_t rows_offset = 0;    // four u32 rows: best key, second-best cost, S(best - 1), S(best + 1)
  size_t row_count = 0;
  size_t staged_offset = 0;  // forward pass: the right census row with its border
  size_t staged_count = 0;   // words
  size_t total = 0;
};

inline constexpr int sgm_left_halo(const SgmParams& params) {
  const int max_disparity = params.min_disparity + params.num_disparities - 1;
  return max_disparity > 0 ? max_disparity : 0;
}
inline constexpr int sgm_right_halo(const SgmParams& params) {
  return params.min_disparity < 0 ? -params.min_disparity : 0;
}

inline SgmScratchLayout sgm_scratch_layout(int width, const SgmParams& params, SgmPass pass, int word_bytes) {
  SgmScratchLayout layout;
  const size_t dp32 = static_cast<size_t>(sgm_padded(params.num_disparities, kSgmWidestLanesU16));
  auto align = [](size_t bytes) { return (bytes + 63) / 64 * 64; };
  layout.u16_buffer = dp32 + 2;
  layout.keys_offset = align(2 * layout.u16_buffer * 2);
  layout.keys_count = static_cast<size_t>(width) + 2 * dp32 + 64;
  layout.rows_offset = align(layout.keys_offset + 4 * layout.keys_count);
  layout.row_count = static_cast<size_t>(width) + 64;
  layout.staged_offset = align(layout.rows_offset + 4 * 4 * layout.row_count);
  layout.staged_count = sgm_stages_right_row(pass) ? static_cast<size_t>(width) + sgm_left_halo(params) +
                                                       sgm_right_halo(params) + 64
                                                 : 0;
  layout.total = align(layout.staged_offset + static_cast<size_t>(word_bytes) * layout.staged_count);
  return layout;
}

namespace sgm_detail {

// The per-pixel helpers are inlined into the row loop (a call per path and pixel costs as much as
// the path step on the host).
#define LPSTEREO_SGM_INLINE [[gnu::always_inline]] inline

// 0, 1, 2, ...: lane numbers for building constant vectors (one load).
alignas(64) inline constexpr uint16_t kLaneNumbersU16[64] = {
    0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21,
    22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40, 41, 42, 43,
    44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63};
alignas(64) inline constexpr uint32_t kLaneNumbersU32[32] = {0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10,
                                                             11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21,
                                                             22, 23, 24, 25, 26, 27, 28, 29, 30, 31};

// The census Hamming costs of one u16 vector of disparity lanes: lane i is
// popcount(left XOR right_row[column + i]); right words at or past readable_end read as 0.
template <class B, class Word, class VWord>
LPSTEREO_SGM_INLINE typename B::VU16 census_costs(const VWord& left, const Word* right_row, int column, int readable_end) {
  if constexpr (sizeof(Word) == 4) {
    const auto c0 = census_hamming<B>(left, load_clipped<B>(right_row, column, readable_end));
    const auto c1 = census_hamming<B>(left, load_clipped<B>(right_row, column + B::kLanesU32, readable_end));
    return B::narrow_sat_u16(B::as_s32(c0), B::as_s32(c1));
  } else {
    typename B::VU64 c[4];
    for (int i = 0; i < 4; ++i) {
      c[i] = census_hamming<B>(left, load_clipped<B>(right_row, column + i * B::kLanesU64, readable_end));
    }
    // Each u64 count is < 65 in its low 32 bits: two narrows give the counts as u32 lanes, a third as u16.
    const auto low = B::narrow_sat_u16(B::as_s32(c[0]), B::as_s32(c[1]));
    const auto high = B::narrow_sat_u16(B::as_s32(c[2]), B::as_s32(c[3]));
    return B::narrow_sat_u16(B::as_s32(low), B::as_s32(high));
  }
}

template <class B>
struct PathConstants {
  typename B::VU16 p1, p2;
};

// One step of one path for one pixel. `previous` points at lane 0 of the previous pixel's path
// costs on this path (previous[-1] and previous[Dp] are 0xFFFF sentinels, or everything is 0 for
// a path start); the new costs go to `out` (which may be `previous`: everything is loaded before
// anything is stored). sum[k] gets the costs added (or set, for the first path).
// kAccumulate = false: the checkpoint passes, which keep the path costs and sum nothing.
template <class B, int kMaxVectors, bool kAccumulate = true>
LPSTEREO_SGM_INLINE void path_step(const uint16_t* previous, uint16_t* out, const typename B::VU16* cost, typename B::VU16* sum, bool first,
               int vectors, const PathConstants<B>& constants) {
  using VU16 = typename B::VU16;
  constexpr int L = B::kLanesU16;
  VU16 last[kMaxVectors];
  VU16 neighbours[kMaxVectors];
  last[0] = B::load(previous);
  VU16 minimum = last[0];
  for (int k = 1; k < vectors; ++k) {
    last[k] = B::load(previous + k * L);
    minimum = B::min(minimum, last[k]);
  }
  minimum = B::min_across(minimum);
  const VU16 minimum_p2 = B::adds(minimum, constants.p2);
  // min(L(d - 1), L(d + 1)) + P1: lanes shifted by one through unaligned loads (0xFFFF sentinels at
  // both ends saturate).
  for (int k = 0; k < vectors; ++k) {
    neighbours[k] = B::adds(B::min(B::load(previous + k * L - 1), B::load(previous + k * L + 1)), constants.p1);
  }
  for (int k = 0; k < vectors; ++k) {
    const VU16 best = B::min(neighbours[k], B::min(last[k], minimum_p2));
    const VU16 value = B::adds(cost[k], B::sub(best, minimum));
    B::store(out + k * L, value);
    if constexpr (kAccumulate) sum[k] = first ? value : B::adds(sum[k], value);
  }
}

// The same step for the path along the row, whose previous pixel is the one just computed: its
// costs stay in registers (`last`, updated in place) and the d +- 1 neighbours are lane shifts
// across adjacent vectors, so nothing goes through memory. (Storing them and loading them back one
// lane off, as the other paths do with last row's slots, stalls the host: a load that straddles two
// recent stores cannot be forwarded from the store buffer.) `sentinel` (0xFFFF) is the neighbour
// beyond either end of the range.
template <class B, int kMaxVectors>
LPSTEREO_SGM_INLINE void path_step_in_registers(typename B::VU16* last, const typename B::VU16* cost, typename B::VU16* sum,
                                                bool first, int vectors, const PathConstants<B>& constants,
                                                const typename B::VU16& sentinel) {
  using VU16 = typename B::VU16;
  VU16 minimum = last[0];
  for (int k = 1; k < vectors; ++k) minimum = B::min(minimum, last[k]);
  minimum = B::min_across(minimum);
  const VU16 minimum_p2 = B::adds(minimum, constants.p2);
  VU16 neighbours[kMaxVectors];
  for (int k = 0; k < vectors; ++k) {
    const VU16 below = B::previous_lanes(k == 0 ? sentinel : last[k - 1], last[k]);
    const VU16 above = B::next_lanes(last[k], k == vectors - 1 ? sentinel : last[k + 1]);
    neighbours[k] = B::adds(B::min(below, above), constants.p1);
  }
  for (int k = 0; k < vectors; ++k) {
    const VU16 best = B::min(neighbours[k], B::min(last[k], minimum_p2));
    last[k] = B::adds(cost[k], B::sub(best, minimum));
    sum[k] = first ? last[k] : B::adds(sum[k], last[k]);
  }
}

}  // namespace sgm_detail

// The tile body. Inputs: 0 = left census (Word), 1 = right census (Word), for the backward pass
// 2 = the forward sums (u16, whole). The single and backward passes get census tiles with the
// right view's halo; the forward pass gets the census planes whole and stages each right row with
// its replicate border itself (its output is W*D wide, so the executor cannot cut census windows
// for it). Output 0: s16 Q4 disparity (single, backward) or the sums (forward).
namespace sgm_detail {

// kFixedVectors > 0: the body compiled for exactly that many disparity vectors (loops unrolled,
// per-pixel vectors kept in registers); 0: any count.
template <class B, class Word, SgmPass kPass, int kFixedVectors>
void sgm_tile_for(const TileArgs& args) {
  using VU16 = typename B::VU16;
  using VU32 = typename B::VU32;
  constexpr int L16 = B::kLanesU16;
  constexpr int L32 = B::kLanesU32;
  constexpr int kMaxVectors = kSgmMaxDisparities / L16;
  constexpr bool kBackward = sgm_rows_bottom_up(kPass);
  constexpr bool kSelect = sgm_selects(kPass);
  constexpr bool kPaths = sgm_runs_paths(kPass);
  constexpr bool kWritesSums = sgm_writes_sums(kPass);
  constexpr bool kStagesRight = sgm_stages_right_row(kPass);
  constexpr bool kAccumulates = kWritesSums || kSelect;

  const SgmParams& params = *static_cast<const SgmParams*>(args.params);
  const int count = params.num_disparities;
  const int vectors = kFixedVectors > 0 ? kFixedVectors : (count + L16 - 1) / L16;
  if (vectors < 1) __builtin_unreachable();  // prepare() guarantees num_disparities >= 1
  const int padded = vectors * L16;
  const int width = kStagesRight ? args.inputs[0].width : args.outputs[0].width;
  const int height = kStagesRight ? args.inputs[0].height : args.image_height;
  const int tile_rows = args.outputs[0].height;
  const bool lr_check = kSelect && params.lr_max_diff >= 0;

  // Row state: three path regions of W slots (stride Dp + 1, this back end's Dp) plus a sentinel.
  const ptrdiff_t slot_stride = padded + 1;
  const ptrdiff_t region_size = static_cast<ptrdiff_t>(width) * slot_stride + 1;
  // regions[0] down diagonal, [1] straight, [2] up diagonal; a pass that skips a path has no region for it.
  constexpr bool kRowPath = sgm_runs_row_path(kPass), kDownDiagonal = sgm_runs_down_diagonal(kPass);
  constexpr bool kStraight = sgm_runs_straight(kPass), kUpDiagonal = sgm_runs_up_diagonal(kPass);
  uint16_t* regions[3] = {nullptr, nullptr, nullptr};
  {
    int next_region = 0;
    const bool runs[3] = {kDownDiagonal, kStraight, kUpDiagonal};
    for (int path = 0; path < 3; ++path) {
      if (runs[path]) regions[path] = reinterpret_cast<uint16_t*>(args.state) + (next_region++) * region_size;
    }
  }
  const bool first_tile = kBackward ? args.tile_y + tile_rows == height : args.tile_y == 0;
  if (kPaths && first_tile) {
    // Once per frame (not counted: W + 1 scalar writes per path): the slot sentinels.
    for (int path = 0; path < 3; ++path) {
      if (regions[path] == nullptr) continue;
      for (ptrdiff_t slot = 0; slot <= width; ++slot) regions[path][slot * slot_stride] = 0xFFFF;
    }
  }

  const SgmScratchLayout layout = sgm_scratch_layout(width, params, kPass, static_cast<int>(sizeof(Word)));
  uint16_t* const zero_buffer = reinterpret_cast<uint16_t*>(args.scratch);
  uint16_t* const sums_buffer = zero_buffer + layout.u16_buffer;
  uint32_t* const right_keys = reinterpret_cast<uint32_t*>(args.scratch + layout.keys_offset);
  uint32_t* const best_key_row = reinterpret_cast<uint32_t*>(args.scratch + layout.rows_offset);
  uint32_t* const second_row = best_key_row + layout.row_count;
  uint32_t* const minus_row = second_row + layout.row_count;
  uint32_t* const plus_row = minus_row + layout.row_count;
  Word* const staged = reinterpret_cast<Word*>(args.scratch + layout.staged_offset);

  // Per-tile constants.
  const VU16 zero16 = B::set1_u16(0);
  const VU16 ones16 = B::set1_u16(0xFFFF);
  const sgm_detail::PathConstants<B> path_constants{B::set1_u16(static_cast<uint16_t>(params.p1)),
                                                    B::set1_u16(static_cast<uint16_t>(params.p2))};
  if constexpr (kPaths) {
    for (int i = 0; i < padded + 2; i += L16) store_clipped<B>(zero_buffer, i, padded + 2, zero16);
  }
  VU16 row_path[kMaxVectors];  // the path along the row: the previous pixel's costs, in registers
  for (VU16& costs : row_path) costs = zero16;
  // d - min_disparity per lane (0xFFFF on padding lanes), and the padding mask of the last vector.
  VU16 best_index[kMaxVectors];
  VU16 padding_mask = zero16;
  {
    const VU16 step = B::set1_u16(static_cast<uint16_t>(L16));
    const VU16 last_index = B::set1_u16(static_cast<uint16_t>(count - 1));
    VU16 lane = B::load(sgm_detail::kLaneNumbersU16);
    for (int k = 0; k < vectors; ++k) {
      const VU16 padding = B::cmpgt(lane, last_index);
      best_index[k] = B::select(padding, ones16, B::sub(last_index, lane));
      if (k == vectors - 1) padding_mask = padding;
      lane = B::add(lane, step);
    }
  }
  const bool has_padding = padded != count;
  const VU32 low_half = B::set1_u32(0xFFFFu);
  const VU32 zero32 = B::set1_u32(0);
  const VU32 ones32 = B::set1_u32(0xFFFFFFFFu);
  const VU32 disparity_base = B::set1_u32(static_cast<uint32_t>(params.min_disparity * 16));
  const VU32 invalid = B::set1_u32(static_cast<uint32_t>((params.min_disparity - 1) * 16));
  VU16 near_index[kMaxVectors];  // (d - min_disparity) + 1 per lane, for |d - best| <= 1
  for (VU16& lane_index : near_index) lane_index = zero16;
  VU16 three = zero16;
  VU32 hundred = zero32, keep_percent = zero32;
  if (kSelect && params.uniqueness_percent > 0) {
    const VU16 one = B::set1_u16(1);
    for (int k = 0; k < vectors; ++k) near_index[k] = B::add(best_index[k], one);
    three = B::set1_u16(3);
    hundred = B::set1_u32(100);
    keep_percent = B::set1_u32(static_cast<uint32_t>(100 - params.uniqueness_percent));
  }
  VU32 last_index32 = zero32, bit_values[4] = {zero32, zero32, zero32, zero32};
  if (kSelect && params.subpixel) {
    last_index32 = B::set1_u32(static_cast<uint32_t>(count - 1));  // D - 1: the sub-pixel step needs best < D - 1
    for (int bit = 0; bit < 4; ++bit) bit_values[bit] = B::set1_u32(1u << bit);
  }
  VU32 lane_numbers32 = zero32, right_key_offset = zero32, lr_tolerance = zero32, width32 = zero32, minus_one32 = zero32;
  if (lr_check) {
    lane_numbers32 = B::load(sgm_detail::kLaneNumbersU32);
    right_key_offset = B::set1_u32(static_cast<uint32_t>(count - 1 + params.min_disparity));
    lr_tolerance = B::set1_u32(static_cast<uint32_t>(params.lr_max_diff));
    width32 = B::set1_u32(static_cast<uint32_t>(width));
    minus_one32 = B::set1_u32(0xFFFFFFFFu);
  }

  const bool stream_sums = kWritesSums && kPass != SgmPass::forward_band && padded == count;
  // Right-view words are readable up to the right halo (the forward pass stages the same border).
  const int right_end = width + sgm_right_halo(params);
  for (int step = 0; step < tile_rows; ++step) {
    const int row = kBackward ? tile_rows - 1 - step : step;
    const int y = args.tile_y + row;
    const int mirrored_y = kBackward ? height - 1 - y : y;
    [[maybe_unused]] const Word* left_row = nullptr;
    [[maybe_unused]] const Word* right_row = nullptr;
    if constexpr (kStagesRight) {
      // Stage the right row with its replicate border: [-left halo, W + right halo).
      left_row = plane_row<const Word>(args.inputs[0], y);
      const Word* source = plane_row<const Word>(args.inputs[1], y);
      const int left_halo = sgm_left_halo(params);
      const int right_halo = sgm_right_halo(params);
      auto fill = [&](int begin, int end, Word value) {
        const auto broadcast = [&] {
          if constexpr (sizeof(Word) == 4) return B::set1_u32(value);
          else return B::set1_u64(value);
        }();
        constexpr int kWordLanes = B::kBytes / static_cast<int>(sizeof(Word));
        for (int i = begin; i < end; i += kWordLanes) store_clipped<B>(staged, i, end, broadcast);
      };
      fill(0, left_halo, source[0]);
      constexpr int kWordLanes = B::kBytes / static_cast<int>(sizeof(Word));
      for (int i = 0; i < width; i += kWordLanes) store_clipped<B>(staged + left_halo, i, width, load_clipped<B>(source, i, width));
      fill(left_halo + width, left_halo + width + right_halo, source[width - 1]);
      right_row = staged + left_halo;
    } else if constexpr (kPaths) {
      left_row = plane_row<const Word>(args.inputs[0], row);
      right_row = plane_row<const Word>(args.inputs[1], row);
    }
    // The right view's running minimum of keys (LR check): element e = right_keys[e] collects lane
    // j of every left pixel x with x + j = e. It slides along the row in registers, one lane per
    // pixel: right_window lane i of vector m is element x + m L32 + i at pixel x. (Loading and
    // storing right_keys at x + m L32 for every pixel stalls the host: each load straddles the
    // previous pixel's stores, one element off, which the store buffer cannot forward.)
    [[maybe_unused]] VU32 right_window[2 * kMaxVectors];
    for (int m = 0; m < 2 * vectors; ++m) right_window[m] = ones32;
    [[maybe_unused]] int diagonal_down = ((0 - mirrored_y) % width + width) % width;   // slot of (x - y) mod W at x = 0
    [[maybe_unused]] int diagonal_up = (mirrored_y % width);                            // slot of (x + y) mod W at x = 0
    for (int mirrored_x = 0; mirrored_x < width; ++mirrored_x) {
      const int x = kBackward ? width - 1 - mirrored_x : mirrored_x;
      // Matching costs, lanes j = 0 .. Dp-1 <-> d = min_disparity + D - 1 - j <-> right word x - d.
      VU16 sum[kMaxVectors];
      if constexpr (!kPaths) {
        // sgm_sums_select: S = the forward sums + the backward sums (each <= 4 (Cmax + P2), so no
        // saturation), padding lanes forced to 0xFFFF as the path passes leave them.
        const ptrdiff_t element = static_cast<ptrdiff_t>(x) * count;
        const uint16_t* forward = plane_row<const uint16_t>(args.inputs[0], y) + element;
        const uint16_t* backward = plane_row<const uint16_t>(args.inputs[1], y) + element;
        for (int k = 0; k < vectors; ++k) {
          sum[k] = B::adds(load_clipped<B>(forward, k * L16, count), load_clipped<B>(backward, k * L16, count));
        }
        if (has_padding) sum[vectors - 1] = B::bit_or(sum[vectors - 1], padding_mask);
      } else {
        VU16 cost[kMaxVectors];
        const auto left_word = [&] {
          if constexpr (sizeof(Word) == 4) return B::set1_u32(left_row[x]);
          else return B::set1_u64(left_row[x]);
        }();
        const int first_column = x - params.min_disparity - count + 1;
        for (int k = 0; k < vectors; ++k) {
          cost[k] = sgm_detail::census_costs<B, Word>(left_word, right_row, first_column + k * L16, right_end);
        }
        if (has_padding) cost[vectors - 1] = B::bit_or(cost[vectors - 1], padding_mask);
        // The paths: along the row, then those from the previous row (the pass's subset of the four;
        // the first one run sets the sums).
        const uint16_t* start = zero_buffer + 1;
        if constexpr (kRowPath) {
          if (mirrored_x == 0) {
            for (int k = 0; k < vectors; ++k) row_path[k] = zero16;  // path start: L = C
          }
          sgm_detail::path_step_in_registers<B, kMaxVectors>(row_path, cost, sum, true, vectors, path_constants, ones16);
        }
        if constexpr (kDownDiagonal) {
          uint16_t* down_slot = regions[0] + diagonal_down * slot_stride + 1;
          sgm_detail::path_step<B, kMaxVectors, kAccumulates>(mirrored_x == 0 ? start : down_slot, down_slot, cost, sum, !kRowPath, vectors,
                                                path_constants);
        }
        if constexpr (kStraight) {
          uint16_t* straight_slot = regions[1] + static_cast<ptrdiff_t>(mirrored_x) * slot_stride + 1;
          sgm_detail::path_step<B, kMaxVectors, kAccumulates>(straight_slot, straight_slot, cost, sum, !kRowPath && !kDownDiagonal, vectors,
                                                path_constants);
        }
        if constexpr (kUpDiagonal) {
          uint16_t* up_slot = regions[2] + diagonal_up * slot_stride + 1;
          sgm_detail::path_step<B, kMaxVectors, kAccumulates>(mirrored_x == width - 1 ? start : up_slot, up_slot, cost, sum, false,
                                                vectors, path_constants);
        }
        diagonal_down = diagonal_down + 1 == width ? 0 : diagonal_down + 1;
        diagonal_up = diagonal_up + 1 == width ? 0 : diagonal_up + 1;
      }

      if constexpr (kWritesSums) {
        uint16_t* out = plane_row<uint16_t>(args.outputs[0], row) + static_cast<ptrdiff_t>(x) * count;
        // The sums are read back by the backward pass only after the whole frame: streaming
        // stores where the pixel's vectors are whole and aligned (D a multiple of the lanes and
        // 64-byte aligned rows), plain clipped stores elsewhere. Same bits, same counted stores.
        if (stream_sums && (reinterpret_cast<uintptr_t>(out) % B::kBytes) == 0) {
          for (int k = 0; k < vectors; ++k) B::store_stream(out + k * L16, sum[k]);
        } else {
          for (int k = 0; k < vectors; ++k) store_clipped<B>(out, k * L16, count, sum[k]);
        }
        continue;
      } else if constexpr (kSelect) {
        if constexpr (sgm_reads_forward_sums(kPass)) {
          // The whole frame's forward sums (backward) or the band's, rows from the band's top (backward_band).
          const int forward_row = kPass == SgmPass::backward_band ? row : y;
          const uint16_t* forward = plane_row<const uint16_t>(args.inputs[2], forward_row) + static_cast<ptrdiff_t>(x) * count;
          for (int k = 0; k < vectors; ++k) sum[k] = B::adds(sum[k], load_clipped<B>(forward, k * L16, count));
        }
        // Winner takes all on keys S << 16 | (d - min_disparity).
        VU32 keys[2 * kMaxVectors];
        for (int k = 0; k < vectors; ++k) {
          keys[2 * k] = B::zip_lo(best_index[k], sum[k]);
          keys[2 * k + 1] = B::zip_hi(best_index[k], sum[k]);
        }
        VU32 best_key = keys[0];
        for (int m = 1; m < 2 * vectors; ++m) best_key = B::min(best_key, keys[m]);
        best_key = B::min_across(best_key);
        B::store_partial(best_key_row + x, best_key, 1);
        const VU32 best = B::bit_and(best_key, low_half);
        if (params.uniqueness_percent > 0) {
          // The lowest sum farther than 1 px from the best: lanes d - best in {-1, 0, 1} masked to 0xFFFF.
          const VU16 best16 = B::as_u16(B::bit_or(best, B::template shl<16>(best)));
          VU16 second = B::bit_or(sum[0], B::cmplt(B::sub(near_index[0], best16), three));
          for (int k = 1; k < vectors; ++k) {
            second = B::min(second, B::bit_or(sum[k], B::cmplt(B::sub(near_index[k], best16), three)));
          }
          B::store_partial(second_row + x, B::as_u32(B::min_across(second)), 1);
        }
        if (params.subpixel) {
          // S(best - 1) and S(best + 1) from the pixel's sums (lane j of S at sums_buffer[1 + j]).
          for (int k = 0; k < vectors; ++k) B::store(sums_buffer + 1 + k * L16, sum[k]);
          // One element each, read at an index taken from lane 0 of `best` (a lane move, then a
          // one-lane load and store): a 16-lane gather of the same address would cost a gather's
          // worth of loads on every back end for one useful lane. S < 2^15 and the u16 lane after
          // it is loaded as 0, so the u32 lane 0 of the pair is S itself.
          const ptrdiff_t best_element = static_cast<ptrdiff_t>(B::first_lane(best));
          B::store_partial(minus_row + x, B::as_u32(B::load_partial(sums_buffer + (count + 1 - best_element), 1)), 1);
          B::store_partial(plus_row + x, B::as_u32(B::load_partial(sums_buffer + (count - 1 - best_element), 1)), 1);
        }
        if (lr_check) {
          // Right view: key of right pixel x - d kept at right_keys[x - d + d0 + D - 1] = right_keys[x + j].
          for (int m = 0; m < 2 * vectors; ++m) right_window[m] = B::min(right_window[m], keys[m]);
          // The window's element that no later pixel reaches is final now: x going right, element x
          // (lane 0), stored with its vector, whose other lanes later pixels store again; going left,
          // element x + Dp - 1 (the last lane). Then the window slides one lane (not after the row's
          // last pixel: the whole window is stored below, every element final).
          if constexpr (!kBackward) {
            B::store(right_keys + x, right_window[0]);
            if (mirrored_x + 1 < width) {
              for (int m = 0; m + 1 < 2 * vectors; ++m) right_window[m] = B::next_lanes(right_window[m], right_window[m + 1]);
              right_window[2 * vectors - 1] = B::next_lanes(right_window[2 * vectors - 1], ones32);
            }
          } else {
            B::store(right_keys + x + (2 * vectors - 1) * L32, right_window[2 * vectors - 1]);
            if (mirrored_x + 1 < width) {
              for (int m = 2 * vectors - 1; m > 0; --m) right_window[m] = B::previous_lanes(right_window[m - 1], right_window[m]);
              right_window[0] = B::previous_lanes(ones32, right_window[0]);
            }
          }
        }
      }
    }
    if constexpr (kSelect) {
      if (lr_check) {
        const int last_x = kBackward ? 0 : width - 1;  // the window's position after the row's last pixel
        for (int m = 0; m < 2 * vectors; ++m) B::store(right_keys + last_x + m * L32, right_window[m]);
      }
      // Finish the row, L32 pixels per vector: integer disparity, sub-pixel step, uniqueness,
      // left-right check, narrow to s16.
      int16_t* out = plane_row<int16_t>(args.outputs[0], row);
      VU32 position = lr_check ? B::sub(lane_numbers32, B::set1_u32(static_cast<uint32_t>(params.min_disparity))) : zero32;
      const VU32 step32 = B::set1_u32(static_cast<uint32_t>(L32));
      for (int x = 0; x < width; x += L16) {
        VU32 result[2];
        for (int half = 0; half < 2; ++half) {
          const int first = x + half * L32;
          const VU32 best_key = load_clipped<B>(best_key_row, first, width);
          const VU32 best = B::bit_and(best_key, low_half);
          const VU32 best_cost = B::template shr<16>(best_key);
          VU32 disparity = B::add(B::template shl<4>(best), disparity_base);
          if (params.subpixel) {
            const VU32 a = B::sub(load_clipped<B>(minus_row, first, width), best_cost);
            const VU32 c = B::sub(load_clipped<B>(plus_row, first, width), best_cost);
            const VU32 offset = parabola_offset_q4<B>(a, c, bit_values, zero32);
            const VU32 interior = B::bit_and(B::cmpgt(best, zero32), B::cmplt(best, last_index32));
            disparity = B::add(disparity, B::bit_and(offset, interior));
          }
          if (params.uniqueness_percent > 0) {
            const VU32 second = B::bit_and(load_clipped<B>(second_row, first, width), low_half);
            const VU32 unique = B::cmpgt(B::mullo(second, keep_percent), B::mullo(best_cost, hundred));
            disparity = B::select(unique, disparity, invalid);
          }
          if (lr_check) {
            const VU32 right_x = B::sub(position, best);  // x - (min_disparity + best)
            position = B::add(position, step32);
            const VU32 key_element = B::template shl<1>(B::add(right_x, right_key_offset));
            const VU32 right_best = B::gather_u16(reinterpret_cast<const uint16_t*>(right_keys), B::as_s32(key_element));
            const VU32 inside = B::as_u32(B::bit_and(B::cmpgt(B::as_s32(right_x), B::as_s32(minus_one32)),
                                                     B::cmplt(B::as_s32(right_x), B::as_s32(width32))));
            const VU32 seen = B::cmplt(right_best, low_half);
            const VU32 difference = B::sub(B::max(best, right_best), B::min(best, right_best));
            const VU32 mismatch = B::bit_and(B::bit_and(B::cmpgt(difference, lr_tolerance), inside), seen);
            disparity = B::select(mismatch, invalid, disparity);
          }
          result[half] = disparity;
        }
        store_clipped<B>(out, x, width, B::narrow_sat_s16(B::as_s32(result[0]), B::as_s32(result[1])));
      }
    }
  }
  if (stream_sums) B::stream_fence();
}

template <class B>
struct IsEmulated : std::false_type {};
template <int kBytes, bool kCounting, int kTag>
struct IsEmulated<simd::Emulated<kBytes, kCounting, kTag>> : std::true_type {};

}  // namespace sgm_detail

// The tile body (see sgm_tile_for). Native vector back ends get bodies specialised for 2, 4 and 8
// disparity vectors (64, 128, 256 disparities on AVX-512): same ops, same bits, faster on the host.
// The emulated back ends (counting, scalar fallback) run the general body.
template <class B, class Word, SgmPass kPass>
void sgm_tile(const TileArgs& args) {
  if constexpr (!sgm_detail::IsEmulated<B>::value) {
    const int vectors = (static_cast<const SgmParams*>(args.params)->num_disparities + B::kLanesU16 - 1) / B::kLanesU16;
    switch (vectors) {
      case 2: return sgm_detail::sgm_tile_for<B, Word, kPass, 2>(args);
      case 4: return sgm_detail::sgm_tile_for<B, Word, kPass, 4>(args);
      case 8: return sgm_detail::sgm_tile_for<B, Word, kPass, 8>(args);
      default: break;
    }
  }
  sgm_detail::sgm_tile_for<B, Word, kPass, 0>(args);
}

// THE BANDED 8-PATH SCHEDULE (kernels/sgm_8path_bands.cpp has its working set in closed form).
// A checkpoint row holds the row state a pass has before it enters a band: the previous row's path
// costs of the three paths that come from it (region 0 the down diagonal, 1 straight, 2 the up
// diagonal; for the backward pass bottom-right, bottom, bottom-left), each as W positions p of D
// values (u8 or u16, sgm_checkpoint_value_bytes):
// value (r W + p) D + j = L_r(pixel p of the previous row, d = min_disparity + D - 1 - j), the
// lanes' reversed order. Positions are in the pass's own order: p = x forward, p = W - 1 - x backward
// (rows and columns mirrored, as the pass walks them). The row state itself is a back end's layout
// (slots of its Dp + 1 u16, diagonals rotated by the row); a checkpoint is the same for every back
// end, so the checkpoint kernels' outputs are compared bit for bit like any other kernel's.
// The first band a pass enters has no previous row: its checkpoint is zero, the frame start's state.
// Saving and restoring are plain copies (on the chip: a DMA of the state), not counted as vector ops.
namespace sgm_detail {

inline int positive_modulo(int value, int modulus) { return ((value % modulus) + modulus) % modulus; }

// The slot that position p of mirrored row `previous_row` wrote in region r (see the tile body).
inline int checkpoint_slot(int region, int position, int previous_row, int width) {
  if (region == 0) return positive_modulo(position - previous_row, width);
  if (region == 2) return positive_modulo(position + previous_row, width);
  return position;
}

// Calls visit(slot, values) for every slot of the row state (this back end's: `padded` lanes per
// slot) and the checkpoint's D values it is kept as (Value: u8 or u16, sgm_checkpoint_value_bytes).
template <class Value, class Visit>
inline void for_each_checkpoint_slot(uint16_t* state, Value* checkpoint, int width, int padded, int count, int previous_row,
                                     Visit&& visit) {
  const ptrdiff_t slot_stride = padded + 1;
  const ptrdiff_t region_size = static_cast<ptrdiff_t>(width) * slot_stride + 1;
  for (int region = 0; region < 3; ++region) {
    for (int position = 0; position < width; ++position) {
      visit(state + region * region_size + static_cast<ptrdiff_t>(checkpoint_slot(region, position, previous_row, width)) * slot_stride + 1,
            checkpoint + (static_cast<ptrdiff_t>(region) * width + position) * count);
    }
  }
}

// The row state into a checkpoint row. A u8 checkpoint is taken only where every value fits (the
// bound above), so the narrowing is exact. The rows of a plane of bytes are only byte-aligned, so
// u16 values are copied bytewise (memcpy), never stored through a u16 pointer.
template <class Value>
inline void save_checkpoint(const uint16_t* state, int width, int padded, int count, int previous_row, Value* checkpoint) {
  for_each_checkpoint_slot(const_cast<uint16_t*>(state), checkpoint, width, padded, count, previous_row,
                           [count](const uint16_t* slot, Value* values) {
                             for (int lane = 0; lane < count; ++lane) {
                               const Value value = static_cast<Value>(slot[lane]);
                               std::memcpy(values + lane, &value, sizeof value);
                             }
                           });
}

// A checkpoint row back into this back end's row state: sentinels and padding lanes 0xFFFF, as the
// pass leaves them after any row. checkpoint == nullptr: the frame start, all zero (the pass sets
// the sentinels on its first row, as for a whole frame).
template <class Value>
inline void restore_checkpoint(const Value* checkpoint, int width, int padded, int count, int previous_row, uint16_t* state) {
  const ptrdiff_t region_size = static_cast<ptrdiff_t>(width) * (padded + 1) + 1;
  if (checkpoint == nullptr) {
    std::fill(state, state + 3 * region_size, uint16_t{0});
    return;
  }
  std::fill(state, state + 3 * region_size, uint16_t{0xFFFF});
  for_each_checkpoint_slot(state, checkpoint, width, padded, count, previous_row, [count](uint16_t* slot, const Value* values) {
    for (int lane = 0; lane < count; ++lane) {
      Value value;
      std::memcpy(&value, values + lane, sizeof value);
      slot[lane] = value;
    }
  });
}

// A checkpoint row of a plane of bytes as its values (u8 or u16).
template <class Value>
inline Value* checkpoint_values(const PlaneView& checkpoints, int row) {
  return reinterpret_cast<Value*>(plane_row<uint8_t>(checkpoints, row));
}

}  // namespace sgm_detail

// What both banded kernels read off their arguments: the census planes are whole, so their size is
// the image's.
struct SgmBandedFrame {
  const SgmParams& params;
  int count, width, height, padded, bands;
};
template <class B>
SgmBandedFrame sgm_banded_frame(const TileArgs& args) {
  const SgmParams& params = *static_cast<const SgmParams*>(args.params);
  return SgmBandedFrame{params, params.num_disparities, args.inputs[0].width, args.inputs[0].height,
                        sgm_padded(params.num_disparities, B::kLanesU16), sgm_band_count(args.inputs[0].height)};
}

// The checkpoint passes' tile: output rows are bands (`args.outputs[0]` row i = band tile_y + i).
// For each band in the pass's order: the state before it goes to its checkpoint row, then the pass
// runs the band's rows (all but the last band: nothing after it reads that state).
template <class B, class Word, SgmPass kPass, class Value>
void sgm_checkpoints_tile_as(const TileArgs& args) {
  static_assert(sgm_writes_checkpoints(kPass));
  constexpr bool kBackward = sgm_rows_bottom_up(kPass);
  const SgmBandedFrame frame = sgm_banded_frame<B>(args);
  const auto [params, count, width, height, padded, bands] = frame;
  const int tile_bands = args.outputs[0].height;
  for (int step = 0; step < tile_bands; ++step) {
    const int band_in_tile = kBackward ? tile_bands - 1 - step : step;
    const int band = args.tile_y + band_in_tile;
    const int y0 = band * kSgmBandRows;
    const int y1 = std::min(y0 + kSgmBandRows, height);
    Value* checkpoint = sgm_detail::checkpoint_values<Value>(args.outputs[0], band_in_tile);
    const bool first_band = kBackward ? band == bands - 1 : band == 0;
    if (first_band) {
      std::memset(checkpoint, 0, sizeof(Value) * 3 * static_cast<size_t>(width) * static_cast<size_t>(count));
    } else {
      sgm_detail::save_checkpoint(reinterpret_cast<const uint16_t*>(args.state), width, padded, count,
                                  kBackward ? height - y1 - 1 : y0 - 1, checkpoint);
    }
    if (kBackward ? band == 0 : band == bands - 1) continue;
    TileArgs band_args = args;
    band_args.outputs[0] = PlaneView{nullptr, 0, width, y1 - y0};  // the band's rows; the pass writes nothing
    band_args.tile_y = y0;
    band_args.image_height = height;
    sgm_tile<B, Word, kPass>(band_args);
  }
}
template <class B, class Word, SgmPass kPass>
void sgm_checkpoints_tile(const TileArgs& args) {
  const auto& params = *static_cast<const SgmParams*>(args.params);
  if (sgm_checkpoint_value_bytes(params, static_cast<int>(sizeof(Word))) == 1) {
    sgm_checkpoints_tile_as<B, Word, kPass, uint8_t>(args);
  } else {
    sgm_checkpoints_tile_as<B, Word, kPass, uint16_t>(args);
  }
}

// sgm_8path_bands' scratch (bytes): the forward and the backward row state (3 regions each), one
// band of forward sums (kSgmBandRows W D u16), then the passes' own scratch.
struct SgmBandsScratchLayout {
  size_t state_bytes = 0;   // each of the two states
  size_t sums_offset = 0;
  size_t pass_offset = 0;
  size_t total = 0;
};
inline SgmBandsScratchLayout sgm_bands_scratch_layout(int width, const SgmParams& params, int word_bytes) {
  auto align = [](size_t bytes) { return (bytes + 63) / 64 * 64; };
  SgmBandsScratchLayout layout;
  layout.state_bytes = align(sgm_state_bytes(width, params.num_disparities, 3));
  layout.sums_offset = 2 * layout.state_bytes;
  layout.pass_offset =
      layout.sums_offset + align(size_t{2} * kSgmBandRows * static_cast<size_t>(width) * static_cast<size_t>(params.num_disparities));
  layout.total = layout.pass_offset + std::max(sgm_scratch_layout(width, params, SgmPass::forward_band, word_bytes).total,
                                               sgm_scratch_layout(width, params, SgmPass::backward_band, word_bytes).total);
  return layout;
}

// sgm_8path_bands' tile: whole rows, whole bands (the tile height is a multiple of kSgmBandRows).
// Inputs: left and right census (whole), the forward and the backward checkpoints. Per band: the
// forward paths from the band's checkpoint write the band's forward sums, then the backward paths
// from theirs add them and select, exactly as sgm_8path_forward + sgm_8path_backward over the frame.
template <class B, class Word>
void sgm_bands_tile(const TileArgs& args) {
  const SgmBandedFrame frame = sgm_banded_frame<B>(args);
  const auto [params, count, width, height, padded, bands] = frame;
  const SgmBandsScratchLayout layout = sgm_bands_scratch_layout(width, params, static_cast<int>(sizeof(Word)));
  uint16_t* const forward_state = reinterpret_cast<uint16_t*>(args.scratch);
  uint16_t* const backward_state = reinterpret_cast<uint16_t*>(args.scratch + layout.state_bytes);
  uint8_t* const sums = args.scratch + layout.sums_offset;
  const ptrdiff_t sums_stride = static_cast<ptrdiff_t>(width) * count * 2;
  const bool narrow = sgm_checkpoint_value_bytes(params, static_cast<int>(sizeof(Word))) == 1;
  for (int y0 = args.tile_y; y0 < args.tile_y + args.outputs[0].height; y0 += kSgmBandRows) {
    const int band = y0 / kSgmBandRows;
    const int y1 = std::min(y0 + kSgmBandRows, height);
    const PlaneView band_sums{sums, sums_stride, width * count, y1 - y0};

    TileArgs forward = args;
    forward.input_count = 2;
    forward.outputs[0] = band_sums;
    forward.tile_y = y0;
    forward.image_height = height;
    forward.state = reinterpret_cast<uint8_t*>(forward_state);
    forward.state_bytes = layout.state_bytes;
    forward.scratch = args.scratch + layout.pass_offset;
    forward.scratch_bytes = layout.total - layout.pass_offset;
    if (narrow) {
      sgm_detail::restore_checkpoint(band == 0 ? nullptr : sgm_detail::checkpoint_values<const uint8_t>(args.inputs[2], band), width,
                                     padded, count, y0 - 1, forward_state);
    } else {
      sgm_detail::restore_checkpoint(band == 0 ? nullptr : sgm_detail::checkpoint_values<const uint16_t>(args.inputs[2], band), width,
                                     padded, count, y0 - 1, forward_state);
    }
    sgm_tile<B, Word, SgmPass::forward_band>(forward);

    TileArgs backward = forward;
    backward.input_count = 3;
    backward.inputs[2] = band_sums;
    backward.outputs[0] = PlaneView{args.outputs[0].origin + static_cast<ptrdiff_t>(y0 - args.tile_y) * args.outputs[0].stride_bytes,
                                    args.outputs[0].stride_bytes, width, y1 - y0};
    backward.state = reinterpret_cast<uint8_t*>(backward_state);
    const bool last_band = band == bands - 1;
    if (narrow) {
      sgm_detail::restore_checkpoint(last_band ? nullptr : sgm_detail::checkpoint_values<const uint8_t>(args.inputs[3], band), width,
                                     padded, count, height - y1 - 1, backward_state);
    } else {
      sgm_detail::restore_checkpoint(last_band ? nullptr : sgm_detail::checkpoint_values<const uint16_t>(args.inputs[3], band), width,
                                     padded, count, height - y1 - 1, backward_state);
    }
    sgm_tile<B, Word, SgmPass::backward_band>(backward);
  }
}

}  // namespace lpstereo::kernels
