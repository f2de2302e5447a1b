// The 3x3 median shared by median3x3 (u8) and median3x3_s16 (s16 Q4 disparity): one tile body over
// the lane type, the same selection network for both.
//
// Vector schedule (one chunk = one vector of Lane pixels of an output row): the nine window values
// are nine unaligned loads (rows y-1, y, y+1 at columns x-1, x, x+1); the median comes out of a
// min/max selection network, the 19-exchange network of J. L. Smith, "Implementing median filters
// in XC4000E FPGAs", Xilinx XCELL 23 (1996), as written in N. Devillard, "Fast median search: an
// ANSI C implementation" (1998), opt_med9(). Its stages:
//   1. sort each column of three (3 exchanges a column, 9 in all): lo_c <= mid_c <= hi_c;
//   2. the median is med3(max(lo_0, lo_1, lo_2), med3(mid_0, mid_1, mid_2), min(hi_0, hi_1, hi_2)).
// An exchange is a min and a max; the stage-2 exchanges whose other output the network never reads
// are pruned to the one op that is read, so the 19 exchanges cost 30 ops instead of 38:
//   column sorts 3 x 6 = 18, max of lows 2, min of highs 2, median of mids 4, final median 4.
// Per chunk: load 9, arith 30 (min and max, unsigned for u8, signed for s16), store 1, plus what
// the kernel's `finish` adds (median3x3: nothing; median3x3_s16: see its header).
#pragma once

#include "kernels/kernel.h"
#include "kernels/row_access.h"

namespace lpstereo::kernels {

// Sorts a, b, c with three exchanges (six ops): lo <= mid <= hi.
template <class B, class V>
void sort_three(const V& a, const V& b, const V& c, V& lo, V& mid, V& hi) {
  const V b1 = B::min(b, c);
  const V c1 = B::max(b, c);
  const V a2 = B::min(a, b1);
  const V b2 = B::max(a, b1);
  lo = a2;
  mid = B::min(b2, c1);
  hi = B::max(b2, c1);
}

// Median of three with four ops: max(min(a, b), min(max(a, b), c)).
template <class B, class V>
V median_of_three(const V& a, const V& b, const V& c) {
  return B::max(B::min(a, b), B::min(B::max(a, b), c));
}

// The tile body. Input 0: Lane tile with a halo of 1 on every side; output 0: Lane tile.
// finish(centre, median) gives the stored vector (ops it spends are the kernel's to document).
template <class B, class Lane, class Finish>
void median3x3_tile(const TileArgs& args, Finish finish) {
  constexpr int kLanes = B::kBytes / static_cast<int>(sizeof(Lane));
  using V = typename B::template Vec<Lane>;
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int height = destination.height;
  const int readable_end = width + 1;  // the right halo column is the last readable one

  for (int y = 0; y < height; ++y) {
    const Lane* rows[3] = {plane_row<const Lane>(source, y - 1), plane_row<const Lane>(source, y),
                           plane_row<const Lane>(source, y + 1)};
    Lane* out_row = plane_row<Lane>(destination, y);
    for (int x = 0; x < width; x += kLanes) {
      V lo[3], mid[3], hi[3];
      V centre{};
      for (int dx = -1; dx <= 1; ++dx) {
        const V top = load_clipped<B>(rows[0], x + dx, readable_end);
        const V middle = load_clipped<B>(rows[1], x + dx, readable_end);
        const V bottom = load_clipped<B>(rows[2], x + dx, readable_end);
        if (dx == 0) centre = middle;
        sort_three<B>(top, middle, bottom, lo[dx + 1], mid[dx + 1], hi[dx + 1]);
      }
      const V low_max = B::max(B::max(lo[0], lo[1]), lo[2]);
      const V high_min = B::min(B::min(hi[0], hi[1]), hi[2]);
      const V mid_median = median_of_three<B>(mid[0], mid[1], mid[2]);
      store_clipped<B>(out_row, x, width, finish(centre, median_of_three<B>(low_max, mid_median, high_min)));
    }
  }
}

}  // namespace lpstereo::kernels
