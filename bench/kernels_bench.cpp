// Kernel throughput on the host: lpstereo's vector kernels through the tile executor
// (run_vector_node, native back end at the active ISA level, one thread) next to the OpenCV
// function that does the same job, on the same data, in the same process, with OpenCV held to one
// thread (cv::setNumThreads(1)).
//
//   census5x5, census9x7          (no OpenCV counterpart)
//   median3x3                      vs cv::medianBlur(ksize 3)                (both replicate borders)
//   remap_bilinear (remap_q5 map)  vs cv::remap(INTER_LINEAR) with the float maps and with the
//                                  fixed-point maps of cv::convertMaps (CV_16SC2 + CV_16UC1, built
//                                  once outside the timing, as our remap_q5 map is)
//   disparity_to_points            vs cv::reprojectImageTo3D on the same CV_16S Q4 map (Q scaled by
//                                  1/16): b = 0.12 m, f = 1000 px, disparities 20 .. 72 px with 1 in
//                                  16 invalid; ours writes three s32 mm planes, OpenCV one CV_32FC3
//   point_cell_binning             (no OpenCV counterpart; beside it cv::transform of the same points
//                                  as CV_32FC3 by the 3x4 camera-to-vehicle matrix, which is only the
//                                  rotation step): the disparity_to_points output of the map above, a
//                                  level camera 1.65 m up, 34 m x 22 m area, 0.5 m cells
//   hamming_match                  vs cv::BFMatcher(NORM_HAMMING).knnMatch(k = 2) plus the ratio test
//                                  (0.8) over the 2 neighbours: N random BRIEF-256 queries, each a
//                                  copy of a train with up to 40 bits flipped (or random), against N
//                                  trains, N = 512 and 2048; the best distances are checked equal
//                                  before timing; rate = query x train pairs per second
//   sgm_8path_forward, sgm_8path_backward_sums, sgm_sums_select
//                                  (no OpenCV counterpart: disparity_bench compares whole matchers)
//                                  the host's three SGM passes alone, 64 or 128 disparities (see
//                                  sgm_sizes below)
//
// Sizes 1920x1080 and 3840x1728 (the SGM passes: their own); throughput in megapixels of output
// per second of CPU time: the rate counter "Mpx" (the console prints it with an SI prefix,
// "Mpx=2.5k/s" = 2500 megapixels/s).
// CPU time, not wall time, because everything runs on the calling thread (so the two are equal on
// an idle machine) and CPU time stays meaningful on a shared CI or developer machine.
// Each benchmark warms up for 0.1 s (not timed) and runs 5 repetitions; read the _median rows.
// The settings (ISA, tile shape, threads, OpenCV version) are printed in the context header.
// Usage: kernels_bench [--benchmark_filter=median] [--benchmark_repetitions=N] (Google Benchmark flags).
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstring>
#include <random>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "dag/plane.h"
#include "dag/remap_table.h"
#include "dag/tile_executor.h"
#include "arm/tasks/keypoint_record.h"
#include "kernels/kernel.h"
#include "kernels/match_record.h"

#include <nlohmann/json.hpp>
#include "kernels/simd/isa.h"

namespace lpstereo {
namespace {

// Output tile shape for every lpstereo kernel run here (a tile of 256x64 u8 plus halo is a few tens
// of KiB, the order of a vector engine's tile buffers).
constexpr int kTileWidth = 256;
constexpr int kTileHeight = 64;
constexpr int kRepetitions = 5;
constexpr double kWarmUpSeconds = 0.1;

// One frame's worth of inputs of a given size, built once per size and shared by all benchmarks.
struct Frame {
  cv::Mat image;                          // u8, textured
  Plane image_plane;                      // the same pixels as an lpstereo plane
  std::vector<float> map_x, map_y;        // synthetic rectification, absolute float coordinates
  cv::Mat cv_map_x, cv_map_y;             // views of map_x, map_y
  cv::Mat cv_fixed_xy, cv_fixed_fraction; // cv::convertMaps output (CV_16SC2, CV_16UC1)
  Plane map_q5;                           // the same map as remap_q5
};

const Frame& frame(int width, int height) {
  static std::map<std::pair<int, int>, Frame> frames;
  auto found = frames.find({width, height});
  if (found != frames.end()) return found->second;
  Frame& built = frames[{width, height}];
  cv::Mat noise(height, width, CV_8UC1);
  cv::randu(noise, cv::Scalar(0), cv::Scalar(256));
  cv::GaussianBlur(noise, built.image, cv::Size(5, 5), 1.0);
  built.image_plane = Plane(width, height, {ElementType::u8, 0});
  for (int y = 0; y < height; ++y) std::memcpy(built.image_plane.row<uint8_t>(y), built.image.ptr<uint8_t>(y), width);
  make_synthetic_rectification_float(width, height, {}, built.map_x, built.map_y);
  built.cv_map_x = cv::Mat(height, width, CV_32FC1, built.map_x.data());
  built.cv_map_y = cv::Mat(height, width, CV_32FC1, built.map_y.data());
  cv::convertMaps(built.cv_map_x, built.cv_map_y, built.cv_fixed_xy, built.cv_fixed_fraction, CV_16SC2);
  built.map_q5 = make_remap_q5_from_float(built.map_x.data(), built.map_y.data(), width, height, width);
  return built;
}

void set_megapixels_per_second(benchmark::State& state, int width, int height) {
  state.counters["Mpx"] = benchmark::Counter(static_cast<double>(width) * height * 1e-6,
                                              benchmark::Counter::kIsIterationInvariantRate);
}

const KernelDescriptor& kernel_named(const std::string& name) {
  const KernelDescriptor* kernel = KernelRegistry::instance().find(name);
  if (kernel == nullptr) throw std::runtime_error("kernel '" + name + "' is not registered");
  return *kernel;
}

// The timed loop of a vector node: the tile executor in kTileWidth x kTileHeight tiles on the host's
// ISA level; `output` is the plane the node writes (kept from being optimised away).
void time_vector_node(benchmark::State& state, const VectorNodeBinding& binding, const Plane& output, int width, int height) {
  const simd::Isa isa = simd::active_isa();
  for (auto _ : state) {
    run_vector_node(binding, kTileWidth, kTileHeight, KernelBackend::native, isa);
    benchmark::DoNotOptimize(output.row<uint8_t>(0));
    benchmark::ClobberMemory();
  }
  set_megapixels_per_second(state, width, height);
}

// Times one lpstereo kernel on the frame's image (and map, for the remap) through run_vector_node.
void run_lpstereo_kernel(benchmark::State& state, const std::string& name, ElementType output_type) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Frame& input = frame(width, height);
  const KernelDescriptor& kernel = kernel_named(name);
  std::vector<PlaneView> inputs = {input.image_plane.view()};
  std::vector<PlaneShape> shapes = {{width, height}};
  if (kernel.input_count() == 2) {
    inputs.push_back(input.map_q5.view());
    shapes.push_back({width, height});
  }
  const PreparedKernel prepared = kernel.prepare(nlohmann::json::object(), shapes);
  Plane output(width, height, {output_type, 0});
  const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, inputs, {output.view()}};
  time_vector_node(state, binding, output, width, height);
}

void BM_census5x5(benchmark::State& state) { run_lpstereo_kernel(state, "census5x5", ElementType::census32); }
void BM_census9x7(benchmark::State& state) { run_lpstereo_kernel(state, "census9x7", ElementType::census64); }
void BM_median3x3(benchmark::State& state) { run_lpstereo_kernel(state, "median3x3", ElementType::u8); }
void BM_remap_bilinear(benchmark::State& state) { run_lpstereo_kernel(state, "remap_bilinear", ElementType::u8); }

// An s16 Q4 disparity map from the frame's texture (20 .. 72 px), 1 pixel in 16 invalid (-16).
const Plane& disparity_frame(int width, int height) {
  static std::map<std::pair<int, int>, Plane> maps;
  auto found = maps.find({width, height});
  if (found != maps.end()) return found->second;
  const Frame& input = frame(width, height);
  Plane& map = maps[{width, height}] = Plane(width, height, {ElementType::s16, 4});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int value = (x * 7 + y * 3) % 16 == 0 ? -16 : 320 + 13 * input.image.at<uint8_t>(y, x) / 4;
      map.at<int16_t>(x, y) = static_cast<int16_t>(value);
    }
  }
  return map;
}

constexpr double kBenchBaselineM = 0.12;
constexpr double kBenchFocalPx = 1000.0;

void BM_disparity_to_points(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Plane& disparity = disparity_frame(width, height);
  const KernelDescriptor& kernel = kernel_named("disparity_to_points");
  const nlohmann::json params = {{"baseline_m", kBenchBaselineM}, {"focal_px", kBenchFocalPx}, {"u0_px", width / 2.0},
                                 {"v0_px", height / 2.0},         {"min_disparity", 0},         {"num_disparities", 128}};
  const PreparedKernel prepared = kernel.prepare(params, {{width, height}});
  const BufferFormat millimetres{ElementType::s32, 0};
  Plane x(width, height, millimetres), y(width, height, millimetres), z(width, height, millimetres);
  const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {disparity.view()},
                                  {x.view(), y.view(), z.view()}};
  time_vector_node(state, binding, z, width, height);
}

// discontinuity_near_side on disparity_frame (the settings of the terrain graphs: radius 3, jump 2 px),
// against the same rule in OpenCV: invalid pixels mapped to 32767, a 7x7 erode (the window
// minimum), then the jump test and the invalid value written where it holds.
void BM_discontinuity_near_side(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Plane& disparity = disparity_frame(width, height);
  const KernelDescriptor& kernel = kernel_named("discontinuity_near_side");
  const PreparedKernel prepared = kernel.prepare({{"invalid_q4", -16}, {"radius_px", 3}, {"jump_q4", 32}}, {{width, height}});
  Plane output(width, height, {ElementType::s16, 4});
  const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {disparity.view()}, {output.view()},
                                  prepared.input_halos};
  time_vector_node(state, binding, output, width, height);
}

void BM_opencv_erode_disparity_jump(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Plane& disparity = disparity_frame(width, height);
  const cv::Mat map(height, width, CV_16SC1, const_cast<uint8_t*>(disparity.row<uint8_t>(0)), static_cast<size_t>(disparity.stride_bytes()));
  const cv::Mat element = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(7, 7));
  cv::Mat valid_only, window_minimum, near_side, output;
  for (auto _ : state) {
    valid_only = map.clone();
    valid_only.setTo(32767, map <= -16);
    cv::erode(valid_only, window_minimum, element, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
    near_side = (map - window_minimum > 32) & (map > -16);
    output = map.clone();
    output.setTo(-16, near_side);
    benchmark::DoNotOptimize(output.data);
    benchmark::ClobberMemory();
  }
  set_megapixels_per_second(state, width, height);
}

// The disparity_to_points planes of disparity_frame (what point_cell_binning reads), built once per size.
const std::vector<Plane>& points_frame(int width, int height) {
  static std::map<std::pair<int, int>, std::vector<Plane>> frames;
  auto found = frames.find({width, height});
  if (found != frames.end()) return found->second;
  const KernelDescriptor& kernel = kernel_named("disparity_to_points");
  const nlohmann::json params = {{"baseline_m", kBenchBaselineM}, {"focal_px", kBenchFocalPx}, {"u0_px", width / 2.0},
                                 {"v0_px", height / 2.0},         {"min_disparity", 0},         {"num_disparities", 128}};
  const PreparedKernel prepared = kernel.prepare(params, {{width, height}});
  std::vector<Plane>& planes = frames[{width, height}];
  for (int p = 0; p < 3; ++p) planes.emplace_back(width, height, BufferFormat{ElementType::s32, 0});
  const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {disparity_frame(width, height).view()},
                                  {planes[0].view(), planes[1].view(), planes[2].view()}};
  run_vector_node(binding, kTileWidth, kTileHeight, KernelBackend::native, simd::active_isa());
  return planes;
}

void BM_point_cell_binning(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const std::vector<Plane>& points = points_frame(width, height);
  const KernelDescriptor& kernel = kernel_named("point_cell_binning");
  const nlohmann::json params = {{"translation_mm", {0, 0, 1650}}};  // the level camera, the default area
  const PreparedKernel prepared = kernel.prepare(params, {{width, height}, {width, height}, {width, height}});
  const BufferFormat millimetres{ElementType::s32, 0};
  Plane cell(width, height, millimetres), height_mm(width, height, millimetres);
  const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0,
                                  {points[0].view(), points[1].view(), points[2].view()}, {cell.view(), height_mm.view()}};
  const simd::Isa isa = simd::active_isa();
  for (auto _ : state) {
    run_vector_node(binding, kTileWidth, kTileHeight, KernelBackend::native, isa);
    benchmark::DoNotOptimize(cell.row<uint8_t>(0));
    benchmark::ClobberMemory();
  }
  set_megapixels_per_second(state, width, height);
}

void BM_opencv_transform_points(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const std::vector<Plane>& points = points_frame(width, height);
  cv::Mat xyz(height, width, CV_32FC3);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      for (int c = 0; c < 3; ++c) xyz.at<cv::Vec3f>(v, u)[c] = static_cast<float>(points[static_cast<size_t>(c)].at<int32_t>(u, v));
    }
  }
  const cv::Mat to_vehicle = (cv::Mat_<double>(3, 4) << 0, 0, 1, 0, -1, 0, 0, 0, 0, -1, 0, 1650);
  cv::Mat output;
  for (auto _ : state) {
    cv::transform(xyz, output, to_vehicle);
    benchmark::DoNotOptimize(output.data);
    benchmark::ClobberMemory();
  }
  set_megapixels_per_second(state, width, height);
}

// Times `function(frame, output)`, an OpenCV call on the frame's inputs.
template <class Function>
void run_opencv(benchmark::State& state, const Function& function) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Frame& input = frame(width, height);
  cv::Mat output;
  for (auto _ : state) {
    function(input, output);
    benchmark::DoNotOptimize(output.data);
    benchmark::ClobberMemory();
  }
  set_megapixels_per_second(state, width, height);
}

void BM_opencv_medianBlur3(benchmark::State& state) {
  run_opencv(state, [](const Frame& input, cv::Mat& output) { cv::medianBlur(input.image, output, 3); });
}

void BM_opencv_remap_linear_float_map(benchmark::State& state) {
  run_opencv(state, [](const Frame& input, cv::Mat& output) {
    cv::remap(input.image, output, input.cv_map_x, input.cv_map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  });
}

void BM_opencv_remap_linear_fixed_map(benchmark::State& state) {
  run_opencv(state, [](const Frame& input, cv::Mat& output) {
    cv::remap(input.image, output, input.cv_fixed_xy, input.cv_fixed_fraction, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  });
}

void BM_opencv_reprojectImageTo3D(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const Plane& disparity = disparity_frame(width, height);
  const cv::Mat map(height, width, CV_16SC1, disparity.row<int16_t>(0), static_cast<size_t>(disparity.stride_bytes()));
  // OpenCV's Q (stereoRectify) for a raw Q4 map: W = d_q4 / (16 B).
  const cv::Mat q = (cv::Mat_<double>(4, 4) << 1, 0, 0, -width / 2.0, 0, 1, 0, -height / 2.0, 0, 0, 0, kBenchFocalPx, 0, 0,
                     1.0 / (16 * kBenchBaselineM), 0);
  run_opencv(state, [&](const Frame&, cv::Mat& output) { cv::reprojectImageTo3D(map, output, q, true); });
}

// N BRIEF-256 descriptors (8 u32 words, the bytes OpenCV reads as 32 CV_8U columns) of a train set
// and of a query set made of near copies, with all-valid keypoint lists.
struct DescriptorSets {
  Plane query, train, query_keypoints, train_keypoints;
  cv::Mat cv_query, cv_train;
};

const DescriptorSets& descriptor_sets(int count) {
  static std::map<int, DescriptorSets> sets;
  auto found = sets.find(count);
  if (found != sets.end()) return found->second;
  DescriptorSets& built = sets[count];
  std::mt19937 generator(7);
  built.query = Plane(8, count, {ElementType::u32, 0});
  built.train = Plane(8, count, {ElementType::u32, 0});
  built.query_keypoints = Plane(arm::kKeypointWords, count, {ElementType::s32, 0});
  built.train_keypoints = Plane(arm::kKeypointWords, count, {ElementType::s32, 0});
  for (int k = 0; k < count; ++k) {
    for (int w = 0; w < 8; ++w) built.train.at<uint32_t>(w, k) = static_cast<uint32_t>(generator());
  }
  for (int k = 0; k < count; ++k) {
    const int source = static_cast<int>(generator() % static_cast<uint32_t>(count));
    for (int w = 0; w < 8; ++w) {
      built.query.at<uint32_t>(w, k) = k % 4 == 3 ? static_cast<uint32_t>(generator()) : built.train.at<uint32_t>(w, source);
    }
    const int flips = static_cast<int>(generator() % 41);
    for (int f = 0; f < flips; ++f) {
      const uint32_t bit = generator() % 256;
      built.query.at<uint32_t>(static_cast<int>(bit / 32), k) ^= uint32_t{1} << (bit % 32);
    }
    for (Plane* list : {&built.query_keypoints, &built.train_keypoints}) {
      list->at<int32_t>(arm::kKeypointValid, k) = 1;
      list->at<int32_t>(arm::kKeypointXPx, k) = k;
      list->at<int32_t>(arm::kKeypointYPx, k) = 0;
      list->at<int32_t>(arm::kKeypointResponse, k) = 0;
    }
  }
  built.cv_query = cv::Mat(count, 32, CV_8UC1, built.query.row<uint8_t>(0), static_cast<size_t>(built.query.stride_bytes()));
  built.cv_train = cv::Mat(count, 32, CV_8UC1, built.train.row<uint8_t>(0), static_cast<size_t>(built.train.stride_bytes()));
  return built;
}

void set_pairs_per_second(benchmark::State& state, int count) {
  state.counters["pairs"] = benchmark::Counter(static_cast<double>(state.iterations()) * count * count, benchmark::Counter::kIsRate);
}

void BM_hamming_match(benchmark::State& state) {
  const int count = static_cast<int>(state.range(0));
  const DescriptorSets& sets = descriptor_sets(count);
  const KernelDescriptor& kernel = kernel_named("hamming_match");
  const PreparedKernel prepared = kernel.prepare({{"ratio_q8", 205}}, {{8, count}, {4, count}, {8, count}, {4, count}});
  Plane matches(kernels::kMatchWords, count, {ElementType::s32, 0});
  const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0,
                                  {sets.query.view(), sets.query_keypoints.view(), sets.train.view(), sets.train_keypoints.view()},
                                  {matches.view()}};
  const simd::Isa isa = simd::active_isa();
  run_vector_node(binding, kernels::kMatchWords, kTileHeight, KernelBackend::native, isa);
  std::vector<std::vector<cv::DMatch>> cv_matches;
  cv::BFMatcher(cv::NORM_HAMMING).knnMatch(sets.cv_query, sets.cv_train, cv_matches, 2);
  for (int q = 0; q < count; ++q) {
    if (cv_matches[static_cast<size_t>(q)][0].distance != static_cast<float>(matches.at<int32_t>(kernels::kMatchBestDistance, q))) {
      state.SkipWithError("hamming_match and cv::BFMatcher disagree on a best distance");
      return;
    }
  }
  for (auto _ : state) {
    run_vector_node(binding, kernels::kMatchWords, kTileHeight, KernelBackend::native, isa);
    benchmark::DoNotOptimize(matches.row<uint8_t>(0));
    benchmark::ClobberMemory();
  }
  set_pairs_per_second(state, count);
}

void BM_opencv_BFMatcher_knn2_ratio(benchmark::State& state) {
  const int count = static_cast<int>(state.range(0));
  const DescriptorSets& sets = descriptor_sets(count);
  const cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> cv_matches;
  for (auto _ : state) {
    matcher.knnMatch(sets.cv_query, sets.cv_train, cv_matches, 2);
    int accepted = 0;
    for (const auto& pair : cv_matches) accepted += pair.size() == 2 && pair[0].distance < 0.8f * pair[1].distance;
    benchmark::DoNotOptimize(accepted);
  }
  set_pairs_per_second(state, count);
}

// The three passes of the two-pass-side-by-side 8-path SGM layout (graph files may use it; the
// engine runs sgm_8path_bands, which holds no volume), each alone on one thread: sgm_8path_forward and sgm_8path_backward_sums (each
// writes its u16 sums volume, W x H x D) and sgm_sums_select (reads both, selects with the engine's
// defaults: uniqueness 5 %, sub-pixel, LR check 2 px). Census 5x5 of the frame's texture and of the
// same texture shifted by kSgmShiftPx. Sizes: 640x480 with 64 disparities (the obstacle chain's),
// 1242x375 with 128 (KITTI's), and 256x128 with 64, whose two 4 MB volumes stay in the caches (the
// passes' arithmetic without the DRAM traffic). Megapixels of disparity a second, as the others.
constexpr int kSgmShiftPx = 17;

struct SgmFrame {
  Plane left_census, right_census;
  Plane forward_sums, backward_sums, disparity;
  nlohmann::json path_params, select_params;
};

SgmFrame& sgm_frame(int width, int height, int disparities) {
  static std::map<std::tuple<int, int, int>, SgmFrame> frames;
  auto found = frames.find({width, height, disparities});
  if (found != frames.end()) return found->second;
  SgmFrame& built = frames[{width, height, disparities}];
  const Frame& input = frame(width, height);
  Plane shifted(width, height, {ElementType::u8, 0});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) shifted.at<uint8_t>(x, y) = input.image.at<uint8_t>(y, std::min(width - 1, x + kSgmShiftPx));
  }
  const KernelDescriptor& census = kernel_named("census5x5");
  built.left_census = Plane(width, height, census.ports[1].format);
  built.right_census = Plane(width, height, census.ports[1].format);
  census.reference({input.image_plane.view()}, {built.left_census.view()}, nullptr, BorderMode::replicate, 0);
  census.reference({shifted.view()}, {built.right_census.view()}, nullptr, BorderMode::replicate, 0);
  built.path_params = {{"min_disparity", 0}, {"num_disparities", disparities}, {"p1", 5}, {"p2", 45}};
  built.select_params = built.path_params;
  built.select_params["uniqueness_percent"] = 5;
  built.select_params["subpixel"] = 1;
  built.select_params["lr_max_diff"] = 2;
  built.forward_sums = Plane(width * disparities, height, {ElementType::u16, 0});
  built.backward_sums = Plane(width * disparities, height, {ElementType::u16, 0});
  built.disparity = Plane(width, height, {ElementType::s16, 4});
  // The path passes once, so that the selection reads this frame's sums whichever benchmarks a
  // filter selects (zeroed volumes would make every disparity tie).
  for (const auto& [name, sums] : {std::pair<const char*, Plane*>{"sgm_8path_forward", &built.forward_sums},
                                   std::pair<const char*, Plane*>{"sgm_8path_backward_sums", &built.backward_sums}}) {
    const KernelDescriptor& kernel = kernel_named(name);
    const PreparedKernel prepared = kernel.prepare(built.path_params, {{width, height}, {width, height}});
    const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0,
                                    {built.left_census.view(), built.right_census.view()}, {sums->view()}, prepared.input_halos};
    run_vector_node(binding, kTileWidth, kTileHeight, KernelBackend::native, simd::active_isa());
  }
  return built;
}

// One SGM pass on the frame: a path pass rewrites its sums volume (the same values), the selection
// reads both.
void run_sgm_pass(benchmark::State& state, const std::string& name) {
  const int width = static_cast<int>(state.range(0));
  const int height = static_cast<int>(state.range(1));
  const int disparities = static_cast<int>(state.range(2));
  SgmFrame& sgm = sgm_frame(width, height, disparities);
  const KernelDescriptor& kernel = kernel_named(name);
  const bool select = name == "sgm_sums_select";
  std::vector<PlaneShape> shapes;
  std::vector<PlaneView> inputs;
  if (select) {
    shapes = {{sgm.forward_sums.width(), height}, {sgm.backward_sums.width(), height}};
    inputs = {sgm.forward_sums.view(), sgm.backward_sums.view()};
  } else {
    shapes = {{width, height}, {width, height}};
    inputs = {sgm.left_census.view(), sgm.right_census.view()};
  }
  const PreparedKernel prepared = kernel.prepare(select ? sgm.select_params : sgm.path_params, shapes);
  Plane& output = select ? sgm.disparity : name == "sgm_8path_forward" ? sgm.forward_sums : sgm.backward_sums;
  const VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, inputs, {output.view()},
                                  prepared.input_halos};
  time_vector_node(state, binding, output, width, height);
}

void BM_sgm_8path_forward(benchmark::State& state) { run_sgm_pass(state, "sgm_8path_forward"); }
void BM_sgm_8path_backward_sums(benchmark::State& state) { run_sgm_pass(state, "sgm_8path_backward_sums"); }
void BM_sgm_sums_select(benchmark::State& state) { run_sgm_pass(state, "sgm_sums_select"); }

void sgm_sizes(benchmark::internal::Benchmark* benchmark) {
  benchmark->ArgNames({"width", "height", "disparities"})
      ->Args({640, 480, 64})
      ->Args({1242, 375, 128})
      ->Args({256, 128, 64})
      ->Unit(benchmark::kMillisecond)
      ->MinWarmUpTime(kWarmUpSeconds)
      ->Repetitions(kRepetitions)
      ->ReportAggregatesOnly(true);
}

void descriptor_counts(benchmark::internal::Benchmark* benchmark) {
  benchmark->ArgNames({"descriptors"})
      ->Arg(512)
      ->Arg(2048)
      ->Unit(benchmark::kMillisecond)
      ->MinWarmUpTime(kWarmUpSeconds)
      ->Repetitions(kRepetitions)
      ->ReportAggregatesOnly(true);
}

void sizes(benchmark::internal::Benchmark* benchmark) {
  benchmark->ArgNames({"width", "height"})
      ->Args({1920, 1080})
      ->Args({3840, 1728})
      ->Unit(benchmark::kMillisecond)
      ->MinWarmUpTime(kWarmUpSeconds)
      ->Repetitions(kRepetitions)
      ->ReportAggregatesOnly(true);
}

BENCHMARK(BM_census5x5)->Apply(sizes);
BENCHMARK(BM_census9x7)->Apply(sizes);
BENCHMARK(BM_median3x3)->Apply(sizes);
BENCHMARK(BM_opencv_medianBlur3)->Apply(sizes);
BENCHMARK(BM_remap_bilinear)->Apply(sizes);
BENCHMARK(BM_opencv_remap_linear_float_map)->Apply(sizes);
BENCHMARK(BM_opencv_remap_linear_fixed_map)->Apply(sizes);
BENCHMARK(BM_discontinuity_near_side)->Apply(sizes);
BENCHMARK(BM_opencv_erode_disparity_jump)->Apply(sizes);
BENCHMARK(BM_disparity_to_points)->Apply(sizes);
BENCHMARK(BM_opencv_reprojectImageTo3D)->Apply(sizes);
BENCHMARK(BM_point_cell_binning)->Apply(sizes);
BENCHMARK(BM_opencv_transform_points)->Apply(sizes);
BENCHMARK(BM_sgm_8path_forward)->Apply(sgm_sizes);
BENCHMARK(BM_sgm_8path_backward_sums)->Apply(sgm_sizes);
BENCHMARK(BM_sgm_sums_select)->Apply(sgm_sizes);
BENCHMARK(BM_hamming_match)->Apply(descriptor_counts);
BENCHMARK(BM_opencv_BFMatcher_knn2_ratio)->Apply(descriptor_counts);

}  // namespace
}  // namespace lpstereo

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("lpstereo_isa", std::string(lpstereo::simd::isa_name(lpstereo::simd::active_isa())));
  benchmark::AddCustomContext("lpstereo_tile", std::to_string(lpstereo::kTileWidth) + "x" +
                                                   std::to_string(lpstereo::kTileHeight) + " px, border replicate");
  benchmark::AddCustomContext("threads", "1 (lpstereo: tiles on the calling thread; OpenCV: cv::setNumThreads(1), "
                                         "cv::getNumThreads() = " + std::to_string(cv::getNumThreads()) + ")");
  benchmark::AddCustomContext("opencv", CV_VERSION);
  benchmark::AddCustomContext("sizes", "1920x1080 and 3840x1728 u8 (textured noise); remap map: synthetic "
                                       "rectification (dag/remap_table.h defaults); SGM passes: 640x480 with 64 "
                                       "disparities, 1242x375 with 128, 256x128 with 64, census 5x5, P1 5, P2 45, "
                                       "the right view shifted " + std::to_string(lpstereo::kSgmShiftPx) + " px");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
