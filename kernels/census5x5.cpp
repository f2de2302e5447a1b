// census5x5: census transform over a 5x5 window, u8 -> census32. Body and reference:
// kernels/census_window.h.
#include "kernels/census_window.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void census5x5_body(const TileArgs& args) {
  census_tile<B, 5, 5, uint32_t>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(census5x5, census5x5_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(census5x5)

namespace lpstereo::kernels {
namespace {
void census5x5_counting(const TileArgs& args) { census5x5_body<simd::Counting>(args); }

KernelDescriptor make_census5x5() {
  KernelDescriptor descriptor = census_descriptor<5, 5, uint32_t>("census5x5", ElementType::census32, census5x5_counting);
  LPSTEREO_FILL_NATIVE_TABLE(census5x5)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(census5x5, lpstereo::kernels::make_census5x5);
#endif
