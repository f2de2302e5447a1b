#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run calls this): installs the Debian packages, then
#   1. release build, every test;
#   2. debug-asan build (AddressSanitizer + UndefinedBehaviorSanitizer), every test;
#   3. the 4K budget: every graph under graphs/ profiled at 3840x1728 on cv1-class with --enforce,
#      its Markdown summary printed (graphs marked "budget": {"enforce": false} are reported only).
# Stop at the first failure. LPSTEREO_CHECK_SKIP_ASAN=1 skips stage 2 for a quick local run.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

./scripts/install-deps.sh

echo "== release: build and test"
cmake --preset release >/dev/null
cmake --build --preset release -j "$jobs"
ctest --preset release

if [ "${LPSTEREO_CHECK_SKIP_ASAN:-0}" != "1" ]; then
  echo "== debug-asan: build and test"
  cmake --preset debug-asan >/dev/null
  cmake --build --preset debug-asan -j "$jobs"
  ctest --preset debug-asan
fi

echo "== 4K budget on cv1-class: every graph at 3840x1728, --enforce"
./scripts/profile-graphs.sh build/release/tools/lpstereo
