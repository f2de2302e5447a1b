// arm/heap_policy.h: with glibc's malloc, keep_freed_heap_memory() reports that it took effect, and
// then an 8 MiB block comes from the heap rather than a mapping of its own and stays in the process
// once freed, from the main thread and from another thread's arena. (Without the policy glibc maps
// the first such block on its own and unmaps it on free: the main thread's two checks fail then,
// checked.) Under a sanitizer, whose allocator replaces glibc's, it reports that it did not.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <thread>

#include "arm/heap_policy.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lpstereo::arm {
namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)

TEST(HeapPolicy, ReportsThatASanitizersAllocatorDidNotTakeIt) { EXPECT_FALSE(keep_freed_heap_memory()); }

#elif defined(__GLIBC__)

constexpr size_t kBlockBytes = size_t{8} << 20;

// Allocates, touches and frees one block; returns false when the allocation failed. Records the
// mapped blocks (hblks) while it was held and the heap's free bytes (fordblks) after it was freed.
bool allocate_touch_free(size_t* mapped_blocks_while_held, size_t* free_heap_bytes_after) {
  char* block = static_cast<char*>(std::malloc(kBlockBytes));
  if (block == nullptr) return false;
  std::memset(block, 1, kBlockBytes);
  *mapped_blocks_while_held = mallinfo2().hblks;
  std::free(block);
  *free_heap_bytes_after = mallinfo2().fordblks;
  return true;
}

TEST(HeapPolicy, FreedBlocksStayInTheProcessFromAnyThread) {
  const size_t mapped_before = mallinfo2().hblks;
  ASSERT_TRUE(keep_freed_heap_memory());
  size_t mapped_while_held = 0, free_after = 0;
  ASSERT_TRUE(allocate_touch_free(&mapped_while_held, &free_after));
  EXPECT_EQ(mapped_while_held, mapped_before) << "the 8 MiB block was mapped on its own";
  EXPECT_GE(free_after, kBlockBytes) << "the freed 8 MiB went back to the kernel";

  // Another thread allocates from an arena of its own, whose heap trims by the same threshold.
  bool allocated = false;
  std::thread other([&] { allocated = allocate_touch_free(&mapped_while_held, &free_after); });
  other.join();
  ASSERT_TRUE(allocated);
  EXPECT_EQ(mapped_while_held, mapped_before) << "the other thread's 8 MiB block was mapped on its own";
  EXPECT_GE(free_after, kBlockBytes) << "the other thread's freed 8 MiB went back to the kernel";
}

#else

TEST(HeapPolicy, ReportsThatAnotherCLibraryDidNotTakeIt) { EXPECT_FALSE(keep_freed_heap_memory()); }

#endif

}  // namespace
}  // namespace lpstereo::arm
