// The backward paths of 8-path semi-global matching as a pass of their own: sgm_8path_backward_sums
// runs right, bottom-right, bottom and bottom-left (rows bottom up) on census Hamming costs and
// writes the per-pixel sums of their path costs (u16, W*D per row, reversed disparity order, as
// sgm_8path_forward). It reads only the census planes, so it runs beside sgm_8path_forward (two
// workers on the host, two vector units on a chip that has them); sgm_sums_select then adds the
// two sums and selects. Same bits as the two-pass sgm_8path_forward + sgm_8path_backward pair,
// which keeps one sums volume less in DRAM (the chip graphs' choice). _census64 takes census9x7.
// Algorithm, formats and the overflow bound: kernels/sgm_core.h; working set as sgm_8path_forward
// (kernels/sgm_8path.cpp).
#include "kernels/sgm_core.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void sgm_8path_backward_sums_body(const TileArgs& args) {
  sgm_tile<B, uint32_t, SgmPass::backward_sums>(args);
}
template <class B>
void sgm_8path_backward_sums_census64_body(const TileArgs& args) {
  sgm_tile<B, uint64_t, SgmPass::backward_sums>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sgm_8path_backward_sums, sgm_8path_backward_sums_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_backward_sums_census64, sgm_8path_backward_sums_census64_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/sgm_reference.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_backward_sums)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_backward_sums_census64)

namespace lpstereo::kernels {
namespace {
void sgm_8path_backward_sums_counting(const TileArgs& args) { sgm_8path_backward_sums_body<simd::Counting>(args); }
void sgm_8path_backward_sums_census64_counting(const TileArgs& args) {
  sgm_8path_backward_sums_census64_body<simd::Counting>(args);
}

KernelDescriptor make_sgm_8path_backward_sums() {
  KernelDescriptor descriptor =
      sgm_descriptor(SgmPass::backward_sums, 4, "sgm_8path_backward_sums", sgm_8path_backward_sums_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_backward_sums)
  return descriptor;
}
KernelDescriptor make_sgm_8path_backward_sums_census64() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::backward_sums, 8, "sgm_8path_backward_sums_census64",
                                               sgm_8path_backward_sums_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_backward_sums_census64)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sgm_8path_backward_sums, lpstereo::kernels::make_sgm_8path_backward_sums);
LPSTEREO_REGISTER_KERNEL(sgm_8path_backward_sums_census64, lpstereo::kernels::make_sgm_8path_backward_sums_census64);
#endif
