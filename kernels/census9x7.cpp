// census9x7: census transform over a 9x7 window, u8 -> census64. Body and reference:
// kernels/census_window.h.
#include "kernels/census_window.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void census9x7_body(const TileArgs& args) {
  census_tile<B, 9, 7, uint64_t>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(census9x7, census9x7_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(census9x7)

namespace lpstereo::kernels {
namespace {
void census9x7_counting(const TileArgs& args) { census9x7_body<simd::Counting>(args); }

KernelDescriptor make_census9x7() {
  KernelDescriptor descriptor = census_descriptor<9, 7, uint64_t>("census9x7", ElementType::census64, census9x7_counting);
  LPSTEREO_FILL_NATIVE_TABLE(census9x7)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(census9x7, lpstereo::kernels::make_census9x7);
#endif
