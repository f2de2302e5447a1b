// ARM task obstacle_tracker over sequences of hand-built obstacle records, its state fed back frame to
// frame (by hand, and through a graph's delayed edge): a constant-velocity obstacle's velocity
// converges, ids persist (also when the records change rows and when two obstacles cross), a
// disappearing obstacle's track is dropped after max_missed_frames, new obstacles get new ids never
// reused, the gates start new tracks for jumps in position or pixel count, the measurement noise is
// the stereo depth error z^2 sigma_d / (f B), the counted work is the header's closed form, and bad
// parameters or state give a KernelError naming the thing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "arm/scheduler.h"
#include "arm/tasks/obstacle_record.h"
#include "arm/tasks/obstacle_tracker.h"
#include "dag/arm_task.h"
#include "dag/graph.h"

namespace lpstereo {
namespace {

constexpr int kMaxObstacles = 7;  // odd, and more rows than any test fills
constexpr double kFocalPx = 1400.0;
constexpr double kBaselineM = 0.30;
constexpr double kPeriodS = 1.0 / 30.0;

struct Sighting {
  double x_m = 0.0, z_m = 0.0;
  int pixels = 0;
};

// One frame's record plane: the sightings in rows 0.., the rest unused (all zero). Fields the tracker
// does not read are filled with recognisable values, to check it passes them through.
Plane obstacle_plane(const std::vector<Sighting>& sightings) {
  Plane plane(arm::kObstacleWords, kMaxObstacles, {ElementType::s32, 0});
  for (int r = 0; r < kMaxObstacles; ++r) {
    for (int w = 0; w < arm::kObstacleWords; ++w) plane.at<int32_t>(w, r) = 0;
  }
  for (int r = 0; r < static_cast<int>(sightings.size()); ++r) {
    const Sighting& sighting = sightings[r];
    int32_t* record = plane.row<int32_t>(r);
    record[arm::kObstacleValid] = 1;
    record[arm::kObstacleId] = r + 1;
    record[arm::kObstacleX0] = 100 + r;
    record[arm::kObstacleX1] = 140 + r;
    record[arm::kObstaclePixels] = sighting.pixels;
    record[arm::kObstacleDisparityQ4] = static_cast<int32_t>(std::lround(16.0 * kFocalPx * kBaselineM / sighting.z_m));
    record[arm::kObstacleDistanceMm] = static_cast<int32_t>(std::lround(sighting.z_m * 1000.0));
    record[arm::kObstaclePositionXMm] = static_cast<int32_t>(std::lround(sighting.x_m * 1000.0));
    record[arm::kObstaclePositionYMm] = 1500;
    record[arm::kObstacleFeatures] = 9;
  }
  return plane;
}

nlohmann::json base_params() { return {{"focal_px", kFocalPx}, {"baseline_m", kBaselineM}, {"frame_period_s", kPeriodS}}; }

const ArmTaskDescriptor& tracker_task() {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("obstacle_tracker");
  if (task == nullptr) throw std::runtime_error("ARM task 'obstacle_tracker' is not registered");
  return *task;
}

// The task run frame after frame with its "tracks" output fed back as "previous_tracks", as a delayed
// edge does (all zero before the first frame).
class Tracker {
 public:
  explicit Tracker(const nlohmann::json& params) : task_(tracker_task()) {
    prepared_ = task_.prepare(params, {{arm::kObstacleWords, kMaxObstacles}, {arm::kTrackWords, 1}});
    const PlaneShape state_shape = prepared_.output_shapes.at(1);
    state_ = Plane(state_shape.width, state_shape.height, {ElementType::s32, 0});
    for (int r = 0; r < state_.height(); ++r) {
      for (int w = 0; w < state_.width(); ++w) state_.at<int32_t>(w, r) = 0;
    }
  }

  // Returns the "tracked" records; state() is the new "tracks" plane.
  Plane step(const std::vector<Sighting>& sightings) {
    const Plane obstacles = obstacle_plane(sightings);
    Plane tracked(arm::kObstacleWords, kMaxObstacles, {ElementType::s32, 0});
    Plane next(state_.width(), state_.height(), {ElementType::s32, 0});
    work_ = ArmWork{};
    task_.run(ArmTaskArgs{{&obstacles, &state_}, {&tracked, &next}, prepared_.params.get(), &work_});
    state_ = std::move(next);
    return tracked;
  }

  const Plane& state() const { return state_; }
  arm::TrackState decoded() const { return arm::decode_tracks(state_); }
  const ArmWork& work() const { return work_; }

 private:
  const ArmTaskDescriptor& task_;
  PreparedKernel prepared_;
  Plane state_;
  ArmWork work_;
};

int32_t word(const Plane& records, int row, int index) { return records.at<int32_t>(index, row); }

// The row of `records` whose position is (x_m, z_m) to the mm (the tracker keeps the input's rows).
int row_at(const Plane& records, const Sighting& sighting) {
  for (int r = 0; r < records.height(); ++r) {
    if (word(records, r, arm::kObstacleValid) == 1 &&
        word(records, r, arm::kObstaclePositionXMm) == std::lround(sighting.x_m * 1000.0) &&
        word(records, r, arm::kObstacleDistanceMm) == std::lround(sighting.z_m * 1000.0)) {
      return r;
    }
  }
  return -1;
}

// An obstacle moving at +2 m/s lateral and -10 m/s in z (approaching) from (-4, 60) m, exact
// positions: the constant-velocity model holds exactly, so the filter's velocity converges to the
// truth, monotonically once it has started; before min_hits_for_velocity measurements the record's
// velocity is 0. At 60 m the depth noise the filter assumes is z^2 sigma_d / (f B) = 2.1 m, so it
// weighs each depth lightly and takes over a second: within 0.1 m/s after 40 frames (1.33 s), within
// 0.05 m/s after 60 (2 s).
TEST(ObstacleTracker, ConstantVelocityObstacleConvergesToItsVelocity) {
  constexpr double kVx = 2.0, kVz = -10.0;
  constexpr int kFrames = 75;
  Tracker tracker(base_params());  // min_hits_for_velocity 3 by default
  int track_id = 0;
  double last_error_x = 1e9, last_error_z = 1e9;
  for (int frame = 0; frame < kFrames; ++frame) {
    const double t = frame * kPeriodS;
    const Plane tracked = tracker.step({{-4.0 + kVx * t, 60.0 + kVz * t, 800}});
    ASSERT_EQ(word(tracked, 0, arm::kObstacleValid), 1);
    if (frame == 0) track_id = word(tracked, 0, arm::kObstacleTrackId);
    EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), track_id) << "frame " << frame;
    EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackAgeFrames), frame + 1);
    EXPECT_EQ(word(tracked, 0, arm::kObstacleVelocityYMmPerS), 0);
    const double error_x = std::abs(word(tracked, 0, arm::kObstacleVelocityXMmPerS) - kVx * 1000.0);
    const double error_z = std::abs(word(tracked, 0, arm::kObstacleVelocityZMmPerS) - kVz * 1000.0);
    if (frame < 2) {
      EXPECT_EQ(word(tracked, 0, arm::kObstacleVelocityXMmPerS), 0) << "frame " << frame;
      EXPECT_EQ(word(tracked, 0, arm::kObstacleVelocityZMmPerS), 0) << "frame " << frame;
    } else {
      EXPECT_LE(error_x, last_error_x + 1.0) << "frame " << frame;  // 1 mm/s: the record's rounding
      EXPECT_LE(error_z, last_error_z + 1.0) << "frame " << frame;
      last_error_x = error_x;
      last_error_z = error_z;
    }
    const double tolerance_mm_per_s = frame >= 60 ? 50.0 : frame >= 40 ? 100.0 : 1e9;
    EXPECT_LE(error_x, tolerance_mm_per_s) << "frame " << frame;
    EXPECT_LE(error_z, tolerance_mm_per_s) << "frame " << frame;
    // Untouched fields pass through.
    EXPECT_EQ(word(tracked, 0, arm::kObstacleFeatures), 9);
    EXPECT_EQ(word(tracked, 0, arm::kObstaclePositionYMm), 1500);
  }
  EXPECT_EQ(track_id, 1);
  const arm::TrackState state = tracker.decoded();
  ASSERT_EQ(state.tracks.size(), 1u);
  EXPECT_EQ(state.frames_processed, kFrames);
  EXPECT_EQ(state.next_id, 2);
  const arm::Track& track = state.tracks[0];
  EXPECT_EQ(track.hits, kFrames);
  EXPECT_EQ(track.misses, 0);
  const double t_last = (kFrames - 1) * kPeriodS;
  EXPECT_NEAR(track.state[0], -4.0 + kVx * t_last, 0.01);
  EXPECT_NEAR(track.state[1], 60.0 + kVz * t_last, 0.01);
  EXPECT_NEAR(track.state[2], kVx, 0.05);
  EXPECT_NEAR(track.state[3], kVz, 0.05);
}

// The same motion measured with the noise the filter models (Gaussian, the header's R at each
// point), 90 frames from z = 45 m to 15 m. The filter's own velocity standard deviation at the end
// bounds the error: it must be within 3 sigma of the truth on both axes, and that sigma must be
// small enough to be useful (< 0.5 m/s).
TEST(ObstacleTracker, NoisyConstantVelocityObstacleConvergesWithinTheFiltersUncertainty) {
  constexpr double kVx = 2.0, kVz = -10.0;
  constexpr double kDisparitySigmaPx = 0.25, kLateralSigmaM = 0.1;
  Tracker tracker(base_params());
  std::mt19937 generator(12345);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int frame = 0; frame < 90; ++frame) {
    const double t = frame * kPeriodS;
    const double x = -3.0 + kVx * t, z = 45.0 + kVz * t;
    // x = (u - u0) z / f at a fixed column: a depth error dz moves x by (x / z) dz (header comment).
    const double depth_error = unit(generator) * z * z * kDisparitySigmaPx / (kFocalPx * kBaselineM);
    const double lateral_error = unit(generator) * kLateralSigmaM;
    const Plane tracked = tracker.step({{x + lateral_error + x / z * depth_error, z + depth_error, 800}});
    ASSERT_EQ(word(tracked, 0, arm::kObstacleTrackId), 1) << "frame " << frame;
  }
  const arm::TrackState state = tracker.decoded();
  const arm::Track& track = state.tracks.at(0);
  const double sigma_vx = std::sqrt(track.covariance[2][2]);
  const double sigma_vz = std::sqrt(track.covariance[3][3]);
  std::printf("noisy track: v = (%.3f, %.3f) m/s, truth (%.1f, %.1f), filter sigma (%.3f, %.3f) m/s\n", track.state[2],
              track.state[3], kVx, kVz, sigma_vx, sigma_vz);
  EXPECT_LT(sigma_vx, 0.5);
  EXPECT_LT(sigma_vz, 0.5);
  EXPECT_NEAR(track.state[2], kVx, 3.0 * sigma_vx);
  EXPECT_NEAR(track.state[3], kVz, 3.0 * sigma_vz);
}

// A new track's position covariance is the measurement noise R: the depth variance
// (z^2 sigma_d / (f B))^2 (first-order stereo depth error), the lateral one lateral_sigma^2 plus the
// depth error carried by x = (u - u0) z / f, and their covariance.
TEST(ObstacleTracker, NewTrackCovarianceIsTheStereoMeasurementNoise) {
  nlohmann::json params = base_params();
  params["disparity_sigma_px"] = 0.5;
  params["lateral_sigma_m"] = 0.2;
  params["initial_speed_sigma_mps"] = 7.0;
  Tracker tracker(params);
  tracker.step({{6.0, 30.0, 400}});
  const arm::TrackState state = tracker.decoded();
  const arm::Track& track = state.tracks.at(0);
  const double sigma_z = 30.0 * 30.0 * 0.5 / (kFocalPx * kBaselineM);  // 1.0714 m
  const double slope = 6.0 / 30.0;
  EXPECT_NEAR(track.covariance[1][1], sigma_z * sigma_z, 1e-5);
  EXPECT_NEAR(track.covariance[0][0], 0.2 * 0.2 + slope * slope * sigma_z * sigma_z, 1e-5);
  EXPECT_NEAR(track.covariance[0][1], slope * sigma_z * sigma_z, 1e-5);
  EXPECT_NEAR(track.covariance[2][2], 49.0, 1e-4);
  EXPECT_NEAR(track.covariance[3][3], 49.0, 1e-4);
  EXPECT_EQ(track.covariance[0][2], 0.0);
  EXPECT_EQ(track.state[0], 6.0f);
  EXPECT_EQ(track.state[1], 30.0f);
  EXPECT_EQ(track.state[2], 0.0);
}

// Three still obstacles listed in a different row order every frame: the ids follow the obstacles,
// not the rows. A fourth appearing later gets the next id.
TEST(ObstacleTracker, IdsFollowTheObstaclesAndANewObstacleGetsANewId) {
  Tracker tracker(base_params());
  const std::vector<Sighting> still = {{-3.0, 12.0, 2000}, {0.5, 25.0, 600}, {4.0, 40.0, 300}};
  std::vector<int> ids(3, 0);
  for (int frame = 0; frame < 8; ++frame) {
    std::vector<Sighting> sightings = still;
    std::rotate(sightings.begin(), sightings.begin() + frame % 3, sightings.end());
    if (frame >= 5) sightings.push_back({-1.0, 18.0, 900});
    const Plane tracked = tracker.step(sightings);
    for (int k = 0; k < 3; ++k) {
      const int row = row_at(tracked, still[k]);
      ASSERT_GE(row, 0);
      const int id = word(tracked, row, arm::kObstacleTrackId);
      if (frame == 0) {
        EXPECT_EQ(id, row + 1);  // the first frame's tracks start in row order
        ids[k] = id;
      }
      EXPECT_EQ(id, ids[k]) << "obstacle " << k << " frame " << frame;
      EXPECT_EQ(word(tracked, row, arm::kObstacleTrackAgeFrames), frame + 1);
    }
    if (frame >= 5) {
      const int row = row_at(tracked, {-1.0, 18.0, 900});
      EXPECT_EQ(word(tracked, row, arm::kObstacleTrackId), 4) << "frame " << frame;
      EXPECT_EQ(word(tracked, row, arm::kObstacleTrackAgeFrames), frame - 4);
    }
    for (int r = static_cast<int>(sightings.size()); r < kMaxObstacles; ++r) {
      EXPECT_EQ(word(tracked, r, arm::kObstacleValid), 0);
      EXPECT_EQ(word(tracked, r, arm::kObstacleTrackId), 0);
    }
  }
  const arm::TrackState state = tracker.decoded();
  ASSERT_EQ(state.tracks.size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(state.tracks[k].id, k + 1);  // rows in increasing id order
  EXPECT_EQ(state.next_id, 5);
}

// Two obstacles cross at the same distance: A (large, 1500 px) from x = -3 m to +3 m, B (small, 500 px)
// from +3 m to -3 m, both at 3 m/s, rows ordered left to right as a clustering would emit them (so
// they swap rows after the crossing). At frame 30 both are at the same point, listed B first: only
// the pixel count tells them apart there (without it the tie goes by the documented tie-break, lower
// track id to the lower row, which swaps them); before and after, the predicted centroids do too.
// Both keep their ids all along.
std::vector<int> crossing_ids(const nlohmann::json& params, int last_frame, int* ids_at_crossing) {
  Tracker tracker(params);
  std::vector<int> ids;  // per frame: A's id, B's id
  for (int frame = 0; frame <= last_frame; ++frame) {
    const double offset = frame == 30 ? 0.0 : -3.0 + 3.0 * frame * kPeriodS;
    const Sighting a{offset, 20.0, 1500};
    const Sighting b{-offset, 20.0, 500};
    const bool a_first = frame < 30;
    const Plane tracked = tracker.step(a_first ? std::vector<Sighting>{a, b} : std::vector<Sighting>{b, a});
    const int row_a = a_first ? 0 : 1;
    if (word(tracked, row_a, arm::kObstaclePixels) != 1500) throw std::runtime_error("row of A");
    ids.push_back(word(tracked, row_a, arm::kObstacleTrackId));
    ids.push_back(word(tracked, 1 - row_a, arm::kObstacleTrackId));
    if (frame == 30) {
      ids_at_crossing[0] = ids[ids.size() - 2];
      ids_at_crossing[1] = ids.back();
    }
    if (frame >= 40) {  // and their velocities have the right signs and size
      EXPECT_NEAR(word(tracked, row_a, arm::kObstacleVelocityXMmPerS), 3000.0, 200.0) << "frame " << frame;
      EXPECT_NEAR(word(tracked, 1 - row_a, arm::kObstacleVelocityXMmPerS), -3000.0, 200.0) << "frame " << frame;
    }
  }
  EXPECT_EQ(tracker.decoded().next_id, 3);  // no track was ever restarted
  return ids;
}

TEST(ObstacleTracker, CrossingObstaclesKeepTheirIds) {
  int at_crossing[2] = {0, 0};
  const std::vector<int> ids = crossing_ids(base_params(), 60, at_crossing);
  ASSERT_EQ(ids[0], 1);  // A is row 0 in the first frame
  ASSERT_EQ(ids[1], 2);
  for (size_t k = 0; k < ids.size(); k += 2) {
    EXPECT_EQ(ids[k], 1) << "frame " << k / 2;
    EXPECT_EQ(ids[k + 1], 2) << "frame " << k / 2;
  }
  nlohmann::json without_pixels = base_params();
  without_pixels["pixel_weight"] = 0.0;
  without_pixels["max_relative_pixel_difference"] = 1.0;
  crossing_ids(without_pixels, 30, at_crossing);
  EXPECT_EQ(at_crossing[0], 2);  // swapped: track 1 took row 0, which is B
  EXPECT_EQ(at_crossing[1], 1);
}

// A track without a measurement is predicted and kept for max_missed_frames frames, then dropped; an
// obstacle reappearing after that gets a new id (ids are never reused).
TEST(ObstacleTracker, DisappearingObstacleIsDroppedAfterMaxMissedFramesAndIdsAreNotReused) {
  nlohmann::json params = base_params();
  params["max_missed_frames"] = 2;
  Tracker tracker(params);
  const Sighting walker{1.0, 15.0, 700};
  const Sighting still{-2.0, 10.0, 1200};
  for (int frame = 0; frame < 5; ++frame) tracker.step({walker, still});
  for (int missed = 1; missed <= 3; ++missed) {
    const Plane tracked = tracker.step({still});
    EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 2);
    const arm::TrackState state = tracker.decoded();
    if (missed <= 2) {
      ASSERT_EQ(state.tracks.size(), 2u) << "missed " << missed;
      EXPECT_EQ(state.tracks[0].id, 1);
      EXPECT_EQ(state.tracks[0].misses, missed);
      EXPECT_EQ(state.tracks[0].hits, 5);
      EXPECT_EQ(state.tracks[0].age_frames, 5 + missed);
      EXPECT_EQ(state.tracks[0].obstacle_row, -1);
      EXPECT_EQ(state.tracks[1].obstacle_row, 0);
    } else {
      ASSERT_EQ(state.tracks.size(), 1u) << "missed " << missed;
      EXPECT_EQ(state.tracks[0].id, 2);
    }
  }
  const Plane tracked = tracker.step({still, walker});
  EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 2);
  EXPECT_EQ(word(tracked, 1, arm::kObstacleTrackId), 3);
  EXPECT_EQ(word(tracked, 1, arm::kObstacleTrackAgeFrames), 1);
}

// A track missed for a frame or two keeps predicting and picks its obstacle up again.
TEST(ObstacleTracker, TrackCoastsThroughAShortGap) {
  Tracker tracker(base_params());
  for (int frame = 0; frame < 20; ++frame) {
    const double t = frame * kPeriodS;
    const Sighting sighting{1.0 - 1.5 * t, 30.0 - 8.0 * t, 500};
    const Plane tracked = tracker.step(frame == 12 || frame == 13 ? std::vector<Sighting>{} : std::vector<Sighting>{sighting});
    if (frame != 12 && frame != 13) {
      EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 1) << "frame " << frame;
    }
  }
  const arm::TrackState state = tracker.decoded();
  const arm::Track& track = state.tracks.at(0);
  EXPECT_EQ(track.hits, 18);
  EXPECT_EQ(track.age_frames, 20);
}

// The gates: a jump of 3 m at 10 m (many sigmas) or a pixel count 5 times the track's starts a new
// track instead of associating; the old one misses.
TEST(ObstacleTracker, GatesStartNewTracksForPositionAndPixelCountJumps) {
  Tracker tracker(base_params());
  for (int frame = 0; frame < 5; ++frame) tracker.step({{0.0, 10.0, 1000}});
  Plane tracked = tracker.step({{3.0, 10.0, 1000}});
  EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 2);
  tracked = tracker.step({{0.0, 10.0, 5000}});
  EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 3);
  // Within the gates (5 cm, 10 % more pixels): associated with track 1 again.
  tracked = tracker.step({{0.05, 10.0, 1100}});
  EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 1);
}

// An obstacle whose pixel count changes as it approaches (area ~ 1 / z^2) stays associated even with a
// tight pixel gate: the track predicts the count at the predicted distance. From frame to frame the
// count grows by up to 17 % (4.33 m to 4.0 m), over twice the gate of 8 %; the first step (12 m to
// 11.67 m, +5.8 %, no velocity known yet) is within it.
TEST(ObstacleTracker, PixelCountIsPredictedAtThePredictedDistance) {
  nlohmann::json params = base_params();
  params["max_relative_pixel_difference"] = 0.08;
  Tracker tracker(params);
  for (int frame = 0; frame < 25; ++frame) {
    const double z = 12.0 - 10.0 * frame * kPeriodS;  // 12 m to 4.0 m: area x 9
    const int pixels = static_cast<int>(std::lround(1000.0 * 64.0 / (z * z)));
    const Plane tracked = tracker.step({{0.0, z, pixels}});
    EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 1) << "frame " << frame;
  }
}

// Only max_tracks tracks live; the obstacles left over are untracked and counted.
TEST(ObstacleTracker, ObstaclesBeyondMaxTracksAreUntrackedAndCounted) {
  nlohmann::json params = base_params();
  params["max_tracks"] = 2;
  Tracker tracker(params);
  const Plane tracked = tracker.step({{-5.0, 20.0, 300}, {0.0, 20.0, 300}, {5.0, 20.0, 300}});
  EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 1);
  EXPECT_EQ(word(tracked, 1, arm::kObstacleTrackId), 2);
  EXPECT_EQ(word(tracked, 2, arm::kObstacleTrackId), 0);
  EXPECT_EQ(word(tracked, 2, arm::kObstacleTrackAgeFrames), 0);
  EXPECT_EQ(tracker.state().height(), 3);
  const arm::TrackState state = tracker.decoded();
  EXPECT_EQ(state.refused_this_frame, 1);
  EXPECT_EQ(state.tracks.size(), 2u);
}

// The s32 counters at their extremes: a track with age and hits at INT32_MAX keeps them (saturating,
// no wrap), and with the last id (2^31 - 2) given out the next obstacle gets no track instead of an
// id that would overflow the stored next id.
TEST(ObstacleTracker, CountersSaturateAndIdsStopAtTheLastId) {
  constexpr int32_t kMax = std::numeric_limits<int32_t>::max();
  const ArmTaskDescriptor& task = tracker_task();
  const PreparedKernel prepared = task.prepare(base_params(), {{arm::kObstacleWords, kMaxObstacles}, {arm::kTrackWords, 1}});
  Plane previous(arm::kTrackWords, 65, {ElementType::s32, 0});
  for (int r = 0; r < previous.height(); ++r) {
    for (int w = 0; w < arm::kTrackWords; ++w) previous.at<int32_t>(w, r) = 0;
  }
  previous.at<int32_t>(arm::kTracksNextId, 0) = kMax;
  previous.at<int32_t>(arm::kTracksCount, 0) = 1;
  previous.at<int32_t>(arm::kTracksFramesProcessed, 0) = kMax;
  int32_t* row = previous.row<int32_t>(1);
  row[arm::kTrackId] = kMax - 1;
  row[arm::kTrackAgeFrames] = kMax;
  row[arm::kTrackHits] = kMax;
  row[arm::kTrackPixels] = 500;
  row[arm::kTrackLastDistanceMm] = 20000;
  row[arm::kTrackZM] = arm::track_word(20.0f);
  for (int word : {arm::kTrackCovariance00, arm::kTrackCovariance11, arm::kTrackCovariance22, arm::kTrackCovariance33}) {
    row[word] = arm::track_word(0.01f);
  }
  const Plane obstacles = obstacle_plane({{0.0, 20.0, 500}, {5.0, 30.0, 500}});
  Plane tracked(arm::kObstacleWords, kMaxObstacles, {ElementType::s32, 0});
  Plane next(arm::kTrackWords, 65, {ElementType::s32, 0});
  task.run(ArmTaskArgs{{&obstacles, &previous}, {&tracked, &next}, prepared.params.get(), nullptr});
  EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), kMax - 1);
  EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackAgeFrames), kMax);
  EXPECT_EQ(word(tracked, 1, arm::kObstacleTrackId), 0);
  const arm::TrackState state = arm::decode_tracks(next);
  EXPECT_EQ(state.next_id, kMax);
  EXPECT_EQ(state.frames_processed, kMax);
  EXPECT_EQ(state.refused_this_frame, 1);
  ASSERT_EQ(state.tracks.size(), 1u);
  EXPECT_EQ(state.tracks[0].hits, kMax);
  EXPECT_EQ(state.tracks[0].age_frames, kMax);
}

// The counted work of the header's closed form on two frames: frame 1 starts two tracks (T = 0,
// M = 2, N = 2); frame 2 sees both again, 20 m apart so only the two right pairs pass the gates
// (T = 2, M = 2, G = 2, U = 2).
TEST(ObstacleTracker, CountedWorkEqualsClosedForm) {
  Tracker tracker(base_params());
  const uint64_t memory = 2ull * 4 * arm::kObstacleWords * kMaxObstacles + 2ull * 4 * arm::kTrackWords * (1 + 64);
  tracker.step({{-10.0, 20.0, 400}, {10.0, 20.0, 400}});
  EXPECT_EQ(tracker.work().scalar_ops, 32u + 12u * 2 + 24u * 2 + 8u * kMaxObstacles + 8u * 2);
  EXPECT_EQ(tracker.work().memory_bytes, memory);
  tracker.step({{-10.0, 20.0, 400}, {10.0, 20.0, 400}});
  const uint64_t sort_model = 4u * 2 * 2;  // 4 G bit_width(G), G = 2
  EXPECT_EQ(tracker.work().scalar_ops,
            32u + 48u * 2 + 12u * 2 + 40u * 2 * 2 + sort_model + 4u * 2 + 96u * 2 + 8u * kMaxObstacles + 8u * 2);
  EXPECT_EQ(tracker.work().memory_bytes, memory);
}

std::string kernel_error_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const KernelError& error) {
    return error.what();
  }
  return "(no KernelError)";
}

TEST(ObstacleTrackerMustFail, RefusesBadParametersAndShapes) {
  const ArmTaskDescriptor& task = tracker_task();
  const std::vector<PlaneShape> shapes = {{arm::kObstacleWords, kMaxObstacles}, {arm::kTrackWords, 1}};
  EXPECT_EQ(kernel_error_of([&] { task.prepare({{"focal_px", kFocalPx}}, shapes); }),
            "parameter 'baseline_m': expected a number > 0 (from the calibration), got none");
  const std::string period = kernel_error_of([&] {
    nlohmann::json params = base_params();
    params["frame_period_s"] = 0.0;
    task.prepare(params, shapes);
  });
  EXPECT_NE(period.find("parameter 'frame_period_s'"), std::string::npos) << period;
  EXPECT_NE(period.find("got 0"), std::string::npos) << period;
  const std::string focal = kernel_error_of([&] {
    nlohmann::json params = base_params();
    params["focal_px"] = -700.0;
    task.prepare(params, shapes);
  });
  EXPECT_NE(focal.find("parameter 'focal_px'"), std::string::npos) << focal;
  for (const char* name : {"max_missed_frames", "min_hits_for_velocity", "max_tracks"}) {
    nlohmann::json params = base_params();
    params[name] = -1;
    const std::string message = kernel_error_of([&] { task.prepare(params, shapes); });
    EXPECT_NE(message.find(std::string("parameter '") + name + "'"), std::string::npos) << message;
  }
  const std::string unknown = kernel_error_of([&] {
    nlohmann::json params = base_params();
    params["max_miss"] = 2;
    task.prepare(params, shapes);
  });
  EXPECT_NE(unknown.find("unknown parameter 'max_miss'"), std::string::npos) << unknown;
  EXPECT_EQ(kernel_error_of([&] { task.prepare(base_params(), {{23, kMaxObstacles}, {arm::kTrackWords, 1}}); }),
            "input 'obstacles': expected 24 x max_obstacles (>= 1) obstacle records, got 23x7");
}

TEST(ObstacleTrackerMustFail, RefusesAWrongOrCorruptStatePlane) {
  const ArmTaskDescriptor& task = tracker_task();
  nlohmann::json params = base_params();
  params["max_tracks"] = 4;
  const PreparedKernel prepared = task.prepare(params, {{arm::kObstacleWords, kMaxObstacles}, {arm::kTrackWords, 1}});
  const Plane obstacles = obstacle_plane({{0.0, 10.0, 100}});
  Plane tracked(arm::kObstacleWords, kMaxObstacles, {ElementType::s32, 0});
  Plane next(arm::kTrackWords, 5, {ElementType::s32, 0});
  auto run_with = [&](const Plane& previous) {
    return kernel_error_of([&] { task.run(ArmTaskArgs{{&obstacles, &previous}, {&tracked, &next}, prepared.params.get(), nullptr}); });
  };
  auto zeros = [](int width, int height) {
    Plane plane(width, height, {ElementType::s32, 0});
    for (int r = 0; r < height; ++r) {
      for (int w = 0; w < width; ++w) plane.at<int32_t>(w, r) = 0;
    }
    return plane;
  };
  EXPECT_EQ(run_with(zeros(arm::kTrackWords, 4)),
            "input 'previous_tracks': expected the 21x5 track state plane (this task's own output 'tracks', delayed; 1 + "
            "max_tracks rows), got 21x4");
  EXPECT_NE(run_with(zeros(arm::kObstacleWords, 5)).find("input 'previous_tracks'"), std::string::npos);
  Plane corrupt = zeros(arm::kTrackWords, 5);
  corrupt.at<int32_t>(arm::kTracksCount, 0) = 5;
  EXPECT_EQ(run_with(corrupt), "input 'previous_tracks': header track count expected 0 .. 4 (max_tracks), got 5");
  corrupt.at<int32_t>(arm::kTracksCount, 0) = 1;
  corrupt.at<int32_t>(arm::kTracksNextId, 0) = 3;
  corrupt.at<int32_t>(arm::kTrackId, 1) = 7;
  EXPECT_EQ(run_with(corrupt), "input 'previous_tracks': row 1 track id expected in 1 .. 2 (increasing, below the next id), got 7");
  EXPECT_EQ(run_with(zeros(arm::kTrackWords, 5)), "(no KernelError)");
}

// The task in a graph, its state on a delayed edge as the obstacle graph will wire it: the ids persist
// and the velocity converges through the scheduler's double-buffered delayed buffer.
TEST(ObstacleTrackerGraph, CarriesTracksThroughTheDelayedEdge) {
  const std::string json = R"({
    "name": "obstacle-tracker-test",
    "inputs": [{"name": "obstacles", "format": "s32"}],
    "nodes": [
      {"name": "tracker", "task": "obstacle_tracker",
       "inputs": {"obstacles": "obstacles", "previous_tracks": {"buffer": "tracks", "delayed": true}},
       "outputs": {"tracked": "tracked", "tracks": "tracks"},
       "params": {"focal_px": 1400.0, "baseline_m": 0.30, "max_tracks": 8}}
    ],
    "outputs": ["tracked", "tracks"],
    "budget": {"enforce": false, "note": "test graph"}
  })";
  Graph graph(parse_graph_spec(json, "obstacle-tracker-test"));
  VerifyOptions options;
  options.frame_width = arm::kObstacleWords;
  options.frame_height = kMaxObstacles;
  graph.verify(options);
  ASSERT_TRUE(graph.buffers()[graph.buffer_index("tracks")].read_delayed);
  arm::FrameRunner runner(graph, 1);
  for (int frame = 0; frame < 45; ++frame) {
    const double t = frame * kPeriodS;
    const Plane obstacles = obstacle_plane({{2.0 - 1.0 * t, 30.0 - 6.0 * t, 600}, {-4.0, 50.0, 300}});
    runner.process({{"obstacles", &obstacles}});
    const Plane& tracked = runner.buffer("tracked");
    EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackId), 1) << "frame " << frame;
    EXPECT_EQ(word(tracked, 1, arm::kObstacleTrackId), 2) << "frame " << frame;
    EXPECT_EQ(word(tracked, 0, arm::kObstacleTrackAgeFrames), frame + 1);
    if (frame >= 30) {
      EXPECT_NEAR(word(tracked, 0, arm::kObstacleVelocityXMmPerS), -1000.0, 100.0) << "frame " << frame;
      EXPECT_NEAR(word(tracked, 0, arm::kObstacleVelocityZMmPerS), -6000.0, 100.0) << "frame " << frame;
      EXPECT_NEAR(word(tracked, 1, arm::kObstacleVelocityZMmPerS), 0.0, 100.0) << "frame " << frame;
    }
  }
  const arm::TrackState state = arm::decode_tracks(runner.buffer("tracks"));
  EXPECT_EQ(state.frames_processed, 45);
  EXPECT_EQ(state.tracks.size(), 2u);
  EXPECT_GT(runner.arm_work().at(0).scalar_ops, 0u);
}

}  // namespace
}  // namespace lpstereo
