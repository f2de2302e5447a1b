// Op classes of the `simd` vector layer, and the tally the counting back end keeps.
//
// Every vector op belongs to exactly one class; the simulator turns counted ops into cycles with
// the target's issue model (targets/*.json, "vector.op_cycles"), so the class list is part of the
// target file format. Counts are in ops of the counting back end's width (kCountingVectorBytes,
// 512 bits); a target with narrower vectors splits each counted op (host_sim/cost_model.h).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace lpstereo::simd {

enum class OpClass : int {
  load = 0,   // aligned or unaligned vector load, partial (tail) load
  store,      // vector store, partial (tail) store
  arith,      // add/sub (wrapping or saturating), abs-diff, min/max, average
  logic,      // and/or/xor/andnot, select (bitwise blend)
  shift,      // shifts by an immediate
  compare,    // compare to lane mask
  multiply,   // lane-wise multiply (low half), widening multiply
  popcount,   // population count per lane
  permute,    // widen, narrow, zip/interleave, broadcast: lane movement between or within vectors
  gather,     // indexed load: one gather op fetches one element per lane
  count_      // number of classes (not a class)
};

inline constexpr int kOpClassCount = static_cast<int>(OpClass::count_);

inline constexpr std::array<std::string_view, kOpClassCount> kOpClassNames = {
    "load", "store", "arith", "logic", "shift", "compare", "multiply", "popcount", "permute", "gather"};

constexpr std::string_view op_class_name(OpClass op_class) {
  return kOpClassNames[static_cast<int>(op_class)];
}

// Counted vector ops by class. Plain value type; adding two tallies merges them.
struct OpCounts {
  std::array<uint64_t, kOpClassCount> by_class{};

  uint64_t& operator[](OpClass op_class) { return by_class[static_cast<int>(op_class)]; }
  uint64_t operator[](OpClass op_class) const { return by_class[static_cast<int>(op_class)]; }
  uint64_t total() const {
    uint64_t sum = 0;
    for (uint64_t count : by_class) sum += count;
    return sum;
  }
  OpCounts& operator+=(const OpCounts& other) {
    for (int i = 0; i < kOpClassCount; ++i) by_class[i] += other.by_class[i];
    return *this;
  }
  bool operator==(const OpCounts& other) const = default;
};

}  // namespace lpstereo::simd
