// io/stereo_flight: the route is the one asked for (take-off height, the four waypoints, back on the
// pad), flown smoothly; the ground truth disparity is f B / height and the two views agree with it;
// the ground has corners from 0.4 m to 3 m; a yaw turns the image as a turning camera would; bad
// options name themselves.
#include "io/stereo_flight.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace {

using namespace lpstereo;
using io::StereoFlightOptions;

constexpr double kPi = 3.14159265358979323846;

StereoFlightOptions small_options() {
  StereoFlightOptions options;
  options.width = 160;
  options.height = 120;
  options.hfov_deg = 90;  // f = 80 px
  options.baseline_m = 0.10;
  options.samples_per_axis = 1;
  return options;
}

const io::FlightLeg& leg_named(const io::FlightPlan& plan, const std::string& name) {
  for (const io::FlightLeg& leg : plan.legs) {
    if (leg.name == name) return leg;
  }
  throw std::runtime_error("no leg " + name);
}

// The left camera standing level at ground point (x, y), height h, yaw psi (the header's axes:
// x = (cos, sin, 0), y = (sin, -cos, 0), z = down).
io::FlightState state_at(double x, double y, double height_m, double yaw_rad) {
  io::FlightState state;
  Eigen::Matrix3d rotation;
  rotation << std::cos(yaw_rad), std::sin(yaw_rad), 0, std::sin(yaw_rad), -std::cos(yaw_rad), 0, 0, 0, -1;
  state.left_camera.linear() = rotation;
  state.left_camera.translation() = Eigen::Vector3d(x, y, height_m);
  state.height_m = height_m;
  return state;
}

TEST(StereoFlight, RouteTakesOffFliesTheSquareAndLandsOnThePad) {
  StereoFlightOptions options = small_options();
  options.side_m = 6;
  options.altitude_m = 2;
  options.start_height_m = 0.4;
  const io::FlightPlan plan = io::plan_flight(options);
  const double half = 3.0, b = options.baseline_m;

  const io::FlightState start = io::flight_state_at(options, plan, 0);
  EXPECT_NEAR(start.height_m, 0.4, 1e-12);
  EXPECT_NEAR(start.rig_m.norm(), 0.4, 1e-12);  // above the pad centre
  const io::FlightState airborne = io::flight_state_at(options, plan, leg_named(plan, "take-off").end_s);
  EXPECT_NEAR(airborne.height_m, 2.0, 1e-12);
  EXPECT_NEAR(airborne.rig_m.head<2>().norm(), 0, 1e-12);  // straight up

  // Counter-clockwise seen from above, centred on the pad; with no yaw the left camera is b / 2 to
  // the rig's -X, and its pose relative to the first frame is a pure translation in the first
  // camera's axes (x = X, y = -Y, z = -Z).
  const double corners[4][2] = {{half, half}, {-half, half}, {-half, -half}, {half, -half}};
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    const io::FlightState at = io::flight_state_at(options, plan, leg_named(plan, "waypoint " + std::to_string(i + 1)).end_s);
    EXPECT_NEAR((at.rig_m - Eigen::Vector3d(corners[i][0], corners[i][1], 2)).norm(), 0, 1e-9);
    const Eigen::Isometry3d relative = start.left_camera.inverse() * at.left_camera;
    EXPECT_NEAR((relative.translation() - Eigen::Vector3d(corners[i][0], -corners[i][1], -1.6)).norm(), 0, 1e-9);
    EXPECT_NEAR((relative.linear() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
    EXPECT_NEAR(at.left_camera.translation().x(), corners[i][0] - b / 2, 1e-9);
  }
  const io::FlightState end = io::flight_state_at(options, plan, plan.duration_s);
  EXPECT_NEAR((end.left_camera.translation() - start.left_camera.translation()).norm(), 0, 1e-9);
  EXPECT_EQ(plan.legs.back().name, "landing");
  EXPECT_EQ(plan.legs.size(), 7u);  // take-off, four waypoints, return, landing

  // Frames: --fps covers the flight from 0 at 1 / fps; --frames spreads N over it, ending on the pad.
  EXPECT_NEAR(plan.frame_times_s[1], 0.1, 1e-12);
  EXPECT_GE(plan.frame_times_s.back(), plan.duration_s);
  options.frames = 9;
  const io::FlightPlan nine = io::plan_flight(options);
  ASSERT_EQ(nine.frame_times_s.size(), 9u);
  EXPECT_DOUBLE_EQ(nine.frame_times_s.back(), nine.duration_s);
}

TEST(StereoFlight, MotionIsSmoothWithinTheSpeedLimits) {
  for (const io::FlightYawMode mode : {io::FlightYawMode::none, io::FlightYawMode::corners, io::FlightYawMode::continuous}) {
    SCOPED_TRACE(static_cast<int>(mode));
    StereoFlightOptions options = small_options();
    options.yaw_mode = mode;
    options.corner_yaw_deg[1] = -45;
    options.continuous_yaw_deg_s = 20;
    const io::FlightPlan plan = io::plan_flight(options);
    const double dt = 0.005;
    double max_horizontal = 0, max_vertical = 0, max_acceleration = 0, max_yaw_rate = 0;
    io::FlightState previous = io::flight_state_at(options, plan, 0);
    Eigen::Vector3d previous_velocity = Eigen::Vector3d::Zero();
    for (double t = dt; t <= plan.duration_s; t += dt) {
      const io::FlightState now = io::flight_state_at(options, plan, t);
      const Eigen::Vector3d velocity = (now.rig_m - previous.rig_m) / dt;
      max_horizontal = std::max(max_horizontal, velocity.head<2>().norm());
      max_vertical = std::max(max_vertical, std::abs(velocity.z()));
      max_acceleration = std::max(max_acceleration, (velocity - previous_velocity).norm() / dt);
      max_yaw_rate = std::max(max_yaw_rate, std::abs(now.yaw_rad - previous.yaw_rad) / dt);
      previous = now;
      previous_velocity = velocity;
    }
    EXPECT_LE(max_horizontal, options.speed_mps * 1.001);
    EXPECT_GE(max_horizontal, options.speed_mps * 0.99);  // the peak is reached
    EXPECT_LE(max_vertical, options.climb_speed_mps * 1.001);
    // Minimum jerk over a leg of length D and time T = 1.875 D / v peaks at 5.77 D / T^2; the
    // shortest leg here is take-off (1.6 m at 0.5 m/s): 5.77 * 1.6 / 6^2 = 0.26 m/s^2.
    EXPECT_LE(max_acceleration, 0.5);
    const double rate_limit = mode == io::FlightYawMode::continuous ? 20 : options.yaw_rate_deg_s;
    EXPECT_LE(max_yaw_rate * 180 / kPi, rate_limit * 1.001 + 1e-9);
    // The left camera stays b / 2 from the rig centre whatever the yaw.
    EXPECT_NEAR((previous.left_camera.translation() - previous.rig_m).norm(), options.baseline_m / 2, 1e-12);
  }
}

TEST(StereoFlight, CornerYawTurnsTheCameraAtEachWaypoint) {
  StereoFlightOptions options = small_options();
  options.yaw_mode = io::FlightYawMode::corners;  // 90 degrees at each of the four corners
  const io::FlightPlan plan = io::plan_flight(options);
  const io::FlightState start = io::flight_state_at(options, plan, 0);
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    const io::FlightLeg& turn = leg_named(plan, "turn at waypoint " + std::to_string(i + 1));
    const io::FlightState before = io::flight_state_at(options, plan, turn.start_s);
    const io::FlightState after = io::flight_state_at(options, plan, turn.end_s);
    EXPECT_NEAR((before.rig_m - after.rig_m).norm(), 0, 1e-12);  // turning on the spot
    EXPECT_NEAR(after.yaw_rad - before.yaw_rad, kPi / 2, 1e-12);
    // Yaw psi counter-clockwise about ground Z: the new x axis seen in the first camera frame
    // (x = X, y = -Y) is (cos psi, -sin psi, 0); z stays down.
    const double psi = (i + 1) * kPi / 2;
    const Eigen::Matrix3d relative = (start.left_camera.inverse() * after.left_camera).linear();
    EXPECT_NEAR((relative.col(0) - Eigen::Vector3d(std::cos(psi), -std::sin(psi), 0)).norm(), 0, 1e-9);
    EXPECT_NEAR((relative.col(2) - Eigen::Vector3d(0, 0, 1)).norm(), 0, 1e-9);
  }
  // Four quarter turns: back on the pad with the start's pose.
  const io::FlightState end = io::flight_state_at(options, plan, plan.duration_s);
  EXPECT_TRUE((start.left_camera.inverse() * end.left_camera).matrix().isIdentity(1e-9));
}

// A state at a chosen pose is the route's state at the same rig position and yaw.
TEST(StereoFlight, StateAtAPoseMatchesTheRoutesState) {
  StereoFlightOptions options = small_options();
  options.yaw_mode = io::FlightYawMode::corners;
  const io::FlightPlan plan = io::plan_flight(options);
  const io::FlightState on_route = io::flight_state_at(options, plan, leg_named(plan, "turn at waypoint 2").end_s);
  const io::FlightState at_pose = io::flight_state_at_pose(options, on_route.rig_m, on_route.yaw_rad);
  EXPECT_TRUE(at_pose.left_camera.matrix().isApprox(on_route.left_camera.matrix(), 1e-12));
  EXPECT_DOUBLE_EQ(at_pose.height_m, on_route.height_m);
  EXPECT_EQ(at_pose.rig_m, on_route.rig_m);
  EXPECT_EQ(at_pose.yaw_rad, on_route.yaw_rad);
}

TEST(StereoFlight, YawRotatesTheImageAboutItsCentre) {
  // A square image with the principal point at its centre: a quarter turn of the camera maps the
  // pixel grid (and the sub-pixel sample grid) onto itself, so the rendered image must be the other
  // one rotated. Counter-clockwise yaw seen from above turns the image content clockwise (header).
  StereoFlightOptions options = small_options();
  options.width = options.height = 96;
  options.samples_per_axis = 2;
  const cv::Mat straight = io::render_flight_frame(options, state_at(1.3, -0.7, 1.0, 0), 0).left;
  const cv::Mat turned = io::render_flight_frame(options, state_at(1.3, -0.7, 1.0, kPi / 2), 0).left;
  cv::Mat expected;
  cv::rotate(straight, expected, cv::ROTATE_90_CLOCKWISE);
  cv::Mat difference;
  cv::absdiff(turned, expected, difference);
  double worst = 0;
  cv::minMaxLoc(difference, nullptr, &worst);
  EXPECT_LE(worst, 1);  // rounding of the same values at most
  cv::absdiff(turned, straight, difference);
  EXPECT_GT(cv::mean(difference)[0], 5);  // and the turn did change the image
  cv::Mat wrong_way;
  cv::rotate(straight, wrong_way, cv::ROTATE_90_COUNTERCLOCKWISE);
  cv::absdiff(turned, wrong_way, difference);
  EXPECT_GT(cv::mean(difference)[0], 5);
}

TEST(StereoFlight, DisparityIsFocalTimesBaselineOverHeightAndTheViewsAgree) {
  const StereoFlightOptions options = small_options();
  const double focal = 80.0 / std::tan(kPi / 4);  // (W / 2) / tan(hfov / 2)
  EXPECT_NEAR(io::flight_focal_px(options), focal, 1e-9);
  for (const double height : {0.4, 1.0, 2.0, 3.0}) {
    SCOPED_TRACE(height);
    const io::StereoFlightFrame frame = io::render_flight_frame(options, state_at(2.1, 0.6, height, 0.3), 0);
    const double expected = focal * options.baseline_m / height;
    double low = 0, high = 0;
    cv::minMaxLoc(frame.disparity_px, &low, &high);
    EXPECT_NEAR(low, expected, 1e-5 * expected);
    EXPECT_NEAR(high, expected, 1e-5 * expected);
    // The right view seen at x - d is the left view: compare with the error of a shift 2 px off.
    auto median_error = [&](double shift) {
      cv::Mat map_x(frame.left.size(), CV_32FC1), map_y(frame.left.size(), CV_32FC1);
      for (int v = 0; v < map_x.rows; ++v) {
        for (int u = 0; u < map_x.cols; ++u) map_x.at<float>(v, u) = static_cast<float>(u - shift), map_y.at<float>(v, u) = static_cast<float>(v);
      }
      cv::Mat warped;
      cv::remap(frame.right, warped, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(-1));
      std::vector<int> errors;
      const int margin = static_cast<int>(std::ceil(shift)) + 2;
      for (int v = 0; v < warped.rows; ++v) {
        for (int u = margin; u < warped.cols; ++u) errors.push_back(std::abs(warped.at<uint8_t>(v, u) - frame.left.at<uint8_t>(v, u)));
      }
      std::nth_element(errors.begin(), errors.begin() + static_cast<long>(errors.size() / 2), errors.end());
      return errors[errors.size() / 2];
    };
    const int right_shift = median_error(expected), wrong_shift = median_error(expected + 2);
    EXPECT_LE(right_shift, 3);
    EXPECT_GT(wrong_shift, 2 * right_shift + 3);
  }
}

// The number of cells of a 6 x 5 grid over the image that hold a corner at least as strong as an
// ideal right-angle corner of `contrast` grey levels (the Shi-Tomasi measure, OpenCV's
// cornerMinEigenVal over 5 x 5): the share of the image where a Harris / BRIEF front end finds
// something to hold on to.
int cells_with_corners(const cv::Mat& image, double contrast) {
  cv::Mat ideal(32, 32, CV_8UC1, cv::Scalar(100));
  ideal(cv::Rect(16, 16, 16, 16)).setTo(100 + contrast);
  cv::Mat ideal_response, response;
  cv::cornerMinEigenVal(ideal, ideal_response, 5, 3);
  double threshold = 0;
  cv::minMaxLoc(ideal_response, nullptr, &threshold);
  cv::cornerMinEigenVal(image, response, 5, 3);
  int cells = 0;
  for (int j = 0; j < 5; ++j) {
    for (int i = 0; i < 6; ++i) {
      const cv::Rect cell(i * image.cols / 6, j * image.rows / 5, image.cols / 6, image.rows / 5);
      double best = 0;
      cv::minMaxLoc(response(cell), nullptr, &best);
      cells += best >= threshold ? 1 : 0;
    }
  }
  return cells;
}

TEST(StereoFlight, GroundHasCornersFromPointFourToThreeMetres) {
  StereoFlightOptions options = small_options();
  options.width = 320;  // f = 160 px: a half-size camera, so the default one sees finer detail still
  options.height = 240;
  options.samples_per_axis = 2;
  for (const double height : {0.4, 1.5, 3.0}) {
    for (const uint32_t seed : {1u, 7u}) {
      SCOPED_TRACE("height " + std::to_string(height) + " seed " + std::to_string(seed));
      options.seed = seed;
      const cv::Mat left = io::render_flight_frame(options, state_at(4.0 + seed, -2.5, height, 0), 0).left;
      EXPECT_GE(cells_with_corners(left, 20), 28);  // of 30
      cv::Scalar mean, deviation;
      cv::meanStdDev(left, mean, deviation);
      EXPECT_GT(deviation[0], 15);
    }
  }
  // On the pad at the start (it fills the view from 0.4 m): its mat is textured, the H is there.
  const cv::Mat pad = io::render_flight_frame(options, state_at(-0.05, 0, 0.4, 0), 0).left;
  EXPECT_GE(cells_with_corners(pad, 20), 24);
  EXPECT_GT(cv::countNonZero(pad > 190), pad.total() / 20);  // white markings
}

TEST(StereoFlight, SameSeedSameBitsWhateverTheThreadsAndNoisePerFrame) {
  StereoFlightOptions options = small_options();
  options.noise_sigma = 2;
  const io::FlightState state = state_at(0.3, 0.2, 1.2, 0.1);
  const io::StereoFlightFrame one = io::render_flight_frame(options, state, 3);
  options.threads = 1;
  const io::StereoFlightFrame two = io::render_flight_frame(options, state, 3);
  EXPECT_EQ(cv::norm(one.left, two.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(one.right, two.right, cv::NORM_INF), 0);
  const io::StereoFlightFrame next = io::render_flight_frame(options, state, 4);  // another noise draw
  EXPECT_GT(cv::norm(one.left, next.left, cv::NORM_L1) / static_cast<double>(one.left.total()), 1.0);
  options.seed = 2;
  options.noise_sigma = 0;
  const io::StereoFlightFrame other = io::render_flight_frame(options, state, 3);
  EXPECT_GT(cv::norm(one.left, other.left, cv::NORM_L1) / static_cast<double>(one.left.total()), 10.0);
}

TEST(StereoFlight, BadOptionsNameTheOption) {
  struct Case {
    const char* option;
    void (*change)(StereoFlightOptions&);
  };
  const Case cases[] = {
      {"side-m", [](StereoFlightOptions& o) { o.side_m = 0.5; }},
      {"start-height-m", [](StereoFlightOptions& o) { o.start_height_m = 2.5; }},
      {"altitude-m", [](StereoFlightOptions& o) { o.altitude_m = -1; }},
      {"frames", [](StereoFlightOptions& o) { o.frames = 1; }},
      {"fps", [](StereoFlightOptions& o) { o.fps = 0; }},
      {"speed-mps", [](StereoFlightOptions& o) { o.speed_mps = 0; }},
      {"yaw", [](StereoFlightOptions& o) { o.corner_yaw_deg[2] = 400; }},
      {"baseline-m", [](StereoFlightOptions& o) { o.baseline_m = 0; }},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.option);
    StereoFlightOptions options = small_options();
    c.change(options);
    try {
      io::plan_flight(options);
      ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& error) {
      EXPECT_EQ(std::string(error.what()).rfind(std::string(c.option) + ": expected", 0), 0u) << error.what();
    }
  }
}

}  // namespace
