// extract_obstacle_candidates (arm/obstacles3d/obstacle_candidates.h) on a hand-made disparity map:
// a level camera 1.5 m above a flat road (row v below the horizon has d = B (v - v0) / H) with a box
// 10 m ahead (d = 6 px) rising from the road. The candidates are exactly the points that
// terrain::classify_points calls obstacle against the returned fit (the CandidateTest shortcut
// changes no class), each with z - S as its height; 1, 2, 3 and 7 threads give the same result field
// for field; a thread count out of range is refused by name; with the occlusion-aware sampling the
// cells of a far sign seen over the box are marked as upper bounds and no road cell is; the road read
// too near under a hanging board samples the terrain but gives no candidates; the cells nearer than
// the road seen in the image's last row are upper bounds, so a board there keeps its height.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/disparity_engine.h"
#include "arm/obstacles3d/obstacle_candidates.h"
#include "arm/point_cloud.h"
#include "arm/terrain/terrain_model.h"
#include "kernels/disparity_to_points.h"

namespace lpstereo {
namespace {

namespace o3 = arm::obstacles3d;

constexpr int kWidth = 160, kHeight = 120;
constexpr double kFocalPx = 200, kBaselineM = 0.3, kCameraHeightM = 1.5;
constexpr double kU0 = (kWidth - 1) / 2.0, kV0 = (kHeight - 1) / 2.0;
constexpr int16_t kInvalidQ4 = -16;  // min_disparity 0
const arm::TriangulationParameters kView{kBaselineM, kFocalPx, kU0, kV0, 0, 64, 0};

struct Frame {
  Plane disparity{kWidth, kHeight, {ElementType::s16, 4}};
  Plane grey{kWidth, kHeight, {ElementType::u8}};
  arm::CameraPoints camera;
  arm::CameraToVehicle to_vehicle{[] {
    arm::CameraMount mount;
    mount.position_m = Eigen::Vector3d(0, 0, kCameraHeightM);
    return mount;
  }()};
};

Frame make_frame() {
  Frame frame;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      double d_px = v > kV0 + 1 ? kBaselineM * (v - kV0) / kCameraHeightM : -1;  // the road below the horizon
      if (u >= 60 && u < 100 && v >= 40 && v < 90) d_px = 6.0;                   // the box, Z = 10 m
      frame.disparity.at<int16_t>(u, v) = d_px > 0 ? static_cast<int16_t>(std::lround(16 * d_px)) : kInvalidQ4;
      frame.grey.at<uint8_t>(u, v) = static_cast<uint8_t>((u * 7 + v * 3) % 251);
    }
  }
  frame.camera = arm::triangulate(frame.disparity, kView);
  return frame;
}

// A fronto-parallel surface over columns [u_first, u_end) and rows [v_first, v_end) at d px, the
// frame's points triangulated again.
void paint_rectangle(Frame& frame, int u_first, int u_end, int v_first, int v_end, int disparity_px) {
  for (int v = v_first; v < v_end; ++v)
    for (int u = u_first; u < u_end; ++u) frame.disparity.at<int16_t>(u, v) = static_cast<int16_t>(16 * disparity_px);
  frame.camera = arm::triangulate(frame.disparity, kView);
}

// Every valid pixel's vehicle point, in row order (the function's own conversion: mm -> float m).
std::vector<Eigen::Vector3d> frame_vehicle_points(const Frame& frame) {
  std::vector<Eigen::Vector3d> vehicle_points;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      if (frame.camera.x_mm.at<int32_t>(u, v) == kernels::kNoPointMm || frame.disparity.at<int16_t>(u, v) <= 0) continue;
      const Eigen::Vector3f camera_m(static_cast<float>(frame.camera.x_mm.at<int32_t>(u, v)) * 1e-3f,
                                     static_cast<float>(frame.camera.y_mm.at<int32_t>(u, v)) * 1e-3f,
                                     static_cast<float>(frame.camera.z_mm.at<int32_t>(u, v)) * 1e-3f);
      vehicle_points.push_back(frame.to_vehicle.apply(camera_m.cast<double>()));
    }
  }
  return vehicle_points;
}

// The fit's own heights (z - S): the local ground has a test of its own below.
o3::CandidatePoints extract(const Frame& frame, int threads) {
  o3::CandidateParameters parameters;
  parameters.threads = threads;
  parameters.local_ground_reference = false;
  return o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
}

TEST(ObstacleCandidates, AreClassifyPointsObstaclesWithTheirHeight) {
  const Frame frame = make_frame();
  const o3::CandidatePoints result = extract(frame, 2);
  ASSERT_TRUE(result.terrain.known) << result.note;
  const std::vector<Eigen::Vector3d> vehicle_points = frame_vehicle_points(frame);
  EXPECT_EQ(result.cloud_points, static_cast<int64_t>(vehicle_points.size()));
  const std::vector<arm::terrain::PointClass> classes = arm::terrain::classify_points(vehicle_points, result.terrain, 0.2);
  std::vector<Eigen::Vector3d> expected;
  int64_t outside = 0;
  for (size_t k = 0; k < classes.size(); ++k) {
    if (classes[k] == arm::terrain::PointClass::obstacle) expected.push_back(vehicle_points[k]);
    outside += classes[k] == arm::terrain::PointClass::outside;
  }
  EXPECT_EQ(result.outside_area, outside);
  ASSERT_EQ(result.points.size(), expected.size());
  ASSERT_GT(expected.size(), 500u);  // the box: 40 x 50 pixels, most of it above 0.2 m
  for (size_t k = 0; k < expected.size(); ++k) {
    const o3::ObstaclePoint& point = result.points[k];
    EXPECT_EQ(point.vehicle_m, expected[k].cast<float>()) << k;
    EXPECT_EQ(point.height_above_ground_m,
              static_cast<float>(expected[k].z() - result.terrain.surface.height_m(expected[k].x(), expected[k].y())))
        << k;
    EXPECT_EQ(point.disparity_px, 6.0f) << k;  // only the box stands above the road
    EXPECT_EQ(point.rgb[0], frame.grey.at<uint8_t>(point.u_px, point.v_px)) << k;
  }
}

// The local ground (CandidateParameters::local_ground_reference, local_ground.h): the same
// candidates, each measured from the terrain inliers around it by LocalGround over every point of
// the frame; the box's candidates stand at least as high as without it.
TEST(ObstacleCandidates, TheLocalGroundMeasuresTheSameCandidatesFromTheInliersAroundThem) {
  Frame frame = make_frame();
  paint_rectangle(frame, 20, 40, 70, 80, 5);  // a board 12 m ahead, 0.3-0.9 m up, over the road
  o3::CandidateParameters parameters;
  ASSERT_TRUE(parameters.local_ground_reference);  // the default
  parameters.local_ground_reference = false;
  const o3::CandidatePoints off =
      o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
  parameters.local_ground_reference = true;
  parameters.threads = 3;
  const o3::CandidatePoints on =
      o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
  ASSERT_TRUE(off.terrain.known && on.terrain.known) << off.note << " / " << on.note;
  EXPECT_EQ(on.terrain.surface.control_z_m, off.terrain.surface.control_z_m);
  ASSERT_EQ(on.points.size(), off.points.size());
  ASSERT_GT(on.points.size(), 500u);
  // The reference: LocalGround over every valid pixel's vehicle point.
  o3::LocalGround local_ground(parameters.grid, off.terrain.surface, parameters.obstacle_height_m, parameters.local_ground);
  std::vector<o3::ObstaclePoint> expected = off.points;
  local_ground.mark_candidates(expected);
  for (const Eigen::Vector3d& point : frame_vehicle_points(frame)) local_ground.add_point(point);
  EXPECT_EQ(on.local_ground_cells, local_ground.apply(expected));
  EXPECT_EQ(off.local_ground_cells, 0);
  EXPECT_GT(on.local_ground_cells, 0);
  for (size_t k = 0; k < on.points.size(); ++k) {
    EXPECT_EQ(on.points[k].vehicle_m, off.points[k].vehicle_m) << k;
    EXPECT_EQ(on.points[k].height_above_ground_m, expected[k].height_above_ground_m) << k;
    EXPECT_GE(on.points[k].height_above_ground_m, off.points[k].height_above_ground_m) << k;
    EXPECT_LE(on.points[k].height_above_ground_m, off.points[k].height_above_ground_m + parameters.local_ground.band_below_m) << k;
  }
}

TEST(ObstacleCandidates, ThreadCountDoesNotChangeTheResult) {
  const Frame frame = make_frame();
  const o3::CandidatePoints one = extract(frame, 1);
  ASSERT_FALSE(one.points.empty());
  // 7 threads: the bands balance the valid disparities, which all lie below row 40, so several
  // bands start on the same row and hold no rows at all.
  for (int threads : {2, 3, 7}) {
    const o3::CandidatePoints many = extract(frame, threads);
    EXPECT_EQ(many.cloud_points, one.cloud_points) << threads;
    EXPECT_EQ(many.outside_area, one.outside_area) << threads;
    EXPECT_EQ(many.terrain.surface.control_z_m, one.terrain.surface.control_z_m) << threads;
    EXPECT_EQ(many.measured_grid.point_count, one.measured_grid.point_count) << threads;
    EXPECT_EQ(many.measured_grid.state, one.measured_grid.state) << threads;
    ASSERT_EQ(many.points.size(), one.points.size()) << threads;
    for (size_t k = 0; k < one.points.size(); ++k) {
      const o3::ObstaclePoint &a = one.points[k], &b = many.points[k];
      EXPECT_TRUE(a.camera_m == b.camera_m && a.vehicle_m == b.vehicle_m && a.height_above_ground_m == b.height_above_ground_m &&
                  a.disparity_px == b.disparity_px && a.u_px == b.u_px && a.v_px == b.v_px && a.rgb == b.rgb)
          << threads << " threads, point " << k;
    }
  }
}

TEST(ObstacleCandidates, RefusesAThreadCountOutOfRange) {
  const Frame frame = make_frame();
  for (int threads : {0, 17}) {
    try {
      extract(frame, threads);
      ADD_FAILURE() << "accepted threads = " << threads;
    } catch (const std::invalid_argument& error) {
      const std::string text = error.what();
      EXPECT_NE(text.find("threads"), std::string::npos) << text;
      EXPECT_NE(text.find("[1, 16]"), std::string::npos) << text;
      EXPECT_NE(text.find("got " + std::to_string(threads)), std::string::npos) << text;
    }
  }
}

// The grid is checked before any point is built: its cells are found with the points.
TEST(ObstacleCandidates, RefusesAGridWithoutCells) {
  const Frame frame = make_frame();
  o3::CandidateParameters parameters;
  parameters.grid.cell_m = 0;
  try {
    o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
    ADD_FAILURE() << "accepted cell_m = 0";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()), "cell_m: expected > 0, got 0");
  }
}

// With the occlusion-aware sampling (grid.occlusion_upper_bounds): a far sign (d = 2 px, Z = 30 m,
// rows 20-39) seen right above the box (d = 6 px from row 40): its bottom rows lie over the box, so
// the sign's cells at 30 m, which hold nothing under the sign, are marked as upper bounds; no road
// cell is; 1 and 3 threads give the same marks.
TEST(ObstacleCandidates, OcclusionUpperBoundsMarkTheCellsOverANearerObject) {
  Frame frame = make_frame();
  paint_rectangle(frame, 60, 100, 20, 40, 2);
  o3::CandidateParameters parameters;
  parameters.grid.occlusion_upper_bounds = true;
  const auto run = [&](int threads) {
    parameters.threads = threads;
    return o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
  };
  const o3::CandidatePoints one = run(1), three = run(3);
  ASSERT_TRUE(one.terrain.known) << one.note;
  const arm::terrain::HeightGrid& grid = one.measured_grid;
  ASSERT_EQ(grid.upper_bound.rows(), grid.spec.forward_cells());
  EXPECT_EQ(three.measured_grid.upper_bound, grid.upper_bound);
  int sign_cells = 0;
  for (int i = 0; i < grid.spec.forward_cells(); ++i) {
    for (int j = 0; j < grid.spec.lateral_cells(); ++j) {
      if (grid.state(i, j) != arm::terrain::kCellMeasured) continue;
      const double x = grid.spec.cell_centre_x_m(i);
      if (x > 29 && x < 31 && grid.height_m(i, j) > 3) {  // the sign, 3.6-6.6 m up
        EXPECT_EQ(grid.upper_bound(i, j), 1) << i << " " << j;
        ++sign_cells;
      } else if (x < 9.5 || x > 10.5) {  // the road (the box stands at 10 m)
        EXPECT_EQ(grid.upper_bound(i, j), 0) << i << " " << j;
      }
    }
  }
  EXPECT_GE(sign_cells, 8);
  // A bad image test is refused by name.
  parameters.occluder.rows_below_px = 0;
  try {
    run(1);
    ADD_FAILURE() << "accepted rows_below_px = 0";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()), "rows_below_px: expected in [1, 64], got 0");
  }
}

// The far side under a nearer surface's lower edge (CandidateParameters::far_side, on by default): a board hanging
// 0.9-1.6 m up at 6 m (d = 10 px, rows 57-79, columns 20-49, beside the box) over the road, whose
// first six rows under it the matcher reads too near (the road's d plus 3.3, 2.5, 2.0, 1.6, 1.2 and
// 1.0 px, as measured under a board at 15 m in bench/obstacles3d_eval, floating seed 2 frame 12):
// points 0.25-0.7 m above the road. With the test off they are candidates; on, none is, the
// board's and the box's candidates stay the same, and the flagged points still sample the terrain
// (the same cloud, the same 2.5D grid, the same fit).
TEST(ObstacleCandidates, PointsUnderAnOverhangSampleTheTerrainButAreNoCandidates) {
  Frame frame = make_frame();
  const double ramp_px[6] = {3.3, 2.5, 2.0, 1.6, 1.2, 1.0};
  for (int u = 20; u < 50; ++u) {
    for (int v = 57; v < 80; ++v) frame.disparity.at<int16_t>(u, v) = 10 * 16;
    for (int k = 0; k < 6; ++k) {
      const int v = 80 + k;
      const double road_px = kBaselineM * (v - kV0) / kCameraHeightM;
      frame.disparity.at<int16_t>(u, v) = static_cast<int16_t>(std::lround(16 * (road_px + ramp_px[k])));
    }
  }
  frame.camera = arm::triangulate(frame.disparity, kView);
  o3::CandidateParameters parameters;
  const auto run = [&](const arm::FarSideTest& test) {
    parameters.far_side = test;
    return o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
  };
  const arm::FarSideTest by_default = parameters.far_side;
  ASSERT_GT(by_default.rows_above_px, 0);
  const o3::CandidatePoints off = run(arm::FarSideTest{.rows_above_px = 0, .columns_beside_px = 0}), on = run(by_default);
  ASSERT_TRUE(off.terrain.known && on.terrain.known) << off.note << " / " << on.note;
  const auto is_ramp = [](const o3::ObstaclePoint& point) { return point.u_px >= 20 && point.u_px < 50 && point.v_px >= 80; };
  std::vector<o3::ObstaclePoint> off_without_ramp;
  int ramp_candidates = 0;
  for (const o3::ObstaclePoint& point : off.points) {
    if (is_ramp(point)) {
      ++ramp_candidates;
    } else {
      off_without_ramp.push_back(point);
    }
  }
  EXPECT_EQ(ramp_candidates, 6 * 30);  // every ramp pixel stands above 0.2 m
  EXPECT_EQ(on.far_side, ramp_candidates);
  EXPECT_EQ(off.far_side, 0);
  for (const o3::ObstaclePoint& point : on.points) EXPECT_FALSE(is_ramp(point)) << point.u_px << "," << point.v_px;
  ASSERT_EQ(on.points.size(), off_without_ramp.size());
  for (size_t k = 0; k < on.points.size(); ++k) {
    EXPECT_EQ(on.points[k].vehicle_m, off_without_ramp[k].vehicle_m) << k;
    EXPECT_EQ(on.points[k].height_above_ground_m, off_without_ramp[k].height_above_ground_m) << k;
  }
  EXPECT_EQ(on.cloud_points, off.cloud_points);
  EXPECT_EQ(on.measured_grid.point_count, off.measured_grid.point_count);
  EXPECT_EQ(on.terrain.surface.control_z_m, off.terrain.surface.control_z_m);
  // A bad test is refused by name.
  try {
    run(arm::FarSideTest{.jump_px = -1});
    ADD_FAILURE() << "accepted jump_px = -1";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()), "jump_px: expected a finite value > 0, got -1");
  }
}

// The cells whose ground lies below the image (CandidateParameters::ground_below_view_upper_bounds,
// on by default): the camera sees the road from 1.5 x 200 / 60 = 5.0 m on (the last row's bottom
// edge, 119.5, is 60 px under v0). A board hanging 0.9-1.6 m up at 4 m (d = 15 px, rows 55-89,
// columns 60-99; row 89 is 1.5 - 29.5 x 4 / 200 = 0.91 m up) fills the cells at 4.0-4.5 m with
// nothing but itself. Marked, they are upper bounds the fit sets aside, and the board's lowest
// candidates stand 0.91 m above the surface; unmarked, they are ground samples 0.9-1.6 m high and
// the surface follows them up. A focal length that is not positive is refused by name.
TEST(ObstacleCandidates, CellsWhoseGroundIsBelowTheViewAreUpperBounds) {
  Frame frame = make_frame();
  paint_rectangle(frame, 60, 100, 55, 90, 15);
  o3::CandidateParameters parameters;
  ASSERT_TRUE(parameters.ground_below_view_upper_bounds);
  const auto board_lower_edge_m = [](const o3::CandidatePoints& result) {
    double lowest_m = 1e9;
    for (const o3::ObstaclePoint& point : result.points) {
      if (point.u_px >= 60 && point.u_px < 100 && point.v_px >= 55 && point.v_px < 90) lowest_m = std::min<double>(lowest_m, point.height_above_ground_m);
    }
    return lowest_m;
  };
  const o3::CandidatePoints marked =
      o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
  ASSERT_TRUE(marked.terrain.known) << marked.note;
  EXPECT_GE(marked.below_view_cells, 2);  // the board's 0.8 m spans two or three 0.5 m cells
  const arm::terrain::HeightGrid& grid = marked.measured_grid;
  for (int i = 0; i < grid.spec.forward_cells(); ++i) {
    for (int j = 0; j < grid.spec.lateral_cells(); ++j) {
      if (grid.state(i, j) == arm::terrain::kCellInvalid) continue;
      // Marked exactly when the cell's centre lies nearer than 5.0 m (no cell centre is within 0.25 m of it).
      EXPECT_EQ(grid.upper_bound(i, j), grid.spec.cell_centre_x_m(i) < 5.0 ? 1 : 0) << i << " " << j;
    }
  }
  EXPECT_NEAR(board_lower_edge_m(marked), 0.91, 0.05);
  parameters.ground_below_view_upper_bounds = false;
  const o3::CandidatePoints unmarked =
      o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, kView, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
  ASSERT_TRUE(unmarked.terrain.known) << unmarked.note;
  EXPECT_EQ(unmarked.below_view_cells, 0);
  EXPECT_LT(board_lower_edge_m(unmarked), 0.91 - 0.1);
  arm::TriangulationParameters no_focal = kView;
  no_focal.focal_px = 0;
  try {
    o3::extract_obstacle_candidates(frame.disparity, kInvalidQ4, frame.camera, no_focal, frame.grey, o3::ColourView{}, frame.to_vehicle, parameters);
    ADD_FAILURE() << "accepted focal_px = 0";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("view.focal_px: expected a finite focal length > 0 px"), std::string::npos) << error.what();
  }
}

// The chain's matcher and the near guard beside it (arm/obstacles3d/obstacle_candidates.h): the guard
// is the same matcher with 128 px, 64 of them at full resolution, and the half-resolution pass reaches
// the whole range; the engine accepts both.
TEST(ObstacleCandidates, TheNearGuardIsTheChainsMatcherWithAHalfResolutionPassTo128Pixels) {
  const arm::DisparityParameters chain = o3::obstacles3d_disparity_defaults();
  const arm::DisparityParameters guard = o3::obstacles3d_near_guard_disparity_parameters();
  EXPECT_FALSE(chain.multires);
  EXPECT_EQ(chain.num_disparities, 64);
  EXPECT_TRUE(guard.multires);
  EXPECT_EQ(guard.num_disparities, 128);
  EXPECT_EQ(arm::settings_text(guard).rfind(arm::settings_text(chain), 0), 0u)
      << "the guard changes the range only: " << arm::settings_text(guard);
  const arm::MultiresSplit split = arm::multires_split(guard.min_disparity, guard.num_disparities, guard.multires_far_disparities);
  EXPECT_EQ(split.num_far, chain.num_disparities);
  EXPECT_GE(2 * (split.min_near + split.num_near - 1), guard.num_disparities - 1);
  EXPECT_NO_THROW(arm::DisparityEngine(640, 480, guard));
  EXPECT_NO_THROW(arm::DisparityEngine(640, 480, chain));
}

}  // namespace
}  // namespace lpstereo
