// Frames in flight for `lpstereo run`: N disparity engines ("lanes"), each on its own pair, so that a
// recording streams on every core. One engine's single-pass 4-path SGM carries row state down the
// frame and runs on one worker (arm/scheduler.h), and reading a pair (PNG decoding) runs before it:
// with one pair at a time a second core idles for most of a frame. Pairs go to the lanes in turn and
// come back in the order they went in; each lane's engine is the one engine's code on fewer workers,
// so the maps are the same bits whatever the number of lanes.
#pragma once

#include <chrono>
#include <deque>
#include <future>
#include <memory>
#include <optional>
#include <vector>

#include "arm/disparity_engine.h"
#include "dag/plane.h"
#include "io/camera/stereo_source.h"

namespace lpstereo::tools {

struct InFlightPair {
  io::StereoFrame pair;                               // as read
  std::optional<Plane> rectified_left, rectified_right;  // rectified views owned (more than one lane)
  // Or the rectifier's own planes, valid until it rectifies the next pair: one lane completes each
  // pair before the next is read, so nothing is copied.
  const Plane* borrowed_left = nullptr;
  const Plane* borrowed_right = nullptr;
  std::chrono::steady_clock::time_point started;        // when the pair was read
  const Plane* disparity = nullptr;  // the lane's map: valid until the next submit() or drain()
  const Plane& left() const { return borrowed_left ? *borrowed_left : rectified_left ? *rectified_left : pair.left; }
  const Plane& right() const { return borrowed_right ? *borrowed_right : rectified_right ? *rectified_right : pair.right; }
};

class DisparityLanes {
 public:
  // `lanes` engines of `workers_per_lane` worker threads each (0 = one per hardware thread).
  DisparityLanes(int width, int height, const arm::DisparityParameters& parameters, int lanes, int workers_per_lane);
  int lanes() const { return static_cast<int>(engines_.size()); }

  // Hands the pair to the next lane. Returns the oldest pair in flight with its map once `lanes`
  // pairs are (so at most that many are at once); with one lane, this pair, computed here.
  // Rethrows what the engine threw.
  std::optional<InFlightPair> submit(InFlightPair pair);
  // The oldest pair still in flight with its map (waiting for it), or nothing when none is.
  std::optional<InFlightPair> drain();

 private:
  InFlightPair compute(int lane, InFlightPair pair);

  std::vector<std::unique_ptr<arm::DisparityEngine>> engines_;
  std::deque<std::future<InFlightPair>> in_flight_;  // oldest first
  int next_lane_ = 0;
};

// The lanes `lpstereo run --in-flight` asks for: `requested` when positive; 0 (automatic): 2 for a
// recording with at least 2 worker threads and an engine whose SGM runs on one worker (4 paths, or
// the census matcher alone), else 1. 8 paths already keep every worker busy (the checkpoint passes
// side by side, then the bands in parallel): a second engine there gains 10 % for 13 % more memory
// (3840x1728 x 128: 1.6 against 1.5 pairs a second, 677 against 600 MB). A live camera keeps one
// pair at a time, for its latency.
int resolved_lanes(int requested, bool live, int worker_threads, const arm::DisparityParameters& parameters);

}  // namespace lpstereo::tools
