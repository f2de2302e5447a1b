// Dense disparity speed on the host: lpstereo's DisparityEngine (census 5x5 + SGM, 4 paths in one
// pass and 8 paths in two) against OpenCV StereoSGBM in MODE_SGBM, MODE_SGBM_3WAY and MODE_HH, in
// the same process, on the same inputs (the synthetic scene of io/synthetic_scene.h), with the same
// number of threads for both (cv::setNumThreads and the engine's worker threads), 128 disparities,
// at 640x480 and 1242x375. Each configuration runs once to warm up (not timed), then N times
// (default 7); the median wall time is printed with frames per second and MDE/s (million disparity
// evaluations per second = W * H * D / seconds / 1e6), and the bad-2 / density of each method
// against the scene's ground truth as a sanity figure (accuracy is measured by `lpstereo eval`).
// OpenCV settings: blockSize 5, P1 = 8 * 25, P2 = 32 * 25, uniquenessRatio 10, speckle window 100
// range 2, disp12MaxDiff 1, preFilterCap 63 (the comparison settings).
// Usage: disparity_bench [--runs N] [--threads T] [--sizes 640x480,1242x375] [--disparities D] [--census 5|9]
//                        [--no-opencv]
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "arm/disparity_engine.h"
#include "io/synthetic_scene.h"
#include "kernels/simd/isa.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Quality {
  double bad2 = 0, density = 0;
};

// bad-2 (share of valid pixels off by more than 2 px) and density over the pixels x >= D (both
// methods leave the left band without a match).
Quality quality(const std::function<double(int, int)>& disparity_px, const lpstereo::Plane& truth_q4, int count) {
  int64_t valid = 0, bad = 0, total = 0;
  for (int y = 0; y < truth_q4.height(); ++y) {
    for (int x = count; x < truth_q4.width(); ++x) {
      ++total;
      const double value = disparity_px(x, y);
      if (!(value >= 0)) continue;
      ++valid;
      if (std::abs(value - truth_q4.at<int16_t>(x, y) / 16.0) > 2.0) ++bad;
    }
  }
  return {valid > 0 ? 100.0 * bad / valid : 0.0, total > 0 ? 100.0 * valid / total : 0.0};
}

struct Timing {
  double wall_ms = 0;  // median wall time
  double cpu_ms = 0;   // median process CPU time (all threads): robust on a shared machine
};

double process_cpu_ms() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return now.tv_sec * 1e3 + now.tv_nsec * 1e-6;
}

Timing median_ms(int runs, const std::function<void()>& run) {
  run();  // warm-up, not timed
  std::vector<double> walls, cpus;
  for (int i = 0; i < runs; ++i) {
    const double cpu_start = process_cpu_ms();
    const auto start = Clock::now();
    run();
    walls.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    cpus.push_back(process_cpu_ms() - cpu_start);
  }
  std::sort(walls.begin(), walls.end());
  std::sort(cpus.begin(), cpus.end());
  return {walls[walls.size() / 2], cpus[cpus.size() / 2]};
}

void print_row(const char* method, int width, int height, int count, const Timing& t, const Quality& q) {
  const double mde = static_cast<double>(width) * height * count / (t.wall_ms * 1e-3) / 1e6;
  std::printf("%-22s %5dx%-4d D=%-4d %9.2f ms %8.2f fps %9.1f MDE/s  (CPU %8.2f ms)  bad-2 %6.2f %%  density %6.2f %%\n",
              method, width, height, count, t.wall_ms, 1000.0 / t.wall_ms, mde, t.cpu_ms, q.bad2, q.density);
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 7, threads = 2, count = 128;
  bool opencv = true;
  int census = 5;
  std::vector<std::pair<int, int>> sizes = {{640, 480}, {1242, 375}};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--no-opencv") opencv = false;
    else if (arg == "--census" && i + 1 < argc) census = std::atoi(argv[++i]) == 9 ? 9 : 5;
    else if (arg == "--runs" && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--threads" && i + 1 < argc) threads = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--disparities" && i + 1 < argc) count = std::max(16, std::atoi(argv[++i]));
    else if (arg == "--sizes" && i + 1 < argc) {
      sizes.clear();
      std::string list = argv[++i];
      for (size_t start = 0; start < list.size();) {
        const size_t comma = std::min(list.find(',', start), list.size());
        int w = 0, h = 0;
        if (std::sscanf(list.substr(start, comma - start).c_str(), "%dx%d", &w, &h) == 2) sizes.push_back({w, h});
        start = comma + 1;
      }
    } else {
      std::fprintf(stderr, "usage: disparity_bench [--runs N] [--threads T] [--sizes WxH,...] [--disparities D] [--census 5|9] [--no-opencv]\n");
      return 2;
    }
  }
  cv::setNumThreads(threads);
  std::printf("settings: threads %d (lpstereo workers and cv::setNumThreads), median of %d runs after 1 warm-up, "
              "ISA %s, OpenCV %s, synthetic scene (io/synthetic_scene.h)\n",
              threads, runs, std::string(lpstereo::simd::isa_name(lpstereo::simd::active_isa())).c_str(), CV_VERSION);
  std::printf("lpstereo: census %s, SGM P1/P2 %s, uniqueness 5 %%, LR check 1 px, sub-pixel; "
              "OpenCV: blockSize 5, P1 200, P2 800, uniqueness 10, speckle 100/2, disp12MaxDiff 1\n",
              census == 9 ? "9x7" : "5x5", census == 9 ? "7/50" : "5/45");
  for (const auto& [width, height] : sizes) {
    lpstereo::io::SyntheticSceneOptions options;
    options.width = width;
    options.height = height;
    options.max_disparity_fraction = std::min(0.08, 0.85 * count / width);
    const lpstereo::io::SyntheticStereoScene scene = lpstereo::io::make_synthetic_stereo_scene(options);
    for (int paths : {4, 8}) {
      lpstereo::arm::DisparityParameters parameters;
      parameters.num_disparities = count;
      parameters.paths = paths;
      parameters.threads = threads;
      parameters.census_width = census;
      lpstereo::arm::DisparityEngine engine(width, height, parameters);
      const lpstereo::Plane* result = nullptr;
      const Timing ms = median_ms(runs, [&] { result = &engine.compute(scene.left, scene.right); });
      const int16_t invalid = engine.invalid_disparity_q4();
      const Quality q = quality(
          [&](int x, int y) {
            const int16_t v = result->at<int16_t>(x, y);
            return v == invalid ? -1.0 : v / 16.0;
          },
          scene.disparity_q4, count);
      print_row(paths == 4 ? "lpstereo SGM 4 paths" : "lpstereo SGM 8 paths", width, height, count, ms, q);
    }
    const cv::Mat left(height, width, CV_8UC1, scene.left.row<uint8_t>(0), static_cast<size_t>(scene.left.stride_bytes()));
    const cv::Mat right(height, width, CV_8UC1, scene.right.row<uint8_t>(0), static_cast<size_t>(scene.right.stride_bytes()));
    const std::pair<int, const char*> modes[] = {{cv::StereoSGBM::MODE_SGBM, "OpenCV MODE_SGBM"},
                                                 {cv::StereoSGBM::MODE_SGBM_3WAY, "OpenCV MODE_SGBM_3WAY"},
                                                 {cv::StereoSGBM::MODE_HH, "OpenCV MODE_HH"}};
    for (const auto& [mode, name] : modes) {
      if (!opencv) break;
      cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0, count, 5, 8 * 25, 32 * 25, 1, 63, 10, 100, 2, mode);
      cv::Mat disparity;
      const Timing ms = median_ms(runs, [&] { sgbm->compute(left, right, disparity); });
      const Quality q = quality(
          [&](int x, int y) {
            const int16_t v = disparity.at<int16_t>(y, x);
            return v < 0 ? -1.0 : v / 16.0;
          },
          scene.disparity_q4, count);
      print_row(name, width, height, count, ms, q);
    }
  }
  return 0;
}
