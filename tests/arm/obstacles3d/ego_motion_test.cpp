// Ego-motion across odometry dropouts (arm/obstacles3d/ego_motion.h): the sources frame by frame, the
// vehicle-frame conversion, the bridge's limit, parameter errors, and what a dropout does to the
// moving flag of a static object seen from a moving camera (map, clustering, tracking).
#include "arm/obstacles3d/ego_motion.h"

#include <gtest/gtest.h>

#include <cmath>
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
  OdometryEgoMotionParameters parameters;
  parameters.max_extrapolated_frames = 2;
  OdometryEgoMotion source(parameters);

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

  // A valid increment resets the count: the next dropout is bridged with the newest increment (0.2 m
  // slower than the last: within the plausibility bound after 3 dropouts, 10 m/s^2 0.01 s^2 4 + 0.1 m).
  const Eigen::Isometry3d slower(Eigen::Translation3d(0, 0, 1.0));
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
  OdometryEgoMotionParameters parameters;
  parameters.max_extrapolated_frames = 0;
  OdometryEgoMotion source(parameters);
  const Eigen::Isometry3d v = vehicle_from_camera();
  source.next(true, Eigen::Isometry3d::Identity(), v);
  EXPECT_TRUE(source.next(true, camera_increment(), v).available);
  EXPECT_FALSE(source.next(false, camera_increment(), v).available);
  EXPECT_EQ(source.source(), EgoMotionSource::static_camera);
}

// The plausibility bound at 10 Hz: one frame a dt^2 + noise = 10 0.01 + 0.1 = 0.2 m; after k bridged
// frames 0.1 (k + 1) + 0.1 m.
TEST(OdometryEgoMotion, AnImplausibleIncrementIsBridgedAndTwoInARowAreAccepted) {
  const Eigen::Isometry3d v = vehicle_from_camera(), e = camera_increment();  // 1.2 m a frame
  auto forward = [](double metres) { return Eigen::Isometry3d(Eigen::Translation3d(0.05, 0.0, metres)); };
  OdometryEgoMotion source;
  source.next(true, Eigen::Isometry3d::Identity(), v);
  source.next(true, e, v);
  // 0.19 m slower: within 0.2 m, accepted.
  EXPECT_TRUE(source.next(true, forward(1.01), v).available);
  EXPECT_EQ(source.source(), EgoMotionSource::odometry);
  EXPECT_FALSE(source.rejected_implausible());
  // A jump of 0.8 m (the recovered odometry on urban seed 1): rejected, bridged with 1.01 m.
  EgoMotion ego = source.next(true, forward(0.21), v);
  EXPECT_TRUE(source.rejected_implausible());
  EXPECT_EQ(source.source(), EgoMotionSource::extrapolated);
  EXPECT_TRUE(ego.previous_from_current.isApprox(v * forward(1.01) * v.inverse(), 1e-12));
  EXPECT_EQ(source.note(), "odometry implausible (0.80 m off the last increment, at most 0.20 m): last increment applied (dropout 1 of at most 5)");
  // The next one agrees with the last accepted (within 0.3 m after one bridged frame): accepted.
  ego = source.next(true, forward(1.25), v);
  EXPECT_EQ(source.source(), EgoMotionSource::odometry);
  EXPECT_TRUE(ego.previous_from_current.isApprox(v * forward(1.25) * v.inverse(), 1e-12));
  // A real stop: 1.25 -> 0.3 m, then 0.3 m again: the first is rejected, the second confirms it.
  source.next(true, forward(0.3), v);
  EXPECT_TRUE(source.rejected_implausible());
  ego = source.next(true, forward(0.3), v);
  EXPECT_FALSE(source.rejected_implausible());
  EXPECT_EQ(source.source(), EgoMotionSource::odometry);
  EXPECT_TRUE(ego.previous_from_current.isApprox(v * forward(0.3) * v.inverse(), 1e-12));
  // The bound off (0): any valid increment is taken.
  OdometryEgoMotionParameters off;
  off.max_acceleration_mps2 = 0;
  OdometryEgoMotion unbounded(off);
  unbounded.next(true, Eigen::Isometry3d::Identity(), v);
  unbounded.next(true, e, v);
  unbounded.next(true, forward(0.0), v);
  EXPECT_EQ(unbounded.source(), EgoMotionSource::odometry);
}

TEST(OdometryEgoMotion, BadParameters) {
  auto message = [](const OdometryEgoMotionParameters& parameters) {
    try {
      OdometryEgoMotion source(parameters);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  OdometryEgoMotionParameters parameters;
  parameters.max_extrapolated_frames = 101;
  EXPECT_EQ(message(parameters), "max_extrapolated_frames: expected [0, 100], got 101");
  parameters = {};
  parameters.max_extrapolated_frames = -1;
  EXPECT_EQ(message(parameters), "max_extrapolated_frames: expected [0, 100], got -1");
  parameters = {};
  parameters.frame_period_s = 0;
  EXPECT_EQ(message(parameters), "frame_period_s: expected (0, 10] s, got 0");
  parameters = {};
  parameters.max_acceleration_mps2 = -1;
  EXPECT_EQ(message(parameters), "max_acceleration_mps2: expected [0, 1000] m/s^2, got -1");
  parameters = {};
  parameters.increment_noise_m = std::nan("");
  EXPECT_EQ(message(parameters), "increment_noise_m: expected [0, 100] m, got nan");
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
  OdometryEgoMotionParameters parameters;
  parameters.max_extrapolated_frames = max_extrapolated_frames;
  OdometryEgoMotion source(parameters);
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
