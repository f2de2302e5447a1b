// The heap policy a benchmark runs under, applied and described in one call: the benchmarks time
// frame loops as the lpstereo command runs them, which keeps freed heap memory in the process
// (arm/heap_policy.h). Without it a freed block of 128 KiB or more goes back to the kernel and the
// next frame faults it in again, which the timings would then include.
#pragma once

#include <string>

#include "arm/heap_policy.h"

namespace lpstereo::bench {

// Calls arm::keep_freed_heap_memory() and returns the setting line the benchmark prints.
inline std::string keep_freed_heap_memory_setting() {
  return arm::keep_freed_heap_memory()
             ? "freed blocks under 32 MiB kept in the process (arm::keep_freed_heap_memory, as the lpstereo command)"
             : "the C library's default (arm::keep_freed_heap_memory did not take: not glibc's malloc)";
}

}  // namespace lpstereo::bench
