// 8-path semi-global matching in two row-streaming passes, never holding a W x H x D volume per
// path: sgm_8path_forward runs the 4 forward paths (left, top-left, top, top-right; rows top to
// bottom) and writes the per-pixel sums of their costs to a DRAM buffer (u16, W*D per row, each
// pixel's D sums in reversed disparity order: element x * D + j holds d = min_disparity + D - 1 - j);
// sgm_8path_backward (rows_bottom_up) runs the other 4 (right, bottom-right, bottom, bottom-left),
// adds the forward sums row by row and selects the disparity exactly as sgm_4path does (winner
// takes all, uniqueness, sub-pixel, LR check). _census64 variants take census9x7 signatures.
// Algorithm, formats and the overflow bound (8 paths: S <= 8 (Cmax + P2) <= 32496): kernels/sgm_core.h.
//
// Working set (bytes; Dp32 = ceil(D / 32) * 32, W x H image, h = tile height, w_c = census bytes):
//   DRAM    : the forward sums, 2 W H D (3840 x 1728 x 128: 1.70 GB, over a 1 GiB budget, so the
//             4K graph uses the single-pass 4-path kernel);
//   forward : state 6 (W (Dp32 + 1) + 1); scratch as sgm_4path plus the staged right row
//             w_c (W + halo + 64); tiles 2 h (2 w_c W + 2 W D) (census rows in, sums out)
//   backward: state as forward; scratch as sgm_4path; tiles 2 h (w_c W + w_c (W + halo) + 2 W D + 2 W)
// Parameters: as sgm_4path; the forward pass takes only min_disparity, num_disparities, p1, p2.
#include "kernels/sgm_core.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void sgm_8path_forward_body(const TileArgs& args) {
  sgm_tile<B, uint32_t, SgmPass::forward>(args);
}
template <class B>
void sgm_8path_backward_body(const TileArgs& args) {
  sgm_tile<B, uint32_t, SgmPass::backward>(args);
}
template <class B>
void sgm_8path_forward_census64_body(const TileArgs& args) {
  sgm_tile<B, uint64_t, SgmPass::forward>(args);
}
template <class B>
void sgm_8path_backward_census64_body(const TileArgs& args) {
  sgm_tile<B, uint64_t, SgmPass::backward>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sgm_8path_forward, sgm_8path_forward_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_backward, sgm_8path_backward_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_forward_census64, sgm_8path_forward_census64_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_backward_census64, sgm_8path_backward_census64_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/sgm_reference.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_forward)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_backward)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_forward_census64)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_backward_census64)

namespace lpstereo::kernels {
namespace {
void sgm_8path_forward_counting(const TileArgs& args) { sgm_8path_forward_body<simd::Counting>(args); }
void sgm_8path_backward_counting(const TileArgs& args) { sgm_8path_backward_body<simd::Counting>(args); }
void sgm_8path_forward_census64_counting(const TileArgs& args) { sgm_8path_forward_census64_body<simd::Counting>(args); }
void sgm_8path_backward_census64_counting(const TileArgs& args) { sgm_8path_backward_census64_body<simd::Counting>(args); }

KernelDescriptor make_sgm_8path_forward() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::forward, 4, "sgm_8path_forward", sgm_8path_forward_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_forward)
  return descriptor;
}
KernelDescriptor make_sgm_8path_backward() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::backward, 4, "sgm_8path_backward", sgm_8path_backward_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_backward)
  return descriptor;
}
KernelDescriptor make_sgm_8path_forward_census64() {
  KernelDescriptor descriptor =
      sgm_descriptor(SgmPass::forward, 8, "sgm_8path_forward_census64", sgm_8path_forward_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_forward_census64)
  return descriptor;
}
KernelDescriptor make_sgm_8path_backward_census64() {
  KernelDescriptor descriptor =
      sgm_descriptor(SgmPass::backward, 8, "sgm_8path_backward_census64", sgm_8path_backward_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_backward_census64)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sgm_8path_forward, lpstereo::kernels::make_sgm_8path_forward);
LPSTEREO_REGISTER_KERNEL(sgm_8path_backward, lpstereo::kernels::make_sgm_8path_backward);
LPSTEREO_REGISTER_KERNEL(sgm_8path_forward_census64, lpstereo::kernels::make_sgm_8path_forward_census64);
LPSTEREO_REGISTER_KERNEL(sgm_8path_backward_census64, lpstereo::kernels::make_sgm_8path_backward_census64);
#endif
