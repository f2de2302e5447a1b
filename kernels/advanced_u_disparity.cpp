// advanced_u_disparity: the Advanced U-disparity grid of the obstacle detector (thesis 003 §4.2.3):
// the disparity map accumulated column-wise into a grid of arbitrary width and height whose rows are
// log-scaled in disparity (eq. 4.2, kernels/advanced_u_disparity.h), each vote weighted by the
// obstacle mask (kernels/obstacle_mask.h): obstacle pixels reward their cell, free-space pixels
// penalise it (the thesis' free-space penalty against false positives). s16q4 + u8 -> u16.
//
// Ports: input "disparity" s16q4 W x H and input "mask" u8 W x H (the vldh_mask output), both
//   PortAccess::whole; output "grid" u16 of grid_columns x grid_rows, grid_columns =
//   ceil(W / columns_per_cell). Row 0 = far (min_disparity_px), the last row = near.
// Parameters (prepare refuses others and out-of-range values, KernelError naming the parameter):
//   columns_per_cell (1 .. 64, default 8), grid_rows (1 .. 1024, default 128), min_disparity_px
//   (1/16 .. 2047, default 2.0: no Q4 value lies in (0, 1/16)), max_disparity_px (> min, <= 2048,
//   default 128.0: the s16 Q4 range), exponent_k (0.01 .. 100, default 1.0), obstacle_weight
//   (1 .. 255, default 2), free_weight (0 .. 255, default 1). Shapes: mask = disparity's shape,
//   height <= kMaxHeightPx = 65535 (the overflow bound below).
//
// Semantics: pixel (u, v) with mask m and Q4 disparity D votes when m is kMaskObstacle (+obstacle_
// weight) or kMaskFree (-free_weight) and D has a grid row r = aud_grid_row_of_q4(boundaries, D) >= 0
// (the header's Q4 boundaries; any other mask value, or D outside [d_min, d_max), casts no vote).
// cell(c, r) = clamp(sum of the votes of the pixels with u / columns_per_cell == c and row r, over
// the whole frame, 0, 65535) = clamp(obstacle_weight n_obstacle - free_weight n_free, 0, 65535).
//
// A reduction over the whole frame. The framework tiles a kernel's OUTPUT; the output here is the
// grid, and a grid cell depends on a whole image column strip (every row can vote into it). So the
// inputs are PortAccess::whole and source_rect reports, for a tile of grid columns [c0, c1), the
// image strip [c0 columns_per_cell, c1 columns_per_cell) x all rows: tiles are vertical strips of
// the grid, independent (they run in parallel), each reading its image strip once per window of at
// most 255 grid rows, and the SRAM working set is the strip (2 x 3 bytes x strip width x H) plus the
// scratch below. Full-width tiles would need the whole frame in SRAM (20 MB at 3840 x 1728), so a
// graph at 4K sets the tile width (graphs/obstacle-mask.json: 16 cells x 128 rows, 1.6 MB).
//
// Fixed point and overflow. Counts are exact integers: per band of at most 255 image rows, a u8 lane
// counts one image column's hits of one grid row (<= 255, no wrap); the band's counts are added to
// u16 column totals n_obstacle(x, r), n_free(x, r) <= H <= 65535 (no wrap: prepare refuses taller
// maps); a cell sums columns_per_cell <= 64 column totals in u32 lanes (<= 64 x 65535 < 2^23) and
// weights them: obstacle_weight n_obstacle <= 255 x 2^22 < 2^31 and so is the free term, so the s32
// difference is exact and narrow_sat_u16 (s32 -> u16, clamping to [0, 65535]) is the clamp of the
// semantics. tests/kernels/advanced_u_disparity_test.cpp runs 65535 rows of one weighted column
// into one cell (no wrap, saturates at 65535) and 300 rows (a second band) with exact totals.
//
// Vector schedule. The contract has gather but no scatter (as in v_disparity), so a pixel cannot add
// into its cell; instead compare-and-count over grid rows, in u8 lanes (L8 = B::kLanesU8 columns of
// the strip per chunk), in three steps per chunk, per window of up to 255 grid rows of the tile:
//   1. keys, per image row of a band of up to 255 rows: D (two s16 vectors) -> grid row by a gather
//      from a lookup table of every Q4 value from boundary[0] - 1 to boundary[N] (index clamp(D) -
//      first; rows outside -> 0xFFFF; built in prepare with the header's helpers, copied into the
//      tile's scratch), minus the window's first row, narrowed to u8 with saturation (255 = none);
//      then an obstacle key (the row where m == 2, else 255) and a free key (where m == 1); both
//      stored to scratch. Op count per chunk row: load 3, arith 8, permute 7, gather 4, compare 2,
//      logic 2, store 2.
//   2. per pass of G = 16 grid rows (32 u8 counters in registers): per band row, load the 2 keys,
//      per grid row j: count_obstacle_j -= (key_obstacle == j), count_free_j -= (key_free == j)
//      (a true lane is all ones = -1): 4 ops per grid row per 64 columns (512-bit).
//   3. after the band, the u8 counts are widened and added to the u16 column totals in scratch
//      (per grid row: permute 4, store 4, and from the second band on load 4, arith 4).
// then per grid row of the tile, the merge of columns into cells by gather (a transpose, as in
// v_disparity): per block of L16 cells, per half of L32 cells, sum over i < columns_per_cell of
// gather_u16(totals + i, lane columns_per_cell), for both counts; the weights by mullo; the
// difference; narrow_sat_u16; one store (partial at the last block).
// Closed form per tile of w x h cells (C = ceil(w columns_per_cell / L8) chunks, windows of <= 255
// grid rows, bands of <= 255 image rows, passes of g <= 16 rows, E lookup entries, K = cpc):
//   per tile:            load ceil(E / L16) + 1, store ceil(E / L16), permute 9, multiply 1
//   per chunk, window:   permute 1
//     per image row:     load 3, arith 8, permute 7, gather 4, compare 2, logic 2, store 2
//     per band, pass:    permute g; per band row: load 2, compare 2 g, arith 2 g;
//                        then permute 4 g, store 4 g, and for bands after the first load 4 g, arith 4 g
//   per grid row, block of L16 cells: gather 4 K, arith 4 K - 2, multiply 4, permute 1, store 1.
// On cv1-class (L8 = 64; 0.125 cycle per ALU op, 0.25 per load/store/permute, 1 per gather) at
// 3840 x 1728, 128 grid rows, K = 8: per 64 pixels, 512 compare+sub (64 cycles), 16 key loads (4),
// the key step (8.5), the band flushes (about 1.8): about 78 cycles, 1.2 cycles a pixel, 8.1 M cycles
// a frame, 10.2 ms at 800 MHz; the merge and the tables add well under 1 %. The cost is linear in
// grid_rows (64 rows: about 5.5 ms). Scratch: the table (<= 64 KiB), the band keys (255 x 64 x 2
// bytes) and the column totals (2 x h x Tw x 2 bytes, Tw = round_up(round_up(w, 32) K, 64)).
#include <algorithm>
#include <bit>
#include <cstdint>
#include <string>

#include "kernels/advanced_u_disparity.h"
#include "kernels/kernel.h"
#include "kernels/obstacle_mask.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int kMaxHeightPx = 65535;   // u16 column totals (see the header)
constexpr int kGridRowsPerPass = 16;  // G: 32 u8 counters in registers
constexpr int kRowsPerWindow = 255;   // u8 keys relative to the window's first row; 255 = none
constexpr int kRowsPerBand = 255;     // u8 counts flushed before they can wrap
constexpr int kMaxLanesU8 = 64;       // the widest back end's u8 lanes, sizes scratch
constexpr int kMaxLanesU16 = 32;
constexpr uint16_t kNoRow = 0xFFFF;

struct AudParams {
  int columns_per_cell = 8;
  int grid_rows = 128;
  int obstacle_weight = 2;
  int free_weight = 1;
  int image_width = 0, image_height = 0;
  int16_t table_first_q4 = 0;  // boundary[0] - 1: every D below maps here (no row)
  int16_t table_last_q4 = 0;   // min(boundary[N], 32767): every D above maps here
  int table_entries = 0;       // table_last_q4 - table_first_q4 + 1
  const uint16_t* row_of_q4 = nullptr;  // table_entries grid rows (kNoRow for none), owned below
  std::vector<uint16_t> row_table;
  std::vector<int32_t> boundaries_q4;   // the header's boundaries, for the reference
};

constexpr int round_up(int value, int multiple) { return (value + multiple - 1) / multiple * multiple; }

// Column totals per grid row of the tile: the totals row width (u16 elements), covering every chunk
// and every column a merge block reads, for any back end.
constexpr int totals_width(int tile_width_cells, int columns_per_cell) {
  return round_up(round_up(tile_width_cells, kMaxLanesU16) * columns_per_cell, kMaxLanesU8);
}

struct ScratchLayout {
  size_t table_bytes, keys_bytes, totals_bytes;
};

inline ScratchLayout scratch_layout(int tile_width, int tile_height, const AudParams& params) {
  ScratchLayout layout;
  layout.table_bytes = static_cast<size_t>(round_up(params.table_entries, kMaxLanesU8)) * sizeof(uint16_t);
  layout.keys_bytes = static_cast<size_t>(kRowsPerBand) * 2 * kMaxLanesU8;
  layout.totals_bytes =
      2 * static_cast<size_t>(tile_height) * static_cast<size_t>(totals_width(tile_width, params.columns_per_cell)) * sizeof(uint16_t);
  return layout;
}

alignas(64) constexpr int32_t kLaneIndexS32[kMaxLanesU16 / 2] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};

template <class B>
void advanced_u_disparity_body(const TileArgs& args) {
  using VU8 = typename B::VU8;
  using VU16 = typename B::VU16;
  using VS16 = typename B::VS16;
  using VU32 = typename B::VU32;
  using VS32 = typename B::VS32;
  constexpr int kLanes8 = B::kLanesU8;
  constexpr int kLanes16 = B::kLanesU16;
  constexpr int kLanes32 = B::kLanesU32;
  static_assert(kLanes8 <= kMaxLanesU8 && kLanes16 <= kMaxLanesU16);

  const auto& params = *static_cast<const AudParams*>(args.params);
  const PlaneView& disparity = args.inputs[0];  // whole planes
  const PlaneView& mask = args.inputs[1];
  const PlaneView& grid = args.outputs[0];      // the tile: cells [tile_x, +w) x rows [tile_y, +h)
  const int columns_per_cell = params.columns_per_cell;
  const int tile_cells = grid.width;
  const int tile_rows = grid.height;
  const int strip_x0 = args.tile_x * columns_per_cell;
  const int strip_width = std::min(disparity.width, (args.tile_x + tile_cells) * columns_per_cell) - strip_x0;
  const int chunks = (tile_cells * columns_per_cell + kLanes8 - 1) / kLanes8;
  const int image_height = disparity.height;
  const int width_totals = totals_width(tile_cells, columns_per_cell);

  const ScratchLayout layout = scratch_layout(tile_cells, tile_rows, params);
  uint16_t* table = reinterpret_cast<uint16_t*>(args.scratch);
  uint8_t* keys = args.scratch + layout.table_bytes;  // per band row: obstacle keys, then free keys (L8 each)
  uint16_t* totals_obstacle = reinterpret_cast<uint16_t*>(args.scratch + layout.table_bytes + layout.keys_bytes);
  uint16_t* totals_free = totals_obstacle + static_cast<size_t>(tile_rows) * width_totals;

  // The lookup table into the tile's scratch (SRAM), where the gathers read it.
  for (int i = 0; i < params.table_entries; i += kLanes16) {
    const int lanes = std::min(kLanes16, params.table_entries - i);
    if (lanes == kLanes16) B::store(table + i, B::load(params.row_of_q4 + i));
    else B::store_partial(table + i, B::load_partial(params.row_of_q4 + i, lanes), lanes);
  }
  const VS16 table_first = B::set1_s16(params.table_first_q4);
  const VS16 table_last = B::set1_s16(params.table_last_q4);
  const VU8 no_row = B::set1_u8(0xFF);
  const VU8 obstacle_value = B::set1_u8(kMaskObstacle);
  const VU8 free_value = B::set1_u8(kMaskFree);
  const VU8 zero8 = B::set1_u8(0);
  const VS32 lane_index = B::load(kLaneIndexS32);
  const VS32 cell_offsets = B::mullo(lane_index, B::set1_s32(columns_per_cell));  // lane i: i columns_per_cell
  const VS32 obstacle_weight = B::set1_s32(params.obstacle_weight);
  const VS32 free_weight = B::set1_s32(params.free_weight);

  // Grid row of each lane of a row of Q4 disparities, minus first_row, as u16 (wrapping: rows below
  // first_row and kNoRow become >= 65536 - 1024, which the u8 narrowing saturates to 255 = none).
  auto relative_rows = [&](const VS16& disparity_q4, const VU16& first_row) {
    const VS16 index = B::sub(B::min(B::max(disparity_q4, table_first), table_last), table_first);  // 0 .. 32767
    const VU32 index_low = B::widen_lo(B::as_u16(index));
    const VU32 index_high = B::widen_hi(B::as_u16(index));
    const VU16 rows = B::narrow_sat_u16(B::as_s32(B::gather_u16(table, B::as_s32(index_low))),
                                        B::as_s32(B::gather_u16(table, B::as_s32(index_high))));
    return B::sub(rows, first_row);
  };

  for (int chunk = 0; chunk < chunks; ++chunk) {
    const int column = chunk * kLanes8;  // in the strip and in the totals rows
    const int lanes = std::clamp(strip_width - column, 0, kLanes8);
    const int lanes_low = std::min(lanes, kLanes16);
    const int lanes_high = lanes - lanes_low;
    for (int window_row = 0; window_row < tile_rows; window_row += kRowsPerWindow) {
      const int window_rows = std::min(kRowsPerWindow, tile_rows - window_row);
      const VU16 first_row = B::set1_u16(static_cast<uint16_t>(args.tile_y + window_row));
      for (int band_row = 0; band_row < image_height; band_row += kRowsPerBand) {
        const int band_rows = std::min(kRowsPerBand, image_height - band_row);
        // 1. Keys of the band.
        for (int r = 0; r < band_rows; ++r) {
          const int16_t* d_row = plane_row<const int16_t>(disparity, band_row + r) + strip_x0 + column;
          const uint8_t* m_row = plane_row<const uint8_t>(mask, band_row + r) + strip_x0 + column;
          const VS16 d_low = lanes_low == kLanes16 ? B::load(d_row) : B::load_partial(d_row, lanes_low);
          const VS16 d_high = lanes_high == kLanes16 ? B::load(d_row + kLanes16) : B::load_partial(d_row + kLanes16, lanes_high);
          const VU8 m = lanes == kLanes8 ? B::load(m_row) : B::load_partial(m_row, lanes);
          const VU8 row8 = B::narrow_sat_u8(relative_rows(d_low, first_row), relative_rows(d_high, first_row));
          uint8_t* key_row = keys + static_cast<size_t>(r) * 2 * kLanes8;
          B::store(key_row, B::select(B::cmpeq(m, obstacle_value), row8, no_row));
          B::store(key_row + kLanes8, B::select(B::cmpeq(m, free_value), row8, no_row));
        }
        // 2. Compare-and-count, G grid rows per pass; 3. flush into the u16 column totals.
        for (int pass_row = 0; pass_row < window_rows; pass_row += kGridRowsPerPass) {
          const int pass_rows = std::min(kGridRowsPerPass, window_rows - pass_row);
          VU8 row_keys[kGridRowsPerPass];
          VU8 count_obstacle[kGridRowsPerPass];
          VU8 count_free[kGridRowsPerPass];
          for (int j = 0; j < pass_rows; ++j) {
            row_keys[j] = B::set1_u8(static_cast<uint8_t>(pass_row + j));
            count_obstacle[j] = zero8;
            count_free[j] = zero8;
          }
          for (int r = 0; r < band_rows; ++r) {
            const uint8_t* key_row = keys + static_cast<size_t>(r) * 2 * kLanes8;
            const VU8 key_obstacle = B::load(key_row);
            const VU8 key_free = B::load(key_row + kLanes8);
            for (int j = 0; j < pass_rows; ++j) {
              count_obstacle[j] = B::sub(count_obstacle[j], B::cmpeq(key_obstacle, row_keys[j]));
              count_free[j] = B::sub(count_free[j], B::cmpeq(key_free, row_keys[j]));
            }
          }
          for (int j = 0; j < pass_rows; ++j) {
            const size_t offset = static_cast<size_t>(window_row + pass_row + j) * width_totals + column;
            auto flush = [&](uint16_t* totals, const VU8& counts) {
              VU16 low = B::widen_lo(counts);
              VU16 high = B::widen_hi(counts);
              if (band_row > 0) {
                low = B::add(low, B::load(totals + offset));
                high = B::add(high, B::load(totals + offset + kLanes16));
              }
              B::store(totals + offset, low);
              B::store(totals + offset + kLanes16, high);
            };
            flush(totals_obstacle, count_obstacle[j]);
            flush(totals_free, count_free[j]);
          }
        }
      }
    }
  }

  // The merge: columns into cells by gather, weights, clamp to u16.
  for (int row = 0; row < tile_rows; ++row) {
    uint16_t* out_row = plane_row<uint16_t>(grid, row);
    for (int block = 0; block * kLanes16 < tile_cells; ++block) {
      VS32 values[2];
      for (int half = 0; half < 2; ++half) {
        const size_t first_column = static_cast<size_t>(row) * width_totals +
                                    static_cast<size_t>(block * kLanes16 + half * kLanes32) * columns_per_cell;
        VU32 sum_obstacle = B::gather_u16(totals_obstacle + first_column, cell_offsets);
        VU32 sum_free = B::gather_u16(totals_free + first_column, cell_offsets);
        for (int i = 1; i < columns_per_cell; ++i) {
          sum_obstacle = B::add(sum_obstacle, B::gather_u16(totals_obstacle + first_column + i, cell_offsets));
          sum_free = B::add(sum_free, B::gather_u16(totals_free + first_column + i, cell_offsets));
        }
        values[half] = B::sub(B::mullo(B::as_s32(sum_obstacle), obstacle_weight), B::mullo(B::as_s32(sum_free), free_weight));
      }
      const VU16 cells = B::narrow_sat_u16(values[0], values[1]);
      const int cells_here = std::min(kLanes16, tile_cells - block * kLanes16);
      if (cells_here == kLanes16) B::store(out_row + block * kLanes16, cells);
      else B::store_partial(out_row + block * kLanes16, cells, cells_here);
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(advanced_u_disparity, advanced_u_disparity_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(advanced_u_disparity)

namespace lpstereo::kernels {
namespace {

void advanced_u_disparity_counting(const TileArgs& args) { advanced_u_disparity_body<simd::Counting>(args); }

// Scalar reference: one pass over the image, one signed vote per pixel into an int64 cell, the grid
// row from the header's binary search; clamped at the end.
void advanced_u_disparity_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                    const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const AudParams*>(params_pointer);
  const PlaneView& disparity = inputs[0];
  const PlaneView& mask = inputs[1];
  const PlaneView& grid = outputs[0];
  std::vector<int64_t> sums(static_cast<size_t>(grid.width) * grid.height, 0);
  for (int v = 0; v < disparity.height; ++v) {
    for (int u = 0; u < disparity.width; ++u) {
      const uint8_t m = plane_row<const uint8_t>(mask, v)[u];
      if (m != kMaskObstacle && m != kMaskFree) continue;
      const int row = aud_grid_row_of_q4(params.boundaries_q4, plane_row<const int16_t>(disparity, v)[u]);
      if (row < 0) continue;
      sums[static_cast<size_t>(row) * grid.width + u / params.columns_per_cell] +=
          m == kMaskObstacle ? params.obstacle_weight : -params.free_weight;
    }
  }
  for (int r = 0; r < grid.height; ++r) {
    for (int c = 0; c < grid.width; ++c) {
      plane_row<uint16_t>(grid, r)[c] =
          static_cast<uint16_t>(std::clamp<int64_t>(sums[static_cast<size_t>(r) * grid.width + c], 0, 65535));
    }
  }
}

PreparedKernel advanced_u_disparity_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"columns_per_cell", "grid_rows", "min_disparity_px", "max_disparity_px", "exponent_k",
                             "obstacle_weight", "free_weight"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (disparity, mask), got " + std::to_string(input_shapes.size()));
  }
  auto prepared = std::make_shared<AudParams>();
  prepared->columns_per_cell = param_int(params, "columns_per_cell", 8, 1, 64);
  prepared->obstacle_weight = param_int(params, "obstacle_weight", 2, 1, 255);
  prepared->free_weight = param_int(params, "free_weight", 1, 0, 255);
  AudGridGeometry geometry;
  geometry.grid_rows = param_int(params, "grid_rows", 128, 1, 1024);
  geometry.min_disparity_px = param_double(params, "min_disparity_px", 2.0, 1.0 / 16.0, 2047.0);
  geometry.max_disparity_px = param_double(params, "max_disparity_px", 128.0, 1.0 / 16.0, 2048.0);
  geometry.exponent_k = param_double(params, "exponent_k", 1.0, 0.01, 100.0);
  if (!(geometry.max_disparity_px > geometry.min_disparity_px)) {
    throw KernelError("parameter 'max_disparity_px': expected more than min_disparity_px (" +
                      std::to_string(geometry.min_disparity_px) + "), got " + std::to_string(geometry.max_disparity_px));
  }
  prepared->grid_rows = geometry.grid_rows;
  const PlaneShape& image = input_shapes[0];
  if (input_shapes[1] != image) {
    throw KernelError("input 'mask': expected the disparity's size " + std::to_string(image.width) + " x " +
                      std::to_string(image.height) + ", got " + std::to_string(input_shapes[1].width) + " x " +
                      std::to_string(input_shapes[1].height));
  }
  if (image.height > kMaxHeightPx) {
    throw KernelError("input 'disparity': expected a height of at most " + std::to_string(kMaxHeightPx) +
                      " rows (u16 column totals, see kernels/advanced_u_disparity.cpp), got " + std::to_string(image.height));
  }
  prepared->image_width = image.width;
  prepared->image_height = image.height;
  // The table from Q4 disparity to grid row, built with the header's helpers (the rows of eq. 4.2).
  prepared->boundaries_q4 = aud_row_boundaries_q4(geometry);
  const int32_t first_q4 = prepared->boundaries_q4.front() - 1;  // >= 0: boundary[0] >= 1 since d_min >= 1/16
  const int32_t last_q4 = std::min<int32_t>(prepared->boundaries_q4.back(), 32767);
  prepared->table_first_q4 = static_cast<int16_t>(first_q4);
  prepared->table_last_q4 = static_cast<int16_t>(last_q4);
  prepared->table_entries = last_q4 - first_q4 + 1;
  prepared->row_table.assign(static_cast<size_t>(round_up(prepared->table_entries, kMaxLanesU8)), kNoRow);
  for (int32_t q4 = first_q4; q4 <= last_q4; ++q4) {
    const int row = aud_grid_row_of_q4(prepared->boundaries_q4, q4);
    prepared->row_table[static_cast<size_t>(q4 - first_q4)] = row < 0 ? kNoRow : static_cast<uint16_t>(row);
  }
  prepared->row_of_q4 = prepared->row_table.data();
  const int grid_columns = (image.width + prepared->columns_per_cell - 1) / prepared->columns_per_cell;
  return PreparedKernel{prepared, {{grid_columns, prepared->grid_rows}}};
}

KernelDescriptor make_advanced_u_disparity() {
  KernelDescriptor descriptor;
  descriptor.name = "advanced_u_disparity";
  descriptor.summary =
      "Advanced U-disparity (thesis 003 eq. 4.2): u16 grid of columns_per_cell-wide cells x log-scaled disparity rows, "
      "votes weighted by the obstacle mask (+obstacle_weight, -free_weight), clamped to 0..65535";
  descriptor.ports = {{"disparity", PortDirection::input, {ElementType::s16, 4}, PortAccess::whole},
                      {"mask", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"grid", PortDirection::output, {ElementType::u16, 0}, PortAccess::window}};
  descriptor.halo = {0, 0, 0, 0};
  descriptor.border_modes = {BorderMode::replicate};  // no pixel outside the image is ever read
  descriptor.prepare = advanced_u_disparity_prepare;
  descriptor.scratch_bytes = [](int tile_width, int tile_height, const void* params_pointer) {
    const ScratchLayout layout = scratch_layout(tile_width, tile_height, *static_cast<const AudParams*>(params_pointer));
    return layout.table_bytes + layout.keys_bytes + layout.totals_bytes;
  };
  // A tile of grid columns [x0, x1) reads the image strip under them, every row.
  descriptor.source_rect = [](int, const PixelRect& output_tile, const PlaneShape& input_shape, const void* params_pointer) {
    const int columns_per_cell = static_cast<const AudParams*>(params_pointer)->columns_per_cell;
    return PixelRect{std::min(input_shape.width, output_tile.x0 * columns_per_cell), 0,
                     std::min(input_shape.width, output_tile.x1 * columns_per_cell), input_shape.height};
  };
  descriptor.counting = advanced_u_disparity_counting;
  descriptor.reference = advanced_u_disparity_reference;
  LPSTEREO_FILL_NATIVE_TABLE(advanced_u_disparity)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(advanced_u_disparity, lpstereo::kernels::make_advanced_u_disparity);
#endif
