#include "kernels/simd/isa.h"

#include <array>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "kernels/simd/emulated.h"

namespace lpstereo::simd {

OpCounts*& current_op_counts() {
  thread_local OpCounts* counts = nullptr;
  return counts;
}

namespace {

constexpr std::array<std::string_view, kIsaCount> kIsaNames = {"scalar", "sse4.2", "avx2", "avx512", "avx512-icl", "neon"};

bool compiled_in(Isa isa) {
  switch (isa) {
    case Isa::scalar: return true;
#if defined(LPSTEREO_HAVE_ISA_SSE42)
    case Isa::sse42: return true;
#endif
#if defined(LPSTEREO_HAVE_ISA_AVX2)
    case Isa::avx2: return true;
#endif
#if defined(LPSTEREO_HAVE_ISA_AVX512)
    case Isa::avx512: return true;
#endif
#if defined(LPSTEREO_HAVE_ISA_AVX512_ICL)
    case Isa::avx512_icl: return true;
#endif
#if defined(LPSTEREO_HAVE_ISA_NEON)
    case Isa::neon: return true;
#endif
    default: return false;
  }
}

bool cpu_supports(Isa isa) {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  switch (isa) {
    case Isa::scalar: return true;
    case Isa::sse42: return __builtin_cpu_supports("sse4.2") && __builtin_cpu_supports("popcnt");
    // Each level asks for every feature its -m flags (cmake/isa.cmake) let the compiler use.
    case Isa::avx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
    case Isa::avx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
             __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq") &&
             __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
    case Isa::avx512_icl:
      return cpu_supports(Isa::avx512) && __builtin_cpu_supports("avx512vpopcntdq") && __builtin_cpu_supports("avx512bitalg");
    default: return false;
  }
#elif defined(__aarch64__)
  return isa == Isa::scalar || isa == Isa::neon;  // Advanced SIMD is mandatory on AArch64
#else
  return isa == Isa::scalar;
#endif
}

std::vector<Isa> detect() {
  std::vector<Isa> levels;
  for (int i = 0; i < kIsaCount; ++i) {
    const Isa isa = static_cast<Isa>(i);
    if (compiled_in(isa) && cpu_supports(isa)) levels.push_back(isa);
  }
  return levels;
}

Isa initial_isa() {
  const std::vector<Isa>& levels = available_isas();
  Isa best = levels.back();
  if (const char* cap = std::getenv("LPSTEREO_ISA"); cap != nullptr && *cap != '\0') {
    Isa requested;
    if (!parse_isa(cap, requested)) {
      std::fprintf(stderr, "lpstereo: LPSTEREO_ISA='%s' is not an ISA name (scalar, sse4.2, avx2, avx512, avx512-icl, neon)\n", cap);
      std::exit(2);
    }
    // Cap: the best available level not above the requested one.
    for (Isa level : levels) {
      if (static_cast<int>(level) <= static_cast<int>(requested)) best = level;
    }
    if (static_cast<int>(best) > static_cast<int>(requested)) best = Isa::scalar;
  }
  return best;
}

std::atomic<int>& active_storage() {
  static std::atomic<int> active{static_cast<int>(initial_isa())};
  return active;
}

}  // namespace

std::string_view isa_name(Isa isa) {
  const int index = static_cast<int>(isa);
  return index >= 0 && index < kIsaCount ? kIsaNames[index] : std::string_view("unknown");
}

bool parse_isa(std::string_view name, Isa& isa) {
  for (int i = 0; i < kIsaCount; ++i) {
    if (kIsaNames[i] == name) {
      isa = static_cast<Isa>(i);
      return true;
    }
  }
  return false;
}

const std::vector<Isa>& available_isas() {
  static const std::vector<Isa> levels = detect();
  return levels;
}

Isa active_isa() { return static_cast<Isa>(active_storage().load(std::memory_order_relaxed)); }

Isa set_active_isa(Isa isa) {
  bool available = false;
  for (Isa level : available_isas()) available = available || level == isa;
  if (!available) {
    throw std::invalid_argument("set_active_isa: ISA '" + std::string(isa_name(isa)) +
                                "' is not available in this binary on this CPU");
  }
  return static_cast<Isa>(active_storage().exchange(static_cast<int>(isa)));
}

}  // namespace lpstereo::simd
