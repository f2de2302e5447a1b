#include "eval/obstacle_range.h"

#include <chrono>
#include <cmath>

#include "io/image_io.h"

namespace lpstereo::eval {
namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

double RangeTestSetup::focal_px() const {
  constexpr double kPi = 3.14159265358979323846;
  return (width / 2.0) / std::tan(hfov_deg * kPi / 360.0);
}

std::vector<io::DetectedBox> detected_boxes(const std::vector<arm::Obstacle>& obstacles) {
  std::vector<io::DetectedBox> boxes;
  for (const arm::Obstacle& obstacle : obstacles) {
    io::DetectedBox box;
    for (int i = 0; i < 4; ++i) box.bbox_px[i] = obstacle.bbox_px[i];
    box.distance_m = obstacle.distance_m;
    boxes.push_back(box);
  }
  return boxes;
}

RangeTestRunner::RangeTestRunner(const RangeTestSetup& setup, arm::ObstacleParameters detector) : setup_(setup) {
  const arm::DisparityParameters& disparity = setup.disparity;
  engine_ = std::make_unique<arm::DisparityEngine>(setup.width, setup.height, disparity, MemoryBudget{}, setup.threads);
  if (!(detector.focal_px > 0)) detector.focal_px = setup.focal_px();
  if (!(detector.baseline_m > 0)) detector.baseline_m = setup.baseline_m;
  detector_parameters_ = detector.for_disparity_range(disparity.min_disparity, disparity.num_disparities);
  detector_ = std::make_unique<arm::ObstacleDetector>(setup.width, setup.height, detector_parameters_, MemoryBudget{},
                                                      setup.threads);
}

RangeTestRunner::~RangeTestRunner() = default;

SceneResult RangeTestRunner::run(const io::StereoSynthOptions& options) {
  SceneResult result;
  auto start = std::chrono::steady_clock::now();
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  result.render_s = seconds_since(start);
  result.truth = scene.objects;

  const Plane left = io::mat_to_plane(scene.left, {ElementType::u8, 0});
  const Plane right = io::mat_to_plane(scene.right, {ElementType::u8, 0});
  start = std::chrono::steady_clock::now();
  const Plane& disparity = engine_->compute(left, right);
  result.disparity_s = seconds_since(start);

  start = std::chrono::steady_clock::now();
  const arm::ObstacleFrame frame = detector_->run(disparity, left);
  result.obstacles_s = seconds_since(start);
  result.road = frame.road;
  result.obstacles = frame.obstacles;
  result.score = io::score_frame(result.truth, detected_boxes(result.obstacles), io::MatchRule{});
  return result;
}

namespace {

io::StereoSynthOptions scene_options(const RangeTestSetup& setup, uint32_t seed) {
  io::StereoSynthOptions options;
  options.width = setup.width;
  options.height = setup.height;
  options.hfov_deg = setup.hfov_deg;
  options.baseline_m = setup.baseline_m;
  options.camera_height_m = setup.camera_height_m;
  options.noise_sigma = setup.noise_sigma;
  if (setup.real_camera) io::use_real_camera_pair(options);
  options.road_surface = setup.surface;
  options.samples_per_axis = setup.samples_per_axis;
  options.threads = setup.threads;
  options.seed = seed;
  return options;
}

}  // namespace

SceneResult RangeTestRunner::run_lineup(double distance_m, uint32_t seed) {
  io::StereoSynthOptions options = scene_options(setup_, seed);
  options.objects = io::lineup_synth_objects(distance_m);
  return run(options);
}

SceneResult RangeTestRunner::run_empty_road(uint32_t seed, double slope_deg) {
  io::StereoSynthOptions options = scene_options(setup_, seed);
  options.slope_deg = slope_deg;
  return run(options);
}

}  // namespace lpstereo::eval
