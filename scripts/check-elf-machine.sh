#!/usr/bin/env bash
# Checks that each file is an ELF executable for the given machine (aarch64 or x86_64), reading the
# ELF header itself (e_ident and e_machine), so no `file` package is needed.
# Usage: check-elf-machine.sh aarch64|x86_64 FILE...
set -euo pipefail
machine=${1:?usage: check-elf-machine.sh aarch64|x86_64 FILE...}
shift
case "$machine" in
  aarch64) expected=183 ;;  # EM_AARCH64
  x86_64) expected=62 ;;    # EM_X86_64
  *) echo "check-elf-machine: unknown machine '$machine' (aarch64 or x86_64)" >&2; exit 2 ;;
esac
[ "$#" -gt 0 ] || { echo "check-elf-machine: no files given" >&2; exit 2; }
status=0
for file in "$@"; do
  magic=$(od -An -c -N4 "$file" | tr -d ' ')
  if [ "$magic" != "177ELF" ]; then
    echo "check-elf-machine: $file: not an ELF file"
    status=1
    continue
  fi
  # e_machine: 2 bytes at offset 18, little-endian (EI_DATA = 1 on both machines).
  actual=$(od -An -tu2 -j18 -N2 --endian=little "$file" | tr -d ' ')
  if [ "$actual" != "$expected" ]; then
    echo "check-elf-machine: $file: e_machine $actual, expected $expected ($machine)"
    status=1
  fi
done
[ "$status" -eq 0 ] && echo "check-elf-machine: $# files are $machine ELF"
exit $status
