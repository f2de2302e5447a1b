// The track state plane the ARM task "obstacle_tracker" (arm/tasks/obstacle_tracker.cpp) writes as
// its output "tracks" and reads back over a delayed edge as "previous_tracks" in the next frame: s32
// words (BufferFormat {s32, 0}), kTrackWords wide and 1 + max_tracks rows. Row 0 is the header, rows
// 1 .. kTracksCount the live tracks in increasing id order, the rows after them all zero. An all-zero
// plane (what a delayed buffer holds before the first frame) is "no tracks yet, next id 1".
//
// Encoding. Integer words (ids, counts, pixels, mm) are plain s32. The Kalman filter's state and
// covariance are IEEE-754 binary32 floats stored bit for bit in s32 words (std::bit_cast), SI units
// (m, m/s, m^2, m^2/s, m^2/s^2). Why floats and not a Q format: the covariance spans ~10 decades
// within one track (a far track's depth variance ~10 m^2, a converged velocity variance ~1e-3
// m^2/s^2, their cross terms, and the intermediate products of F P F^T and the gain), so no single Q
// format holds all entries without overflow or losing the small ones, and per-entry exponents would be
// a hand-made float. The ARM cores have FPUs (the ARM tasks already compute in double); the task
// computes in double and rounds to binary32 only when it stores: 24 mantissa bits give ~10 um at
// 150 m and a relative 6e-8 on every variance, far below the filter's own noise. A +0.0f float is the
// all-zero s32 word, so the zero plane is a valid empty state.
//
// Frame: camera frame (DESIGN.md §4: x right, z forward); the filter runs on the ground plane (x, z),
// so the reported y velocity is 0.
#pragma once

#include <bit>
#include <cstdint>
#include <vector>

#include "dag/plane.h"

namespace lpstereo::arm {

// Row 0.
enum TrackHeaderWord : int {
  kTracksNextId = 0,           // the id the next new track gets; 0 before the first frame (read as 1)
  kTracksCount = 1,            // live tracks in rows 1 .. kTracksCount
  kTracksFramesProcessed = 2,  // frames the tracker has run, this one included
  kTracksRefusedThisFrame = 3, // obstacles that got no track this frame because max_tracks were live
};

// Rows 1 .. kTracksCount: one track each.
enum TrackWord : int {
  kTrackId = 0,             // >= 1, increasing, never reused within a run
  kTrackAgeFrames = 1,      // frames the track has existed, this one included (1 when created)
  kTrackHits = 2,           // frames with a measurement, the creating one included
  kTrackMisses = 3,         // consecutive frames without a measurement up to this one (0 when matched)
  kTrackPixels = 4,         // the pixel count (kObstaclePixels) of the last matched obstacle
  kTrackLastDistanceMm = 5, // the distance (kObstacleDistanceMm) of the last matched obstacle
  kTrackObstacleRow = 6,    // row of this frame's obstacle it was matched to or created from; -1 if missed
  // Filter state after this frame (updated when matched, predicted only when missed), binary32 bits:
  kTrackXM = 7,             // lateral position x, m
  kTrackZM = 8,             // forward distance z, m
  kTrackVxMPerS = 9,        // velocity, m/s
  kTrackVzMPerS = 10,
  // Covariance of (x, z, vx, vz), the upper triangle by rows, binary32 bits:
  kTrackCovariance00 = 11,  // var x, m^2
  kTrackCovariance01 = 12,  // cov x z, m^2
  kTrackCovariance02 = 13,  // cov x vx, m^2/s
  kTrackCovariance03 = 14,  // cov x vz
  kTrackCovariance11 = 15,  // var z, m^2
  kTrackCovariance12 = 16,  // cov z vx
  kTrackCovariance13 = 17,  // cov z vz, m^2/s
  kTrackCovariance22 = 18,  // var vx, m^2/s^2
  kTrackCovariance23 = 19,  // cov vx vz
  kTrackCovariance33 = 20,  // var vz, m^2/s^2
  kTrackWords = 21,
};

inline float track_float(int32_t word) { return std::bit_cast<float>(word); }
inline int32_t track_word(float value) { return std::bit_cast<int32_t>(value); }

struct Track {
  int id = 0;
  int age_frames = 0;
  int hits = 0;
  int misses = 0;
  int64_t pixels = 0;
  int last_distance_mm = 0;
  int obstacle_row = -1;
  double state[4] = {0, 0, 0, 0};       // x m, z m, vx m/s, vz m/s
  double covariance[4][4] = {};          // full symmetric matrix
};

struct TrackState {
  int next_id = 1;
  int frames_processed = 0;
  int refused_this_frame = 0;
  std::vector<Track> tracks;  // in row order (increasing id)
};

// The tracker's tuning (arm/tasks/obstacle_tracker.cpp documents each): the task's own defaults
// (prepare reads them from here) and the struct arm/obstacle_detector.h aggregates, so the detector,
// the CLI and the task share one set of values. focal_px and baseline_m come from the calibration.
struct TrackerSettings {
  int max_tracks = 64;
  double frame_period_s = 1.0 / 30.0;
  double accel_sigma_mps2 = 3.0;
  double disparity_sigma_px = 0.25;
  double lateral_sigma_m = 0.1;
  double initial_speed_sigma_mps = 10.0;
  double gate_mahalanobis_sq = 13.8;  // chi-square, 2 degrees of freedom, 0.999
  double max_centroid_distance_m = 5.0;
  double pixel_weight = 0.5;
  double max_relative_pixel_difference = 0.75;
  int max_missed_frames = 3;
  int min_hits_for_velocity = 3;
};

// Decodes a track state plane (kTrackWords wide, >= 1 row, s32). Throws std::runtime_error on another
// shape or a header that counts more tracks than the plane has rows.
TrackState decode_tracks(const Plane& tracks);

}  // namespace lpstereo::arm
