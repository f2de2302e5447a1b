// ARM task "obstacle_tracker": the obstacles of one frame (arm/tasks/obstacle_record.h) associated
// with the tracks of the previous frames, one constant-velocity Kalman filter per track on the ground
// plane, track ids, ages and velocities. Track state layout and encoding: arm/tasks/obstacle_tracker.h.
//
// Model. Thesis 003 §4.2.4 associates clusters over time by their pixel count and the position of
// their centroid; here the centroid is predicted by a constant-velocity Kalman filter (Kalman 1960;
// Bar-Shalom, Li, Kirubarajan 2001, "Estimation with Applications to Tracking and Navigation", §6.3.2
// "discrete white noise acceleration model") on the ground plane, state s = (x, z, vx, vz) in the
// camera frame (m, m/s), period T = frame_period_s:
//     F = [1 0 T 0; 0 1 0 T; 0 0 1 0; 0 0 0 1],
//     Q = accel_sigma_mps2^2 [T^4/4 I, T^3/2 I; T^3/2 I, T^2 I]          (Bar-Shalom §6.3.2)
// The measurement is the obstacle's foot point m = (kObstaclePositionXMm, kObstacleDistanceMm) / 1000,
// H = [I 0]. Its noise grows with distance: stereo depth z = f B / d, so by first-order propagation of
// the disparity error sigma_d (Chang, Chatterjee 1990, "Quantization error analysis in stereo
// vision"; Gallup et al. 2008, "Variable baseline/resolution stereo", CVPR, §3)
//     sigma_z = z^2 / (f B) * sigma_d,
// with f = focal_px, B = baseline_m, sigma_d = disparity_sigma_px; and x = (u - u0) z / f at a fixed
// image column u moves with z as dx/dz = x / z, plus lateral_sigma_m for the centroid's own jitter:
//     R = [lateral_sigma_m^2 + (x/z)^2 sigma_z^2, (x/z) sigma_z^2; (x/z) sigma_z^2, sigma_z^2],
// evaluated at the measurement (z clamped to >= 0.1 m). A new track starts at s = (m, 0, 0) with
// P = [R 0; 0 initial_speed_sigma_mps^2 I]. The update uses the Joseph form
// P = (I - K H) P (I - K H)^T + K R K^T (Bucy, Joseph 1968), which keeps P positive
// semi-definite despite rounding, then symmetrises it (the state plane stores the upper triangle).
//
// Steps, per frame:
//   1. decode "previous_tracks" (all zero before the first frame: no tracks, next id 1) and predict
//      every track one period ahead: s = F s, P = F P F^T + Q;
//   2. the measurable obstacles: rows with kObstacleValid = 1 and kObstacleDistanceMm > 0 (others
//      pass through untracked, track id 0);
//   3. for every (track, obstacle) pair: the innovation nu = m - H s, S = H P H^T + R, the squared
//      Mahalanobis distance d2 = nu^T S^-1 nu, the centroid distance |nu| in metres, and the relative
//      pixel-count difference r = |p - p^| / max(p, p^, 1) against the track's last pixel count scaled
//      to the predicted distance, p^ = p_last (z_last / z_pred)^2 (an object's image area goes with
//      1 / z^2). A pair is a candidate when d2 <= gate_mahalanobis_sq, |nu| <= max_centroid_distance_m
//      and r <= max_relative_pixel_difference; its cost is
//          cost = sqrt(d2 / gate_mahalanobis_sq) + pixel_weight * r
//      (both terms in [0, 1] after the gates: the centroid distance in units of its predicted
//      uncertainty, and the pixel count, thesis §4.2.4);
//   4. greedy association: candidates in increasing (cost, track id, obstacle row), each taken when
//      neither its track nor its obstacle is used yet; a matched track gets the Kalman update, hits
//      + 1, misses 0; an unmatched track misses + 1 and is removed when misses > max_missed_frames;
//      every surviving track ages by one frame;
//   5. each measurable obstacle left unmatched, in row order, starts a track with id next_id++ (ids
//      increase and are never reused within a run; the next id is kept in the state header) while
//      fewer than max_tracks are live and the id fits (ids 1 .. 2^31 - 2, so the stored next id never
//      overflows); the rest are counted in kTracksRefusedThisFrame and untracked;
//   6. "tracked" = "obstacles" with kObstacleTrackId, kObstacleTrackAgeFrames and the velocity filled:
//      the filter's (vx, 0, vz) in mm/s once the track has min_hits_for_velocity measurements (the
//      creating one included), else 0; "tracks" = the header and the tracks in increasing id order.
//
// Integer ranges: ids 1 .. 2^31 - 2 (above), age and hits saturate at 2^31 - 1 (828 days at 30 fps),
// misses <= max_missed_frames + 1; velocities are rounded to mm/s and clamped to s32 (a filter
// velocity above 2.1e6 m/s would be a corrupt state, not a measurement).
//
// Ports: "obstacles" s32 kObstacleWords x max_obstacles (rows with kObstacleValid = 1 first),
// "previous_tracks" s32 kTrackWords x (1 + max_tracks) (this task's own "tracks" over a delayed edge),
// outputs "tracked" s32 kObstacleWords x max_obstacles and "tracks" s32 kTrackWords x (1 + max_tracks).
// The previous state's shape and header are checked in run, not prepare: verify() prepares a node in
// a delayed loop once with a guessed frame-size shape.
//
// Parameters (units in the names): focal_px (> 0, required), baseline_m (> 0, required), max_tracks
// (default 64), frame_period_s (default 1/30), accel_sigma_mps2 (default 3.0), disparity_sigma_px
// (default 0.25), lateral_sigma_m (default 0.1), initial_speed_sigma_mps (default 10.0),
// gate_mahalanobis_sq (default 13.8: chi-square, 2 degrees of freedom, 0.999), max_centroid_distance_m
// (default 5.0), pixel_weight (default 0.5), max_relative_pixel_difference (default 0.75),
// max_missed_frames (default 3), min_hits_for_velocity (default 3); the defaults live in TrackerSettings
// (obstacle_tracker.h), which arm/obstacle_detector.h aggregates.
//
// Counted work (deterministic, ArmWork), with T live previous tracks, M measurable obstacles, G gated
// candidate pairs, U matched tracks, N new tracks, O = max_obstacles rows, L = 1 + max_tracks rows:
//   scalar_ops   = 32 (header) + 48 T (prediction: F P F^T + Q on the 4x4 with F's sparsity, F s)
//                  + 12 M (R) + 40 T M (pair: innovation 4, S and its inverse 12, Mahalanobis 8,
//                  pixel prediction and ratio 8, gates and cost 8)
//                  + 4 G bit_width(G) (sorting the candidates, a comparison model) + 4 G (greedy pass)
//                  + 96 U (gain 4x2, state, Joseph form) + 24 N (track start)
//                  + 8 O (record copy and track fields, per row) + 8 (T + N) (track rows stored);
//   memory_bytes = 2 * 4 kObstacleWords O (obstacles read, tracked written)
//                  + 2 * 4 kTrackWords L (previous_tracks read, tracks written).
#include "arm/tasks/obstacle_tracker.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "arm/tasks/obstacle_record.h"
#include "dag/arm_task.h"

namespace lpstereo::arm {

namespace {

// Ids run 1 .. kLastTrackId; the next id is stored in an s32 word, so after kLastTrackId no new track
// starts (a run of 2^31 - 2 tracks: at 100 new tracks per frame, 8 months at 30 fps).
constexpr int kLastTrackId = std::numeric_limits<int32_t>::max() - 1;

std::string shape_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// One track row of the state plane (layout in the header).
Track track_from_row(const int32_t* row) {
  Track track;
  track.id = row[kTrackId];
  track.age_frames = row[kTrackAgeFrames];
  track.hits = row[kTrackHits];
  track.misses = row[kTrackMisses];
  track.pixels = row[kTrackPixels];
  track.last_distance_mm = row[kTrackLastDistanceMm];
  track.obstacle_row = row[kTrackObstacleRow];
  for (int i = 0; i < 4; ++i) track.state[i] = track_float(row[kTrackXM + i]);
  int word = kTrackCovariance00;
  for (int i = 0; i < 4; ++i) {
    for (int j = i; j < 4; ++j) track.covariance[i][j] = track.covariance[j][i] = track_float(row[word++]);
  }
  return track;
}

}  // namespace

TrackState decode_tracks(const Plane& tracks) {
  if (tracks.width() != kTrackWords || tracks.height() < 1 || tracks.format().type != ElementType::s32) {
    throw std::runtime_error("track state plane: expected " + std::to_string(int(kTrackWords)) + " x (1 + max_tracks) s32, got " +
                             shape_text(tracks.width(), tracks.height()) + " " + format_name(tracks.format()));
  }
  const int32_t* header = tracks.row<const int32_t>(0);
  TrackState state;
  state.next_id = std::max(1, header[kTracksNextId]);
  state.frames_processed = header[kTracksFramesProcessed];
  state.refused_this_frame = header[kTracksRefusedThisFrame];
  const int count = header[kTracksCount];
  if (count < 0 || count > tracks.height() - 1) {
    throw std::runtime_error("track state plane: header track count expected 0 .. " + std::to_string(tracks.height() - 1) +
                             ", got " + std::to_string(count));
  }
  for (int r = 1; r <= count; ++r) state.tracks.push_back(track_from_row(tracks.row<const int32_t>(r)));
  return state;
}

namespace {

using Vector2 = Eigen::Vector2d;
using Vector4 = Eigen::Vector4d;
using Matrix2 = Eigen::Matrix2d;
using Matrix4 = Eigen::Matrix4d;
using Matrix42 = Eigen::Matrix<double, 4, 2>;

// The prepared parameters: the calibration's camera and the tuning (defaults: TrackerSettings).
struct TrackerParams : TrackerSettings {
  int max_obstacles = 0;
  double focal_px = 0.0;
  double baseline_m = 0.0;
};

// A calibration value the task cannot default: absent or not > 0 is an error naming it.
double calibration_param(const nlohmann::json& params, const char* name) {
  if (!params.is_object() || !params.contains(name)) {
    throw KernelError(std::string("parameter '") + name + "': expected a number > 0 (from the calibration), got none");
  }
  return param_double(params, name, 0.0, 1e-9, 1e9);
}

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"focal_px", "baseline_m", "max_tracks", "frame_period_s", "accel_sigma_mps2", "disparity_sigma_px",
                             "lateral_sigma_m", "initial_speed_sigma_mps", "gate_mahalanobis_sq", "max_centroid_distance_m",
                             "pixel_weight", "max_relative_pixel_difference", "max_missed_frames", "min_hits_for_velocity"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (obstacles, previous_tracks), got " + std::to_string(input_shapes.size()));
  }
  const PlaneShape& obstacles = input_shapes[0];
  if (obstacles.width != kObstacleWords || obstacles.height < 1) {
    throw KernelError("input 'obstacles': expected " + std::to_string(int(kObstacleWords)) +
                      " x max_obstacles (>= 1) obstacle records, got " + shape_text(obstacles.width, obstacles.height));
  }
  auto prepared = std::make_shared<TrackerParams>();
  TrackerParams& p = *prepared;
  p.max_obstacles = obstacles.height;
  p.focal_px = calibration_param(params, "focal_px");
  p.baseline_m = calibration_param(params, "baseline_m");
  const TrackerSettings defaults;
  p.max_tracks = param_int(params, "max_tracks", defaults.max_tracks, 1, 4096);
  p.frame_period_s = param_double(params, "frame_period_s", defaults.frame_period_s, 1e-4, 10.0);
  p.accel_sigma_mps2 = param_double(params, "accel_sigma_mps2", defaults.accel_sigma_mps2, 0.0, 100.0);
  p.disparity_sigma_px = param_double(params, "disparity_sigma_px", defaults.disparity_sigma_px, 1e-3, 100.0);
  p.lateral_sigma_m = param_double(params, "lateral_sigma_m", defaults.lateral_sigma_m, 1e-3, 100.0);
  p.initial_speed_sigma_mps = param_double(params, "initial_speed_sigma_mps", defaults.initial_speed_sigma_mps, 1e-2, 1000.0);
  p.gate_mahalanobis_sq = param_double(params, "gate_mahalanobis_sq", defaults.gate_mahalanobis_sq, 0.01, 1e6);
  p.max_centroid_distance_m = param_double(params, "max_centroid_distance_m", defaults.max_centroid_distance_m, 1e-3, 1e4);
  p.pixel_weight = param_double(params, "pixel_weight", defaults.pixel_weight, 0.0, 100.0);
  p.max_relative_pixel_difference =
      param_double(params, "max_relative_pixel_difference", defaults.max_relative_pixel_difference, 0.0, 1.0);
  p.max_missed_frames = param_int(params, "max_missed_frames", defaults.max_missed_frames, 0, 1000000);
  p.min_hits_for_velocity = param_int(params, "min_hits_for_velocity", defaults.min_hits_for_velocity, 1, 1000000);
  return PreparedKernel{prepared, {{kObstacleWords, obstacles.height}, {kTrackWords, 1 + p.max_tracks}}};
}

using RowMajorMatrix4 = Eigen::Matrix<double, 4, 4, Eigen::RowMajor>;

// The filter's view of a track's state and covariance (Track keeps them as plain arrays).
Eigen::Map<Vector4> mean_of(Track& track) { return Eigen::Map<Vector4>(track.state); }
Eigen::Map<const Vector4> mean_of(const Track& track) { return Eigen::Map<const Vector4>(track.state); }
Eigen::Map<RowMajorMatrix4> covariance_of(Track& track) { return Eigen::Map<RowMajorMatrix4>(&track.covariance[0][0]); }
Eigen::Map<const RowMajorMatrix4> covariance_of(const Track& track) {
  return Eigen::Map<const RowMajorMatrix4>(&track.covariance[0][0]);
}

struct Measurement {
  int row = 0;
  Vector2 position_m = Vector2::Zero();
  Matrix2 noise = Matrix2::Zero();  // R
  int32_t pixels = 0;
  int32_t distance_mm = 0;
};

struct Candidate {
  double cost = 0.0;
  int track = 0;        // index into the live tracks (their ids increase with the index)
  int measurement = 0;  // index into the measurements (their rows increase with the index)
  Vector2 innovation = Vector2::Zero();
  Matrix2 innovation_covariance = Matrix2::Zero();
};

// The stereo measurement noise at the foot point (x, z), header comment: sigma_z = z^2 sigma_d / (f B).
Matrix2 measurement_noise(const TrackerParams& p, double x_m, double z_m) {
  const double z = std::max(z_m, 0.1);
  const double sigma_z = z * z * p.disparity_sigma_px / (p.focal_px * p.baseline_m);
  const double variance_z = sigma_z * sigma_z;
  const double slope = x_m / z;  // dx/dz at a fixed image column
  Matrix2 noise;
  noise << p.lateral_sigma_m * p.lateral_sigma_m + slope * slope * variance_z, slope * variance_z, slope * variance_z, variance_z;
  return noise;
}

void write_track(const Track& track, int32_t* row) {
  std::fill(row, row + kTrackWords, 0);
  row[kTrackId] = track.id;
  row[kTrackAgeFrames] = track.age_frames;
  row[kTrackHits] = track.hits;
  row[kTrackMisses] = track.misses;
  row[kTrackPixels] = static_cast<int32_t>(track.pixels);
  row[kTrackLastDistanceMm] = track.last_distance_mm;
  row[kTrackObstacleRow] = track.obstacle_row;
  for (int i = 0; i < 4; ++i) row[kTrackXM + i] = track_word(static_cast<float>(track.state[i]));
  int word = kTrackCovariance00;
  for (int i = 0; i < 4; ++i) {
    for (int j = i; j < 4; ++j) row[word++] = track_word(static_cast<float>(track.covariance[i][j]));
  }
}

// The counters are s32 words: age and hits stop at INT32_MAX (2^31 - 1 frames, 828 days at 30 fps)
// instead of wrapping.
int saturating_increment(int counter) { return counter < std::numeric_limits<int32_t>::max() ? counter + 1 : counter; }

int32_t round_to_s32(double value) {
  return static_cast<int32_t>(std::llround(std::clamp(value, -2147483648.0, 2147483647.0)));
}

void run(const ArmTaskArgs& args) {
  const auto& p = *static_cast<const TrackerParams*>(args.params);
  const Plane& obstacles = *args.inputs.at(0);
  const Plane& previous = *args.inputs.at(1);
  Plane& tracked = *args.outputs.at(0);
  Plane& tracks_out = *args.outputs.at(1);
  const int state_rows = 1 + p.max_tracks;
  if (previous.width() != kTrackWords || previous.height() != state_rows) {
    throw KernelError("input 'previous_tracks': expected the " + shape_text(kTrackWords, state_rows) +
                      " track state plane (this task's own output 'tracks', delayed; 1 + max_tracks rows), got " +
                      shape_text(previous.width(), previous.height()));
  }
  if (obstacles.width() != kObstacleWords || obstacles.height() != p.max_obstacles) {
    throw KernelError("input 'obstacles': expected the prepared " + shape_text(kObstacleWords, p.max_obstacles) +
                      " obstacle records, got " + shape_text(obstacles.width(), obstacles.height()));
  }

  // 1. The previous tracks, predicted.
  const int32_t* previous_header = previous.row<const int32_t>(0);
  const int next_id_before = std::max(1, previous_header[kTracksNextId]);
  const int previous_count = previous_header[kTracksCount];
  if (previous_count < 0 || previous_count > p.max_tracks) {
    throw KernelError("input 'previous_tracks': header track count expected 0 .. " + std::to_string(p.max_tracks) + " (max_tracks), got " +
                      std::to_string(previous_count));
  }
  const double period = p.frame_period_s;
  Matrix4 transition = Matrix4::Identity();
  transition(0, 2) = transition(1, 3) = period;
  const double accel_variance = p.accel_sigma_mps2 * p.accel_sigma_mps2;
  Matrix4 process_noise = Matrix4::Zero();
  for (int axis = 0; axis < 2; ++axis) {
    process_noise(axis, axis) = accel_variance * std::pow(period, 4) / 4.0;
    process_noise(axis, axis + 2) = process_noise(axis + 2, axis) = accel_variance * std::pow(period, 3) / 2.0;
    process_noise(axis + 2, axis + 2) = accel_variance * period * period;
  }
  std::vector<Track> live;
  live.reserve(previous_count);
  int last_id = 0;
  for (int r = 1; r <= previous_count; ++r) {
    Track track = track_from_row(previous.row<const int32_t>(r));
    if (track.id <= last_id || track.id >= next_id_before) {
      throw KernelError("input 'previous_tracks': row " + std::to_string(r) + " track id expected in " + std::to_string(last_id + 1) +
                        " .. " + std::to_string(next_id_before - 1) + " (increasing, below the next id), got " +
                        std::to_string(track.id));
    }
    last_id = track.id;
    mean_of(track) = transition * mean_of(track);
    covariance_of(track) = transition * covariance_of(track) * transition.transpose() + process_noise;
    track.obstacle_row = -1;
    live.push_back(track);
  }
  uint64_t ops = 32 + 48ull * live.size();

  // 2. The measurable obstacles.
  std::vector<Measurement> measurements;
  for (int r = 0; r < p.max_obstacles; ++r) {
    const int32_t* record = obstacles.row<const int32_t>(r);
    if (record[kObstacleValid] != 1 || record[kObstacleDistanceMm] <= 0) continue;
    Measurement measurement;
    measurement.row = r;
    measurement.position_m = Vector2(record[kObstaclePositionXMm] * 1e-3, record[kObstacleDistanceMm] * 1e-3);
    measurement.noise = measurement_noise(p, measurement.position_m(0), measurement.position_m(1));
    measurement.pixels = record[kObstaclePixels];
    measurement.distance_mm = record[kObstacleDistanceMm];
    measurements.push_back(measurement);
  }
  ops += 12ull * measurements.size();

  // 3. Gated candidate pairs and their costs.
  std::vector<Candidate> candidates;
  for (int t = 0; t < static_cast<int>(live.size()); ++t) {
    const Track& track = live[t];
    const Vector2 predicted = mean_of(track).head<2>();
    const double predicted_pixels =
        track.last_distance_mm > 0 && predicted(1) > 0.0
            ? track.pixels * std::pow(track.last_distance_mm * 1e-3 / predicted(1), 2)
            : static_cast<double>(track.pixels);
    for (int m = 0; m < static_cast<int>(measurements.size()); ++m) {
      const Measurement& measurement = measurements[m];
      Candidate candidate;
      candidate.track = t;
      candidate.measurement = m;
      candidate.innovation = measurement.position_m - predicted;
      candidate.innovation_covariance = covariance_of(track).topLeftCorner<2, 2>() + measurement.noise;
      const double mahalanobis_sq =
          candidate.innovation.dot(candidate.innovation_covariance.inverse() * candidate.innovation);
      const double distance_m = candidate.innovation.norm();
      const double relative_pixels = std::abs(measurement.pixels - predicted_pixels) /
                                     std::max({static_cast<double>(measurement.pixels), predicted_pixels, 1.0});
      if (mahalanobis_sq <= p.gate_mahalanobis_sq && distance_m <= p.max_centroid_distance_m &&
          relative_pixels <= p.max_relative_pixel_difference) {
        candidate.cost = std::sqrt(mahalanobis_sq / p.gate_mahalanobis_sq) + p.pixel_weight * relative_pixels;
        candidates.push_back(candidate);
      }
    }
  }
  ops += 40ull * live.size() * measurements.size();

  // 4. Greedy association, deterministic order; the Kalman update of each match.
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    if (a.cost != b.cost) return a.cost < b.cost;
    if (a.track != b.track) return a.track < b.track;
    return a.measurement < b.measurement;
  });
  const uint64_t gated = candidates.size();
  ops += 4ull * gated * std::bit_width(gated) + 4ull * gated;
  std::vector<int> measurement_track(measurements.size(), -1);
  std::vector<bool> track_used(live.size(), false);
  Eigen::Matrix<double, 2, 4> observation = Eigen::Matrix<double, 2, 4>::Zero();
  observation(0, 0) = observation(1, 1) = 1.0;
  for (const Candidate& candidate : candidates) {
    if (track_used[candidate.track] || measurement_track[candidate.measurement] >= 0) continue;
    track_used[candidate.track] = true;
    measurement_track[candidate.measurement] = candidate.track;
    Track& track = live[candidate.track];
    const Measurement& measurement = measurements[candidate.measurement];
    const Matrix4 covariance = covariance_of(track);
    const Matrix42 gain = covariance * observation.transpose() * candidate.innovation_covariance.inverse();
    mean_of(track) += gain * candidate.innovation;
    const Matrix4 reduction = Matrix4::Identity() - gain * observation;
    const Matrix4 joseph = reduction * covariance * reduction.transpose() + gain * measurement.noise * gain.transpose();
    covariance_of(track) = 0.5 * (joseph + joseph.transpose());
    track.hits = saturating_increment(track.hits);
    track.misses = 0;
    track.pixels = measurement.pixels;
    track.last_distance_mm = measurement.distance_mm;
    track.obstacle_row = measurement.row;
    ops += 96;
  }
  std::vector<Track> surviving;
  for (int t = 0; t < static_cast<int>(live.size()); ++t) {
    Track& track = live[t];
    track.age_frames = saturating_increment(track.age_frames);
    if (!track_used[t]) track.misses += 1;
    if (track.misses <= p.max_missed_frames) surviving.push_back(track);
  }

  // 5. New tracks for the unmatched measurable obstacles, in row order, while there is room.
  int next_id = next_id_before;
  int refused = 0;
  int created = 0;
  for (int m = 0; m < static_cast<int>(measurements.size()); ++m) {
    if (measurement_track[m] >= 0) continue;
    if (static_cast<int>(surviving.size()) >= p.max_tracks || next_id == kLastTrackId + 1) {
      ++refused;
      continue;
    }
    const Measurement& measurement = measurements[m];
    Track track;
    track.id = next_id++;
    track.age_frames = 1;
    track.hits = 1;
    track.misses = 0;
    track.pixels = measurement.pixels;
    track.last_distance_mm = measurement.distance_mm;
    track.obstacle_row = measurement.row;
    mean_of(track) << measurement.position_m(0), measurement.position_m(1), 0.0, 0.0;
    covariance_of(track).topLeftCorner<2, 2>() = measurement.noise;
    track.covariance[2][2] = track.covariance[3][3] = p.initial_speed_sigma_mps * p.initial_speed_sigma_mps;
    surviving.push_back(track);
    ++created;
  }
  ops += 24ull * created;

  // 6. The records and the state plane.
  for (int r = 0; r < p.max_obstacles; ++r) {
    const int32_t* source = obstacles.row<const int32_t>(r);
    int32_t* record = tracked.row<int32_t>(r);
    std::copy(source, source + kObstacleWords, record);
    if (record[kObstacleValid] != 1) continue;
    record[kObstacleTrackId] = 0;
    record[kObstacleTrackAgeFrames] = 0;
    record[kObstacleVelocityXMmPerS] = record[kObstacleVelocityYMmPerS] = record[kObstacleVelocityZMmPerS] = 0;
  }
  ops += 8ull * p.max_obstacles;
  int32_t* header = tracks_out.row<int32_t>(0);
  std::fill(header, header + kTrackWords, 0);
  header[kTracksNextId] = next_id;
  header[kTracksCount] = static_cast<int32_t>(surviving.size());
  header[kTracksFramesProcessed] = saturating_increment(previous_header[kTracksFramesProcessed]);
  header[kTracksRefusedThisFrame] = refused;
  for (int t = 0; t < p.max_tracks; ++t) {
    int32_t* row = tracks_out.row<int32_t>(1 + t);
    if (t >= static_cast<int>(surviving.size())) {
      std::fill(row, row + kTrackWords, 0);
      continue;
    }
    const Track& track = surviving[t];
    write_track(track, row);
    if (track.obstacle_row < 0) continue;
    int32_t* record = tracked.row<int32_t>(track.obstacle_row);
    record[kObstacleTrackId] = track.id;
    record[kObstacleTrackAgeFrames] = track.age_frames;
    if (track.hits >= p.min_hits_for_velocity) {
      record[kObstacleVelocityXMmPerS] = round_to_s32(track.state[2] * 1000.0);
      record[kObstacleVelocityZMmPerS] = round_to_s32(track.state[3] * 1000.0);
    }
  }
  ops += 8ull * (live.size() + created);
  if (args.work != nullptr) {
    args.work->scalar_ops += ops;
    args.work->memory_bytes += 2ull * 4 * kObstacleWords * p.max_obstacles + 2ull * 4 * kTrackWords * state_rows;
  }
}

ArmTaskDescriptor make_obstacle_tracker() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "obstacle_tracker";
  descriptor.summary =
      "obstacles tracked across frames: greedy association by predicted centroid (Mahalanobis-gated) and pixel count, a "
      "constant-velocity Kalman filter per track on the ground plane, track ids, ages and velocities; state over a delayed edge";
  descriptor.ports = {{"obstacles", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"previous_tracks", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"tracked", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole},
                      {"tracks", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(obstacle_tracker, lpstereo::arm::make_obstacle_tracker);
