// sgm_sums_select: the last step of semi-global matching when the paths ran as two passes side by
// side, each writing the per-pixel sums of its paths (u16 W*D x H, reversed disparity order):
// sgm_8path_forward + sgm_8path_backward_sums (8 paths), or sgm_4path_row_pair_sums +
// sgm_4path_column_pair_sums (4 paths). S = the two sums (each <= 4 (Cmax + P2), S <= 8 (Cmax + P2)
// < 2^15, no saturation), then winner takes all with the uniqueness ratio, the parabola sub-pixel
// step and the left-right check, exactly as sgm_4path and sgm_8path_backward select
// (kernels/sgm_core.h). No row state: each tile is a band of whole rows (the LR check works along
// the row), and the bands run in parallel.
// Working set (bytes, h = tile height): tiles 2 h (4 W D + 2 W); scratch as sgm_4path (the
// right-view keys and the four per-pixel rows); DRAM reads 4 W H D per frame.
#include "kernels/sgm_core.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void sgm_sums_select_body(const TileArgs& args) {
  sgm_tile<B, uint32_t, SgmPass::select>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sgm_sums_select, sgm_sums_select_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/sgm_reference.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_sums_select)

namespace lpstereo::kernels {
namespace {
void sgm_sums_select_counting(const TileArgs& args) { sgm_sums_select_body<simd::Counting>(args); }

KernelDescriptor make_sgm_sums_select() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::select, 4, "sgm_sums_select", sgm_sums_select_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_sums_select)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sgm_sums_select, lpstereo::kernels::make_sgm_sums_select);
#endif
