// Fork-join on the host for an ARM task whose frame work splits into independent shares (the
// grids' evidence, the obstacle candidates' image bands, the stixel clusters' descriptions):
// share 0 runs on the calling thread, shares 1 .. thread_count - 1 on threads of their own, and
// all are joined before it returns. Each share writes only its own outputs (and keeps its counters
// in locals until its end: counters of two threads on one cache line, incremented per item, cost
// as much as the second thread saves), so a result never depends on scheduling.
#pragma once

#include <cstddef>
#include <thread>
#include <vector>

namespace lpstereo::arm {

// Calls work(share) for every share in [0, thread_count); thread_count <= 1 runs share 0 alone.
template <typename Work>
void fork_join(int thread_count, const Work& work) {
  std::vector<std::thread> workers;
  for (int share = 1; share < thread_count; ++share) workers.emplace_back([&work, share] { work(share); });
  work(0);
  for (std::thread& worker : workers) worker.join();
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

}  // namespace lpstereo::arm
