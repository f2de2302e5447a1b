#!/usr/bin/env bash
# Checks that code compiled at one ISA level cannot be picked by the linker for a call from another
# level (kernels/simd/native.h): every symbol a per-level kernel object exports weakly (inline
# functions, template instantiations) must belong to that level, i.e. name its back end type
# (lpstereo::simd::Avx512, ...). A weak std::string or JSON helper compiled with -mavx512bw would
# otherwise be merged with the baseline copy and crash a CPU without AVX-512.
# Usage: check-isa-objects.sh LEVEL_TYPE OBJECT...   (e.g. Avx512 build/.../census5x5.cpp.o)
set -euo pipefail
level_type=${1:?usage: check-isa-objects.sh LEVEL_TYPE OBJECT...}
shift
nm_tool=${NM:-nm}
status=0
checked=0
for object in "$@"; do
  checked=$((checked + 1))
  # Weak (W, V) and unique-global (u) definitions.
  while IFS= read -r symbol; do
    case "$symbol" in
      *"lpstereo::simd::${level_type}"*) ;;
      *)
        echo "check-isa-objects: $object: weak symbol outside the ${level_type} level: $symbol"
        status=1
        ;;
    esac
  done < <("$nm_tool" -C --defined-only "$object" | awk '$2 == "W" || $2 == "V" || $2 == "u" { $1 = ""; $2 = ""; sub(/^  /, ""); print }')
done
if [ "$checked" -eq 0 ]; then
  echo "check-isa-objects: no objects given" >&2
  exit 2
fi
[ "$status" -eq 0 ] && echo "check-isa-objects: $checked ${level_type} objects export only ${level_type} symbols"
exit $status
