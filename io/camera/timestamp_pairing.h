// Pairs the frames of two free-running cameras by capture time. Two V4L2 devices that are not
// hardware-synchronised deliver frames at the same nominal rate with an arbitrary phase between
// them, occasional drops on either side and some jitter; a pair is one frame of each side whose
// timestamps differ by at most a tolerance (by default half the frame period, so that at most one
// frame of the other side can qualify).
//
// The rule (greedy, no waiting for future frames): look at the oldest queued frame of each side.
//   - they differ by at most the tolerance: a pair, unless the other side's second frame is even
//     closer to this side's oldest (then the other side's oldest is the one left unpaired: a
//     frame that only jitter put within the tolerance);
//   - otherwise the older of the two can never be paired (every later frame of the other side is
//     later still): it is discarded and counted unpaired on its side.
// Each side queues at most `max_queued_per_side` frames; when a side stalls, the other side's
// oldest frames are discarded (and counted unpaired) so memory and latency stay bounded.
//
// Sequence numbers: a gap between two consecutive frames pushed on a side is frames the driver
// dropped before the application saw them (counted as driver drops on that side). A sequence that
// does not increase (a restarted stream) counts no drop.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

namespace lpstereo::io {

enum class PairingSide { left, right };

// Half the frame period in ns, the default tolerance: within it, at most one frame of a stream of
// that rate can be the partner. frame_rate_hz <= 0 (unknown) gives half of 1/30 s, the most common
// camera rate.
int64_t default_pairing_tolerance_ns(double frame_rate_hz);

// The decision for the oldest frames of the two queues (see the header comment). `left_next` and
// `right_next` are the second-oldest timestamps when queued.
enum class PairingStep { pair, discard_left, discard_right, wait };
PairingStep next_pairing_step(std::optional<int64_t> left_oldest_ns, std::optional<int64_t> left_next_ns,
                              std::optional<int64_t> right_oldest_ns, std::optional<int64_t> right_next_ns,
                              int64_t tolerance_ns);

// Throws std::invalid_argument naming the setting when tolerance_ns < 0 or max_queued_per_side < 1.
void check_timestamp_pairing_settings(int64_t tolerance_ns, size_t max_queued_per_side);

// Counts of a pairing since it was made (per side).
struct PairingCounts {
  uint64_t pushed[2] = {0, 0};
  uint64_t unpaired[2] = {0, 0};      // discarded: no partner within the tolerance, or queue full
  uint64_t driver_drops[2] = {0, 0};  // gaps in the sequence numbers
  uint64_t pairs = 0;
};

// A frame in the pairing: its capture time, the driver's sequence number and what the caller
// carries with it (an image, a buffer index).
template <class Payload>
struct PairingFrame {
  int64_t timestamp_ns = 0;
  uint64_t sequence = 0;
  Payload payload{};
};

template <class Payload>
class TimestampPairing {
 public:
  using Frame = PairingFrame<Payload>;

  // tolerance_ns >= 0; max_queued_per_side >= 1 (throws std::invalid_argument naming the value).
  TimestampPairing(int64_t tolerance_ns, size_t max_queued_per_side)
      : tolerance_ns_(tolerance_ns), max_queued_(max_queued_per_side) {
    check_timestamp_pairing_settings(tolerance_ns, max_queued_per_side);
  }

  int64_t tolerance_ns() const { return tolerance_ns_; }
  const PairingCounts& counts() const { return counts_; }
  size_t queued(PairingSide side) const { return queue(side).size(); }

  void push(PairingSide side, Frame frame) {
    const int index = side_index(side);
    if (counts_.pushed[index] > 0 && frame.sequence > last_sequence_[index] + 1) {
      counts_.driver_drops[index] += frame.sequence - last_sequence_[index] - 1;
    }
    last_sequence_[index] = frame.sequence;
    ++counts_.pushed[index];
    auto& frames = queue(side);
    frames.push_back(std::move(frame));
    while (frames.size() > max_queued_) {
      frames.pop_front();
      ++counts_.unpaired[index];
    }
  }

  // The next pair when the queued frames make one (discarding what can never pair on the way).
  std::optional<std::pair<Frame, Frame>> pop_pair() {
    for (;;) {
      const PairingStep step =
          next_pairing_step(timestamp_at(left_, 0), timestamp_at(left_, 1), timestamp_at(right_, 0),
                            timestamp_at(right_, 1), tolerance_ns_);
      switch (step) {
        case PairingStep::wait: return std::nullopt;
        case PairingStep::discard_left: discard(PairingSide::left); break;
        case PairingStep::discard_right: discard(PairingSide::right); break;
        case PairingStep::pair: {
          std::pair<Frame, Frame> pair{std::move(left_.front()), std::move(right_.front())};
          left_.pop_front();
          right_.pop_front();
          ++counts_.pairs;
          return pair;
        }
      }
    }
  }

 private:
  static int side_index(PairingSide side) { return side == PairingSide::left ? 0 : 1; }
  static std::optional<int64_t> timestamp_at(const std::deque<Frame>& frames, size_t position) {
    if (frames.size() <= position) return std::nullopt;
    return frames[position].timestamp_ns;
  }
  std::deque<Frame>& queue(PairingSide side) { return side == PairingSide::left ? left_ : right_; }
  const std::deque<Frame>& queue(PairingSide side) const { return side == PairingSide::left ? left_ : right_; }
  void discard(PairingSide side) {
    queue(side).pop_front();
    ++counts_.unpaired[side_index(side)];
  }

  int64_t tolerance_ns_;
  size_t max_queued_;
  std::deque<Frame> left_, right_;
  uint64_t last_sequence_[2] = {0, 0};
  PairingCounts counts_;
};

}  // namespace lpstereo::io
