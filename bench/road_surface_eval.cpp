// road_surface_eval: dense disparity on the generator's road surfaces, the current textured road and
// real asphalt (io/stereo_synth.h, SynthRoadSurface), beside each other. An evaluation program, not a
// test: it renders the scenes, prints every figure and checks no line (issue 46's lines are on
// the matcher that holds there; this program is how they are measured).
//
// Scenes: the road scene of io::render_stereo_synth with its random objects, per seed, at each size,
// under three conditions:
//   textured, clean    the generator's road as the evaluations used it: sensor noise 2 grey levels,
//                      both cameras alike;
//   textured, camera   the same road through a real camera pair (the "camera" settings below);
//   asphalt, camera    real asphalt through the same camera pair: the realistic scene.
// The camera pair: io::use_real_camera_pair, sensor noise 2 grey levels, the right camera's gain 1.08
// and offset -5 grey levels (auto-exposure per camera), vignetting 0.3 (the left lens loses 30 % of
// the light at the corners, the right 36 %), optics blur sigma 0.7 px. `lpstereo synth` renders the
// same with --real-camera [--surface asphalt].
//
// Matchers, each over [0, 128): lpstereo's arm::DisparityEngine with its defaults (8 paths) and with 4
// paths, OpenCV StereoSGBM MODE_SGBM_3WAY and MODE_HH (io/opencv_sgbm.h settings), 2 threads.
// Figures on the ground (object id 0, finite true disparity; the road and its verges):
//   density   valid pixels / ground pixels whose true depth is at most 30 m;
//   median    the median signed error (estimate - truth, px) of the valid ground pixels at 8-25 m
//             (a matcher's bias there scales every depth and every odometry step);
//   bad-1     the share of those with |error| > 1 px.
// Usage: road_surface_eval [--seeds N] [--first-seed S] [--sizes WxH,...]   (default 3 seeds from 1,
//        1242x375 and 640x480)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/disparity_engine.h"
#include "bench/heap_setting.h"
#include "bench/number_argument.h"
#include "io/image_io.h"
#include "io/opencv_sgbm.h"
#include "io/stereo_synth.h"

namespace {

using namespace lpstereo;

constexpr int kDisparities = 128;
constexpr double kDensityRangeM = 30;
constexpr double kBiasNearM = 8, kBiasFarM = 25;

struct Condition {
  const char* name;
  io::SynthRoadSurface surface;
  bool real_camera;
};
constexpr Condition kConditions[] = {{"textured, clean", io::SynthRoadSurface::textured, false},
                                     {"textured, camera", io::SynthRoadSurface::textured, true},
                                     {"asphalt, camera", io::SynthRoadSurface::asphalt, true}};

struct Figures {
  double density = 0, median_error_px = 0, bad1 = 0;
};

// The ground figures of one s16 Q4 map against the scene's truth.
// invalid_q4: the maps' invalid value (the engine's and OpenCV's are the same for one range).
Figures ground_figures(const Plane& disparity_q4, int16_t invalid_q4, const io::StereoSynthScene& scene, double focal_baseline) {
  size_t near_ground = 0, near_valid = 0;
  std::vector<double> errors;
  for (int v = 0; v < scene.disparity_px.rows; ++v) {
    for (int u = 0; u < scene.disparity_px.cols; ++u) {
      const float truth = scene.disparity_px.at<float>(v, u);
      if (!std::isfinite(truth) || truth <= 0 || scene.object_ids.at<uint16_t>(v, u) != 0) continue;
      const double depth_m = focal_baseline / truth;
      const int16_t value = disparity_q4.at<int16_t>(u, v);
      const bool valid = value > invalid_q4;
      if (depth_m <= kDensityRangeM) {
        ++near_ground;
        near_valid += valid ? 1 : 0;
      }
      if (valid && depth_m >= kBiasNearM && depth_m <= kBiasFarM) errors.push_back(value / 16.0 - truth);
    }
  }
  Figures figures;
  figures.density = near_ground > 0 ? static_cast<double>(near_valid) / static_cast<double>(near_ground) : 0;
  if (!errors.empty()) {
    const size_t bad = static_cast<size_t>(std::count_if(errors.begin(), errors.end(), [](double e) { return std::abs(e) > 1; }));
    figures.bad1 = static_cast<double>(bad) / static_cast<double>(errors.size());
    std::nth_element(errors.begin(), errors.begin() + static_cast<ptrdiff_t>(errors.size() / 2), errors.end());
    figures.median_error_px = errors[errors.size() / 2];
  } else {
    figures.median_error_px = std::nan("");
  }
  return figures;
}

struct Size {
  int width, height;
};

std::vector<Size> parse_sizes(const std::string& text) {
  std::vector<Size> sizes;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    Size size{};
    char x = 0;
    char rest = 0;
    if (std::sscanf(item.c_str(), "%d%c%d%c", &size.width, &x, &size.height, &rest) != 3 || x != 'x' || size.width < 256 ||
        size.height < 64) {
      throw std::invalid_argument("--sizes: expected WxH[,WxH...] with W >= 256 and H >= 64, got '" + text + "'");
    }
    sizes.push_back(size);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return sizes;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string heap = bench::keep_freed_heap_memory_setting();
  int seeds = 3, first_seed = 1;
  std::vector<Size> sizes = {{1242, 375}, {640, 480}};
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string argument = argv[i];
      if (argument == "--seeds" || argument == "--first-seed") {
        const double number = bench::number_argument(i, argc, argv);
        if (number != std::floor(number) || number < 1 || number > 100000) {
          throw std::invalid_argument(argument + ": expected a whole number in [1, 100000], got " + argv[i]);
        }
        (argument == "--seeds" ? seeds : first_seed) = static_cast<int>(number);
      } else if (argument == "--sizes") {
        if (i + 1 >= argc) throw std::invalid_argument("--sizes: expected a value");
        sizes = parse_sizes(argv[++i]);
      } else {
        throw std::invalid_argument("unknown argument '" + argument + "' (usage: road_surface_eval [--seeds N] [--first-seed S] [--sizes WxH,...])");
      }
    }
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "road_surface_eval: %s\n", error.what());
    return 2;
  }

  arm::DisparityParameters eight_paths;
  eight_paths.num_disparities = kDisparities;
  arm::DisparityParameters four_paths = eight_paths;
  four_paths.paths = 4;
  std::printf("# Ground disparity on the generator's road surfaces, seeds %d..%d, [0, %d) px, 2 threads\n", first_seed,
              first_seed + seeds - 1, kDisparities);
  std::printf("# lpstereo 8 paths: %s\n# lpstereo 4 paths: %s\n# OpenCV: %s\n", arm::settings_text(eight_paths).c_str(),
              arm::settings_text(four_paths).c_str(), io::sgbm_settings_text(io::SgbmSettings{}).c_str());
  std::printf("# heap: %s\n", heap.c_str());
  std::printf("# density: valid ground pixels within %.0f m; median: signed error of valid ground pixels at %.0f-%.0f m, px; bad-1 there\n",
              kDensityRangeM, kBiasNearM, kBiasFarM);
  std::printf("%-10s %-17s %-22s %8s %9s %7s\n", "size", "scene", "matcher", "density", "median px", "bad-1");
  const char* matcher_names[] = {"lpstereo 8 paths", "lpstereo 4 paths", "OpenCV MODE_SGBM_3WAY", "OpenCV MODE_HH"};
  for (const Size& size : sizes) {
    arm::DisparityEngine engine8(size.width, size.height, eight_paths, {}, 2);
    arm::DisparityEngine engine4(size.width, size.height, four_paths, {}, 2);
    for (const Condition& condition : kConditions) {
      Figures sums[4];
      int counted[4] = {0, 0, 0, 0};
      for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
        io::StereoSynthOptions options;
        options.width = size.width;
        options.height = size.height;
        options.seed = static_cast<uint32_t>(seed);
        options.objects = io::random_synth_objects(options.seed);
        options.noise_sigma = 2;
        options.road_surface = condition.surface;
        if (condition.real_camera) io::use_real_camera_pair(options);
        const io::StereoSynthScene scene = io::render_stereo_synth(options);
        const Plane left = io::mat_to_plane(scene.left, {ElementType::u8, 0});
        const Plane right = io::mat_to_plane(scene.right, {ElementType::u8, 0});
        const double focal_baseline = scene.focal_px * options.baseline_m;
        const Plane maps[4] = {engine8.compute(left, right), engine4.compute(left, right),
                               io::run_opencv_sgbm(left, right, 0, kDisparities, io::SgbmMode::sgbm_3way),
                               io::run_opencv_sgbm(left, right, 0, kDisparities, io::SgbmMode::hh)};
        for (int m = 0; m < 4; ++m) {
          const Figures figures = ground_figures(maps[m], engine8.invalid_disparity_q4(), scene, focal_baseline);
          std::printf("%4dx%-5d %-17s %-22s %7.1f%% %+9.3f %6.1f%%   seed %d\n", size.width, size.height, condition.name,
                      matcher_names[m], 100 * figures.density, figures.median_error_px, 100 * figures.bad1, seed);
          sums[m].density += figures.density;
          if (std::isfinite(figures.median_error_px)) {
            sums[m].median_error_px += figures.median_error_px;
            sums[m].bad1 += figures.bad1;
            ++counted[m];
          }
        }
      }
      for (int m = 0; m < 4; ++m) {
        std::printf("%4dx%-5d %-17s %-22s %7.1f%% %+9.3f %6.1f%%   mean of %d seeds\n", size.width, size.height, condition.name,
                    matcher_names[m], 100 * sums[m].density / seeds, counted[m] > 0 ? sums[m].median_error_px / counted[m] : std::nan(""),
                    counted[m] > 0 ? 100 * sums[m].bad1 / counted[m] : std::nan(""), seeds);
      }
    }
  }
  return 0;
}
