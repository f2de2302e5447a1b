// Instruction-set levels of the native back end, detected at run time.
//
// The kernels are compiled once per level the build supports (kernels/CMakeLists.txt); at run time
// the best level the CPU has is used, capped by the environment variable LPSTEREO_ISA (one of the
// names below) or by set_active_isa() (tests use it to run every level and compare the bits).
#pragma once

#include <string_view>
#include <vector>

namespace lpstereo::simd {

// avx512_icl: AVX-512 with VPOPCNTDQ and BITALG (Ice Lake, Sapphire Rapids, Zen 4 and later): the
// avx512 back end with single-instruction popcounts (kernels/simd/x86_avx512.h). The order is the
// cap's (LPSTEREO_ISA caps at the best level not above it), so it sits between avx512 and neon.
enum class Isa : int { scalar = 0, sse42, avx2, avx512, avx512_icl, neon, count_ };

inline constexpr int kIsaCount = static_cast<int>(Isa::count_);

std::string_view isa_name(Isa isa);

// Parses an ISA name ("scalar", "sse4.2", "avx2", "avx512", "avx512-icl", "neon"); false if unknown.
bool parse_isa(std::string_view name, Isa& isa);

// Levels compiled into this binary AND supported by this CPU, lowest first (scalar is always there).
const std::vector<Isa>& available_isas();

// The level kernels dispatch to now: the best available, capped by LPSTEREO_ISA, or as set below.
Isa active_isa();

// Selects the level for this process (must be available); returns the previous one.
Isa set_active_isa(Isa isa);

// Runs a scope with another active ISA, restoring the previous one at exit.
class ActiveIsaScope {
 public:
  explicit ActiveIsaScope(Isa isa) : previous_(set_active_isa(isa)) {}
  ~ActiveIsaScope() { set_active_isa(previous_); }
  ActiveIsaScope(const ActiveIsaScope&) = delete;
  ActiveIsaScope& operator=(const ActiveIsaScope&) = delete;

 private:
  Isa previous_;
};

}  // namespace lpstereo::simd
