#!/usr/bin/env bash
# Runs the host build's kernel, scheduler and simulator tests on an emulated x86-64 CPU without AVX-512
# (qemu-x86_64 user mode, TCG, CPU model Haswell: AVX2 + BMI2, no AVX-512), to prove that a binary
# built on an AVX-512 machine still runs there and that run-time dispatch then picks avx2.
#
# QEMU raises SIGILL for any AVX-512 (EVEX) instruction, so AVX-512 code reached outside the
# dispatch (for example an inline function compiled at the avx512 level and merged by the linker
# into a call from another level) makes the run fail. The tests also check, with
# LPSTEREO_EXPECT_ACTIVE_ISA, that the active level is the expected one.
#
# Usage: scripts/test-without-avx512.sh BUILD_DIR        (e.g. build/release)
# Environment: LPSTEREO_QEMU_CPU (default Haswell), LPSTEREO_EXPECT_ACTIVE_ISA (default avx2).
set -euo pipefail

if [ "$#" -ne 1 ]; then
  echo "usage: $0 BUILD_DIR   (a host x86-64 build, e.g. build/release)" >&2
  exit 2
fi
build_dir=$1
cpu_model=${LPSTEREO_QEMU_CPU:-Haswell}
expected_isa=${LPSTEREO_EXPECT_ACTIVE_ISA:-avx2}

if ! command -v qemu-x86_64 >/dev/null 2>&1; then
  echo "test-without-avx512: qemu-x86_64 not found (Debian package qemu-user, see scripts/install-deps.sh)" >&2
  exit 2
fi

binaries=(tests/census_test tests/census_wta_disparity_test tests/median3x3_test tests/remap_bilinear_test tests/sgm_test
          tests/simd_ops_test tests/scheduler_test tests/simulator_test)
for binary in "${binaries[@]}"; do
  if [ ! -x "$build_dir/$binary" ]; then
    echo "test-without-avx512: $build_dir/$binary not found; build the host preset first" >&2
    exit 2
  fi
done

# The dispatch must pick the best level of the emulated CPU, not a level capped by the caller.
unset LPSTEREO_ISA

failed=0
for binary in "${binaries[@]}"; do
  echo "== $binary on qemu-x86_64 -cpu $cpu_model (expecting the $expected_isa level)"
  # QEMU warns once per CPUID feature of the model its TCG lacks (pcid, x2apic, tsx...); those are
  # not instruction-set features the binary uses, so the warnings are filtered out.
  set +e
  LPSTEREO_EXPECT_ACTIVE_ISA=$expected_isa qemu-x86_64 -cpu "$cpu_model" "$build_dir/$binary" --gtest_brief=1 \
    2> >(grep -v "TCG doesn't support requested feature" >&2)
  status=$?
  set -e
  if [ "$status" -ne 0 ]; then
    echo "test-without-avx512: $binary FAILED on -cpu $cpu_model (exit status $status)" >&2
    failed=1
  fi
done

# The dispatch check lives in simd_ops_test; make sure it really ran rather than being skipped.
set +e
dispatch_output=$(LPSTEREO_EXPECT_ACTIVE_ISA=$expected_isa qemu-x86_64 -cpu "$cpu_model" "$build_dir/tests/simd_ops_test" \
  --gtest_filter=SimdDispatch.ActiveLevelIsTheOneTheEnvironmentExpects 2>/dev/null)
set -e
echo "$dispatch_output" | grep "simd levels available here" || true
if ! echo "$dispatch_output" | grep -q "\[  PASSED  \] 1 test"; then
  echo "test-without-avx512: the dispatch check did not pass on -cpu $cpu_model" >&2
  failed=1
fi

if [ "$failed" -ne 0 ]; then
  exit 1
fi
echo "test-without-avx512: ${#binaries[@]} test programs pass on -cpu $cpu_model with the $expected_isa level active"
