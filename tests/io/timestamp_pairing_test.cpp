// The pairing of two timestamp streams (io/camera/timestamp_pairing.h) on simulated cameras: two
// streams of one frame period sampled at the same instants ("ticks"), with a phase between them,
// jitter and drops. The expected pairs come from the simulation (the frames of one tick belong
// together), not from the pairing: each payload is its tick number.
#include "io/camera/timestamp_pairing.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

namespace lpstereo::io {
namespace {

constexpr int64_t kPeriodNs = 33'333'333;  // 30 fps

struct Arrival {
  PairingSide side;
  PairingFrame<int> frame;
};

struct StreamSpec {
  int ticks = 100;
  int64_t right_phase_ns = 0;                 // right captures this much after left
  std::set<int> left_dropped, right_dropped;  // ticks the driver lost
  int64_t jitter_ns = 0;                      // uniform +- on every timestamp
  uint32_t seed = 1;
};

// Both streams, in the order their frames arrive (by timestamp). Sequence numbers count every tick
// the driver saw, so a dropped tick is a gap.
std::vector<Arrival> simulate(const StreamSpec& spec) {
  std::mt19937 random(spec.seed);
  std::uniform_int_distribution<int64_t> jitter(-spec.jitter_ns, spec.jitter_ns);
  std::vector<Arrival> arrivals;
  for (int tick = 0; tick < spec.ticks; ++tick) {
    const int64_t left_ns = 1'000'000'000 + tick * kPeriodNs + jitter(random);
    const int64_t right_ns = 1'000'000'000 + tick * kPeriodNs + spec.right_phase_ns + jitter(random);
    if (!spec.left_dropped.count(tick)) {
      arrivals.push_back({PairingSide::left, {left_ns, static_cast<uint64_t>(tick), tick}});
    }
    if (!spec.right_dropped.count(tick)) {
      arrivals.push_back({PairingSide::right, {right_ns, static_cast<uint64_t>(tick), tick}});
    }
  }
  std::stable_sort(arrivals.begin(), arrivals.end(),
                   [](const Arrival& a, const Arrival& b) { return a.frame.timestamp_ns < b.frame.timestamp_ns; });
  return arrivals;
}

struct Outcome {
  std::vector<std::pair<int, int>> pairs;  // (left tick, right tick)
  PairingCounts counts;
  size_t left_queued = 0, right_queued = 0;
};

Outcome run(const std::vector<Arrival>& arrivals, int64_t tolerance_ns, size_t max_queued = 4) {
  TimestampPairing<int> pairing(tolerance_ns, max_queued);
  Outcome outcome;
  for (const Arrival& arrival : arrivals) {
    pairing.push(arrival.side, arrival.frame);
    while (auto pair = pairing.pop_pair()) outcome.pairs.emplace_back(pair->first.payload, pair->second.payload);
  }
  outcome.counts = pairing.counts();
  outcome.left_queued = pairing.queued(PairingSide::left);
  outcome.right_queued = pairing.queued(PairingSide::right);
  return outcome;
}

// Every frame is paired, discarded or still queued: nothing is lost without a count.
void expect_accounted(const Outcome& outcome) {
  EXPECT_EQ(outcome.counts.pushed[0], outcome.counts.pairs + outcome.counts.unpaired[0] + outcome.left_queued);
  EXPECT_EQ(outcome.counts.pushed[1], outcome.counts.pairs + outcome.counts.unpaired[1] + outcome.right_queued);
  EXPECT_EQ(outcome.counts.pairs, outcome.pairs.size());
}

std::vector<std::pair<int, int>> same_tick_pairs(int ticks, const std::set<int>& missing) {
  std::vector<std::pair<int, int>> pairs;
  for (int tick = 0; tick < ticks; ++tick) {
    if (!missing.count(tick)) pairs.emplace_back(tick, tick);
  }
  return pairs;
}

TEST(TimestampPairing, DefaultToleranceIsHalfTheFramePeriod) {
  EXPECT_EQ(default_pairing_tolerance_ns(30.0), 16'666'667);
  EXPECT_EQ(default_pairing_tolerance_ns(60.0), 8'333'333);
  EXPECT_EQ(default_pairing_tolerance_ns(0.0), 16'666'667);  // unknown rate: 30 fps assumed
}

TEST(TimestampPairing, CompleteStreamsPairTickByTick) {
  StreamSpec spec;
  spec.right_phase_ns = 3'000'000;
  const Outcome outcome = run(simulate(spec), default_pairing_tolerance_ns(30.0));
  EXPECT_EQ(outcome.pairs, same_tick_pairs(spec.ticks, {}));
  EXPECT_EQ(outcome.counts.unpaired[0], 0u);
  EXPECT_EQ(outcome.counts.unpaired[1], 0u);
  EXPECT_EQ(outcome.counts.driver_drops[0], 0u);
  EXPECT_EQ(outcome.counts.driver_drops[1], 0u);
  expect_accounted(outcome);
}

TEST(TimestampPairing, DropsOnEitherSideLeaveTheirPartnersUnpairedAndCountAsDriverDrops) {
  StreamSpec spec;
  spec.right_phase_ns = -4'000'000;  // right slightly ahead
  spec.left_dropped = {5, 17, 18};
  spec.right_dropped = {9, 40};
  const Outcome outcome = run(simulate(spec), default_pairing_tolerance_ns(30.0));
  EXPECT_EQ(outcome.pairs, same_tick_pairs(spec.ticks, {5, 9, 17, 18, 40}));
  EXPECT_EQ(outcome.counts.unpaired[0], 2u);  // left frames of ticks 9 and 40
  EXPECT_EQ(outcome.counts.unpaired[1], 3u);  // right frames of ticks 5, 17, 18
  EXPECT_EQ(outcome.counts.driver_drops[0], 3u);
  EXPECT_EQ(outcome.counts.driver_drops[1], 2u);
  expect_accounted(outcome);
}

TEST(TimestampPairing, JitterWithinTheTolerancePairsTickByTick) {
  StreamSpec spec;
  spec.right_phase_ns = 2'000'000;
  spec.jitter_ns = 6'000'000;  // |difference| <= 2 + 12 ms < 16.7 ms; neighbours >= 33.3 - 14 ms away
  const Outcome outcome = run(simulate(spec), default_pairing_tolerance_ns(30.0));
  EXPECT_EQ(outcome.pairs, same_tick_pairs(spec.ticks, {}));
  expect_accounted(outcome);
}

TEST(TimestampPairing, AFrameJitteredBeyondTheToleranceIsNotPaired) {
  std::vector<Arrival> arrivals = simulate(StreamSpec{});
  // Right frame of tick 50 arrives 12 ms late; the tolerance is 10 ms.
  for (Arrival& arrival : arrivals) {
    if (arrival.side == PairingSide::right && arrival.frame.payload == 50) arrival.frame.timestamp_ns += 12'000'000;
  }
  const Outcome outcome = run(arrivals, 10'000'000);
  EXPECT_EQ(outcome.pairs, same_tick_pairs(100, {50}));
  EXPECT_EQ(outcome.counts.unpaired[0], 1u);
  EXPECT_EQ(outcome.counts.unpaired[1], 1u);
  EXPECT_EQ(outcome.counts.driver_drops[0] + outcome.counts.driver_drops[1], 0u);
  expect_accounted(outcome);
}

TEST(TimestampPairing, APhaseBeyondHalfAPeriodPairsWithTheNearerNeighbour) {
  // Right captures 0.6 period after left, so its nearest left frame is the next tick's
  // (0.4 period away): pairs (k + 1, k), the first left frame and the last right frame have none.
  StreamSpec spec;
  spec.ticks = 50;
  spec.right_phase_ns = kPeriodNs * 6 / 10;
  const Outcome outcome = run(simulate(spec), default_pairing_tolerance_ns(30.0));
  std::vector<std::pair<int, int>> expected;
  for (int tick = 0; tick + 1 < spec.ticks; ++tick) expected.emplace_back(tick + 1, tick);
  EXPECT_EQ(outcome.pairs, expected);
  EXPECT_EQ(outcome.counts.unpaired[0], 1u);
  EXPECT_EQ(outcome.right_queued, 1u);  // tick 49's right frame still waits for a partner
  expect_accounted(outcome);
}

TEST(TimestampPairing, AStalledSideBoundsTheOtherQueueAndPairingResumes) {
  StreamSpec spec;
  spec.ticks = 60;
  spec.right_phase_ns = 1'000'000;
  for (int tick = 10; tick < 30; ++tick) spec.right_dropped.insert(tick);  // right stalls for 20 frames
  const size_t max_queued = 4;
  const std::vector<Arrival> arrivals = simulate(spec);

  TimestampPairing<int> pairing(default_pairing_tolerance_ns(30.0), max_queued);
  size_t most_left_queued = 0;
  std::vector<std::pair<int, int>> pairs;
  for (const Arrival& arrival : arrivals) {
    pairing.push(arrival.side, arrival.frame);
    most_left_queued = std::max(most_left_queued, pairing.queued(PairingSide::left));
    while (auto pair = pairing.pop_pair()) pairs.emplace_back(pair->first.payload, pair->second.payload);
  }
  EXPECT_LE(most_left_queued, max_queued);
  EXPECT_EQ(pairs, same_tick_pairs(spec.ticks, spec.right_dropped));
  EXPECT_EQ(pairing.counts().unpaired[0], 20u);
  EXPECT_EQ(pairing.counts().driver_drops[1], 20u);  // right sequence jumps from 9 to 30
}

TEST(TimestampPairing, TheOtherSidesNextFrameWinsWhenItIsCloser) {
  // A wide tolerance (one period) admits two candidates; the closer one pairs.
  EXPECT_EQ(next_pairing_step(100, 133, 80, 101, 30), PairingStep::discard_right);
  EXPECT_EQ(next_pairing_step(80, 101, 100, 133, 30), PairingStep::discard_left);
  EXPECT_EQ(next_pairing_step(100, 133, 95, 128, 30), PairingStep::pair);
  EXPECT_EQ(next_pairing_step(100, std::nullopt, std::nullopt, std::nullopt, 30), PairingStep::wait);
  EXPECT_EQ(next_pairing_step(100, std::nullopt, 131, std::nullopt, 30), PairingStep::discard_left);
  EXPECT_EQ(next_pairing_step(100, std::nullopt, 130, std::nullopt, 30), PairingStep::pair);  // tolerance inclusive
}

TEST(TimestampPairing, ARestartedSequenceCountsNoDrop) {
  TimestampPairing<int> pairing(1000, 4);
  pairing.push(PairingSide::left, {0, 7, 0});
  pairing.push(PairingSide::left, {10, 0, 1});  // the driver restarted its counter
  pairing.push(PairingSide::left, {20, 3, 2});  // then lost two frames
  EXPECT_EQ(pairing.counts().driver_drops[0], 2u);
}

TEST(TimestampPairing, RefusesANegativeToleranceAndAnEmptyQueue) {
  EXPECT_THROW(TimestampPairing<int>(-1, 4), std::invalid_argument);
  EXPECT_THROW(TimestampPairing<int>(0, 0), std::invalid_argument);
  try {
    TimestampPairing<int> pairing(-5, 4);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "timestamp pairing: tolerance_ns must be >= 0, got -5");
  }
}

}  // namespace
}  // namespace lpstereo::io
