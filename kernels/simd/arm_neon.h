// The Neon native back end of the simd layer. PLACEHOLDER STAGE: the lane-wise emulation at this
// level's width (16 bytes), compiled with the level's -m flags so the compiler vectorizes it.
// Intrinsic implementations replace it op by op; the contract is kernels/simd/emulated.h.
#pragma once

#include "kernels/simd/emulated.h"

namespace lpstereo::simd {
using Neon = Emulated<16, false, 4>;
}  // namespace lpstereo::simd
