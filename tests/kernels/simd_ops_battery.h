// The op battery of tests/kernels/simd_ops_test.cpp: one function template that runs a single op of
// the simd contract (kernels/simd/emulated.h) for one lane type on back end B, reading its operands
// from byte arrays and writing its result vector to a byte array.
//
// It is instantiated twice over: with each native back end inside a per-ISA probe unit
// (simd_ops_probe.cpp, compiled with that level's -m flags) and with Emulated<kBytes> in the test
// itself, which then compares the bytes. Like a kernel body, it lives in an anonymous namespace and
// uses no standard library code, so nothing compiled with -mavx512bw can leak into other levels.
#pragma once

#include <cstdint>
#include <cstring>

namespace lpstereo::simd_probe {

// Lane types of the contract, in a fixed order.
enum class LaneKind : int { u8 = 0, u16, s16, u32, s32, u64, count_ };
inline constexpr int kLaneKindCount = static_cast<int>(LaneKind::count_);
inline constexpr const char* kLaneKindNames[kLaneKindCount] = {"u8", "u16", "s16", "u32", "s32", "u64"};
inline constexpr int kLaneKindBytes[kLaneKindCount] = {1, 2, 2, 4, 4, 8};
inline constexpr bool kLaneKindSigned[kLaneKindCount] = {false, false, true, false, true, false};

// Every op of the contract. `param` of a ProbeOp is the shift count (shl, shr), the target lane type
// (bitcast, as_type) or the lane count (load_partial, store_partial).
enum class OpKind : int {
  load_store = 0,  // load from a, store to out
  load_partial,    // load_partial(partial_source, param), store to out
  store_partial,   // load a, store_partial(partial_destination, param)
  set1,            // set1 of lane 0 of a
  extract,         // out lane i = extract(a, i)
  add, sub, adds, subs, min, max, absdiff, avg, mullo,
  bit_and, bit_or, bit_xor, bit_andnot,
  select,          // select(c, a, b)
  shl, shr,
  cmpeq, cmpgt, cmplt,
  popcount,
  widen_lo, widen_hi,
  zip_lo, zip_hi,
  narrow_sat_u8,   // (a, b) as u16
  narrow_sat_s16,  // (a, b) as s32
  narrow_sat_u16,  // (a, b) as s32
  gather_u8,       // offsets = a as s32, base = gather_base_u8
  gather_u16,      // offsets = a as s32, base = gather_base_u16
  bitcast,         // bitcast<param lane>(a)
  as_type,         // as_<param lane>(a)
  min_across,      // every lane = the minimum of a's lanes
  first_lane,      // out lane 0 = first_lane(a), the other lanes 0
  store_stream,    // store_stream(aligned buffer, a), stream_fence(), copied to out
  previous_lanes,  // previous_lanes(a, b)
  next_lanes,      // next_lanes(a, b)
  count_
};
inline constexpr int kOpKindCount = static_cast<int>(OpKind::count_);
inline constexpr const char* kOpKindNames[kOpKindCount] = {
    "load/store", "load_partial", "store_partial", "set1", "extract", "add", "sub", "adds", "subs", "min", "max",
    "absdiff", "avg", "mullo", "bit_and", "bit_or", "bit_xor", "bit_andnot", "select", "shl", "shr", "cmpeq",
    "cmpgt", "cmplt", "popcount", "widen_lo", "widen_hi", "zip_lo", "zip_hi", "narrow_sat_u8", "narrow_sat_s16",
    "narrow_sat_u16", "gather_u8", "gather_u16", "bitcast", "as_*", "min_across", "first_lane", "store_stream", "previous_lanes", "next_lanes"};

// Shift counts the battery can run (each op uses those below its lane bits).
inline constexpr int kShiftCounts[] = {0, 1, 3, 7, 8, 15, 16, 31, 32, 63};

struct ProbeOp {
  OpKind kind = OpKind::load_store;
  LaneKind lane = LaneKind::u8;
  int param = 0;
};

// Operands and result of one probe run. a, b, c: one full vector each (any alignment that suits
// the lane type). out: one full vector (written by every op except store_partial).
struct ProbeArgs {
  const uint8_t* a = nullptr;
  const uint8_t* b = nullptr;
  const uint8_t* c = nullptr;
  const uint8_t* gather_base_u8 = nullptr;
  const uint16_t* gather_base_u16 = nullptr;
  const void* partial_source = nullptr;  // load_partial reads param lanes from here
  void* partial_destination = nullptr;   // store_partial writes param lanes here
  uint8_t* out = nullptr;
};

// A per-ISA probe entry point: runs one op on that level's native back end.
using ProbeFunction = void (*)(const ProbeOp& op, const ProbeArgs& args);

// Functions (unlike the plain types above) stay in an anonymous namespace: each unit gets its own
// copy, so none compiled with another level's flags can be picked by the linker.
namespace {

// Which lane types each op exists for, per the contract.
constexpr bool op_supports(OpKind kind, LaneKind lane) {
  switch (kind) {
    case OpKind::adds:
    case OpKind::subs: return lane == LaneKind::u8 || lane == LaneKind::u16 || lane == LaneKind::s16;
    case OpKind::absdiff:
    case OpKind::avg: return lane == LaneKind::u8 || lane == LaneKind::u16;
    case OpKind::mullo:
      return lane == LaneKind::u16 || lane == LaneKind::s16 || lane == LaneKind::u32 || lane == LaneKind::s32;
    case OpKind::popcount: return lane == LaneKind::u8 || lane == LaneKind::u32 || lane == LaneKind::u64;
    case OpKind::widen_lo:
    case OpKind::widen_hi: return lane == LaneKind::u8 || lane == LaneKind::u16 || lane == LaneKind::s16;
    case OpKind::zip_lo:
    case OpKind::zip_hi: return lane == LaneKind::u8 || lane == LaneKind::u16 || lane == LaneKind::u32;
    case OpKind::narrow_sat_u8: return lane == LaneKind::u16;
    case OpKind::narrow_sat_s16:
    case OpKind::narrow_sat_u16:
    case OpKind::gather_u8:
    case OpKind::gather_u16: return lane == LaneKind::s32;
    case OpKind::min_across: return lane == LaneKind::u16 || lane == LaneKind::u32;
    case OpKind::previous_lanes:
    case OpKind::next_lanes: return lane == LaneKind::u16 || lane == LaneKind::u32;
    default: return true;
  }
}

// The lane type of the op's result vector (what the test compares lane by lane).
constexpr LaneKind result_lane(OpKind kind, LaneKind lane, int param) {
  switch (kind) {
    case OpKind::widen_lo:
    case OpKind::widen_hi:
    case OpKind::zip_lo:
    case OpKind::zip_hi:
      return lane == LaneKind::u8 ? LaneKind::u16
             : lane == LaneKind::u16 ? LaneKind::u32
             : lane == LaneKind::s16 ? LaneKind::s32
                                     : LaneKind::u64;
    case OpKind::narrow_sat_u8: return LaneKind::u8;
    case OpKind::narrow_sat_s16: return LaneKind::s16;
    case OpKind::narrow_sat_u16: return LaneKind::u16;
    case OpKind::gather_u8:
    case OpKind::gather_u16: return LaneKind::u32;
    case OpKind::bitcast:
    case OpKind::as_type: return static_cast<LaneKind>(param);
    default: return lane;
  }
}

template <class Lane> struct LaneKindOf;
template <> struct LaneKindOf<uint8_t> { static constexpr LaneKind value = LaneKind::u8; };
template <> struct LaneKindOf<uint16_t> { static constexpr LaneKind value = LaneKind::u16; };
template <> struct LaneKindOf<int16_t> { static constexpr LaneKind value = LaneKind::s16; };
template <> struct LaneKindOf<uint32_t> { static constexpr LaneKind value = LaneKind::u32; };
template <> struct LaneKindOf<int32_t> { static constexpr LaneKind value = LaneKind::s32; };
template <> struct LaneKindOf<uint64_t> { static constexpr LaneKind value = LaneKind::u64; };

template <class Lane>
constexpr bool lane_has(OpKind kind) {
  return op_supports(kind, LaneKindOf<Lane>::value);
}

template <class B, class Lane>
auto probe_load(const uint8_t* bytes) {
  return B::load(reinterpret_cast<const Lane*>(bytes));
}

template <class B, class Vector>
void probe_store(uint8_t* bytes, const Vector& v) {
  using Lane = typename Vector::lane_type;
  B::store(reinterpret_cast<Lane*>(bytes), v);
}

template <class B, class Lane>
void probe_set1(const ProbeArgs& args) {
  Lane x;
  std::memcpy(&x, args.a, sizeof(x));
  if constexpr (LaneKindOf<Lane>::value == LaneKind::u8) probe_store<B>(args.out, B::set1_u8(x));
  if constexpr (LaneKindOf<Lane>::value == LaneKind::u16) probe_store<B>(args.out, B::set1_u16(x));
  if constexpr (LaneKindOf<Lane>::value == LaneKind::s16) probe_store<B>(args.out, B::set1_s16(x));
  if constexpr (LaneKindOf<Lane>::value == LaneKind::u32) probe_store<B>(args.out, B::set1_u32(x));
  if constexpr (LaneKindOf<Lane>::value == LaneKind::s32) probe_store<B>(args.out, B::set1_s32(x));
  if constexpr (LaneKindOf<Lane>::value == LaneKind::u64) probe_store<B>(args.out, B::set1_u64(x));
}

template <class B, class Lane, int kShift>
void probe_shift(const ProbeOp& op, const ProbeArgs& args) {
  if constexpr (kShift < 8 * static_cast<int>(sizeof(Lane))) {
    const auto a = probe_load<B, Lane>(args.a);
    if (op.kind == OpKind::shl) probe_store<B>(args.out, B::template shl<kShift>(a));
    if (op.kind == OpKind::shr) probe_store<B>(args.out, B::template shr<kShift>(a));
  }
}

template <class B, class Lane>
void probe_shift_by(const ProbeOp& op, const ProbeArgs& args) {
  switch (op.param) {
    case 0: probe_shift<B, Lane, 0>(op, args); break;
    case 1: probe_shift<B, Lane, 1>(op, args); break;
    case 3: probe_shift<B, Lane, 3>(op, args); break;
    case 7: probe_shift<B, Lane, 7>(op, args); break;
    case 8: probe_shift<B, Lane, 8>(op, args); break;
    case 15: probe_shift<B, Lane, 15>(op, args); break;
    case 16: probe_shift<B, Lane, 16>(op, args); break;
    case 31: probe_shift<B, Lane, 31>(op, args); break;
    case 32: probe_shift<B, Lane, 32>(op, args); break;
    case 63: probe_shift<B, Lane, 63>(op, args); break;
    default: break;
  }
}

template <class B, class To, class Vector>
void probe_reinterpret(const ProbeOp& op, const ProbeArgs& args, const Vector& a) {
  if (op.kind == OpKind::bitcast) {
    probe_store<B>(args.out, B::template bitcast<To>(a));
  } else {
    if constexpr (LaneKindOf<To>::value == LaneKind::u8) probe_store<B>(args.out, B::as_u8(a));
    if constexpr (LaneKindOf<To>::value == LaneKind::u16) probe_store<B>(args.out, B::as_u16(a));
    if constexpr (LaneKindOf<To>::value == LaneKind::s16) probe_store<B>(args.out, B::as_s16(a));
    if constexpr (LaneKindOf<To>::value == LaneKind::u32) probe_store<B>(args.out, B::as_u32(a));
    if constexpr (LaneKindOf<To>::value == LaneKind::s32) probe_store<B>(args.out, B::as_s32(a));
    if constexpr (LaneKindOf<To>::value == LaneKind::u64) probe_store<B>(args.out, B::as_u64(a));
  }
}

template <class B, class Lane>
void probe_lane(const ProbeOp& op, const ProbeArgs& args) {
  if (op.kind == OpKind::load_partial) {  // reads partial_source only
    probe_store<B>(args.out, B::load_partial(static_cast<const Lane*>(args.partial_source), op.param));
    return;
  }
  using Vector = decltype(probe_load<B, Lane>(args.a));
  const Vector a = probe_load<B, Lane>(args.a);
  const Vector b = probe_load<B, Lane>(args.b);
  switch (op.kind) {
    case OpKind::load_store: probe_store<B>(args.out, a); break;
    case OpKind::store_partial: B::store_partial(static_cast<Lane*>(args.partial_destination), a, op.param); break;
    case OpKind::set1: probe_set1<B, Lane>(args); break;
    case OpKind::extract: {
      Lane lanes[Vector::kLanes];
      for (int i = 0; i < Vector::kLanes; ++i) lanes[i] = B::extract(a, i);
      std::memcpy(args.out, lanes, sizeof(lanes));
      break;
    }
    case OpKind::add: probe_store<B>(args.out, B::add(a, b)); break;
    case OpKind::sub: probe_store<B>(args.out, B::sub(a, b)); break;
    case OpKind::adds:
      if constexpr (lane_has<Lane>(OpKind::adds)) probe_store<B>(args.out, B::adds(a, b));
      break;
    case OpKind::subs:
      if constexpr (lane_has<Lane>(OpKind::subs)) probe_store<B>(args.out, B::subs(a, b));
      break;
    case OpKind::min: probe_store<B>(args.out, B::min(a, b)); break;
    case OpKind::max: probe_store<B>(args.out, B::max(a, b)); break;
    case OpKind::min_across:
      if constexpr (lane_has<Lane>(OpKind::min_across)) probe_store<B>(args.out, B::min_across(a));
      break;
    case OpKind::previous_lanes:
      if constexpr (std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>) probe_store<B>(args.out, B::previous_lanes(a, b));
      break;
    case OpKind::next_lanes:
      if constexpr (std::is_same_v<Lane, uint16_t> || std::is_same_v<Lane, uint32_t>) probe_store<B>(args.out, B::next_lanes(a, b));
      break;
    case OpKind::store_stream: {
      alignas(64) Lane lanes[Vector::kLanes];
      B::store_stream(lanes, a);
      B::stream_fence();
      std::memcpy(args.out, lanes, sizeof(lanes));
      break;
    }
    case OpKind::first_lane: {
      Lane lanes[Vector::kLanes] = {};
      lanes[0] = B::first_lane(a);
      std::memcpy(args.out, lanes, sizeof(lanes));
      break;
    }
    case OpKind::absdiff:
      if constexpr (lane_has<Lane>(OpKind::absdiff)) probe_store<B>(args.out, B::absdiff(a, b));
      break;
    case OpKind::avg:
      if constexpr (lane_has<Lane>(OpKind::avg)) probe_store<B>(args.out, B::avg(a, b));
      break;
    case OpKind::mullo:
      if constexpr (lane_has<Lane>(OpKind::mullo)) probe_store<B>(args.out, B::mullo(a, b));
      break;
    case OpKind::bit_and: probe_store<B>(args.out, B::bit_and(a, b)); break;
    case OpKind::bit_or: probe_store<B>(args.out, B::bit_or(a, b)); break;
    case OpKind::bit_xor: probe_store<B>(args.out, B::bit_xor(a, b)); break;
    case OpKind::bit_andnot: probe_store<B>(args.out, B::bit_andnot(a, b)); break;
    case OpKind::select: probe_store<B>(args.out, B::select(probe_load<B, Lane>(args.c), a, b)); break;
    case OpKind::shl:
    case OpKind::shr: probe_shift_by<B, Lane>(op, args); break;
    case OpKind::cmpeq: probe_store<B>(args.out, B::cmpeq(a, b)); break;
    case OpKind::cmpgt: probe_store<B>(args.out, B::cmpgt(a, b)); break;
    case OpKind::cmplt: probe_store<B>(args.out, B::cmplt(a, b)); break;
    case OpKind::popcount:
      if constexpr (lane_has<Lane>(OpKind::popcount)) probe_store<B>(args.out, B::popcount(a));
      break;
    case OpKind::widen_lo:
      if constexpr (lane_has<Lane>(OpKind::widen_lo)) probe_store<B>(args.out, B::widen_lo(a));
      break;
    case OpKind::widen_hi:
      if constexpr (lane_has<Lane>(OpKind::widen_hi)) probe_store<B>(args.out, B::widen_hi(a));
      break;
    case OpKind::zip_lo:
      if constexpr (lane_has<Lane>(OpKind::zip_lo)) probe_store<B>(args.out, B::zip_lo(a, b));
      break;
    case OpKind::zip_hi:
      if constexpr (lane_has<Lane>(OpKind::zip_hi)) probe_store<B>(args.out, B::zip_hi(a, b));
      break;
    case OpKind::narrow_sat_u8:
      if constexpr (lane_has<Lane>(OpKind::narrow_sat_u8)) probe_store<B>(args.out, B::narrow_sat_u8(a, b));
      break;
    case OpKind::narrow_sat_s16:
      if constexpr (lane_has<Lane>(OpKind::narrow_sat_s16)) probe_store<B>(args.out, B::narrow_sat_s16(a, b));
      break;
    case OpKind::narrow_sat_u16:
      if constexpr (lane_has<Lane>(OpKind::narrow_sat_u16)) probe_store<B>(args.out, B::narrow_sat_u16(a, b));
      break;
    case OpKind::gather_u8:
      if constexpr (lane_has<Lane>(OpKind::gather_u8)) probe_store<B>(args.out, B::gather_u8(args.gather_base_u8, a));
      break;
    case OpKind::gather_u16:
      if constexpr (lane_has<Lane>(OpKind::gather_u16)) {
        probe_store<B>(args.out, B::gather_u16(args.gather_base_u16, a));
      }
      break;
    case OpKind::bitcast:
    case OpKind::as_type:
      switch (static_cast<LaneKind>(op.param)) {
        case LaneKind::u8: probe_reinterpret<B, uint8_t>(op, args, a); break;
        case LaneKind::u16: probe_reinterpret<B, uint16_t>(op, args, a); break;
        case LaneKind::s16: probe_reinterpret<B, int16_t>(op, args, a); break;
        case LaneKind::u32: probe_reinterpret<B, uint32_t>(op, args, a); break;
        case LaneKind::s32: probe_reinterpret<B, int32_t>(op, args, a); break;
        case LaneKind::u64: probe_reinterpret<B, uint64_t>(op, args, a); break;
        default: break;
      }
      break;
    default: break;
  }
}

// Runs one op of the contract on back end B. Ops a lane type does not have do nothing.
template <class B>
void run_probe(const ProbeOp& op, const ProbeArgs& args) {
  switch (op.lane) {
    case LaneKind::u8: probe_lane<B, uint8_t>(op, args); break;
    case LaneKind::u16: probe_lane<B, uint16_t>(op, args); break;
    case LaneKind::s16: probe_lane<B, int16_t>(op, args); break;
    case LaneKind::u32: probe_lane<B, uint32_t>(op, args); break;
    case LaneKind::s32: probe_lane<B, int32_t>(op, args); break;
    case LaneKind::u64: probe_lane<B, uint64_t>(op, args); break;
    default: break;
  }
}

}  // namespace
}  // namespace lpstereo::simd_probe
