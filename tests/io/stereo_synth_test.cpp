// io/stereo_synth: the ground truth is the geometry (road disparity against the closed form, object
// boxes against their pixels and their 3D positions), the two views agree with it, the disparity
// engine recovers it, and the files (KITTI PNG, objects.json, both calibration files) read back.
#include "io/stereo_synth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arm/disparity_engine.h"
#include "io/calibration.h"
#include "io/disparity_io.h"
#include "io/disparity_metrics.h"
#include "io/image_io.h"
#include "tests/support/scratch_directory.h"

namespace {

using namespace lpstereo;
using io::StereoSynthOptions;

constexpr double kPi = 3.14159265358979323846;

StereoSynthOptions small_options() {
  StereoSynthOptions options;
  options.width = 320;
  options.height = 160;
  options.hfov_deg = 60;
  options.baseline_m = 0.30;
  options.camera_height_m = 1.5;
  return options;
}

TEST(StereoSynth, FlatRoadDisparityIsTheClosedForm) {
  StereoSynthOptions options = small_options();
  options.pitch_rad = 0.03;
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const double f = 160 / std::tan(30 * kPi / 180), cy = 79.5;
  EXPECT_NEAR(scene.focal_px, f, 1e-9);
  // Ray through row v, pitched down by theta: its road-frame y component per unit camera depth is
  // y cos(theta) + sin(theta), so the road y = h is met at depth Z = h / (that): d = f B / Z.
  int checked = 0;
  for (int v = 100; v < 160; v += 7) {
    const double y = (v - cy) / f;
    const double expected = f * options.baseline_m * (y * std::cos(0.03) + std::sin(0.03)) / options.camera_height_m;
    for (int u : {3, 160, 317}) {
      EXPECT_NEAR(scene.disparity_px.at<float>(v, u), expected, 1e-3) << "row " << v << " column " << u;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 27);
  EXPECT_EQ(cv::countNonZero(scene.object_ids), 0);
  // The top row looks above the horizon: sky or the background wall, never the road's disparity.
  const float top = scene.disparity_px.at<float>(0, 160);
  EXPECT_TRUE(!std::isfinite(top) || top < f * options.baseline_m / 300) << top;
}

TEST(StereoSynth, SlopedRoadRisesBeyondTheSlopeStart) {
  StereoSynthOptions options = small_options();
  options.slope_deg = 4;
  options.slope_start_m = 15;
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const double f = scene.focal_px, cy = 79.5, tan_slope = std::tan(4 * kPi / 180);
  int beyond = 0;
  for (int v = 80; v < 160; ++v) {
    const double y = (v - cy) / f;
    double z = options.camera_height_m / y;  // flat part
    if (!(y > 0) || z > options.slope_start_m) {
      // y Z = h - tan(a) (Z - Z0): Z = (h + tan(a) Z0) / (y + tan(a))
      z = (options.camera_height_m + tan_slope * options.slope_start_m) / (y + tan_slope);
      ++beyond;
    }
    EXPECT_NEAR(scene.disparity_px.at<float>(v, 10), f * options.baseline_m / z, 1e-3) << "row " << v;
  }
  EXPECT_GT(beyond, 5);
}

TEST(StereoSynth, ObjectTruthMatchesItsPixelsAndPosition) {
  StereoSynthOptions options = small_options();
  options.pitch_rad = 0.04;  // looking down: camera depth and road distance differ
  options.objects = io::lineup_synth_objects(12);
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  ASSERT_EQ(scene.objects.size(), 6u);
  // The base centre (road X, 1.5 m down, 12 m ahead) in the pitched camera frame.
  const double depth_m = 1.5 * std::sin(0.04) + 12 * std::cos(0.04);
  const double f = scene.focal_px, cx = 159.5, cy = 79.5;
  for (const io::SynthObjectTruth& truth : scene.objects) {
    SCOPED_TRACE(io::synth_class_name(truth.object.object_class));
    ASSERT_GT(truth.visible_pixels, 0);
    int64_t pixels = 0;
    int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1;
    for (int v = 0; v < scene.object_ids.rows; ++v) {
      for (int u = 0; u < scene.object_ids.cols; ++u) {
        if (scene.object_ids.at<uint16_t>(v, u) != truth.id) continue;
        ++pixels;
        x0 = std::min(x0, u), x1 = std::max(x1, u), y0 = std::min(y0, v), y1 = std::max(y1, v);
        // The object's own depth range: its disparity lies between its back and its front.
        const double d = scene.disparity_px.at<float>(v, u);
        // (the pitch tilts the object's top 0.04 x height towards the camera)
        EXPECT_GE(d, f * 0.3 / (truth.distance_m + truth.object.length_m) - 1e-3);
        EXPECT_LE(d, f * 0.3 / (truth.distance_m - truth.object.length_m - 0.04 * truth.object.height_m) + 1e-3);
      }
    }
    EXPECT_EQ(pixels, truth.visible_pixels);
    EXPECT_EQ(x0, truth.bbox_px[0]);
    EXPECT_EQ(y0, truth.bbox_px[1]);
    EXPECT_EQ(x1, truth.bbox_px[2]);
    EXPECT_EQ(y1, truth.bbox_px[3]);
    // The 3D base centre projects to the bottom of the box, horizontally inside it; the box's
    // height in pixels is the object's height at its distance (within the front face's nearness).
    const double u_base = f * truth.position_m[0] / truth.position_m[2] + cx;
    const double v_base = f * truth.position_m[1] / truth.position_m[2] + cy;
    EXPECT_GE(u_base, truth.bbox_px[0] - 0.5);
    EXPECT_LE(u_base, truth.bbox_px[2] + 0.5);
    EXPECT_NEAR(v_base, truth.bbox_px[3], 1.5);
    EXPECT_NEAR(truth.bbox_px[3] - truth.bbox_px[1] + 1, f * truth.object.height_m / truth.distance_m, 2.5);
    EXPECT_NEAR(truth.distance_m, depth_m, 1e-9);
    EXPECT_NEAR(truth.position_m[1], 1.5 * std::cos(0.04) - 12 * std::sin(0.04), 1e-9);
    EXPECT_NEAR(truth.disparity_px, f * 0.3 / depth_m, 1e-9);
  }
}

// Bilinear sample of the right view at (x, v).
double sample_right(const cv::Mat& right, double x, int v) {
  const int x0 = static_cast<int>(std::floor(x));
  const double a = x - x0;
  return (1 - a) * right.at<uint8_t>(v, x0) + a * right.at<uint8_t>(v, x0 + 1);
}

TEST(StereoSynth, ViewsAgreeWithTheGroundTruth) {
  StereoSynthOptions options = small_options();
  options.objects = io::random_synth_objects(5);
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  std::vector<double> errors;
  for (int v = 1; v + 1 < options.height; v += 3) {
    for (int u = 1; u + 1 < options.width; u += 3) {
      const double d = scene.disparity_px.at<float>(v, u);
      if (!std::isfinite(d) || u - d < 1) continue;
      // Away from depth edges (where a pixel mixes surfaces or is occluded in the right view).
      bool smooth = true;
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const double n = scene.disparity_px.at<float>(v + dv, u + du);
          if (!std::isfinite(n) || std::abs(n - d) > 0.3 || scene.object_ids.at<uint16_t>(v + dv, u + du) != scene.object_ids.at<uint16_t>(v, u)) smooth = false;
        }
      }
      if (!smooth) continue;
      errors.push_back(std::abs(scene.left.at<uint8_t>(v, u) - sample_right(scene.right, u - d, v)));
    }
  }
  ASSERT_GT(errors.size(), 3000u);
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2], p90 = errors[errors.size() * 9 / 10];
  std::printf("left vs right at x - d: median %.2f, p90 %.2f grey levels over %zu pixels\n", median, p90, errors.size());
  EXPECT_LT(median, 1.5) << "p90 " << p90;
  EXPECT_LT(p90, 5.0) << "median " << median;
  // The same pixels one disparity off disagree much more: the test can tell.
  std::vector<double> shifted;
  for (int v = 1; v + 1 < options.height; v += 3) {
    for (int u = 1; u + 1 < options.width; u += 3) {
      const double d = scene.disparity_px.at<float>(v, u);
      if (!std::isfinite(d) || u - d - 3 < 1) continue;
      shifted.push_back(std::abs(scene.left.at<uint8_t>(v, u) - sample_right(scene.right, u - d - 3, v)));
    }
  }
  std::sort(shifted.begin(), shifted.end());
  EXPECT_GT(shifted[shifted.size() / 2], 3 * median + 2);
}

TEST(StereoSynth, RightCameraGainAndOffset) {
  StereoSynthOptions options = small_options();
  options.objects = io::random_synth_objects(2);
  const io::StereoSynthScene plain = io::render_stereo_synth(options);
  options.right_gain = 0.8;
  options.right_offset = 12;
  const io::StereoSynthScene changed = io::render_stereo_synth(options);
  EXPECT_EQ(cv::norm(plain.left, changed.left, cv::NORM_INF), 0);
  int checked = 0;
  for (int v = 0; v < options.height; v += 5) {
    for (int u = 0; u < options.width; u += 5) {
      const double expected = 0.8 * plain.right.at<uint8_t>(v, u) + 12;
      if (expected > 250) continue;
      EXPECT_NEAR(changed.right.at<uint8_t>(v, u), expected, 1.0) << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(StereoSynth, DeterministicBySeedAndThreadCount) {
  StereoSynthOptions options = small_options();
  options.objects = io::random_synth_objects(9);
  options.noise_sigma = 2;
  options.threads = 1;
  const io::StereoSynthScene one = io::render_stereo_synth(options);
  options.threads = 3;
  const io::StereoSynthScene three = io::render_stereo_synth(options);
  EXPECT_EQ(cv::norm(one.left, three.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(one.right, three.right, cv::NORM_INF), 0);
  options.seed = 10;
  const io::StereoSynthScene other = io::render_stereo_synth(options);
  EXPECT_GT(cv::norm(one.left, other.left, cv::NORM_L1), 0);
  EXPECT_NE(io::random_synth_objects(9).size() * 1000 + static_cast<size_t>(io::random_synth_objects(9)[0].z_m * 10),
            io::random_synth_objects(10).size() * 1000 + static_cast<size_t>(io::random_synth_objects(10)[0].z_m * 10));
}

// FNV-1a over both views, the object ids and the ground truth in KITTI's 1/256 px form (quantised so
// a last-bit difference of a maths library cannot change it, only a real change of the rendering).
uint64_t scene_checksum(const io::StereoSynthScene& scene) {
  uint64_t hash = 1469598103934665603ull;
  auto add = [&hash](const cv::Mat& image) {
    for (int v = 0; v < image.rows; ++v) {
      const auto* bytes = image.ptr<uint8_t>(v);
      for (size_t i = 0; i < image.cols * image.elemSize(); ++i) hash = (hash ^ bytes[i]) * 1099511628211ull;
    }
  };
  add(scene.left);
  add(scene.right);
  add(scene.object_ids);
  cv::Mat truth_q8(scene.disparity_px.size(), CV_32SC1);
  for (int v = 0; v < truth_q8.rows; ++v) {
    for (int u = 0; u < truth_q8.cols; ++u) {
      const float d = scene.disparity_px.at<float>(v, u);
      truth_q8.at<int32_t>(v, u) = std::isfinite(d) ? static_cast<int32_t>(std::lround(d * 256.0)) : -1;
    }
  }
  add(truth_q8);
  return hash;
}

// The flat and sloped road with objects, pitch, noise and a right-camera gain, exactly as the
// generator rendered them before the height-field ground and the roll angle were added: the pinned
// value was computed by that older code (commit 4d8bfa9), so any change of the existing options'
// output fails here.
TEST(StereoSynth, ExistingOptionsRenderTheSameBitsAsBeforeTheHeightField) {
  StereoSynthOptions options = small_options();
  options.width = 192;
  options.height = 96;
  options.pitch_rad = 0.02;
  options.slope_deg = 3;
  options.slope_start_m = 14;
  options.noise_sigma = 2;
  options.right_gain = 1.05;
  options.seed = 5;
  options.objects = io::lineup_synth_objects(11);
  options.objects.push_back(io::synth_object(io::SynthClass::car, 3.5, 24));
  const uint64_t sloped = scene_checksum(io::render_stereo_synth(options));
  options.slope_deg = 0;
  options.objects = io::random_synth_objects(4);
  const uint64_t flat = scene_checksum(io::render_stereo_synth(options));
  EXPECT_EQ(sloped, 0x67c6c786ec497376ull) << std::hex << sloped;
  EXPECT_EQ(flat, 0xcc9cfb446c18be32ull) << std::hex << flat;
}

TEST(StereoSynth, DisparityEngineRecoversTheGroundTruth) {
  StereoSynthOptions options = small_options();
  options.objects = io::random_synth_objects(3);
  options.noise_sigma = 1.0;
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  arm::DisparityEngine engine(options.width, options.height, arm::DisparityParameters{});
  const Plane left = io::mat_to_plane(scene.left, BufferFormat{ElementType::u8});
  const Plane right = io::mat_to_plane(scene.right, BufferFormat{ElementType::u8});
  const Plane& disparity = engine.compute(left, right);
  const io::DisparityMetrics metrics =
      io::evaluate_disparity(disparity, engine.invalid_disparity_q4(), scene.disparity_px, cv::Mat());
  std::printf("synth 320x160 seed 3, noise 1: density %.1f %%, bad-2 (valid) %.2f %%, bad-2 (dense) %.2f %%\n",
              metrics.all.density_pct, metrics.all.valid.bad2_pct, metrics.all.dense.bad2_pct);
  EXPECT_GT(metrics.all.density_pct, 80);
  EXPECT_LT(metrics.all.valid.bad2_pct, 5);
}

TEST(StereoSynth, FilesReadBack) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_synth");
  StereoSynthOptions options = small_options();
  options.baseline_m = 0.25;
  options.hfov_deg = 70;
  options.objects = io::lineup_synth_objects(15);
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const std::string folder = scratch.path("scene");
  io::write_stereo_synth(folder, scene, options);
  io::write_stereo_synth(folder, scene, options);  // replaces the folder
  const double f = 160 / std::tan(35 * kPi / 180);
  for (const std::string name : {"calib.yaml", "calib_cam_to_cam.txt"}) {
    SCOPED_TRACE(name);
    const io::StereoCalibration calibration = io::load_stereo_calibration(folder + "/" + name);
    EXPECT_NEAR(calibration.baseline_m(), 0.25, 1e-9);
    EXPECT_NEAR(calibration.focal_px(), f, 1e-6);
    EXPECT_NEAR(calibration.left.cx_px, 159.5, 1e-9);
    EXPECT_NEAR(calibration.left.cy_px, 79.5, 1e-9);
    EXPECT_EQ(calibration.left.width_px, 320);
    EXPECT_EQ(calibration.left.height_px, 160);
    EXPECT_FALSE(calibration.left.has_distortion());
  }
  const cv::Mat disparity = io::read_kitti_disparity_png_px(folder + "/disparity.png");
  int valid = 0;
  for (int v = 0; v < 160; ++v) {
    for (int u = 0; u < 320; ++u) {
      const float truth = scene.disparity_px.at<float>(v, u);
      const float read = disparity.at<float>(v, u);
      if (std::isfinite(truth)) {
        ++valid;
        ASSERT_NEAR(read, truth, 1.0 / 512 + 1e-6) << u << "," << v;
      } else {
        ASSERT_FALSE(std::isfinite(read)) << u << "," << v;
      }
    }
  }
  EXPECT_GT(valid, 320 * 60);
  const cv::Mat ids = cv::imread(folder + "/object_ids.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(ids.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(ids, scene.object_ids, cv::NORM_INF), 0);
  const cv::Mat left = cv::imread(folder + "/left.png", cv::IMREAD_UNCHANGED);
  ASSERT_EQ(left.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(left, scene.left, cv::NORM_INF), 0);

  std::ifstream json_file(folder + "/objects.json");
  const nlohmann::json json = nlohmann::json::parse(json_file);
  ASSERT_EQ(json["objects"].size(), 6u);
  EXPECT_EQ(json["objects"][0]["class"], "cone");
  EXPECT_EQ(json["objects"][5]["class"], "pedestrian");
  EXPECT_NEAR(json["objects"][5]["size_m"]["h"].get<double>(), 1.70, 1e-12);
  EXPECT_NEAR(json["objects"][4]["distance_m"].get<double>(), 15, 1e-9);
  EXPECT_EQ(json["objects"][4]["bbox_px"][3].get<int>(), scene.objects[4].bbox_px[3]);
  // Nothing but the folder itself is left in its parent (no temporary or old copies).
  int entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(scratch.root())) {
    (void)entry;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
}

TEST(StereoSynth, BadOptionsAreRefusedByName) {
  StereoSynthOptions options = small_options();
  options.hfov_deg = 180;
  try {
    io::render_stereo_synth(options);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("hfov-deg"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("180"), std::string::npos) << error.what();
  }
  options = small_options();
  options.baseline_m = 0;
  EXPECT_THROW(io::render_stereo_synth(options), std::invalid_argument);
  options = small_options();
  options.objects = {io::synth_object(io::SynthClass::cone, 0, -3)};
  EXPECT_THROW(io::render_stereo_synth(options), std::invalid_argument);
}

TEST(StereoSynth, UnwritableFolderLeavesNothing) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_synth");
  StereoSynthOptions options = small_options();
  options.width = 32;
  options.height = 16;
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  std::ofstream(scratch.path("file")) << "x";
  EXPECT_THROW(io::write_stereo_synth(scratch.path("file") + "/scene", scene, options), std::runtime_error);
  EXPECT_THROW(io::write_stereo_synth(scratch.path("file"), scene, options), std::runtime_error);
  int entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(scratch.root())) {
    (void)entry;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
}

}  // namespace
