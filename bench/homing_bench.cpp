// Issue 8's drone-homing acceptance (docs/localization.md, "Homing"): the project's synthetic flight
// (io/stereo_flight.h: take-off from the pad, the square through four waypoints, return, landing) for
// several seeds, with sensor noise and yaw changes (even seeds: 90-degree turns at the corners; odd
// seeds: continuous yaw), run through the keyframe localizer (arm/localization/localizer.h) twice on
// the same frames: with keyframe corrections and visual height, and with visual odometry alone. Per
// seed: the landing error, the distance between the true and the estimated left-camera position at
// the last frame (cm; both relative to the first frame's camera, as poses.txt), for both runs; then
// the median and the largest. Acceptance: at most 10 cm with corrections.
//
// Not a test: it renders hundreds of frames per seed (minutes). Options:
//   --seeds N (4)  --first-seed S (1)  --width W (640) --height H (480) --fps F (10) --side-m M (6)
//   --noise SIGMA (2, grey levels) --threads T (2) --log DIR (per-seed JSON lines of the corrected run)
// Exit status 1 when a corrected landing error exceeds 10 cm.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "arm/localization/localizer.h"
#include "io/image_io.h"
#include "io/stereo_flight.h"
#include "bench/heap_setting.h"

namespace {

using lpstereo::arm::localization::KeyframeLocalizer;
using lpstereo::arm::localization::KeyframeLocalizerParameters;
using lpstereo::arm::localization::LocalizerFrame;

struct Options {
  int seeds = 4, first_seed = 1, width = 640, height = 480, threads = 2;
  double fps = 10, side_m = 6, noise = 2;
  std::string log_directory;
};

bool parse(int argc, char** argv, Options& options) {
  for (int i = 1; i < argc; ++i) {
    const std::string name = argv[i];
    if (i + 1 >= argc) return false;
    const char* value = argv[++i];
    if (name == "--seeds") options.seeds = std::atoi(value);
    else if (name == "--first-seed") options.first_seed = std::atoi(value);
    else if (name == "--width") options.width = std::atoi(value);
    else if (name == "--height") options.height = std::atoi(value);
    else if (name == "--fps") options.fps = std::atof(value);
    else if (name == "--side-m") options.side_m = std::atof(value);
    else if (name == "--noise") options.noise = std::atof(value);
    else if (name == "--threads") options.threads = std::atoi(value);
    else if (name == "--log") options.log_directory = value;
    else return false;
  }
  return options.seeds >= 1 && options.width >= 64 && options.height >= 64 && options.fps > 0 && options.threads >= 1;
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

struct SeedResult {
  int seed = 0;
  std::string yaw;
  int frames = 0;
  double path_m = 0;
  double corrected_cm = 0, odometry_only_cm = 0;
  int keyframes = 0, accepted_corrections = 0, invalid_odometry = 0;
  double final_sigma_cm = 0;
  double seconds = 0;
};

}  // namespace

int main(int argc, char** argv) {
  std::printf("heap: %s\n", lpstereo::bench::keep_freed_heap_memory_setting().c_str());
  Options options;
  if (!parse(argc, argv, options)) {
    std::fprintf(stderr,
                 "usage: homing_bench [--seeds N] [--first-seed S] [--width W] [--height H] [--fps F] [--side-m M] "
                 "[--noise SIGMA] [--threads T] [--log DIR]\n");
    return 2;
  }
  std::printf("homing_bench: %d seeds from %d, %dx%d, %.0f fps, square side %.1f m, noise sigma %.1f grey levels, %d threads\n",
              options.seeds, options.first_seed, options.width, options.height, options.fps, options.side_m, options.noise,
              options.threads);
  std::vector<SeedResult> results;
  for (int seed = options.first_seed; seed < options.first_seed + options.seeds; ++seed) {
    const auto started = std::chrono::steady_clock::now();
    lpstereo::io::StereoFlightOptions flight;
    flight.width = options.width;
    flight.height = options.height;
    flight.fps = options.fps;
    flight.side_m = options.side_m;
    flight.noise_sigma = options.noise;
    flight.seed = static_cast<uint32_t>(seed);
    flight.threads = options.threads;
    // Yaw changes: corners (90 degrees at each waypoint, a full turn over the flight) or continuous.
    flight.yaw_mode = seed % 2 == 0 ? lpstereo::io::FlightYawMode::corners : lpstereo::io::FlightYawMode::continuous;
    lpstereo::io::validate_flight_options(flight);
    const lpstereo::io::FlightPlan plan = lpstereo::io::plan_flight(flight);
    const lpstereo::io::StereoCalibration calibration = lpstereo::io::flight_calibration(flight);

    KeyframeLocalizerParameters parameters;
    parameters.focal_px = lpstereo::io::flight_focal_px(flight);
    parameters.principal_point_x_px = calibration.left.cx_px;
    parameters.principal_point_y_px = calibration.left.cy_px;
    parameters.baseline_m = flight.baseline_m;
    parameters.start_height_m = flight.start_height_m;
    KeyframeLocalizerParameters odometry_only = parameters;
    odometry_only.keyframe_corrections = false;
    odometry_only.height_updates = false;
    KeyframeLocalizer corrected(flight.width, flight.height, parameters, options.threads);
    KeyframeLocalizer alone(flight.width, flight.height, odometry_only, options.threads);
    if (seed == options.first_seed) std::printf("localizer: %s\n", parameters.summary().c_str());

    std::ofstream log;
    if (!options.log_directory.empty()) log.open(options.log_directory + "/homing_seed" + std::to_string(seed) + ".jsonl");
    SeedResult result;
    result.seed = seed;
    result.yaw = seed % 2 == 0 ? "corners 4 x 90 deg" : "continuous 10 deg/s";
    Eigen::Isometry3d first_truth = Eigen::Isometry3d::Identity(), truth = first_truth;
    LocalizerFrame last_corrected, last_alone;
    Eigen::Vector3d previous_position = Eigen::Vector3d::Zero();
    const int frames = static_cast<int>(plan.frame_times_s.size());
    for (int i = 0; i < frames; ++i) {
      const lpstereo::io::FlightState state = lpstereo::io::flight_state_at(flight, plan, plan.frame_times_s[static_cast<size_t>(i)]);
      const lpstereo::io::StereoFlightFrame frame = lpstereo::io::render_flight_frame(flight, state, i);
      const lpstereo::Plane left = lpstereo::io::mat_to_plane(frame.left, {lpstereo::ElementType::u8, 0});
      const lpstereo::Plane right = lpstereo::io::mat_to_plane(frame.right, {lpstereo::ElementType::u8, 0});
      if (i == 0) first_truth = state.left_camera;
      truth = first_truth.inverse() * state.left_camera;
      if (i > 0) result.path_m += (truth.translation() - previous_position).norm();
      previous_position = truth.translation();
      last_corrected = corrected.process(left, right);
      last_alone = alone.process(left, right);
      result.accepted_corrections += last_corrected.correction_accepted ? 1 : 0;
      result.invalid_odometry += last_corrected.odometry_valid ? 0 : 1;
      if (log.is_open()) {
        const Eigen::Vector3d e = last_corrected.pose.translation(), t = truth.translation();
        log << "{\"frame\":" << i << ",\"truth\":[" << t.x() << "," << t.y() << "," << t.z() << "],\"estimate\":[" << e.x() << ","
            << e.y() << "," << e.z() << "],\"vo\":[" << last_alone.pose.translation().x() << "," << last_alone.pose.translation().y()
            << "," << last_alone.pose.translation().z() << "],\"sigma\":" << last_corrected.position_sigma_m
            << ",\"keyframe\":" << last_corrected.keyframe_id << ",\"sector\":" << last_corrected.yaw_sector
            << ",\"matches\":" << last_corrected.keyframe_matches << ",\"inliers\":" << last_corrected.correction_inliers
            << ",\"accepted\":" << (last_corrected.correction_accepted ? "true" : "false") << ",\"note\":\""
            << last_corrected.correction_note << "\",\"height\":" << last_corrected.visual_height_m
            << ",\"stored\":" << last_corrected.stored_keyframe_id << "}\n";
      }
    }
    result.frames = frames;
    result.corrected_cm = 100.0 * (last_corrected.pose.translation() - truth.translation()).norm();
    result.odometry_only_cm = 100.0 * (last_alone.pose.translation() - truth.translation()).norm();
    result.keyframes = static_cast<int>(corrected.database().size());
    result.final_sigma_cm = 100.0 * last_corrected.position_sigma_m;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    std::printf("seed %d (%s): %d frames, path %.1f m, landing error %.1f cm with keyframe corrections (%d keyframes, %d "
                "corrections accepted, sigma %.1f cm), %.1f cm with visual odometry alone; %d invalid odometry frames; %.0f s\n",
                seed, result.yaw.c_str(), frames, result.path_m, result.corrected_cm, result.keyframes, result.accepted_corrections,
                result.final_sigma_cm, result.odometry_only_cm, result.invalid_odometry, result.seconds);
    std::fflush(stdout);
    results.push_back(result);
  }
  std::vector<double> corrected, alone;
  for (const SeedResult& r : results) {
    corrected.push_back(r.corrected_cm);
    alone.push_back(r.odometry_only_cm);
  }
  std::printf("\n| seed | yaw | frames | path (m) | landing error, keyframe corrections (cm) | landing error, VO alone (cm) |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (const SeedResult& r : results) {
    std::printf("| %d | %s | %d | %.1f | %.1f | %.1f |\n", r.seed, r.yaw.c_str(), r.frames, r.path_m, r.corrected_cm, r.odometry_only_cm);
  }
  const double worst = *std::max_element(corrected.begin(), corrected.end());
  std::printf("| median | | | | %.1f | %.1f |\n| max | | | | %.1f | %.1f |\n", median(corrected), median(alone), worst,
              *std::max_element(alone.begin(), alone.end()));
  std::printf("acceptance (landing error <= 10 cm with keyframe corrections): %s\n", worst <= 10.0 ? "PASS" : "FAIL");
  return worst <= 10.0 ? 0 : 1;
}
