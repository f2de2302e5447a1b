// Fork-join on the host for an ARM task whose frame work splits into independent shares (the
// grids' evidence, the obstacle candidates' image bands, the stixel clusters' descriptions, the
// speckle filter's bands): share 0 runs on the calling thread, shares 1 .. thread_count - 1 on the
// process's helper threads, and all are joined before it returns. Each share writes only its own
// outputs (and keeps its counters in locals until its end: counters of two threads on one cache
// line, incremented per item, cost as much as the second thread saves), so a result never depends
// on scheduling.
//
// The helpers are persistent (arm/fork_join.cpp): a thread started per call cost 45 us on one
// 2-core VM and a median of 83 us (90th percentile 3.8 ms, the new thread waiting for a core) on
// another under load, against 24 us (29 us) for waking a waiting helper, and a frame of the
// obstacle chain forks about seven times. A call made while the helpers serve another (a second
// caller thread, or a share that forks again) starts threads of its own, as every call did before:
// no call waits for another. An exception thrown by a share is rethrown to the caller after every
// share has finished (when several throw, share 0's if it threw, else one of the others').
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lpstereo::arm {

// Calls call(context, share) for every share in [0, thread_count) as fork_join describes; thread_count
// <= 1 runs share 0 alone on the calling thread.
void run_shares(int thread_count, void (*call)(const void* context, int share), const void* context);

// Calls work(share) for every share in [0, thread_count); thread_count <= 1 runs share 0 alone.
template <typename Work>
void fork_join(int thread_count, const Work& work) {
  if (thread_count <= 1) {
    work(0);
    return;
  }
  run_shares(
      thread_count, [](const void* context, int share) { (*static_cast<const Work*>(context))(share); }, &work);
}

// The items of share `share` of `share_count` when items are dealt in blocks of `block` (block b to
// share b mod share_count): work of uneven items spreads evenly where contiguous halves would not.
template <typename Visit>
void for_each_dealt(size_t item_count, size_t block, int share, int share_count, const Visit& visit) {
  const size_t stride = block * static_cast<size_t>(share_count);
  for (size_t first = block * static_cast<size_t>(share); first < item_count; first += stride) {
    const size_t end = first + block < item_count ? first + block : item_count;
    for (size_t item = first; item < end; ++item) visit(item);
  }
}

// Contiguous bands of rows with about equal shares of a per-row weight (the work a band's thread
// will do: a road scene's top rows are sky, with no disparity, and equal row bands left one thread
// with almost every point). weight_before_row[r] is the weight of rows [0, r), so its size is the
// row count + 1. Returns the band_count + 1 boundaries: band b is rows [result[b], result[b + 1]),
// starting at the first row whose weight before it reaches b / band_count of the total; bands may
// be empty when the weight sits in few rows.
std::vector<int> balanced_row_bands(const std::vector<int64_t>& weight_before_row, int band_count);

}  // namespace lpstereo::arm
