// geometry_eval: the acceptance checks of the cameras-and-geometry work that need the real data in
// ../shared/data (or --data DIR, or $LPSTEREO_SHARED_DATA). An evaluation, not a test: the test
// suite passes without the data; this program prints every figure and exits 1 when a check fails,
// 0 when all pass. A data set that is absent is reported as "absent" and not counted.
//
//   calibration loaders   each real calibration file: baseline (m) and focal length (px) against the
//                         figures in the set's SOURCE.md
//
// Usage: geometry_eval [--data DIR]
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "io/calibration.h"
#include "io/stereo_datasets.h"

namespace {

using namespace lpstereo;
namespace fs = std::filesystem;

int failures = 0;
int passes = 0;

void check(bool ok, const std::string& what) {
  std::printf("  %s %s\n", ok ? "PASS" : "FAIL", what.c_str());
  (ok ? passes : failures)++;
}

// Runs `body` when every file exists, else prints the set as absent.
void with_files(const std::string& title, const std::vector<std::string>& files, const std::function<void()>& body) {
  std::printf("%s\n", title.c_str());
  for (const std::string& file : files) {
    if (!fs::exists(file)) {
      std::printf("  absent (%s): not counted\n", file.c_str());
      return;
    }
  }
  try {
    body();
  } catch (const std::exception& error) {
    check(false, std::string("error: ") + error.what());
  }
}

void calibration_loaders(const std::string& data) {
  struct Expected {
    std::string title;
    std::vector<std::string> files;
    double baseline_m, focal_px, baseline_tolerance_m;
  };
  const std::vector<Expected> sets = {
      {"kitti2015 (object-style P2/P3, frame 000046)", {data + "/kitti2015/extra_shapepriors_gcpr16/calib_000046.txt"},
       384.38148 / 721.5377, 721.5377, 1e-6},
      {"kitti_odometry_06 (bare P0/P1 lines)", {data + "/kitti_odometry_06/calib.txt"}, 379.8145 / 707.0912, 707.0912, 1e-6},
      {"kitti_object_lidar (P0..P3, R0_rect, Tr_*)", {data + "/kitti_object_lidar/calib.txt"},
       (44.85728 + 339.5242) / 721.5377, 721.5377, 1e-6},
      {"middlebury2014 Motorcycle calib.txt", {data + "/middlebury2014/Motorcycle/calib.txt"}, 0.193001, 999.421, 1e-9},
      {"fisheye_mynteye (Kimera sensor YAML pair, equidistant)",
       {data + "/fisheye_mynteye/left_sensor_fisheye.yaml", data + "/fisheye_mynteye/right_sensor_fisheye.yaml"}, 0.1203,
       366.163, 0.0005},
  };
  for (const Expected& set : sets) {
    with_files("calibration: " + set.title, set.files, [&] {
      const io::StereoCalibration calibration = set.files.size() == 1
                                                    ? io::load_stereo_calibration(set.files[0])
                                                    : io::load_stereo_calibration(set.files[0], set.files[1]);
      char line[256];
      std::snprintf(line, sizeof(line), "format %s, rectified %s, baseline %.6f m (expected %.6f), focal %.4f px (expected %.4f)",
                    calibration.format.c_str(), calibration.already_rectified ? "yes" : "no", calibration.baseline_m(),
                    set.baseline_m, calibration.focal_px(), set.focal_px);
      check(std::abs(calibration.baseline_m() - set.baseline_m) <= set.baseline_tolerance_m &&
                std::abs(calibration.focal_px() - set.focal_px) <= 1e-9,
            line);
    });
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string explicit_data;
  for (int i = 1; i < argc; ++i) {
    const std::string argument = argv[i];
    if (argument == "--data" && i + 1 < argc) {
      explicit_data = argv[++i];
    } else {
      std::fprintf(stderr, "usage: geometry_eval [--data DIR]\n");
      return 2;
    }
  }
  const std::string data = io::shared_data_directory(explicit_data);
  std::printf("geometry_eval: data folder %s\n", data.c_str());
  calibration_loaders(data);
  std::printf("geometry_eval: %d passed, %d failed\n", passes, failures);
  return failures == 0 ? 0 : 1;
}
