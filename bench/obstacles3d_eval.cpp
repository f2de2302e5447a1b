// obstacles3d_eval: issue 10's acceptance measurements on synthetic sequences. An evaluation program,
// not a test (it renders and processes whole sequences; the figures are printed, the lines checked at
// the end).
//
// For each preset scene (io::preset_stereo_sequence: urban, country, mining, floating) and seed,
// render_sequence_frame renders --frames 640x480 frames with exact ground truth; per frame the
// `lpstereo obstacles3d` pipeline runs once (arm::DisparityEngine, 64 disparities; arm::triangulate;
// arm::CameraToVehicle with the synthetic mount; the 2.5D grid, fit_terrain and classify_points: the
// points more than 0.2 m above the fitted terrain are the candidates, but for those on the far side
// of a nearer surface's edge, arm/obstacles3d/obstacle_candidates.h) and feeds the same candidates to
// all five methods side by side: occupancy grids polar, cartesian, coldisp, the augmented stixels and
// the voxel map + colour clustering + Kalman tracking (0.25 m voxels, 3 acceptance frames). As the
// command by default: the ego-motion from arm::StereoOdometry (its camera increment t -> t-1 in the
// vehicle frame, V E V^-1; a frame whose odometry fails is bridged with the last valid increment
// for up to 5 frames, else static camera assumed: arm/obstacles3d/ego_motion.h, as the command;
// both counted and printed, with the odometry's per-frame error against the true increment) and the candidates coloured from the left colour view (the voxel clustering is colour-
// based). Options measure the methods apart from the odometry (--ego-motion truth: the sequence's
// true camera motion) or on grey (--grey: the grey image as the colour).
// The scoring rules below (the gate, the measurable pixels, the lower edge seen, the hanging part's
// report, the free space) are eval/obstacles3d_scoring.h, tested on hand-built cases in
// tests/eval/obstacles3d_scoring_test.cpp; this program keeps the tallies, the logs and the tables.
//
// Measured (objects: >= --min-pixels measurable pixels and base-centre depth <= --range-m; a pixel of
// the object is measurable when its true disparity lies in the engine's range [min, min + count - 1]
// and its match u - d is inside the right image and not covered there by a nearer surface (see
// eval::measurable_pixels): objects nearer than f B / 63 px (2.6 m here), seen only in the left border
// that the right camera does not see, or hidden from the right camera behind a nearer object (a board
// at 28 m showing its end beside a near board's edge to the left camera only) cannot be measured by
// any stereo method, and are counted apart as "unmeasurable" (the last printed apart as "half-occluded");
// --all-visible counts every object with
// visible_pixels >= --min-pixels instead; objects lower than the candidates' obstacle height, 0.2 m
// above the terrain (the mining scene's 7 cm tape roll), are no obstacle by the definition,
// "obstacle candidates are the terrain's outliers" above it, and are counted apart as "below obstacle
// height"; --count-low counts them):
//   detection rate  an object counts as detected in a frame when an obstacle's centre lies within its
//                   gate: |dx| <= 1 m + width / 2 and |dz| <= max(1 m, 3 sigma_Z(z)) + length / 2
//                   (camera frame, truth = base centre; sigma_Z = z^2 0.25 px / (f B)). Line: polar and
//                   stixels >= 99 % on every scene.
//   false positives obstacles within --range-m whose centre lies in no object's gate (any object of
//                   the frame's truth, visible or not), per frame; printed apart also for the frames
//                   whose view is at least 1 % nearer than the engine's search range reaches
//                   (eval::view_partly_nearer_than_range: the floating camera driving into a board)
//                   and for the others.
//   floating        for board_on_poles, hanging_sign, ball_on_post whose lower edge is seen (at least
//                   max(10, 25 %) of the pixels of the hanging part's lowest 10 cm across its width,
//                   by the true disparity and the true ground, are measurable; others, the sign's or
//                   a board's bottom hidden behind a nearer board, are printed apart as "lower edge
//                   hidden", not scored for the edge nor the free space; --score-hidden-edges scores
//                   them): the report of the hanging part,
//                   of the obstacles in the object's gate whose height interval spans 0.2 m above
//                   the truth's lower edge (inside every hanging part: a board's and a sign's 0.7 m,
//                   a ball's 0.4 m) the one with the highest min_height_m, against the truth's
//                   min_height_m; when none spans it, the in-gate obstacle with the highest
//                   min_height_m (|error| <= 10 cm counted; line: stixels within 10 cm in >= 90 % of
//                   the frames the object is seen). The probe keeps out what is not a report of the
//                   hanging part: a fragment of a sign's arm and post top 2.6-3.0 m high beside a
//                   sign reported at 1.9-2.7 m, mismatches 2.4-6.4 m high over a 1.6 m board. Printed
//                   beside it, not in the line: the former rule, the highest min_height_m in the gate
//                   whatever it spans; "free under" = no obstacle in the inner part of a board's gate
//                   (|dx| <= width / 2 - 0.3 m, away from the posts) with min_height_m below the truth's
//                   lower edge - 10 cm (line: stixels keep it in >= 99 % of the frames; the ball has a
//                   post under it: not counted). The grid methods are printed beside it.
//   moving          voxels only: each detected object's `moving` flag against the truth's, read from
//                   the nearest in-gate obstacle that shows the object in the image (the object id
//                   with most pixels in its box), else from the nearest in-gate obstacle
//                   (eval::moving_scored_obstacle: gates overlap, and a pedestrian walking behind a
//                   parked car was the car's nearest obstacle); TP rate over the truly moving, FP
//                   rate over the static (line: TP >= 90 %, FP <= 10 %); velocity error |v - v_true|
//                   over x and z (mean, median) on truly moving objects matched by a confirmed track.
//                   Printed beside: the former rule, the nearest in-gate obstacle whatever it shows;
//                   and the settled object-frames only (eval::CountedRuns: the object counted in more
//                   than 6 frames in a row, voxels_bench's rule: no track can be "moving" earlier).
//
// Usage: obstacles3d_eval [--frames N] [--seeds N] [--scenes urban,country,mining,floating]
//        [--min-pixels P] [--range-m R] [--ego-motion vo|truth] [--grey] [--threads N] [--first-seed S]
//        [--frame-cache DIR] [--misses FILE.csv] [--moving-log FILE.csv] [--surface-errors FILE.csv] [--all-visible] [--count-low] [--score-hidden-edges] [--vertical-gap-m G]
//        [--hole-membrane H] [--obstacle-refit-m H] [--local-ground on|off] [--local-ground-reach N]
//        [--innovation-gate-chi2 X] [--moving-disparity-bias PX] [--moving-significance-chi2 X] [--accel-sigma A]
//        [--moving-consistency N] [--feature-motion on|off] [--feature-motion-min N] [--feature-motion-sigma MPS]
//        [--feature-disparity-sigma PX]
//        [--occlusion-upper-bounds on|off] [--occluder-rows N] [--occluder-jump J] [--upper-bound-tolerance-m T]
//        [--far-side-rows N] [--far-side-columns N] [--far-side-jump J] [--ground-below-view upper-bounds|samples]
//        [--num-disparities N] [--multires-far F] [--discontinuity-radius R] [--discontinuity-jump J]
// (--threads: the rendering's, the disparity engine's and the odometry's worker threads, default 2;
// --first-seed: seeds S .. S + N - 1, default 1; --misses: one CSV row per missed object and per false
// positive of every method, with the nearest obstacle, and per hanging object whose reported lower
// edge is off by more than 10 cm (lower_edge_high / lower_edge_low, with the in-gate obstacle of the
// highest lower edge) or whose free space is lost (free_space_lost, with the first obstacle under
// it), for finding out why; --frame-cache DIR: frames 1.. read from DIR when it holds them, else
// rendered and written there (io/sequence_frame_cache.h; the same bits, a rerun about 7x faster);
// --feature-motion off: the voxel tracker without the odometry's feature motion (obstacle_tracking.h,
// "Feature motion"; --feature-motion-min, --feature-motion-sigma, --feature-disparity-sigma set its
// parameters); --moving-log: one CSV row
// per object-frame the voxels detected, with the truth's motion and the reported track's flag,
// velocity and update count, for finding out why a flag is wrong; --surface-errors: one CSV row per
// valid cell of the candidates' 2.5D grid per frame (about 2000 a frame at 640x480: --frames limits
// it), its measured, equalised and fitted height against the true ground under the cell centre, for
// telling a terrain lift under a hanging object from the stixels' own error; --vertical-gap-m: the
// terrain's 2.5D sampling leaves out of a cell the points above a vertical gap wider than G, default
// the TerrainGridSpec's (off), arm/terrain/height_grid.cpp; --hole-membrane: the candidates' terrain
// fit's membrane over holes (TerrainFitParameters::hole_membrane); --obstacle-refit-m: its obstacle
// refit (TerrainFitParameters::obstacle_refit_height_m, default off); --local-ground: the candidates
// measured from the terrain inliers around them where the surface stands above them (CandidateParameters::
// local_ground_reference, default the CandidateParameters'), --local-ground-reach its window's half
// width in cells (arm/obstacles3d/local_ground.h); --occlusion-upper-bounds: the
// occlusion-aware sampling of the candidates' terrain (grid.occlusion_upper_bounds, default the
// CandidateParameters'), --occluder-rows / --occluder-jump its image test (arm::OccluderTest),
// --upper-bound-tolerance-m the fit's one-sided tolerance; --far-side-rows / --far-side-columns /
// --far-side-jump: the candidates' test of the far side of a nearer surface's edge (arm::FarSideTest,
// CandidateParameters::far_side; rows and columns 0 turn it off); --ground-below-view: the cells whose
// ground lies below the image are upper bounds (the default, CandidateParameters::
// ground_below_view_upper_bounds) or plain samples; --num-disparities: the engine's range, default
// the command's 64; --multires-far F: F px at full resolution and the whole range again at half
// resolution (arm::DisparityParameters::multires_far_disparities), 0: one full-resolution pass over
// the range (the default); `--num-disparities 128 --multires-far 64` is the near guard of
// docs/obstacles3d.md; the "measurable" rule follows the range.)
// Exit 0 when every line is met, 1 otherwise (the issue wants >= 300 frames and several seeds).
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "arm/disparity_engine.h"
#include "arm/odometry/stereo_odometry.h"
#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/disparity_coverage.h"
#include "arm/obstacles3d/ego_motion.h"
#include "arm/obstacles3d/obstacle_candidates.h"
#include "arm/obstacles3d/obstacle_tracking.h"
#include "arm/obstacles3d/occupancy_grid.h"
#include "arm/obstacles3d/voxel_clustering.h"
#include "arm/obstacles3d/voxel_map.h"
#include "arm/point_cloud.h"
#include "arm/terrain/terrain_model.h"
#include "arm/terrain_points.h"
#include "eval/obstacles3d_scoring.h"
#include "bench/number_argument.h"
#include "io/image_io.h"
#include "io/sequence_frame_cache.h"
#include "io/stereo_sequence.h"
#include "kernels/disparity_to_points.h"
#include "bench/heap_setting.h"

namespace {

using namespace lpstereo;
using bench::number_argument;
namespace o3 = arm::obstacles3d;

constexpr int kMethods = 5;
const char* const kMethodNames[kMethods] = {"polar", "cartesian", "coldisp", "stixels", "voxels"};

struct Settings {
  int frames = 30;
  int seeds = 1;
  std::vector<std::string> scenes{"urban", "country", "mining", "floating"};
  int64_t min_pixels = 200;
  bool all_visible = false;  // --all-visible: count objects by visible, not measurable, pixels
  bool count_low = false;    // --count-low: also count objects lower than the candidates' obstacle height
  bool score_hidden_edges = false;  // --score-hidden-edges: score a hanging object's lower edge even when it is not measurable
  double range_m = 30;
  bool true_ego_motion = false;  // --ego-motion truth; default vo (arm::StereoOdometry, as the command)
  bool colour = true;            // --grey: candidates coloured from the grey image instead
  int threads = 2;
  int first_seed = 1;
  std::string misses_path;  // --misses: the CSV of misses and false positives, empty: none
  std::string frame_cache;  // --frame-cache: a folder of rendered frames (io/sequence_frame_cache.h), empty: render every frame
  std::string moving_path;  // --moving-log: the CSV of the voxels' moving flag per counted object-frame, empty: none
  std::string surface_path;  // --surface-errors: the CSV of the candidates' terrain against the true ground per cell, empty: none
  // The candidates' parameters: the command's defaults (--obstacle-height-m 0.2) but the grid's
  // vertical_gap_m (--vertical-gap-m). One source for the candidates and for the "too low" rule of
  // the scoring.
  o3::CandidateParameters candidates;
  // The voxel tracker's moving decision, robust update and process noise (--innovation-gate-chi2,
  // --moving-consistency, --moving-disparity-bias, --moving-significance-chi2, --accel-sigma): the defaults of ObstacleTrackingParameters unless given.
  o3::ObstacleTrackingParameters tracking;
  // The disparity engine: the command's (o3::obstacles3d_disparity_defaults: 64 px, one
  // full-resolution pass) unless --num-disparities or --multires-far is given (--num-disparities 128
  // --multires-far 64: o3::obstacles3d_near_guard_disparity_parameters, measured and not the
  // default; --multires-far 0: one full-resolution pass over the range).
  arm::DisparityParameters disparity = o3::obstacles3d_disparity_defaults();
  // --discontinuity-radius R (0: off, the chain's default) and --discontinuity-jump J: the terrain's
  // filter (arm::invalidate_near_side_of_discontinuities, lpstereo terrain's settings when R > 0) on
  // the map the points and candidates are made from; the view check still reads the engine's map.
  arm::DiscontinuityFilter discontinuity{0, arm::DiscontinuityFilter{}.jump_px};
};

// Where the rows of --misses go, and which sequence frame is being scored.
struct MissLog {
  std::FILE* file = nullptr;
  std::FILE* moving_file = nullptr;                 // --moving-log
  std::FILE* surface_file = nullptr;                // --surface-errors
  const o3::ObstacleTracker3d* tracker = nullptr;  // for the moving log's track columns
  std::string scene;
  uint32_t seed = 0;
  int frame = 0;
};

struct Tally {  // per method
  int64_t visible = 0, detected = 0, false_positives = 0, frames = 0;
  // Frames whose view is partly nearer than the search range (eval::view_partly_nearer_than_range)
  // and their false positives, printed apart.
  int64_t nearer_view_frames = 0, nearer_view_false_positives = 0;
  int64_t unmeasurable = 0;  // visible and in range, but too few measurable pixels: not counted
  int64_t half_occluded = 0;  // of those, the ones with enough pixels before the right-view occlusion test
  int64_t below_obstacle_height = 0;  // measurable, but lower than the candidates' obstacle height: not counted
  // floating objects
  int64_t floating_seen = 0, floating_within = 0, free_checked = 0, free_kept = 0;
  int64_t edge_hidden = 0;  // detected hanging objects whose lower edge is not measurable: not scored for it
  std::vector<double> floating_error_m;
  // The former rule, printed beside: the in-gate obstacle with the highest lower edge, whatever
  // heights it spans (a fragment of a sign's arm above the sign counts).
  int64_t floating_within_any = 0;
  std::vector<double> floating_error_any_m;
  // moving (voxels)
  int64_t moving_total = 0, moving_flagged = 0, static_total = 0, static_flagged = 0;
  int64_t moving_flagged_nearest = 0, static_flagged_nearest = 0;  // the former rule: the nearest in-gate obstacle
  // The same on the settled object-frames only (eval::CountedRuns: counted in more than
  // eval::kMovingSettleFrames frames in a row), printed beside.
  int64_t moving_total_settled = 0, moving_flagged_settled = 0, static_total_settled = 0, static_flagged_settled = 0;
  std::vector<double> velocity_error_mps;
  void add(const Tally& o) {
    visible += o.visible, detected += o.detected, false_positives += o.false_positives, frames += o.frames;
    nearer_view_frames += o.nearer_view_frames, nearer_view_false_positives += o.nearer_view_false_positives;
    unmeasurable += o.unmeasurable, half_occluded += o.half_occluded, below_obstacle_height += o.below_obstacle_height;
    floating_seen += o.floating_seen, floating_within += o.floating_within, free_checked += o.free_checked, free_kept += o.free_kept;
    edge_hidden += o.edge_hidden;
    floating_error_m.insert(floating_error_m.end(), o.floating_error_m.begin(), o.floating_error_m.end());
    floating_within_any += o.floating_within_any;
    floating_error_any_m.insert(floating_error_any_m.end(), o.floating_error_any_m.begin(), o.floating_error_any_m.end());
    moving_total += o.moving_total, moving_flagged += o.moving_flagged, static_total += o.static_total, static_flagged += o.static_flagged;
    moving_flagged_nearest += o.moving_flagged_nearest, static_flagged_nearest += o.static_flagged_nearest;
    moving_total_settled += o.moving_total_settled, moving_flagged_settled += o.moving_flagged_settled;
    static_total_settled += o.static_total_settled, static_flagged_settled += o.static_flagged_settled;
    velocity_error_mps.insert(velocity_error_mps.end(), o.velocity_error_mps.begin(), o.velocity_error_mps.end());
  }
};

double percent(int64_t part, int64_t whole) { return whole > 0 ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0; }

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + static_cast<long>(values.size() / 2), values.end());
  return values[values.size() / 2];
}

// The q-quantile (0..1) by the nearest rank; 0 for no values.
double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t rank = static_cast<size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank > 0 ? rank - 1 : 0)];
}

double mean(const std::vector<double>& values) {
  double sum = 0;
  for (double v : values) sum += v;
  return values.empty() ? 0 : sum / static_cast<double>(values.size());
}

// One --misses row: scene, seed, frame, method, kind (miss | false_positive), then the object's truth
// (class, id, camera-frame x z, visible pixels; empty for a false positive) and an obstacle (for a
// miss: the nearest one by ground distance, in or out of the gate; for a false positive: itself), its
// x z, size w h l, min and max height above the terrain.
void log_row(const MissLog& log, const char* method, const char* kind, const io::SequenceObjectTruth* object, int64_t measurable,
             const o3::Obstacle3d* obstacle) {
  if (log.file == nullptr) return;
  std::fprintf(log.file, "%s,%u,%d,%s,%s,", log.scene.c_str(), log.seed, log.frame, method, kind);
  if (object != nullptr) {
    std::fprintf(log.file, "%s,%d,%.2f,%.2f,%lld,%lld,", io::synth_class_name(object->truth.object.object_class), object->truth.id,
                 object->truth.position_m[0], object->truth.position_m[2], static_cast<long long>(object->truth.visible_pixels),
                 static_cast<long long>(measurable));
  } else {
    std::fprintf(log.file, ",,,,,,");
  }
  if (obstacle != nullptr) {
    std::fprintf(log.file, "%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f\n", obstacle->position_m.x(), obstacle->position_m.z(), obstacle->size_m.x(),
                 obstacle->size_m.y(), obstacle->size_m.z(), obstacle->min_height_m, obstacle->max_height_m);
  } else {
    std::fprintf(log.file, ",,,,,,\n");
  }
}

// One --moving-log row per counted object-frame of the voxels (detected, so a nearest in-gate
// obstacle exists): scene, seed, frame, the object's truth (id, class, moving, x z, ground velocity vx
// vz in camera axes), the scored obstacle (eval::moving_scored_obstacle: track id, reported moving
// flag, x z, velocity vx vz) and its track (updates, its own moving flag: differs from the reported
// one when adopted), then the nearest in-gate obstacle's track id and moving flag (the former rule).
void log_moving_row(const MissLog& log, const io::SequenceObjectTruth& object, const o3::Obstacle3d& obstacle, const o3::Obstacle3d& nearest,
                    int frames_counted_in_row) {
  if (log.moving_file == nullptr) return;
  int updates = -1, own_moving = -1;
  if (log.tracker != nullptr) {
    for (const o3::Track3d& track : log.tracker->tracks()) {
      if (track.id == obstacle.track_id) updates = track.updates, own_moving = track.moving ? 1 : 0;
    }
  }
  std::fprintf(log.moving_file, "%s,%u,%d,%d,%s,%d,%.2f,%.2f,%.2f,%.2f,%d,%d,%.2f,%.2f,%.2f,%.2f,%d,%d,%d,%d,%d\n", log.scene.c_str(), log.seed, log.frame,
               object.truth.id, io::synth_class_name(object.truth.object.object_class), object.moving ? 1 : 0, object.truth.position_m[0],
               object.truth.position_m[2], object.velocity_mps[0], object.velocity_mps[2], obstacle.track_id, obstacle.moving ? 1 : 0,
               obstacle.position_m.x(), obstacle.position_m.z(), obstacle.velocity_mps.x(), obstacle.velocity_mps.z(), updates, own_moving,
               nearest.track_id, nearest.moving ? 1 : 0, frames_counted_in_row);
}

// The --surface-errors rows of one frame: every valid cell (measured or filled) of the candidates'
// 2.5D grid, with the true ground under its centre (the probe's io::SynthGroundTruth, through the
// frame's camera pose) subtracted from the measured cell height, the equalised one (the sample the
// fit's last iteration used) and the fitted surface, all at the cell centre. Signed, metres: + =
// above the true ground. No rows for a frame whose terrain is unknown. What tells a terrain lift
// under a hanging object (a lower edge read low) from the stixels' own estimate.
void log_surface_errors(const MissLog& log, const o3::CandidatePoints& candidates, const eval::LowerEdgeProbe& probe,
                        const Eigen::Isometry3d& camera_from_vehicle) {
  if (log.surface_file == nullptr || !candidates.terrain.known) return;
  const arm::terrain::HeightGrid& measured = candidates.measured_grid;
  const arm::terrain::TerrainEstimate& terrain = candidates.terrain;
  const Eigen::Isometry3d road_from_vehicle = probe.road_from_camera * camera_from_vehicle;
  const auto above_true_ground = [&](double x_m, double y_m, double z_m) {
    return probe.height_above_true_ground_m(road_from_vehicle * Eigen::Vector3d(x_m, y_m, z_m));
  };
  const bool marked = measured.upper_bound.size() != 0;
  for (int i = 0; i < measured.spec.forward_cells(); ++i) {
    const double x_m = measured.spec.cell_centre_x_m(i);
    for (int j = 0; j < measured.spec.lateral_cells(); ++j) {
      const int state = measured.state(i, j);
      if (state == arm::terrain::kCellInvalid) continue;
      const double y_m = measured.spec.cell_centre_y_m(j);
      const double surface_m = terrain.surface.height_m(x_m, y_m);
      if (!std::isfinite(surface_m)) continue;
      std::fprintf(log.surface_file, "%s,%u,%d,%.2f,%.2f,%s,%d,%d,%.1f,%.3f,%.3f,%.3f\n", log.scene.c_str(), log.seed, log.frame, x_m, y_m,
                   state == arm::terrain::kCellMeasured ? "measured" : "filled", measured.point_count(i, j),
                   marked && measured.upper_bound(i, j) != 0 ? 1 : 0, terrain.weights(i, j),
                   above_true_ground(x_m, y_m, measured.height_m(i, j)), above_true_ground(x_m, y_m, terrain.grid.height_m(i, j)),
                   above_true_ground(x_m, y_m, surface_m));
    }
  }
}

// Whether an object counts in a frame's scoring, and if not, why (the tallies' "unmeasured",
// "half-occluded" and "too low" rows).
enum class ObjectCount { out_of_view, unmeasurable, half_occluded, too_low, counted };
ObjectCount count_object(const io::SequenceObjectTruth& object, const eval::MeasurablePixels& measurable, const Settings& settings) {
  if (object.truth.visible_pixels < settings.min_pixels || object.truth.position_m[2] > settings.range_m) return ObjectCount::out_of_view;
  if (!settings.all_visible && measurable.measurable_of(object.truth.id) < settings.min_pixels) {
    return measurable.in_range_of(object.truth.id) >= settings.min_pixels ? ObjectCount::half_occluded : ObjectCount::unmeasurable;
  }
  // The same obstacle height as the candidates run_sequence made.
  if (!settings.count_low && object.truth.max_height_m < settings.candidates.obstacle_height_m) return ObjectCount::too_low;
  return ObjectCount::counted;
}

// What every method of a frame is scored against, worked out once per frame.
struct FrameTruth {
  const io::StereoSequenceFrame& frame;
  const eval::MeasurablePixels& measurable;
  const eval::CountedRuns& runs;  // the moving flag's settled object-frames
  bool nearer_view = false;       // eval::view_partly_nearer_than_range
};

void score_frame(const std::vector<o3::Obstacle3d>& obstacles, const FrameTruth& truth, const o3::StereoErrorModel& error_model,
                 const Settings& settings, bool is_voxels, const char* method, const MissLog& log, Tally& tally) {
  const io::StereoSequenceFrame& frame = truth.frame;
  const eval::MeasurablePixels& measurable = truth.measurable;
  const bool nearer_view = truth.nearer_view;
  ++tally.frames;
  if (nearer_view) ++tally.nearer_view_frames;
  for (const o3::Obstacle3d& obstacle : obstacles) {
    if (obstacle.position_m.z() > settings.range_m) continue;
    bool matched = false;
    for (const io::SequenceObjectTruth& object : frame.objects) {
      matched = matched || eval::in_gate(obstacle, object.truth, eval::gate_of(object.truth, error_model));
    }
    if (!matched) {
      ++tally.false_positives;
      if (nearer_view) ++tally.nearer_view_false_positives;
      log_row(log, method, "false_positive", nullptr, 0, &obstacle);
    }
  }
  for (const io::SequenceObjectTruth& object : frame.objects) {
    const ObjectCount count = count_object(object, measurable, settings);
    if (count == ObjectCount::out_of_view) continue;
    const int64_t measurable_count = measurable.measurable_of(object.truth.id);
    if (count == ObjectCount::unmeasurable || count == ObjectCount::half_occluded) {
      ++tally.unmeasurable;
      if (count == ObjectCount::half_occluded) ++tally.half_occluded;
      continue;
    }
    if (count == ObjectCount::too_low) {
      ++tally.below_obstacle_height;
      continue;
    }
    ++tally.visible;
    const eval::ObstacleGate gate = eval::gate_of(object.truth, error_model);
    // In the gate: the nearest obstacle; anywhere: the nearest (what --misses reports for a miss).
    const o3::Obstacle3d* nearest = nullptr;
    const o3::Obstacle3d* nearest_anywhere = nullptr;
    double nearest_distance = 1e9, nearest_anywhere_m = 1e9;
    for (const o3::Obstacle3d& obstacle : obstacles) {
      const double distance = std::hypot(obstacle.position_m.x() - object.truth.position_m[0], obstacle.position_m.z() - object.truth.position_m[2]);
      if (distance < nearest_anywhere_m) nearest_anywhere_m = distance, nearest_anywhere = &obstacle;
      if (!eval::in_gate(obstacle, object.truth, gate)) continue;
      if (distance < nearest_distance) nearest_distance = distance, nearest = &obstacle;
    }
    if (!nearest) {
      log_row(log, method, "miss", &object, measurable_count, nearest_anywhere);
      continue;
    }
    ++tally.detected;
    const bool floating = eval::is_floating(object.truth.object.object_class);
    // The hanging part's lowest band not measurable (behind a nearer object): no method sees its
    // lower edge, nor the space under it; counted apart.
    const bool edge_hidden = floating && !settings.score_hidden_edges &&
                             !eval::lower_edge_seen(measurable.lower_edge_of(object.truth.id), object.truth, error_model.focal_px);
    if (edge_hidden) ++tally.edge_hidden;
    if (floating && !edge_hidden) {
      ++tally.floating_seen;
      const eval::HangingObjectScore score = eval::score_hanging_object(obstacles, object.truth, gate);
      tally.floating_error_m.push_back(score.error_m);
      if (score.within_tolerance()) {
        ++tally.floating_within;
      } else {
        log_row(log, method, score.error_m > 0 ? "lower_edge_high" : "lower_edge_low", &object, measurable_count, score.scored);
      }
      tally.floating_error_any_m.push_back(score.highest_lower_edge_error_m);
      if (std::abs(score.highest_lower_edge_error_m) <= eval::kLowerEdgeToleranceM) ++tally.floating_within_any;
      if (score.free_space_checked) {
        ++tally.free_checked;
        if (score.free_space_kept()) {
          ++tally.free_kept;
        } else {
          log_row(log, method, "free_space_lost", &object, measurable_count, score.under);
        }
      }
    }
    if (is_voxels) {
      const o3::Obstacle3d* scored = eval::moving_scored_obstacle(obstacles, object.truth, gate, frame.scene.object_ids);
      log_moving_row(log, object, *scored, *nearest, truth.runs.frames_in_row(object.truth.id));
      const bool settled = truth.runs.settled(object.truth.id);
      if (object.moving) {
        ++tally.moving_total;
        if (scored->moving) ++tally.moving_flagged;
        if (nearest->moving) ++tally.moving_flagged_nearest;
        if (settled) ++tally.moving_total_settled, tally.moving_flagged_settled += scored->moving ? 1 : 0;
        if (scored->track_id >= 0) {
          tally.velocity_error_mps.push_back(
              std::hypot(scored->velocity_mps.x() - object.velocity_mps[0], scored->velocity_mps.z() - object.velocity_mps[2]));
        }
      } else {
        ++tally.static_total;
        if (scored->moving) ++tally.static_flagged;
        if (nearest->moving) ++tally.static_flagged_nearest;
        if (settled) ++tally.static_total_settled, tally.static_flagged_settled += scored->moving ? 1 : 0;
      }
    }
  }
}

std::vector<Tally> evaluate(const std::string& scene, uint32_t seed, const Settings& settings, std::FILE* log_file, std::FILE* moving_file,
                            std::FILE* surface_file) {
  io::StereoSequenceOptions options = io::preset_stereo_sequence(scene, seed);
  options.frames = settings.frames;
  options.base.colour = settings.colour;
  options.base.threads = settings.threads;
  io::validate_stereo_sequence(options);
  const io::StereoSynthOptions& base = options.base;
  const int width = base.width, height = base.height;

  const arm::DisparityParameters& disparity_parameters = settings.disparity;
  arm::DisparityEngine engine(width, height, disparity_parameters, {}, settings.threads);
  const double cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
  // Wall-clock time of the rendering and of the rest (printed per sequence: what a run costs).
  using Clock = std::chrono::steady_clock;
  double render_s = 0, pipeline_s = 0;
  auto seconds_since = [](Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); };
  Clock::time_point started = Clock::now();
  const io::StereoSequenceFrame first = io::render_sequence_frame(options, 0);
  render_s += seconds_since(started);
  // --frame-cache: frames 1.. read from the cache when it holds them, else rendered and written there
  // (io/sequence_frame_cache.h: the same bits either way; frame 0, rendered always, keys the cache).
  const uint64_t cache_key = settings.frame_cache.empty() ? 0 : io::sequence_cache_key(options, first);
  int cached_frames = 0;
  auto obtain_frame = [&](int n) {
    if (n == 0) return first;
    if (settings.frame_cache.empty()) return io::render_sequence_frame(options, n);
    const std::string path = io::sequence_frame_cache_path(settings.frame_cache, cache_key, n);
    io::StereoSequenceFrame frame;
    std::string problem;
    const io::CachedFrame cached = io::read_cached_sequence_frame(path, cache_key, n, first.scene.calibration, frame, &problem);
    if (cached == io::CachedFrame::loaded) {
      ++cached_frames;
      return frame;
    }
    if (cached == io::CachedFrame::damaged) std::fprintf(stderr, "obstacles3d_eval: --frame-cache: %s; rendering it again\n", problem.c_str());
    frame = io::render_sequence_frame(options, n);
    io::write_cached_sequence_frame(path, cache_key, n, frame);
    return frame;
  };
  const double focal_px = first.scene.focal_px;
  const io::SynthGroundTruth ground_truth(base);  // the lower-edge probe's true ground height
  const arm::TriangulationParameters triangulation{base.baseline_m, focal_px, cx, cy, disparity_parameters.min_disparity,
                                                   disparity_parameters.num_disparities, 0};
  arm::CameraMount mount;
  mount.roll_rad = base.roll_rad;
  mount.pitch_rad = base.pitch_rad;
  mount.position_m = Eigen::Vector3d(0, 0, base.camera_height_m);
  const arm::CameraToVehicle to_vehicle(mount);
  const o3::CandidateParameters& candidate_parameters = settings.candidates;
  const Eigen::Isometry3d vehicle_from_camera = to_vehicle.vehicle_from_camera();
  const Eigen::Isometry3d camera_from_vehicle = vehicle_from_camera.inverse();

  arm::StereoOdometryParameters odometry_parameters;  // the command's (tools/obstacles3d_command.cpp)
  odometry_parameters.focal_px = focal_px;
  odometry_parameters.principal_point_x_px = cx;
  odometry_parameters.principal_point_y_px = cy;
  odometry_parameters.baseline_m = base.baseline_m;
  std::unique_ptr<arm::StereoOdometry> odometry;
  if (!settings.true_ego_motion) odometry = std::make_unique<arm::StereoOdometry>(width, height, odometry_parameters, settings.threads);
  // Odometry dropouts after the first frame, and of them those the constant-velocity bridge did not
  // cover (static camera assumed; arm/obstacles3d/ego_motion.h).
  int frames_without_ego_motion = 0, frames_static_camera = 0;
  int64_t feature_velocity_updates = 0;  // the voxel tracker's velocity measurements from the odometry's feature motion
  int frames_implausible = 0;  // valid increments the plausibility bound rejected (bridged)
  std::unique_ptr<o3::OdometryEgoMotion> odometry_ego_motion;
  if (odometry) {
    o3::OdometryEgoMotionParameters ego_motion_parameters;  // the command's (tools/obstacles3d_command.cpp)
    ego_motion_parameters.frame_period_s = 1.0 / options.fps;
    odometry_ego_motion = std::make_unique<o3::OdometryEgoMotion>(ego_motion_parameters);
  }
  std::string frames_without_ego_motion_list;  // their numbers, printed
  std::vector<double> odometry_translation_error_m, odometry_rotation_error_deg;  // per frame with an increment
  double odometry_worst_error_m = 0;
  int odometry_worst_frame = -1;

  o3::StereoErrorModel error_model;
  error_model.focal_px = focal_px;
  error_model.baseline_m = base.baseline_m;
  std::vector<std::unique_ptr<o3::OccupancyGrid>> grids;
  const o3::GridKind kinds[3] = {o3::GridKind::polar, o3::GridKind::cartesian, o3::GridKind::column_disparity};
  auto grid_parameters = [&](o3::GridKind kind) {
    o3::OccupancyGridParameters parameters = o3::OccupancyGridParameters::defaults(kind, width);
    parameters.error_model = error_model;
    parameters.principal_u_px = cx;
    parameters.vehicle_from_camera = vehicle_from_camera;
    return parameters;
  };
  for (o3::GridKind kind : kinds) grids.push_back(std::make_unique<o3::OccupancyGrid>(grid_parameters(kind)));
  o3::AugmentedStixelParameters stixel_parameters;
  stixel_parameters.grid = grid_parameters(o3::GridKind::polar);
  o3::AugmentedStixels stixels(stixel_parameters);
  o3::VoxelMapParameters map_parameters;
  map_parameters.voxel_size_m = 0.25;
  map_parameters.view_half_angle_rad = std::atan2(width / 2.0, focal_px);
  o3::VoxelMap voxel_map(map_parameters);
  o3::VoxelClusteringParameters clustering;
  clustering.image_width_px = width;
  clustering.image_height_px = height;
  clustering.candidate_forward_max_m = candidate_parameters.grid.forward_max_m;  // the command's (voxel_clustering.h)
  o3::validate_clustering_parameters(clustering);
  o3::ObstacleTrackingParameters tracking = settings.tracking;
  tracking.frame_period_s = 1.0 / options.fps;
  tracking.stereo_error = error_model;
  tracking.camera_mount = mount;
  tracking.acceptance_frames = 3;
  o3::ObstacleTracker3d tracker(tracking);

  std::vector<Tally> tallies(kMethods);
  MissLog log{log_file, moving_file, surface_file, &tracker, scene, seed, 0};
  eval::CountedRuns counted_runs;  // the moving flag's settled object-frames
  // The view check (arm/obstacles3d/disparity_coverage.h) against the truth, printed per sequence.
  int nearer_view_frames = 0, other_frames = 0, degraded_nearer_view = 0, degraded_other = 0;
  std::string degraded_other_list, missed_nearer_view_list;
  io::SynthCameraPose previous_pose = first.pose;
  for (int n = 0; n < settings.frames; ++n) {
    log.frame = n;
    started = Clock::now();
    const io::StereoSequenceFrame frame = obtain_frame(n);
    render_s += seconds_since(started);
    started = Clock::now();
    const Plane left = io::mat_to_plane(frame.scene.left, BufferFormat{ElementType::u8});
    const Plane right = io::mat_to_plane(frame.scene.right, BufferFormat{ElementType::u8});
    const Plane& disparity = engine.compute(left, right);
    Plane filtered;
    if (settings.discontinuity.radius_px > 0) {
      filtered = disparity.clone();
      settings.discontinuity.apply(filtered, engine.invalid_disparity_q4());
    }
    const Plane& point_disparity = settings.discontinuity.radius_px > 0 ? filtered : disparity;
    const arm::CameraPoints camera = arm::triangulate(point_disparity, triangulation);
    const o3::CandidatePoints candidate_points =
        o3::extract_obstacle_candidates(point_disparity, engine.invalid_disparity_q4(), camera, triangulation, left,
                                        settings.colour ? o3::ColourView{frame.scene.left_colour.data, frame.scene.left_colour.step, true}
                                                        : o3::ColourView{},
                                        to_vehicle, candidate_parameters);
    const std::vector<o3::ObstaclePoint>& candidates = candidate_points.points;
    // Ego-motion (t -> t-1) in the vehicle frame, V E V^-1: the odometry's increment (the command's)
    // or the sequence's true camera motion.
    o3::EgoMotion ego_motion;
    std::vector<arm::FeatureMotion> feature_motions;  // the tracker's evidence, on frames whose ego-motion is the odometry's increment
    if (odometry) {
      arm::StereoOdometryFrame motion = odometry->process(left, right);
      ego_motion = odometry_ego_motion->next(motion.statistics.valid, motion.increment, vehicle_from_camera);
      if (odometry_ego_motion->source() == o3::EgoMotionSource::odometry) feature_motions = std::move(motion.feature_motions);
      if (n > 0 && motion.statistics.valid && odometry_ego_motion->rejected_implausible()) {
        ++frames_implausible;
        frames_without_ego_motion_list += (frames_without_ego_motion_list.empty() ? " (frames " : ", ") + std::to_string(n) + ": " +
                                          odometry_ego_motion->note();
      }
      if (n > 0 && motion.statistics.valid) {
        // The odometry's error against the true camera increment (printed per sequence).
        const Eigen::Isometry3d truth = io::camera_previous_from_current(previous_pose, frame.pose);
        const Eigen::Isometry3d error = truth.inverse() * motion.increment;
        odometry_translation_error_m.push_back(error.translation().norm());
        if (error.translation().norm() > odometry_worst_error_m) odometry_worst_error_m = error.translation().norm(), odometry_worst_frame = n;
        odometry_rotation_error_deg.push_back(Eigen::AngleAxisd(error.linear()).angle() * 180.0 / M_PI);
      } else if (n > 0) {
        ++frames_without_ego_motion;
        if (odometry_ego_motion->source() == o3::EgoMotionSource::static_camera) ++frames_static_camera;
        frames_without_ego_motion_list += (frames_without_ego_motion_list.empty() ? " (frames " : ", ") + std::to_string(n) + ": " +
                                          std::to_string(motion.statistics.inliers) + " inliers of " +
                                          std::to_string(motion.statistics.circle_matches) + " circles, " +
                                          std::to_string(motion.statistics.stereo_matches) + " stereo matches";
      }
    } else if (n > 0) {
      ego_motion.available = true;
      ego_motion.previous_from_current =
          vehicle_from_camera * io::camera_previous_from_current(previous_pose, frame.pose) * vehicle_from_camera.inverse();
    }
    previous_pose = frame.pose;
    eval::LowerEdgeProbe probe;
    probe.focal_px = focal_px, probe.cx_px = cx, probe.cy_px = cy, probe.baseline_m = base.baseline_m;
    probe.camera_height_m = base.camera_height_m;
    probe.road_from_camera = io::road_from_camera(frame.pose);
    probe.ground = &ground_truth;
    for (const io::SequenceObjectTruth& object : frame.objects) probe.add_part(object.truth);
    log_surface_errors(log, candidate_points, probe, camera_from_vehicle);
    const eval::MeasurablePixels measurable =
        eval::measurable_pixels(frame.scene, disparity_parameters.min_disparity, disparity_parameters.num_disparities, &probe);
    // The command's view check against the truth's frames partly nearer than the range.
    const bool degraded =
        o3::disparity_coverage(disparity, engine.invalid_disparity_q4(), o3::DisparityCoverageParameters{}).degraded;
    const bool nearer_view = eval::view_partly_nearer_than_range(measurable, static_cast<int64_t>(frame.scene.object_ids.total()));
    (nearer_view ? nearer_view_frames : other_frames) += 1;
    (nearer_view ? degraded_nearer_view : degraded_other) += degraded ? 1 : 0;
    if (degraded && !nearer_view) degraded_other_list += (degraded_other_list.empty() ? "" : ", ") + std::to_string(n);
    if (!degraded && nearer_view) missed_nearer_view_list += (missed_nearer_view_list.empty() ? "" : ", ") + std::to_string(n);
    std::vector<int> counted_ids;
    for (const io::SequenceObjectTruth& object : frame.objects) {
      if (count_object(object, measurable, settings) == ObjectCount::counted) counted_ids.push_back(object.truth.id);
    }
    counted_runs.next_frame(counted_ids);
    const FrameTruth frame_truth{frame, measurable, counted_runs, nearer_view};
    for (int g = 0; g < 3; ++g) {
      grids[static_cast<size_t>(g)]->update(candidates, ego_motion);
      score_frame(grids[static_cast<size_t>(g)]->obstacles(), frame_truth, error_model, settings, false, kMethodNames[g], log,
                  tallies[static_cast<size_t>(g)]);
    }
    stixels.update(candidates, ego_motion);
    score_frame(stixels.obstacles(), frame_truth, error_model, settings, false, kMethodNames[3], log, tallies[3]);
    voxel_map.update(candidates, ego_motion);
    const o3::ClusteringResult clusters = o3::cluster_voxels(voxel_map, clustering);
    const o3::TrackingResult& tracks = tracker.update(clusters.clusters, voxel_map.world_from_current(), feature_motions);
    feature_velocity_updates += tracks.feature_velocity_updates;
    score_frame(tracks.obstacles, frame_truth, error_model, settings, true, kMethodNames[4], log, tallies[4]);
    pipeline_s += seconds_since(started);
  }
  std::printf("%-9s seed %u: %d frames %s in %.1f s (%.2f s a frame), processed and scored in %.1f s (%.2f s a frame), wall clock\n",
              scene.c_str(), seed, settings.frames, settings.frame_cache.empty() ? "rendered" : "rendered or read from the cache", render_s, render_s / settings.frames, pipeline_s, pipeline_s / settings.frames);
  if (!settings.frame_cache.empty()) {
    std::printf("%-9s seed %u: %d of %d frames read from --frame-cache %s (key %016llx), the others rendered and written there\n", scene.c_str(),
                seed, cached_frames, settings.frames, settings.frame_cache.c_str(), static_cast<unsigned long long>(cache_key));
  }
  std::printf("%-9s seed %u: view degraded (>= %.0f %% of the disparities invalid) in %d of the %d frames with >= %.0f %% of the view nearer "
              "than the search range (missed: %s) and in %d of the %d others (%s)\n",
              scene.c_str(), seed, 100.0 * o3::DisparityCoverageParameters{}.degraded_invalid_share, degraded_nearer_view, nearer_view_frames,
              100.0 * eval::kNearerThanRangeShare, missed_nearer_view_list.empty() ? "none" : missed_nearer_view_list.c_str(), degraded_other,
              other_frames, degraded_other_list.empty() ? "none" : degraded_other_list.c_str());
  if (odometry) {
    if (!frames_without_ego_motion_list.empty()) frames_without_ego_motion_list += ")";
    std::printf("%-9s seed %u: visual odometry failed in %d of %d frames after the first and was implausible in %d%s; bridged with the "
                "last increment in %d, static camera assumed in %d\n",
                scene.c_str(), seed, frames_without_ego_motion, settings.frames - 1, frames_implausible, frames_without_ego_motion_list.c_str(),
                frames_without_ego_motion + frames_implausible - frames_static_camera, frames_static_camera);
    std::printf("%-9s seed %u: visual odometry error per frame against the true increment: translation median %.3f m, 95th pct %.3f m, max "
                "%.3f m (frame %d); rotation median %.3f deg, max %.3f deg\n",
                scene.c_str(), seed, median(odometry_translation_error_m), percentile(odometry_translation_error_m, 0.95),
                percentile(odometry_translation_error_m, 1.0), odometry_worst_frame, median(odometry_rotation_error_deg), percentile(odometry_rotation_error_deg, 1.0));
    std::printf("%-9s seed %u: voxel tracker: %lld velocity measurements from the odometry's feature motion\n", scene.c_str(), seed,
                static_cast<long long>(feature_velocity_updates));
  }
  return tallies;
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

// One CSV output of the eval (--misses, --moving-log): nothing when its path is empty; on a failure
// the file is removed, so no half-written file stays.
struct CsvOutput {
  const char* option;
  std::string path;
  std::FILE* file = nullptr;
  bool created = false;  // this run created the file (only then may discard remove it)
  CsvOutput(const char* option_name, std::string file_path) : option(option_name), path(std::move(file_path)) {}
  bool open(const char* header) {
    if (path.empty()) return true;
    file = std::fopen(path.c_str(), "w");
    if (file == nullptr) {
      std::fprintf(stderr, "obstacles3d_eval: %s: cannot write '%s': %s\n", option, path.c_str(), std::strerror(errno));
      return false;
    }
    created = true;
    std::fputs(header, file);
    return true;
  }
  bool close() {
    if (file == nullptr) return true;
    const bool written = std::fclose(file) == 0;
    file = nullptr;
    if (!written) std::fprintf(stderr, "obstacles3d_eval: %s: writing '%s' failed\n", option, path.c_str());
    return written;
  }
  void discard() {
    if (file != nullptr) std::fclose(file), file = nullptr;
    if (created) std::remove(path.c_str());
    created = false;
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::printf("heap: %s\n", lpstereo::bench::keep_freed_heap_memory_setting().c_str());
  Settings settings;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    // The next argument is one of the two words (an on|off or upper-bounds|samples option).
    const auto next_is_one_of = [&](const char* first, const char* second) {
      return has_value && (std::strcmp(argv[i + 1], first) == 0 || std::strcmp(argv[i + 1], second) == 0);
    };
    if (arg == "--frames" && has_value) {
      settings.frames = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--seeds" && has_value) {
      settings.seeds = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--scenes" && has_value) {
      settings.scenes = split_list(argv[++i]);
    } else if (arg == "--min-pixels" && has_value) {
      settings.min_pixels = static_cast<long long>(number_argument(i, argc, argv));
    } else if (arg == "--range-m" && has_value) {
      settings.range_m = number_argument(i, argc, argv);
    } else if (arg == "--ego-motion" && has_value) {
      const std::string source = argv[++i];
      if (source != "vo" && source != "truth") {
        std::fprintf(stderr, "obstacles3d_eval: --ego-motion: expected vo or truth, got '%s'\n", source.c_str());
        return 2;
      }
      settings.true_ego_motion = source == "truth";
    } else if (arg == "--all-visible") {
      settings.all_visible = true;
    } else if (arg == "--count-low") {
      settings.count_low = true;
    } else if (arg == "--score-hidden-edges") {
      settings.score_hidden_edges = true;
    } else if (arg == "--grey") {
      settings.colour = false;
    } else if (arg == "--threads" && has_value) {
      settings.threads = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--first-seed" && has_value) {
      settings.first_seed = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--misses" && has_value) {
      settings.misses_path = argv[++i];
    } else if (arg == "--frame-cache" && has_value) {
      settings.frame_cache = argv[++i];
    } else if (arg == "--moving-log" && has_value) {
      settings.moving_path = argv[++i];
    } else if (arg == "--surface-errors" && has_value) {
      settings.surface_path = argv[++i];
    } else if (arg == "--innovation-gate-chi2" && has_value) {
      settings.tracking.innovation_gate_chi2 = number_argument(i, argc, argv);
    } else if (arg == "--moving-significance-chi2" && has_value) {
      settings.tracking.moving_significance_chi2 = number_argument(i, argc, argv);
    } else if (arg == "--moving-disparity-bias" && has_value) {
      settings.tracking.moving_disparity_bias_px = number_argument(i, argc, argv);
    } else if (arg == "--accel-sigma" && has_value) {
      settings.tracking.accel_sigma_mps2 = number_argument(i, argc, argv);
    } else if (arg == "--feature-motion" && has_value) {
      const std::string value = argv[++i];
      if (value != "on" && value != "off") {
        std::fprintf(stderr, "obstacles3d_eval: --feature-motion: expected on or off, got '%s'\n", value.c_str());
        return 2;
      }
      settings.tracking.feature_motion_min_features = value == "on" ? o3::ObstacleTrackingParameters{}.feature_motion_min_features : 0;
    } else if (arg == "--feature-motion-min" && has_value) {
      settings.tracking.feature_motion_min_features = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--feature-motion-sigma" && has_value) {
      settings.tracking.feature_motion_sigma_mps = number_argument(i, argc, argv);
    } else if (arg == "--feature-disparity-sigma" && has_value) {
      settings.tracking.feature_disparity_sigma_px = number_argument(i, argc, argv);
    } else if (arg == "--moving-consistency" && has_value) {
      settings.tracking.moving_consistency_frames = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--discontinuity-radius" && has_value) {
      settings.discontinuity.radius_px = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--discontinuity-jump" && has_value) {
      settings.discontinuity.jump_px = number_argument(i, argc, argv);
    } else if (arg == "--vertical-gap-m" && has_value) {
      settings.candidates.grid.vertical_gap_m = number_argument(i, argc, argv);
    } else if (arg == "--hole-membrane" && has_value) {
      settings.candidates.fit.hole_membrane = number_argument(i, argc, argv);
    } else if (arg == "--local-ground" && next_is_one_of("on", "off")) {
      settings.candidates.local_ground_reference = std::string(argv[++i]) == "on";
    } else if (arg == "--local-ground-reach" && has_value) {
      settings.candidates.local_ground.reach_cells = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--obstacle-refit-m" && has_value) {
      settings.candidates.fit.obstacle_refit_height_m = number_argument(i, argc, argv);
    } else if (arg == "--occlusion-upper-bounds" && next_is_one_of("on", "off")) {
      settings.candidates.grid.occlusion_upper_bounds = std::string(argv[++i]) == "on";
    } else if (arg == "--ground-below-view" && next_is_one_of("upper-bounds", "samples")) {
      settings.candidates.ground_below_view_upper_bounds = std::string(argv[++i]) == "upper-bounds";
    } else if (arg == "--occluder-rows" && has_value) {
      settings.candidates.occluder.rows_below_px = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--far-side-rows" && has_value) {
      settings.candidates.far_side.rows_above_px = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--far-side-columns" && has_value) {
      settings.candidates.far_side.columns_beside_px = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--far-side-jump" && has_value) {
      settings.candidates.far_side.jump_px = number_argument(i, argc, argv);
    } else if (arg == "--occluder-jump" && has_value) {
      settings.candidates.occluder.jump_px = number_argument(i, argc, argv);
    } else if (arg == "--num-disparities" && has_value) {
      settings.disparity.num_disparities = static_cast<int>(number_argument(i, argc, argv));
    } else if (arg == "--multires-far" && has_value) {
      const int far_disparities = static_cast<int>(number_argument(i, argc, argv));
      settings.disparity.multires = far_disparities != 0;
      if (far_disparities != 0) settings.disparity.multires_far_disparities = far_disparities;
    } else if (arg == "--upper-bound-tolerance-m" && has_value) {
      settings.candidates.fit.upper_bound_tolerance_m = number_argument(i, argc, argv);
    } else {
      std::fprintf(stderr,
                   "obstacles3d_eval: unknown or incomplete argument '%s'\nusage: obstacles3d_eval [--frames N] [--seeds N] "
                   "[--scenes urban,country,mining,floating] [--min-pixels P] [--range-m R] [--ego-motion vo|truth] [--grey] [--threads N] [--first-seed S] [--all-visible] "
                   "[--count-low] [--score-hidden-edges] [--frame-cache DIR] [--misses FILE.csv] [--moving-log FILE.csv] [--surface-errors FILE.csv] [--vertical-gap-m G] [--discontinuity-radius R] [--discontinuity-jump J] [--hole-membrane H] [--obstacle-refit-m H] [--local-ground on|off] [--local-ground-reach N] [--innovation-gate-chi2 X] [--moving-disparity-bias PX] [--moving-significance-chi2 X] [--accel-sigma A] "
                   "[--moving-consistency N] [--feature-motion on|off] [--feature-motion-min N] [--feature-motion-sigma MPS] [--feature-disparity-sigma PX] [--occlusion-upper-bounds on|off] [--occluder-rows N] "
                   "[--occluder-jump J] [--upper-bound-tolerance-m T] [--far-side-rows N] [--far-side-columns N] [--far-side-jump J] "
                   "[--ground-below-view upper-bounds|samples] [--num-disparities N] [--multires-far F]\n",
                   arg.c_str());
      return 2;
    }
  }
  if (settings.frames < 2 || settings.seeds < 1 || settings.scenes.empty() || !(settings.range_m > 0) || settings.threads < 1 ||
      settings.threads > 64 || settings.first_seed < 0) {
    std::fprintf(stderr,
                 "obstacles3d_eval: expected --frames >= 2, --seeds >= 1, a scene, --range-m > 0, --threads in [1, 64] and --first-seed >= 0, "
                 "got %d, %d, %zu, %.2f, %d, %d\n",
                 settings.frames, settings.seeds, settings.scenes.size(), settings.range_m, settings.threads, settings.first_seed);
    return 2;
  }
  try {
    // a bad --vertical-gap-m, --occluder-rows, --occluder-jump, --far-side-rows, --far-side-columns, --far-side-jump or --local-ground-reach:
    // one line naming it, before any file is written
    settings.candidates.grid.validate();
    settings.candidates.occluder.validate();
    settings.candidates.far_side.validate();
    settings.candidates.local_ground.validate();
    if (!(settings.candidates.fit.upper_bound_tolerance_m >= 0) || !std::isfinite(settings.candidates.fit.upper_bound_tolerance_m)) {
      throw std::invalid_argument("upper_bound_tolerance_m: expected a finite value >= 0, got " +
                                  std::to_string(settings.candidates.fit.upper_bound_tolerance_m));
    }
    if (!(settings.candidates.fit.hole_membrane >= 0) || !std::isfinite(settings.candidates.fit.hole_membrane)) {
      throw std::invalid_argument("hole_membrane: expected a finite value >= 0, got " + std::to_string(settings.candidates.fit.hole_membrane));
    }
    if (!(settings.candidates.fit.obstacle_refit_height_m >= 0) || !std::isfinite(settings.candidates.fit.obstacle_refit_height_m)) {
      throw std::invalid_argument("obstacle_refit_height_m: expected a finite value >= 0, got " +
                                  std::to_string(settings.candidates.fit.obstacle_refit_height_m));
    }
    o3::validate_tracking_parameters(settings.tracking);  // a bad --innovation-gate-chi2, --accel-sigma or --moving-consistency, the same
    if (settings.discontinuity.radius_px < 0 || settings.discontinuity.radius_px > 32 || !(settings.discontinuity.jump_px > 0) ||
        !std::isfinite(settings.discontinuity.jump_px)) {
      throw std::invalid_argument("--discontinuity-radius/--discontinuity-jump: expected a radius in [0, 32] px and a jump > 0 px, got " +
                                  std::to_string(settings.discontinuity.radius_px) + " and " + std::to_string(settings.discontinuity.jump_px));
    }
    const int image_width = io::preset_stereo_sequence(settings.scenes.front(), static_cast<uint32_t>(settings.first_seed)).base.width;
    if (settings.disparity.num_disparities < 1 || settings.disparity.num_disparities > image_width) {
      throw std::invalid_argument("--num-disparities: expected 1.." + std::to_string(image_width) + " (the image's width), got " +
                                  std::to_string(settings.disparity.num_disparities));
    }
    arm::DisparityEngine::graph_spec(settings.disparity);  // a bad --multires-far: the engine's own check
  } catch (const std::exception& error) {
    std::fprintf(stderr, "obstacles3d_eval: %s\n", error.what());
    return 2;
  }
  CsvOutput misses("--misses", settings.misses_path), moving_log("--moving-log", settings.moving_path),
      surface_errors("--surface-errors", settings.surface_path);
  if (!misses.open("scene,seed,frame,method,kind,class,id,truth_x_m,truth_z_m,visible_pixels,measurable_pixels,obstacle_x_m,obstacle_z_m,"
                   "width_m,height_m,length_m,min_height_m,max_height_m\n") ||
      !moving_log.open("scene,seed,frame,id,class,moving,truth_x_m,truth_z_m,truth_vx_mps,truth_vz_mps,track_id,flagged_moving,obstacle_x_m,"
                       "obstacle_z_m,vx_mps,vz_mps,track_updates,track_own_moving,nearest_track_id,nearest_flagged_moving,frames_counted_in_row\n") ||
      !surface_errors.open("scene,seed,frame,forward_m,lateral_m,cell,points,upper_bound,weight,cell_error_m,equalised_error_m,"
                           "surface_error_m\n")) {
    misses.discard();
    moving_log.discard();
    return 2;
  }
  std::printf("obstacles3d_eval: %d frames per sequence (the issue wants >= 300), seeds %d..%d, 640x480, ego-motion %s, candidates "
              "coloured from the %s image, %d thread(s); terrain: hole membrane %.2f, obstacle refit %.2f m, occlusion upper bounds %s (%d rows, jump %.2f px, tolerance %.2f m), "
              "points on the far side of an edge: no candidates (%d rows above, %d columns beside, jump %.2f px; 0 and 0: off), "
              "cells with their ground below the view: %s\n"
              "objects counted when >= %lld %s pixels and <= %.0f m; gate |dx| <= 1 m + w/2, |dz| <= max(1 m, 3 sigma_Z) + l/2\n",
              settings.frames, settings.first_seed, settings.first_seed + settings.seeds - 1,
              settings.true_ego_motion ? "TRUE (the sequence's camera motion)" : "from visual odometry (as the command)",
              settings.colour ? "left colour" : "grey", settings.threads, settings.candidates.fit.hole_membrane, settings.candidates.fit.obstacle_refit_height_m,
              settings.candidates.grid.occlusion_upper_bounds ? "on" : "off",
              settings.candidates.occluder.rows_below_px, settings.candidates.occluder.jump_px, settings.candidates.fit.upper_bound_tolerance_m,
              settings.candidates.far_side.rows_above_px, settings.candidates.far_side.columns_beside_px, settings.candidates.far_side.jump_px,
              settings.candidates.ground_below_view_upper_bounds ? "upper bounds" : "samples", static_cast<long long>(settings.min_pixels),
              settings.all_visible ? "visible" : "measurable (true disparity in the engine's range, match inside the right image)",
              settings.range_m);
  if (settings.candidates.local_ground_reference) {
    std::printf("local ground: candidates measured from the terrain inliers' median within %d cell(s) where it lies below the surface "
                "(band %.2f m below, at least %d points)\n",
                settings.candidates.local_ground.reach_cells, settings.candidates.local_ground.band_below_m,
                settings.candidates.local_ground.min_points);
  }
  if (settings.discontinuity.radius_px > 0) {
    std::printf("discontinuity filter: radius %d px, jump %.2f px, on the map the points and candidates are made from (the view check reads "
                "the engine's)\n",
                settings.discontinuity.radius_px, settings.discontinuity.jump_px);
  }
  std::printf("voxel tracker: process noise %.2f m/s^2, innovation gate chi-square %.2f (0: off), moving from %.2f m/s with chi-square %.2f "
              "after %d update(s), %d consistent vote(s), the range drift of a %.2f px disparity bias in the test (0: off)\n",
              settings.tracking.accel_sigma_mps2, settings.tracking.innovation_gate_chi2, settings.tracking.moving_speed_mps,
              settings.tracking.moving_significance_chi2, settings.tracking.moving_min_updates, settings.tracking.moving_consistency_frames,
              settings.tracking.moving_disparity_bias_px);
  std::printf("voxel tracker: feature motion %s (the odometry's points inside a cluster measure its velocity: at least %d, pixel sigma %.2f px, "
              "disparity sigma %.2f px, model sigma %.2f m/s, gate chi-square %.2f)\n",
              settings.tracking.feature_motion_min_features > 0 ? "on" : "off", settings.tracking.feature_motion_min_features,
              settings.tracking.feature_pixel_sigma_px, settings.tracking.feature_disparity_sigma_px, settings.tracking.feature_motion_sigma_mps,
              settings.tracking.feature_motion_gate_chi2);
  std::printf("disparity: [%d, %d) px, %s\n", settings.disparity.min_disparity,
              settings.disparity.min_disparity + settings.disparity.num_disparities, arm::settings_text(settings.disparity).c_str());

  std::vector<std::vector<Tally>> per_scene(settings.scenes.size(), std::vector<Tally>(kMethods));
  try {
    for (size_t s = 0; s < settings.scenes.size(); ++s) {
      for (int seed = settings.first_seed; seed < settings.first_seed + settings.seeds; ++seed) {
        const std::vector<Tally> tallies = evaluate(settings.scenes[s], static_cast<uint32_t>(seed), settings, misses.file, moving_log.file,
                                                     surface_errors.file);
        std::printf("%-9s seed %d:", settings.scenes[s].c_str(), seed);
        for (int m = 0; m < kMethods; ++m) {
          const Tally& t = tallies[static_cast<size_t>(m)];
          std::printf("  %s %.1f%% (%lld/%lld) FP/f %.2f", kMethodNames[m], percent(t.detected, t.visible), static_cast<long long>(t.detected),
                      static_cast<long long>(t.visible), t.frames ? static_cast<double>(t.false_positives) / static_cast<double>(t.frames) : 0.0);
          per_scene[s][static_cast<size_t>(m)].add(t);
        }
        std::printf("\n");
        std::fflush(stdout);
      }
    }
  } catch (const std::exception& error) {
    std::fprintf(stderr, "obstacles3d_eval: %s\n", error.what());
    misses.discard();  // no half-written file
    moving_log.discard();
    surface_errors.discard();
    return 2;
  }
  if (!misses.close() || !moving_log.close() || !surface_errors.close()) {
    misses.discard();
    moving_log.discard();
    surface_errors.discard();
    return 2;
  }

  // A table of a row per method and a column per scene; cell(tally, method) prints one cell.
  const auto print_method_table = [&](const std::string& title, const std::function<void(const Tally&, int)>& cell) {
    std::printf("\n%s\n%-10s", title.c_str(), "method");
    for (const std::string& scene : settings.scenes) std::printf(" %18s", scene.c_str());
    std::printf("\n");
    for (int m = 0; m < kMethods; ++m) {
      std::printf("%-10s", kMethodNames[m]);
      for (size_t s = 0; s < settings.scenes.size(); ++s) cell(per_scene[s][static_cast<size_t>(m)], m);
      std::printf("\n");
    }
  };
  bool all_met = true;
  print_method_table("detection rate % (false positives per frame)", [&](const Tally& t, int m) {
    const double rate = percent(t.detected, t.visible);
    std::printf("   %6.1f (%6.2f)   ", rate, t.frames ? static_cast<double>(t.false_positives) / static_cast<double>(t.frames) : 0.0);
    if ((m == 0 || m == 3) && rate < 99.0) all_met = false;
  });
  std::printf("%-10s", "unmeasured");
  for (size_t s = 0; s < settings.scenes.size(); ++s) {
    std::printf("   %6lld object-frames ", static_cast<long long>(per_scene[s][0].unmeasurable));
  }
  std::printf("\n%-10s", " half-occl");
  for (size_t s = 0; s < settings.scenes.size(); ++s) {
    std::printf("   %6lld object-frames ", static_cast<long long>(per_scene[s][0].half_occluded));
  }
  std::printf("\n%-10s", "too low");
  for (size_t s = 0; s < settings.scenes.size(); ++s) {
    std::printf("   %6lld object-frames ", static_cast<long long>(per_scene[s][0].below_obstacle_height));
  }
  std::printf("\n(unmeasured: visible and in range but too few measurable pixels, not counted; --all-visible counts them;\n"
              " half-occluded: of those, the ones with enough pixels but for the ones the right camera does not see;\n"
              " too low: measurable but lower than the candidates' obstacle height %.2f m, no obstacle, not counted; --count-low counts them)\n",
              settings.candidates.obstacle_height_m);
  std::printf("line: polar and stixels >= 99 %% on every scene\n");
  // False positives apart for the frames whose view is partly nearer than the engine's range: what
  // the matcher returns there is not a measurement of anything (docs/obstacles3d.md).
  print_method_table("false positives per frame, frames with >= " + std::to_string(static_cast<int>(100 * eval::kNearerThanRangeShare)) +
                         " % of the view nearer than the search range / the other frames",
                     [](const Tally& t, int) {
                       const int64_t other_frames = t.frames - t.nearer_view_frames;
                       const int64_t other_false_positives = t.false_positives - t.nearer_view_false_positives;
                       std::printf("   %6.2f / %6.2f  ",
                                   t.nearer_view_frames ? static_cast<double>(t.nearer_view_false_positives) /
                                                              static_cast<double>(t.nearer_view_frames)
                                                        : 0.0,
                                   other_frames ? static_cast<double>(other_false_positives) / static_cast<double>(other_frames) : 0.0);
                     });
  std::printf("%-10s", "frames");
  for (size_t s = 0; s < settings.scenes.size(); ++s) {
    const Tally& t = per_scene[s][0];
    std::printf("   %6lld / %6lld  ", static_cast<long long>(t.nearer_view_frames), static_cast<long long>(t.frames - t.nearer_view_frames));
  }
  std::printf("\n");

  for (size_t s = 0; s < settings.scenes.size(); ++s) {
    if (per_scene[s][3].floating_seen == 0) continue;
    std::printf("\n%s: hanging objects' lower edge (min_height_m - truth), free space under a board\n", settings.scenes[s].c_str());
    for (int m = 0; m < 4; ++m) {
      const Tally& t = per_scene[s][static_cast<size_t>(m)];
      std::vector<double> absolute;
      for (double e : t.floating_error_m) absolute.push_back(std::abs(e));
      std::printf("  %-9s seen %lld, within 10 cm %.1f%%, error mean %+.3f m, median |error| %.3f m, free under kept %lld/%lld\n",
                  kMethodNames[m], static_cast<long long>(t.floating_seen), percent(t.floating_within, t.floating_seen), mean(t.floating_error_m),
                  median(absolute), static_cast<long long>(t.free_kept), static_cast<long long>(t.free_checked));
      std::vector<double> absolute_any;
      for (double e : t.floating_error_any_m) absolute_any.push_back(std::abs(e));
      std::printf("  %-9s   the former rule (the highest lower edge in the gate, whatever it spans): within 10 cm %.1f%% of %lld seen (%lld), median |error| %.3f m\n",
                  "", percent(t.floating_within_any, t.floating_seen), static_cast<long long>(t.floating_seen),
                  static_cast<long long>(t.floating_within_any), median(absolute_any));
      if (m == 3 && (percent(t.floating_within, t.floating_seen) < 90.0 || percent(t.free_kept, t.free_checked) < 99.0)) all_met = false;
    }
    std::printf("  lower edge hidden: %lld object-frames detected by stixels (%lld by polar) whose hanging part's lowest %.0f cm is not measurable "
                "(fewer than max(%.0f, %.0f %% of its pixels)): behind a nearer object; not scored for the edge nor the free space "
                "(--score-hidden-edges scores them)\n",
                static_cast<long long>(per_scene[s][3].edge_hidden), static_cast<long long>(per_scene[s][0].edge_hidden), 100 * eval::kLowerEdgeBandM,
                eval::kLowerEdgeMinPixels, 100 * eval::kLowerEdgeMinShare);
    std::printf("  line: stixels within 10 cm in >= 90 %% of the frames seen, free space kept in >= 99 %%\n");
  }

  Tally moving;
  for (const auto& scene : per_scene) moving.add(scene[4]);
  const double tp = percent(moving.moving_flagged, moving.moving_total), fp = percent(moving.static_flagged, moving.static_total);
  std::printf("\nvoxels 'moving': TP %.1f%% (%lld/%lld truly moving), FP %.1f%% (%lld/%lld static); velocity error mean %.2f m/s, median "
              "%.2f m/s over %zu matches (thesis: 82 %% / 16 %%)\nline: TP >= 90 %%, FP <= 10 %%\n",
              tp, static_cast<long long>(moving.moving_flagged), static_cast<long long>(moving.moving_total), fp,
              static_cast<long long>(moving.static_flagged), static_cast<long long>(moving.static_total), mean(moving.velocity_error_mps),
              median(moving.velocity_error_mps), moving.velocity_error_mps.size());
  std::printf("  the former rule (the nearest in-gate obstacle, whatever object it shows): TP %.1f%% (%lld), FP %.1f%% (%lld)\n",
              percent(moving.moving_flagged_nearest, moving.moving_total), static_cast<long long>(moving.moving_flagged_nearest),
              percent(moving.static_flagged_nearest, moving.static_total), static_cast<long long>(moving.static_flagged_nearest));
  std::printf("  settled object-frames only (counted in more than %d frames in a row: a track is reported after 3 and a walker's speed is "
              "significant after about 5 updates; voxels_bench's rule): TP %.1f%% (%lld/%lld), FP %.1f%% (%lld/%lld)\n",
              eval::kMovingSettleFrames, percent(moving.moving_flagged_settled, moving.moving_total_settled),
              static_cast<long long>(moving.moving_flagged_settled), static_cast<long long>(moving.moving_total_settled),
              percent(moving.static_flagged_settled, moving.static_total_settled), static_cast<long long>(moving.static_flagged_settled),
              static_cast<long long>(moving.static_total_settled));
  if (moving.moving_total > 0 && tp < 90.0) all_met = false;
  if (moving.static_total > 0 && fp > 10.0) all_met = false;
  std::printf("%s\n", all_met ? "all lines met" : "some line missed");
  return all_met ? 0 : 1;
}
