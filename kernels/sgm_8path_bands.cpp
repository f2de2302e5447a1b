// sgm_8path_bands: 8-path semi-global matching with no W x H x D volume, bit for bit what
// sgm_8path_forward + sgm_8path_backward compute over the whole frame. The image is cut into bands of
// kSgmBandRows rows; sgm_8path_forward_checkpoints and sgm_8path_backward_checkpoints
// (kernels/sgm_8path_checkpoints.cpp) have saved the row state each pass has when it enters a band.
// Per band, this kernel restores the forward state, runs the four forward paths over the band into a
// band of forward sums (scratch), restores the backward state and runs the four backward paths over
// the band bottom up, adding the band's forward sums and selecting (winner takes all, uniqueness,
// sub-pixel, LR check), as sgm_8path_backward does. Bands carry nothing from one to the next, so the
// tiles (whole bands) run in parallel. _census64 takes census9x7.
// Ports: "left", "right" census (whole), "forward_checkpoints", "backward_checkpoints" (whole),
// "disparity" s16 Q4, invalid = (min_disparity - 1) * 16. Parameters: as sgm_4path.
// Algorithm, formats, overflow bound: kernels/sgm_core.h; definitions: kernels/sgm_reference.h.
//
// THE SCHEDULE'S WORKING SET (closed forms, bytes; Dp32 = ceil(D / 32) * 32, W x H image,
// b = ceil(H / 64) bands, w_c = census bytes, n = worker threads, v = 1 byte a checkpoint value
// when 8 w_c + P2 <= 255 (the defaults), else 2: kernels/sgm_core.h, sgm_checkpoint_value_bytes):
//   checkpoints (DRAM, both passes)  6 v W D b
//   per worker (this kernel's scratch) 12 (W (Dp32 + 1) + 1) (two row states) + 128 W D (one band
//                                    of forward sums) + the passes' scratch (as sgm_8path_backward)
//   the checkpoint passes' state     6 (W (Dp32 + 1) + 1) each
//   plus the census planes 2 w_c W H and the s16 output 2 W H.
// Total O(W D (H / 64 + 64 n)): at 3840 x 1728 x 128 the checkpoints take 80 MB (v = 1; 159 MB
// at v = 2) and each worker 69 MB, against 1.70 GB for one W x H x D u16 volume. Work: the three checkpointed paths of each
// direction run twice (once for the checkpoints, once in the band), 1.75 times the path steps of
// the two-pass schedule, with no volume written to and read back from DRAM.
#include "kernels/sgm_core.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {
template <class B>
void sgm_8path_bands_body(const TileArgs& args) {
  sgm_bands_tile<B, uint32_t>(args);
}
template <class B>
void sgm_8path_bands_census64_body(const TileArgs& args) {
  sgm_bands_tile<B, uint64_t>(args);
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(sgm_8path_bands, sgm_8path_bands_body)
LPSTEREO_NATIVE_ENTRY(sgm_8path_bands_census64, sgm_8path_bands_census64_body)

#if LPSTEREO_ISA_TU == 0
#include "kernels/sgm_reference.h"

LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_bands)
LPSTEREO_DECLARE_NATIVE_ENTRIES(sgm_8path_bands_census64)

namespace lpstereo::kernels {
namespace {
void sgm_8path_bands_counting(const TileArgs& args) { sgm_8path_bands_body<simd::Counting>(args); }
void sgm_8path_bands_census64_counting(const TileArgs& args) { sgm_8path_bands_census64_body<simd::Counting>(args); }

KernelDescriptor make_sgm_8path_bands() {
  KernelDescriptor descriptor = sgm_bands_descriptor(4, "sgm_8path_bands", sgm_8path_bands_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_bands)
  return descriptor;
}
KernelDescriptor make_sgm_8path_bands_census64() {
  KernelDescriptor descriptor = sgm_bands_descriptor(8, "sgm_8path_bands_census64", sgm_8path_bands_census64_counting);
  LPSTEREO_FILL_NATIVE_TABLE(sgm_8path_bands_census64)
  return descriptor;
}
}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(sgm_8path_bands, lpstereo::kernels::make_sgm_8path_bands);
LPSTEREO_REGISTER_KERNEL(sgm_8path_bands_census64, lpstereo::kernels::make_sgm_8path_bands_census64);
#endif
