// Dense disparity on the host: lpstereo's arm::DisparityEngine (8-path SGM, its default, and 4-path;
// every other setting the engine's default, printed) next to OpenCV's StereoSGBM in MODE_SGBM,
// MODE_SGBM_3WAY and MODE_HH, same process, same u8 luma inputs, same disparity range, 2 threads for both:
//   OpenCV: cv::setNumThreads(2); lpstereo: the engine's FrameRunner with 2 worker threads.
// Sizes 640x480 and 1242x375, 128 disparities [0, 128). Inputs: the real pairs when the shared data
// folder exists ($LPSTEREO_SHARED_DATA or ../shared/data: KITTI 2015 000046 at 1242x375, the
// top-left 640x480 of Middlebury 2014 Motorcycle), else the synthetic scene (io/synthetic_scene.h).
// The engine and the matchers are built outside the timing (graph build and verify are not timed).
// Each benchmark warms up for 0.5 s (not timed), then runs 7 repetitions; read the _median rows.
// Wall-clock time (UseRealTime), as both run on 2 threads. Counters per frame: ms, fps, and MDE/s
// (million disparity evaluations per second = W * H * D / seconds / 1e6).
// The speckle filter alone (the engine's last step, arm/tasks/speckle_filter.cpp) beside OpenCV's
// cv::filterSpeckles with the same settings, on the engine's map before it (8 paths, the median on,
// speckles off): BM_speckle_filter/threads:1 and :2 (the bands on the engine's workers) against
// BM_opencv_filterSpeckles (one thread: OpenCV's is not parallel); each iteration copies the map
// and filters the copy, as the engine's task does.
// BM_lpstereo_two_in_flight: two frames at once on two one-worker engines (streaming throughput).
// Usage: disparity_bench [--benchmark_filter=opencv] (Google Benchmark flags).
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include <chrono>
#include <filesystem>
#include <future>
#include <map>
#include <string>

#include "arm/disparity_engine.h"
#include "dag/arm_task.h"
#include "io/image_io.h"
#include "io/opencv_sgbm.h"
#include "io/stereo_datasets.h"
#include "io/synthetic_scene.h"
#include "kernels/simd/isa.h"
#include "bench/heap_setting.h"

namespace lpstereo {
namespace {

constexpr int kDisparities = 128;
constexpr int kThreads = 2;
constexpr int kRepetitions = 7;
constexpr double kWarmUpSeconds = 0.5;

struct Pair {
  Plane left, right;
  cv::Mat left_mat, right_mat;
  std::string source;
};

Plane crop(const Plane& plane, int width, int height) {
  return io::mat_to_plane(io::plane_to_mat(plane)(cv::Rect(0, 0, width, height)).clone(), plane.format());
}

// The real pair of that size when the shared data is there, else the synthetic scene.
Pair load_pair(int width, int height) {
  Pair pair;
  const std::string data = io::shared_data_directory();
  try {
    if (width == 1242 && height == 375 && std::filesystem::is_directory(data + "/kitti2015")) {
      io::StereoPair kitti = io::load_kitti2015_frame(data + "/kitti2015");
      pair.left = kitti.left;
      pair.right = kitti.right;
      pair.source = "KITTI 2015 000046 (" + data + ")";
    } else if (width == 640 && height == 480 && std::filesystem::is_directory(data + "/middlebury2014/Motorcycle")) {
      io::StereoPair motorcycle = io::load_middlebury2014_scene(data + "/middlebury2014/Motorcycle");
      pair.left = crop(motorcycle.left, width, height);
      pair.right = crop(motorcycle.right, width, height);
      pair.source = "Middlebury 2014 Motorcycle, top-left 640x480 (" + data + ")";
    }
  } catch (const std::exception&) {
    pair.source.clear();  // unreadable data: fall back to the synthetic scene
  }
  if (pair.source.empty()) {
    io::SyntheticSceneOptions options;
    options.width = width;
    options.height = height;
    const io::SyntheticStereoScene scene = io::make_synthetic_stereo_scene(options);
    pair.left = scene.left;
    pair.right = scene.right;
    pair.source = "synthetic scene (io/synthetic_scene.h)";
  }
  pair.left_mat = io::plane_to_mat(pair.left);
  pair.right_mat = io::plane_to_mat(pair.right);
  return pair;
}

const Pair& pair_of_size(int width, int height) {
  static std::map<std::pair<int, int>, Pair> pairs;
  auto found = pairs.find({width, height});
  if (found == pairs.end()) found = pairs.emplace(std::make_pair(width, height), load_pair(width, height)).first;
  return found->second;
}

// Per frame: ms (wall clock measured around the timed loop, a plain number so it prints without a
// unit suffix), fps and MDE/s (rates over the benchmark's own time).
// `frames` per iteration: the pairs-in-flight rows run two frames an iteration.
void set_counters(benchmark::State& state, int width, int height, std::chrono::steady_clock::duration loop_time, int frames = 1) {
  using benchmark::Counter;
  const double loop_ms = std::chrono::duration<double, std::milli>(loop_time).count();
  const double iterations = static_cast<double>(state.iterations());
  state.counters["ms"] = Counter(state.iterations() > 0 ? loop_ms / (iterations * frames) : 0.0);
  state.counters["fps"] = Counter(frames, Counter::kIsIterationInvariantRate);
  state.counters["MDE/s"] = Counter(frames * static_cast<double>(width) * height * kDisparities * 1e-6, Counter::kIsIterationInvariantRate);
}

// Times the engine with `parameters` (0 to 128 disparities set here) on `worker_threads` threads.
void time_engine(benchmark::State& state, arm::DisparityParameters parameters, int worker_threads) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Pair& pair = pair_of_size(width, height);
  parameters.min_disparity = 0;
  parameters.num_disparities = kDisparities;
  arm::DisparityEngine engine(width, height, parameters, {}, worker_threads);
  // One frame before the timing: the engine's first frame faults in its buffers, which a running
  // system pays once, not per frame (the one-shot cost is bench/oneshot-disparity.sh's). Google
  // Benchmark calls this function afresh for its warm-up and for each repetition, each with a new
  // engine, so the warm-up time alone does not drop it.
  engine.compute(pair.left, pair.right);
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const Plane& disparity = engine.compute(pair.left, pair.right);
    benchmark::DoNotOptimize(disparity.row<int16_t>(0));
    benchmark::ClobberMemory();
  }
  set_counters(state, width, height, std::chrono::steady_clock::now() - start);
}

void run_lpstereo(benchmark::State& state, int paths) {
  arm::DisparityParameters parameters;
  parameters.paths = paths;
  time_engine(state, parameters, kThreads);
}

void BM_lpstereo_4path(benchmark::State& state) { run_lpstereo(state, 4); }
void BM_lpstereo_8path(benchmark::State& state) { run_lpstereo(state, 8); }

// The engine on ONE worker thread (what `--threads 1` and a pipeline stage of one thread run):
// 8 paths by bands (checkpoints, then the bands one after the other), 4 paths in one pass.
void BM_lpstereo_one_worker(benchmark::State& state) {
  arm::DisparityParameters parameters;
  parameters.paths = static_cast<int>(state.range(2));
  time_engine(state, parameters, 1);
}

// Two pairs in flight (what `lpstereo run` does on a recording with 2 threads, tools/disparity_lanes.h):
// two engines of one worker each, each on its own frame at once; ms and fps per frame of the
// throughput (an iteration is two frames), the latency of a frame being the one-worker row's.
void BM_lpstereo_two_in_flight(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Pair& pair = pair_of_size(width, height);
  arm::DisparityParameters parameters;
  parameters.paths = static_cast<int>(state.range(2));
  parameters.min_disparity = 0;
  parameters.num_disparities = kDisparities;
  arm::DisparityEngine first(width, height, parameters, {}, 1), second(width, height, parameters, {}, 1);
  first.compute(pair.left, pair.right);  // first frames untimed, as time_engine's
  second.compute(pair.left, pair.right);
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    std::future<const Plane*> other = std::async(std::launch::async, [&] { return &second.compute(pair.left, pair.right); });
    const Plane& disparity = first.compute(pair.left, pair.right);
    benchmark::DoNotOptimize(disparity.row<int16_t>(0));
    benchmark::DoNotOptimize(other.get()->row<int16_t>(0));
    benchmark::ClobberMemory();
  }
  set_counters(state, width, height, std::chrono::steady_clock::now() - start, 2);
}

void run_opencv(benchmark::State& state, io::SgbmMode mode) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Pair& pair = pair_of_size(width, height);
  const cv::Ptr<cv::StereoSGBM> matcher = io::make_opencv_sgbm(0, kDisparities, mode);
  cv::Mat disparity;
  matcher->compute(pair.left_mat, pair.right_mat, disparity);  // its first frame untimed too, as the engine's
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    matcher->compute(pair.left_mat, pair.right_mat, disparity);
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  set_counters(state, width, height, std::chrono::steady_clock::now() - start);
}

void BM_opencv_MODE_SGBM(benchmark::State& state) { run_opencv(state, io::SgbmMode::sgbm); }
void BM_opencv_MODE_SGBM_3WAY(benchmark::State& state) { run_opencv(state, io::SgbmMode::sgbm_3way); }
void BM_opencv_MODE_HH(benchmark::State& state) { run_opencv(state, io::SgbmMode::hh); }

void sizes(benchmark::internal::Benchmark* benchmark) {
  benchmark->ArgNames({"width", "height"})
      ->Args({640, 480})
      ->Args({1242, 375})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->MinWarmUpTime(kWarmUpSeconds)
      ->Repetitions(kRepetitions)
      ->ReportAggregatesOnly(true);
}

// The engine's map before the speckle filter (the median on), for the speckle benchmarks.
const Plane& unfiltered_map(int width, int height) {
  static std::map<std::pair<int, int>, Plane> maps;
  auto found = maps.find({width, height});
  if (found == maps.end()) {
    arm::DisparityParameters parameters;
    parameters.num_disparities = kDisparities;
    parameters.speckle_max_size_px = 0;
    const Pair& pair = pair_of_size(width, height);
    arm::DisparityEngine engine(width, height, parameters, {}, kThreads);
    found = maps.emplace(std::make_pair(width, height), engine.compute(pair.left, pair.right).clone()).first;
  }
  return found->second;
}

// The engine's speckle settings, in the task's units.
nlohmann::json speckle_params(int threads) {
  const arm::DisparityParameters defaults;
  return {{"max_speckle_size", defaults.speckle_max_size_px},
          {"max_difference_q4", defaults.speckle_max_difference_px * 16},
          {"invalid_q4", (defaults.min_disparity - 1) * 16},
          {"threads", threads}};
}

void BM_speckle_filter(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const Plane& input = unfiltered_map(width, height);
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("speckle_filter");
  if (task == nullptr) {
    state.SkipWithError("ARM task 'speckle_filter' is not registered");
    return;
  }
  const PreparedKernel prepared = task->prepare(speckle_params(static_cast<int>(state.range(2))), {{width, height}});
  Plane output(width, height, input.format());
  ArmWork work;
  ArmTaskArgs args{{&input}, {&output}, prepared.params.get(), &work};
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    task->run(args);
    benchmark::DoNotOptimize(output.row<int16_t>(0));
    benchmark::ClobberMemory();
  }
  set_counters(state, width, height, std::chrono::steady_clock::now() - start);
}

void BM_opencv_filterSpeckles(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0)), height = static_cast<int>(state.range(1));
  const cv::Mat input = io::plane_to_mat(unfiltered_map(width, height));
  const nlohmann::json params = speckle_params(1);
  cv::Mat output, buffer;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    input.copyTo(output);
    cv::filterSpeckles(output, params["invalid_q4"].get<int>(), params["max_speckle_size"].get<int>(),
                       params["max_difference_q4"].get<int>(), buffer);
    benchmark::DoNotOptimize(output.data);
    benchmark::ClobberMemory();
  }
  set_counters(state, width, height, std::chrono::steady_clock::now() - start);
}

BENCHMARK(BM_lpstereo_4path)->Apply(sizes);
BENCHMARK(BM_lpstereo_8path)->Apply(sizes);
BENCHMARK(BM_lpstereo_one_worker)
    ->ArgNames({"width", "height", "paths"})
    ->ArgsProduct({{640}, {480}, {8, 4}})
    ->Args({1242, 375, 8})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinWarmUpTime(kWarmUpSeconds)
    ->Repetitions(kRepetitions)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_lpstereo_two_in_flight)
    ->ArgNames({"width", "height", "paths"})
    ->ArgsProduct({{640}, {480}, {4, 8}})
    ->Args({1242, 375, 4})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinWarmUpTime(kWarmUpSeconds)
    ->Repetitions(kRepetitions)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_opencv_MODE_SGBM)->Apply(sizes);
BENCHMARK(BM_opencv_MODE_SGBM_3WAY)->Apply(sizes);
BENCHMARK(BM_opencv_MODE_HH)->Apply(sizes);
BENCHMARK(BM_speckle_filter)
    ->ArgNames({"width", "height", "threads"})
    ->ArgsProduct({{640}, {480}, {1, 2}})
    ->Args({1242, 375, 1})
    ->Args({1242, 375, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinWarmUpTime(kWarmUpSeconds)
    ->Repetitions(kRepetitions)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_opencv_filterSpeckles)->Apply(sizes);

}  // namespace
}  // namespace lpstereo

int main(int argc, char** argv) {
  const std::string heap = lpstereo::bench::keep_freed_heap_memory_setting();
  cv::setNumThreads(lpstereo::kThreads);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  const lpstereo::arm::DisparityParameters engine_defaults;
  benchmark::AddCustomContext("threads", "2 for both (OpenCV: cv::setNumThreads(2), cv::getNumThreads() = " +
                                             std::to_string(cv::getNumThreads()) +
                                             "; lpstereo: FrameRunner with 2 worker threads)");
  benchmark::AddCustomContext("disparities", "[0, 128): 128 for both");
  lpstereo::arm::DisparityParameters four_path = engine_defaults;
  four_path.paths = 4;
  benchmark::AddCustomContext("lpstereo 8path", "arm::DisparityEngine defaults: " + lpstereo::arm::settings_text(engine_defaults));
  benchmark::AddCustomContext("lpstereo 4path", "arm::DisparityEngine: " + lpstereo::arm::settings_text(four_path));
  benchmark::AddCustomContext("lpstereo isa", std::string(lpstereo::simd::isa_name(lpstereo::simd::active_isa())));
  benchmark::AddCustomContext("opencv", lpstereo::io::sgbm_settings_text({}));
  benchmark::AddCustomContext("input 640x480", lpstereo::pair_of_size(640, 480).source);
  benchmark::AddCustomContext("input 1242x375", lpstereo::pair_of_size(1242, 375).source);
  benchmark::AddCustomContext("heap", heap);
  benchmark::AddCustomContext("timing", "wall clock; 0.5 s warm-up, 7 repetitions, read the _median rows; "
                                        "MDE/s = W*H*D/seconds/1e6");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
