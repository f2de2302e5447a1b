// The Avx2 native back end of the simd layer: 256-bit vectors on x86-64 with AVX2 and BMI2.
// Included only by the avx2 translation units (LPSTEREO_ISA_TU == 2, compiled with -mavx2 -mbmi2
// -mpopcnt; see kernels/simd/native.h).
//
// The contract for every op is kernels/simd/emulated.h; tests/kernels/simd_ops_test.cpp compares each
// op and lane type of this file with it lane by lane. Vector types are thin structs around __m256i so
// that overloads resolve by lane type. Everything is in-class (implicitly inline) and uses no
// standard library templates with code, so no function compiled here can be merged into another
// ISA level by the linker.
//
// AVX2's unpack and pack instructions work within each 128-bit half; widen, zip and narrow follow
// the contract's whole-vector lane order (a cross-half permute before zip, after narrow).
//
// Ops AVX2 has no single instruction for (built from several instructions, marked "emulated"):
//   unsigned compares (u8/u16/u32/u64: sign-bias xor then signed compare), min/max on u64 (compare +
//   blend), u8 shifts (16-bit shift + mask), absdiff (two saturating subs), popcount (nibble table
//   with vpshufb, then horizontal byte sums), narrow_sat_u8 (clamp to 255 first: packus is signed).
//   Scalar loops: gather_u8 / gather_u16 (vpgatherdd reads 4 bytes per lane, past the addressed
//   element), and load_partial / store_partial through a stack buffer (so no byte past p + n is read
//   or written). vpmaskmov is not used for them: the manuals leave faults on masked-off elements
//   "implementation dependent", and QEMU's x86 emulation does fault there.
#pragma once

#if !defined(__AVX2__) || !defined(__BMI2__)
#error "x86_avx2.h must be compiled with -mavx2 -mbmi2 (the avx2 ISA level, kernels/simd/native.h)"
#endif

#include <immintrin.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "kernels/simd/x86_lane0.h"

namespace lpstereo::simd {

struct Avx2 {
  static constexpr int kBytes = 32;
  static constexpr const char* kName = "avx2";

  template <class Lane>
  struct Vec {
    static_assert(std::is_same_v<Lane, uint8_t> || std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, int16_t> ||
                      std::is_same_v<Lane, uint32_t> || std::is_same_v<Lane, int32_t> || std::is_same_v<Lane, uint64_t>,
                  "simd lane types are u8, u16, s16, u32, s32 and u64");
    using lane_type = Lane;
    static constexpr int kLanes = kBytes / static_cast<int>(sizeof(Lane));
    __m256i v;
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
    return {_mm256_loadu_si256(reinterpret_cast<const __m256i*>(source))};
  }
  // Emulated: copies exactly lane_count lanes into a zeroed buffer, then loads it. One lane is a
  // scalar load and a move into lane 0 instead: the store buffer forwards a scalar load from a
  // pending wider store, while the buffer's vector load after small stores waits for them to reach
  // the cache (the SGM's sub-pixel reads, kernels/sgm_core.h; see x86_avx512.h).
  template <class Lane>
  static Vec<Lane> load_partial(const Lane* source, int lane_count) {
    if (lane_count == 1) return {_mm256_zextsi128_si256(load_lane0(source))};
    alignas(32) uint8_t buffer[kBytes] = {};
    if (lane_count > 0) std::memcpy(buffer, source, sizeof(Lane) * static_cast<size_t>(lane_count));
    return {_mm256_load_si256(reinterpret_cast<const __m256i*>(buffer))};
  }
  template <class Lane>
  static void store(Lane* destination, const Vec<Lane>& value) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(destination), value.v);
  }
  // Emulated: stores to a buffer, then copies exactly lane_count lanes out; one lane is a scalar store.
  template <class Lane>
  static void store_partial(Lane* destination, const Vec<Lane>& value, int lane_count) {
    if (lane_count == 1) {
      store_lane0(destination, _mm256_castsi256_si128(value.v));
      return;
    }
    alignas(32) uint8_t buffer[kBytes];
    _mm256_store_si256(reinterpret_cast<__m256i*>(buffer), value.v);
    if (lane_count > 0) std::memcpy(destination, buffer, sizeof(Lane) * static_cast<size_t>(lane_count));
  }  // Non-temporal streaming store (destination aligned to the vector width); stream_fence() = sfence.
  template <class Lane>
  static void store_stream(Lane* destination, const Vec<Lane>& value) {
    _mm256_stream_si256(reinterpret_cast<__m256i*>(destination), value.v);
  }
  static void stream_fence() { _mm_sfence(); }


  static VU8 set1_u8(uint8_t x) { return {_mm256_set1_epi8(static_cast<char>(x))}; }
  static VU16 set1_u16(uint16_t x) { return {_mm256_set1_epi16(static_cast<short>(x))}; }
  static VS16 set1_s16(int16_t x) { return {_mm256_set1_epi16(x)}; }
  static VU32 set1_u32(uint32_t x) { return {_mm256_set1_epi32(static_cast<int>(x))}; }
  static VS32 set1_s32(int32_t x) { return {_mm256_set1_epi32(x)}; }
  static VU64 set1_u64(uint64_t x) { return {_mm256_set1_epi64x(static_cast<long long>(x))}; }

  template <class Lane>
  static Lane extract(const Vec<Lane>& v, int index) {
    Lane lanes[Vec<Lane>::kLanes];
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(lanes), v.v);
    return lanes[index];
  }  template <class Lane>
  static Lane first_lane(const Vec<Lane>& v) {
    return static_cast<Lane>(_mm_cvtsi128_si64(_mm256_castsi256_si128(v.v)));  // the low 64 bits, truncated to lane 0
  }


  // ---- arithmetic ----
  template <class Lane>
  static Vec<Lane> add(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (sizeof(Lane) == 1) return {_mm256_add_epi8(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 2) return {_mm256_add_epi16(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 4) return {_mm256_add_epi32(a.v, b.v)};
    else return {_mm256_add_epi64(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> sub(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (sizeof(Lane) == 1) return {_mm256_sub_epi8(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 2) return {_mm256_sub_epi16(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 4) return {_mm256_sub_epi32(a.v, b.v)};
    else return {_mm256_sub_epi64(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> adds(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating add exists for 8- and 16-bit lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm256_adds_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm256_adds_epu16(a.v, b.v)};
    else return {_mm256_adds_epi16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> subs(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating sub exists for 8- and 16-bit lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm256_subs_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm256_subs_epu16(a.v, b.v)};
    else return {_mm256_subs_epi16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> min(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm256_min_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm256_min_epu16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {_mm256_min_epi16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {_mm256_min_epu32(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {_mm256_min_epi32(a.v, b.v)};
    else return {_mm256_blendv_epi8(a.v, b.v, greater_u64(a.v, b.v))};  // emulated: compare + blend
  }
  template <class Lane>
  static Vec<Lane> max(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return {_mm256_max_epu8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {_mm256_max_epu16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {_mm256_max_epi16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {_mm256_max_epu32(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {_mm256_max_epi32(a.v, b.v)};
    else return {_mm256_blendv_epi8(b.v, a.v, greater_u64(a.v, b.v))};  // emulated: compare + blend
  }  // Fold the two 128-bit halves, then u16: phminposuw + broadcast; u32: two shuffle + min folds + broadcast.
  template <class Lane>
  static Vec<Lane> min_across(const Vec<Lane>& a) {
    static_assert(std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>, "min_across exists for u16 and u32 lanes");
    const __m128i low = _mm256_castsi256_si128(a.v);
    const __m128i high = _mm256_extracti128_si256(a.v, 1);
    if constexpr (std::is_same_v<Lane, uint16_t>) {
      return {_mm256_broadcastw_epi16(_mm_minpos_epu16(_mm_min_epu16(low, high)))};
    } else {
      const __m128i quarter = _mm_min_epu32(low, high);
      const __m128i halves = _mm_min_epu32(quarter, _mm_shuffle_epi32(quarter, 0x4E));
      return {_mm256_broadcastd_epi32(_mm_min_epu32(halves, _mm_shuffle_epi32(halves, 0xB1)))};
    }
  }  // vpalignr works per 128-bit block: the block pair that straddles the two vectors first (vperm2i128).
  static VU16 previous_lanes(const VU16& before, const VU16& v) {
    return {_mm256_alignr_epi8(v.v, _mm256_permute2x128_si256(before.v, v.v, 0x21), 14)};
  }
  static VU16 next_lanes(const VU16& v, const VU16& after) {
    return {_mm256_alignr_epi8(_mm256_permute2x128_si256(v.v, after.v, 0x21), v.v, 2)};
  }
  static VU32 previous_lanes(const VU32& before, const VU32& v) {
    return {_mm256_alignr_epi8(v.v, _mm256_permute2x128_si256(before.v, v.v, 0x21), 12)};
  }
  static VU32 next_lanes(const VU32& v, const VU32& after) {
    return {_mm256_alignr_epi8(_mm256_permute2x128_si256(v.v, after.v, 0x21), v.v, 4)};
  }


  // Emulated: (a -sat b) | (b -sat a); one of the two is 0.
  template <class Lane>
  static Vec<Lane> absdiff(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "absdiff exists for u8 and u16 lanes");
    if constexpr (sizeof(Lane) == 1) return {_mm256_or_si256(_mm256_subs_epu8(a.v, b.v), _mm256_subs_epu8(b.v, a.v))};
    else return {_mm256_or_si256(_mm256_subs_epu16(a.v, b.v), _mm256_subs_epu16(b.v, a.v))};
  }
  template <class Lane>
  static Vec<Lane> avg(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "avg exists for u8 and u16 lanes");
    if constexpr (sizeof(Lane) == 1) return {_mm256_avg_epu8(a.v, b.v)};
    else return {_mm256_avg_epu16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> mullo(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) == 2 || sizeof(Lane) == 4, "mullo exists for 16- and 32-bit lanes");
    if constexpr (sizeof(Lane) == 2) return {_mm256_mullo_epi16(a.v, b.v)};
    else return {_mm256_mullo_epi32(a.v, b.v)};
  }

  // ---- bitwise ----
  template <class Lane>
  static Vec<Lane> bit_and(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm256_and_si256(a.v, b.v)}; }
  template <class Lane>
  static Vec<Lane> bit_or(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm256_or_si256(a.v, b.v)}; }
  template <class Lane>
  static Vec<Lane> bit_xor(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm256_xor_si256(a.v, b.v)}; }
  template <class Lane>
  static Vec<Lane> bit_andnot(const Vec<Lane>& a, const Vec<Lane>& b) { return {_mm256_andnot_si256(a.v, b.v)}; }
  // Bitwise blend of every bit (not pblendvb, which looks at the top bit of each byte only).
  template <class Lane>
  static Vec<Lane> select(const Vec<Lane>& mask, const Vec<Lane>& a, const Vec<Lane>& b) {
    return {_mm256_or_si256(_mm256_and_si256(mask.v, a.v), _mm256_andnot_si256(mask.v, b.v))};
  }

  template <int kShift, class Lane>
  static Vec<Lane> shl(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    if constexpr (sizeof(Lane) == 1) {
      // emulated: 16-bit shift, then clear the bits that crossed in from the neighbouring byte
      return {_mm256_and_si256(_mm256_slli_epi16(a.v, kShift), _mm256_set1_epi8(static_cast<char>((0xFF << kShift) & 0xFF)))};
    } else if constexpr (sizeof(Lane) == 2) {
      return {_mm256_slli_epi16(a.v, kShift)};
    } else if constexpr (sizeof(Lane) == 4) {
      return {_mm256_slli_epi32(a.v, kShift)};
    } else {
      return {_mm256_slli_epi64(a.v, kShift)};
    }
  }
  template <int kShift, class Lane>
  static Vec<Lane> shr(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    if constexpr (sizeof(Lane) == 1) {
      // emulated: 16-bit shift, then clear the bits that crossed in from the neighbouring byte
      return {_mm256_and_si256(_mm256_srli_epi16(a.v, kShift), _mm256_set1_epi8(static_cast<char>(0xFF >> kShift)))};
    } else if constexpr (std::is_same_v<Lane, uint16_t>) {
      return {_mm256_srli_epi16(a.v, kShift)};
    } else if constexpr (std::is_same_v<Lane, int16_t>) {
      return {_mm256_srai_epi16(a.v, kShift)};
    } else if constexpr (std::is_same_v<Lane, uint32_t>) {
      return {_mm256_srli_epi32(a.v, kShift)};
    } else if constexpr (std::is_same_v<Lane, int32_t>) {
      return {_mm256_srai_epi32(a.v, kShift)};
    } else {
      return {_mm256_srli_epi64(a.v, kShift)};
    }
  }

  // ---- compare ----
  template <class Lane>
  static Vec<Lane> cmpeq(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (sizeof(Lane) == 1) return {_mm256_cmpeq_epi8(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 2) return {_mm256_cmpeq_epi16(a.v, b.v)};
    else if constexpr (sizeof(Lane) == 4) return {_mm256_cmpeq_epi32(a.v, b.v)};
    else return {_mm256_cmpeq_epi64(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> cmpgt(const Vec<Lane>& a, const Vec<Lane>& b) {
    return {greater<Lane>(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> cmplt(const Vec<Lane>& a, const Vec<Lane>& b) {
    return {greater<Lane>(b.v, a.v)};
  }

  // Emulated: per-byte counts from a nibble table (pshufb), summed per lane for u32 / u64.
  template <class Lane>
  static Vec<Lane> popcount(const Vec<Lane>& a) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) != 2, "popcount exists for u8, u32 and u64 lanes");
    const __m256i byte_counts = popcount_bytes(a.v);
    if constexpr (sizeof(Lane) == 1) {
      return {byte_counts};
    } else if constexpr (sizeof(Lane) == 4) {
      const __m256i pair_sums = _mm256_maddubs_epi16(byte_counts, _mm256_set1_epi8(1));
      return {_mm256_madd_epi16(pair_sums, _mm256_set1_epi16(1))};
    } else {
      return {_mm256_sad_epu8(byte_counts, _mm256_setzero_si256())};
    }
  }

  // ---- lane movement ----
  template <class Lane>
  static auto widen_lo(const Vec<Lane>& a) { return widen<Lane>(_mm256_castsi256_si128(a.v)); }
  template <class Lane>
  static auto widen_hi(const Vec<Lane>& a) { return widen<Lane>(_mm256_extracti128_si256(a.v, 1)); }

  // The unpacks work per 128-bit half; with the middle 64-bit quarters of both inputs swapped, the
  // low half of the result interleaves the vector's first quarter and the high half its second
  // (zip_lo), or its third and fourth (zip_hi).
  template <class Lane>
  static auto zip_lo(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 4, "zip exists for u8, u16 and u32 lanes");
    const __m256i a_swapped = swap_middle_quarters(a.v);
    const __m256i b_swapped = swap_middle_quarters(b.v);
    if constexpr (sizeof(Lane) == 1) return VU16{_mm256_unpacklo_epi8(a_swapped, b_swapped)};
    else if constexpr (sizeof(Lane) == 2) return VU32{_mm256_unpacklo_epi16(a_swapped, b_swapped)};
    else return VU64{_mm256_unpacklo_epi32(a_swapped, b_swapped)};
  }
  template <class Lane>
  static auto zip_hi(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 4, "zip exists for u8, u16 and u32 lanes");
    const __m256i a_swapped = swap_middle_quarters(a.v);
    const __m256i b_swapped = swap_middle_quarters(b.v);
    if constexpr (sizeof(Lane) == 1) return VU16{_mm256_unpackhi_epi8(a_swapped, b_swapped)};
    else if constexpr (sizeof(Lane) == 2) return VU32{_mm256_unpackhi_epi16(a_swapped, b_swapped)};
    else return VU64{_mm256_unpackhi_epi32(a_swapped, b_swapped)};
  }

  // The packs work per 128-bit half, giving 64-bit quarters (lo.0 hi.0 lo.1 hi.1); swapping the
  // middle quarters puts them in whole-vector order (lo.0 lo.1 hi.0 hi.1).
  // packus_epi16 reads its input as signed, so u16 lanes are clamped to 255 first (emulated step).
  static VU8 narrow_sat_u8(const VU16& lo, const VU16& hi) {
    const __m256i limit = _mm256_set1_epi16(0xFF);
    return {swap_middle_quarters(_mm256_packus_epi16(_mm256_min_epu16(lo.v, limit), _mm256_min_epu16(hi.v, limit)))};
  }
  static VS16 narrow_sat_s16(const VS32& lo, const VS32& hi) {
    return {swap_middle_quarters(_mm256_packs_epi32(lo.v, hi.v))};
  }
  static VU16 narrow_sat_u16(const VS32& lo, const VS32& hi) {
    return {swap_middle_quarters(_mm256_packus_epi32(lo.v, hi.v))};
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
  LPSTEREO_X86_LANE0_HELPERS
  // Unsigned a > b as a lane mask: flip the sign bits, then compare signed.
  template <class Lane>
  static __m256i greater(__m256i a, __m256i b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) {
      const __m256i bias = _mm256_set1_epi8(static_cast<char>(0x80));
      return _mm256_cmpgt_epi8(_mm256_xor_si256(a, bias), _mm256_xor_si256(b, bias));
    } else if constexpr (std::is_same_v<Lane, uint16_t>) {
      const __m256i bias = _mm256_set1_epi16(static_cast<short>(0x8000));
      return _mm256_cmpgt_epi16(_mm256_xor_si256(a, bias), _mm256_xor_si256(b, bias));
    } else if constexpr (std::is_same_v<Lane, int16_t>) {
      return _mm256_cmpgt_epi16(a, b);
    } else if constexpr (std::is_same_v<Lane, uint32_t>) {
      const __m256i bias = _mm256_set1_epi32(static_cast<int>(0x80000000u));
      return _mm256_cmpgt_epi32(_mm256_xor_si256(a, bias), _mm256_xor_si256(b, bias));
    } else if constexpr (std::is_same_v<Lane, int32_t>) {
      return _mm256_cmpgt_epi32(a, b);
    } else {
      return greater_u64(a, b);
    }
  }
  static __m256i greater_u64(__m256i a, __m256i b) {
    const __m256i bias = _mm256_set1_epi64x(static_cast<long long>(0x8000000000000000ull));
    return _mm256_cmpgt_epi64(_mm256_xor_si256(a, bias), _mm256_xor_si256(b, bias));
  }

  static __m256i popcount_bytes(__m256i x) {
    const __m256i nibble_counts = _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4,  //
                                                   0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4);
    const __m256i low_nibble = _mm256_set1_epi8(0x0F);
    const __m256i low = _mm256_and_si256(x, low_nibble);
    const __m256i high = _mm256_and_si256(_mm256_srli_epi16(x, 4), low_nibble);
    return _mm256_add_epi8(_mm256_shuffle_epi8(nibble_counts, low), _mm256_shuffle_epi8(nibble_counts, high));
  }

  // 64-bit quarters (0 1 2 3) -> (0 2 1 3).
  static __m256i swap_middle_quarters(__m256i x) { return _mm256_permute4x64_epi64(x, 0xD8); }

  // Widens the 16 bytes of x to a full vector.
  template <class Lane>
  static auto widen(__m128i x) {
    static_assert(sizeof(Lane) <= 2, "widen exists for u8, u16 and s16 lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return VU16{_mm256_cvtepu8_epi16(x)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return VU32{_mm256_cvtepu16_epi32(x)};
    else return VS32{_mm256_cvtepi16_epi32(x)};
  }

  template <class Element>
  static VU32 gather(const Element* base, const VS32& offsets) {
    alignas(32) int32_t offset_lanes[kLanesU32];
    alignas(32) uint32_t values[kLanesU32];
    _mm256_store_si256(reinterpret_cast<__m256i*>(offset_lanes), offsets.v);
    for (int i = 0; i < kLanesU32; ++i) values[i] = base[offset_lanes[i]];
    return {_mm256_load_si256(reinterpret_cast<const __m256i*>(values))};
  }
};

}  // namespace lpstereo::simd
