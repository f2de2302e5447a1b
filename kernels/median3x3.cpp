// median3x3: the median of each pixel's 3x3 neighbourhood, u8 -> u8.
//
// Ports: input "input" u8 (window, halo 1 on every side), output "output" u8 of the same size.
// Border modes: replicate and constant (the executor fills the halo; outside pixels of the constant
// mode take the low byte of border_value). No parameters. Exact: the output is one of the nine input
// values, so there is no rounding and no saturation.
//
// Vector schedule (one chunk = B::kLanesU8 pixels of an output row): the nine window values are nine
// unaligned loads (rows y-1, y, y+1 at columns x-1, x, x+1); the median comes out of a min/max
// selection network, the 19-exchange network of J. L. Smith, "Implementing median filters in
// XC4000E FPGAs", Xilinx XCELL 23 (1996), as written in N. Devillard, "Fast median search: an ANSI
// C implementation" (1998), opt_med9(). Its stages:
//   1. sort each column of three (3 exchanges a column, 9 in all): lo_c <= mid_c <= hi_c;
//   2. the median is med3(max(lo_0, lo_1, lo_2), med3(mid_0, mid_1, mid_2), min(hi_0, hi_1, hi_2)).
// An exchange is a min and a max; the stage-2 exchanges whose other output the network never reads
// are pruned to the one op that is read, so the 19 exchanges cost 30 ops instead of 38:
//   column sorts 3 x 6 = 18, max of lows 2, min of highs 2, median of mids 4, final median 4.
// Op count per chunk (closed form, checked by tests/kernels/median3x3_test.cpp):
//   load  = 9
//   arith = 30   (min and max)
//   store = 1
// and nothing else: per tile, ceil(tile_width / L) chunks per row (L = B::kLanesU8), no broadcasts.
#include <algorithm>
#include <array>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

// The three values of one column, sorted: lo <= mid <= hi.
template <class B>
struct SortedColumn {
  typename B::VU8 lo, mid, hi;
};

// Sorts a, b, c with three exchanges (six ops).
template <class B>
SortedColumn<B> sort_column(const typename B::VU8& a, const typename B::VU8& b, const typename B::VU8& c) {
  const auto b1 = B::min(b, c);
  const auto c1 = B::max(b, c);
  const auto a2 = B::min(a, b1);
  const auto b2 = B::max(a, b1);
  return {a2, B::min(b2, c1), B::max(b2, c1)};
}

// Median of three with four ops: max(min(a, b), min(max(a, b), c)).
template <class B>
typename B::VU8 median_of_three(const typename B::VU8& a, const typename B::VU8& b, const typename B::VU8& c) {
  return B::max(B::min(a, b), B::min(B::max(a, b), c));
}

template <class B>
void median3x3_body(const TileArgs& args) {
  constexpr int kLanes = B::kLanesU8;
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int height = destination.height;
  const int readable_end = width + 1;  // the right halo column is the last readable one

  for (int y = 0; y < height; ++y) {
    const uint8_t* rows[3] = {plane_row<const uint8_t>(source, y - 1), plane_row<const uint8_t>(source, y),
                              plane_row<const uint8_t>(source, y + 1)};
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    for (int x = 0; x < width; x += kLanes) {
      SortedColumn<B> columns[3];
      for (int dx = -1; dx <= 1; ++dx) {
        columns[dx + 1] = sort_column<B>(load_clipped<B>(rows[0], x + dx, readable_end),
                                         load_clipped<B>(rows[1], x + dx, readable_end),
                                         load_clipped<B>(rows[2], x + dx, readable_end));
      }
      const auto low_max = B::max(B::max(columns[0].lo, columns[1].lo), columns[2].lo);
      const auto high_min = B::min(B::min(columns[0].hi, columns[1].hi), columns[2].hi);
      const auto mid_median = median_of_three<B>(columns[0].mid, columns[1].mid, columns[2].mid);
      store_clipped<B>(out_row, x, width, median_of_three<B>(low_max, mid_median, high_min));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(median3x3, median3x3_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(median3x3)

namespace lpstereo::kernels {
namespace {

void median3x3_counting(const TileArgs& args) { median3x3_body<simd::Counting>(args); }

// Scalar reference: gathers the nine window values (border applied here) and sorts them.
void median3x3_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                         const void* /*params*/, BorderMode border_mode, uint32_t border_value) {
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  auto pixel = [&](int x, int y) { return reference_pixel_u8(source, x, y, border_mode, border_value); };
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) {
      std::array<uint8_t, 9> window{};
      int index = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) window[index++] = pixel(x + dx, y + dy);
      }
      std::sort(window.begin(), window.end());
      plane_row<uint8_t>(destination, y)[x] = window[4];
    }
  }
}

KernelDescriptor make_median3x3() {
  KernelDescriptor descriptor;
  descriptor.name = "median3x3";
  descriptor.summary = "median of the 3x3 neighbourhood (min/max selection network)";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.halo = {1, 1, 1, 1};
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = [](const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
    check_param_names(params, {});
    return PreparedKernel{nullptr, {input_shapes.at(0)}};
  };
  descriptor.counting = median3x3_counting;
  descriptor.reference = median3x3_reference;
  LPSTEREO_FILL_NATIVE_TABLE(median3x3)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(median3x3, lpstereo::kernels::make_median3x3);
#endif
