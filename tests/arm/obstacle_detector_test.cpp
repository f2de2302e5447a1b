// ObstacleDetector (arm/obstacle_detector.h) end to end on synthetic disparity maps of known
// geometry: a flat road (Labayrade's d(v) = (B / h)((v - v0) cos theta + f sin theta)) with
// fronto-parallel boxes gives a road profile near the true camera pose and one obstacle per box, with
// the box's projected bounding box and its distance; the road alone gives no obstacle; a wall and an
// all-invalid map give no road and no obstacle; the parameters reach the graph from one struct; with
// tracking the tracker joins the graph on a delayed edge and follows an approaching box.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>

#include <cmath>
#include <random>

#include "arm/obstacle_detector.h"

namespace lpstereo {
namespace {

constexpr int kWidth = 641;
constexpr int kHeight = 481;
constexpr int16_t kInvalid = -16;

struct Camera {
  double focal_px = 700.0;
  double baseline_m = 0.30;
  double height_m = 1.5;
  double pitch_rad = 0.05;
  double principal_row_px = (kHeight - 1) / 2.0;
  double principal_column_px = (kWidth - 1) / 2.0;
  double slope() const { return baseline_m / height_m * std::cos(pitch_rad); }
  double horizon_row() const { return principal_row_px - focal_px * std::tan(pitch_rad); }
  double road_disparity(double v) const { return slope() * (v - horizon_row()); }
  double road_row(double d) const { return horizon_row() + d / slope(); }
};

struct Box {
  double depth_m, left_m, width_m, height_m;  // left_m: lateral position of the left edge, x right
  // The image box (inclusive pixel centres covered), as the scene below paints it.
  int x0(const Camera& c) const { return static_cast<int>(std::ceil(c.principal_column_px + c.focal_px * left_m / depth_m)); }
  int x1(const Camera& c) const {
    return static_cast<int>(std::ceil(c.principal_column_px + c.focal_px * (left_m + width_m) / depth_m)) - 1;
  }
  double disparity(const Camera& c) const { return c.focal_px * c.baseline_m / depth_m; }
  double foot(const Camera& c) const { return c.road_row(disparity(c)); }
  double top(const Camera& c) const { return foot(c) - c.focal_px * height_m / depth_m; }
};

Plane road_scene(const Camera& camera, const std::vector<Box>& boxes, uint32_t seed) {
  Plane plane(kWidth, kHeight, {ElementType::s16, 4}, kWidth * 2 + 22);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> noise(-0.25, 0.25);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      double d = camera.road_disparity(v);
      bool valid = d > 0.0;
      for (const Box& box : boxes) {
        if (v >= box.top(camera) && v <= box.foot(camera) && u >= box.x0(camera) && u <= box.x1(camera) &&
            (!valid || box.disparity(camera) >= d)) {
          d = box.disparity(camera);
          valid = true;
        }
      }
      const double draw = unit(generator);
      plane.at<int16_t>(u, v) = valid && draw > 0.05 ? static_cast<int16_t>(std::lround((d + noise(generator)) * 16.0)) : kInvalid;
    }
  }
  return plane;
}

// The disparity stages alone: these maps have no image, so no corners to validate with.
arm::ObstacleParameters parameters(const Camera& camera) {
  arm::ObstacleParameters p;
  p.feature_validation = false;
  p.focal_px = camera.focal_px;
  p.baseline_m = camera.baseline_m;
  return p.for_disparity_range(0, 64);
}

const Plane& no_left() {
  static const Plane left(kWidth, kHeight, {ElementType::u8, 0});
  return left;
}

TEST(ObstacleDetector, FindsTheBoxesOnTheRoadAtTheirDistances) {
  const Camera camera;
  // A car-sized box at 12 m on the left and a 0.5 m box at 25 m on the right; the bottom road row's
  // disparity is 0.196 (480 - 205) = 54 px, inside the 64 searched.
  const std::vector<Box> boxes = {{12.0, -4.0, 1.8, 1.5}, {25.0, 2.0, 0.5, 0.5}};
  arm::ObstacleDetector detector(kWidth, kHeight, parameters(camera), {}, 2);
  const arm::ObstacleFrame frame = detector.run(road_scene(camera, boxes, 3), no_left());
  ASSERT_TRUE(frame.road.valid);
  EXPECT_NEAR(frame.road.camera_height_mm, 1500, 30);
  EXPECT_NEAR(frame.road.pitch_rad, camera.pitch_rad, 0.003);
  ASSERT_EQ(frame.obstacles.size(), boxes.size());
  // Fill order: far first.
  for (size_t i = 0; i < boxes.size(); ++i) {
    const Box& box = boxes[boxes.size() - 1 - i];
    const arm::Obstacle& found = frame.obstacles[i];
    SCOPED_TRACE("box at " + std::to_string(box.depth_m) + " m");
    EXPECT_NEAR(found.distance_m, box.depth_m, 0.03 * box.depth_m);
    EXPECT_NEAR(found.bbox_px[0], box.x0(camera), 1);
    EXPECT_NEAR(found.bbox_px[2], box.x1(camera), 1);
    // The top is the box's; the bottom stops where the box's disparity meets the road's within
    // VLDH's road margin (0.5 px + 2 %, at 0.196 px of road disparity per row about 3 rows, plus
    // the +-0.25 px noise): a few rows above the foot, up to a third of the small box's 14 rows.
    EXPECT_NEAR(found.bbox_px[1], std::ceil(box.top(camera)), 1);
    EXPECT_LE(found.bbox_px[3], box.foot(camera) + 1);
    EXPECT_GE(found.bbox_px[3], box.foot(camera) - 0.35 * (box.foot(camera) - box.top(camera)));
    EXPECT_NEAR(found.width_m, box.width_m, 0.1 * box.width_m + 0.01);
    EXPECT_NEAR(found.position_m[0], box.left_m + box.width_m / 2, 0.1);
    // The foot on the road in the pitched camera frame: y = (h - z sin theta) / cos theta
    // (Labayrade), minus the rows cut off at the bottom (up to 0.35 of the box's height).
    const double foot_y = (camera.height_m - box.depth_m * std::sin(camera.pitch_rad)) / std::cos(camera.pitch_rad);
    EXPECT_LE(found.position_m[1], foot_y + 0.02);
    EXPECT_GE(found.position_m[1], foot_y - 0.35 * box.height_m - 0.02);
  }
  // The planes for pictures.
  ASSERT_NE(frame.grid, nullptr);
  const arm::ObstacleParameters defaults;
  EXPECT_EQ(frame.grid->width(), (kWidth + defaults.grid.columns_per_cell - 1) / defaults.grid.columns_per_cell);
  EXPECT_EQ(frame.grid->height(), defaults.grid.geometry.grid_rows);
  EXPECT_EQ(frame.mask->width(), kWidth);
  EXPECT_EQ(frame.vdisp->width(), 62);  // bins from road_min_disparity_px = 2 to 64
}

TEST(ObstacleDetector, TheRoadAloneGivesNoObstacle) {
  const Camera camera;
  arm::ObstacleDetector detector(kWidth, kHeight, parameters(camera), {}, 2);
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const arm::ObstacleFrame frame = detector.run(road_scene(camera, {}, seed), no_left());
    EXPECT_TRUE(frame.road.valid);
    EXPECT_TRUE(frame.obstacles.empty()) << "seed " << seed << ": " << frame.obstacles.size() << " obstacles";
  }
}

// The sky and the far background as a matcher sees them: valid disparities of 0 .. 1.25 px above the
// horizon, so every upper row has its V-disparity peak in bin 0 or 1. With the camera pitched up
// (horizon at row 310) those 310 rows outnumber the road's 170, and from bin 0 RANSAC takes a
// near-vertical line through them (bins 0 and 1 give it a slope > 0) that the height gate then
// refuses: no road (checked with road_min_disparity_px = 0). The V-disparity from
// road_min_disparity_px = 2 leaves them out.
TEST(ObstacleDetector, ASkyOfNearZeroDisparitiesDoesNotHideTheRoad) {
  Camera camera;
  camera.pitch_rad = -0.1;
  Plane map = road_scene(camera, {{15.0, -1.0, 1.0, 1.0}}, 5);
  std::mt19937 generator(9);
  std::uniform_int_distribution<int> sky_q4(0, 20);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      if (map.at<int16_t>(u, v) == kInvalid && v < camera.horizon_row() + 2) map.at<int16_t>(u, v) = static_cast<int16_t>(sky_q4(generator));
    }
  }
  arm::ObstacleDetector detector(kWidth, kHeight, parameters(camera), {}, 2);
  const arm::ObstacleFrame frame = detector.run(map, no_left());
  ASSERT_TRUE(frame.road.valid);
  EXPECT_NEAR(frame.road.camera_height_mm, 1500, 30);
  ASSERT_EQ(frame.obstacles.size(), 1u);
  EXPECT_NEAR(frame.obstacles[0].distance_m, 15.0, 0.5);
}

TEST(ObstacleDetector, NoRoadGivesNoObstaclesAndConfidenceZero) {
  const Camera camera;
  arm::ObstacleDetector detector(kWidth, kHeight, parameters(camera), {}, 2);
  Plane wall(kWidth, kHeight, {ElementType::s16, 4}), invalid(kWidth, kHeight, {ElementType::s16, 4});
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      wall.at<int16_t>(u, v) = 20 * 16;
      invalid.at<int16_t>(u, v) = kInvalid;
    }
  }
  for (const Plane* map : {&invalid, &wall}) {
    const arm::ObstacleFrame frame = detector.run(*map, no_left());
    EXPECT_FALSE(frame.road.valid);
    EXPECT_EQ(frame.road.confidence, 0);
    EXPECT_TRUE(frame.obstacles.empty());
  }
}

TEST(ObstacleDetector, GraphSpecCarriesTheParametersFromOneStruct) {
  arm::ObstacleParameters p;
  p.feature_validation = false;
  p.focal_px = 1000;
  p.baseline_m = 0.3;
  p.grid.columns_per_cell = 6;
  p.grid.geometry.grid_rows = 96;
  p.clusters.min_cells = 3;
  p.principal_point_y_px = 200.5;
  const GraphSpec spec = arm::ObstacleDetector::graph_spec(p.for_disparity_range(0, 96));
  const NodeSpec* grid = nullptr;
  const NodeSpec* clusters = nullptr;
  const NodeSpec* road = nullptr;
  for (const NodeSpec& node : spec.nodes) {
    if (node.name == "advanced_u_disparity") grid = &node;
    if (node.name == "obstacle_clusters") clusters = &node;
    if (node.name == "road_profile") road = &node;
  }
  ASSERT_TRUE(grid && clusters && road);
  for (const char* name : {"columns_per_cell", "grid_rows", "min_disparity_px", "max_disparity_px", "exponent_k", "obstacle_weight"}) {
    EXPECT_EQ(grid->params.at(name), clusters->params.at(name)) << name;
  }
  EXPECT_EQ(grid->params.at("columns_per_cell"), 6);
  EXPECT_EQ(grid->params.at("max_disparity_px"), 96.0);
  EXPECT_EQ(clusters->params.at("min_cells"), 3);
  EXPECT_EQ(road->params.at("principal_row_px"), 200.5);
  EXPECT_TRUE(road->inputs.at("previous").delayed);
  EXPECT_EQ(clusters->outputs.at("obstacles"), "obstacles");

  arm::ObstacleParameters no_baseline = p;
  no_baseline.baseline_m = 0;
  EXPECT_THROW(arm::ObstacleDetector::graph_spec(no_baseline), std::invalid_argument);
  // With feature validation: the Harris nodes on the graph input "left", the clusters into
  // "clusters", validated against the keypoints and the mask into "obstacles".
  arm::ObstacleParameters validation = p;
  validation.feature_validation = true;
  validation.features.harris_threshold = 12345;
  validation.validation.mask_radius_px = 2;
  const GraphSpec validated = arm::ObstacleDetector::graph_spec(validation.for_disparity_range(0, 96));
  std::map<std::string, const NodeSpec*> by_name;
  for (const NodeSpec& node : validated.nodes) by_name[node.name] = &node;
  for (const char* name : {"harris_response", "harris_nms", "select_keypoints", "obstacle_feature_validation"}) {
    ASSERT_TRUE(by_name.count(name)) << name;
  }
  EXPECT_EQ(by_name["harris_response"]->inputs.at("image").buffer, "left");
  EXPECT_EQ(by_name["harris_nms"]->params.at("threshold"), 12345);
  EXPECT_EQ(by_name["obstacle_clusters"]->outputs.at("obstacles"), "clusters");
  EXPECT_EQ(by_name["obstacle_feature_validation"]->inputs.at("mask").buffer, "mask");
  EXPECT_EQ(by_name["obstacle_feature_validation"]->params.at("mask_radius_px"), 2);
  EXPECT_EQ(by_name["obstacle_feature_validation"]->outputs.at("validated"), "obstacles");
  // Tracking off (the default): no tracker, no track state, nothing delayed but the road.
  EXPECT_FALSE(arm::ObstacleParameters{}.tracking);
  for (const GraphSpec* untracked : {&spec, &validated}) {
    for (const NodeSpec& node : untracked->nodes) {
      EXPECT_NE(node.task, "obstacle_tracker") << node.name;
      for (const auto& [port, input] : node.inputs) EXPECT_TRUE(!input.delayed || input.buffer == "road") << node.name << "." << port;
    }
    EXPECT_EQ(std::count(untracked->outputs.begin(), untracked->outputs.end(), "tracks"), 0);
  }
}

// With tracking: obstacle_tracker after validation (or after the clusters without it) reads the
// validated records and its own state over a delayed edge, writes "obstacles" (tracked) and "tracks";
// every tracker setting reaches the node from ObstacleParameters::tracking_settings.
TEST(ObstacleDetector, GraphSpecWithTrackingHasTheTrackerOnADelayedEdge) {
  arm::ObstacleParameters p;
  p.focal_px = 1000;
  p.baseline_m = 0.3;
  p.tracking = true;
  p.tracking_settings.frame_period_s = 0.1;
  p.tracking_settings.min_hits_for_velocity = 2;
  p.tracking_settings.max_tracks = 17;
  for (const bool validation : {true, false}) {
    SCOPED_TRACE(validation ? "with feature validation" : "without feature validation");
    p.feature_validation = validation;
    const GraphSpec spec = arm::ObstacleDetector::graph_spec(p.for_disparity_range(0, 96));
    std::map<std::string, const NodeSpec*> by_name;
    for (const NodeSpec& node : spec.nodes) by_name[node.name] = &node;
    ASSERT_TRUE(by_name.count("obstacle_tracker"));
    const NodeSpec& tracker = *by_name["obstacle_tracker"];
    EXPECT_EQ(tracker.task, "obstacle_tracker");
    EXPECT_EQ(tracker.inputs.at("obstacles").buffer, "validated");
    EXPECT_FALSE(tracker.inputs.at("obstacles").delayed);
    EXPECT_EQ(tracker.inputs.at("previous_tracks").buffer, "tracks");
    EXPECT_TRUE(tracker.inputs.at("previous_tracks").delayed);
    EXPECT_EQ(tracker.outputs.at("tracked"), "obstacles");
    EXPECT_EQ(tracker.outputs.at("tracks"), "tracks");
    const std::string producer = validation ? "obstacle_feature_validation" : "obstacle_clusters";
    const std::string port = validation ? "validated" : "obstacles";
    EXPECT_EQ(by_name[producer]->outputs.at(port), "validated");
    // The tracker is the only writer of "obstacles".
    int writers = 0;
    for (const NodeSpec& node : spec.nodes) {
      for (const auto& [name, buffer] : node.outputs) writers += buffer == "obstacles" ? 1 : 0;
    }
    EXPECT_EQ(writers, 1);
    EXPECT_EQ(tracker.params.at("frame_period_s"), 0.1);
    EXPECT_EQ(tracker.params.at("min_hits_for_velocity"), 2);
    EXPECT_EQ(tracker.params.at("max_tracks"), 17);
    EXPECT_EQ(tracker.params.at("focal_px"), 1000.0);
    EXPECT_EQ(tracker.params.at("baseline_m"), 0.3);
    EXPECT_EQ(std::count(spec.outputs.begin(), spec.outputs.end(), "tracks"), 1);
  }
  // The defaults are the task's: the graph from default settings verifies and runs (below), and a
  // default-constructed TrackerSettings is what the task falls back to (arm/tasks/obstacle_tracker.cpp).
  const arm::TrackerSettings defaults;
  EXPECT_DOUBLE_EQ(defaults.frame_period_s, 1.0 / 30.0);
  EXPECT_EQ(defaults.min_hits_for_velocity, 3);
}

// A box driving towards the camera, 1 m closer every 0.1 s (-10 m/s in z): one track from the first
// frame on, its age counting frames, and once it has min_hits_for_velocity (3) measurements a z
// velocity near -10 m/s. Tolerance: the filter starts a track at zero velocity with
// sigma = initial_speed_sigma_mps = 10 m/s and weighs measurements with sigma_z = z^2 sigma_d / (f B)
// = 0.48 m at 20 m (f 700 px, B 0.30 m, sigma_d 0.25 px); with exact measurements the 2-state filter
// (x decouples for a box straight ahead) gives -9.16 m/s after 3 and -9.68 m/s after 4 (the
// predict/update equations of docs/obstacles.md iterated by hand in z alone): the prior's pull plus
// the map's centimetre distance errors stay within 1.5 m/s at frame 2 and 1.0 m/s at frame 3 (the
// filter's own velocity sigma there: 2.9 and 1.8 m/s); x stays within 0.5 m/s.
TEST(ObstacleDetector, TrackingFollowsAnApproachingBox) {
  const Camera camera;
  arm::ObstacleParameters p = parameters(camera);
  p.tracking = true;
  p.tracking_settings.frame_period_s = 0.1;
  arm::ObstacleDetector detector(kWidth, kHeight, p, {}, 2);
  int track_id = 0;
  for (int frame_index = 0; frame_index < 4; ++frame_index) {
    SCOPED_TRACE("frame " + std::to_string(frame_index));
    const double depth_m = 20.0 - frame_index;
    const arm::ObstacleFrame frame = detector.run(road_scene(camera, {{depth_m, -0.5, 1.0, 1.0}}, 11 + frame_index), no_left());
    ASSERT_EQ(frame.obstacles.size(), 1u);
    const arm::Obstacle& box = frame.obstacles[0];
    EXPECT_NEAR(box.distance_m, depth_m, 0.03 * depth_m);
    EXPECT_GE(box.track_id, 1);
    if (frame_index == 0) track_id = box.track_id;
    EXPECT_EQ(box.track_id, track_id);
    EXPECT_EQ(box.track_age_frames, frame_index + 1);
    if (frame_index < 2) {
      // Fewer than min_hits_for_velocity measurements: no velocity yet.
      EXPECT_EQ(box.velocity_mps[2], 0.0);
    } else {
      EXPECT_NEAR(box.velocity_mps[2], -10.0, frame_index == 2 ? 1.5 : 1.0);
      EXPECT_NEAR(box.velocity_mps[0], 0.0, 0.5);
    }
    EXPECT_EQ(box.velocity_mps[1], 0.0);  // ground-plane model
  }
}

}  // namespace
}  // namespace lpstereo
