// A drone flight seen by a downward-looking rectified stereo pair, rendered by ray casting with exact
// ground truth (docs/synth.md, "Drone flight"): the synthetic data of issue 8's drone homing (take-off
// from a 1 m x 1 m pad, a square route through four waypoints, return, landing). It shares the road
// scene's texture noise, sensor model and folder writing (io/synth_render.h).
//
// Frames (all metres, radians):
// - Ground frame: origin at the centre of the landing pad on the ground, Z up, X to the right of the
//   first image, Y towards the top of the first image (right-handed). The ground is the plane Z = 0.
// - Camera frame (DESIGN.md §4): x right, y down, z forward = looking straight down. At yaw psi the
//   camera axes in the ground frame are x = (cos psi, sin psi, 0), y = (sin psi, -cos psi, 0),
//   z = (0, 0, -1): positive yaw turns the drone counter-clockwise seen from above, which turns the
//   image content clockwise on the screen. The drone stays level (no roll or pitch).
// - The rig centre (midpoint of the baseline) follows the trajectory; the left camera sits baseline_m / 2
//   to its left (-x), the right camera baseline_m / 2 to its right: the drone yaws about its centre.
//
// Route: standing on the pad (camera start_height_m above the ground), take-off straight up to
// altitude_m, then the square of side side_m centred on the pad, corners in counter-clockwise order
// (+S, +S), (-S, +S), (-S, -S), (+S, -S) with S = side_m / 2, back above the pad, and landing. Every
// leg is a straight line flown with a minimum-jerk profile (Flash and Hogan 1985: position
// s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, zero velocity and acceleration at both ends, peak velocity
// 1.875 x the mean), so the drone stops at each waypoint; with yaw at the corners it turns there,
// hovering, with the same profile in angle. Continuous yaw turns at a constant rate from take-off to
// touch-down (the rate ramps linearly over the first and the last second).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "io/calibration.h"

namespace lpstereo::io {

enum class FlightYawMode { none, corners, continuous };

struct StereoFlightOptions {
  int width = 640;
  int height = 480;
  double hfov_deg = 90;          // horizontal field of view, degrees, (1, 170): f = (W / 2) / tan(hfov / 2)
  double baseline_m = 0.10;      // (0, 1]
  double start_height_m = 0.4;   // camera above the ground standing on the pad, [0.2, altitude_m)
  double altitude_m = 2.0;       // cruise height of the camera above the ground, (start_height_m, 20]
  double side_m = 6.0;           // side of the square route, [1, 200]
  double speed_mps = 1.0;        // peak horizontal speed of a leg, (0, 20]
  double climb_speed_mps = 0.5;  // peak vertical speed of take-off and landing, (0, 5]
  double yaw_rate_deg_s = 45;    // peak yaw rate of a turn at a corner, (0, 360]
  FlightYawMode yaw_mode = FlightYawMode::none;
  double corner_yaw_deg[4] = {90, 90, 90, 90};  // turns at waypoints 1..4 (yaw_mode corners), |.| <= 360
  double continuous_yaw_deg_s = 10;             // yaw rate (yaw_mode continuous), |.| <= 90
  double fps = 10;               // frame rate, (0, 1000]; ignored when frames > 0
  int frames = 0;                // > 1: this many frames spread evenly over the flight; 0: from fps
  int samples_per_axis = 2;      // anti-aliasing: samples_per_axis^2 rays per pixel, 1..4
  double noise_sigma = 0;        // Gaussian sensor noise, grey levels (each view and frame independently)
  double right_gain = 1;         // the right camera's response: gain * value + offset, before noise
  double right_offset = 0;       // grey levels
  uint32_t seed = 1;             // ground texture and noise
  int threads = 2;               // rows of a frame are shared between this many threads
};

// Throws std::invalid_argument "<option>: expected ..., got ..." (the option as the command line
// names it, without "--") for a value out of range.
void validate_flight_options(const StereoFlightOptions& options);

// One straight leg (or a turn on the spot) of the route: from the state at start_s to the state at
// end_s, minimum-jerk in position and yaw.
struct FlightLeg {
  std::string name;  // "take-off", "waypoint 1" .. "waypoint 4", "turn at waypoint 1", "return", "landing"
  double start_s = 0, end_s = 0;
  Eigen::Vector3d from_m = Eigen::Vector3d::Zero(), to_m = Eigen::Vector3d::Zero();  // rig centre, ground frame
  double from_yaw_rad = 0, to_yaw_rad = 0;
};

struct FlightPlan {
  std::vector<FlightLeg> legs;
  Eigen::Vector3d waypoints_m[4];  // ground frame, at altitude_m
  double duration_s = 0;           // take-off start to touch-down
  std::vector<double> frame_times_s;  // from 0; frames after touch-down (fps rounding) stand on the pad
};

FlightPlan plan_flight(const StereoFlightOptions& options);

struct FlightState {
  double time_s = 0;
  Eigen::Vector3d rig_m = Eigen::Vector3d::Zero();  // rig centre, ground frame
  double yaw_rad = 0;
  Eigen::Isometry3d left_camera = Eigen::Isometry3d::Identity();  // left camera -> ground frame
  double height_m = 0;  // camera above the ground = the depth of every ground pixel
};

FlightState flight_state_at(const StereoFlightOptions& options, const FlightPlan& plan, double time_s);
// The state at a chosen pose (time 0): the rig centre at rig_m, the given yaw, level; for views
// rendered away from the route (relocalization maps and tests).
FlightState flight_state_at_pose(const StereoFlightOptions& options, const Eigen::Vector3d& rig_m, double yaw_rad);

struct StereoFlightFrame {
  cv::Mat left, right;  // CV_8UC1
  cv::Mat disparity_px;  // CV_32FC1, left view: f B / depth of the hit (exact; the ground is flat: f B / height)
};

double flight_focal_px(const StereoFlightOptions& options);

// Renders the pair seen from `state`; frame_index seeds the sensor noise (a different draw per frame).
StereoFlightFrame render_flight_frame(const StereoFlightOptions& options, const FlightState& state, int frame_index);

// The rectified pinhole pair of the flight (already_rectified).
StereoCalibration flight_calibration(const StereoFlightOptions& options);

// Renders every frame into `directory` (first a temporary sibling folder, renamed when complete; an
// existing folder is replaced): left/%06d.png, right/%06d.png, poses.txt (KITTI: the left camera of
// each frame relative to the first), times.txt (s), heights.txt (camera above the ground, m),
// calib.txt (KITTI odometry P0 P1), calib.yaml (OpenCV), flight.json (settings, waypoints, pad,
// legs), and with write_disparity disparity/%06d.png (KITTI 16-bit, x 256). `progress` (if set) gets
// the fraction of frames done. Throws std::runtime_error naming the path on failure, leaving nothing.
void write_stereo_flight(const std::string& directory, const StereoFlightOptions& options, bool write_disparity,
                         const std::function<void(double)>& progress = {});

}  // namespace lpstereo::io
