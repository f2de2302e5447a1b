// arm/fork_join.h: fork_join runs every share exactly once, share 0 on the calling thread and the
// others each on a thread of its own; the helper threads persist from call to call; a call made
// while they serve another (a share that forks again, a second caller thread) still runs every
// share; a share's exception reaches the caller and leaves the helpers usable; for_each_dealt
// visits every item exactly once over the shares, in blocks dealt round robin, for item counts
// around the block size and share counts that do and do not divide them.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <stdexcept>
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

// Calls of this thread's shares so far: a helper that persists counts up, a new thread starts at 0.
thread_local int shares_run_on_this_thread = 0;

TEST(ForkJoin, HelperThreadsPersistFromCallToCall) {
  std::vector<int> share_one_counts;
  for (int call = 0; call < 4; ++call) {
    int count = 0;
    fork_join(2, [&](int share) {
      ++shares_run_on_this_thread;
      if (share == 1) count = shares_run_on_this_thread;
    });
    share_one_counts.push_back(count);
  }
  // Each call's share 1 ran on a thread that had run one more share than the call before.
  for (size_t call = 1; call < share_one_counts.size(); ++call) EXPECT_EQ(share_one_counts[call], share_one_counts[call - 1] + 1);
}

TEST(ForkJoin, FewerSharesThanHelpersRunOnlyTheirShares) {
  for (int thread_count : {5, 2, 4, 3}) {
    std::vector<std::atomic<int>> calls(5);
    fork_join(thread_count, [&](int share) { ++calls[static_cast<size_t>(share)]; });
    for (int share = 0; share < 5; ++share) EXPECT_EQ(calls[static_cast<size_t>(share)], share < thread_count ? 1 : 0) << thread_count;
  }
}

TEST(ForkJoin, ASharesOwnForkAndASecondCallerRunEveryShare) {
  std::atomic<int> inner_calls{0};
  fork_join(2, [&](int) { fork_join(3, [&](int) { ++inner_calls; }); });
  EXPECT_EQ(inner_calls, 6);
  std::atomic<int> calls{0};
  std::vector<std::thread> callers;
  for (int caller = 0; caller < 3; ++caller) {
    callers.emplace_back([&] {
      for (int repeat = 0; repeat < 50; ++repeat) fork_join(2, [&](int) { ++calls; });
    });
  }
  for (std::thread& caller : callers) caller.join();
  EXPECT_EQ(calls, 3 * 50 * 2);
}

TEST(ForkJoin, AShareExceptionReachesTheCallerAndTheHelpersGoOn) {
  for (int failing_share : {0, 1}) {
    std::atomic<int> calls{0};
    EXPECT_THROW(fork_join(3,
                           [&](int share) {
                             ++calls;
                             if (share == failing_share) throw std::runtime_error("share failed");
                           }),
                 std::runtime_error);
    EXPECT_EQ(calls, 3) << "every share runs even when one throws";
  }
  std::atomic<int> calls{0};
  fork_join(3, [&](int) { ++calls; });
  EXPECT_EQ(calls, 3);
}

// Rows' weights (per row) -> the prefix sums balanced_row_bands takes.
std::vector<int64_t> weight_before_row(const std::vector<int64_t>& row_weights) {
  std::vector<int64_t> before(row_weights.size() + 1, 0);
  for (size_t row = 0; row < row_weights.size(); ++row) before[row + 1] = before[row] + row_weights[row];
  return before;
}

TEST(BalancedRowBands, CutsWhereTheWeightReachesEachShare) {
  // 10 rows, the weight in the bottom half (a road scene's sky on top): halves of the weight, not the rows.
  const std::vector<int> two = balanced_row_bands(weight_before_row({0, 0, 0, 0, 0, 1, 1, 1, 1, 1}), 2);
  EXPECT_EQ(two, (std::vector<int>{0, 7, 10}));  // the first band ends where 5 / 2 = 2 of the weight lies before the row
  const std::vector<int> even = balanced_row_bands(weight_before_row(std::vector<int64_t>(12, 3)), 3);
  EXPECT_EQ(even, (std::vector<int>{0, 4, 8, 12}));
  // Every boundary in order, the first 0 and the last the row count, for any weights.
  for (int bands : {1, 2, 3, 7}) {
    for (const std::vector<int64_t>& weights :
         {std::vector<int64_t>{}, std::vector<int64_t>(5, 0), std::vector<int64_t>{0, 0, 100, 0}, std::vector<int64_t>{1, 2, 3, 4, 5, 6}}) {
      const std::vector<int> cut = balanced_row_bands(weight_before_row(weights), bands);
      ASSERT_EQ(cut.size(), static_cast<size_t>(bands) + 1);
      EXPECT_EQ(cut.front(), 0);
      EXPECT_EQ(cut.back(), static_cast<int>(weights.size()));
      for (size_t b = 1; b < cut.size(); ++b) EXPECT_LE(cut[b - 1], cut[b]);
    }
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
