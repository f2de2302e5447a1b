// The obstacle detector's range test and false-positive runs (issue 6 acceptance) on the project's
// own scene generator: render a scene (io/stereo_synth.h), match it with the DisparityEngine, detect
// with the ObstacleDetector, score against the scene's ground truth (io/obstacle_matching.h). One
// runner serves bench/obstacle_range_bench.cpp (the full sweep at 3840x1728, printed as a table) and
// the reduced test (tests/eval/obstacle_range_test.cpp).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "arm/disparity_engine.h"
#include "arm/obstacle_detector.h"
#include "io/obstacle_matching.h"
#include "io/stereo_synth.h"

namespace lpstereo::eval {

// The camera and scene of the range test (issue 6: 3840x1728, 60 degrees, 0.30 m baseline, 1.5 m
// camera height, with sensor noise) and the disparity search.
struct RangeTestSetup {
  int width = 3840;
  int height = 1728;
  double hfov_deg = 60;
  double baseline_m = 0.30;
  double camera_height_m = 1.5;
  double noise_sigma = 2.0;     // grey levels, each view independently (with real_camera: the pair's)
  int samples_per_axis = 2;     // anti-aliasing of the renderer
  // The road and the camera pair (issue 46): the generator's textured road through cameras alike (the
  // scenes issue 6's lines are met on), or real asphalt and io::use_real_camera_pair.
  io::SynthRoadSurface surface = io::SynthRoadSurface::textured;
  bool real_camera = false;
  // The DisparityEngine's settings: the detector's (arm::obstacle_disparity_defaults) but for the
  // range, [0, 128) (20 m is 50 px at 4K; the road nearer than ~7.8 m is left invalid).
  arm::DisparityParameters disparity = [] {
    arm::DisparityParameters parameters = arm::obstacle_disparity_defaults();
    parameters.num_disparities = 128;
    return parameters;
  }();
  int threads = 2;
  double focal_px() const;      // (W / 2) / tan(hfov / 2), as the renderer
};

struct SceneResult {
  std::vector<io::SynthObjectTruth> truth;
  std::vector<arm::Obstacle> obstacles;
  io::FrameScore score;
  arm::RoadProfile road;
  double render_s = 0, disparity_s = 0, obstacles_s = 0;  // wall-clock seconds, for the bench's log only
};

class RangeTestRunner {
 public:
  // `detector` may leave focal_px, baseline_m and the disparity range unset: they come from `setup`.
  RangeTestRunner(const RangeTestSetup& setup, arm::ObstacleParameters detector = {});
  ~RangeTestRunner();

  // The lineup of issue 6 (cone, can, box, tape roll, bin, pedestrian across the road) at
  // distance_m; `seed` draws textures and noise.
  SceneResult run_lineup(double distance_m, uint32_t seed);
  // An obstacle-free road, flat (slope_deg 0) or sloped from 20 m ahead.
  SceneResult run_empty_road(uint32_t seed, double slope_deg);

  const arm::ObstacleParameters& detector_parameters() const { return detector_parameters_; }

 private:
  SceneResult run(const io::StereoSynthOptions& options);

  RangeTestSetup setup_;
  arm::ObstacleParameters detector_parameters_;
  std::unique_ptr<arm::DisparityEngine> engine_;
  std::unique_ptr<arm::ObstacleDetector> detector_;
};

// What io/obstacle_matching.h scores, from the detector's records.
std::vector<io::DetectedBox> detected_boxes(const std::vector<arm::Obstacle>& obstacles);

}  // namespace lpstereo::eval
