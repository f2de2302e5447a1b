// Every op of the simd contract, on every native back end this CPU runs, against the emulated back
// end at the same width (kernels/simd/emulated.h is the definition), lane by lane: random operands
// plus every pair of edge values (0, 1, max, min, 0x7F, 0x80, saturation boundaries) of the lane
// type. Partial loads and stores are checked at the edge of a guard page, so a back end that reads
// or writes one byte past p + n (or before p) faults.
//
// The native back ends live in per-ISA units (simd_ops_probe.cpp, compiled with each level's flags);
// this file is baseline code and runs the same battery (simd_ops_battery.h) on Emulated.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "kernels/simd/emulated.h"
#include "kernels/simd/isa.h"
#include "tests/kernels/simd_ops_battery.h"

namespace lpstereo::simd_probe {
#if defined(LPSTEREO_SIMD_PROBE_SSE42)
void simd_ops_probe_sse42(const ProbeOp& op, const ProbeArgs& args);
int simd_ops_probe_sse42_bytes();
#endif
#if defined(LPSTEREO_SIMD_PROBE_AVX2)
void simd_ops_probe_avx2(const ProbeOp& op, const ProbeArgs& args);
int simd_ops_probe_avx2_bytes();
#endif
#if defined(LPSTEREO_SIMD_PROBE_AVX512)
void simd_ops_probe_avx512(const ProbeOp& op, const ProbeArgs& args);
int simd_ops_probe_avx512_bytes();
#endif
#if defined(LPSTEREO_SIMD_PROBE_AVX512_ICL)
void simd_ops_probe_avx512_icl(const ProbeOp& op, const ProbeArgs& args);
int simd_ops_probe_avx512_icl_bytes();
#endif
#if defined(LPSTEREO_SIMD_PROBE_NEON)
void simd_ops_probe_neon(const ProbeOp& op, const ProbeArgs& args);
int simd_ops_probe_neon_bytes();
#endif
}  // namespace lpstereo::simd_probe

namespace lpstereo {
namespace {

using simd_probe::kLaneKindBytes;
using simd_probe::kLaneKindCount;
using simd_probe::kLaneKindNames;
using simd_probe::kOpKindNames;
using simd_probe::LaneKind;
using simd_probe::OpKind;
using simd_probe::ProbeArgs;
using simd_probe::ProbeFunction;
using simd_probe::ProbeOp;

static_assert(std::endian::native == std::endian::little, "the test writes lanes as little-endian bytes");

constexpr int kMaxVectorBytes = 64;
constexpr int kRandomRounds = 64;
constexpr int kGatherReach = 300;  // gather offsets fall in [-kGatherReach, kGatherReach)

struct NativeLevel {
  simd::Isa isa;
  ProbeFunction run;
  int bytes;
};

// Native levels compiled into this test AND supported by this CPU.
std::vector<NativeLevel> native_levels() {
  std::vector<NativeLevel> compiled;
#if defined(LPSTEREO_SIMD_PROBE_SSE42)
  compiled.push_back({simd::Isa::sse42, simd_probe::simd_ops_probe_sse42, simd_probe::simd_ops_probe_sse42_bytes()});
#endif
#if defined(LPSTEREO_SIMD_PROBE_AVX2)
  compiled.push_back({simd::Isa::avx2, simd_probe::simd_ops_probe_avx2, simd_probe::simd_ops_probe_avx2_bytes()});
#endif
#if defined(LPSTEREO_SIMD_PROBE_AVX512)
  compiled.push_back({simd::Isa::avx512, simd_probe::simd_ops_probe_avx512, simd_probe::simd_ops_probe_avx512_bytes()});
#endif
#if defined(LPSTEREO_SIMD_PROBE_AVX512_ICL)
  compiled.push_back(
      {simd::Isa::avx512_icl, simd_probe::simd_ops_probe_avx512_icl, simd_probe::simd_ops_probe_avx512_icl_bytes()});
#endif
#if defined(LPSTEREO_SIMD_PROBE_NEON)
  compiled.push_back({simd::Isa::neon, simd_probe::simd_ops_probe_neon, simd_probe::simd_ops_probe_neon_bytes()});
#endif
  std::vector<NativeLevel> runnable;
  const std::vector<simd::Isa>& available = simd::available_isas();
  for (const NativeLevel& level : compiled) {
    if (std::find(available.begin(), available.end(), level.isa) != available.end()) runnable.push_back(level);
  }
  return runnable;
}

// The definition: the emulated back end at the native level's width.
void run_emulated(int bytes, const ProbeOp& op, const ProbeArgs& args) {
  switch (bytes) {
    case 16: simd_probe::run_probe<simd::Emulated<16, false>>(op, args); break;
    case 32: simd_probe::run_probe<simd::Emulated<32, false>>(op, args); break;
    case 64: simd_probe::run_probe<simd::Emulated<64, false>>(op, args); break;
    default: FAIL() << "no emulated back end of " << bytes << " bytes";
  }
}

int lane_bits(LaneKind lane) { return 8 * kLaneKindBytes[static_cast<int>(lane)]; }
const char* lane_name(LaneKind lane) { return kLaneKindNames[static_cast<int>(lane)]; }

// Interesting values per lane type, as bit patterns (written as the low bytes).
std::vector<uint64_t> edge_values(LaneKind lane) {
  auto s = [](int64_t x) { return static_cast<uint64_t>(x); };
  switch (lane) {
    case LaneKind::u8: return {0, 1, 2, 0x0F, 0x7E, 0x7F, 0x80, 0x81, 0xFE, 0xFF};
    case LaneKind::u16: return {0, 1, 0x7F, 0x80, 0xFF, 0x100, 0x7FFF, 0x8000, 0x8001, 0xFFFE, 0xFFFF};
    case LaneKind::s16: return {0, 1, s(-1), 0x7F, 0x80, 0xFF, 0x100, 0x7FFE, 0x7FFF, s(-0x8000), s(-0x7FFF), s(-0x100)};
    case LaneKind::u32:
      return {0, 1, 0xFF, 0x100, 0xFFFF, 0x10000, 0x7FFFFFFF, 0x80000000, 0x80000001, 0xFFFFFFFE, 0xFFFFFFFF};
    case LaneKind::s32:
      return {0,     1,       s(-1),       0x7F,        0x80,       0xFF,       0x100,      0x7FFF,    0x8000,
              0xFFFF, 0x10000, s(-0x7FFF), s(-0x8000), s(-0x8001), 0x7FFFFFFF, s(-0x7FFFFFFF - 1), s(-0x100)};
    case LaneKind::u64:
      return {0, 1, 0xFF, 0xFFFFFFFF, 0x100000000, 0x7FFFFFFFFFFFFFFF, 0x8000000000000000, 0xFFFFFFFFFFFFFFFE,
              0xFFFFFFFFFFFFFFFF};
    default: return {0};
  }
}

void write_lane(uint8_t* vector, LaneKind lane, int index, uint64_t value) {
  const int size = kLaneKindBytes[static_cast<int>(lane)];
  std::memcpy(vector + index * size, &value, size);
}

uint64_t read_lane(const uint8_t* vector, LaneKind lane, int index) {
  uint64_t value = 0;
  const int size = kLaneKindBytes[static_cast<int>(lane)];
  std::memcpy(&value, vector + index * size, size);
  return value;
}

// A lane as the number it stands for (signed lane types sign-extended).
std::string lane_text(uint64_t bits, LaneKind lane) {
  std::ostringstream text;
  switch (lane) {
    case LaneKind::s16: text << static_cast<int16_t>(bits); break;
    case LaneKind::s32: text << static_cast<int32_t>(bits); break;
    default: text << bits; break;
  }
  text << " (0x" << std::hex << bits << ")";
  return text.str();
}

std::string vector_text(const uint8_t* vector, int bytes, LaneKind lane) {
  std::ostringstream text;
  text << "[";
  const int lanes = bytes / kLaneKindBytes[static_cast<int>(lane)];
  for (int i = 0; i < lanes; ++i) {
    if (i > 0) text << " ";
    const uint64_t bits = read_lane(vector, lane, i);
    if (lane == LaneKind::s16) text << static_cast<int16_t>(bits);
    else if (lane == LaneKind::s32) text << static_cast<int32_t>(bits);
    else text << bits;
  }
  text << "]";
  return text.str();
}

std::string op_text(const ProbeOp& op) {
  std::ostringstream text;
  text << kOpKindNames[static_cast<int>(op.kind)] << " on " << lane_name(op.lane) << " lanes";
  if (op.kind == OpKind::shl || op.kind == OpKind::shr) text << " by " << op.param;
  if (op.kind == OpKind::bitcast || op.kind == OpKind::as_type) text << " to " << lane_name(static_cast<LaneKind>(op.param));
  if (op.kind == OpKind::load_partial || op.kind == OpKind::store_partial) text << " with n = " << op.param;
  return text.str();
}

// Every (lane type, parameter) the contract defines for an op kind.
std::vector<ProbeOp> cases_of(OpKind kind) {
  std::vector<ProbeOp> cases;
  for (int lane_index = 0; lane_index < kLaneKindCount; ++lane_index) {
    const LaneKind lane = static_cast<LaneKind>(lane_index);
    if (!simd_probe::op_supports(kind, lane)) continue;
    if (kind == OpKind::shl || kind == OpKind::shr) {
      for (int shift : simd_probe::kShiftCounts) {
        if (shift < lane_bits(lane)) cases.push_back({kind, lane, shift});
      }
    } else if (kind == OpKind::bitcast || kind == OpKind::as_type) {
      for (int to = 0; to < kLaneKindCount; ++to) cases.push_back({kind, lane, to});
    } else {
      cases.push_back({kind, lane, 0});
    }
  }
  return cases;
}

// Operand vectors of one round. a, b, c start 8 bytes into 64-byte aligned storage: aligned for every
// lane type, not for the vector.
struct Operands {
  alignas(64) uint8_t storage[3][kMaxVectorBytes + 64] = {};
  uint8_t* a() { return storage[0] + 8; }
  uint8_t* b() { return storage[1] + 8; }
  uint8_t* c() { return storage[2] + 8; }
};

class OperandSource {
 public:
  explicit OperandSource(uint64_t seed) : generator_(seed) {}

  uint64_t bits() { return generator_(); }
  // Half the time any bits, half the time an edge value nudged by -2 .. +2.
  uint64_t value(const std::vector<uint64_t>& edges) {
    if (generator_() & 1) return generator_();
    return edges[generator_() % edges.size()] + generator_() % 5 - 2;
  }
  int32_t gather_offset() {
    return static_cast<int32_t>(generator_() % (2 * kGatherReach)) - kGatherReach;
  }

 private:
  std::mt19937_64 generator_;
};

// Fills a round's operands. Rounds [0, edge_rounds) pair every edge value of a with every edge value
// of b; later rounds are random. Gathers get offsets instead.
void fill_operands(const ProbeOp& op, int bytes, int round, int edge_rounds, OperandSource& source, Operands& operands) {
  const LaneKind lane = op.lane;
  const int lanes = bytes / kLaneKindBytes[static_cast<int>(lane)];
  const std::vector<uint64_t> edges = edge_values(lane);
  const int edge_count = static_cast<int>(edges.size());
  const bool gather = op.kind == OpKind::gather_u8 || op.kind == OpKind::gather_u16;
  for (int i = 0; i < lanes; ++i) {
    uint64_t a = 0, b = 0;
    if (gather) {
      const int extremes[3] = {-kGatherReach, kGatherReach - 1, 0};
      a = static_cast<uint64_t>(round < edge_rounds ? extremes[i % 3] : source.gather_offset());
      b = a;
    } else if (round < edge_rounds) {
      const int pair = round * lanes + i;
      a = edges[pair % edge_count];
      b = edges[(pair / edge_count) % edge_count];
    } else {
      a = source.value(edges);
      b = source.value(edges);
    }
    write_lane(operands.a(), lane, i, a);
    write_lane(operands.b(), lane, i, b);
    write_lane(operands.c(), lane, i, source.bits());
  }
}

// Compares result vectors lane by lane; on a difference, says which op, lane type, ISA and lane.
::testing::AssertionResult same_lanes(const ProbeOp& op, const NativeLevel& level, const uint8_t* expected,
                                      const uint8_t* actual, Operands* operands) {
  const LaneKind result = simd_probe::result_lane(op.kind, op.lane, op.param);
  const int lanes = level.bytes / kLaneKindBytes[static_cast<int>(result)];
  for (int i = 0; i < lanes; ++i) {
    const uint64_t want = read_lane(expected, result, i);
    const uint64_t got = read_lane(actual, result, i);
    if (want != got) {
      auto failure = ::testing::AssertionFailure();
      failure << op_text(op) << " on " << simd::isa_name(level.isa) << ": result lane " << i << " ("
              << lane_name(result) << ") is " << lane_text(got, result) << ", the contract (emulated) gives "
              << lane_text(want, result);
      if (operands != nullptr) {
        failure << "\n  a = " << vector_text(operands->a(), level.bytes, op.lane)
                << "\n  b = " << vector_text(operands->b(), level.bytes, op.lane);
        if (op.kind == OpKind::select) failure << "\n  mask = " << vector_text(operands->c(), level.bytes, op.lane);
      }
      return failure;
    }
  }
  return ::testing::AssertionSuccess();
}

class SimdOps : public ::testing::TestWithParam<OpKind> {};

TEST_P(SimdOps, EveryLaneTypeMatchesEmulatedOnEveryNativeLevel) {
  const OpKind kind = GetParam();
  const std::vector<NativeLevel> levels = native_levels();
  if (levels.empty()) GTEST_SKIP() << "no native simd level is compiled in and supported by this CPU";

  std::vector<uint8_t> gather_bytes(2 * kGatherReach);
  std::vector<uint16_t> gather_words(2 * kGatherReach);
  OperandSource fill_source(0x5eed0000u + static_cast<uint64_t>(kind));
  for (uint8_t& x : gather_bytes) x = static_cast<uint8_t>(fill_source.bits());
  for (uint16_t& x : gather_words) x = static_cast<uint16_t>(fill_source.bits());

  for (const NativeLevel& level : levels) {
    for (const ProbeOp& op : cases_of(kind)) {
      const int lanes = level.bytes / kLaneKindBytes[static_cast<int>(op.lane)];
      const int edge_count = static_cast<int>(edge_values(op.lane).size());
      const int edge_rounds = (edge_count * edge_count + lanes - 1) / lanes;
      OperandSource source(0xC0FFEEu * (static_cast<uint64_t>(kind) + 1) + static_cast<uint64_t>(op.lane) * 131 +
                           static_cast<uint64_t>(op.param));
      for (int round = 0; round < edge_rounds + kRandomRounds; ++round) {
        Operands operands;
        fill_operands(op, level.bytes, round, edge_rounds, source, operands);
        alignas(64) uint8_t expected[kMaxVectorBytes];
        alignas(64) uint8_t actual[kMaxVectorBytes];
        // Different fills: a result byte neither back end writes shows up as a difference.
        std::memset(expected, 0x11, sizeof(expected));
        std::memset(actual, 0x22, sizeof(actual));
        ProbeArgs args;
        args.a = operands.a();
        args.b = operands.b();
        args.c = operands.c();
        args.gather_base_u8 = gather_bytes.data() + kGatherReach;
        args.gather_base_u16 = gather_words.data() + kGatherReach;
        args.out = expected;
        run_emulated(level.bytes, op, args);
        args.out = actual;
        level.run(op, args);
        const ::testing::AssertionResult same = same_lanes(op, level, expected, actual, &operands);
        if (!same) {
          ADD_FAILURE() << same.message() << "\n  (round " << round << (round < edge_rounds ? ", edge values" : ", random")
                        << "; later rounds of this case skipped)";
          break;
        }
      }
    }
  }
}

// Names the parameter in test listings ("GetParam() = add" rather than its bytes).
}  // namespace
namespace simd_probe {
void PrintTo(OpKind kind, std::ostream* out) { *out << kOpKindNames[static_cast<int>(kind)]; }
}  // namespace simd_probe
namespace {

std::string op_test_name(const ::testing::TestParamInfo<OpKind>& info) {
  std::string name = kOpKindNames[static_cast<int>(info.param)];
  for (char& ch : name) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return name;
}

std::vector<OpKind> lane_op_kinds() {
  std::vector<OpKind> kinds;
  for (int i = 0; i < simd_probe::kOpKindCount; ++i) {
    const OpKind kind = static_cast<OpKind>(i);
    if (kind != OpKind::load_partial && kind != OpKind::store_partial) kinds.push_back(kind);
  }
  return kinds;
}

INSTANTIATE_TEST_SUITE_P(Contract, SimdOps, ::testing::ValuesIn(lane_op_kinds()), op_test_name);

// ---- partial loads and stores next to guard pages ----

// One read-write page between two inaccessible pages: touching a byte before or after it faults.
class GuardedPage {
 public:
  GuardedPage() : page_bytes_(static_cast<size_t>(sysconf(_SC_PAGESIZE))) {
    void* mapping = mmap(nullptr, 3 * page_bytes_, PROT_NONE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapping == MAP_FAILED) throw std::runtime_error("mmap of a guarded page failed");
    mapping_ = static_cast<uint8_t*>(mapping);
    if (mprotect(mapping_ + page_bytes_, page_bytes_, PROT_READ | PROT_WRITE) != 0) {
      munmap(mapping_, 3 * page_bytes_);
      throw std::runtime_error("mprotect of a guarded page failed");
    }
  }
  ~GuardedPage() { munmap(mapping_, 3 * page_bytes_); }
  GuardedPage(const GuardedPage&) = delete;
  GuardedPage& operator=(const GuardedPage&) = delete;

  uint8_t* begin() const { return mapping_ + page_bytes_; }
  uint8_t* end() const { return begin() + page_bytes_; }
  size_t size() const { return page_bytes_; }

 private:
  size_t page_bytes_;
  uint8_t* mapping_ = nullptr;
};

// While alive, a fault (touching a guard page) prints what was running and exits non-zero, instead
// of an anonymous crash.
char g_running_probe[256];

extern "C" void report_guard_fault(int) {
  static const char kPrefix[] = "\nsimd_ops_test: memory fault (a guard page was touched) in ";
  [[maybe_unused]] ssize_t written = write(STDERR_FILENO, kPrefix, sizeof(kPrefix) - 1);
  written = write(STDERR_FILENO, g_running_probe, strnlen(g_running_probe, sizeof(g_running_probe)));
  written = write(STDERR_FILENO, "\n", 1);
  _exit(3);
}

class GuardFaultReport {
 public:
  GuardFaultReport() {
    struct sigaction action = {};
    action.sa_handler = report_guard_fault;
    sigemptyset(&action.sa_mask);
    sigaction(SIGSEGV, &action, &previous_segv_);
    sigaction(SIGBUS, &action, &previous_bus_);
  }
  ~GuardFaultReport() {
    sigaction(SIGSEGV, &previous_segv_, nullptr);
    sigaction(SIGBUS, &previous_bus_, nullptr);
  }
  GuardFaultReport(const GuardFaultReport&) = delete;
  GuardFaultReport& operator=(const GuardFaultReport&) = delete;

  void running(const std::string& what) { std::snprintf(g_running_probe, sizeof(g_running_probe), "%s", what.c_str()); }

 private:
  struct sigaction previous_segv_ = {};
  struct sigaction previous_bus_ = {};
};

// Where the n lanes sit: against the guard page after them or before them, or one byte into the
// page, misaligned for lanes wider than a byte (the contract allows any alignment; the debug-asan
// preset's UBSan reports a native back end that reads or writes a lane through a misaligned pointer).
enum class Placement { ending_at_guard, starting_at_guard, one_byte_in };
const char* placement_text(Placement placement) {
  switch (placement) {
    case Placement::ending_at_guard: return "lanes ending at a guard page";
    case Placement::starting_at_guard: return "lanes starting at a guard page";
    case Placement::one_byte_in: return "lanes starting one byte into the page (misaligned)";
  }
  return "";
}
// The byte offset of the n lanes (span bytes) in the page.
size_t placement_offset(Placement placement, size_t page_size, size_t span) {
  switch (placement) {
    case Placement::ending_at_guard: return page_size - span;
    case Placement::starting_at_guard: return 0;
    case Placement::one_byte_in: return 1;
  }
  return 0;
}

TEST(SimdPartial, LoadPartialReadsExactlyNLanesAndZeroesTheRest) {
  const std::vector<NativeLevel> levels = native_levels();
  if (levels.empty()) GTEST_SKIP() << "no native simd level is compiled in and supported by this CPU";
  GuardedPage page;
  GuardFaultReport fault_report;
  std::mt19937 generator(11);
  for (const NativeLevel& level : levels) {
    for (int lane_index = 0; lane_index < kLaneKindCount; ++lane_index) {
      const LaneKind lane = static_cast<LaneKind>(lane_index);
      const int lanes = level.bytes / kLaneKindBytes[lane_index];
      for (int count = 0; count <= lanes; ++count) {
        for (Placement placement : {Placement::ending_at_guard, Placement::starting_at_guard, Placement::one_byte_in}) {
          for (size_t i = 0; i < page.size(); ++i) page.begin()[i] = static_cast<uint8_t>(generator());
          const size_t span = static_cast<size_t>(count) * kLaneKindBytes[lane_index];
          const uint8_t* source = page.begin() + placement_offset(placement, page.size(), span);
          const ProbeOp op{OpKind::load_partial, lane, count};
          ProbeArgs args;
          args.partial_source = source;
          alignas(64) uint8_t expected[kMaxVectorBytes];
          alignas(64) uint8_t actual[kMaxVectorBytes];
          std::memset(expected, 0x11, sizeof(expected));
          std::memset(actual, 0x22, sizeof(actual));
          fault_report.running(op_text(op) + " on " + std::string(simd::isa_name(level.isa)) + ", " +
                               placement_text(placement));
          args.out = expected;
          run_emulated(level.bytes, op, args);
          args.out = actual;
          level.run(op, args);
          const ::testing::AssertionResult same = same_lanes(op, level, expected, actual, nullptr);
          EXPECT_TRUE(same) << placement_text(placement);
          if (!same) break;
        }
      }
    }
  }
}

TEST(SimdPartial, StorePartialWritesExactlyNLanes) {
  const std::vector<NativeLevel> levels = native_levels();
  if (levels.empty()) GTEST_SKIP() << "no native simd level is compiled in and supported by this CPU";
  GuardedPage page;
  GuardFaultReport fault_report;
  constexpr uint8_t kUntouched = 0xCD;
  std::vector<uint8_t> expected_page(page.size());
  OperandSource source(12);
  for (const NativeLevel& level : levels) {
    for (int lane_index = 0; lane_index < kLaneKindCount; ++lane_index) {
      const LaneKind lane = static_cast<LaneKind>(lane_index);
      const int lanes = level.bytes / kLaneKindBytes[lane_index];
      for (int count = 0; count <= lanes; ++count) {
        for (Placement placement : {Placement::ending_at_guard, Placement::starting_at_guard, Placement::one_byte_in}) {
          Operands operands;
          for (int i = 0; i < level.bytes; ++i) operands.a()[i] = static_cast<uint8_t>(source.bits());
          const size_t span = static_cast<size_t>(count) * kLaneKindBytes[lane_index];
          const size_t offset = placement_offset(placement, page.size(), span);
          const ProbeOp op{OpKind::store_partial, lane, count};
          ProbeArgs args;
          args.a = operands.a();
          args.b = operands.a();
          fault_report.running(op_text(op) + " on " + std::string(simd::isa_name(level.isa)) + ", " +
                               placement_text(placement));
          std::fill(expected_page.begin(), expected_page.end(), kUntouched);
          args.partial_destination = expected_page.data() + offset;
          run_emulated(level.bytes, op, args);
          std::memset(page.begin(), kUntouched, page.size());
          args.partial_destination = page.begin() + offset;
          level.run(op, args);
          for (size_t i = 0; i < page.size(); ++i) {
            if (page.begin()[i] != expected_page[i]) {
              const ptrdiff_t relative = static_cast<ptrdiff_t>(i) - static_cast<ptrdiff_t>(offset);
              ADD_FAILURE() << op_text(op) << " on " << simd::isa_name(level.isa) << ", " << placement_text(placement)
                            << ": byte " << relative << " from the destination (lane "
                            << (relative >= 0 ? relative / kLaneKindBytes[lane_index] : -1) << ", "
                            << (relative >= 0 && static_cast<size_t>(relative) < span ? "inside" : "OUTSIDE")
                            << " the n lanes) is 0x" << std::hex << int(page.begin()[i]) << ", expected 0x"
                            << int(expected_page[i]);
              break;
            }
          }
        }
      }
    }
  }
}

// The dispatch picks the best level the CPU has. scripts/test-without-avx512.sh runs this binary on
// an emulated CPU without AVX-512 and sets LPSTEREO_EXPECT_ACTIVE_ISA=avx2 to prove it.
TEST(SimdDispatch, ActiveLevelIsTheOneTheEnvironmentExpects) {
  std::string available;
  for (simd::Isa isa : simd::available_isas()) available += std::string(available.empty() ? "" : " ") + std::string(simd::isa_name(isa));
  std::printf("simd levels available here: %s; active: %s\n", available.c_str(),
              std::string(simd::isa_name(simd::active_isa())).c_str());
  // Without a cap, the best available level; with LPSTEREO_ISA, the best level not above it.
  simd::Isa best = simd::available_isas().back();
  if (const char* cap = std::getenv("LPSTEREO_ISA"); cap != nullptr && *cap != '\0') {
    simd::Isa requested;
    ASSERT_TRUE(simd::parse_isa(cap, requested)) << cap;
    best = simd::Isa::scalar;
    for (simd::Isa isa : simd::available_isas()) {
      if (static_cast<int>(isa) <= static_cast<int>(requested)) best = isa;
    }
  }
  EXPECT_EQ(simd::active_isa(), best) << "available: " << available;
  // scripts/test-without-avx512.sh names the level it expects on its emulated CPU.
  if (const char* expected = std::getenv("LPSTEREO_EXPECT_ACTIVE_ISA"); expected != nullptr && *expected != '\0') {
    EXPECT_EQ(simd::isa_name(simd::active_isa()), std::string(expected)) << "available: " << available;
  }
}

}  // namespace
}  // namespace lpstereo
