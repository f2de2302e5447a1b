// The Neon native back end of the simd layer: 128-bit Advanced SIMD vectors on AArch64 (arm_neon.h).
// Included only by the neon translation units (LPSTEREO_ISA_TU == 4; see kernels/simd/native.h).
//
// The contract for every op is kernels/simd/emulated.h; tests/kernels/simd_ops_test.cpp compares each
// op and lane type of this file with it lane by lane (run through qemu-aarch64 in the aarch64 preset).
// Vector types are thin structs around the NEON register type of their lanes (uint8x16_t,
// int16x8_t, ...). Everything is in-class (implicitly inline) and uses no standard library templates
// with code.
//
// NEON has an instruction for nearly every op: unsigned and signed compares, saturating add/sub,
// absdiff (vabd), rounding average (vrhadd), per-byte popcount (vcnt), saturating narrows (vqmovn,
// vqmovun), zip (vzip1/vzip2), widen (vmovl). Ops built from several instructions (marked
// "emulated"): min/max on u64 (compare + bit select), popcount on u32/u64 (vcnt then pairwise
// widening adds). Scalar loops: gather_u8 / gather_u16, and load_partial / store_partial through a
// zeroed stack buffer (so no byte past p + n is read or written).
#pragma once

#if !defined(__aarch64__) || !defined(__ARM_NEON)
#error "arm_neon.h (lpstereo) is the AArch64 NEON back end; it is compiled only for aarch64 targets"
#endif

#include <arm_neon.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace lpstereo::simd {

namespace neon_detail {
// The NEON register type holding 128 bits of Lane.
template <class Lane> struct Register;
template <> struct Register<uint8_t> { using type = uint8x16_t; };
template <> struct Register<uint16_t> { using type = uint16x8_t; };
template <> struct Register<int16_t> { using type = int16x8_t; };
template <> struct Register<uint32_t> { using type = uint32x4_t; };
template <> struct Register<int32_t> { using type = int32x4_t; };
template <> struct Register<uint64_t> { using type = uint64x2_t; };
}  // namespace neon_detail

// Expands to one intrinsic per lane type: name##_u8, name##_u16, name##_s16, name##_u32, name##_s32,
// name##_u64, applied to (a.v, b.v). Undefined at the end of this file.
#define LPSTEREO_NEON_BINARY_ALL_LANES(name)                                  \
  if constexpr (std::is_same_v<Lane, uint8_t>) return {name##_u8(a.v, b.v)};   \
  else if constexpr (std::is_same_v<Lane, uint16_t>) return {name##_u16(a.v, b.v)}; \
  else if constexpr (std::is_same_v<Lane, int16_t>) return {name##_s16(a.v, b.v)};  \
  else if constexpr (std::is_same_v<Lane, uint32_t>) return {name##_u32(a.v, b.v)}; \
  else if constexpr (std::is_same_v<Lane, int32_t>) return {name##_s32(a.v, b.v)};  \
  else return {name##_u64(a.v, b.v)}

// The same for compares: the result register is unsigned, reinterpreted for signed lanes.
#define LPSTEREO_NEON_COMPARE_ALL_LANES(name, x, y)                                             \
  if constexpr (std::is_same_v<Lane, uint8_t>) return {name##_u8(x.v, y.v)};                     \
  else if constexpr (std::is_same_v<Lane, uint16_t>) return {name##_u16(x.v, y.v)};              \
  else if constexpr (std::is_same_v<Lane, int16_t>) return {vreinterpretq_s16_u16(name##_s16(x.v, y.v))}; \
  else if constexpr (std::is_same_v<Lane, uint32_t>) return {name##_u32(x.v, y.v)};              \
  else if constexpr (std::is_same_v<Lane, int32_t>) return {vreinterpretq_s32_u32(name##_s32(x.v, y.v))}; \
  else return {name##_u64(x.v, y.v)}

struct Neon {
  static constexpr int kBytes = 16;
  static constexpr const char* kName = "neon";

  template <class Lane>
  struct Vec {
    using lane_type = Lane;
    static constexpr int kLanes = kBytes / static_cast<int>(sizeof(Lane));
    typename neon_detail::Register<Lane>::type v;  // only the six contract lane types have a register
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
    if constexpr (std::is_same_v<Lane, uint8_t>) return {vld1q_u8(source)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {vld1q_u16(source)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {vld1q_s16(source)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {vld1q_u32(source)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {vld1q_s32(source)};
    else return {vld1q_u64(source)};
  }
  // Emulated: copies exactly lane_count lanes into a zeroed buffer, then loads it.
  template <class Lane>
  static Vec<Lane> load_partial(const Lane* source, int lane_count) {
    alignas(16) uint8_t buffer[kBytes] = {};
    if (lane_count > 0) std::memcpy(buffer, source, sizeof(Lane) * static_cast<size_t>(lane_count));
    return {from_bytes<Lane>(vld1q_u8(buffer))};
  }
  template <class Lane>
  static void store(Lane* destination, const Vec<Lane>& value) {
    if constexpr (std::is_same_v<Lane, uint8_t>) vst1q_u8(destination, value.v);
    else if constexpr (std::is_same_v<Lane, uint16_t>) vst1q_u16(destination, value.v);
    else if constexpr (std::is_same_v<Lane, int16_t>) vst1q_s16(destination, value.v);
    else if constexpr (std::is_same_v<Lane, uint32_t>) vst1q_u32(destination, value.v);
    else if constexpr (std::is_same_v<Lane, int32_t>) vst1q_s32(destination, value.v);
    else vst1q_u64(destination, value.v);
  }
  // Emulated: stores to a buffer, then copies exactly lane_count lanes out.
  template <class Lane>
  static void store_partial(Lane* destination, const Vec<Lane>& value, int lane_count) {
    alignas(16) uint8_t buffer[kBytes];
    vst1q_u8(buffer, bytes_of(value.v));
    if (lane_count > 0) std::memcpy(destination, buffer, sizeof(Lane) * static_cast<size_t>(lane_count));
  }  // A plain store: NEON's streaming hint (STNP) is a pair store of scalar/64-bit registers with no
  // intrinsic for q registers in GCC; ordinary stores are already ordered for the next node.
  template <class Lane>
  static void store_stream(Lane* destination, const Vec<Lane>& value) {
    store(destination, value);
  }
  static void stream_fence() {}


  static VU8 set1_u8(uint8_t x) { return {vdupq_n_u8(x)}; }
  static VU16 set1_u16(uint16_t x) { return {vdupq_n_u16(x)}; }
  static VS16 set1_s16(int16_t x) { return {vdupq_n_s16(x)}; }
  static VU32 set1_u32(uint32_t x) { return {vdupq_n_u32(x)}; }
  static VS32 set1_s32(int32_t x) { return {vdupq_n_s32(x)}; }
  static VU64 set1_u64(uint64_t x) { return {vdupq_n_u64(x)}; }

  template <class Lane>
  static Lane extract(const Vec<Lane>& v, int index) {
    Lane lanes[Vec<Lane>::kLanes];
    store(lanes, v);
    return lanes[index];
  }  template <class Lane>
  static Lane first_lane(const Vec<Lane>& v) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return vgetq_lane_u8(v.v, 0);
    else if constexpr (std::is_same_v<Lane, uint16_t>) return vgetq_lane_u16(v.v, 0);
    else if constexpr (std::is_same_v<Lane, int16_t>) return vgetq_lane_s16(v.v, 0);
    else if constexpr (std::is_same_v<Lane, uint32_t>) return vgetq_lane_u32(v.v, 0);
    else if constexpr (std::is_same_v<Lane, int32_t>) return vgetq_lane_s32(v.v, 0);
    else return vgetq_lane_u64(v.v, 0);
  }


  // ---- arithmetic ----
  template <class Lane>
  static Vec<Lane> add(const Vec<Lane>& a, const Vec<Lane>& b) {
    LPSTEREO_NEON_BINARY_ALL_LANES(vaddq);
  }
  template <class Lane>
  static Vec<Lane> sub(const Vec<Lane>& a, const Vec<Lane>& b) {
    LPSTEREO_NEON_BINARY_ALL_LANES(vsubq);
  }
  template <class Lane>
  static Vec<Lane> adds(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating add exists for 8- and 16-bit lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return {vqaddq_u8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {vqaddq_u16(a.v, b.v)};
    else return {vqaddq_s16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> subs(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating sub exists for 8- and 16-bit lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return {vqsubq_u8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {vqsubq_u16(a.v, b.v)};
    else return {vqsubq_s16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> min(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return {vminq_u8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {vminq_u16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {vminq_s16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {vminq_u32(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {vminq_s32(a.v, b.v)};
    else return {vbslq_u64(vcgtq_u64(a.v, b.v), b.v, a.v)};  // emulated: compare + bit select
  }
  template <class Lane>
  static Vec<Lane> max(const Vec<Lane>& a, const Vec<Lane>& b) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return {vmaxq_u8(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {vmaxq_u16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {vmaxq_s16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {vmaxq_u32(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {vmaxq_s32(a.v, b.v)};
    else return {vbslq_u64(vcgtq_u64(a.v, b.v), a.v, b.v)};  // emulated: compare + bit select
  }  // Across-vector minimum (vminvq), broadcast back to every lane.
  template <class Lane>
  static Vec<Lane> min_across(const Vec<Lane>& a) {
    static_assert(std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>, "min_across exists for u16 and u32 lanes");
    if constexpr (std::is_same_v<Lane, uint16_t>) return {vdupq_n_u16(vminvq_u16(a.v))};
    else return {vdupq_n_u32(vminvq_u32(a.v))};
  }  // vext on the concatenation.
  static VU16 previous_lanes(const VU16& before, const VU16& v) { return {vextq_u16(before.v, v.v, 7)}; }
  static VU16 next_lanes(const VU16& v, const VU16& after) { return {vextq_u16(v.v, after.v, 1)}; }
  static VU32 previous_lanes(const VU32& before, const VU32& v) { return {vextq_u32(before.v, v.v, 3)}; }
  static VU32 next_lanes(const VU32& v, const VU32& after) { return {vextq_u32(v.v, after.v, 1)}; }


  template <class Lane>
  static Vec<Lane> absdiff(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "absdiff exists for u8 and u16 lanes");
    if constexpr (sizeof(Lane) == 1) return {vabdq_u8(a.v, b.v)};
    else return {vabdq_u16(a.v, b.v)};
  }
  // Rounding halving add: (a + b + 1) >> 1 computed without overflow.
  template <class Lane>
  static Vec<Lane> avg(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "avg exists for u8 and u16 lanes");
    if constexpr (sizeof(Lane) == 1) return {vrhaddq_u8(a.v, b.v)};
    else return {vrhaddq_u16(a.v, b.v)};
  }
  template <class Lane>
  static Vec<Lane> mullo(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) == 2 || sizeof(Lane) == 4, "mullo exists for 16- and 32-bit lanes");
    if constexpr (std::is_same_v<Lane, uint16_t>) return {vmulq_u16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {vmulq_s16(a.v, b.v)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {vmulq_u32(a.v, b.v)};
    else return {vmulq_s32(a.v, b.v)};
  }

  // ---- bitwise (on the bytes; the lane type does not matter) ----
  template <class Lane>
  static Vec<Lane> bit_and(const Vec<Lane>& a, const Vec<Lane>& b) {
    return {from_bytes<Lane>(vandq_u8(bytes_of(a.v), bytes_of(b.v)))};
  }
  template <class Lane>
  static Vec<Lane> bit_or(const Vec<Lane>& a, const Vec<Lane>& b) {
    return {from_bytes<Lane>(vorrq_u8(bytes_of(a.v), bytes_of(b.v)))};
  }
  template <class Lane>
  static Vec<Lane> bit_xor(const Vec<Lane>& a, const Vec<Lane>& b) {
    return {from_bytes<Lane>(veorq_u8(bytes_of(a.v), bytes_of(b.v)))};
  }
  // ~a & b: vbic(x, y) is x & ~y.
  template <class Lane>
  static Vec<Lane> bit_andnot(const Vec<Lane>& a, const Vec<Lane>& b) {
    return {from_bytes<Lane>(vbicq_u8(bytes_of(b.v), bytes_of(a.v)))};
  }
  template <class Lane>
  static Vec<Lane> select(const Vec<Lane>& mask, const Vec<Lane>& a, const Vec<Lane>& b) {
    return {from_bytes<Lane>(vbslq_u8(bytes_of(mask.v), bytes_of(a.v), bytes_of(b.v)))};
  }

  template <int kShift, class Lane>
  static Vec<Lane> shl(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    if constexpr (std::is_same_v<Lane, uint8_t>) return {vshlq_n_u8(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {vshlq_n_u16(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {vshlq_n_s16(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {vshlq_n_u32(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {vshlq_n_s32(a.v, kShift)};
    else return {vshlq_n_u64(a.v, kShift)};
  }
  // vshrq_n takes shifts 1 .. lane bits, so a shift by 0 returns the input.
  template <int kShift, class Lane>
  static Vec<Lane> shr(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    if constexpr (kShift == 0) return a;
    else if constexpr (std::is_same_v<Lane, uint8_t>) return {vshrq_n_u8(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return {vshrq_n_u16(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, int16_t>) return {vshrq_n_s16(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, uint32_t>) return {vshrq_n_u32(a.v, kShift)};
    else if constexpr (std::is_same_v<Lane, int32_t>) return {vshrq_n_s32(a.v, kShift)};
    else return {vshrq_n_u64(a.v, kShift)};
  }

  // ---- compare ----
  template <class Lane>
  static Vec<Lane> cmpeq(const Vec<Lane>& a, const Vec<Lane>& b) {
    LPSTEREO_NEON_COMPARE_ALL_LANES(vceqq, a, b);
  }
  template <class Lane>
  static Vec<Lane> cmpgt(const Vec<Lane>& a, const Vec<Lane>& b) {
    LPSTEREO_NEON_COMPARE_ALL_LANES(vcgtq, a, b);
  }
  template <class Lane>
  static Vec<Lane> cmplt(const Vec<Lane>& a, const Vec<Lane>& b) {
    LPSTEREO_NEON_COMPARE_ALL_LANES(vcltq, a, b);
  }

  // vcnt counts per byte; u32 and u64 (emulated) sum the bytes with pairwise widening adds.
  template <class Lane>
  static Vec<Lane> popcount(const Vec<Lane>& a) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) != 2, "popcount exists for u8, u32 and u64 lanes");
    const uint8x16_t byte_counts = vcntq_u8(bytes_of(a.v));
    if constexpr (sizeof(Lane) == 1) return {byte_counts};
    else if constexpr (sizeof(Lane) == 4) return {vpaddlq_u16(vpaddlq_u8(byte_counts))};
    else return {vpaddlq_u32(vpaddlq_u16(vpaddlq_u8(byte_counts)))};
  }

  // ---- lane movement ----
  template <class Lane>
  static auto widen_lo(const Vec<Lane>& a) {
    static_assert(sizeof(Lane) <= 2, "widen exists for u8, u16 and s16 lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return VU16{vmovl_u8(vget_low_u8(a.v))};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return VU32{vmovl_u16(vget_low_u16(a.v))};
    else return VS32{vmovl_s16(vget_low_s16(a.v))};
  }
  template <class Lane>
  static auto widen_hi(const Vec<Lane>& a) {
    static_assert(sizeof(Lane) <= 2, "widen exists for u8, u16 and s16 lanes");
    if constexpr (std::is_same_v<Lane, uint8_t>) return VU16{vmovl_high_u8(a.v)};
    else if constexpr (std::is_same_v<Lane, uint16_t>) return VU32{vmovl_high_u16(a.v)};
    else return VS32{vmovl_high_s16(a.v)};
  }

  // vzip1 / vzip2 interleave a (low half of each wide lane) with b (high half), little-endian.
  template <class Lane>
  static auto zip_lo(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 4, "zip exists for u8, u16 and u32 lanes");
    if constexpr (sizeof(Lane) == 1) return VU16{vreinterpretq_u16_u8(vzip1q_u8(a.v, b.v))};
    else if constexpr (sizeof(Lane) == 2) return VU32{vreinterpretq_u32_u16(vzip1q_u16(a.v, b.v))};
    else return VU64{vreinterpretq_u64_u32(vzip1q_u32(a.v, b.v))};
  }
  template <class Lane>
  static auto zip_hi(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 4, "zip exists for u8, u16 and u32 lanes");
    if constexpr (sizeof(Lane) == 1) return VU16{vreinterpretq_u16_u8(vzip2q_u8(a.v, b.v))};
    else if constexpr (sizeof(Lane) == 2) return VU32{vreinterpretq_u32_u16(vzip2q_u16(a.v, b.v))};
    else return VU64{vreinterpretq_u64_u32(vzip2q_u32(a.v, b.v))};
  }

  static VU8 narrow_sat_u8(const VU16& lo, const VU16& hi) { return {vqmovn_high_u16(vqmovn_u16(lo.v), hi.v)}; }
  static VS16 narrow_sat_s16(const VS32& lo, const VS32& hi) { return {vqmovn_high_s32(vqmovn_s32(lo.v), hi.v)}; }
  // vqmovun: signed in, unsigned saturated out (negative -> 0).
  static VU16 narrow_sat_u16(const VS32& lo, const VS32& hi) { return {vqmovun_high_s32(vqmovun_s32(lo.v), hi.v)}; }

  // Emulated: scalar loop.
  static VU32 gather_u8(const uint8_t* base, const VS32& offsets) { return gather(base, offsets); }
  static VU32 gather_u16(const uint16_t* base, const VS32& offsets) { return gather(base, offsets); }

  // ---- reinterpretation (free) ----
  template <class To, class From>
  static Vec<To> bitcast(const Vec<From>& a) { return {from_bytes<To>(bytes_of(a.v))}; }
  template <class From> static VU8 as_u8(const Vec<From>& a) { return bitcast<uint8_t>(a); }
  template <class From> static VU16 as_u16(const Vec<From>& a) { return bitcast<uint16_t>(a); }
  template <class From> static VS16 as_s16(const Vec<From>& a) { return bitcast<int16_t>(a); }
  template <class From> static VU32 as_u32(const Vec<From>& a) { return bitcast<uint32_t>(a); }
  template <class From> static VS32 as_s32(const Vec<From>& a) { return bitcast<int32_t>(a); }
  template <class From> static VU64 as_u64(const Vec<From>& a) { return bitcast<uint64_t>(a); }

 private:
  static uint8x16_t bytes_of(uint8x16_t x) { return x; }
  static uint8x16_t bytes_of(uint16x8_t x) { return vreinterpretq_u8_u16(x); }
  static uint8x16_t bytes_of(int16x8_t x) { return vreinterpretq_u8_s16(x); }
  static uint8x16_t bytes_of(uint32x4_t x) { return vreinterpretq_u8_u32(x); }
  static uint8x16_t bytes_of(int32x4_t x) { return vreinterpretq_u8_s32(x); }
  static uint8x16_t bytes_of(uint64x2_t x) { return vreinterpretq_u8_u64(x); }

  template <class Lane>
  static typename neon_detail::Register<Lane>::type from_bytes(uint8x16_t x) {
    if constexpr (std::is_same_v<Lane, uint8_t>) return x;
    else if constexpr (std::is_same_v<Lane, uint16_t>) return vreinterpretq_u16_u8(x);
    else if constexpr (std::is_same_v<Lane, int16_t>) return vreinterpretq_s16_u8(x);
    else if constexpr (std::is_same_v<Lane, uint32_t>) return vreinterpretq_u32_u8(x);
    else if constexpr (std::is_same_v<Lane, int32_t>) return vreinterpretq_s32_u8(x);
    else return vreinterpretq_u64_u8(x);
  }

  template <class Element>
  static VU32 gather(const Element* base, const VS32& offsets) {
    int32_t offset_lanes[kLanesU32];
    uint32_t values[kLanesU32];
    vst1q_s32(offset_lanes, offsets.v);
    for (int i = 0; i < kLanesU32; ++i) values[i] = base[offset_lanes[i]];
    return {vld1q_u32(values)};
  }
};

#undef LPSTEREO_NEON_BINARY_ALL_LANES
#undef LPSTEREO_NEON_COMPARE_ALL_LANES

}  // namespace lpstereo::simd
