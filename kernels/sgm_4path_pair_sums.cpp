// The four paths of single-pass semi-global matching split in two pairs that run side by side:
// sgm_4path_row_pair_sums runs the path along the row and the top-left diagonal, and
// sgm_4path_column_pair_sums the top and top-right paths, each over the whole frame (rows top to
// bottom) writing the per-pixel sums of its two path costs (u16, W*D per row, reversed disparity
// order, as sgm_8path_forward); sgm_sums_select adds the two and selects. Same bits as sgm_4path
// (tested): a schedule for a host with two cores, where sgm_4path's single row-streaming pass keeps
// one core busy. The chip graphs keep sgm_4path, which holds no W x H x D volume at all; this pair
// writes and reads two (4 W H D bytes of DRAM traffic each way). _census64 variants take census9x7.
// Row state: one region (row pair) or two (column pair) of W (Dp32 + 1) + 1 u16; scratch and
// tiles as sgm_8path_forward (kernels/sgm_8path.cpp). Algorithm and bounds: kernels/sgm_core.h.
#include "kernels/sgm_core.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void sgm_4path_row_pair_sums_body(const TileArgs& args) {
  sgm_tile<B, uint32_t, SgmPass::row_pair_sums>(args);
}
template <class B>
void sgm_4path_column_pair_sums_body(const TileArgs& args) {
  sgm_tile<B, uint32_t, SgmPass::column_pair_sums>(args);
}
template <class B>
void sgm_4path_row_pair_sums_census64_body(const TileArgs& args) {
  sgm_tile<B, uint64_t, SgmPass::row_pair_sums>(args);
}
template <class B>
void sgm_4path_column_pair_sums_census64_body(const TileArgs& args) {
  sgm_tile<B, uint64_t, SgmPass::column_pair_sums>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sgm_4path_row_pair_sums, sgm_4path_row_pair_sums_body)
LPSTEREO_NATIVE_ENTRY(sgm_4path_column_pair_sums, sgm_4path_column_pair_sums_body)
LPSTEREO_NATIVE_ENTRY(sgm_4path_row_pair_sums_census64, sgm_4path_row_pair_sums_census64_body)
LPSTEREO_NATIVE_ENTRY(sgm_4path_column_pair_sums_census64, sgm_4path_column_pair_sums_census64_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/sgm_reference.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_4path_row_pair_sums)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_4path_column_pair_sums)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_4path_row_pair_sums_census64)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_4path_column_pair_sums_census64)

namespace lpstereo::kernels {
namespace {
void sgm_4path_row_pair_sums_counting(const TileArgs& args) { sgm_4path_row_pair_sums_body<simd::Counting>(args); }
void sgm_4path_column_pair_sums_counting(const TileArgs& args) { sgm_4path_column_pair_sums_body<simd::Counting>(args); }
void sgm_4path_row_pair_sums_census64_counting(const TileArgs& args) {
  sgm_4path_row_pair_sums_census64_body<simd::Counting>(args);
}
void sgm_4path_column_pair_sums_census64_counting(const TileArgs& args) {
  sgm_4path_column_pair_sums_census64_body<simd::Counting>(args);
}

KernelDescriptor make_sgm_4path_row_pair_sums() {
  KernelDescriptor descriptor =
      sgm_descriptor(SgmPass::row_pair_sums, 4, "sgm_4path_row_pair_sums", sgm_4path_row_pair_sums_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_4path_row_pair_sums)
  return descriptor;
}
KernelDescriptor make_sgm_4path_column_pair_sums() {
  KernelDescriptor descriptor =
      sgm_descriptor(SgmPass::column_pair_sums, 4, "sgm_4path_column_pair_sums", sgm_4path_column_pair_sums_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_4path_column_pair_sums)
  return descriptor;
}
KernelDescriptor make_sgm_4path_row_pair_sums_census64() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::row_pair_sums, 8, "sgm_4path_row_pair_sums_census64",
                                               sgm_4path_row_pair_sums_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_4path_row_pair_sums_census64)
  return descriptor;
}
KernelDescriptor make_sgm_4path_column_pair_sums_census64() {
  KernelDescriptor descriptor = sgm_descriptor(SgmPass::column_pair_sums, 8, "sgm_4path_column_pair_sums_census64",
                                               sgm_4path_column_pair_sums_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_4path_column_pair_sums_census64)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sgm_4path_row_pair_sums, lpstereo::kernels::make_sgm_4path_row_pair_sums);
LPSTEREO_REGISTER_KERNEL(sgm_4path_column_pair_sums, lpstereo::kernels::make_sgm_4path_column_pair_sums);
LPSTEREO_REGISTER_KERNEL(sgm_4path_row_pair_sums_census64, lpstereo::kernels::make_sgm_4path_row_pair_sums_census64);
LPSTEREO_REGISTER_KERNEL(sgm_4path_column_pair_sums_census64, lpstereo::kernels::make_sgm_4path_column_pair_sums_census64);
#endif
