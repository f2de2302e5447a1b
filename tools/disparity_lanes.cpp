#include "tools/disparity_lanes.h"

#include <utility>

#include "arm/scheduler.h"

namespace lpstereo::tools {

DisparityLanes::DisparityLanes(int width, int height, const arm::DisparityParameters& parameters, int lanes, int workers_per_lane) {
  for (int lane = 0; lane < lanes; ++lane) {
    engines_.push_back(std::make_unique<arm::DisparityEngine>(width, height, parameters, MemoryBudget{}, workers_per_lane));
  }
}

InFlightPair DisparityLanes::compute(int lane, InFlightPair pair) {
  pair.disparity = &engines_[static_cast<size_t>(lane)]->compute(pair.left(), pair.right());
  return pair;
}

std::optional<InFlightPair> DisparityLanes::submit(InFlightPair pair) {
  const int lane = next_lane_;
  next_lane_ = (next_lane_ + 1) % lanes();
  if (lanes() == 1) return compute(lane, std::move(pair));
  // The lane's previous pair was handed back before this one came (at most `lanes` in flight, oldest
  // out first), so its engine is free and nothing reads its map any more.
  in_flight_.push_back(std::async(std::launch::async, [this, lane, moved = std::move(pair)]() mutable {
    return compute(lane, std::move(moved));
  }));
  if (static_cast<int>(in_flight_.size()) < lanes()) return std::nullopt;
  return drain();
}

std::optional<InFlightPair> DisparityLanes::drain() {
  if (in_flight_.empty()) return std::nullopt;
  std::future<InFlightPair> oldest = std::move(in_flight_.front());
  in_flight_.pop_front();
  return oldest.get();
}

int resolved_lanes(int requested, bool live, int worker_threads, const arm::DisparityParameters& parameters) {
  if (requested > 0) return requested;
  return !live && parameters.paths != 8 && arm::resolved_worker_threads(worker_threads) >= 2 ? 2 : 1;
}

}  // namespace lpstereo::tools
