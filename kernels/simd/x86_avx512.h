// The Avx512 native back end of the simd layer: 512-bit vectors on x86-64 with AVX-512 F, BW, VL and
// DQ. Included only by the avx512 translation units (LPSTEREO_ISA_TU == 3, compiled with
// -mavx512f -mavx512bw -mavx512vl -mavx512dq -mbmi2 -mpopcnt; see kernels/simd/native.h), and by
// the avx512-icl ones (LPSTEREO_ISA_TU == 5, the same flags plus -mavx512vpopcntdq -mavx512bitalg),
// which define LPSTEREO_AVX512_STRUCT as Avx512Icl: the same struct under the level's own name (so
// that no function compiled with VPOPCNTDQ can be merged into the avx512 level), whose popcount is
// one instruction (vpopcntb, vpopcntd, vpopcntq) instead of the nibble table.
//
// The contract for every op is kernels/simd/emulated.h; tests/kernels/simd_ops_test.cpp compares each
// op and lane type of this file with it lane by lane. Vector types are thin structs around __m512i so
// that overloads resolve by lane type. Everything is in-class (implicitly inline) and uses no
// standard library templates with code, so no function compiled here can be merged into another
// ISA level by the linker.
//
// Compares produce mask registers; they are expanded to all-ones lanes (vpmovm2*) because the
// contract's masks are vectors. load_partial / store_partial are masked loads and stores (masked-off
// lanes are neither read nor written, and cannot fault), except for one lane: a scalar load or
// store. Unpack instructions work per 128-bit block; zip permutes its inputs first so the result
// follows the contract's whole-vector order.
//
// Ops built from several instructions (marked "emulated"): u8 shifts (16-bit shift + mask), absdiff
// (two saturating subs), popcount on the avx512 level (nibble table with vpshufb, then horizontal
// byte sums), narrow_sat_u16 (clamp negatives to 0 first: vpmovusdw is unsigned).
// Scalar loops: gather_u8 / gather_u16 (vpgatherdd reads 4 bytes per lane, past the addressed
// element).
#pragma once

#if !defined(__AVX512F__) || !defined(__AVX512BW__) || !defined(__AVX512VL__) || !defined(__AVX512DQ__)
#error "x86_avx512.h must be compiled with -mavx512f -mavx512bw -mavx512vl -mavx512dq (the avx512 ISA level)"
#endif

#include <immintrin.h>

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "kernels/simd/x86_lane0.h"

#ifndef LPSTEREO_AVX512_STRUCT
#define LPSTEREO_AVX512_STRUCT Avx512
#endif
#if defined(__AVX512VPOPCNTDQ__) && defined(__AVX512BITALG__)
#define LPSTEREO_AVX512_POPCOUNT_INSTRUCTIONS 1
#else
#define LPSTEREO_AVX512_POPCOUNT_INSTRUCTIONS 0
#endif

namespace lpstereo::simd {

struct LPSTEREO_AVX512_STRUCT {
  static constexpr int kBytes = 64;
  static constexpr const char* kName = LPSTEREO_AVX512_POPCOUNT_INSTRUCTIONS ? "avx512-icl" : "avx512";

  template <class Lane>
  struct Vec {
    static_assert(std::is_same_v<Lane, uint8_t> || std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, int16_t> ||
                      std::is_same_v<Lane, uint32_t> || std::is_same_v<Lane, int32_t> || std::is_same_v<Lane, uint64_t>,
                  "simd lane types are u8, u16, s16, u32, s32 and u64");
    using lane_type = Lane;
    static constexpr int kLanes = kBytes / static_cast<int>(sizeof(Lane));
    __m512i v;
  };
  using VU8 = Vec<uint8_t>;
  using VU16 = Vec<uint16_t>;
  using VS16 = Vec<int16_t>;
  using VU32 = Vec<uint32_t>;
  using VS32 = Vec<int32_t>;
  using VU64 = Vec<uint64_t>;

  static constexpr int kLanesU8 = VU8::kLanes;
  static constexpr int kLanesU16 = VU16::kLanes;
  static constexpr int kLanesU32 = VU32::kLanes;
  static constexpr int kLanesU64 = VU64::kLanes;

  // ---- memory ----
  template <class Lane>
  static Vec<Lane> load(const Lane* source) {
    return {_mm512_loadu_si512(source)};
  }
  // One lane (lane_count == 1) is a scalar load and a move into lane 0, not a masked load: the store
  // buffer forwards a scalar load from a pending vector store that holds its bytes, but not a masked
  // load, which waits for the store to reach the cache. The SGM's sub-pixel step reads S(best +- 1)
  // this way right after storing the pixel's sums (kernels/sgm_core.h); sgm_sums_select with its
  // volumes in cache takes about a fifth less time with these (docs/evaluation.md). Same lanes.
  template <class Lane>
  static Vec<Lane> load_partial(const Lane* source, int lane_count) {
    if (lane_count == 1) return {_mm512_zextsi128_si512(load_lane0(source))};
    const uint64_t mask = lanes_below(lane_count);
    if constexpr (sizeof(Lane) == 1) return {_mm512_maskz_loadu_epi8(static_cast<__mmask64>(mask), source)};
    else if constexpr (sizeof(Lane) == 2) return {_mm512_maskz_loadu_epi16(static_cast<__mmask32>(mask), source)};
    else if constexpr (sizeof(Lane) == 4) return {_mm512_maskz_loadu_epi32(static_cast<__mmask16>(mask), source)};
    else return {_mm512_maskz_loadu_epi64(static_cast<__mmask8>(mask), source)};
  }
  template <class Lane>
  static void store(Lane* destination, const Vec<Lane>& value) {
    _mm512_storeu_si512(destination, value.v);
  }
  template <class Lane>
  static void store_partial(Lane* destination, const Vec<Lane>& value, int lane_count) {
    if (lane_count == 1) {  // a scalar store of lane 0 (see load_partial)
      store_lane0(destination, _mm512_castsi512_si128(value.v));
      return;
    }
    const uint64_t mask = lanes_below(lane_count);
    if constexpr (sizeof(Lane) == 1) _mm512_mask_storeu_epi8(destination, static_cast<__mmask64>(mask), value.v);
    else if constexpr (sizeof(Lane) == 2) _mm512_mask_storeu_epi16(destination, static_cast<__mmask32>(mask), value.v);
    else if constexpr (sizeof(Lane) == 4) _mm512_mask_storeu_epi32(destination, static_cast<__mmask16>(mask), value.v);
    else _mm512_mask_storeu_epi64(destination, static_cast<__mmask8>(mask), value.v);
  }  // Non-temporal streaming store (destination aligned to the vector width); stream_fence() = sfence.
  template <class Lane>
  static void store_stream(Lane* destination, const Vec<Lane>& value) {
    _mm512_stream_si512(reinterpret_cast<__m512i*>(destination), value.v);
  }
  static void stream_fence() { _mm_sfence(); }


  static VU8 set1_u8(uint8_t x) { return {_mm512_set1_epi8(static_cast<char>(x))}; }
  static VU16 set1_u16(uint16_t x) { return {_mm512_set1_epi16(static_cast<short>(x))}; }
  static VS16 set1_s16(int16_t x) { return {_mm512_set1_epi16(x)}; }
  static VU32 set1_u32(uint32_t x) { return {_mm512_set1_epi32(static_cast<int>(x))}; }
  static VS32 set1_s32(int32_t x) { return {_mm512_set1_epi32(x)}; }
  static VU64 set1_u64(uint64_t x) { return {_mm512_set1_epi64(static_cast<long long>(x))}; }

  template <class Lane>
  static Lane extract(const Vec<Lane>& v, int index) {
    Lane lanes[Vec<Lane>::kLanes];
    _mm512_storeu_si512(lanes, v.v);
    return lanes[index];
  }  template <class Lane>
  static Lane first_lane(const Vec<Lane>& v) {
    return static_cast<Lane>(_mm_cvtsi128_si64(_mm512_castsi512_si128(v.v)));  // the low 64 bits, truncated to lane 0
  }


  // ---- arithmetic ----
  template <class Lane>
  static Vec<Lane> add(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (sizeof(Lane) == 1) return {_mm512_add_epi8(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 2) return {_mm512_add_epi16(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 4) return {_mm512_add_epi32(a.v, b.v)};
    else return {_mm512_add_epi64(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> sub(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (sizeof(Lane) == 1) return {_mm512_sub_epi8(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 2) return {_mm512_sub_epi16(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 4) return {_mm512_sub_epi32(a.v, b.v)};
    else return {_mm512_sub_epi64(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> adds(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating add exists for 8- and 16-bit lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm512_adds_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm512_adds_epu16(a.v, b.v)};
    else return {_mm512_adds_epi16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> subs(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating sub exists for 8- and 16-bit lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm512_subs_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm512_subs_epu16(a.v, b.v)};
    else return {_mm512_subs_epi16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> min(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm512_min_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm512_min_epu16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {_mm512_min_epi16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {_mm512_min_epu32(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {_mm512_min_epi32(a.v, b.v)};
    else return {_mm512_min_epu64(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> max(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm512_max_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm512_max_epu16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {_mm512_max_epi16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {_mm512_max_epu32(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {_mm512_max_epi32(a.v, b.v)};
    else return {_mm512_max_epu64(a.v, b.v)};
  }  // Fold 512 -> 256 -> 128 bits, then u16: phminposuw + broadcast; u32: two shuffle + min folds + broadcast.
  template <class Lane>
  static Vec<Lane> min_across(const Vec<Lane>& a) {
    static_assert(std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>, "min_across exists for u16 and u32 lanes");
    const __m256i low256 = _mm512_castsi512_si256(a.v);
    const __m256i high256 = _mm512_extracti64x4_epi64(a.v, 1);
    if constexpr (std::is_same_v<Lane, uint16_t>) {
      const __m256i half = _mm256_min_epu16(low256, high256);
      const __m128i quarter = _mm_min_epu16(_mm256_castsi256_si128(half), _mm256_extracti128_si256(half, 1));
      return {_mm512_broadcastw_epi16(_mm_minpos_epu16(quarter))};
    } else {
      const __m256i half = _mm256_min_epu32(low256, high256);
      const __m128i quarter = _mm_min_epu32(_mm256_castsi256_si128(half), _mm256_extracti128_si256(half, 1));
      const __m128i eighth = _mm_min_epu32(quarter, _mm_shuffle_epi32(quarter, 0x4E));
      return {_mm512_broadcastd_epi32(_mm_min_epu32(eighth, _mm_shuffle_epi32(eighth, 0xB1)))};
    }
  }  // One two-source word permute (vpermt2w) each.
  static VU16 previous_lanes(const VU16& before, const VU16& v) {
    const __m512i index = _mm512_set_epi16(62, 61, 60, 59, 58, 57, 56, 55, 54, 53, 52, 51, 50, 49, 48, 47, 46, 45, 44, 43, 42,
                                           41, 40, 39, 38, 37, 36, 35, 34, 33, 32, 31);
    return {_mm512_permutex2var_epi16(before.v, index, v.v)};
  }
  static VU16 next_lanes(const VU16& v, const VU16& after) {
    const __m512i index = _mm512_set_epi16(32, 31, 30, 29, 28, 27, 26, 25, 24, 23, 22, 21, 20, 19, 18, 17, 16, 15, 14, 13, 12,
                                           11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1);
    return {_mm512_permutex2var_epi16(v.v, index, after.v)};
  }
  // valignd on the concatenation.
  static VU32 previous_lanes(const VU32& before, const VU32& v) { return {_mm512_alignr_epi32(v.v, before.v, 15)}; }
  static VU32 next_lanes(const VU32& v, const VU32& after) { return {_mm512_alignr_epi32(after.v, v.v, 1)}; }


  // Emulated: (a -sat b) | (b -sat a); one of the two is 0.
  template <class Lane>
  static Vec<Lane> absdiff(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "absdiff exists for u8 and u16 lanes");
    if constexpr (sizeof(Lane) == 1) return {_mm512_or_si512(_mm512_subs_epu8(a.v, b.v), _mm512_subs_epu8(b.v, a.v))};
    else return {_mm512_or_si512(_mm512_subs_epu16(a.v, b.v), _mm512_subs_epu16(b.v, a.v))};
  }
  template <class Lane>
  static Vec<Lane> avg(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "avg exists for u8 and u16 lanes");
    if constexpr (sizeof(Lane) == 1) return {_mm512_avg_epu8(a.v, b.v)};
    else return {_mm512_avg_epu16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> mullo(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) == 2 || sizeof(Lane) == 4, "mullo exists for 16- and 32-bit lanes");
    if constexpr (sizeof(Lane) == 2) return {_mm512_mullo_epi16(a.v, b.v)};
    else return {_mm512_mullo_epi32(a.v, b.v)};
  }

  // ---- bitwise ----
  template <class Lane>
  static Vec<Lane> bit_and(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm512_and_si512(a.v, b.v)}; }
  template <class Lane>
  static Vec<Lane> bit_or(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm512_or_si512(a.v, b.v)}; }
  template <class Lane>
  static Vec<Lane> bit_xor(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm512_xor_si512(a.v, b.v)}; }
  template <class Lane>
  static Vec<Lane> bit_andnot(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm512_andnot_si512(a.v, b.v)}; }
  // Bitwise blend in one vpternlog: truth table 0xCA is "first ? second : third" per bit.
  template <class Lane>
  static Vec<Lane> select(const Vec<Lane>& mask, const Vec<Lane>& a, const Vec<Lane>& b) {
    return {_mm512_ternarylogic_epi64(mask.v, a.v, b.v, 0xCA)};
  }

  template <int kShift, class Lane>
  static Vec<Lane> shl(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    if constexpr (sizeof(Lane) == 1) {
      // emulated: 16-bit shift, then clear the bits that crossed in from the neighbouring byte
      return {_mm512_and_si512(_mm512_slli_epi16(a.v, kShift), _mm512_set1_epi8(static_cast<char>((0xFF << kShift) & 0xFF)))};
    } else if constexpr (sizeof(Lane) == 2) {
      return {_mm512_slli_epi16(a.v, kShift)};
    } else if constexpr (sizeof(Lane) == 4) {
      return {_mm512_slli_epi32(a.v, kShift)};
    } else {
      return {_mm512_slli_epi64(a.v, kShift)};
    }
  }
  template <int kShift, class Lane>
  static Vec<Lane> shr(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    if constexpr (sizeof(Lane) == 1) {
      // emulated: 16-bit shift, then clear the bits that crossed in from the neighbouring byte
      return {_mm512_and_si512(_mm512_srli_epi16(a.v, kShift), _mm512_set1_epi8(static_cast<char>(0xFF >> kShift)))};
    } else if constexpr (std::is_same_v<Lane, uint16_t>) {
      return {_mm512_srli_epi16(a.v, kShift)};
    } else if constexpr (std::is_same_v<Lane, int16_t>) {
      return {_mm512_srai_epi16(a.v, kShift)};
    } else if constexpr (std::is_same_v<Lane, uint32_t>) {
      return {_mm512_srli_epi32(a.v, kShift)};
    } else if constexpr (std::is_same_v<Lane, int32_t>) {
      return {_mm512_srai_epi32(a.v, kShift)};
    } else {
      return {_mm512_srli_epi64(a.v, kShift)};
    }
  }

  // ---- compare (mask register expanded to all-ones lanes) ----
  template <class Lane>
  static Vec<Lane> cmpeq(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (sizeof(Lane) == 1) return {_mm512_movm_epi8(_mm512_cmpeq_epi8_mask(a.v, b.v))};
    else if constexpr (sizeof(Lane) == 2) return {_mm512_movm_epi16(_mm512_cmpeq_epi16_mask(a.v, b.v))};
    else if constexpr (sizeof(Lane) == 4) return {_mm512_movm_epi32(_mm512_cmpeq_epi32_mask(a.v, b.v))};
    else return {_mm512_movm_epi64(_mm512_cmpeq_epi64_mask(a.v, b.v))};
  }
  template <class Lane>
  static Vec<Lane> cmpgt(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm512_movm_epi8(_mm512_cmpgt_epu8_mask(a.v, b.v))};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm512_movm_epi16(_mm512_cmpgt_epu16_mask(a.v, b.v))};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {_mm512_movm_epi16(_mm512_cmpgt_epi16_mask(a.v, b.v))};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {_mm512_movm_epi32(_mm512_cmpgt_epu32_mask(a.v, b.v))};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {_mm512_movm_epi32(_mm512_cmpgt_epi32_mask(a.v, b.v))};
    else return {_mm512_movm_epi64(_mm512_cmpgt_epu64_mask(a.v, b.v))};
  }
  template <class Lane>
  static Vec<Lane> cmplt(const Vec<Lane>& a, const Vec<Lane>& b) {
    return cmpgt(b, a);
  }

  // avx512-icl: one instruction per vector (BITALG vpopcntb, VPOPCNTDQ vpopcntd / vpopcntq). The
  // census Hamming costs of the SGM passes are most of its uses: without them, a path pass took
  // about a fifth less time (kernels_bench, 640x480, 64 disparities; docs/kernels.md).
  // avx512, emulated: per-byte counts from a nibble table (vpshufb), summed per lane for u32 / u64.
  template <class Lane>
  static Vec<Lane> popcount(const Vec<Lane>& a) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) != 2, "popcount exists for u8, u32 and u64 lanes");
#if LPSTEREO_AVX512_POPCOUNT_INSTRUCTIONS
    if constexpr (sizeof(Lane) == 1) return {_mm512_popcnt_epi8(a.v)};
    else if constexpr (sizeof(Lane) == 4) return {_mm512_popcnt_epi32(a.v)};
    else return {_mm512_popcnt_epi64(a.v)};
#else
    const __m512i byte_counts = popcount_bytes(a.v);
    if constexpr (sizeof(Lane) == 1) {
      return {byte_counts};
    } else if constexpr (sizeof(Lane) == 4) {
      const __m512i pair_sums = _mm512_maddubs_epi16(byte_counts, _mm512_set1_epi8(1));
      return {_mm512_madd_epi16(pair_sums, _mm512_set1_epi16(1))};
    } else {
      return {_mm512_sad_epu8(byte_counts, _mm512_setzero_si512())};
    }
#endif
  }

  // ---- lane movement ----
  template <class Lane>
  static auto widen_lo(const Vec<Lane>& a) { return widen<Lane>(_mm512_castsi512_si256(a.v)); }
  template <class Lane>
  static auto widen_hi(const Vec<Lane>& a) { return widen<Lane>(_mm512_extracti64x4_epi64(a.v, 1)); }

  // The unpacks work per 128-bit block: block k of the result reads 64-bit element 2k (unpacklo) or
  // 2k + 1 (unpackhi) of each input. Spreading the inputs' 64-bit elements as (0 4 1 5 2 6 3 7)
  // makes zip_lo interleave elements 0..3 (the low half) and zip_hi elements 4..7, in order.
  template <class Lane>
  static auto zip_lo(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 4, "zip exists for u8, u16 and u32 lanes");
    const __m512i a_spread = spread_halves(a.v);
    const __m512i b_spread = spread_halves(b.v);
    if constexpr (sizeof(Lane) == 1) return VU16{_mm512_unpacklo_epi8(a_spread, b_spread)};
    else if constexpr (sizeof(Lane) == 2) return VU32{_mm512_unpacklo_epi16(a_spread, b_spread)};
    else return VU64{_mm512_unpacklo_epi32(a_spread, b_spread)};
  }
  template <class Lane>
  static auto zip_hi(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 4, "zip exists for u8, u16 and u32 lanes");
    const __m512i a_spread = spread_halves(a.v);
    const __m512i b_spread = spread_halves(b.v);
    if constexpr (sizeof(Lane) == 1) return VU16{_mm512_unpackhi_epi8(a_spread, b_spread)};
    else if constexpr (sizeof(Lane) == 2) return VU32{_mm512_unpackhi_epi16(a_spread, b_spread)};
    else return VU64{_mm512_unpackhi_epi32(a_spread, b_spread)};
  }

  // Saturating down-converts (vpmovuswb, vpmovsdw, vpmovusdw) narrow a whole vector to a half in lane
  // order, so no per-block fix-up is needed.
  static VU8 narrow_sat_u8(const VU16& lo, const VU16& hi) {
    return {join_halves(_mm512_cvtusepi16_epi8(lo.v), _mm512_cvtusepi16_epi8(hi.v))};
  }
  static VS16 narrow_sat_s16(const VS32& lo, const VS32& hi) {
    return {join_halves(_mm512_cvtsepi32_epi16(lo.v), _mm512_cvtsepi32_epi16(hi.v))};
  }
  // vpmovusdw reads its input as unsigned: negative lanes are clamped to 0 first (emulated step).
  static VU16 narrow_sat_u16(const VS32& lo, const VS32& hi) {
    const __m512i zero = _mm512_setzero_si512();
    return {join_halves(_mm512_cvtusepi32_epi16(_mm512_max_epi32(lo.v, zero)),
                        _mm512_cvtusepi32_epi16(_mm512_max_epi32(hi.v, zero)))};
  }

  // Emulated: scalar loop (a 32-bit hardware gather would read bytes past the addressed element).
  static VU32 gather_u8(const uint8_t* base, const VS32& offsets) { return gather(base, offsets); }
  static VU32 gather_u16(const uint16_t* base, const VS32& offsets) { return gather(base, offsets); }

  // ---- reinterpretation (free) ----
  template <class To, class From>
  static Vec<To> bitcast(const Vec<From>& a) { return {a.v}; }
  template <class From> static VU8 as_u8(const Vec<From>& a) { return {a.v}; }
  template <class From> static VU16 as_u16(const Vec<From>& a) { return {a.v}; }
  template <class From> static VS16 as_s16(const Vec<From>& a) { return {a.v}; }
  template <class From> static VU32 as_u32(const Vec<From>& a) { return {a.v}; }
  template <class From> static VS32 as_s32(const Vec<From>& a) { return {a.v}; }
  template <class From> static VU64 as_u64(const Vec<From>& a) { return {a.v}; }

 private:
  // Bit i set for i < lane_count (0 <= lane_count <= 64); the caller narrows it to its mask type.
  static uint64_t lanes_below(int lane_count) {
    return lane_count >= 64 ? ~uint64_t{0} : (uint64_t{1} << lane_count) - 1;
  }
  LPSTEREO_X86_LANE0_HELPERS

  static __m512i popcount_bytes(__m512i x) {
    const __m512i nibble_counts =
        _mm512_broadcast_i32x4(_mm_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4));
    const __m512i low_nibble = _mm512_set1_epi8(0x0F);
    const __m512i low = _mm512_and_si512(x, low_nibble);
    const __m512i high = _mm512_and_si512(_mm512_srli_epi16(x, 4), low_nibble);
    return _mm512_add_epi8(_mm512_shuffle_epi8(nibble_counts, low), _mm512_shuffle_epi8(nibble_counts, high));
  }

  // 64-bit elements (0 1 2 3 4 5 6 7) -> (0 4 1 5 2 6 3 7).
  static __m512i spread_halves(__m512i x) {
    return _mm512_permutexvar_epi64(_mm512_set_epi64(7, 3, 6, 2, 5, 1, 4, 0), x);
  }

  static __m512i join_halves(__m256i low, __m256i high) {
    return _mm512_inserti64x4(_mm512_castsi256_si512(low), high, 1);
  }

  // Widens the 32 bytes of x to a full vector.
  template <class Lane>
  static auto widen(__m256i x) {
    static_assert(sizeof(Lane) <= 2, "widen exists for u8, u16 and s16 lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return VU16{_mm512_cvtepu8_epi16(x)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return VU32{_mm512_cvtepu16_epi32(x)};
    else return VS32{_mm512_cvtepi16_epi32(x)};
  }

  template <class Element>
  static VU32 gather(const Element* base, const VS32& offsets) {
    alignas(64) int32_t offset_lanes[kLanesU32];
    alignas(64) uint32_t values[kLanesU32];
    _mm512_store_si512(offset_lanes, offsets.v);
    for (int i = 0; i < kLanesU32; ++i) values[i] = base[offset_lanes[i]];
    return {_mm512_load_si512(values)};
  }
};

}  // namespace lpstereo::simd
