// The per-ISA half of tests/kernels/simd_ops_test.cpp: compiled once per instruction-set level with
// that level's flags (tests/CMakeLists.txt, like the kernels), it exposes the op battery run on the
// level's native back end as simd_ops_probe_<level>() and the back end's vector width as
// simd_ops_probe_<level>_bytes().
#include "kernels/simd/native.h"
#include "tests/kernels/simd_ops_battery.h"

#if LPSTEREO_ISA_TU == 0
#error "simd_ops_probe.cpp is compiled per native ISA level only (the baseline is the emulated back end)"
#endif

#define LPSTEREO_PROBE_CONCAT_INNER(a, b) a##_##b
#define LPSTEREO_PROBE_CONCAT(a, b) LPSTEREO_PROBE_CONCAT_INNER(a, b)
#define LPSTEREO_PROBE_NAME LPSTEREO_PROBE_CONCAT(simd_ops_probe, LPSTEREO_ISA_SUFFIX)
#define LPSTEREO_PROBE_BYTES_NAME LPSTEREO_PROBE_CONCAT(LPSTEREO_PROBE_NAME, bytes)

namespace lpstereo::simd_probe {

void LPSTEREO_PROBE_NAME(const ProbeOp& op, const ProbeArgs& args) { run_probe<simd::Native>(op, args); }

int LPSTEREO_PROBE_BYTES_NAME() { return simd::Native::kBytes; }

}  // namespace lpstereo::simd_probe
