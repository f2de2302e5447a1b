// ARM task road_profile with the v_disparity kernel on synthetic disparity maps of known geometry:
// a flat road (Labayrade's d(v) = (B / h)((v - v0) cos theta + f sin theta)) with fronto-parallel
// boxes gives the V-disparity line on the plane's disparity, a fitted line, camera height and pitch
// close to the truth, boxes rejected by RANSAC; empty, wall, sky, upside-down and implausibly high
// scenes give no road; graphs/road-profile.json carries a profile over a weak frame through its
// delayed edge and stops carrying after max_carried_frames.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "arm/scheduler.h"
#include "arm/tasks/road_profile.h"
#include "dag/graph.h"
#include "dag/tile_executor.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

constexpr int kWidth = 641;
constexpr int kHeight = 481;
constexpr int kMinDisparity = 0;
constexpr int kNumBins = 64;
constexpr int16_t kInvalid = (kMinDisparity - 1) * 16;

struct Camera {
  double focal_px = 700.0;
  double baseline_m = 0.30;
  double height_m = 1.5;
  double pitch_rad = 0.05;  // optical axis below the horizon
  double principal_row_px = (kHeight - 1) / 2.0;
  double slope() const { return baseline_m / height_m * std::cos(pitch_rad); }
  double horizon_row() const { return principal_row_px - focal_px * std::tan(pitch_rad); }
  double road_disparity(double v) const { return slope() * (v - horizon_row()); }
  // The road row whose disparity is d (a box standing on the road has its foot there).
  double road_row(double d) const { return horizon_row() + d / slope(); }
};

struct Box {
  double depth_m, left_m, width_m, height_m;  // left_m: lateral position of its left edge, x right
};

// The road below the horizon (noise +-0.25 px, 5 % invalid), invalid sky, and fronto-parallel boxes.
Plane road_scene(const Camera& camera, const std::vector<Box>& boxes, uint32_t seed) {
  Plane plane(kWidth, kHeight, {ElementType::s16, 4}, kWidth * 2 + 22);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> noise(-0.25, 0.25);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double u0 = (kWidth - 1) / 2.0;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      double d = camera.road_disparity(v);
      bool valid = d > 0.0;
      for (const Box& box : boxes) {
        const double box_d = camera.focal_px * camera.baseline_m / box.depth_m;
        const double foot = camera.road_row(box_d);
        const double top = foot - camera.focal_px * box.height_m / box.depth_m;
        const double x0 = u0 + camera.focal_px * box.left_m / box.depth_m;
        const double x1 = x0 + camera.focal_px * box.width_m / box.depth_m;
        if (v >= top && v <= foot && u >= x0 && u < x1 && (!valid || box_d >= d)) {
          d = box_d;
          valid = true;
        }
      }
      const double draw = unit(generator);
      plane.at<int16_t>(u, v) =
          valid && draw > 0.05 ? static_cast<int16_t>(std::lround((d + noise(generator)) * 16.0)) : kInvalid;
    }
  }
  return plane;
}

Plane filled(int16_t value_q4) {
  Plane plane(kWidth, kHeight, {ElementType::s16, 4});
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) plane.at<int16_t>(u, v) = value_q4;
  }
  return plane;
}

Plane v_disparity(const Plane& disparity) {
  const KernelDescriptor& kernel = testing::kernel_named("v_disparity");
  const PreparedKernel prepared =
      kernel.prepare({{"min_disparity", kMinDisparity}, {"num_bins", kNumBins}}, {{disparity.width(), disparity.height()}});
  Plane histogram(kNumBins, disparity.height(), {ElementType::u16, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {disparity.view()}, {histogram.view()}};
  run_vector_node(binding, kNumBins, 32, KernelBackend::native, simd::active_isa());
  return histogram;
}

nlohmann::json task_params(const Camera& camera) {
  return {{"min_disparity", kMinDisparity}, {"focal_px", camera.focal_px}, {"baseline_m", camera.baseline_m},
          {"principal_row_px", camera.principal_row_px}};
}

arm::RoadProfile road_profile(const Plane& histogram, const nlohmann::json& params, const Plane* previous = nullptr) {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("road_profile");
  if (task == nullptr) throw std::runtime_error("ARM task 'road_profile' is not registered");
  const PreparedKernel prepared = task->prepare(params, {{histogram.width(), histogram.height()}, {arm::kRoadProfileWords, 1}});
  Plane none(arm::kRoadProfileWords, 1, {ElementType::s32, 0});
  for (int i = 0; i < arm::kRoadProfileWords; ++i) none.at<int32_t>(i, 0) = 0;
  Plane output(arm::kRoadProfileWords, 1, {ElementType::s32, 0});
  ArmWork work;
  ArmTaskArgs args{{&histogram, previous != nullptr ? previous : &none}, {&output}, prepared.params.get(), &work};
  task->run(args);
  EXPECT_GT(work.scalar_ops, 0u);
  return arm::decode_road_profile(output);
}

int peak_bin(const Plane& histogram, int v) {
  int best = 0;
  for (int b = 1; b < histogram.width(); ++b) best = histogram.at<uint16_t>(b, v) > histogram.at<uint16_t>(best, v) ? b : best;
  return best;
}

const std::vector<Box> kBoxes = {
    {12.0, -4.0, 8.0, 2.0},   // wide: in its rows the box, not the road, is each row's peak
    {25.0, -6.0, 1.0, 1.7},   // a pedestrian-sized box on the left
    {40.0, 3.0, 0.5, 0.5},    // a small one on the right
};

TEST(RoadProfile, VDisparityOfAFlatRoadPeaksOnThePlaneDisparity) {
  const Camera camera;
  const Plane histogram = v_disparity(road_scene(camera, kBoxes, 7));
  const double big_box_d = camera.focal_px * camera.baseline_m / kBoxes[0].depth_m;  // 17.5 px
  const double big_box_foot = camera.road_row(big_box_d);
  int road_rows = 0, box_rows = 0;
  for (int v = static_cast<int>(camera.horizon_row()) + 3; v < kHeight; ++v) {
    const int peak = peak_bin(histogram, v);
    if (v <= big_box_foot) {
      // The wide box covers 467 of 641 columns: its disparity is the row's peak.
      EXPECT_EQ(peak, static_cast<int>(std::floor(big_box_d)) - kMinDisparity) << "row " << v;
      ++box_rows;
    } else {
      // The road: the bin of the plane's disparity (noise +-0.25 px may tip it into a neighbour).
      EXPECT_NEAR(peak + kMinDisparity + 0.5, camera.road_disparity(v), 1.0) << "row " << v;
      ++road_rows;
    }
  }
  EXPECT_GT(box_rows, 50);
  EXPECT_GT(road_rows, 150);
}

void print_fit(const char* label, const arm::RoadProfile& profile, const Camera& camera) {
  std::printf("%s: slope %.6f (true %.6f), horizon row %.3f (true %.3f), height %d mm (true %.0f), pitch %.5f rad (true %.5f), "
              "%d inliers of %d rows, confidence %d, rms %.3f px\n",
              label, profile.slope, camera.slope(), profile.horizon_row, camera.horizon_row(), profile.camera_height_mm,
              camera.height_m * 1000.0, profile.pitch_rad, camera.pitch_rad, profile.inlier_count, profile.point_count,
              profile.confidence, profile.rms_residual_px);
}

// The plane alone: the error left is the bins' quantisation (the kernel floors d) and the noise.
TEST(RoadProfile, FitsTheFlatRoadLineAndCameraPose) {
  const Camera camera;
  const arm::RoadProfile profile = road_profile(v_disparity(road_scene(camera, {}, 7)), task_params(camera));
  print_fit("plane alone", profile, camera);
  ASSERT_TRUE(profile.valid);
  EXPECT_FALSE(profile.carried);
  EXPECT_NEAR(profile.slope, camera.slope(), 0.001);
  EXPECT_NEAR(profile.horizon_row, camera.horizon_row(), 1.0);
  EXPECT_NEAR(profile.camera_height_mm, camera.height_m * 1000.0, 10.0);
  EXPECT_NEAR(profile.pitch_rad, camera.pitch_rad, 0.0015);
  EXPECT_GT(profile.confidence, 900);
  EXPECT_LT(profile.rms_residual_px, 0.4);
}

// With boxes: the wide box is each row's peak from the horizon down to its foot (a vertical segment
// in V-disparity) and RANSAC leaves those rows out. Least squares over all rows would be pulled far
// off; what is left is a small pull from the rows just above each box's foot, where the box's
// disparity is within the inlier threshold of the road's (the box stands on the road).
TEST(RoadProfile, FitsTheRoadLineAndCameraPoseDespiteBoxes) {
  const Camera camera;
  const arm::RoadProfile profile = road_profile(v_disparity(road_scene(camera, kBoxes, 7)), task_params(camera));
  print_fit("plane and boxes", profile, camera);
  ASSERT_TRUE(profile.valid);
  EXPECT_FALSE(profile.carried);
  EXPECT_NEAR(profile.slope, camera.slope(), 0.002);
  EXPECT_NEAR(profile.horizon_row, camera.horizon_row(), 2.0);
  EXPECT_NEAR(profile.camera_height_mm, camera.height_m * 1000.0, 20.0);
  EXPECT_NEAR(profile.pitch_rad, camera.pitch_rad, 0.003);
  EXPECT_GE(profile.point_count - profile.inlier_count, 50);  // the box rows, left out
  EXPECT_GT(profile.confidence, 600);
  EXPECT_LE(profile.confidence, 1000);
  EXPECT_LT(profile.rms_residual_px, 0.5);
}

TEST(RoadProfile, FitsOtherHeightsAndPitches) {
  for (const auto& [height_m, pitch_rad] : std::vector<std::pair<double, double>>{{1.2, 0.0}, {2.0, -0.03}, {0.8, 0.1}}) {
    Camera camera;
    camera.height_m = height_m;
    camera.pitch_rad = pitch_rad;
    const arm::RoadProfile profile = road_profile(v_disparity(road_scene(camera, {kBoxes[1]}, 11)), task_params(camera));
    ASSERT_TRUE(profile.valid) << height_m << " m, " << pitch_rad << " rad";
    EXPECT_NEAR(profile.camera_height_mm, height_m * 1000.0, height_m * 15.0) << height_m << " m";
    EXPECT_NEAR(profile.pitch_rad, pitch_rad, 0.003) << height_m << " m";
  }
}

// A far background (one disparity) on every row above the horizon, more rows than the road has (the
// camera looks up, so the horizon is low): those rows' peaks form a near-vertical line in V-disparity
// with more points than the road's line; the gate inside RANSAC keeps that implausible candidate from
// winning, and the confidence counts only the rows below the horizon.
TEST(RoadProfile, FindsTheRoadUnderAFarBackgroundThatCoversMoreRows) {
  Camera camera;
  camera.pitch_rad = -0.1;
  constexpr double kBackgroundDisparityPx = 2.0;
  Plane disparity = road_scene(camera, {}, 5);
  int background_rows = 0;
  for (int v = 0; v < kHeight; ++v) {
    if (camera.road_disparity(v) >= kBackgroundDisparityPx) continue;
    ++background_rows;
    for (int u = 0; u < kWidth; ++u) disparity.at<int16_t>(u, v) = static_cast<int16_t>(kBackgroundDisparityPx * 16);
  }
  ASSERT_GT(background_rows, kHeight - background_rows);
  const arm::RoadProfile profile = road_profile(v_disparity(disparity), task_params(camera));
  print_fit("far background over most rows", profile, camera);
  ASSERT_TRUE(profile.valid);
  EXPECT_NEAR(profile.camera_height_mm, camera.height_m * 1000.0, 20.0);
  EXPECT_NEAR(profile.pitch_rad, camera.pitch_rad, 0.003);
  EXPECT_GT(profile.confidence, 800);
}

// A road that climbs from row kBreakRow up (convex in V-disparity: above the crossing the far line,
// less steep, lies above the near one). Both segments are found whichever the main fit took first;
// the record's near line and camera are the near segment's; road_disparity_q4_at_row follows the far
// line above the break. A flat road has no second segment.
TEST(RoadProfile, FitsASecondSegmentWhereTheRoadClimbs) {
  const Camera camera;
  for (const double far_slope_ratio : {0.7, 0.5}) {
    constexpr int kBreakRow = 330;
    const double near_slope = camera.slope();
    const double near_intercept = -near_slope * camera.horizon_row();
    const double far_slope = far_slope_ratio * near_slope;
    const double far_intercept = near_slope * kBreakRow + near_intercept - far_slope * kBreakRow;  // crosses at the break
    Plane disparity = road_scene(camera, {}, 13);
    std::mt19937 generator(17);
    std::uniform_real_distribution<double> noise(-0.25, 0.25);
    for (int v = 0; v < kBreakRow; ++v) {
      const double d = far_slope * v + far_intercept;
      for (int u = 0; u < kWidth; ++u) {
        disparity.at<int16_t>(u, v) = d > 0.0 ? static_cast<int16_t>(std::lround((d + noise(generator)) * 16.0)) : kInvalid;
      }
    }
    const Plane histogram = v_disparity(disparity);
    const arm::RoadProfile profile = road_profile(histogram, task_params(camera));
    print_fit("climb", profile, camera);
    ASSERT_TRUE(profile.valid) << far_slope_ratio;
    ASSERT_TRUE(profile.far_valid) << far_slope_ratio;
    EXPECT_NEAR(profile.slope, near_slope, 0.003) << far_slope_ratio;
    EXPECT_NEAR(profile.camera_height_mm, camera.height_m * 1000.0, 25.0) << far_slope_ratio;
    EXPECT_NEAR(profile.far_slope, far_slope, 0.003) << far_slope_ratio;
    EXPECT_NEAR(profile.far_break_row, kBreakRow, 4) << far_slope_ratio;

    // The record's per-row profile: the far line above the break, the near line below.
    Plane record(arm::kRoadProfileWords, 1, {ElementType::s32, 0});
    const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("road_profile");
    const PreparedKernel prepared = task->prepare(task_params(camera), {{histogram.width(), histogram.height()}, {arm::kRoadProfileWords, 1}});
    Plane none(arm::kRoadProfileWords, 1, {ElementType::s32, 0});
    for (int i = 0; i < arm::kRoadProfileWords; ++i) none.at<int32_t>(i, 0) = 0;
    ArmWork work;
    task->run(ArmTaskArgs{{&histogram, &none}, {&record}, prepared.params.get(), &work});
    const int32_t* word = record.row<const int32_t>(0);
    for (const int v : {kBreakRow - 60, kBreakRow + 60}) {
      const double expected_px = v < kBreakRow ? far_slope * v + far_intercept : near_slope * v + near_intercept;
      EXPECT_NEAR(arm::road_disparity_q4_at_row(word, v) / 16.0, expected_px, 0.3) << "row " << v;
    }
  }
  const arm::RoadProfile flat = road_profile(v_disparity(road_scene(camera, kBoxes, 7)), task_params(camera));
  ASSERT_TRUE(flat.valid);
  EXPECT_FALSE(flat.far_valid);
}

// road_disparity_q4_at_row's arithmetic on a hand-made record: Q16 line, rounding half up to Q4.
TEST(RoadProfile, RecordGivesTheRowDisparityInQ4RoundedHalfUp) {
  int32_t word[arm::kRoadProfileWords] = {};
  word[arm::kRoadValid] = 1;
  word[arm::kRoadSlopeQ16] = 13107;          // 0.2 px per row (0.199996...)
  word[arm::kRoadInterceptQ16] = -65536 * 100;
  word[arm::kRoadFarValid] = 1;
  word[arm::kRoadFarSlopeQ16] = 6554;        // ~0.1
  word[arm::kRoadFarInterceptQ16] = -65536 * 50;
  word[arm::kRoadFarBreakRow] = 500;
  // Row 600: (13107 * 600 - 6553600 + 2048) >> 12 = (1310600 + 2048) >> 12 = 320 (20.0 px).
  EXPECT_EQ(arm::road_disparity_q4_at_row(word, 600), (int64_t{13107} * 600 - 6553600 + 2048) >> 12);
  EXPECT_EQ(arm::road_disparity_q4_at_row(word, 600), 320);
  // Row 499 is above the break: the far line, (6554 * 499 - 3276800 + 2048) >> 12 = -2.
  EXPECT_EQ(arm::road_disparity_q4_at_row(word, 499), (int64_t{6554} * 499 - 3276800 + 2048) >> 12);
  word[arm::kRoadFarValid] = 0;  // one line again
  EXPECT_EQ(arm::road_disparity_q4_at_row(word, 499), (int64_t{13107} * 499 - 6553600 + 2048) >> 12);
}

TEST(RoadProfileNoRoad, EmptyWallSkyUpsideDownAndImplausibleScenesGiveNone) {
  const Camera camera;
  Plane upside_down = road_scene(camera, {}, 9);  // the road at the top of the image
  Plane flipped(kWidth, kHeight, {ElementType::s16, 4});
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) flipped.at<int16_t>(u, v) = upside_down.at<int16_t>(u, kHeight - 1 - v);
  }
  Camera high = camera;
  high.height_m = 10.0;  // a road seen from 10 m: the gate (<= 4000 mm) refuses it
  struct Scene {
    const char* name;
    Plane disparity;
  };
  std::vector<Scene> scenes;
  scenes.push_back({"all invalid", filled(kInvalid)});
  // A wall 4 m ahead across the view (52.5 px): only the 14 rows below its foot show road, fewer than
  // min_inliers. (A wall far enough to leave the road many rows, 21 m say, rightly gives a road.)
  scenes.push_back({"wall 4 m ahead", road_scene(camera, {{4.0, -100.0, 200.0, 100.0}}, 3)});
  scenes.push_back({"wall everywhere", filled(10 * 16 + 5)});
  scenes.push_back({"sky at 0.2 px", filled(3)});
  scenes.push_back({"upside down", std::move(flipped)});
  scenes.push_back({"camera 10 m high", road_scene(high, {}, 5)});
  for (const Scene& scene : scenes) {
    const arm::RoadProfile profile = road_profile(v_disparity(scene.disparity), task_params(camera));
    EXPECT_FALSE(profile.valid) << scene.name;
    EXPECT_EQ(profile.confidence, 0) << scene.name;
    EXPECT_FALSE(profile.carried) << scene.name;
  }
}

// arm/tasks/road_profile.cpp's counted work where no row has a peak: the peak scan (3 per bin and
// row) and the fixed 64 of gate and record; the V-disparity plane read once, the two records.
TEST(RoadProfile, CountedWorkOfAnEmptyMapEqualsClosedForm) {
  const Camera camera;
  const Plane histogram = v_disparity(filled(kInvalid));
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("road_profile");
  ASSERT_NE(task, nullptr);
  const PreparedKernel prepared = task->prepare(task_params(camera), {{kNumBins, kHeight}, {arm::kRoadProfileWords, 1}});
  Plane previous(arm::kRoadProfileWords, 1, {ElementType::s32, 0});
  for (int i = 0; i < arm::kRoadProfileWords; ++i) previous.at<int32_t>(i, 0) = 0;
  Plane output(arm::kRoadProfileWords, 1, {ElementType::s32, 0});
  ArmWork work;
  task->run(ArmTaskArgs{{&histogram, &previous}, {&output}, prepared.params.get(), &work});
  EXPECT_EQ(work.scalar_ops, 3u * kNumBins * kHeight + 64u);
  EXPECT_EQ(work.memory_bytes, 2u * kNumBins * kHeight + 2u * 4u * arm::kRoadProfileWords);
}

TEST(RoadProfileMustFail, RefusesMissingCalibrationAndUnknownParameters) {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("road_profile");
  ASSERT_NE(task, nullptr);
  try {
    task->prepare({{"focal_px", 700.0}}, {{64, 480}, {arm::kRoadProfileWords, 1}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "parameter 'baseline_m': expected a number > 0, got none");
  }
  EXPECT_THROW(task->prepare({{"focal_px", 700.0}, {"baseline_m", 0.3}, {"ransac_iters", 5}}, {{64, 480}, {arm::kRoadProfileWords, 1}}),
               KernelError);
  EXPECT_THROW(task->prepare({{"focal_px", 700.0}, {"baseline_m", 0.3}, {"min_confidence", 1001}}, {{64, 480}, {arm::kRoadProfileWords, 1}}),
               KernelError);
}

// graphs/road-profile.json: v_disparity then road_profile, whose "previous" input is its own output
// over a delayed edge. Frame 1 fits, frame 2 (all invalid) carries frame 1's profile, frame 3 (all
// invalid again) stops carrying (max_carried_frames 1 here), frame 4 fits again.
TEST(RoadProfileGraph, CarriesThePreviousProfileOverAWeakFrameThroughTheDelayedEdge) {
  GraphSpec spec = load_graph_spec(std::string(LPSTEREO_SOURCE_DIR) + "/graphs/road-profile.json");
  Camera camera;
  for (NodeSpec& node : spec.nodes) {
    if (node.task != "road_profile") continue;
    camera.focal_px = node.params.at("focal_px").get<double>();
    camera.baseline_m = node.params.at("baseline_m").get<double>();
    node.params["principal_row_px"] = camera.principal_row_px;
    node.params["max_carried_frames"] = 1;
  }
  Graph graph(spec);
  VerifyOptions options;
  options.frame_width = kWidth;
  options.frame_height = kHeight;
  graph.verify(options);
  ASSERT_TRUE(graph.buffers()[graph.buffer_index("road")].read_delayed);

  const Plane road = road_scene(camera, kBoxes, 21);
  const Plane empty = filled(kInvalid);
  for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
    arm::FrameRunner runner(graph, 2, backend);
    runner.process({{"disparity", &road}});
    const arm::RoadProfile first = arm::decode_road_profile(runner.buffer("road"));
    ASSERT_TRUE(first.valid);
    EXPECT_FALSE(first.carried);
    EXPECT_NEAR(first.camera_height_mm, camera.height_m * 1000.0, 20.0);

    runner.process({{"disparity", &empty}});
    const arm::RoadProfile second = arm::decode_road_profile(runner.buffer("road"));
    EXPECT_TRUE(second.valid);
    EXPECT_TRUE(second.carried);
    EXPECT_EQ(second.frames_carried, 1);
    EXPECT_EQ(second.confidence, 0);  // this frame's own confidence
    EXPECT_EQ(second.slope, first.slope);
    EXPECT_EQ(second.horizon_row, first.horizon_row);
    EXPECT_EQ(second.camera_height_mm, first.camera_height_mm);

    runner.process({{"disparity", &empty}});
    const arm::RoadProfile third = arm::decode_road_profile(runner.buffer("road"));
    EXPECT_FALSE(third.valid);
    EXPECT_FALSE(third.carried);

    runner.process({{"disparity", &road}});
    const arm::RoadProfile fourth = arm::decode_road_profile(runner.buffer("road"));
    EXPECT_TRUE(fourth.valid);
    EXPECT_FALSE(fourth.carried);
    EXPECT_EQ(fourth.slope, first.slope);  // same map, same deterministic RANSAC
  }
}

}  // namespace
}  // namespace lpstereo
