#!/usr/bin/env bash
# The aarch64 lpstereo command, run under qemu-aarch64 on the arm64 sysroot, must write exactly the
# bytes the x86-64 build writes for the same commands on the same pair (scripts/check.sh, stage 4).
# The pair is rendered by the x86 build (`lpstereo synth`, 320x240 with sensor noise), so nothing
# outside the repository is read; 64 disparities keep the emulated run to seconds. Compared:
#   - lpstereo disparity LEFT RIGHT -o OUT.png (KITTI 16-bit PNG: SGM, sub-pixel, LR check, median,
#     speckle filter, and the PNG encoder);
#   - lpstereo run --source files:... --calib calib.yaml --graph obstacles --out DIR on a rendered
#     two-frame sequence with moving objects (recording source, rectification, the obstacle graph,
#     its tracker and JSON output).
# Usage: compare-aarch64-lpstereo.sh X86_LPSTEREO AARCH64_LPSTEREO SYSROOT
set -euo pipefail
x86=${1:?usage: compare-aarch64-lpstereo.sh X86_LPSTEREO AARCH64_LPSTEREO SYSROOT}
arm=${2:?usage: compare-aarch64-lpstereo.sh X86_LPSTEREO AARCH64_LPSTEREO SYSROOT}
sysroot=${3:?usage: compare-aarch64-lpstereo.sh X86_LPSTEREO AARCH64_LPSTEREO SYSROOT}
here=$(cd "$(dirname "$0")" && pwd)
"$here/check-elf-machine.sh" x86_64 "$x86"
"$here/check-elf-machine.sh" aarch64 "$arm"
[ -f "$sysroot/lib/ld-linux-aarch64.so.1" ] ||
  { echo "compare-aarch64-lpstereo: $sysroot has no lib/ld-linux-aarch64.so.1: not an arm64 sysroot (scripts/make-arm64-sysroot.sh)" >&2; exit 1; }
qemu=(qemu-aarch64 -L "$sysroot")

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# quiet NAME COMMAND...: runs the command with its output kept aside, printed only when it fails.
quiet() {
  local name=$1 code=0
  shift
  "$@" >"$work/output.txt" 2>&1 || code=$?
  if [ "$code" -ne 0 ]; then
    echo "compare-aarch64-lpstereo: $name exited $code, expected 0; its output:"
    cat "$work/output.txt"
    exit 1
  fi
}
quiet "x86 lpstereo synth" "$x86" synth -o "$work/pair" --width 320 --height 240 --noise 2
quiet "x86 lpstereo synth --sequence" "$x86" synth -o "$work/sequence" --width 320 --height 240 --noise 2 --sequence urban --frames 2

status=0
# compare NAME X86_OUTPUT AARCH64_OUTPUT: files, or folders compared file by file.
compare() {
  if diff -r "$2" "$3" >/dev/null; then
    echo "compare-aarch64-lpstereo: $1: aarch64 output equals x86-64's ($(find "$2" -type f | wc -l) files)"
  else
    echo "compare-aarch64-lpstereo: $1: aarch64 output differs from x86-64's:"
    diff -rq "$2" "$3" | head -n 20 || true
    status=1
  fi
}

disparity=(disparity "$work/pair/left.png" "$work/pair/right.png" --num-disp 64)
quiet "x86 lpstereo disparity" "$x86" "${disparity[@]}" -o "$work/x86.png"
start=$SECONDS
quiet "aarch64 lpstereo disparity under qemu" "${qemu[@]}" "$arm" "${disparity[@]}" -o "$work/aarch64.png"
echo "compare-aarch64-lpstereo: lpstereo disparity under qemu: $((SECONDS - start)) s"
compare "lpstereo disparity (KITTI PNG)" "$work/x86.png" "$work/aarch64.png"

run=(run --source "files:$work/sequence/left/%06d.png,$work/sequence/right/%06d.png" --calib "$work/sequence/calib.yaml"
     --graph obstacles --num-disp 64 --target none)
quiet "x86 lpstereo run" "$x86" "${run[@]}" --out "$work/x86-run"
start=$SECONDS
quiet "aarch64 lpstereo run under qemu" "${qemu[@]}" "$arm" "${run[@]}" --out "$work/aarch64-run"
echo "compare-aarch64-lpstereo: lpstereo run under qemu: $((SECONDS - start)) s"
compare "lpstereo run --graph obstacles (disparity PNGs, colour PNGs, obstacles.jsonl)" "$work/x86-run" "$work/aarch64-run"
exit $status
