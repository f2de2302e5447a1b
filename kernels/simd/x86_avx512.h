// The Avx512 native back end of the simd layer. PLACEHOLDER STAGE: the lane-wise emulation at this
// level's width (64 bytes), compiled with the level's -m flags so the compiler vectorizes it.
// Intrinsic implementations replace it op by op; the contract is kernels/simd/emulated.h.
#pragma once

#include "kernels/simd/emulated.h"

namespace lpstereo::simd {
using Avx512 = Emulated<64, false, 3>;
}  // namespace lpstereo::simd
