// obstacles3d_bench: the occupancy grids and the augmented stixels (arm/obstacles3d/) per frame on a
// 640x480 point cloud (issue 10's speed acceptance: stixels at most 5 ms per frame on 2 threads).
// The scene: io/stereo_synth.h's road scene at 640x480 (hfov 65 deg, baseline 0.3 m, camera 1.5 m,
// level, the range test's object lineups at 8, 15, 25 and 35 m and a car), triangulated from its EXACT disparity (no matcher in the loop):
//   dense:      every pixel with a finite disparity (road, objects, the far wall): ~300k points, the
//               worst case where every pixel is a candidate;
//   candidates: the pixels more than 0.15 m above the road plane (the flat road is y = 1.5 m in the
//               camera frame): what the terrain stage would hand over.
// Each point's height above the road is 1.5 - y. Timing: each benchmark runs update() on the same
// frame (the grid keeps its memory: a static scene, as after a few frames of a still camera), warm-up
// 0.5 s then 7 repetitions; read the _median rows: "Time" is wall clock, "CPU" the whole process's
// CPU time (both threads) per frame, the figure to trust on a loaded machine (wall clock there waits
// for the second thread to be scheduled; on an idle 2-core machine wall ~ CPU / 2 plus the join).
// Stixels = polar grid update + stixels (the whole per-frame cost); StixelsDriving the same with an
// ego-motion each frame (the grid's memory resampled). Settings are printed first.
// Usage: obstacles3d_bench [Google Benchmark flags]
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/occupancy_grid.h"
#include "io/obstacles3d_pictures.h"
#include "io/stereo_synth.h"
#include "bench/heap_setting.h"

namespace lpstereo {
namespace {

using arm::obstacles3d::AugmentedStixelParameters;
using arm::obstacles3d::AugmentedStixels;
using arm::obstacles3d::EgoMotion;
using arm::obstacles3d::GridKind;
using arm::obstacles3d::ObstaclePoint;
using arm::obstacles3d::OccupancyGrid;
using arm::obstacles3d::OccupancyGridParameters;

constexpr int kThreads = 2;
constexpr int kRepetitions = 7;
constexpr double kWarmUpSeconds = 0.5;
constexpr double kStixelBudgetMs = 5.0;
constexpr double kCandidateHeightM = 0.15;
constexpr double kDrivingStepM = 0.5;                            // BM_StixelsDriving's ego-motion a frame
constexpr double kDrivingYawRad = 0.3 * 3.14159265358979323846 / 180;

struct Cloud {
  io::StereoSynthScene scene;
  io::StereoSynthOptions options;
  std::vector<ObstaclePoint> dense, candidates;
};

Cloud& cloud() {
  static Cloud built = [] {
    Cloud c;
    c.options.width = 640;
    c.options.height = 480;
    c.options.hfov_deg = 65;
    c.options.baseline_m = 0.3;
    c.options.camera_height_m = 1.5;
    c.options.colour = true;
    c.options.seed = 7;
    // The range test's lineups (cone, can, box, tape roll, bin, pedestrian, 1.2 m apart) at 8, 15,
    // 25 and 35 m, within the grids' 40 m, and a car on the left at 12 m.
    for (double distance_m : {8.0, 15.0, 25.0, 35.0})
      for (const io::SynthObject& object : io::lineup_synth_objects(distance_m)) c.options.objects.push_back(object);
    c.options.objects.push_back(io::synth_object(io::SynthClass::car, -4.5, 12.0));
    c.scene = io::render_stereo_synth(c.options);
    const double f = c.scene.focal_px, u0 = (c.options.width - 1) / 2.0, v0 = (c.options.height - 1) / 2.0;
    for (int v = 0; v < c.options.height; ++v) {
      for (int u = 0; u < c.options.width; ++u) {
        const float d = c.scene.disparity_px.at<float>(v, u);
        if (!std::isfinite(d) || !(d > 0)) continue;
        ObstaclePoint point;
        const double z = f * c.options.baseline_m / d;
        const double x = (u - u0) * z / f, y = (v - v0) * z / f;
        point.camera_m = Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
        point.vehicle_m = Eigen::Vector3f(static_cast<float>(z), static_cast<float>(-x), static_cast<float>(1.5 - y));
        point.height_above_ground_m = static_cast<float>(c.options.camera_height_m - y);
        point.disparity_px = d;
        point.u_px = static_cast<uint16_t>(u);
        point.v_px = static_cast<uint16_t>(v);
        const cv::Vec3b bgr = c.scene.left_colour.at<cv::Vec3b>(v, u);
        point.rgb = {bgr[2], bgr[1], bgr[0]};
        c.dense.push_back(point);
        if (point.height_above_ground_m > kCandidateHeightM) c.candidates.push_back(point);
      }
    }
    return c;
  }();
  return built;
}

OccupancyGridParameters grid_parameters(GridKind kind) {
  OccupancyGridParameters parameters = OccupancyGridParameters::defaults(kind, cloud().options.width);
  parameters.error_model.focal_px = cloud().scene.focal_px;
  parameters.error_model.baseline_m = cloud().options.baseline_m;
  parameters.principal_u_px = (cloud().options.width - 1) / 2.0;
  parameters.threads = kThreads;
  return parameters;
}

AugmentedStixelParameters stixel_parameters() {
  AugmentedStixelParameters parameters;
  parameters.grid = grid_parameters(GridKind::polar);
  return parameters;
}

const std::vector<ObstaclePoint>& points_of(int which) { return which == 0 ? cloud().dense : cloud().candidates; }
const char* cloud_name(int which) { return which == 0 ? "dense" : "candidates"; }

void BM_Stixels(benchmark::State& state) {
  const std::vector<ObstaclePoint>& points = points_of(static_cast<int>(state.range(0)));
  AugmentedStixels stixels(stixel_parameters());
  stixels.update(points, EgoMotion{});
  for (auto _ : state) {
    stixels.update(points, EgoMotion{});
    benchmark::DoNotOptimize(stixels.stixels().data());
  }
  state.SetLabel(std::string(cloud_name(static_cast<int>(state.range(0)))) + ", " + std::to_string(points.size()) + " points");
  state.counters["stixels"] = static_cast<double>(stixels.stixels().size());
  state.counters["obstacles"] = static_cast<double>(stixels.obstacles().size());
  state.counters["budget_ms"] = kStixelBudgetMs;
  state.counters["arm_Mops"] = static_cast<double>(stixels.work().scalar_ops) / 1e6;
}
BENCHMARK(BM_Stixels)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinWarmUpTime(kWarmUpSeconds)->Repetitions(kRepetitions);

// The stixels of a driving camera: the same candidates with an ego-motion of 0.5 m forward and a
// 0.3 deg yaw a frame (15 m/s at 30 fps, a gentle bend), so that the grid's memory is resampled into
// each new frame (occupancy_grid.h, the ego-motion compensation), as in the chain and the command.
void BM_StixelsDriving(benchmark::State& state) {
  const std::vector<ObstaclePoint>& points = cloud().candidates;
  EgoMotion motion;
  motion.available = true;
  motion.previous_from_current = Eigen::Translation3d(kDrivingStepM, 0, 0) * Eigen::AngleAxisd(kDrivingYawRad, Eigen::Vector3d::UnitZ());
  AugmentedStixels stixels(stixel_parameters());
  stixels.update(points, motion);
  for (auto _ : state) {
    stixels.update(points, motion);
    benchmark::DoNotOptimize(stixels.stixels().data());
  }
  state.SetLabel("candidates, " + std::to_string(points.size()) + " points, driving");
  state.counters["stixels"] = static_cast<double>(stixels.stixels().size());
  state.counters["obstacles"] = static_cast<double>(stixels.obstacles().size());
  state.counters["budget_ms"] = kStixelBudgetMs;
  state.counters["arm_Mops"] = static_cast<double>(stixels.work().scalar_ops) / 1e6;
}
BENCHMARK(BM_StixelsDriving)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime()->MinWarmUpTime(kWarmUpSeconds)->Repetitions(kRepetitions);

void BM_GridUpdate(benchmark::State& state) {
  const GridKind kind = static_cast<GridKind>(state.range(0));
  const std::vector<ObstaclePoint>& points = points_of(static_cast<int>(state.range(1)));
  OccupancyGrid grid(grid_parameters(kind));
  grid.update(points, EgoMotion{});
  for (auto _ : state) {
    grid.update(points, EgoMotion{});
    benchmark::DoNotOptimize(grid.log_odds().data());
  }
  state.SetLabel(std::string(arm::obstacles3d::grid_kind_name(kind)) + ", " + cloud_name(static_cast<int>(state.range(1))) +
                 ", " + std::to_string(points.size()) + " points");
  state.counters["obstacles"] = static_cast<double>(grid.obstacles().size());
  state.counters["arm_Mops"] = static_cast<double>(grid.work().scalar_ops) / 1e6;
}
BENCHMARK(BM_GridUpdate)
    ->ArgsProduct({{static_cast<int>(GridKind::cartesian), static_cast<int>(GridKind::column_disparity),
                    static_cast<int>(GridKind::polar)},
                   {1, 0}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime()
    ->MinWarmUpTime(kWarmUpSeconds)
    ->Repetitions(kRepetitions);

// The figures of docs/obstacles3d.md, when LPSTEREO_OBSTACLES3D_FIGURES names a folder.
void write_figures(const std::string& folder) {
  const std::vector<ObstaclePoint>& points = cloud().candidates;
  for (GridKind kind : {GridKind::cartesian, GridKind::column_disparity, GridKind::polar}) {
    OccupancyGrid grid(grid_parameters(kind));
    for (int frame = 0; frame < 3; ++frame) grid.update(points, EgoMotion{});
    const std::string path = folder + "/obstacles3d-grid-" + arm::obstacles3d::grid_kind_name(kind) + ".png";
    // Colours: blue at 40.5 m for all three (the column/disparity grid reaches 300 m).
    cv::imwrite(path, io::occupancy_grid_picture(grid, kind == GridKind::column_disparity ? 3.0 : 16.0, 40.5));
    std::printf("figure %s: %s\n", path.c_str(), grid.status().c_str());
  }
  AugmentedStixels stixels(stixel_parameters());
  for (int frame = 0; frame < 3; ++frame) stixels.update(points, EgoMotion{});
  cv::imwrite(folder + "/obstacles3d-stixels-overlay.png", io::stixel_image_overlay(cloud().scene.left_colour, stixels, points));
  cv::imwrite(folder + "/obstacles3d-stixels-top.png", io::stixel_top_view(stixels, 16.0));
  std::printf("figures %s/obstacles3d-stixels-{overlay,top}.png: %s\n", folder.c_str(), stixels.status().c_str());
}

}  // namespace
}  // namespace lpstereo

int main(int argc, char** argv) {
  std::printf("heap: %s\n", lpstereo::bench::keep_freed_heap_memory_setting().c_str());
  using namespace lpstereo;
  const Cloud& c = cloud();
  std::printf("obstacles3d_bench: synthetic road scene %dx%d, hfov %.0f deg (f %.1f px), baseline %.2f m, camera %.1f m, "
              "%zu objects (lineups at 8, 15, 25, 35 m, a car at 12 m), exact disparity; dense cloud %zu points, candidates (> %.2f m above the road) %zu "
              "points; %d threads; stixel budget %.1f ms per frame\n",
              c.options.width, c.options.height, c.options.hfov_deg, c.scene.focal_px, c.options.baseline_m,
              c.options.camera_height_m, c.options.objects.size(), c.dense.size(), kCandidateHeightM, c.candidates.size(),
              kThreads, kStixelBudgetMs);
  for (GridKind kind : {GridKind::cartesian, GridKind::column_disparity, GridKind::polar}) {
    const arm::obstacles3d::OccupancyGridParameters p = grid_parameters(kind);
    std::printf("  %s grid: columns [%g, %g) cell %g, rows [%g, %g) cell %g (%d x %d cells), k = %g sigma\n",
                arm::obstacles3d::grid_kind_name(kind), p.column_min, p.column_max, p.column_cell, p.row_min, p.row_max,
                p.row_cell, p.columns(), p.rows(), p.window_sigmas);
  }
  if (const char* folder = std::getenv("LPSTEREO_OBSTACLES3D_FIGURES")) write_figures(folder);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
