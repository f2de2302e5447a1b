// Ego-motion across odometry dropouts (arm/obstacles3d/ego_motion.h): the sources frame by frame, the
// vehicle-frame conversion, the bridge's limit, parameter errors, and what a dropout does to the
// moving flag of a static object seen from a moving camera (map, clustering, tracking).
#include "arm/obstacles3d/ego_motion.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "arm/obstacles3d/obstacle_tracking.h"
#include "arm/obstacles3d/voxel_clustering.h"
#include "arm/obstacles3d/voxel_map.h"
#include "arm/point_cloud.h"
#include "tests/arm/obstacles3d/voxel_scene.h"

namespace lpstereo::arm::obstacles3d {
namespace {

// One camera increment: 1.2 m forward (camera z) and a small turn, so that the vehicle-frame
// conversion has both parts to get right.
Eigen::Isometry3d camera_increment() {
  Eigen::Isometry3d increment = Eigen::Isometry3d::Identity();
  increment.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()).toRotationMatrix();
  increment.translation() = Eigen::Vector3d(0.05, 0.0, 1.2);
  return increment;
}

// A camera 1.5 m up, pitched 0.06 rad: V is neither the identity nor a pure axis swap.
Eigen::Isometry3d vehicle_from_camera() {
  CameraMount mount;
  mount.pitch_rad = 0.06;
  mount.position_m = Eigen::Vector3d(0, 0, 1.5);
  return CameraToVehicle(mount).vehicle_from_camera();
}

TEST(OdometryEgoMotion, FirstFrameThenOdometryThenBridgedDropoutsThenStatic) {
  const Eigen::Isometry3d v = vehicle_from_camera(), e = camera_increment();
  const Eigen::Isometry3d expected = v * e * v.inverse();
  OdometryEgoMotion source(2);

  EXPECT_FALSE(source.next(true, Eigen::Isometry3d::Identity(), v).available);
  EXPECT_EQ(source.source(), EgoMotionSource::first_frame);
  EXPECT_EQ(source.note(), "first frame: no ego-motion");

  EgoMotion ego = source.next(true, e, v);
  EXPECT_TRUE(ego.available);
  EXPECT_EQ(source.source(), EgoMotionSource::odometry);
  EXPECT_TRUE(ego.previous_from_current.isApprox(expected, 1e-12));
  // Vehicle x is the camera's forward axis: the 1.2 m step shows up there (pitch and turn move it by centimetres).
  EXPECT_NEAR(ego.previous_from_current.translation().x(), 1.2, 0.1);

  // Two dropouts are bridged with the last valid increment (whatever the failed frame's increment says) ...
  for (int dropout = 1; dropout <= 2; ++dropout) {
    ego = source.next(false, Eigen::Isometry3d::Identity(), v);
    EXPECT_TRUE(ego.available) << dropout;
    EXPECT_EQ(source.source(), EgoMotionSource::extrapolated);
    EXPECT_EQ(source.consecutive_dropouts(), dropout);
    EXPECT_TRUE(ego.previous_from_current.isApprox(expected, 1e-12));
  }
  EXPECT_EQ(source.note(), "odometry failed: last increment applied (dropout 2 of at most 2)");
  // ... the third is not: static camera, and it says so.
  ego = source.next(false, Eigen::Isometry3d::Identity(), v);
  EXPECT_FALSE(ego.available);
  EXPECT_EQ(source.source(), EgoMotionSource::static_camera);
  EXPECT_EQ(source.note(), "no ego-motion: static camera assumed");

  // A valid increment resets the count: the next dropout is bridged with the newest increment.
  const Eigen::Isometry3d slower(Eigen::Translation3d(0, 0, 0.6));
  EXPECT_TRUE(source.next(true, slower, v).available);
  EXPECT_EQ(source.consecutive_dropouts(), 0);
  ego = source.next(false, Eigen::Isometry3d::Identity(), v);
  EXPECT_EQ(source.source(), EgoMotionSource::extrapolated);
  EXPECT_TRUE(ego.previous_from_current.isApprox(v * slower * v.inverse(), 1e-12));
}

TEST(OdometryEgoMotion, ADropoutBeforeAnyValidIncrementIsAStaticCamera) {
  OdometryEgoMotion source;
  const Eigen::Isometry3d v = vehicle_from_camera();
  source.next(false, Eigen::Isometry3d::Identity(), v);  // first frame
  EXPECT_EQ(source.source(), EgoMotionSource::first_frame);
  EXPECT_FALSE(source.next(false, Eigen::Isometry3d::Identity(), v).available);
  EXPECT_EQ(source.source(), EgoMotionSource::static_camera);
}

TEST(OdometryEgoMotion, ZeroExtrapolatedFramesIsTheStaticFallbackAlone) {
  OdometryEgoMotion source(0);
  const Eigen::Isometry3d v = vehicle_from_camera();
  source.next(true, Eigen::Isometry3d::Identity(), v);
  EXPECT_TRUE(source.next(true, camera_increment(), v).available);
  EXPECT_FALSE(source.next(false, camera_increment(), v).available);
  EXPECT_EQ(source.source(), EgoMotionSource::static_camera);
}

TEST(OdometryEgoMotion, BadParameter) {
  for (int frames : {-1, 101}) {
    try {
      OdometryEgoMotion source(frames);
      ADD_FAILURE() << frames << " accepted";
    } catch (const std::invalid_argument& error) {
      EXPECT_EQ(std::string(error.what()), "max_extrapolated_frames: expected [0, 100], got " + std::to_string(frames));
    }
  }
}

// The case the bridge is for: a camera at 12 m/s (1.2 m a frame at 10 Hz) approaching a static box,
// its odometry dropping frame 12. Assumed static for that frame, the box seems to step 1.2 m towards
// the camera in the world frame and the tracker's filter turns the step into a speed that flags it
// moving; bridged, the box stays static in every frame.
std::vector<bool> static_box_moving_flags(int max_extrapolated_frames) {
  const double period_s = 0.1, camera_speed_mps = 12.0;
  const int dropout_frame = 12, frames = 20;
  VoxelMap map;
  ObstacleTrackingParameters tracking;
  tracking.frame_period_s = period_s;
  ObstacleTracker3d tracker(tracking);
  OdometryEgoMotion source(max_extrapolated_frames);
  // The odometry's increments are camera-frame: z forward. A level camera at the vehicle origin.
  const Eigen::Isometry3d v = CameraToVehicle(CameraMount{}).vehicle_from_camera();
  const Eigen::Isometry3d step(Eigen::Translation3d(0, 0, camera_speed_mps * period_s));
  std::vector<bool> flags;
  for (int frame = 0; frame < frames; ++frame) {
    const double camera_x = camera_speed_mps * period_s * frame;
    std::vector<ObstaclePoint> points;
    const Eigen::Vector3d box_min(30.0 - camera_x, 2.0, 0.0);
    test::add_box(points, box_min, box_min + Eigen::Vector3d(1.0, 1.0, 1.5), {200, 40, 40});
    map.update(points, source.next(frame != dropout_frame, step, v));
    const TrackingResult& result = tracker.update(cluster_voxels(map).clusters, map.world_from_current());
    bool moving = false;
    for (const Obstacle3d& obstacle : result.obstacles) moving = moving || obstacle.moving;
    flags.push_back(moving);
  }
  return flags;
}

TEST(OdometryEgoMotion, ABridgedDropoutKeepsAStaticObjectStaticWhereAStaticCameraFlagsItMoving) {
  const std::vector<bool> bridged = static_box_moving_flags(5), assumed_static = static_box_moving_flags(0);
  int bridged_flags = 0, static_flags = 0;
  for (size_t frame = 0; frame < bridged.size(); ++frame) bridged_flags += bridged[frame], static_flags += assumed_static[frame];
  EXPECT_EQ(bridged_flags, 0);
  EXPECT_GE(static_flags, 1) << "the static camera's step should flag the box";
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
