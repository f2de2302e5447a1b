// The two checkpoint passes of the banded 8-path SGM schedule (kernels/sgm_8path_bands.cpp):
// sgm_8path_forward_checkpoints runs the three forward paths that come from the previous row
// (top-left, top, top-right; rows top to bottom) and writes, for each band of kSgmBandRows rows, the
// state they have at the band's top; sgm_8path_backward_checkpoints runs the three backward ones
// (bottom-right, bottom, bottom-left; rows bottom up) and writes the state below each band. The path
// along the row starts afresh on every row, so it needs no checkpoint and neither pass runs it; they
// sum nothing and select nothing. They read only the census planes, so they run side by side (two
// workers on the host). _census64 variants take census9x7.
// Output: bytes, one row per band of 3 W D values, u8 when 8 w_c + P2 <= 255 (exact: the path costs
// bound) else u16 (layout and bound: kernels/sgm_core.h, "THE BANDED 8-PATH SCHEDULE" and
// sgm_checkpoint_value_bytes); the first band a pass enters gets zeros. Parameters: min_disparity, num_disparities,
// p1, p2, as sgm_8path_forward. Algorithm, formats, overflow bound: kernels/sgm_core.h.
//
// Working set (bytes; Dp32 = ceil(D / 32) * 32, W x H image, w_c = census bytes):
//   state  : 6 (W (Dp32 + 1) + 1) (three paths' previous row, as sgm_4path)
//   scratch: as sgm_8path_forward (the staged right row included)
//   DRAM   : out 3 v W D ceil(H / 64) per pass, v = 1 or 2 bytes a value (3840 x 1728 x 128:
//            39.8 MB at v = 1), census rows in.
#include "kernels/sgm_core.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void sgm_8path_forward_checkpoints_body(const TileArgs& args) {
  sgm_checkpoints_tile<B, uint32_t, SgmPass::forward_checkpoints>(args);
}
template <class B>
void sgm_8path_backward_checkpoints_body(const TileArgs& args) {
  sgm_checkpoints_tile<B, uint32_t, SgmPass::backward_checkpoints>(args);
}
template <class B>
void sgm_8path_forward_checkpoints_census64_body(const TileArgs& args) {
  sgm_checkpoints_tile<B, uint64_t, SgmPass::forward_checkpoints>(args);
}
template <class B>
void sgm_8path_backward_checkpoints_census64_body(const TileArgs& args) {
  sgm_checkpoints_tile<B, uint64_t, SgmPass::backward_checkpoints>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sgm_8path_forward_checkpoints, sgm_8path_forward_checkpoints_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_backward_checkpoints, sgm_8path_backward_checkpoints_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_forward_checkpoints_census64, sgm_8path_forward_checkpoints_census64_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_backward_checkpoints_census64, sgm_8path_backward_checkpoints_census64_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/sgm_reference.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_forward_checkpoints)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_backward_checkpoints)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_forward_checkpoints_census64)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_backward_checkpoints_census64)

namespace lpstereo::kernels {
namespace {
void sgm_8path_forward_checkpoints_counting(const TileArgs& args) {
  sgm_8path_forward_checkpoints_body<simd::Counting>(args);
}
void sgm_8path_backward_checkpoints_counting(const TileArgs& args) {
  sgm_8path_backward_checkpoints_body<simd::Counting>(args);
}
void sgm_8path_forward_checkpoints_census64_counting(const TileArgs& args) {
  sgm_8path_forward_checkpoints_census64_body<simd::Counting>(args);
}
void sgm_8path_backward_checkpoints_census64_counting(const TileArgs& args) {
  sgm_8path_backward_checkpoints_census64_body<simd::Counting>(args);
}

KernelDescriptor make_sgm_8path_forward_checkpoints() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::forward_checkpoints, 4, "sgm_8path_forward_checkpoints",
                                               sgm_8path_forward_checkpoints_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_forward_checkpoints)
  return descriptor;
}
KernelDescriptor make_sgm_8path_backward_checkpoints() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::backward_checkpoints, 4, "sgm_8path_backward_checkpoints",
                                               sgm_8path_backward_checkpoints_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_backward_checkpoints)
  return descriptor;
}
KernelDescriptor make_sgm_8path_forward_checkpoints_census64() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::forward_checkpoints, 8, "sgm_8path_forward_checkpoints_census64",
                                               sgm_8path_forward_checkpoints_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_forward_checkpoints_census64)
  return descriptor;
}
KernelDescriptor make_sgm_8path_backward_checkpoints_census64() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::backward_checkpoints, 8, "sgm_8path_backward_checkpoints_census64",
                                               sgm_8path_backward_checkpoints_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_backward_checkpoints_census64)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sgm_8path_forward_checkpoints, lpstereo::kernels::make_sgm_8path_forward_checkpoints);
LPSTEREO_REGISTER_KERNEL(sgm_8path_backward_checkpoints, lpstereo::kernels::make_sgm_8path_backward_checkpoints);
LPSTEREO_REGISTER_KERNEL(sgm_8path_forward_checkpoints_census64,
                         lpstereo::kernels::make_sgm_8path_forward_checkpoints_census64);
LPSTEREO_REGISTER_KERNEL(sgm_8path_backward_checkpoints_census64,
                         lpstereo::kernels::make_sgm_8path_backward_checkpoints_census64);
#endif
