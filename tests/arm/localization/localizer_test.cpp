// The keyframe localizer (arm/localization/localizer.h) end to end on a short rendered flight
// (io/stereo_flight.h: small images, a 1 m square at 1 m with a quarter turn at the first corner, noise):
// with keyframe corrections it lands closer to the truth than visual odometry alone, the odometry
// follows the turn on the spot (a pure rotation), the landing is corrected against the take-off
// keyframe with steered descriptors; textureless
// frames keep the filter predicting with a growing covariance and a falling confidence; the frame
// conversion (body_from_camera) reproduces the flight's yaw convention.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "arm/localization/localizer.h"
#include "io/image_io.h"
#include "io/stereo_flight.h"

namespace lpstereo::arm::localization {
namespace {

io::StereoFlightOptions short_flight() {
  io::StereoFlightOptions flight;
  flight.width = 240;
  flight.height = 180;
  flight.side_m = 1.0;
  flight.altitude_m = 1.0;
  // One quarter turn at the first waypoint: the drone lands at yaw 90 degrees, so the landing's
  // corrections against the take-off keyframe need the steered descriptors of sector 4.
  flight.yaw_mode = io::FlightYawMode::corners;
  flight.corner_yaw_deg[0] = 90;
  flight.corner_yaw_deg[1] = flight.corner_yaw_deg[2] = flight.corner_yaw_deg[3] = 0;
  flight.noise_sigma = 2;
  flight.samples_per_axis = 1;
  flight.fps = 5;
  flight.seed = 7;
  return flight;
}

KeyframeLocalizerParameters parameters_for(const io::StereoFlightOptions& flight) {
  const io::StereoCalibration calibration = io::flight_calibration(flight);
  KeyframeLocalizerParameters parameters;
  parameters.focal_px = io::flight_focal_px(flight);
  parameters.principal_point_x_px = calibration.left.cx_px;
  parameters.principal_point_y_px = calibration.left.cy_px;
  parameters.baseline_m = flight.baseline_m;
  parameters.start_height_m = flight.start_height_m;
  return parameters;
}

// The flight's camera axes at yaw psi (io/stereo_flight.h) are the body's at psi through the mounting.
TEST(KeyframeLocalizer, MountingMakesTheFilterYawTheFlightYaw) {
  const Eigen::Matrix3d mount = KeyframeLocalizer::body_from_camera().linear();
  EXPECT_NEAR(mount.determinant(), 1.0, 1e-12);
  for (double psi : {0.0, 0.7, -2.0, 3.0}) {
    Eigen::Matrix3d camera_axes;  // columns: x_c, y_c, z_c in the ground frame, from the flight's header
    camera_axes.col(0) = Eigen::Vector3d(std::cos(psi), std::sin(psi), 0);
    camera_axes.col(1) = Eigen::Vector3d(std::sin(psi), -std::cos(psi), 0);
    camera_axes.col(2) = Eigen::Vector3d(0, 0, -1);
    const Eigen::Matrix3d body = Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_TRUE((body * mount).isApprox(camera_axes, 1e-12)) << "psi " << psi;
  }
  // And the flight renderer agrees: its left camera's rotation at some yaw.
  const io::StereoFlightOptions flight = short_flight();
  const io::FlightPlan plan = io::plan_flight(flight);
  const io::FlightState state = io::flight_state_at(flight, plan, 0.6 * plan.duration_s);
  const Eigen::Matrix3d body = Eigen::AngleAxisd(state.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE((body * mount).isApprox(state.left_camera.linear(), 1e-9));
}

TEST(KeyframeLocalizer, KeyframeCorrectionsLandCloserThanOdometryAlone) {
  const io::StereoFlightOptions flight = short_flight();
  const io::FlightPlan plan = io::plan_flight(flight);
  const KeyframeLocalizerParameters parameters = parameters_for(flight);
  KeyframeLocalizerParameters odometry_only = parameters;
  odometry_only.keyframe_corrections = false;
  odometry_only.height_updates = false;
  KeyframeLocalizer corrected(flight.width, flight.height, parameters, 2);
  KeyframeLocalizer alone(flight.width, flight.height, odometry_only, 2);
  Eigen::Isometry3d first_truth = Eigen::Isometry3d::Identity(), truth = first_truth;
  LocalizerFrame with_corrections, without;
  int accepted = 0, turned_sector_accepted = 0, last_frames_sector_4 = 0, turn_frames = 0;
  for (size_t i = 0; i < plan.frame_times_s.size(); ++i) {
    const io::FlightState state = io::flight_state_at(flight, plan, plan.frame_times_s[i]);
    const io::StereoFlightFrame frame = io::render_flight_frame(flight, state, static_cast<int>(i));
    const Plane left = io::mat_to_plane(frame.left, {ElementType::u8, 0});
    const Plane right = io::mat_to_plane(frame.right, {ElementType::u8, 0});
    if (i == 0) first_truth = state.left_camera;
    truth = first_truth.inverse() * state.left_camera;
    with_corrections = corrected.process(left, right);
    without = alone.process(left, right);
    accepted += with_corrections.correction_accepted ? 1 : 0;
    turned_sector_accepted += with_corrections.correction_accepted && with_corrections.yaw_sector != 0 ? 1 : 0;
    if (i + 5 >= plan.frame_times_s.size()) last_frames_sector_4 += with_corrections.correction_accepted && with_corrections.keyframe_id == 0 && with_corrections.yaw_sector == 4 ? 1 : 0;
    EXPECT_EQ(without.keyframe_id, -1);
    // A pure rotation (the quarter turn on the spot at waypoint 1): the odometry follows it.
    for (const io::FlightLeg& leg : plan.legs) {
      if (leg.name.rfind("turn", 0) == 0 && plan.frame_times_s[i] > leg.start_s && plan.frame_times_s[i] <= leg.end_s) {
        EXPECT_TRUE(with_corrections.odometry_valid) << "frame " << i << " during " << leg.name;
        ++turn_frames;
      }
    }
  }
  EXPECT_GE(turn_frames, 3);
  ASSERT_GT(plan.frame_times_s.size(), 30u);
  EXPECT_GE(corrected.database().size(), 1u);
  EXPECT_EQ(alone.database().size(), 0u);
  EXPECT_GE(accepted, 5);  // the take-off and landing frames near the pad keyframe (10 in this flight)
  // After the quarter turn the drone is at sector 4 relative to the take-off keyframe (0): the last
  // frames, back on the pad, are corrected against it with steered descriptors.
  EXPECT_GT(turned_sector_accepted, 0);
  EXPECT_GE(last_frames_sector_4, 3);
  const double corrected_m = (with_corrections.pose.translation() - truth.translation()).norm();
  const double alone_m = (without.pose.translation() - truth.translation()).norm();
  EXPECT_LT(corrected_m, alone_m) << "with corrections " << corrected_m << " m, odometry alone " << alone_m << " m";
  EXPECT_LT(corrected_m, 0.10);
}

TEST(KeyframeLocalizer, TexturelessFramesKeepPredictingWithLowConfidence) {
  const io::StereoFlightOptions flight = short_flight();
  const io::FlightPlan plan = io::plan_flight(flight);
  KeyframeLocalizer localizer(flight.width, flight.height, parameters_for(flight), 2);
  for (int i = 0; i < 3; ++i) {
    const io::StereoFlightFrame frame = io::render_flight_frame(flight, io::flight_state_at(flight, plan, 0.0), i);
    const LocalizerFrame result =
        localizer.process(io::mat_to_plane(frame.left, {ElementType::u8, 0}), io::mat_to_plane(frame.right, {ElementType::u8, 0}));
    EXPECT_FALSE(result.low_confidence) << "textured frame " << i;
  }
  Plane grey(flight.width, flight.height, {ElementType::u8, 0});
  for (int y = 0; y < grey.height(); ++y) {
    for (int x = 0; x < grey.width(); ++x) grey.at<uint8_t>(x, y) = 128;
  }
  double previous_trace = localizer.filter().covariance().trace(), previous_confidence = 2.0;
  const Eigen::Vector3d held = localizer.filter().position_m();
  LocalizerFrame result;
  for (int i = 0; i < 6; ++i) {
    result = localizer.process(grey, grey);
    EXPECT_FALSE(result.odometry_valid);
    EXPECT_EQ(result.keypoints, 0);
    EXPECT_FALSE(result.correction_accepted);
    EXPECT_FALSE(result.correction_note.empty());
    EXPECT_GT(result.covariance.trace(), previous_trace) << "frame " << i;
    EXPECT_LT(result.confidence, previous_confidence) << "frame " << i;
    EXPECT_TRUE(result.state.allFinite());
    previous_trace = result.covariance.trace();
    previous_confidence = result.confidence;
  }
  EXPECT_TRUE(result.low_confidence);
  EXPECT_LT(result.confidence, 0.5);
  // A zero increment: the filter holds its position while it predicts.
  EXPECT_LT((result.state.head<3>() - held).norm(), 1e-9);
}

TEST(KeyframeLocalizer, RefusesViewsOfAnotherSize) {
  const io::StereoFlightOptions flight = short_flight();
  KeyframeLocalizer localizer(flight.width, flight.height, parameters_for(flight), 1);
  const Plane small(100, 80, {ElementType::u8, 0});
  EXPECT_THROW(localizer.process(small, small), std::invalid_argument);
  KeyframeLocalizerParameters bad = parameters_for(flight);
  bad.baseline_m = 0;
  EXPECT_THROW(KeyframeLocalizer(flight.width, flight.height, bad, 1), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm::localization
