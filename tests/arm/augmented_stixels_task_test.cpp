// ARM task augmented_stixels (arm/tasks/augmented_stixels.cpp): a hand-built frame over a flat
// terrain record (every control height 0: the clamped B-spline is 0 everywhere, partition of unity)
// seen by a level camera 1.65 m up: a box 0.3-1.0 m high at 5 m, a sign hanging 1.5-1.8 m above the
// ground at 7 m, ground points, points beyond the terrain area and pixels without a point. The
// record's counts are the scene's, the two obstacles keep their heights (the sign's free space
// under it), the counted work is the documented closed form with the library's own count taken from
// the same call; an unknown terrain gives an empty frame; the parameters, shapes and records it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/local_ground.h"
#include "arm/obstacles3d/obstacle_candidates.h"
#include "arm/point_cloud.h"
#include "arm/tasks/stixel_record.h"
#include "arm/tasks/terrain_record.h"
#include "arm/terrain/terrain_model.h"
#include "dag/arm_task.h"
#include "kernels/disparity_to_points.h"

namespace lpstereo {
namespace {

namespace o3 = arm::obstacles3d;

constexpr int kWidth = 40, kHeight = 30;
constexpr int kControlForward = 8, kControlLateral = 6;
constexpr double kFocalPx = 200.0, kBaselineM = 0.3, kCameraHeightM = 1.65;

const ArmTaskDescriptor& stixel_task() {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("augmented_stixels");
  if (task == nullptr) throw std::runtime_error("ARM task 'augmented_stixels' is not registered");
  return *task;
}

// A 10 m x 8 m area of 0.5 m cells, 8 x 6 control points of degree 3.
nlohmann::json base_params() {
  return {{"forward_min_m", 0.0},  {"forward_max_m", 10.0},   {"lateral_min_m", -4.0},        {"lateral_max_m", 4.0},
          {"cell_m", 0.5},         {"control_forward", 8},    {"control_lateral", 6},         {"focal_px", kFocalPx},
          {"baseline_m", kBaselineM}, {"u0_px", 19.5},        {"camera_height_m", kCameraHeightM}, {"sample_step", 1}};
}

Plane terrain_record(bool known) {
  Plane record(arm::kTerrainHeaderWords + kControlForward * kControlLateral, 1, {ElementType::s32, 0});
  int32_t* words = record.row<int32_t>(0);
  for (int w = 0; w < record.width(); ++w) words[w] = 0;
  words[arm::kTerrainDegreeForward] = 3;
  words[arm::kTerrainDegreeLateral] = 3;
  words[arm::kTerrainCellMm] = 500;
  if (known) {
    words[arm::kTerrainKnown] = 1;
    words[arm::kTerrainControlForward] = kControlForward;
    words[arm::kTerrainControlLateral] = kControlLateral;
  }
  return record;
}

struct Scene {
  Plane x{kWidth, kHeight, {ElementType::s32, 0}}, y{kWidth, kHeight, {ElementType::s32, 0}}, z{kWidth, kHeight, {ElementType::s32, 0}};
  int candidates = 0, valid = 0, outside = 0;
};

void put(Scene& scene, int u, int v, double x_m, double height_m, double z_m) {
  scene.x.at<int32_t>(u, v) = static_cast<int32_t>(std::lround(1000 * x_m));
  scene.y.at<int32_t>(u, v) = static_cast<int32_t>(std::lround(1000 * (kCameraHeightM - height_m)));  // y down, camera 1.65 m up
  scene.z.at<int32_t>(u, v) = static_cast<int32_t>(std::lround(1000 * z_m));
}

// Rows 0-9: the box (columns 0-19: x 0 .. 0.38 m at z 5 m, heights 0.3 .. 1.0 m) and the sign
// (columns 20-39: x -1.2 .. -0.82 m at z 7 m, heights 1.5 .. 1.8 m); rows 10-19 the ground (height
// 0); rows 20-24 points 15 m ahead, beyond the 10 m area; rows 25-29 no point.
Scene make_scene() {
  Scene scene;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      if (v < 10) {
        if (u < 20) {
          put(scene, u, v, 0.02 * u, 0.3 + 0.7 * v / 9.0, 5.0);
        } else {
          put(scene, u, v, -1.2 + 0.02 * (u - 20), 1.5 + 0.3 * v / 9.0, 7.0);
        }
        ++scene.candidates, ++scene.valid;
      } else if (v < 20) {
        put(scene, u, v, -2.0 + 0.1 * u, 0.0, 2.0 + 0.3 * (v - 10));
        ++scene.valid;
      } else if (v < 25) {
        put(scene, u, v, 0.1 * (u - 20), 0.0, 15.0);
        ++scene.valid, ++scene.outside;
      } else {
        scene.x.at<int32_t>(u, v) = scene.y.at<int32_t>(u, v) = scene.z.at<int32_t>(u, v) = kernels::kNoPointMm;
      }
    }
  }
  return scene;
}

struct TaskRun {
  Plane stixels, obstacles;
  ArmWork work;
};

TaskRun run_task(const Scene& scene, const Plane& record, const nlohmann::json& params) {
  const ArmTaskDescriptor& task = stixel_task();
  const PreparedKernel prepared = task.prepare(params, {{kWidth, kHeight}, {kWidth, kHeight}, {kWidth, kHeight}, {record.width(), 1}});
  TaskRun result{Plane(prepared.output_shapes[0].width, prepared.output_shapes[0].height, {ElementType::s32, 0}),
                 Plane(prepared.output_shapes[1].width, prepared.output_shapes[1].height, {ElementType::s32, 0}),
                 {}};
  ArmTaskArgs args{{&scene.x, &scene.y, &scene.z, &record}, {&result.stixels, &result.obstacles}, prepared.params.get(), &result.work};
  task.run(args);
  return result;
}

TEST(AugmentedStixelsTask, BoxAndHangingSignOverFlatTerrain) {
  const Scene scene = make_scene();
  const Plane record = terrain_record(true);
  const TaskRun run = run_task(scene, record, base_params());
  ASSERT_EQ(run.stixels.width(), arm::kStixelWords);
  ASSERT_EQ(run.stixels.height(), 1 + 4096);
  ASSERT_EQ(run.obstacles.width(), arm::kObstacle3dWords);
  const int32_t* header = run.stixels.row<const int32_t>(0);
  EXPECT_EQ(header[arm::kStixelHeaderTerrainKnown], 1);
  EXPECT_EQ(header[arm::kStixelHeaderSampledPixels], kWidth * kHeight);
  EXPECT_EQ(header[arm::kStixelHeaderValidPoints], scene.valid);
  EXPECT_EQ(header[arm::kStixelHeaderOutsidePoints], scene.outside);
  EXPECT_EQ(header[arm::kStixelHeaderCandidatePoints], scene.candidates);
  ASSERT_GT(header[arm::kStixelHeaderWritten], 0);
  EXPECT_EQ(header[arm::kStixelHeaderWritten], header[arm::kStixelHeaderTotal]);

  // Every stixel is the box's (angle >= 0, range ~5 m, 0.3 .. 1.0 m) or the sign's (angle < 0,
  // range ~7.1 m, 1.5 .. 1.8 m: free below 1.5 m); heights within 1 cm (mm rounding of the input).
  int box_stixels = 0, sign_stixels = 0;
  for (int s = 1; s <= header[arm::kStixelHeaderWritten]; ++s) {
    const int32_t* row = run.stixels.row<const int32_t>(s);
    EXPECT_GE(row[arm::kStixelPointCount], 3);
    EXPECT_LE(row[arm::kStixelAngleMinUrad], row[arm::kStixelAngleMaxUrad]);
    if (row[arm::kStixelAngleMaxUrad] > 0) {
      ++box_stixels;
      EXPECT_NEAR(row[arm::kStixelMeanRangeMm], 5000, 60) << s;
      EXPECT_GE(row[arm::kStixelMinHeightMm], 290) << s;
      EXPECT_LE(row[arm::kStixelMaxHeightMm], 1010) << s;
    } else {
      ++sign_stixels;
      EXPECT_NEAR(row[arm::kStixelMeanRangeMm], 7075, 60) << s;
      EXPECT_GE(row[arm::kStixelMinHeightMm], 1490) << s;
      EXPECT_LE(row[arm::kStixelMaxHeightMm], 1810) << s;
    }
    EXPECT_GE(row[arm::kStixelCluster], 0);
  }
  EXPECT_GT(box_stixels, 0);
  EXPECT_GT(sign_stixels, 0);

  // Two obstacles: the box from 0.3 to 1.0 m, the sign from 1.5 to 1.8 m above the terrain. The
  // lower edge (augmented_stixels.h, step 3) from a stixel's points, whose heights are the scene's
  // 10 rows (step d) in equal numbers: p_10 = the second row, lo + d, the median the sixth,
  // lo + 5 d, so the extrapolated edge p_10 - 0.1 / 0.4 (p_50 - p_10) = lo; plus the fattening
  // term 1.5 px x range / f: 1.5 x 5 m / 200 px = 37.5 mm for the box, 1.5 x 7.075 m / 200 px =
  // 53 mm for the sign (ranges as checked above).
  constexpr double kBoxLowerEdgeMm = 300 + 1.5 * 5000 / kFocalPx, kSignLowerEdgeMm = 1500 + 1.5 * 7075 / kFocalPx;
  const int32_t* obstacle_header = run.obstacles.row<const int32_t>(0);
  ASSERT_EQ(obstacle_header[0], 2);
  EXPECT_EQ(obstacle_header[1], 2);
  EXPECT_EQ(header[arm::kStixelHeaderObstacles], 2);
  bool saw_box = false, saw_sign = false;
  for (int o = 1; o <= 2; ++o) {
    const int32_t* row = run.obstacles.row<const int32_t>(o);
    if (row[arm::kObstacle3dPositionXMm] > 0) {
      saw_box = true;
      EXPECT_NEAR(row[arm::kObstacle3dMinHeightMm], kBoxLowerEdgeMm, 10);
      EXPECT_NEAR(row[arm::kObstacle3dMaxHeightMm], 1000, 40);
      EXPECT_NEAR(row[arm::kObstacle3dPositionZMm], 5000, 100);
    } else {
      saw_sign = true;
      EXPECT_NEAR(row[arm::kObstacle3dMinHeightMm], kSignLowerEdgeMm, 10);
      EXPECT_NEAR(row[arm::kObstacle3dMaxHeightMm], 1800, 40);
      EXPECT_NEAR(row[arm::kObstacle3dPositionZMm], 7000, 100);
    }
  }
  EXPECT_TRUE(saw_box);
  EXPECT_TRUE(saw_sign);

  // Counted work: the header comment's closed form; the stixels' own count from the library on the
  // same candidates (built here from the scene: the camera point, its vehicle point, the height).
  arm::CameraMount mount;
  mount.position_m = Eigen::Vector3d(0, 0, kCameraHeightM);
  const arm::CameraToVehicle to_vehicle(mount);
  std::vector<o3::ObstaclePoint> candidates;
  for (int v = 0; v < 10; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      o3::ObstaclePoint point;
      const Eigen::Vector3d camera_m(scene.x.at<int32_t>(u, v) * 1e-3, scene.y.at<int32_t>(u, v) * 1e-3, scene.z.at<int32_t>(u, v) * 1e-3);
      const Eigen::Vector3d vehicle_m = to_vehicle.apply(camera_m);
      point.camera_m = camera_m.cast<float>();
      point.vehicle_m = vehicle_m.cast<float>();
      point.height_above_ground_m = static_cast<float>(vehicle_m.z());  // the surface is 0
      point.disparity_px = static_cast<float>(kFocalPx * kBaselineM / camera_m.z());
      point.u_px = static_cast<uint16_t>(u);
      point.v_px = static_cast<uint16_t>(v);
      candidates.push_back(point);
    }
  }
  o3::AugmentedStixelParameters parameters;
  parameters.grid = o3::OccupancyGridParameters::defaults(o3::GridKind::polar, kWidth);
  parameters.grid.error_model.focal_px = kFocalPx;
  parameters.grid.error_model.baseline_m = kBaselineM;
  parameters.grid.principal_u_px = 19.5;
  parameters.grid.vehicle_from_camera = to_vehicle.vehicle_from_camera();
  o3::AugmentedStixels stixels(parameters);
  stixels.update(candidates, o3::EgoMotion{});
  EXPECT_EQ(static_cast<int>(stixels.stixels().size()), header[arm::kStixelHeaderTotal]);
  const uint64_t sampled = kWidth * kHeight, valid = static_cast<uint64_t>(scene.valid);
  const uint64_t inside = valid - static_cast<uint64_t>(scene.outside), count = static_cast<uint64_t>(scene.candidates);
  const uint64_t stixel_rows = static_cast<uint64_t>(header[arm::kStixelHeaderWritten]);
  // S is evaluated for the box and sign points only: the ground points (z = 0) lie 0.2 m below the
  // threshold over a surface whose control heights are all 0, which the bound decides. Cubic in
  // both axes: 6 * 3 * 4 twice + 2 * 4 * 4 + 8 = 184 ops per evaluated point.
  const uint64_t evaluated = count;
  EXPECT_EQ(run.work.scalar_ops, 64 + 3 * sampled + 15 * valid + 24 * inside + 184 * evaluated + 16 * count + stixels.work().scalar_ops + 16 * stixel_rows + 16 * 2);
  EXPECT_EQ(run.work.memory_bytes, sizeof(o3::ObstaclePoint) * count + stixels.work().memory_bytes + 4ull * arm::kStixelWords * stixel_rows +
                                       4ull * arm::kObstacle3dWords * 2 + 12ull * kWidth * kHeight + 4ull * static_cast<uint64_t>(record.width()) +
                                       4ull * arm::kStixelWords + 4ull * arm::kObstacle3dWords);
}

// local_ground 1 (arm/obstacles3d/local_ground.h): a sign 1.5-1.8 m up at 7 m over road points seen
// around it, with a terrain record 0.12 m above that road (every control height 120 mm). Without the
// local ground the sign is measured from the record's surface, 0.12 m low; with it, from the road's
// median, 0.12 m under the surface: its true heights. The counted work grows by LocalGround's own
// count on the same candidates and points (with the heights the classification evaluated), plus 32
// bytes per point kept for its pass.
TEST(AugmentedStixelsTask, TheLocalGroundMeasuresTheSignFromTheRoadUnderALiftedSurface) {
  Scene scene;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      if (v < 10) {
        put(scene, u, v, -1.2 + 0.02 * u, 1.5 + 0.3 * v / 9.0, 7.0);  // the sign, 0.8 m wide
      } else if (v < 20) {
        put(scene, u, v, -1.6 + 0.04 * u, 0.0, 6.3 + 0.15 * (v - 10));  // the road at 6.3-7.65 m
      } else {
        scene.x.at<int32_t>(u, v) = scene.y.at<int32_t>(u, v) = scene.z.at<int32_t>(u, v) = kernels::kNoPointMm;
      }
    }
  }
  Plane record = terrain_record(true);
  for (int w = arm::kTerrainHeaderWords; w < record.width(); ++w) record.row<int32_t>(0)[w] = 120;
  nlohmann::json params = base_params();
  const TaskRun off = run_task(scene, record, params);
  params["local_ground"] = 1;
  const TaskRun on = run_task(scene, record, params);
  const auto sign_lower_edge_mm = [](const TaskRun& run) {
    const int32_t* header = run.obstacles.row<const int32_t>(0);
    EXPECT_EQ(header[0], 1);
    return header[0] >= 1 ? run.obstacles.row<const int32_t>(1)[arm::kObstacle3dMinHeightMm] : -1;
  };
  constexpr double kSignLowerEdgeMm = 1500 + 1.5 * 7000 / kFocalPx;  // the fattening term as above, at ~7 m
  EXPECT_NEAR(sign_lower_edge_mm(on), kSignLowerEdgeMm, 15);
  EXPECT_NEAR(sign_lower_edge_mm(off), kSignLowerEdgeMm - 120, 15);
  EXPECT_EQ(on.stixels.row<const int32_t>(0)[arm::kStixelHeaderCandidatePoints], 10 * kWidth);

  // The work: LocalGround on the task's candidates (built from the scene as the task builds them)
  // and every point over the surface.
  arm::CameraMount mount;
  mount.position_m = Eigen::Vector3d(0, 0, kCameraHeightM);
  const arm::CameraToVehicle to_vehicle(mount);
  arm::terrain::TerrainGridSpec grid;
  grid.forward_max_m = 10.0;
  grid.lateral_min_m = -4.0;
  grid.lateral_max_m = 4.0;
  arm::terrain::BsplineSurface surface;
  surface.knots_forward_m = arm::terrain::clamped_uniform_knots(kControlForward, 3, 0.0, 10.0);
  surface.knots_lateral_m = arm::terrain::clamped_uniform_knots(kControlLateral, 3, -4.0, 4.0);
  surface.control_z_m = Eigen::MatrixXd::Constant(kControlForward, kControlLateral, 0.12);
  surface.forward_max_m = 10.0;
  surface.lateral_min_m = -4.0;
  surface.lateral_max_m = 4.0;
  std::vector<o3::ObstaclePoint> candidates;
  std::vector<Eigen::Vector3d> inside;
  std::vector<double> inside_heights_m;  // z - S where the classification evaluated it
  const o3::CandidateTest test(surface, 0.2);
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const Eigen::Vector3d camera_m(scene.x.at<int32_t>(u, v) * 1e-3, scene.y.at<int32_t>(u, v) * 1e-3, scene.z.at<int32_t>(u, v) * 1e-3);
      const Eigen::Vector3d vehicle_m = to_vehicle.apply(camera_m);
      double height_m = 0;
      bool evaluated = false;
      ASSERT_NE(test.classify(vehicle_m, &height_m, &evaluated), o3::CandidateTest::Class::outside) << u << ", " << v;
      inside.push_back(vehicle_m);
      inside_heights_m.push_back(evaluated ? height_m : std::numeric_limits<double>::quiet_NaN());
      if (v >= 10) continue;
      o3::ObstaclePoint point;
      point.vehicle_m = vehicle_m.cast<float>();
      candidates.push_back(point);
    }
  }
  o3::LocalGround local_ground(grid, surface, 0.2, o3::LocalGroundParameters{});
  local_ground.mark_candidates(candidates);
  for (size_t k = 0; k < inside.size(); ++k) local_ground.add_point(inside[k], 0, inside_heights_m[k]);
  EXPECT_EQ(local_ground.apply(candidates), 3);  // the sign spans vehicle y 0.42 .. 1.2 m (left): three lateral cells at x 7.0
  EXPECT_EQ(on.work.scalar_ops, off.work.scalar_ops + local_ground.work().scalar_ops);
  EXPECT_EQ(on.work.memory_bytes,
            off.work.memory_bytes + local_ground.work().memory_bytes + (sizeof(Eigen::Vector3d) + sizeof(double)) * inside.size());
}

TEST(AugmentedStixelsTask, SampleStepReadsEveryNthRowAndColumn) {
  const Scene scene = make_scene();
  nlohmann::json params = base_params();
  params["sample_step"] = 3;
  const TaskRun run = run_task(scene, terrain_record(true), params);
  const int32_t* header = run.stixels.row<const int32_t>(0);
  // Rows 0, 3, 6, 9 of the box and sign (14 columns of 40: 0, 3, ..., 39).
  EXPECT_EQ(header[arm::kStixelHeaderSampledPixels], 14 * 10);
  EXPECT_EQ(header[arm::kStixelHeaderCandidatePoints], 14 * 4);
}

TEST(AugmentedStixelsTask, UnknownTerrainGivesAnEmptyFrame) {
  const Scene scene = make_scene();
  const Plane record = terrain_record(false);
  const TaskRun run = run_task(scene, record, base_params());
  const int32_t* header = run.stixels.row<const int32_t>(0);
  EXPECT_EQ(header[arm::kStixelHeaderTerrainKnown], 0);
  EXPECT_EQ(header[arm::kStixelHeaderWritten], 0);
  EXPECT_EQ(header[arm::kStixelHeaderCandidatePoints], 0);
  EXPECT_EQ(run.obstacles.row<const int32_t>(0)[0], 0);
  EXPECT_EQ(run.work.scalar_ops, 64u);
  EXPECT_EQ(run.work.memory_bytes, 12ull * kWidth * kHeight + 4ull * static_cast<uint64_t>(record.width()) + 4ull * arm::kStixelWords +
                                       4ull * arm::kObstacle3dWords);
}

void expect_prepare_error(const nlohmann::json& params, const std::vector<PlaneShape>& shapes, const std::vector<std::string>& fragments) {
  try {
    stixel_task().prepare(params, shapes);
    ADD_FAILURE() << "prepare accepted " << params.dump();
  } catch (const KernelError& error) {
    for (const std::string& fragment : fragments) EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos) << error.what();
  }
}

TEST(AugmentedStixelsTask, PrepareRefusesBadParametersAndShapes) {
  const int record_words = arm::kTerrainHeaderWords + kControlForward * kControlLateral;
  const std::vector<PlaneShape> shapes = {{kWidth, kHeight}, {kWidth, kHeight}, {kWidth, kHeight}, {record_words, 1}};
  EXPECT_NO_THROW(stixel_task().prepare(base_params(), shapes));
  expect_prepare_error(base_params(), {{kWidth, kHeight}, {kWidth, kHeight}, {kWidth, kHeight}}, {"inputs", "expected 4", "got 3"});
  expect_prepare_error(base_params(), {{kWidth, kHeight}, {kWidth, kHeight + 1}, {kWidth, kHeight}, {record_words, 1}},
                       {"'y'", "40x30", "40x31"});
  expect_prepare_error(base_params(), {{kWidth, kHeight}, {kWidth, kHeight}, {kWidth, kHeight}, {record_words + 1, 1}},
                       {"'terrain'", std::to_string(record_words) + "x1", std::to_string(record_words + 1) + "x1"});
  nlohmann::json no_focal = base_params();
  no_focal.erase("focal_px");
  expect_prepare_error(no_focal, shapes, {"focal_px", "required", "got none"});
  nlohmann::json step = base_params();
  step["sample_step"] = 0;
  expect_prepare_error(step, shapes, {"sample_step"});
  nlohmann::json points = base_params();
  points["min_points"] = 0;
  expect_prepare_error(points, shapes, {"min_points"});
  nlohmann::json gap = base_params();
  gap["max_height_gap_m"] = -1.0;
  expect_prepare_error(gap, shapes, {"max_height_gap_m"});
  nlohmann::json height = base_params();
  height["obstacle_height_m"] = 0.0;
  expect_prepare_error(height, shapes, {"obstacle_height_m"});
  nlohmann::json area = base_params();
  area["forward_max_m"] = -1.0;
  expect_prepare_error(area, shapes, {"grid parameters"});
  nlohmann::json local_ground = base_params();
  local_ground["local_ground"] = 2;
  expect_prepare_error(local_ground, shapes, {"local_ground"});
  local_ground = base_params();
  local_ground["local_ground_reach_cells"] = 9;
  expect_prepare_error(local_ground, shapes, {"local_ground_reach_cells"});
  nlohmann::json unknown = base_params();
  unknown["voxel_m"] = 0.25;
  expect_prepare_error(unknown, shapes, {"voxel_m"});
}

TEST(AugmentedStixelsTask, RunRefusesATerrainRecordOfAnotherSurface) {
  const Scene scene = make_scene();
  Plane record = terrain_record(true);
  record.row<int32_t>(0)[arm::kTerrainDegreeForward] = 2;
  try {
    run_task(scene, record, base_params());
    ADD_FAILURE() << "run accepted a degree-2 record";
  } catch (const KernelError& error) {
    const std::string text = error.what();
    EXPECT_NE(text.find("degree_forward"), std::string::npos) << text;
    EXPECT_NE(text.find("expected 3"), std::string::npos) << text;
    EXPECT_NE(text.find("got 2"), std::string::npos) << text;
  }
}

// CandidateTest (arm/obstacles3d/obstacle_candidates.h) against terrain::classify_points on a
// bumpy surface (random control heights within +-0.5 m) and random points in and around its area,
// within 0.6 m of the surface: the same class for every point, the candidates' height z - S
// exactly, and the bound deciding some points without evaluating S.
TEST(CandidateTest, GivesClassifyPointsClassesOnABumpySurface) {
  namespace terrain = arm::terrain;
  std::mt19937 random(11);
  std::uniform_real_distribution<double> control(-0.5, 0.5), forward(-1.0, 11.0), lateral(-5.0, 5.0), offset(-0.6, 0.6);
  terrain::TerrainEstimate estimate;
  estimate.known = true;
  terrain::BsplineSurface& surface = estimate.surface;
  surface.forward_min_m = 0, surface.forward_max_m = 10, surface.lateral_min_m = -4, surface.lateral_max_m = 4;
  surface.knots_forward_m = terrain::clamped_uniform_knots(8, 3, 0.0, 10.0);
  surface.knots_lateral_m = terrain::clamped_uniform_knots(6, 3, -4.0, 4.0);
  surface.control_z_m.resize(8, 6);
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 6; ++j) surface.control_z_m(i, j) = control(random);
  }
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < 20000; ++k) {
    const double x = forward(random), y = lateral(random);
    const double ground = surface.contains(x, y) ? surface.height_m(x, y) : 0.0;
    points.emplace_back(x, y, ground + offset(random));
  }
  const std::vector<terrain::PointClass> expected = terrain::classify_points(points, estimate, 0.2);
  const o3::CandidateTest test(surface, 0.2);
  int skipped = 0, candidates = 0, outside = 0;
  for (size_t k = 0; k < points.size(); ++k) {
    double height_m = -1;
    bool evaluated = true;
    const o3::CandidateTest::Class actual = test.classify(points[k], &height_m, &evaluated);
    switch (expected[k]) {
      case terrain::PointClass::outside: EXPECT_EQ(actual, o3::CandidateTest::Class::outside) << k; ++outside; break;
      case terrain::PointClass::terrain: EXPECT_EQ(actual, o3::CandidateTest::Class::terrain) << k; break;
      case terrain::PointClass::obstacle:
        EXPECT_EQ(actual, o3::CandidateTest::Class::candidate) << k;
        EXPECT_EQ(height_m, points[k].z() - surface.height_m(points[k].x(), points[k].y())) << k;
        ++candidates;
        break;
    }
    skipped += expected[k] != terrain::PointClass::outside && !evaluated;
  }
  EXPECT_GT(outside, 0);
  EXPECT_GT(candidates, 1000);
  EXPECT_GT(skipped, 1000);
}

}  // namespace
}  // namespace lpstereo
