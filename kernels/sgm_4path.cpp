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
// Working set (closed forms, bytes; Dp32 = ceil(D / 32) * 32, W = image width, h = tile height):
//   state   = 6 (W (Dp32 + 1) + 1)                      (three paths' previous row, u16)
//   scratch = align64(6 (Dp32 + 2)) + align64(4 (W + 2 Dp32 + 64)) + 2 align64(4 (W + 64))
//   tiles   = 2 h (2 w_c W + 2 w_c (W + halo) + 2 W)    (double-buffered census in, s16 out; w_c = 4 or 8)
//   At W = 3840, D = 128: state 2,972,166 B, scratch 49,280 B.
//
// Op count (counting back end, L = 32 u16 lanes, V = ceil(D / L), s = log2 L = 5, t = log2(L/2) = 4,
// census32: one cost vector = 2 loads, 2 xor, 2 popcount, 1 narrow; census64: 4, 4, 4, 3), per
// pixel:
//   cost    : 1 broadcast (permute); V x (cost vector); 1 or if D % L != 0
//   paths   : 4 x [3V loads, V stores, (V - 1) + s + 1 + 6V arith, 2s permutes] + 3V arith (sums)
//   select  : 2V permutes (keys), (2V - 1) + t arith, 2t permutes, 1 and, 1 shift + 1 shift + 1 add
//   subpixel: V stores, 2 gathers, 2 + 2 + 3 + 1 + 1 + 1 + 1 arith-ish ... (exact figures in
//             tests/kernels/sgm_test.cpp, CountedOpsEqualClosedForm, which this header and the test keep
//             in step)
// plus per row and per tile terms listed in the test.
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
