// The voxel map (arm/obstacles3d/voxel_map.h): HSL conversion, keys, per-voxel statistics, ego-motion
// chaining, the life rule, clipping, parameter errors and the counted work.
#include "arm/obstacles3d/voxel_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "tests/arm/obstacles3d/voxel_scene.h"

namespace lpstereo::arm::obstacles3d {
namespace {

using test::add_box;
using test::make_point;

void expect_hsl(std::array<uint8_t, 3> rgb, double hue, double saturation, double lightness) {
  const Hsl hsl = hsl_from_rgb(rgb);
  EXPECT_NEAR(hsl.hue, hue, 1e-9) << int(rgb[0]) << " " << int(rgb[1]) << " " << int(rgb[2]);
  EXPECT_NEAR(hsl.saturation, saturation, 1e-9) << int(rgb[0]) << " " << int(rgb[1]) << " " << int(rgb[2]);
  EXPECT_NEAR(hsl.lightness, lightness, 1e-9) << int(rgb[0]) << " " << int(rgb[1]) << " " << int(rgb[2]);
}

TEST(VoxelMap, HslOfKnownColours) {
  // Primaries and secondaries: full saturation, lightness 1/2, hue at sixths of a turn.
  expect_hsl({255, 0, 0}, 0.0, 1.0, 0.5);
  expect_hsl({255, 255, 0}, 1.0 / 6, 1.0, 0.5);
  expect_hsl({0, 255, 0}, 2.0 / 6, 1.0, 0.5);
  expect_hsl({0, 255, 255}, 3.0 / 6, 1.0, 0.5);
  expect_hsl({0, 0, 255}, 4.0 / 6, 1.0, 0.5);
  expect_hsl({255, 0, 255}, 5.0 / 6, 1.0, 0.5);
  // Achromatic: hue and saturation 0.
  expect_hsl({0, 0, 0}, 0.0, 0.0, 0.0);
  expect_hsl({255, 255, 255}, 0.0, 0.0, 1.0);
  expect_hsl({128, 128, 128}, 0.0, 0.0, 128.0 / 255);
  // Steel blue-ish (64, 128, 192): max b, chroma 128/255, L = 128/255, S = C / (1 - |2L - 1|),
  // hue = ((r - g) / C + 4) / 6 = (-0.5 + 4) / 6 = 210 degrees.
  const double chroma = 128.0 / 255, lightness = (64.0 + 192.0) / 2 / 255;
  expect_hsl({64, 128, 192}, 210.0 / 360, chroma / (1 - std::abs(2 * lightness - 1)), lightness);
  // A red with g < b wraps below 360 degrees: (255, 0, 64): hue = ((0 - 64/255) / 1 mod 6) / 6.
  expect_hsl({255, 0, 64}, (6.0 - 64.0 / 255) / 6, 1.0, (255.0 + 0.0) / 2 / 255);
}

TEST(VoxelMap, KeysCentroidAndColourStatistics) {
  VoxelMapParameters parameters;
  parameters.voxel_size_m = 0.25;
  VoxelMap map(parameters);
  // Floor division, negative coordinates included.
  EXPECT_EQ(map.key_of(Eigen::Vector3d(10.1, -0.1, 0.3)), (VoxelKey{40, -1, 1}));
  EXPECT_EQ(map.key_of(Eigen::Vector3d(-0.25, 0.0, 0.2499)), (VoxelKey{-1, 0, 0}));
  EXPECT_TRUE(map.centre_of(VoxelKey{40, -1, 1}).isApprox(Eigen::Vector3d(10.125, -0.125, 0.375)));

  // Two points in voxel (40, 0, 2): a red and a blue; one green point alone in (41, 0, 2).
  std::vector<ObstaclePoint> points = {make_point({10.05, 0.05, 0.55}, {255, 0, 0}), make_point({10.15, 0.20, 0.70}, {0, 0, 255}),
                                       make_point({10.30, 0.10, 0.60}, {0, 255, 0})};
  const VoxelMapStatus& status = map.update(points, EgoMotion{});
  EXPECT_EQ(status.points_inserted, 3);
  EXPECT_EQ(status.voxels_created, 2);
  ASSERT_EQ(map.voxels().size(), 2u);
  const Voxel* voxel = map.find(VoxelKey{40, 0, 2});
  ASSERT_NE(voxel, nullptr);
  EXPECT_EQ(voxel->point_count, 2);
  EXPECT_TRUE(voxel->centroid_world_m().isApprox(Eigen::Vector3d(10.10, 0.125, 0.625), 1e-6));
  // RGB in [0, 1]: mean (1/2, 0, 1/2), population variance (1/4, 0, 1/4).
  EXPECT_TRUE(voxel->colour.rgb_mean().isApprox(Eigen::Vector3d(0.5, 0.0, 0.5)));
  EXPECT_NEAR(voxel->colour.rgb_variance().x(), 0.25, 1e-12);
  EXPECT_NEAR(voxel->colour.rgb_variance().y(), 0.0, 1e-12);
  EXPECT_NEAR(voxel->colour.rgb_variance().z(), 0.25, 1e-12);
  // Hue 0 and 2/3 turn (0 and 240 degrees): the circular mean is 300 degrees (5/6), the mean resultant
  // length |(1 + cos 240, sin 240)| / 2 = 1/2, so the circular variance is 1/2. S = 1, L = 1/2 for both.
  const Hsl mean = voxel->colour.hsl_mean();
  EXPECT_NEAR(mean.hue, 5.0 / 6, 1e-9);
  EXPECT_NEAR(mean.saturation, 1.0, 1e-12);
  EXPECT_NEAR(mean.lightness, 0.5, 1e-12);
  EXPECT_NEAR(voxel->colour.hsl_variance().x(), 0.5, 1e-9);
  EXPECT_NEAR(voxel->colour.hsl_variance().y(), 0.0, 1e-12);
  EXPECT_NEAR(voxel->colour.hsl_variance().z(), 0.0, 1e-12);
  // This frame's heights and camera-frame extent.
  EXPECT_NEAR(voxel->frame_min_height_m, 0.55f, 1e-6);
  EXPECT_NEAR(voxel->frame_max_height_m, 0.70f, 1e-6);
  EXPECT_NEAR(voxel->frame_mean_height_m(), 0.625, 1e-6);
  EXPECT_NEAR(voxel->frame_camera_min_m.z(), 10.05f, 1e-5);  // camera z = vehicle x for a level camera
  EXPECT_NEAR(voxel->frame_camera_max_m.x(), -0.05f, 1e-5);  // camera x = -vehicle y
  EXPECT_TRUE(map.observed_this_frame(*voxel));
}

// A world-fixed box seen from a camera that drives forward and turns: its voxels keep their keys.
TEST(VoxelMap, EgoMotionKeepsAStaticPointsVoxelFixedInTheWorld) {
  VoxelMap map;
  const Eigen::Vector3d world_point(12.1, 1.1, 0.6);
  Eigen::Isometry3d world_from_previous = Eigen::Isometry3d::Identity();
  for (int frame = 0; frame < 10; ++frame) {
    Eigen::Isometry3d world_from_current = Eigen::Isometry3d::Identity();
    world_from_current.translate(Eigen::Vector3d(0.5 * frame, 0.02 * frame * frame, 0.0));
    world_from_current.rotate(Eigen::AngleAxisd(0.03 * frame, Eigen::Vector3d::UnitZ()));
    EgoMotion ego;
    ego.available = true;
    ego.previous_from_current = world_from_previous.inverse() * world_from_current;
    const Eigen::Vector3d vehicle = world_from_current.inverse() * world_point;
    const VoxelMapStatus& status = map.update({make_point(vehicle, {200, 50, 50})}, ego);
    EXPECT_EQ(status.points_inserted, 1) << "frame " << frame;
    ASSERT_EQ(map.voxels().size(), 1u) << "frame " << frame;
    const Voxel& voxel = map.voxels().begin()->second;
    EXPECT_EQ(voxel.key, map.key_of(world_point)) << "frame " << frame;
    EXPECT_EQ(voxel.frames_observed, frame + 1);
    EXPECT_TRUE(voxel.centroid_world_m().isApprox(world_point, 1e-5)) << "frame " << frame;
    EXPECT_TRUE(map.world_from_current().isApprox(world_from_current, 1e-9));
    world_from_previous = world_from_current;
  }
}

TEST(VoxelMap, WithoutEgoMotionTheCameraIsStaticAndTheStatusSaysSo) {
  VoxelMap map;
  const std::string first = map.update({make_point({10.1, 0.1, 0.6}, {1, 2, 3})}, EgoMotion{}).text();
  EXPECT_NE(first.find("static camera assumed"), std::string::npos) << first;
  const VoxelMapStatus& status = map.update({make_point({10.1, 0.1, 0.6}, {1, 2, 3})}, EgoMotion{});
  EXPECT_FALSE(status.ego_motion_available);
  EXPECT_NE(status.text().find("static camera assumed"), std::string::npos) << status.text();
  EXPECT_TRUE(map.world_from_current().isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_EQ(map.voxels().size(), 1u);
}

TEST(VoxelMap, AVoxelInViewThatLosesItsPointsDecaysAndOneOutOfViewIsKept) {
  VoxelMapParameters parameters;
  parameters.max_unobserved_frames = 1;
  VoxelMap map(parameters);
  const Eigen::Vector3d ahead(10.1, 0.1, 0.6);   // in view
  const Eigen::Vector3d beside(1.1, 5.1, 0.6);   // atan2(5.1, 1.1) = 1.36 rad > 0.6: out of view
  map.update({make_point(ahead, {9, 9, 9}), make_point(beside, {9, 9, 9})}, EgoMotion{});
  ASSERT_EQ(map.voxels().size(), 2u);
  // One empty frame: both survive (max_unobserved_frames = 1), the one in view counts the miss.
  map.update({}, EgoMotion{});
  ASSERT_EQ(map.voxels().size(), 2u);
  EXPECT_EQ(map.find(map.key_of(ahead))->unobserved_frames, 1);
  EXPECT_EQ(map.find(map.key_of(beside))->unobserved_frames, 0);
  EXPECT_FALSE(map.observed_this_frame(*map.find(map.key_of(ahead))));
  // Second empty frame: the one in view goes.
  const VoxelMapStatus& status = map.update({}, EgoMotion{});
  EXPECT_EQ(status.voxels_removed_unobserved, 1);
  EXPECT_EQ(map.find(map.key_of(ahead)), nullptr);
  EXPECT_NE(map.find(map.key_of(beside)), nullptr);
  // Re-observed: a new voxel is created where the point comes back.
  EXPECT_EQ(map.update({make_point(ahead, {9, 9, 9})}, EgoMotion{}).voxels_created, 1);
}

TEST(VoxelMap, DefaultRuleRemovesAnEmptyVoxelInViewAtOnce) {
  VoxelMap map;
  map.update({make_point({10.1, 0.1, 0.6}, {9, 9, 9})}, EgoMotion{});
  EXPECT_EQ(map.update({make_point({20.1, 0.1, 0.6}, {9, 9, 9})}, EgoMotion{}).voxels_removed_unobserved, 1);
  EXPECT_EQ(map.voxels().size(), 1u);
}

TEST(VoxelMap, VoxelsLeavingTheBoundsAreRemoved) {
  VoxelMap map;
  map.update({make_point({1.1, 0.1, 0.6}, {9, 9, 9})}, EgoMotion{});
  EgoMotion ego;
  ego.available = true;
  ego.previous_from_current = Eigen::Translation3d(5.0, 0.0, 0.0);  // drove 5 m forward: the voxel is behind
  const VoxelMapStatus& status = map.update({}, ego);
  EXPECT_EQ(status.voxels_removed_out_of_bounds, 1);
  EXPECT_TRUE(map.voxels().empty());
}

TEST(VoxelMap, PointsBeyondTheBoundsAreClippedCountedAndReported) {
  VoxelMap map;
  std::vector<ObstaclePoint> points = {make_point({10.1, 0.1, 0.6}, {9, 9, 9}),  make_point({500.0, 0.0, 0.6}, {9, 9, 9}),
                                       make_point({10.0, -30.0, 0.6}, {9, 9, 9}), make_point({10.0, 0.0, 50.0}, {9, 9, 9}),
                                       make_point({-2.0, 0.0, 0.6}, {9, 9, 9})};
  ObstaclePoint broken = make_point({10.1, 0.1, 0.6}, {9, 9, 9});
  broken.vehicle_m.x() = std::numeric_limits<float>::quiet_NaN();
  points.push_back(broken);
  const VoxelMapStatus& status = map.update(points, EgoMotion{});
  EXPECT_EQ(status.points_in, 6);
  EXPECT_EQ(status.points_inserted, 1);
  EXPECT_EQ(status.points_clipped_out_of_bounds, 4);
  EXPECT_EQ(status.points_not_finite, 1);
  EXPECT_NE(status.text().find("4 clipped beyond the map bounds"), std::string::npos) << status.text();
}

TEST(VoxelMap, BadVoxelSizeThrowsNamingTheParameterTheRangeAndTheValue) {
  for (const double size : {0.0, -0.25, 0.6, 0.01, std::numeric_limits<double>::quiet_NaN()}) {
    VoxelMapParameters parameters;
    parameters.voxel_size_m = size;
    try {
      VoxelMap map(parameters);
      ADD_FAILURE() << "voxel size " << size << " accepted";
    } catch (const std::invalid_argument& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find("voxel_size_m"), std::string::npos) << message;
      EXPECT_NE(message.find("[0.05, 0.5]"), std::string::npos) << message;
      EXPECT_NE(message.find("got"), std::string::npos) << message;
    }
  }
  VoxelMapParameters parameters;
  parameters.voxel_size_m = -0.25;
  EXPECT_THROW(
      {
        try {
          VoxelMap map(parameters);
        } catch (const std::invalid_argument& error) {
          EXPECT_NE(std::string(error.what()).find("-0.25"), std::string::npos) << error.what();
          throw;
        }
      },
      std::invalid_argument);
  EXPECT_NO_THROW(VoxelMap(VoxelMapParameters{0.05}));
  EXPECT_NO_THROW(VoxelMap(VoxelMapParameters{0.5}));
}

TEST(VoxelMap, EmptyCloudsAreFine) {
  VoxelMap map;
  for (int frame = 0; frame < 3; ++frame) {
    const VoxelMapStatus& status = map.update({}, EgoMotion{});
    EXPECT_EQ(status.points_in, 0);
    EXPECT_EQ(status.voxel_count, 0);
  }
}

TEST(VoxelMap, CountedWorkFollowsTheHeaderModel) {
  VoxelMap map;
  std::vector<ObstaclePoint> points;
  add_box(points, {10.0, 0.0, 0.5}, {10.5, 0.25, 0.75}, {100, 100, 100});  // 8 x 4 x 4 points in 2 voxels
  points.push_back(make_point({900.0, 0.0, 0.6}, {1, 1, 1}));            // clipped
  const VoxelMapStatus& status = map.update(points, EgoMotion{});
  ASSERT_EQ(status.points_inserted, 128);
  ASSERT_EQ(status.voxels_created, 2);
  // N = 129, I = 128, C = 2, V = 2, R = 0 (header comment of voxel_map.h).
  EXPECT_EQ(status.work.scalar_ops, 24u + 12u * 129 + 98u * 128 + 16u * 2 + 20u * 2);
  EXPECT_EQ(status.work.memory_bytes, sizeof(ObstaclePoint) * 129 + sizeof(Voxel) * (2 * 128 + 2 + 2));
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
