// Picks the native back end for the translation unit being compiled.
//
// Every kernel source file is compiled once per instruction-set level (kernels/CMakeLists.txt):
// LPSTEREO_ISA_TU is 0 for the baseline build (scalar fallback, descriptor, reference, counting,
// registration) and 1..5 for the sse4.2 / avx2 / avx512 / neon / avx512-icl builds, each with its
// -m flags.
// `Native` is the back end for this unit; kIsa says which level it is; LPSTEREO_ISA_SUFFIX names the
// per-level entry points (census5x5_avx2, ...).
//
// Rule that keeps levels apart: code compiled with -mavx512bw must never be picked by the linker for
// a call from another level. Kernel bodies and helpers therefore live in an anonymous namespace, and
// each back end type is distinct per level (its own struct, or Emulated<..., kIsaTag>).
#pragma once

#include "kernels/simd/emulated.h"
#include "kernels/simd/isa.h"

#ifndef LPSTEREO_ISA_TU
#define LPSTEREO_ISA_TU 0
#endif

#if LPSTEREO_ISA_TU == 0
#define LPSTEREO_ISA_SUFFIX scalar
namespace lpstereo::simd {
inline constexpr Isa kIsa = Isa::scalar;
using Native = Scalar;
}  // namespace lpstereo::simd
#elif LPSTEREO_ISA_TU == 1
#define LPSTEREO_ISA_SUFFIX sse42
#include "kernels/simd/x86_sse42.h"
namespace lpstereo::simd {
inline constexpr Isa kIsa = Isa::sse42;
using Native = Sse42;
}  // namespace lpstereo::simd
#elif LPSTEREO_ISA_TU == 2
#define LPSTEREO_ISA_SUFFIX avx2
#include "kernels/simd/x86_avx2.h"
namespace lpstereo::simd {
inline constexpr Isa kIsa = Isa::avx2;
using Native = Avx2;
}  // namespace lpstereo::simd
#elif LPSTEREO_ISA_TU == 3
#define LPSTEREO_ISA_SUFFIX avx512
#include "kernels/simd/x86_avx512.h"
namespace lpstereo::simd {
inline constexpr Isa kIsa = Isa::avx512;
using Native = Avx512;
}  // namespace lpstereo::simd
#elif LPSTEREO_ISA_TU == 5
#define LPSTEREO_ISA_SUFFIX avx512_icl
#define LPSTEREO_AVX512_STRUCT Avx512Icl
#include "kernels/simd/x86_avx512.h"
namespace lpstereo::simd {
inline constexpr Isa kIsa = Isa::avx512_icl;
using Native = Avx512Icl;
}  // namespace lpstereo::simd
#elif LPSTEREO_ISA_TU == 4
#define LPSTEREO_ISA_SUFFIX neon
#include "kernels/simd/arm_neon.h"
namespace lpstereo::simd {
inline constexpr Isa kIsa = Isa::neon;
using Native = Neon;
}  // namespace lpstereo::simd
#else
#error "LPSTEREO_ISA_TU must be 0..5"
#endif
