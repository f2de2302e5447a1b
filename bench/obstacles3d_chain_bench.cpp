// obstacles3d_chain_bench: issue 10's full-chain speed line, "disparity + terrain + stixel obstacles
// + traversability at least 30 frames per second at 640x480 (the thesis: 12 Hz on 4 cores)", on the
// host with 2 threads.
//
// Input: the preset synthetic sequence (io::preset_stereo_sequence, "urban" by default: moving
// camera, crossing pedestrians and cars), 640x480 grey and colour views, every frame rendered
// BEFORE any timing. Per frame, the chain `lpstereo obstacles3d --method stixels` runs (the same
// calls, the command's defaults):
//   disparity      arm::DisparityEngine::compute (o3::obstacles3d_disparity_defaults: 64 disparities,
//                  census 5x5, SGM 8 paths, LR check, median, speckle filter; 2 worker threads;
//                  --near-guard: 128 disparities, 64 at full resolution, all at half resolution);
//   triangulate    arm::triangulate (camera-frame points, mm);
//   terrain        arm::obstacles3d::extract_obstacle_candidates: vehicle-frame points, the 2.5D grid
//                  (34 m x 22 m, 0.5 m cells), fit_terrain (25 x 25 control points, degree 3) and
//                  classify_points (candidates: more than 0.2 m above the surface); the points built
//                  and classified in two bands of rows on two threads (the same result as one);
//   stixels        AugmentedStixels::update on the candidates (polar grid, 2 threads), with the
//                  sequence's true ego-motion (as visual odometry would give it);
//   traversability arm::terrain::compute_traversability (slope and occupancy cost per cell).
// Timing: one warm-up pass over the first frames, then `passes` passes over every frame (a new
// AugmentedStixels each pass, constructed outside the timing). Each stage is timed with the wall
// clock and with the process's CPU time (both threads); printed: the median per stage, the median
// per-frame total (the sum of the stages in the same frame), frames per second = 1000 / median
// total wall ms, beside the line (>= 30 fps) and the thesis's anchor (12 Hz on an
// i7-3840QM: DSI 45 ms, terrain 15 ms, obstacles 15 ms, traversability 8 ms; issue 10's "Why").
// On a shared machine the wall clock also counts other processes' turns; the CPU column shows
// what the chain itself spent. A results digest (candidate points, stixels, obstacles, occupied
// traversability cells, summed over the timed frames) is printed so that a speed change can be
// checked not to change the results.
// Also printed: the rates the process CPU time bounds on an idle 2-core machine (1000 / CPU ms with
// no overlap, 2000 / CPU ms with both threads busy), the figure to read on a loaded machine.
// Pipelined: the same chain as a two-stage pipeline, the way a system runs it on two cores (and the
// way the chip overlaps its vector engine with its ARM cores): one thread computes disparity and
// points of frame n + 1 while the other runs terrain, stixels and traversability of frame n (that
// stage single-threaded). Throughput = frames / wall time of the whole pass (median over passes);
// each stage on one thread (its own disparity engine with one worker, the bands of its SGM one
// after the other); the results digest must
// equal the sequential one (checked: exit 1 otherwise). Printed beside it, not counted for the
// line: the same pipeline with the disparity engine on 2 workers, 3 threads on the 2 cores (the
// engine leaves a core idle in its single-threaded speckle filter, and stage 2 fills it).
// Exits 1 when neither the sequential median total nor the pipelined throughput reaches 30 fps.
// Usage: obstacles3d_chain_bench [--scene urban|country|mining|floating] [--seed K] [--frames N] [--passes P]
//        [--far-side R,C] (the candidates' far-side test, CandidateParameters::far_side: R rows above, C
//        columns beside; 0,0: off, to time what it costs) [--ground-below-view upper-bounds|samples] (the
//        cells whose ground lies below the image as upper bounds, the default, or as plain samples)
//        [--near-guard on|off] (on: 128 disparities, 64 at full resolution and all at half resolution,
//        docs/obstacles3d.md "The near guard"; off: the command's 64, the default)
//        [--local-ground on|off] (the candidates measured from the terrain inliers around them,
//        CandidateParameters::local_ground_reference; default the candidates')
//        [--heap keep|default] (keep, the default: freed heap memory stays in the process, as in the
//        lpstereo command, arm/heap_policy.h; default: the C library's own policy, under which each
//        frame faults its freed blocks in again, to time what the policy saves)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <future>
#include <stdexcept>
#include <string>
#include <vector>
#include <time.h>

#include <opencv2/core.hpp>

#include "arm/disparity_engine.h"
#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/obstacle_candidates.h"
#include "arm/point_cloud.h"
#include "arm/terrain/terrain_model.h"
#include "io/image_io.h"
#include "io/stereo_sequence.h"
#include "bench/heap_setting.h"

namespace lpstereo {
namespace {

namespace o3 = arm::obstacles3d;

constexpr int kThreads = 2;
constexpr double kLineFps = 30.0;
constexpr double kThesisHz = 12.0;
constexpr int kWarmUpFrames = 5;

enum Stage { kDisparity, kTriangulate, kTerrain, kStixels, kTraversability, kStages };
const char* const kStageNames[kStages] = {"disparity", "triangulate", "terrain (grid, fit, candidates)", "stixels", "traversability"};
// The thesis's per-stage times (issue 10's "Why"; triangulation is inside its DSI/terrain figures).
const double kThesisStageMs[kStages] = {45.0, NAN, 15.0, 15.0, 8.0};

struct Settings {
  std::string scene = "urban";
  uint32_t seed = 1;
  int frames = 30;
  int passes = 3;
  arm::FarSideTest far_side;  // the candidates' default
  bool ground_below_view_upper_bounds = true;  // the candidates' default
  bool near_guard = false;                     // --near-guard on: o3::obstacles3d_near_guard_disparity_parameters
  bool local_ground = o3::CandidateParameters{}.local_ground_reference;  // the candidates' default
  bool keep_freed_heap_memory = true;  // --heap keep|default
};

struct RenderedFrame {
  Plane left, right;
  cv::Mat left_colour;
  io::SynthCameraPose pose;
};

double process_cpu_ms() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return 1e3 * static_cast<double>(now.tv_sec) + 1e-6 * static_cast<double>(now.tv_nsec);
}

double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  const size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle), values.end());
  double result = values[middle];
  if (values.size() % 2 == 0) result = (result + *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle))) / 2;
  return result;
}

bool parse(int argc, char** argv, Settings& settings) {
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) return false;
    const char* value = argv[++i];
    if (flag == "--scene") {
      settings.scene = value;
    } else if (flag == "--seed") {
      settings.seed = static_cast<uint32_t>(std::strtoul(value, nullptr, 10));
    } else if (flag == "--frames") {
      settings.frames = std::atoi(value);
    } else if (flag == "--passes") {
      settings.passes = std::atoi(value);
    } else if (flag == "--far-side") {
      if (std::sscanf(value, "%d,%d", &settings.far_side.rows_above_px, &settings.far_side.columns_beside_px) != 2) return false;
    } else if (flag == "--near-guard") {
      if (std::strcmp(value, "on") != 0 && std::strcmp(value, "off") != 0) return false;
      settings.near_guard = std::strcmp(value, "on") == 0;
    } else if (flag == "--local-ground") {
      if (std::strcmp(value, "on") != 0 && std::strcmp(value, "off") != 0) return false;
      settings.local_ground = std::strcmp(value, "on") == 0;
    } else if (flag == "--heap") {
      if (std::strcmp(value, "keep") != 0 && std::strcmp(value, "default") != 0) return false;
      settings.keep_freed_heap_memory = std::strcmp(value, "keep") == 0;
    } else if (flag == "--ground-below-view") {
      if (std::strcmp(value, "upper-bounds") != 0 && std::strcmp(value, "samples") != 0) return false;
      settings.ground_below_view_upper_bounds = std::strcmp(value, "upper-bounds") == 0;
    } else {
      return false;
    }
  }
  try {
    settings.far_side.validate();
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "obstacles3d_chain_bench: --far-side: %s\n", error.what());
    return false;
  }
  return settings.frames >= 1 && settings.passes >= 1;
}

int run(int argc, char** argv) {
  Settings settings;
  if (!parse(argc, argv, settings)) {
    std::fprintf(stderr, "usage: obstacles3d_chain_bench [--scene urban|country|mining|floating] [--seed K] [--frames N >= 1] [--passes P >= 1] "
                 "[--far-side R,C (rows, columns in [0, 64])] [--ground-below-view upper-bounds|samples] [--near-guard on|off] [--local-ground on|off] "
                 "[--heap keep|default]\n");
    return 2;
  }
  // Before anything allocates (and before the threads start): the process's heap policy.
  const std::string heap = settings.keep_freed_heap_memory ? bench::keep_freed_heap_memory_setting()
                                                           : "the C library's default (--heap default)";
  io::StereoSequenceOptions options = io::preset_stereo_sequence(settings.scene, settings.seed);
  options.frames = settings.frames;
  options.base.width = 640;
  options.base.height = 480;
  options.base.colour = true;
  io::validate_stereo_sequence(options);
  const io::StereoSynthOptions& base = options.base;
  const int width = base.width, height = base.height;

  // Render every frame first: the renderer is not part of the chain.
  std::vector<RenderedFrame> frames;
  double focal_px = 0;
  for (int n = 0; n < settings.frames; ++n) {
    const io::StereoSequenceFrame frame = io::render_sequence_frame(options, n);
    focal_px = frame.scene.focal_px;
    frames.push_back({io::mat_to_plane(frame.scene.left, BufferFormat{ElementType::u8}),
                      io::mat_to_plane(frame.scene.right, BufferFormat{ElementType::u8}), frame.scene.left_colour, frame.pose});
  }

  // The chain's settings: `lpstereo obstacles3d --method stixels`'s defaults.
  const arm::DisparityParameters disparity_parameters =
      settings.near_guard ? o3::obstacles3d_near_guard_disparity_parameters() : o3::obstacles3d_disparity_defaults();
  arm::DisparityEngine engine(width, height, disparity_parameters, {}, kThreads);
  const double cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
  const arm::TriangulationParameters triangulation{base.baseline_m, focal_px, cx, cy, disparity_parameters.min_disparity,
                                                   disparity_parameters.num_disparities, 0};
  arm::CameraMount mount;
  mount.roll_rad = base.roll_rad;
  mount.pitch_rad = base.pitch_rad;
  mount.position_m = Eigen::Vector3d(0, 0, base.camera_height_m);
  const arm::CameraToVehicle to_vehicle(mount);
  o3::CandidateParameters candidate_parameters;
  candidate_parameters.threads = kThreads;
  candidate_parameters.far_side = settings.far_side;
  candidate_parameters.ground_below_view_upper_bounds = settings.ground_below_view_upper_bounds;
  candidate_parameters.local_ground_reference = settings.local_ground;
  arm::terrain::TraversabilityParameters traversability_parameters;
  traversability_parameters.obstacle_height_m = candidate_parameters.obstacle_height_m;
  const Eigen::Isometry3d vehicle_from_camera = to_vehicle.vehicle_from_camera();
  o3::AugmentedStixelParameters stixel_parameters;
  stixel_parameters.grid = o3::OccupancyGridParameters::defaults(o3::GridKind::polar, width);
  stixel_parameters.grid.error_model.focal_px = focal_px;
  stixel_parameters.grid.error_model.baseline_m = base.baseline_m;
  stixel_parameters.grid.principal_u_px = cx;
  stixel_parameters.grid.vehicle_from_camera = vehicle_from_camera;
  stixel_parameters.grid.threads = kThreads;

  std::printf("obstacles3d_chain_bench: scene %s seed %u, %d frames %dx%d (hfov %.0f deg, f %.1f px, baseline %.2f m, camera %.2f m), "
              "rendered before timing; %d threads; %d warm-up frames, %d timed passes\n",
              settings.scene.c_str(), settings.seed, settings.frames, width, height, base.hfov_deg, focal_px, base.baseline_m,
              base.camera_height_m, kThreads, std::min(kWarmUpFrames, settings.frames), settings.passes);
  std::printf("  disparity: %s\n", arm::settings_text(disparity_parameters).c_str());
  std::printf("  terrain: %g..%g m x %g..%g m, %g m cells, %d x %d control points of degree %d, candidates > %g m above the surface, "
              "none on the far side of an edge (%d rows above, %d columns beside; 0 and 0: off), cells with their ground below the view: %s; "
              "local ground %s; %d threads (bands of rows)\n",
              candidate_parameters.grid.forward_min_m, candidate_parameters.grid.forward_max_m, candidate_parameters.grid.lateral_min_m,
              candidate_parameters.grid.lateral_max_m, candidate_parameters.grid.cell_m, candidate_parameters.fit.control_forward,
              candidate_parameters.fit.control_lateral, candidate_parameters.fit.degree_forward, candidate_parameters.obstacle_height_m,
              candidate_parameters.far_side.rows_above_px, candidate_parameters.far_side.columns_beside_px,
              candidate_parameters.ground_below_view_upper_bounds ? "upper bounds" : "samples",
              candidate_parameters.local_ground_reference ? "on" : "off", candidate_parameters.threads);
  std::printf("  stixels: polar grid %d x %d cells, min_points %d, true ego-motion from the sequence's poses\n",
              stixel_parameters.grid.columns(), stixel_parameters.grid.rows(), stixel_parameters.min_points);
  std::printf("  heap: %s\n", heap.c_str());

  std::vector<double> wall_ms[kStages], cpu_ms[kStages], total_wall_ms, total_cpu_ms;
  long long digest_candidates = 0, digest_stixels = 0, digest_obstacles = 0, digest_occupied = 0;
  auto run_pass = [&](int frame_count, bool timed) {
    o3::AugmentedStixels stixels(stixel_parameters);
    for (int n = 0; n < frame_count; ++n) {
      const RenderedFrame& frame = frames[static_cast<size_t>(n)];
      o3::EgoMotion ego_motion;
      if (n > 0) {
        ego_motion.available = true;
        ego_motion.previous_from_current = vehicle_from_camera * io::camera_previous_from_current(frames[static_cast<size_t>(n - 1)].pose, frame.pose) *
                                           vehicle_from_camera.inverse();
      }
      double stage_wall[kStages], stage_cpu[kStages];
      auto wall_start = std::chrono::steady_clock::now();
      double cpu_start = process_cpu_ms();
      auto lap = [&](Stage stage) {
        const auto wall_now = std::chrono::steady_clock::now();
        const double cpu_now = process_cpu_ms();
        stage_wall[stage] = std::chrono::duration<double, std::milli>(wall_now - wall_start).count();
        stage_cpu[stage] = cpu_now - cpu_start;
        wall_start = wall_now;
        cpu_start = cpu_now;
      };
      const Plane& disparity = engine.compute(frame.left, frame.right);
      lap(kDisparity);
      const arm::CameraPoints camera = arm::triangulate(disparity, triangulation);
      lap(kTriangulate);
      const o3::CandidatePoints candidates =
          o3::extract_obstacle_candidates(disparity, engine.invalid_disparity_q4(), camera, triangulation, frame.left,
                                          o3::ColourView{frame.left_colour.data, frame.left_colour.step, true}, to_vehicle, candidate_parameters);
      lap(kTerrain);
      stixels.update(candidates.points, ego_motion);
      lap(kStixels);
      arm::terrain::TraversabilityMap map;
      if (candidates.terrain.known) map = arm::terrain::compute_traversability(candidates.terrain, candidates.measured_grid, traversability_parameters);
      lap(kTraversability);
      if (!timed) continue;
      double frame_wall = 0, frame_cpu = 0;
      for (int s = 0; s < kStages; ++s) {
        wall_ms[s].push_back(stage_wall[s]);
        cpu_ms[s].push_back(stage_cpu[s]);
        frame_wall += stage_wall[s];
        frame_cpu += stage_cpu[s];
      }
      total_wall_ms.push_back(frame_wall);
      total_cpu_ms.push_back(frame_cpu);
      digest_candidates += static_cast<long long>(candidates.points.size());
      digest_stixels += static_cast<long long>(stixels.stixels().size());
      digest_obstacles += static_cast<long long>(stixels.obstacles().size());
      for (Eigen::Index i = 0; i < map.occupancy.size(); ++i) digest_occupied += map.occupancy.data()[i] == 1.0;
    }
  };
  run_pass(std::min(kWarmUpFrames, settings.frames), false);
  for (int pass = 0; pass < settings.passes; ++pass) run_pass(settings.frames, true);

  // The two-stage pipeline (header comment): stage 1 (disparity, points) on its own thread, one frame
  // ahead; stage 2 here, single-threaded. The disparity plane is cloned: the engine reuses its buffer.
  struct PointsOfFrame {
    Plane disparity;
    arm::CameraPoints camera;
  };
  o3::CandidateParameters stage2_candidates = candidate_parameters;
  stage2_candidates.threads = 1;
  o3::AugmentedStixelParameters stage2_stixels = stixel_parameters;
  stage2_stixels.grid.threads = 1;
  struct PipelinedRun {
    double frame_ms = NAN;  // median over the passes
    bool same_results = false;
  };
  // stage1_workers: the disparity engine's threads in stage 1. 1: one thread per stage, 2 in all;
  // 2: three threads on the machine's two cores, the engine's idle worker time (its single-threaded
  // speckle filter, the census) and stage 2 sharing the cores.
  const auto run_pipelined = [&](int stage1_workers) {
    arm::DisparityEngine stage1_engine(width, height, disparity_parameters, {}, stage1_workers);
    const auto stage1 = [&](int n) {
      const RenderedFrame& frame = frames[static_cast<size_t>(n)];
      PointsOfFrame points;
      points.disparity = stage1_engine.compute(frame.left, frame.right).clone();
      points.camera = arm::triangulate(points.disparity, triangulation);
      return points;
    };
    std::vector<double> pipelined_frame_ms;
    long long pipelined_candidates = 0, pipelined_stixels = 0, pipelined_obstacles = 0, pipelined_occupied = 0;
    for (int pass = 0; pass < settings.passes; ++pass) {
      o3::AugmentedStixels stixels(stage2_stixels);
      long long candidates_sum = 0, stixels_sum = 0, obstacles_sum = 0, occupied_sum = 0;
      const auto started = std::chrono::steady_clock::now();
      std::future<PointsOfFrame> next = std::async(std::launch::async, stage1, 0);
      for (int n = 0; n < settings.frames; ++n) {
        const PointsOfFrame points = next.get();
        if (n + 1 < settings.frames) next = std::async(std::launch::async, stage1, n + 1);
        const RenderedFrame& frame = frames[static_cast<size_t>(n)];
        o3::EgoMotion ego_motion;
        if (n > 0) {
          ego_motion.available = true;
          ego_motion.previous_from_current = vehicle_from_camera *
                                             io::camera_previous_from_current(frames[static_cast<size_t>(n - 1)].pose, frame.pose) *
                                             vehicle_from_camera.inverse();
        }
        const o3::CandidatePoints candidates = o3::extract_obstacle_candidates(
            points.disparity, engine.invalid_disparity_q4(), points.camera, triangulation, frame.left,
            o3::ColourView{frame.left_colour.data, frame.left_colour.step, true}, to_vehicle, stage2_candidates);
        stixels.update(candidates.points, ego_motion);
        arm::terrain::TraversabilityMap map;
        if (candidates.terrain.known) map = arm::terrain::compute_traversability(candidates.terrain, candidates.measured_grid, traversability_parameters);
        candidates_sum += static_cast<long long>(candidates.points.size());
        stixels_sum += static_cast<long long>(stixels.stixels().size());
        obstacles_sum += static_cast<long long>(stixels.obstacles().size());
        for (Eigen::Index i = 0; i < map.occupancy.size(); ++i) occupied_sum += map.occupancy.data()[i] == 1.0;
      }
      pipelined_frame_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count() /
                                   settings.frames);
      pipelined_candidates += candidates_sum, pipelined_stixels += stixels_sum;
      pipelined_obstacles += obstacles_sum, pipelined_occupied += occupied_sum;
    }
    PipelinedRun run;
    run.frame_ms = median(pipelined_frame_ms);
    run.same_results = pipelined_candidates == digest_candidates && pipelined_stixels == digest_stixels &&
                       pipelined_obstacles == digest_obstacles && pipelined_occupied == digest_occupied;
    return run;
  };
  const PipelinedRun two_threads = run_pipelined(1), three_threads = run_pipelined(2);

  std::printf("\n  median over %zu frames           wall ms   process CPU ms   thesis ms (i7-3840QM, 4 cores)\n", total_wall_ms.size());
  for (int s = 0; s < kStages; ++s) {
    char thesis[32] = "      -";
    if (std::isfinite(kThesisStageMs[s])) std::snprintf(thesis, sizeof thesis, "%7.1f", kThesisStageMs[s]);
    std::printf("  %-32s %8.2f %15.2f   %s\n", kStageNames[s], median(wall_ms[s]), median(cpu_ms[s]), thesis);
  }
  const double total_ms = median(total_wall_ms);
  const double fps = 1000.0 / total_ms;
  std::printf("  %-32s %8.2f %15.2f   %7.1f\n", "total (per frame)", total_ms, median(total_cpu_ms), 1000.0 / kThesisHz);
  std::printf("  frames per second: %.1f (line: at least %.0f fps; thesis anchor: %.0f Hz); %.1fx the thesis's rate\n", fps, kLineFps, kThesisHz,
              fps / kThesisHz);
  std::printf("  results digest over the timed frames: %lld candidate points, %lld stixels, %lld obstacles, %lld occupied traversability cells\n",
              digest_candidates, digest_stixels, digest_obstacles, digest_occupied);
  // On an idle 2-core machine every stage runs at most its CPU time (one thread doing all of it)
  // and at least half of it (both threads busy): the rate the chain would reach there lies between
  // these two, whatever the load on this machine.
  const double total_cpu_median_ms = median(total_cpu_ms);
  std::printf("  from the process CPU time (%.2f ms per frame): on an idle 2-core machine between %.1f fps (no overlap) and %.1f fps "
              "(both threads busy throughout)\n",
              total_cpu_median_ms, 1000.0 / total_cpu_median_ms, 2000.0 / total_cpu_median_ms);
  const double pipelined_fps = 1000.0 / two_threads.frame_ms;
  const bool same_results = two_threads.same_results && three_threads.same_results;
  std::printf("  pipelined (disparity + points of frame n+1 beside the rest of frame n), one thread per stage (SGM sequential, "
              "its one-worker schedule): %.2f ms per frame, %.1f fps "
              "(median of %d passes); results digest %s the sequential one\n",
              two_threads.frame_ms, pipelined_fps, settings.passes, two_threads.same_results ? "equals" : "DIFFERS FROM");
  std::printf("  the same with the disparity engine on 2 workers (3 threads on the 2 cores; not the line's 2 threads): %.2f ms per frame, "
              "%.1f fps; results digest %s the sequential one\n",
              three_threads.frame_ms, 1000.0 / three_threads.frame_ms, three_threads.same_results ? "equals" : "DIFFERS FROM");
  const bool meets = same_results && std::max(fps, pipelined_fps) >= kLineFps;
  std::printf("%s: full chain with 2 threads at %.1f fps sequential, %.1f fps pipelined: %s the %.0f fps line\n", meets ? "PASS" : "MISSED", fps,
              pipelined_fps, meets ? "meets" : "misses", kLineFps);
  return meets ? 0 : 1;
}

}  // namespace
}  // namespace lpstereo

int main(int argc, char** argv) { return lpstereo::run(argc, argv); }
