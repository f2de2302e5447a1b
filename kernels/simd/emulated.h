// The emulated back ends of the `simd` vector layer: lane-by-lane C++ that defines what every op
// means. Two instances matter:
//   - Counting  = Emulated<kCountingVectorBytes, true>: the counting back end. Same results as every
//     native back end, and each op adds one to its class in the calling thread's tally
//     (CountingScope). The simulator's cycle figures come from these tallies.
//   - Scalar    = Emulated<16, false>: the native fallback on a CPU with no supported vector ISA.
//
// THE CONTRACT (every back end, native or emulated, must give these exact bits; tests/kernels/
// simd_ops_test.cpp checks each op on every back end against this file):
//   Vector types: VU8, VU16, VS16, VU32, VS32, VU64 hold kBytes / sizeof(lane) lanes. Lane i of a
//     vector loaded from p is p[i].
//   load / store: full vector at any alignment. load_partial(p, n) reads lanes [0, n) and sets the
//     others to 0 (never touches memory past p + n); store_partial(p, v, n) writes lanes [0, n) only.
//     0 <= n <= lanes.
//   set1_*(x): every lane = x.
//   add / sub: wrapping (modulo 2^bits).
//   adds / subs: saturating to the lane type's range (u8, u16, s16 only).
//   min / max: lane-wise; unsigned compare for U types, signed for S types.
//   absdiff (u8, u16): |a - b| exactly, no wrap.
//   avg (u8, u16): (a + b + 1) >> 1 without overflow (rounds half up).
//   bit_and / bit_or / bit_xor: bitwise; bit_andnot(a, b) = ~a & b.
//   select(mask, a, b) = (mask & a) | (~mask & b): bitwise blend; masks come from compares.
//   shl<N> / shr<N>: by an immediate 0 <= N < lane bits; shr is logical on U, arithmetic on S lanes.
//   cmpeq / cmpgt / cmplt: all-ones lane where true, zero otherwise (unsigned compare on U, signed on S).
//   mullo (u16, s16, u32, s32): low half of the full product (wrapping).
//   popcount (u8, u32, u64): number of set bits per lane, in the same lane type.
//   widen_lo / widen_hi (u8 -> u16, u16 -> u32, s16 -> s32): zero- or sign-extend lanes
//     [0, N/2) or [N/2, N) of the source, across the whole vector (not per 128-bit block).
//   zip_lo / zip_hi (u8 -> u16, u16 -> u32, u32 -> u64): lane i of the result is
//     a[j] | b[j] << bits, with j = i (lo) or i + N/2 (hi); a gives the low half of each wide lane.
//   narrow_sat(lo, hi) (u16 -> u8, s32 -> s16, s32 -> u16): saturating narrow; result lanes
//     [0, N) come from lo, [N, 2N) from hi (N = lanes of the wide type); u16 -> u8 clamps to 255;
//     s32 -> s16 clamps to [-32768, 32767]; s32 -> u16 clamps to [0, 65535].
//   gather_u8(base, offsets): u32 lane i = base[offsets[i]] (offsets are s32 byte offsets, may be
//     negative; every addressed byte must be readable). gather_u16(base, offsets): u32 lane i =
//     base[offsets[i]] with offsets in elements.
//   reinterpret as_*: the same bits as another lane type; free (counted as nothing).
//   extract(v, i): lane i as a scalar; free in the cost model, for tests and tails only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "kernels/simd/op_class.h"

namespace lpstereo::simd {

// The counting back end's vector width: 512 bits, the width of both shipped targets' vector units.
inline constexpr int kCountingVectorBytes = 64;

// The tally the counting back end adds to in this thread; null means "count nothing".
OpCounts*& current_op_counts();

// Routes the calling thread's counted ops into `counts` for the scope's lifetime.
class CountingScope {
 public:
  explicit CountingScope(OpCounts& counts) : previous_(current_op_counts()) { current_op_counts() = &counts; }
  ~CountingScope() { current_op_counts() = previous_; }
  CountingScope(const CountingScope&) = delete;
  CountingScope& operator=(const CountingScope&) = delete;

 private:
  OpCounts* previous_;
};

// The lane type twice as wide, for widen and zip.
template <class Lane> struct Wider;
template <> struct Wider<uint8_t> { using type = uint16_t; };
template <> struct Wider<uint16_t> { using type = uint32_t; };
template <> struct Wider<int16_t> { using type = int32_t; };
template <> struct Wider<uint32_t> { using type = uint64_t; };

// kIsaTag makes the type distinct for each instruction-set translation unit that instantiates it as
// a placeholder native back end, so inline functions compiled with different -m flags never merge.
template <int kVectorBytes, bool kCounting, int kIsaTag = 0>
struct Emulated {
  static constexpr int kBytes = kVectorBytes;
  static constexpr const char* kName = kCounting ? "counting" : "scalar";

  template <class Lane>
  struct Vec {
    using lane_type = Lane;
    static constexpr int kLanes = kBytes / static_cast<int>(sizeof(Lane));
    Lane lane[kLanes];
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

  static void count(OpClass op_class) {
    if constexpr (kCounting) {
      if (OpCounts* counts = current_op_counts()) ++(*counts)[op_class];
    }
  }

  // ---- memory ----
  template <class Lane>
  static Vec<Lane> load(const Lane* source) {
    count(OpClass::load);
    Vec<Lane> result;
    std::memcpy(result.lane, source, sizeof(result.lane));
    return result;
  }
  template <class Lane>
  static Vec<Lane> load_partial(const Lane* source, int lane_count) {
    count(OpClass::load);
    Vec<Lane> result{};
    std::memcpy(result.lane, source, sizeof(Lane) * static_cast<size_t>(lane_count));
    return result;
  }
  template <class Lane>
  static void store(Lane* destination, const Vec<Lane>& value) {
    count(OpClass::store);
    std::memcpy(destination, value.lane, sizeof(value.lane));
  }
  template <class Lane>
  static void store_partial(Lane* destination, const Vec<Lane>& value, int lane_count) {
    count(OpClass::store);
    std::memcpy(destination, value.lane, sizeof(Lane) * static_cast<size_t>(lane_count));
  }  // A full-vector store of a result that is written once and read much later (by another node):
  // it need not stay in the cache. destination must be aligned to the vector width. x86 back ends
  // issue non-temporal streaming stores (no read-for-ownership, no eviction of the working set);
  // stream_fence() orders them before anything a later node reads. Counted as one store.
  template <class Lane>
  static void store_stream(Lane* destination, const Vec<Lane>& value) {
    count(OpClass::store);
    std::memcpy(destination, value.lane, sizeof(value.lane));
  }
  static void stream_fence() {}


  static VU8 set1_u8(uint8_t x) { return broadcast<uint8_t>(x); }
  static VU16 set1_u16(uint16_t x) { return broadcast<uint16_t>(x); }
  static VS16 set1_s16(int16_t x) { return broadcast<int16_t>(x); }
  static VU32 set1_u32(uint32_t x) { return broadcast<uint32_t>(x); }
  static VS32 set1_s32(int32_t x) { return broadcast<int32_t>(x); }
  static VU64 set1_u64(uint64_t x) { return broadcast<uint64_t>(x); }

  template <class Lane>
  static Lane extract(const Vec<Lane>& v, int index) { return v.lane[index]; }

  // ---- arithmetic ----
  // Computed modulo 2^64 (unsigned, so no overflow even for u64 lanes), then truncated to the lane.
  template <class Lane>
  static Vec<Lane> add(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::arith, a, b, [](Lane x, Lane y) { return static_cast<Lane>(modular(x) + modular(y)); });
  }  // Lane 0 as a scalar, for an address computed in the vector unit (a kernel reads one element
  // there instead of gathering the same address in every lane). Counted as one permute: the lane
  // move into a scalar register. extract() above is for tests and is not counted.
  template <class Lane>
  static Lane first_lane(const Vec<Lane>& v) {
    count(OpClass::permute);
    return v.lane[0];
  }

  template <class Lane>
  static Vec<Lane> sub(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::arith, a, b, [](Lane x, Lane y) { return static_cast<Lane>(modular(x) - modular(y)); });
  }
  template <class Lane>
  static Vec<Lane> adds(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating add exists for 8- and 16-bit lanes");
    return lanewise<Lane>(OpClass::arith, a, b, [](Lane x, Lane y) { return saturate<Lane>(int64_t{x} + int64_t{y}); });
  }
  template <class Lane>
  static Vec<Lane> subs(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) <= 2, "saturating sub exists for 8- and 16-bit lanes");
    return lanewise<Lane>(OpClass::arith, a, b, [](Lane x, Lane y) { return saturate<Lane>(int64_t{x} - int64_t{y}); });
  }
  template <class Lane>
  static Vec<Lane> min(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::arith, a, b, [](Lane x, Lane y) { return y < x ? y : x; });
  }
  template <class Lane>
  static Vec<Lane> max(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::arith, a, b, [](Lane x, Lane y) { return x < y ? y : x; });
  }  // Every lane = the minimum of a's lanes (u16 and u32 lanes): the per-pixel minimum over a vector
  // of disparity costs, without leaving the vector unit. Counted as the reduction a vector engine
  // runs: log2(lanes) stages of one permute (swap halves, lanes duplicated) and one min, which
  // leaves the minimum in every lane.
  template <class Lane>
  static Vec<Lane> min_across(const Vec<Lane>& a) {
    static_assert(std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>, "min_across exists for u16 and u32 lanes");
    for (int lanes = Vec<Lane>::kLanes; lanes > 1; lanes /= 2) {
      count(OpClass::permute);
      count(OpClass::arith);
    }
    Lane minimum = a.lane[0];
    for (int i = 1; i < Vec<Lane>::kLanes; ++i) minimum = a.lane[i] < minimum ? a.lane[i] : minimum;
    Vec<Lane> result;
    for (int i = 0; i < Vec<Lane>::kLanes; ++i) result.lane[i] = minimum;
    return result;
  }  // Lane shifts across a pair of vectors (u16 and u32 lanes), for per-lane neighbours of a value
  // kept in registers (u16: the row path's d +- 1) and for a window that slides along the row one
  // lane per pixel (u32: the right view's running minimum of the SGM keys):
  // previous_lanes(before, v) lane i = v lane i - 1, lane 0 = before's last lane;
  // next_lanes(v, after) lane i = v lane i + 1, the last lane = after's lane 0. Counted as one permute.
  template <class Lane>
  static Vec<Lane> previous_lanes(const Vec<Lane>& before, const Vec<Lane>& v) {
    static_assert(std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>, "lane shifts exist for u16 and u32 lanes");
    count(OpClass::permute);
    Vec<Lane> result;
    result.lane[0] = before.lane[Vec<Lane>::kLanes - 1];
    for (int i = 1; i < Vec<Lane>::kLanes; ++i) result.lane[i] = v.lane[i - 1];
    return result;
  }
  template <class Lane>
  static Vec<Lane> next_lanes(const Vec<Lane>& v, const Vec<Lane>& after) {
    static_assert(std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>, "lane shifts exist for u16 and u32 lanes");
    count(OpClass::permute);
    Vec<Lane> result;
    for (int i = 0; i + 1 < Vec<Lane>::kLanes; ++i) result.lane[i] = v.lane[i + 1];
    result.lane[Vec<Lane>::kLanes - 1] = after.lane[0];
    return result;
  }


  template <class Lane>
  static Vec<Lane> absdiff(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "absdiff exists for u8 and u16 lanes");
    return lanewise<Lane>(OpClass::arith, a, b, [](Lane x, Lane y) { return static_cast<Lane>(x > y ? x - y : y - x); });
  }
  template <class Lane>
  static Vec<Lane> avg(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) <= 2, "avg exists for u8 and u16 lanes");
    return lanewise<Lane>(OpClass::arith, a, b,
                          [](Lane x, Lane y) { return static_cast<Lane>((uint32_t{x} + uint32_t{y} + 1) >> 1); });
  }
  template <class Lane>
  static Vec<Lane> mullo(const Vec<Lane>& a, const Vec<Lane>& b) {
    static_assert(sizeof(Lane) == 2 || sizeof(Lane) == 4, "mullo exists for 16- and 32-bit lanes");
    return lanewise<Lane>(OpClass::multiply, a, b, [](Lane x, Lane y) {
      using Unsigned = std::make_unsigned_t<Lane>;
      return static_cast<Lane>(static_cast<Unsigned>(static_cast<uint64_t>(static_cast<Unsigned>(x)) *
                                                     static_cast<uint64_t>(static_cast<Unsigned>(y))));
    });
  }

  // ---- bitwise ----
  template <class Lane>
  static Vec<Lane> bit_and(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::logic, a, b, [](Lane x, Lane y) { return static_cast<Lane>(x & y); });
  }
  template <class Lane>
  static Vec<Lane> bit_or(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::logic, a, b, [](Lane x, Lane y) { return static_cast<Lane>(x | y); });
  }
  template <class Lane>
  static Vec<Lane> bit_xor(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::logic, a, b, [](Lane x, Lane y) { return static_cast<Lane>(x ^ y); });
  }
  template <class Lane>
  static Vec<Lane> bit_andnot(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::logic, a, b, [](Lane x, Lane y) { return static_cast<Lane>(~x & y); });
  }
  template <class Lane>
  static Vec<Lane> select(const Vec<Lane>& mask, const Vec<Lane>& a, const Vec<Lane>& b) {
    count(OpClass::logic);
    Vec<Lane> result;
    for (int i = 0; i < Vec<Lane>::kLanes; ++i) {
      result.lane[i] = static_cast<Lane>((mask.lane[i] & a.lane[i]) | (~mask.lane[i] & b.lane[i]));
    }
    return result;
  }

  template <int kShift, class Lane>
  static Vec<Lane> shl(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    return unary<Lane>(OpClass::shift, a, [](Lane x) {
      using Unsigned = std::make_unsigned_t<Lane>;
      return static_cast<Lane>(static_cast<Unsigned>(static_cast<Unsigned>(x) << kShift));
    });
  }
  template <int kShift, class Lane>
  static Vec<Lane> shr(const Vec<Lane>& a) {
    static_assert(kShift >= 0 && kShift < 8 * static_cast<int>(sizeof(Lane)), "shift out of range");
    // >> on a negative signed value is arithmetic in C++20.
    return unary<Lane>(OpClass::shift, a, [](Lane x) { return static_cast<Lane>(x >> kShift); });
  }

  // ---- compare ----
  template <class Lane>
  static Vec<Lane> cmpeq(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::compare, a, b, [](Lane x, Lane y) { return mask_of<Lane>(x == y); });
  }
  template <class Lane>
  static Vec<Lane> cmpgt(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::compare, a, b, [](Lane x, Lane y) { return mask_of<Lane>(x > y); });
  }
  template <class Lane>
  static Vec<Lane> cmplt(const Vec<Lane>& a, const Vec<Lane>& b) {
    return lanewise<Lane>(OpClass::compare, a, b, [](Lane x, Lane y) { return mask_of<Lane>(x < y); });
  }

  template <class Lane>
  static Vec<Lane> popcount(const Vec<Lane>& a) {
    static_assert(std::is_unsigned_v<Lane> && sizeof(Lane) != 2, "popcount exists for u8, u32 and u64 lanes");
    return unary<Lane>(OpClass::popcount, a, [](Lane x) { return static_cast<Lane>(__builtin_popcountll(x)); });
  }

  // ---- lane movement ----
  template <class Lane>
  static auto widen_lo(const Vec<Lane>& a) { return widen_half(a, 0); }
  template <class Lane>
  static auto widen_hi(const Vec<Lane>& a) { return widen_half(a, Vec<Lane>::kLanes / 2); }

  template <class Lane>
  static auto zip_lo(const Vec<Lane>& a, const Vec<Lane>& b) { return zip_half(a, b, 0); }
  template <class Lane>
  static auto zip_hi(const Vec<Lane>& a, const Vec<Lane>& b) { return zip_half(a, b, Vec<Lane>::kLanes / 2); }

  static VU8 narrow_sat_u8(const VU16& lo, const VU16& hi) { return narrow<uint8_t>(lo, hi); }
  static VS16 narrow_sat_s16(const VS32& lo, const VS32& hi) { return narrow<int16_t>(lo, hi); }
  static VU16 narrow_sat_u16(const VS32& lo, const VS32& hi) { return narrow<uint16_t>(lo, hi); }

  static VU32 gather_u8(const uint8_t* base, const VS32& offsets) { return gather<uint8_t>(base, offsets); }
  static VU32 gather_u16(const uint16_t* base, const VS32& offsets) { return gather<uint16_t>(base, offsets); }

  // ---- reinterpretation (free) ----
  template <class To, class From>
  static Vec<To> bitcast(const Vec<From>& a) {
    static_assert(sizeof(Vec<To>) == sizeof(Vec<From>));
    Vec<To> result;
    std::memcpy(result.lane, a.lane, sizeof(result.lane));
    return result;
  }
  template <class From> static VU8 as_u8(const Vec<From>& a) { return bitcast<uint8_t>(a); }
  template <class From> static VU16 as_u16(const Vec<From>& a) { return bitcast<uint16_t>(a); }
  template <class From> static VS16 as_s16(const Vec<From>& a) { return bitcast<int16_t>(a); }
  template <class From> static VU32 as_u32(const Vec<From>& a) { return bitcast<uint32_t>(a); }
  template <class From> static VS32 as_s32(const Vec<From>& a) { return bitcast<int32_t>(a); }
  template <class From> static VU64 as_u64(const Vec<From>& a) { return bitcast<uint64_t>(a); }

 private:
  template <class Lane>
  static uint64_t modular(Lane x) { return static_cast<uint64_t>(x); }

  template <class Lane>
  static Lane saturate(int64_t x) {
    constexpr int64_t low = std::numeric_limits<Lane>::min();
    constexpr int64_t high = std::numeric_limits<Lane>::max();
    return static_cast<Lane>(x < low ? low : (x > high ? high : x));
  }
  template <class Lane>
  static Lane mask_of(bool condition) { return condition ? static_cast<Lane>(~Lane{0}) : Lane{0}; }

  template <class Lane>
  static Vec<Lane> broadcast(Lane x) {
    count(OpClass::permute);
    Vec<Lane> result;
    for (int i = 0; i < Vec<Lane>::kLanes; ++i) result.lane[i] = x;
    return result;
  }
  template <class Lane, class Function>
  static Vec<Lane> lanewise(OpClass op_class, const Vec<Lane>& a, const Vec<Lane>& b, Function function) {
    count(op_class);
    Vec<Lane> result;
    for (int i = 0; i < Vec<Lane>::kLanes; ++i) result.lane[i] = function(a.lane[i], b.lane[i]);
    return result;
  }
  template <class Lane, class Function>
  static Vec<Lane> unary(OpClass op_class, const Vec<Lane>& a, Function function) {
    count(op_class);
    Vec<Lane> result;
    for (int i = 0; i < Vec<Lane>::kLanes; ++i) result.lane[i] = function(a.lane[i]);
    return result;
  }

  template <class Lane>
  static Vec<typename Wider<Lane>::type> widen_half(const Vec<Lane>& a, int first) {
    static_assert(!std::is_same_v<Lane, uint32_t>, "widen exists for u8, u16 and s16 lanes");
    count(OpClass::permute);
    using Wide = typename Wider<Lane>::type;
    Vec<Wide> result;
    for (int i = 0; i < Vec<Wide>::kLanes; ++i) result.lane[i] = static_cast<Wide>(a.lane[first + i]);
    return result;
  }
  template <class Lane>
  static Vec<typename Wider<Lane>::type> zip_half(const Vec<Lane>& a, const Vec<Lane>& b, int first) {
    static_assert(std::is_unsigned_v<Lane>, "zip exists for u8, u16 and u32 lanes");
    count(OpClass::permute);
    using Wide = typename Wider<Lane>::type;
    Vec<Wide> result;
    for (int i = 0; i < Vec<Wide>::kLanes; ++i) {
      result.lane[i] = static_cast<Wide>(Wide{a.lane[first + i]} | (Wide{b.lane[first + i]} << (8 * sizeof(Lane))));
    }
    return result;
  }
  template <class Narrow, class Wide>
  static Vec<Narrow> narrow(const Vec<Wide>& lo, const Vec<Wide>& hi) {
    count(OpClass::permute);
    Vec<Narrow> result;
    constexpr int half = Vec<Wide>::kLanes;
    for (int i = 0; i < half; ++i) {
      result.lane[i] = saturate<Narrow>(static_cast<int64_t>(lo.lane[i]));
      result.lane[half + i] = saturate<Narrow>(static_cast<int64_t>(hi.lane[i]));
    }
    return result;
  }
  template <class Element>
  static VU32 gather(const Element* base, const VS32& offsets) {
    count(OpClass::gather);
    VU32 result;
    for (int i = 0; i < VU32::kLanes; ++i) result.lane[i] = base[offsets.lane[i]];
    return result;
  }
};

using Counting = Emulated<kCountingVectorBytes, true>;
using Scalar = Emulated<16, false>;

}  // namespace lpstereo::simd
