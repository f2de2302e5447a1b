// io/stereo_synth: the ground truth is the geometry (road disparity against the closed form, object
// boxes against their pixels and their 3D positions), the two views agree with it, the disparity
// engine recovers it, and the files (KITTI PNG, objects.json, both calibration files) read back.
#include "io/stereo_synth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "arm/disparity_engine.h"
#include "io/calibration.h"
#include "io/disparity_io.h"
#include "io/disparity_metrics.h"
#include "io/image_io.h"
#include "io/stereo_sequence.h"
#include "io/synth_render.h"
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

// Renders with 1 and with 3 threads, expects the same bits (views and truth), returns the scene.
io::StereoSynthScene render_expecting_the_same_bits_for_any_thread_count(StereoSynthOptions options) {
  options.threads = 1;
  io::StereoSynthScene one = io::render_stereo_synth(options);
  options.threads = 3;
  const io::StereoSynthScene three = io::render_stereo_synth(options);
  EXPECT_EQ(cv::norm(one.left, three.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(one.right, three.right, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(one.disparity_px, three.disparity_px, cv::NORM_INF), 0);
  return one;
}

TEST(StereoSynth, DeterministicBySeedAndThreadCount) {
  StereoSynthOptions options = small_options();
  options.objects = io::random_synth_objects(9);
  options.noise_sigma = 2;
  const io::StereoSynthScene one = render_expecting_the_same_bits_for_any_thread_count(options);
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
  add(scene.left_colour);  // empty (adds nothing) unless options.colour
  add(scene.right_colour);
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

// The coefficient of variation (standard deviation / mean) of the left view's grey over the asphalt
// of the middle lane (object id 0, finite truth, |X| < 1.5 m: clear of the lane lines at 1.75 m)
// where the true depth lies in [near_m, far_m).
double lane_contrast(const io::StereoSynthScene& scene, double baseline_m, double near_m, double far_m) {
  const double centre_u = (scene.left.cols - 1) / 2.0;
  double sum = 0, squares = 0;
  int count = 0;
  for (int v = 0; v < scene.left.rows; ++v) {
    for (int u = 0; u < scene.left.cols; ++u) {
      const float truth = scene.disparity_px.at<float>(v, u);
      if (!std::isfinite(truth) || truth <= 0 || scene.object_ids.at<uint16_t>(v, u) != 0) continue;
      const double depth_m = scene.focal_px * baseline_m / truth;
      if (depth_m < near_m || depth_m >= far_m || std::abs(u - centre_u) * baseline_m / truth >= 1.5) continue;
      const double grey = scene.left.at<uint8_t>(v, u);
      sum += grey;
      squares += grey * grey;
      ++count;
    }
  }
  EXPECT_GT(count, 500) << "lane pixels in [" << near_m << ", " << far_m << ") m";
  const double mean = sum / count;
  return std::sqrt(std::max(0.0, squares / count - mean * mean)) / mean;
}

// Real asphalt: little contrast beyond a few metres, where the textured road keeps several times
// more; its grain shows where the pixels are small on the road (a long lens looking down) and blurs
// out farther away.
TEST(StereoSynthSurface, AsphaltIsLowContrastAtDistanceAndGrainyUpClose) {
  StereoSynthOptions options = small_options();
  options.width = 640;
  options.height = 480;
  options.road_surface = io::SynthRoadSurface::asphalt;
  const io::StereoSynthScene asphalt = io::render_stereo_synth(options);
  options.road_surface = io::SynthRoadSurface::textured;
  const io::StereoSynthScene textured = io::render_stereo_synth(options);
  const double asphalt_far = lane_contrast(asphalt, options.baseline_m, 12, 30);
  const double textured_far = lane_contrast(textured, options.baseline_m, 12, 30);
  EXPECT_LT(asphalt_far, 0.5 * textured_far) << "asphalt " << asphalt_far << ", textured " << textured_far;
  EXPECT_LT(asphalt_far, 0.05) << asphalt_far;
  // hfov 20 degrees (f 1815 px), pitched down 0.3 rad: the road from 3.3 to 8.8 m.
  options.hfov_deg = 20;
  options.pitch_rad = 0.3;
  options.road_surface = io::SynthRoadSurface::asphalt;
  const io::StereoSynthScene close_up = io::render_stereo_synth(options);
  const double near = lane_contrast(close_up, options.baseline_m, 3, 4.5);
  const double farther = lane_contrast(close_up, options.baseline_m, 7, 9);
  EXPECT_GT(near, 1.5 * farther) << "near " << near << ", farther " << farther;
  EXPECT_EQ(io::parse_synth_road_surface(io::synth_road_surface_name(io::SynthRoadSurface::asphalt)), io::SynthRoadSurface::asphalt);
  EXPECT_EQ(io::parse_synth_road_surface(io::synth_road_surface_name(io::SynthRoadSurface::textured)), io::SynthRoadSurface::textured);
}

// Vignetting scales the light by 1 - v r^2 / R^2: the corners lose the share v (the right camera
// kRightVignettingRatio v), the centre nothing.
TEST(StereoSynthSurface, VignettingDarkensTheCornersByItsShare) {
  StereoSynthOptions options = small_options();
  const io::StereoSynthScene plain = io::render_stereo_synth(options);
  options.vignetting = 0.3;
  const io::StereoSynthScene vignetted = io::render_stereo_synth(options);
  const int right = options.width - 1, bottom = options.height - 1;
  const int corners[4][2] = {{0, 0}, {right, 0}, {0, bottom}, {right, bottom}};
  for (const auto& corner : corners) {
    const double left_plain = plain.left.at<uint8_t>(corner[1], corner[0]);
    const double right_plain = plain.right.at<uint8_t>(corner[1], corner[0]);
    ASSERT_GT(left_plain, 40) << "a corner too dark to measure";
    EXPECT_NEAR(vignetted.left.at<uint8_t>(corner[1], corner[0]), 0.7 * left_plain, 1.0) << corner[0] << "," << corner[1];
    EXPECT_NEAR(vignetted.right.at<uint8_t>(corner[1], corner[0]), (1 - 0.3 * io::kRightVignettingRatio) * right_plain, 1.0)
        << corner[0] << "," << corner[1];
  }
  // The pixels beside the centre lose under 0.1 % of their light: at most the rounding.
  for (int v = options.height / 2 - 1; v <= options.height / 2; ++v) {
    for (int u = options.width / 2 - 1; u <= options.width / 2; ++u) {
      EXPECT_LE(std::abs(vignetted.left.at<uint8_t>(v, u) - plain.left.at<uint8_t>(v, u)), 1) << u << "," << v;
    }
  }
  EXPECT_EQ(cv::norm(plain.disparity_px, vignetted.disparity_px, cv::NORM_INF), 0) << "the truth does not depend on the lens";
}

// Blur spreads the radiance (less energy in neighbour differences, a nearly equal mean), renders the
// same bits for any thread count, and leaves the truth alone.
TEST(StereoSynthSurface, BlurSpreadsTheImageTheSameForAnyThreadCount) {
  StereoSynthOptions options = small_options();
  options.objects = io::random_synth_objects(3);
  options.road_surface = io::SynthRoadSurface::asphalt;
  const io::StereoSynthScene sharp = io::render_stereo_synth(options);
  options.blur_sigma_px = 1.0;
  options.vignetting = 0.2;
  options.noise_sigma = 2;
  options.colour = true;
  const io::StereoSynthScene blurred = render_expecting_the_same_bits_for_any_thread_count(options);
  options.noise_sigma = 0;
  options.colour = false;
  options.vignetting = 0;
  const io::StereoSynthScene blurred_clean = io::render_stereo_synth(options);
  auto difference_energy = [](const cv::Mat& grey) {
    double energy = 0;
    for (int v = 0; v < grey.rows; ++v) {
      for (int u = 1; u < grey.cols; ++u) energy += std::pow(grey.at<uint8_t>(v, u) - grey.at<uint8_t>(v, u - 1), 2);
    }
    return energy;
  };
  EXPECT_LT(difference_energy(blurred_clean.left), 0.7 * difference_energy(sharp.left));
  EXPECT_LT(difference_energy(blurred_clean.right), 0.7 * difference_energy(sharp.right));
  EXPECT_NEAR(cv::mean(blurred_clean.left)[0], cv::mean(sharp.left)[0], 1.0);
  EXPECT_EQ(cv::norm(sharp.disparity_px, blurred.disparity_px, cv::NORM_INF), 0);
  EXPECT_FALSE(blurred.left_colour.empty());
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
  const auto expect_refused = [](const StereoSynthOptions& bad, const std::string& name, const std::string& value) {
    try {
      io::render_stereo_synth(bad);
      ADD_FAILURE() << "expected std::invalid_argument naming " << name;
    } catch (const std::invalid_argument& error) {
      EXPECT_EQ(std::string(error.what()).rfind(name + ": expected", 0), 0u) << error.what();
      EXPECT_NE(std::string(error.what()).find(value), std::string::npos) << error.what();
    }
  };
  options = small_options();
  options.vignetting = 0.7;
  expect_refused(options, "vignetting", "0.7");
  options.vignetting = -0.1;
  expect_refused(options, "vignetting", "-0.1");
  options = small_options();
  options.blur_sigma_px = 3.5;
  expect_refused(options, "blur-px", "3.5");
  try {
    io::parse_synth_road_surface("gravel");
    ADD_FAILURE() << "expected std::invalid_argument for surface 'gravel'";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()), "surface: expected textured or asphalt, got 'gravel'");
  }
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


// ---- the height-field ground and the roll angle (issue 9) ----

// The road-frame direction of the left ray through pixel (u, v), camera depth 1: the camera is
// rolled by `roll` about its optical axis, then pitched by `pitch` about X (the header's convention,
// written out again here).
struct TestRay {
  double x, y, z;
};
TestRay left_ray(const io::StereoSynthScene& scene, const StereoSynthOptions& options, double u, double v) {
  const double cx = (options.width - 1) / 2.0, cy = (options.height - 1) / 2.0;
  const double a = (u - cx) / scene.focal_px, b = (v - cy) / scene.focal_px;
  const double cr = std::cos(options.roll_rad), sr = std::sin(options.roll_rad);
  const double x = a * cr - b * sr, y = a * sr + b * cr;
  const double cp = std::cos(options.pitch_rad), sp = std::sin(options.pitch_rad);
  return {x, y * cp + sp, -y * sp + cp};
}

// The first crossing of the ray with the ground Y = h - height(X, Z), by dense sampling (1 cm steps
// in depth) and bisection: independent of the renderer's Lipschitz march. +inf when none before 80 m.
double dense_ground_depth(const io::SynthGroundTruth& truth, double camera_height_m, TestRay d) {
  auto above = [&](double t) { return camera_height_m - truth.height_m(t * d.x, t * d.z) - t * d.y; };
  double previous = 0.0;
  for (double t = 0.01; t * d.z < 80; t += 0.01) {
    if (above(t) <= 0) {
      double lo = previous, hi = t;
      for (int i = 0; i < 60; ++i) (above(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
      return 0.5 * (lo + hi);
    }
    previous = t;
  }
  return std::numeric_limits<double>::infinity();
}

StereoSynthOptions field_options() {
  StereoSynthOptions options = small_options();
  options.ground = io::parse_synth_ground("hills+ditch+berm+rough");
  options.pitch_rad = 0.04;
  options.roll_rad = 0.05;
  options.seed = 6;
  options.samples_per_axis = 1;  // the truth comes from the centre ray anyway; keeps the test quick
  return options;
}

TEST(StereoSynthGround, KindsHaveTheirDocumentedShape) {
  StereoSynthOptions options = small_options();
  options.ground.ditch_depth_m = 0.5;
  options.ground.ditch_x_m = 6;
  options.ground.ditch_width_m = 2;
  options.ground.berm_height_m = 0.7;
  options.ground.berm_x_m = -7;
  options.ground.berm_width_m = 3;
  const io::SynthGroundTruth ditch_and_berm(options);
  for (double z : {3.0, 17.0, 55.0}) {
    EXPECT_NEAR(ditch_and_berm.height_m(0, z), 0, 1e-12);
    EXPECT_NEAR(ditch_and_berm.height_m(6, z), -0.5, 1e-12);    // V: full depth at the centre,
    EXPECT_NEAR(ditch_and_berm.height_m(6.5, z), -0.25, 1e-12);  // half at a quarter width,
    EXPECT_NEAR(ditch_and_berm.height_m(7.2, z), 0, 1e-12);      // none beyond the edge
    EXPECT_NEAR(ditch_and_berm.height_m(-7, z), 0.7, 1e-12);     // raised cosine: the crest,
    EXPECT_NEAR(ditch_and_berm.height_m(-7.75, z), 0.35, 1e-12); // half way down its flank
    EXPECT_NEAR(ditch_and_berm.height_m(-8.6, z), 0, 1e-12);
  }
  options.ground.ditch_u_shape = true;
  EXPECT_NEAR(io::SynthGroundTruth(options).height_m(6.5, 9), -0.5 * (1 - 0.25), 1e-12);  // 1 - u^2 at u = 1/2

  // Hills, rough and a slope: 0 under the camera, within the amplitudes, rising with the slope, and
  // no steeper anywhere (finite differences on a grid) than the Lipschitz bound the march relies on.
  options = small_options();
  options.ground = io::parse_synth_ground("hills+rough");
  options.slope_deg = 3;
  options.slope_start_m = 20;
  const io::SynthGroundTruth rolling(options);
  EXPECT_NEAR(rolling.height_m(0, 0), 0, 1e-12);
  double steepest = 0, lowest = 1e9, highest = -1e9;
  for (double z = 0; z < 60; z += 0.05) {
    for (double x = -12; x < 12; x += 0.05) {
      const double e = rolling.elevation_m(x, z);
      lowest = std::min(lowest, e), highest = std::max(highest, e);
      steepest = std::max(steepest, std::hypot(rolling.elevation_m(x + 0.05, z) - e, rolling.elevation_m(x, z + 0.05) - e) / 0.05);
      EXPECT_NEAR(rolling.height_m(x, z) - e, z > 20 ? std::tan(3 * kPi / 180) * (z - 20) : 0.0, 1e-9);
    }
  }
  EXPECT_LE(highest, rolling.max_elevation_m());
  EXPECT_GE(lowest, rolling.min_elevation_m());
  EXPECT_GT(highest - lowest, 0.5);  // hills 0.6 + rough 0.25: a real relief, not a flat road
  EXPECT_LT(steepest, rolling.lipschitz());
  EXPECT_GT(steepest, 0.1);
}

TEST(StereoSynthGround, GroundDisparityIsTheHeightFieldCrossing) {
  const StereoSynthOptions options = field_options();
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const io::SynthGroundTruth truth(options);
  int checked = 0;
  for (int v = 84; v < 160; v += 5) {
    for (int u = 5; u < 320; u += 23) {
      const double depth = dense_ground_depth(truth, options.camera_height_m, left_ray(scene, options, u, v));
      const float disparity = scene.disparity_px.at<float>(v, u);
      ASSERT_TRUE(std::isfinite(depth)) << u << "," << v;
      EXPECT_NEAR(disparity, scene.focal_px * options.baseline_m / depth, 1e-4 * disparity) << "pixel " << u << "," << v;
      EXPECT_NEAR(io::synth_road_disparity_px(options, u, v), scene.focal_px * options.baseline_m / depth, 1e-4 * disparity);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 16 * 14);
}

TEST(StereoSynthGround, ObjectsStandOnTheField) {
  StereoSynthOptions options = small_options();
  options.ground = io::parse_synth_ground("hills+rough");
  options.ground.rough_amplitude_m = 0.4;
  options.seed = 11;
  options.objects = {io::synth_object(io::SynthClass::box, 0.8, 9), io::synth_object(io::SynthClass::bin, -1.5, 14)};
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const io::SynthGroundTruth truth(options);
  for (const io::SynthObjectTruth& object : scene.objects) {
    const double ground = truth.height_m(object.object.x_m, object.object.z_m);
    // The base centre in the camera frame (no pitch, no roll): y is the camera height minus the
    // ground's height there, and the size is the one asked for.
    EXPECT_NEAR(object.position_m[1], options.camera_height_m - ground, 1e-9) << io::synth_class_name(object.object.object_class);
    EXPECT_EQ(object.object.height_m, options.objects[static_cast<size_t>(object.id - 1)].height_m);
    ASSERT_GT(object.visible_pixels, 50);
    // The object's top edge (the far edge of its top face, seen from above, at depth z + length / 2)
    // is where a pinhole puts ground + height_m, within a pixel.
    const double front_z = object.object.z_m - object.object.length_m / 2, back_z = object.object.z_m + object.object.length_m / 2;
    const double top_y = options.camera_height_m - ground - object.object.height_m;
    const double expected_top_v = (options.height - 1) / 2.0 + scene.focal_px * top_y / back_z;
    EXPECT_NEAR(object.bbox_px[1], expected_top_v, 1.0) << io::synth_class_name(object.object.object_class);
    // No gap under it: below the lowest object pixel of the centre column the ground is about as far
    // as the object's front face (it is the ground the object stands on, not ground far behind)
    const int u = static_cast<int>(std::lround((options.width - 1) / 2.0 + scene.focal_px * object.object.x_m / front_z));
    int bottom = -1;
    for (int v = 0; v < options.height; ++v) {
      if (scene.object_ids.at<uint16_t>(v, u) == object.id) bottom = v;
    }
    ASSERT_GE(bottom, 0);
    ASSERT_LT(bottom + 1, options.height);
    EXPECT_EQ(scene.object_ids.at<uint16_t>(bottom + 1, u), 0);
    // (On the ground one row down changes the disparity by about B / h = 0.2 px; ground seen behind a
    // gap would be metres further, over a pixel less.)
    EXPECT_NEAR(scene.disparity_px.at<float>(bottom + 1, u), scene.focal_px * options.baseline_m / front_z, 0.5)
        << io::synth_class_name(object.object.object_class);
  }
}

TEST(StereoSynthGround, RollRotatesTheHorizonByTheRollAngle) {
  // On a flat road a line of constant depth is parallel to the horizon: find where the disparity
  // crosses a fixed value in two columns and measure the angle of the line through both points.
  for (double roll : {0.1, -0.07}) {
    StereoSynthOptions options = small_options();
    options.roll_rad = roll;
    options.pitch_rad = 0.03;
    const io::StereoSynthScene scene = io::render_stereo_synth(options);
    const float level = 6.0f;
    auto crossing_row = [&](int u) {
      for (int v = options.height - 1; v > 0; --v) {
        const float below = scene.disparity_px.at<float>(v, u), above = scene.disparity_px.at<float>(v - 1, u);
        if (below >= level && above < level) return v - (below - level) / (below - above);
      }
      return -1.0f;
    };
    const int u0 = 40, u1 = 280;
    const double v0 = crossing_row(u0), v1 = crossing_row(u1);
    ASSERT_GT(v0, 0);
    ASSERT_GT(v1, 0);
    // + roll lowers the camera's right side: the scene turns the other way, the horizon rises at the right.
    EXPECT_NEAR(std::atan2(v0 - v1, u1 - u0), roll, 0.005) << "roll " << roll;
  }
}

TEST(StereoSynthGround, RolledFieldSceneIsTheSameForAnyThreadCountAndStereoConsistent) {
  StereoSynthOptions options = field_options();
  options.width = 160;
  options.height = 80;
  options.objects = io::random_synth_objects(2);
  const io::StereoSynthScene one = render_expecting_the_same_bits_for_any_thread_count(options);
  // With roll the right camera sits along the rolled x axis: the pair stays rectified, so a ground
  // pixel's texture is found in the right view on the same row, d pixels to the left.
  int compared = 0, close = 0;
  for (int v = 50; v < 80; ++v) {
    for (int u = 30; u < 150; ++u) {
      const float d = one.disparity_px.at<float>(v, u);
      if (!std::isfinite(d) || one.object_ids.at<uint16_t>(v, u) != 0) continue;
      const int ur = static_cast<int>(std::lround(u - d));
      if (ur < 0) continue;
      ++compared;
      close += std::abs(one.left.at<uint8_t>(v, u) - one.right.at<uint8_t>(v, ur)) <= 12 ? 1 : 0;
    }
  }
  ASSERT_GT(compared, 1000);
  EXPECT_GT(close, compared * 8 / 10) << close << " of " << compared;
}

// The height-field grounds (rough + berm, hills, the flat floating scene) with a moving, yawed camera,
// colour, anti-aliasing and every object class, exactly as the renderer drew them before its march was
// made faster (the pinned values were computed by the code of commit e50833d, before the speed-up):
// the speed-up must not change a single rendered bit. Each preset's frame 12, seed 3, at 200 x 150
// (the presets are 640 x 480; the march is the same per ray); country's value changed once since, when
// its oncoming car started farther (380 m instead of 300 m, to stay on the road for 300 frames): the
// renderer, checked unchanged by this test before, drew it. Also the rolled field with a ditch
// (V and U), a berm, hills and rough ground, rendered with 1 and 3 threads.
TEST(StereoSynthGround, HeightFieldScenesRenderTheSameBitsAsBeforeTheSpeedUp) {
  const struct {
    const char* preset;
    uint64_t checksum;
  } presets[] = {{"mining", 0x7b6f9d6688a9f6b2ull}, {"country", 0xe0e9c280b8326685ull}, {"urban", 0x1992b5dc74c98b4bull}, {"floating", 0xdc52f79d2dc1271full}};
  for (const auto& preset : presets) {
    io::StereoSequenceOptions sequence = io::preset_stereo_sequence(preset.preset, 3);
    sequence.base.width = 200;
    sequence.base.height = 150;
    sequence.base.colour = true;
    const uint64_t checksum = scene_checksum(io::render_sequence_frame(sequence, 12).scene);
    EXPECT_EQ(checksum, preset.checksum) << preset.preset << " " << std::hex << checksum;
  }
  StereoSynthOptions options = field_options();
  options.width = 200;
  options.height = 120;
  options.objects = io::random_synth_objects(5);
  options.camera_x_m = 1.5;
  options.camera_z_m = 3;
  options.camera_yaw_rad = -0.1;
  const uint64_t v_ditch = scene_checksum(render_expecting_the_same_bits_for_any_thread_count(options));
  options.ground.ditch_u_shape = true;
  options.camera_yaw_rad = 0.15;
  const uint64_t u_ditch = scene_checksum(io::render_stereo_synth(options));
  EXPECT_EQ(v_ditch, 0x67270855381b27cdull) << std::hex << v_ditch;
  EXPECT_EQ(u_ditch, 0x3baa9adf2ce94736ull) << std::hex << u_ditch;
}

// The march's cached value noise (io/synth_render.h) gives the plain value noise's bits, along a path
// that stays in a cell for several calls, crosses cell edges both ways, lands exactly on lattice
// points and runs through negative coordinates; a cache filled for one cell is not used for another.
TEST(StereoSynthGround, CachedValueNoiseIsTheSameBitsAsThePlainOne) {
  io::synth_detail::NoiseCell cell;
  int compared = 0;
  for (int i = -400; i <= 400; ++i) {
    const double x = i * 0.0625 + (i % 7) * 0.01, y = -3.0 + 0.37 * std::sin(i * 0.05) + i * 0.01;
    for (const double px : {x, std::floor(x)}) {
      const double cached = io::synth_detail::value_noise(px, y, 77, cell), plain = io::synth_detail::value_noise(px, y, 77);
      ASSERT_EQ(std::memcmp(&cached, &plain, sizeof cached), 0) << px << ", " << y;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 1602);
  // A jump back into an earlier cell refills the corners.
  const double first = io::synth_detail::value_noise(0.5, 0.5, 5, cell);
  (void)io::synth_detail::value_noise(10.5, 0.5, 5, cell);
  EXPECT_EQ(io::synth_detail::value_noise(0.5, 0.5, 5, cell), first);
  EXPECT_NE(io::synth_detail::value_noise(10.5, 0.5, 5, cell), first);
}

// The renderer's textures go through one noise cell per octave and surface (io/synth_render.h),
// shared by every object's seed: the cached texture gives the plain one's bits at every footprint
// (octaves fading in and out), along a path through several cells, and a cell filled for one seed is
// refilled, not reused, for another seed at the same cell.
TEST(StereoSynthGround, CachedTextureIsTheSameBitsAsThePlainOneAcrossSeeds) {
  const io::synth_detail::Texture texture{{0.012, 0.035, 0.1, 0.3}, {0.25, 0.2, 0.15, 0.1}, 4};
  io::synth_detail::NoiseCell cells[4];
  int compared = 0, differing_seeds = 0;
  for (int i = 0; i < 600; ++i) {
    const double s = -1.0 + i * 0.004, r = 0.3 + 0.1 * std::sin(i * 0.03);
    const double footprint = 0.001 + 0.0005 * (i % 40);  // from every octave to only the coarsest
    for (const uint64_t seed : {uint64_t{17}, uint64_t{18}, uint64_t{1000003}}) {
      const double cached = io::synth_detail::texture(texture, s, r, seed, footprint, cells);
      // The reference: the octaves' sum written out over the uncached value_noise.
      double plain = 0;
      for (int k = 0; k < texture.octaves; ++k) {
        const double weight = io::synth_detail::octave_weight(texture.cells[k], footprint);
        if (weight > 0) {
          plain += weight * texture.amplitudes[k] *
                   io::synth_detail::value_noise(s / texture.cells[k], r / texture.cells[k], seed + 7919u * static_cast<uint64_t>(k));
        }
      }
      ASSERT_EQ(std::memcmp(&cached, &plain, sizeof cached), 0) << s << ", " << r << ", seed " << seed;
      ++compared;
    }
    // Same point, same cells, other seed: a stale cell would give seed 17's value for seed 18.
    if (io::synth_detail::texture(texture, s, r, 17, 0.001, cells) != io::synth_detail::texture(texture, s, r, 18, 0.001, cells)) {
      ++differing_seeds;
    }
  }
  EXPECT_EQ(compared, 1800);
  EXPECT_GT(differing_seeds, 590);
}

TEST(StereoSynthGround, GroundJsonHoldsTheTrueHeight) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_synth");
  StereoSynthOptions options = field_options();
  options.width = 32;
  options.height = 16;
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  io::write_stereo_synth(scratch.path("scene"), scene, options);
  std::ifstream file(scratch.path("scene") + "/ground.json");
  const nlohmann::json json = nlohmann::json::parse(file);
  const io::SynthGroundTruth truth(options);
  const auto& grid = json.at("grid");
  ASSERT_EQ(grid.at("x_m").size(), 97u);
  ASSERT_EQ(grid.at("z_m").size(), 161u);
  for (size_t i : {0u, 40u, 160u}) {
    for (size_t j : {0u, 50u, 96u}) {
      const double x = grid.at("x_m")[j], z = grid.at("z_m")[i];
      EXPECT_NEAR(grid.at("height_m")[i][j].get<double>(), truth.height_m(x, z), 1e-6);
    }
  }
  EXPECT_EQ(json.at("ditch").at("depth_m").get<double>(), 0.6);
  EXPECT_EQ(json.at("roll_rad").get<double>(), 0.05);
}

TEST(StereoSynthGround, BadGroundAndRollAreRefusedByName) {
  auto message = [](const StereoSynthOptions& options) {
    try {
      io::render_stereo_synth(options);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  StereoSynthOptions options = small_options();
  options.roll_rad = 0.6;
  EXPECT_NE(message(options).find("roll"), std::string::npos) << message(options);
  options = small_options();
  options.ground.hills_amplitude_m = -1;
  EXPECT_NE(message(options).find("hills-amplitude-m"), std::string::npos) << message(options);
  options = small_options();
  options.ground.berm_height_m = 1;
  options.ground.berm_width_m = 0;
  EXPECT_NE(message(options).find("berm-width-m"), std::string::npos) << message(options);
  try {
    io::parse_synth_ground("hills+volcano");
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("ground"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("hills+volcano"), std::string::npos) << error.what();
    EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos);
  }
  EXPECT_FALSE(io::parse_synth_ground("flat").any());
  EXPECT_TRUE(io::parse_synth_ground("ditch-u").ditch_u_shape);
}

}  // namespace
