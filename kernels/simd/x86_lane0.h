// One lane between memory and lane 0 of a 128-bit register, for the x86 back ends' one-lane
// load_partial / store_partial (kernels/simd/x86_sse42.h, x86_avx2.h, x86_avx512.h).
//
// A macro, expanded inside each back end's struct, not a shared inline function: every function of
// a back end must be compiled at that back end's ISA level and belong to it alone, so that the
// linker cannot keep the copy built with -mavx512* for the SSE4.2 or AVX2 level (the back ends'
// headers say the same of their own functions).
#pragma once

#include <cstring>

// load_lane0: the lane at `source` (any alignment, as the contract allows), zero-extended, in lane 0
// (the other lanes 0). store_lane0: lane 0's bits to `destination` (any alignment). memcpy of one
// lane is a single scalar load or store.
#define LPSTEREO_X86_LANE0_HELPERS                                                                      \
  template <class Lane>                                                                                 \
  static __m128i load_lane0(const Lane* source) {                                                       \
    std::make_unsigned_t<Lane> value;                                                                   \
    std::memcpy(&value, source, sizeof value);                                                          \
    if constexpr (sizeof(Lane) == 8) return _mm_cvtsi64_si128(static_cast<long long>(value));          \
    else return _mm_cvtsi32_si128(static_cast<int>(value));                                             \
  }                                                                                                     \
  template <class Lane>                                                                                 \
  static void store_lane0(Lane* destination, __m128i vector) {                                          \
    Lane value;                                                                                         \
    if constexpr (sizeof(Lane) == 8) value = static_cast<Lane>(_mm_cvtsi128_si64(vector));              \
    else value = static_cast<Lane>(_mm_cvtsi128_si32(vector));                                          \
    std::memcpy(destination, &value, sizeof value);                                                     \
  }
