// sgm_4path (census32 from census5x5) and sgm_4path_census64 (census64 from census9x7):
// single-pass semi-global matching over 4 paths (left to right along the row, top-left, top and
// top-right from the previous row), streaming rows top to bottom with the previous row's path
// costs as row state, fused with winner takes all, uniqueness ratio, parabola sub-pixel step and
// the left-right consistency check. The algorithm and its formats: kernels/sgm_core.h (vector body,
// fixed-point formats, overflow bound, row state) and kernels/sgm_reference.h (definitions).
//
// Parameters: min_disparity (-2047..2046, negative allowed), num_disparities (D, 1..512),
// p1, p2 (Hamming bits, 0 <= p1 <= p2 <= 4000), uniqueness_percent (0..50, 0 = off),
// subpixel (0/1), lr_max_diff (-1 = off, else the tolerance in px).
// Ports: "left", "right" census (window; the right view has a halo of max(0, min_disparity + D - 1)
// columns on the left and max(0, -min_disparity) on the right, replicate border), "disparity"
// s16 Q4, invalid = (min_disparity - 1) * 16.
//
// Working set (closed forms, bytes; Dp32 = ceil(D / 32) * 32, W = image width, h = tile height,
// w_c = 4 (census32) or 8 (census64), halo = max(0, min_disparity + D - 1) + max(0, -min_disparity)):
//   state   = 6 (W (Dp32 + 1) + 1)                         (three paths' previous row, u16, SRAM)
//   scratch = align64(6 (Dp32 + 2)) + align64(4 (W + 2 Dp32 + 64)) + 16 (W + 64)
//   tiles   = 2 h (w_c W + w_c (W + halo) + 2 W)            (double-buffered census in, s16 out)
//   DRAM    : only the census inputs and the s16 output; no cost volume.
//   At W = 3840, D = 128, h = 1: state 2,972,166 B, scratch 79,936 B, SRAM working set 3,129,918 B.
//
// Op count on the counting back end (tests/kernels/sgm_test.cpp, CountedOpsEqualClosedForm, holds the
// same closed form): L = 32 u16 lanes, V = ceil(D / 32), s = log2 32 = 5, t = log2 16 = 4.
// Per pixel:
//   matching cost : permute 1 + V (census64: 1 + 3V), load 2V (4V), logic 2V (4V) + 1 if D % 32,
//                   popcount 2V (4V)
//   4 path steps  : load 9V, store 3V, arith 4 (7V + s) + 3V, permute 4s + 2V (the path along the row
//                   keeps its costs in registers: lane shifts instead of loads and stores)
//   selection     : permute 2V + t, arith 2V - 1 + t, logic 1, store 1
//   + uniqueness  : shift 1, logic 1 + V, arith 2V - 1 + s, compare V, permute s, store 1
//   + sub-pixel   : store V + 2, permute 1, load 2
//   + LR check    : arith 2V, store 1, permute 2V but on the row's last pixel
// Per row (c = ceil(W / 32) chunks, 2c halves of 16 pixels): permute 1 + c, store c, load 2c,
//   logic 2c, shift 4c, arith 2c; sub-pixel: load 4c, arith 32c, shift 8c, compare 14c, logic 20c;
//   uniqueness: load 2c, logic 4c, multiply 4c, compare 2c; LR: store 2V,
//   permute 1, arith 1 + 12c, shift 2c, gather 2c, compare 8c, logic 8c.
// Per tile: permute 11 (+ 4 uniqueness, + 6 sub-pixel, + 4 LR), store ceil((Dp + 2) / 32) + 2,
//   load 1 (+ 1 LR), compare V, arith 2V (+ V uniqueness), logic V.
// At D = 128 (V = 4), all options on: about 330 ops per pixel; on cv1-class about 58 cycles per pixel.
#include "kernels/sgm_core.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void sgm_4path_body(const TileArgs& args) {
  sgm_tile<B, uint32_t, SgmPass::single>(args);
}
template <class B>
void sgm_4path_census64_body(const TileArgs& args) {
  sgm_tile<B, uint64_t, SgmPass::single>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sgm_4path, sgm_4path_body)
LPSTEREO_NATIVE_ENTRY(sgm_4path_census64, sgm_4path_census64_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/sgm_reference.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_4path)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_4path_census64)

namespace lpstereo::kernels {
namespace {
void sgm_4path_counting(const TileArgs& args) { sgm_4path_body<simd::Counting>(args); }
void sgm_4path_census64_counting(const TileArgs& args) { sgm_4path_census64_body<simd::Counting>(args); }

KernelDescriptor make_sgm_4path() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::single, 4, "sgm_4path", sgm_4path_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_4path)
  return descriptor;
}
KernelDescriptor make_sgm_4path_census64() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::single, 8, "sgm_4path_census64", sgm_4path_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_4path_census64)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sgm_4path, lpstereo::kernels::make_sgm_4path);
LPSTEREO_REGISTER_KERNEL(sgm_4path_census64, lpstereo::kernels::make_sgm_4path_census64);
#endif
