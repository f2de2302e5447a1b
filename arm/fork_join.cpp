#include "arm/fork_join.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace lpstereo::arm {
namespace {

// The process's helper threads: helper k (k >= 1) runs share k of the job in hand. One caller at a
// time owns them (the busy flag: a caller that finds it set, another thread or a share of its own
// call that forks again, does not wait).
class HelperTeam {
 public:
  ~HelperTeam() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    job_posted_.notify_all();
    for (std::thread& helper : helpers_) helper.join();
  }

  // False when another caller owns the team (nothing run).
  bool try_run(int thread_count, void (*call)(const void*, int), const void* context) {
    if (busy_.exchange(true, std::memory_order_acquire)) return false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      while (static_cast<int>(helpers_.size()) < thread_count - 1) {
        // A new helper starts from the generation before this job's, so it takes this job.
        const int share = static_cast<int>(helpers_.size()) + 1;
        const uint64_t seen = generation_;
        helpers_.emplace_back([this, share, seen] { serve(share, seen); });
      }
      call_ = call;
      context_ = context;
      thread_count_ = thread_count;
      shares_left_ = thread_count - 1;
      error_ = nullptr;
      ++generation_;
    }
    job_posted_.notify_all();
    std::exception_ptr error;
    try {
      call(context, 0);
    } catch (...) {
      error = std::current_exception();
    }
    std::unique_lock<std::mutex> lock(mutex_);
    job_done_.wait(lock, [this] { return shares_left_ == 0; });
    if (!error) error = error_;
    call_ = nullptr;
    context_ = nullptr;
    lock.unlock();
    busy_.store(false, std::memory_order_release);
    if (error) std::rethrow_exception(error);
    return true;
  }

 private:
  void serve(int share, uint64_t seen) {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      job_posted_.wait(lock, [&] { return stopping_ || generation_ != seen; });
      if (stopping_) return;
      seen = generation_;
      if (share >= thread_count_) continue;  // a job with fewer shares than helpers
      void (*const call)(const void*, int) = call_;
      const void* const context = context_;
      lock.unlock();
      std::exception_ptr error;
      try {
        call(context, share);
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      if (error && !error_) error_ = error;
      if (--shares_left_ == 0) job_done_.notify_one();
    }
  }

  std::atomic<bool> busy_{false};
  std::mutex mutex_;  // guards everything below
  std::condition_variable job_posted_, job_done_;
  std::vector<std::thread> helpers_;
  void (*call_)(const void*, int) = nullptr;
  const void* context_ = nullptr;
  int thread_count_ = 0;
  int shares_left_ = 0;
  uint64_t generation_ = 0;
  bool stopping_ = false;
  std::exception_ptr error_;
};

HelperTeam& helper_team() {
  static HelperTeam team;
  return team;
}

// A thread of its own per share, for a call made while the team serves another.
void run_on_new_threads(int thread_count, void (*call)(const void*, int), const void* context) {
  std::vector<std::exception_ptr> errors(static_cast<size_t>(thread_count));
  std::vector<std::thread> workers;
  workers.reserve(static_cast<size_t>(thread_count) - 1);
  for (int share = 1; share < thread_count; ++share) {
    workers.emplace_back([&errors, call, context, share] {
      try {
        call(context, share);
      } catch (...) {
        errors[static_cast<size_t>(share)] = std::current_exception();
      }
    });
  }
  try {
    call(context, 0);
  } catch (...) {
    errors[0] = std::current_exception();
  }
  for (std::thread& worker : workers) worker.join();
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

}  // namespace

std::vector<int> balanced_row_bands(const std::vector<int64_t>& weight_before_row, int band_count) {
  const int rows = static_cast<int>(weight_before_row.size()) - 1;
  band_count = std::max(1, band_count);
  std::vector<int> first_row(static_cast<size_t>(band_count) + 1, std::max(rows, 0));
  first_row[0] = 0;
  if (rows <= 0) return first_row;
  const int64_t total = weight_before_row.back();
  for (int band = 1; band < band_count; ++band) {
    const int64_t target = total * band / band_count;
    const int row = static_cast<int>(std::lower_bound(weight_before_row.begin(), weight_before_row.end(), target) -
                                     weight_before_row.begin());
    first_row[static_cast<size_t>(band)] = std::clamp(row, first_row[static_cast<size_t>(band) - 1], rows);
  }
  return first_row;
}

void run_shares(int thread_count, void (*call)(const void* context, int share), const void* context) {
  if (thread_count <= 1) {
    call(context, 0);
    return;
  }
  if (!helper_team().try_run(thread_count, call, context)) run_on_new_threads(thread_count, call, context);
}

}  // namespace lpstereo::arm
