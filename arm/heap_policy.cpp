#include "arm/heap_policy.h"

#include <cstdlib>  // any C library header: glibc's define __GLIBC__, tested below

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lpstereo::arm {

bool keep_freed_heap_memory() {
#if defined(__GLIBC__)
  // mallopt returns 1 on success, 0 when it refuses a value; the sanitizers' interceptors answer
  // every call with 0 or -1 (by version) and change nothing. The threshold first: with trimming
  // off and the threshold left dynamic, a freed block over 128 KiB would still be unmapped.
  constexpr int kMmapThresholdBytes = 32 << 20;  // glibc's largest on 64-bit targets: half a thread heap's 64 MiB
  if (mallopt(M_MMAP_THRESHOLD, kMmapThresholdBytes) != 1) return false;
  return mallopt(M_TRIM_THRESHOLD, -1) == 1;  // -1: the largest size_t, never trim
#else
  return false;
#endif
}

}  // namespace lpstereo::arm
