// geometry_eval: the acceptance checks of the cameras-and-geometry work that need the real data in
// ../shared/data (or --data DIR, or $LPSTEREO_SHARED_DATA). An evaluation, not a test: the test
// suite passes without the data; this program prints every figure and exits 1 when a check fails,
// 0 when all pass. A data set that is absent is reported as "absent" and not counted.
//
//   calibration loaders   each real calibration file: baseline (m) and focal length (px) against the
//                         figures in the set's SOURCE.md
//   fixed-point remap     the real fisheye_mynteye pair rectified with its own calibration: the
//                         remap_bilinear kernel (remap_q5 tables) against cv::remap(INTER_LINEAR)
//                         on the float maps: share of pixels within 1 grey level (>= 99.9 %), and
//                         the vertical offset of matched features after rectification
//   lat-long rectification the same pair rectified latitude-longitude (rows = epipolar planes) by
//                         the same kernel, hfov 180 and 120 degrees at the input size: median
//                         vertical offset of matched features (io/row_alignment, as
//                         lpstereo check-rectification measures it), at most 0.5 px
//
// Usage: geometry_eval [--data DIR]
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "dag/tile_executor.h"
#include "io/calibration.h"
#include "io/image_io.h"
#include "io/rectification.h"
#include "io/row_alignment.h"
#include "io/stereo_datasets.h"
#include "kernels/kernel.h"

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

// The fixed-point kernel on one view: remap_bilinear with the view's remap_q5 table, constant
// border 0 (as lpstereo rectify runs it), native back end at the active ISA level.
Plane remap_fixed_point(const Plane& source, const Plane& table) {
  const KernelDescriptor& kernel = *KernelRegistry::instance().find("remap_bilinear");
  const PreparedKernel prepared = kernel.prepare({}, {{source.width(), source.height()}, {table.width(), table.height()}});
  Plane output(table.width(), table.height(), {ElementType::u8, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::constant, 0, {source.view(), table.view()}, {output.view()}};
  run_vector_node(binding, 256, 32, KernelBackend::native, simd::active_isa());
  return output;
}

// fisheye_mynteye: the pair and its Kimera sensor files, read when all four are there.
struct MyntEyePair {
  io::StereoCalibration calibration;
  Plane left, right;
};

void with_mynteye_pair(const std::string& data, const std::string& title, const std::function<void(const MyntEyePair&)>& body) {
  const std::string folder = data + "/fisheye_mynteye/";
  const std::vector<std::string> files = {folder + "left_fisheye_img_0.png", folder + "right_fisheye_img_0.png",
                                          folder + "left_sensor_fisheye.yaml", folder + "right_sensor_fisheye.yaml"};
  with_files(title, files, [&] {
    body({io::load_stereo_calibration(files[2], files[3]), io::read_luma_u8(files[0]), io::read_luma_u8(files[1])});
  });
}

void fixed_point_rectification(const std::string& data) {
  with_mynteye_pair(data, "fixed-point rectification of fisheye_mynteye (equidistant, pinhole rectification) vs cv::remap",
                    [&](const MyntEyePair& pair) {
    const io::StereoCalibration& calibration = pair.calibration;
    const Plane& left = pair.left;
    const Plane& right = pair.right;
    const io::RectificationMaps maps = io::compute_rectification_maps(calibration, left.width(), left.height());
    cv::Mat rectified[2];
    for (int view = 0; view < 2; ++view) {
      const Plane& source = view == 0 ? left : right;
      const cv::Mat& map_x = view == 0 ? maps.left_x : maps.right_x;
      const cv::Mat& map_y = view == 0 ? maps.left_y : maps.right_y;
      const Plane ours = remap_fixed_point(source, io::rectification_table(map_x, map_y, view == 0 ? "left" : "right"));
      rectified[view] = io::plane_to_mat(ours);
      cv::Mat expected, difference;
      cv::remap(io::plane_to_mat(source), expected, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
      cv::absdiff(rectified[view], expected, difference);
      double max_difference = 0;
      cv::minMaxLoc(difference, nullptr, &max_difference);
      const double within = static_cast<double>(cv::countNonZero(difference <= 1)) / static_cast<double>(difference.total());
      const double equal = static_cast<double>(cv::countNonZero(difference == 0)) / static_cast<double>(difference.total());
      char line[256];
      std::snprintf(line, sizeof(line), "%s view: %.4f %% of pixels within 1 grey level (>= 99.9 %%), %.4f %% identical, max difference %d",
                    view == 0 ? "left" : "right", 100 * within, 100 * equal, static_cast<int>(max_difference));
      check(within >= 0.999, line);
    }
    const io::RowAlignment before = io::measure_row_alignment(io::plane_to_mat(left), io::plane_to_mat(right), "akaze");
    const io::RowAlignment after = io::measure_row_alignment(rectified[0], rectified[1], "akaze");
    char line[256];
    std::snprintf(line, sizeof(line),
                  "vertical offset of matched features: raw median %.3f px (p95 %.3f, %zu matches); rectified median %.3f px "
                  "(p95 %.3f, %zu matches), at most 0.5 px",
                  before.median_px, before.p95_px, before.matches, after.median_px, after.p95_px, after.matches);
    check(after.median_px <= 0.5, line);
  });
}

void latlong_rectification(const std::string& data) {
  with_mynteye_pair(data, "latitude-longitude rectification of fisheye_mynteye (equidistant), remap_bilinear kernel",
                    [&](const MyntEyePair& pair) {
    const io::StereoCalibration& calibration = pair.calibration;
    const Plane& left = pair.left;
    const Plane& right = pair.right;
    for (double hfov_deg : {180.0, 120.0}) {
      io::LatLongOptions options;
      options.hfov_rad = hfov_deg * M_PI / 180.0;
      const io::RectificationMaps maps = io::compute_latlong_maps(calibration, left.width(), left.height(), options);
      const Plane left_out = remap_fixed_point(left, io::rectification_table(maps.left_x, maps.left_y, "left"));
      const Plane right_out = remap_fixed_point(right, io::rectification_table(maps.right_x, maps.right_y, "right"));
      const io::RowAlignment after = io::measure_row_alignment(io::plane_to_mat(left_out), io::plane_to_mat(right_out), "akaze");
      char line[320];
      std::snprintf(line, sizeof(line),
                    "hfov %.0f deg, %dx%d, %.2f px/rad, %.1f %%/%.1f %% of the pixels from inside the sources: vertical offset of "
                    "matched features median %.3f px (p95 %.3f, %zu matches), at most 0.5 px",
                    hfov_deg, maps.width, maps.height, maps.geometry.focal_px, 100 * maps.left_inside, 100 * maps.right_inside,
                    after.median_px, after.p95_px, after.matches);
      check(after.median_px <= 0.5, line);
    }
  });
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
  fixed_point_rectification(data);
  latlong_rectification(data);
  std::printf("geometry_eval: %d passed, %d failed\n", passes, failures);
  return failures == 0 ? 0 : 1;
}
