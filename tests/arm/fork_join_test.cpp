// arm/fork_join.h: fork_join runs every share exactly once, share 0 on the calling thread and the
// others each on a thread of its own; for_each_dealt visits every item exactly once over the shares,
// in blocks dealt round robin, for item counts around the block size and share counts that do and
// do not divide them.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "arm/fork_join.h"

namespace lpstereo::arm {
namespace {

TEST(ForkJoin, RunsEveryShareOnceShareZeroOnTheCallingThread) {
  for (int thread_count : {0, 1, 2, 5}) {
    std::vector<std::atomic<int>> calls(5);
    std::mutex mutex;
    std::set<std::thread::id> threads;
    std::thread::id share_zero_thread;
    fork_join(thread_count, [&](int share) {
      ++calls[static_cast<size_t>(share)];
      std::lock_guard<std::mutex> lock(mutex);
      threads.insert(std::this_thread::get_id());
      if (share == 0) share_zero_thread = std::this_thread::get_id();
    });
    const int shares = thread_count < 1 ? 1 : thread_count;
    for (int share = 0; share < 5; ++share) EXPECT_EQ(calls[static_cast<size_t>(share)], share < shares ? 1 : 0) << thread_count;
    EXPECT_EQ(share_zero_thread, std::this_thread::get_id());
    EXPECT_EQ(threads.size(), static_cast<size_t>(shares));
  }
}

TEST(ForkJoin, DealtItemsAreVisitedOnceInRoundRobinBlocks) {
  for (size_t items : {0u, 1u, 7u, 255u, 256u, 257u, 1000u}) {
    for (size_t block : {1u, 3u, 256u}) {
      for (int shares : {1, 2, 3, 5}) {
        std::vector<int> visits(items, 0), share_of(items, -1);
        for (int share = 0; share < shares; ++share)
          for_each_dealt(items, block, share, shares, [&](size_t item) {
            ++visits[item];
            share_of[item] = share;
          });
        for (size_t item = 0; item < items; ++item) {
          ASSERT_EQ(visits[item], 1) << items << " items, block " << block << ", " << shares << " shares, item " << item;
          EXPECT_EQ(share_of[item], static_cast<int>((item / block) % static_cast<size_t>(shares)));
        }
      }
    }
  }
}

}  // namespace
}  // namespace lpstereo::arm
