#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls this): installs the Debian packages, then
#   1. release build, every test (with the real-driver tests in a VM: vivid, vimc; their logs printed);
#   2. debug-asan build (AddressSanitizer + UndefinedBehaviorSanitizer), every test. Its libraries
#      are shared objects and it compiles at -O1 (CMakePresets.json): linked statically, every test
#      program carried every kernel (100-230 MB each; stop 31's CI ran out of disk), and at -O0 the
#      keyframe localizer test alone ran 960 s (stop 32's CI ran out of time; 66 s at -O1). Measured on
#      the cold 2-core machine: build 52 min, 1.6 GB; ctest 690 s, the slowest test 110 s;
#   3. the release tests that exercise every kernel, run on an emulated CPU without AVX-512
#      (qemu-x86_64 -cpu Haswell): the binary built here must run there, dispatching to AVX2;
#   4. aarch64 cross-build (NEON) against an arm64 sysroot of Debian's packages (build/arm64-sysroot,
#      assembled by scripts/make-arm64-sysroot.sh at configure time: ~105 MB downloaded, 260 MB
#      unpacked), the lpstereo command included; every test through qemu-aarch64, then the aarch64
#      lpstereo under qemu on a rendered pair and sequence, its outputs compared byte for byte with
#      the release build's (scripts/compare-aarch64-lpstereo.sh);
#   5. the 4K budget: every graph under graphs/ profiled at 3840x1728 on cv1-class with --enforce,
#      its Markdown summary printed (graphs marked "budget": {"enforce": false} are reported only).
# Stops at the first failure. For a quick local run, LPSTEREO_CHECK_SKIP_ASAN=1 and
# LPSTEREO_CHECK_SKIP_AARCH64=1 skip stages 2 and 4.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

./scripts/install-deps.sh

start_seconds=$SECONDS
# Each stage's header carries the seconds since the start, so a slow CI run shows where it went.
stage() { echo "== [$((SECONDS - start_seconds)) s] $*"; }
stage "release: build and test"
cmake --preset release >/dev/null
cmake --build --preset release -j "$jobs"
stage "release: ctest"
ctest --preset release
stage "real-driver tests in the VM: their logs"
./scripts/print-vm-test-logs.sh build/release

if [ "${LPSTEREO_CHECK_SKIP_ASAN:-0}" != "1" ]; then
  stage "debug-asan: build and test"
  cmake --preset debug-asan >/dev/null
  cmake --build --preset debug-asan -j "$jobs"
  stage "debug-asan: ctest"
  ctest --preset debug-asan
fi

stage "release binaries on a CPU without AVX-512 (qemu-x86_64 -cpu Haswell)"
./scripts/test-without-avx512.sh build/release

if [ "${LPSTEREO_CHECK_SKIP_AARCH64:-0}" != "1" ]; then
  stage "aarch64 (NEON): cross-build, test through qemu-aarch64"
  cmake --preset aarch64 >/dev/null
  cmake --build --preset aarch64 -j "$jobs"
  stage "aarch64: ctest"
  ctest --preset aarch64
  stage "aarch64: lpstereo under qemu equals the release build's, byte for byte"
  ./scripts/compare-aarch64-lpstereo.sh build/release/tools/lpstereo build/aarch64/tools/lpstereo \
    "${LPSTEREO_AARCH64_SYSROOT:-build/arm64-sysroot}"
fi

stage "4K budget on cv1-class: every graph at 3840x1728, --enforce"
./scripts/profile-graphs.sh build/release/tools/lpstereo
echo "check: all stages passed in $((SECONDS - start_seconds)) s"
