#!/usr/bin/env bash
# Prints the console logs of the real-driver tests (ctest names Vm.*: vivid, vimc) from the last
# ctest run of a build, so a CI log shows the driver names, the formats negotiated, the frames
# captured and the disconnects handled even when the tests pass (ctest prints output on failure only).
#
# Usage: scripts/print-vm-test-logs.sh BUILD_DIR      (e.g. build/release)
set -euo pipefail
log="${1:?usage: print-vm-test-logs.sh BUILD_DIR}/Testing/Temporary/LastTest.log"
[ -f "$log" ] || { echo "print-vm-test-logs: no $log (run ctest first)" >&2; exit 2; }
if ! grep -q "Testing: Vm\." "$log"; then
  echo "print-vm-test-logs: no Vm.* test in the last run (not registered: see cmake's 'VM tests' line)"
  exit 0
fi
# Each test's section runs from "Testing: NAME" to "<end of output>"; the firmware's banner lines go.
awk '/Testing: Vm\./ { printing = 1 } printing { print } /<end of output>/ { printing = 0 }' "$log" |
  grep -v -E '^(SeaBIOS|iPXE|Press Ctrl-B|Booting from ROM|$)'
