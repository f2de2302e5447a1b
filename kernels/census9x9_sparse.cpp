// census9x9_sparse: sparse census transform over a 9x9 window, u8 -> census32: 5x5 samples two
// pixels apart (every second pixel of every second row), 24 bits. Body and reference:
// kernels/census_window.h. The footprint of the 9x9 census of stereo units such as TI's SDE with
// the 24-bit signature the SGM kernels take.
#include "kernels/census_window.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void census9x9_sparse_body(const TileArgs& args) {
  census_tile<B, 5, 5, uint32_t, 2>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(census9x9_sparse, census9x9_sparse_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(census9x9_sparse)

namespace lpstereo::kernels {
namespace {
void census9x9_sparse_counting(const TileArgs& args) { census9x9_sparse_body<simd::Counting>(args); }

KernelDescriptor make_census9x9_sparse() {
  KernelDescriptor descriptor =
      census_descriptor<5, 5, uint32_t, 2>("census9x9_sparse", ElementType::census32, census9x9_sparse_counting);
  LPSTEREO_FILL_NATIVE_TABLE(census9x9_sparse)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(census9x9_sparse, lpstereo::kernels::make_census9x9_sparse);
#endif
