#include "io/stereo_flight.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/kitti_poses.h"
#include "io/synth_render.h"

namespace lpstereo::io {

namespace {

using synth_detail::kPi;
using synth_detail::mix64;
using synth_detail::octave_weight;
using synth_detail::require;
using synth_detail::Rgb;
using synth_detail::Texture;
using synth_detail::texture;

constexpr double kPadSide_m = 1.0;           // the landing pad, centred on the ground frame's origin
constexpr double kPadBorder_m = 0.05;        // its white border
constexpr double kContinuousYawRamp_s = 1.0;  // continuous yaw: the rate ramps up / down over this

// The ground: stones of many sizes (Voronoi cells, each of its own grey level: sharp polygonal
// edges meeting in corners, which is what Harris needs) over large soil / grass patches (value noise,
// which only varies the brightness). Five stone scales, each three times the last, so that from
// 0.4 m (a pixel covers about 1.3 mm at the default 640 px, 90 degrees) to 3 m (9.4 mm) and at smaller
// image sizes two or three scales are always between 3 and 30 pixels. Nothing repeats: every cell
// is a hash of its integer coordinates and the seed.
struct StoneLayer {
  double cells_m[5];
  double amplitudes[5];
};
constexpr StoneLayer kStones{{0.006, 0.018, 0.054, 0.16, 0.48}, {0.32, 0.3, 0.28, 0.24, 0.2}};
constexpr Texture kPatches{{1.5, 4.5, 13.5, 40}, {0.35, 0.3, 0.25, 0.2}, 4};
constexpr Rgb kSoil{125, 102, 80}, kGrass{92, 112, 68}, kPadColour{95, 105, 125}, kPadMarking{232, 232, 226};

// Jittered-grid Voronoi: the value in [-1, 1) of the cell whose feature point is nearest to (x, y)
// (feature points jittered within [0.1, 0.9] of their unit cell, so the 3 x 3 neighbourhood holds the
// nearest one).
double voronoi_cell_value(double x, double y, uint64_t seed) {
  const auto ix = static_cast<int64_t>(std::floor(x)), iy = static_cast<int64_t>(std::floor(y));
  double best = std::numeric_limits<double>::infinity(), value = 0;
  for (int64_t dy = -1; dy <= 1; ++dy) {
    for (int64_t dx = -1; dx <= 1; ++dx) {
      const int64_t cx = ix + dx, cy = iy + dy;
      const uint64_t h = mix64(static_cast<uint64_t>(cx) * 0x9E3779B97F4A7C15ull ^ mix64(static_cast<uint64_t>(cy) ^ seed));
      const double px = static_cast<double>(cx) + 0.1 + 0.8 * static_cast<double>(h & 0xFFFF) / 65536.0;
      const double py = static_cast<double>(cy) + 0.1 + 0.8 * static_cast<double>((h >> 16) & 0xFFFF) / 65536.0;
      const double d2 = (px - x) * (px - x) + (py - y) * (py - y);
      if (d2 < best) {
        best = d2;
        value = static_cast<double>(h >> 40) * (2.0 / 16777216.0) - 1.0;
      }
    }
  }
  return value;
}

bool on_pad_marking(double x, double y) {
  const double half = kPadSide_m / 2;
  if (half - std::max(std::abs(x), std::abs(y)) < kPadBorder_m) return true;  // border
  const double ax = std::abs(x), ay = std::abs(y);
  const bool bar = ax >= 0.09 && ax <= 0.15 && ay <= 0.20;  // the H's two uprights (along Y), 0.3 x 0.4 m
  const bool cross = ax < 0.09 && ay <= 0.03;                // and its crossbar
  return bar || cross;
}

// The colour of the ground at (x, y) (ground frame, metres) for a pixel footprint of footprint_m.
Rgb ground_albedo(double x, double y, double footprint_m, uint64_t seed) {
  double stones = 0;
  for (int k = 0; k < 5; ++k) {
    const double weight = octave_weight(kStones.cells_m[k], footprint_m);
    if (weight > 0) {
      stones += weight * kStones.amplitudes[k] *
                voronoi_cell_value(x / kStones.cells_m[k], y / kStones.cells_m[k], seed + 6151u * static_cast<uint64_t>(k + 1));
    }
  }
  const double half = kPadSide_m / 2;
  if (std::abs(x) <= half && std::abs(y) <= half) {  // the pad: a mat, textured like the ground, with an H
    return on_pad_marking(x, y) ? kPadMarking * (0.9 + 0.1 * stones) : kPadColour * (1.0 + stones);
  }
  const double grass = std::clamp(0.5 + texture(kPatches, x, y, seed + 505, footprint_m), 0.0, 1.0);
  return (kSoil * (1 - grass) + kGrass * grass) * (1.0 + stones);
}

double minimum_jerk(double tau) {
  tau = std::clamp(tau, 0.0, 1.0);
  return tau * tau * tau * (10 - 15 * tau + 6 * tau * tau);
}
constexpr double kMinimumJerkPeakOverMean = 1.875;  // s'(1/2) = 30/16

// The left camera's pose for a rig centre and yaw (see the header for the axes).
Eigen::Isometry3d left_camera_pose(const Eigen::Vector3d& rig_m, double yaw_rad, double baseline_m) {
  const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
  Eigen::Matrix3d rotation;
  rotation.col(0) = Eigen::Vector3d(c, s, 0);
  rotation.col(1) = Eigen::Vector3d(s, -c, 0);
  rotation.col(2) = Eigen::Vector3d(0, 0, -1);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = rig_m - baseline_m / 2 * rotation.col(0);
  return pose;
}

}  // namespace

void validate_flight_options(const StereoFlightOptions& o) {
  synth_detail::validate_camera_and_sensor(o.width, o.height, o.hfov_deg, o.samples_per_axis, o.noise_sigma, o.right_gain, o.right_offset,
                                          o.threads);
  require(o.baseline_m > 0 && o.baseline_m <= 1, "baseline-m", "(0, 1] metres", o.baseline_m);
  require(o.altitude_m > 0 && o.altitude_m <= 20, "altitude-m", "(0, 20] metres", o.altitude_m);
  require(o.start_height_m >= 0.2 && o.start_height_m < o.altitude_m, "start-height-m",
          "[0.2, altitude " + std::to_string(o.altitude_m) + ") metres", o.start_height_m);
  require(o.side_m >= 1 && o.side_m <= 200, "side-m", "[1, 200] metres", o.side_m);
  require(o.speed_mps > 0 && o.speed_mps <= 20, "speed-mps", "(0, 20] m/s", o.speed_mps);
  require(o.climb_speed_mps > 0 && o.climb_speed_mps <= 5, "climb-speed-mps", "(0, 5] m/s", o.climb_speed_mps);
  require(o.yaw_rate_deg_s > 0 && o.yaw_rate_deg_s <= 360, "yaw-rate-deg-s", "(0, 360] degrees/s", o.yaw_rate_deg_s);
  for (double turn : o.corner_yaw_deg) require(std::abs(turn) <= 360, "yaw", "corner turns within +-360 degrees", turn);
  require(std::abs(o.continuous_yaw_deg_s) <= 90, "yaw", "a continuous rate within +-90 degrees/s", o.continuous_yaw_deg_s);
  require(o.frames == 0 || (o.frames >= 2 && o.frames <= 1000000), "frames", "2..1000000 (or 0: from --fps)", o.frames);
  require(o.fps > 0 && o.fps <= 1000, "fps", "(0, 1000] frames per second", o.fps);
}

FlightPlan plan_flight(const StereoFlightOptions& options) {
  validate_flight_options(options);
  FlightPlan plan;
  const double half = options.side_m / 2, altitude = options.altitude_m;
  const double corners[4][2] = {{half, half}, {-half, half}, {-half, -half}, {half, -half}};
  for (int i = 0; i < 4; ++i) plan.waypoints_m[i] = Eigen::Vector3d(corners[i][0], corners[i][1], altitude);

  Eigen::Vector3d here(0, 0, options.start_height_m);
  double yaw = 0, time = 0;
  auto add_leg = [&](const std::string& name, const Eigen::Vector3d& to, double to_yaw, double duration_s) {
    if (!(duration_s > 0)) return;
    plan.legs.push_back({name, time, time + duration_s, here, to, yaw, to_yaw});
    time += duration_s;
    here = to;
    yaw = to_yaw;
  };
  auto move = [&](const std::string& name, const Eigen::Vector3d& to, double peak_speed_mps) {
    add_leg(name, to, yaw, kMinimumJerkPeakOverMean * (to - here).norm() / peak_speed_mps);
  };
  move("take-off", Eigen::Vector3d(0, 0, altitude), options.climb_speed_mps);
  for (int i = 0; i < 4; ++i) {
    const std::string waypoint = "waypoint " + std::to_string(i + 1);
    move(waypoint, plan.waypoints_m[i], options.speed_mps);
    if (options.yaw_mode == FlightYawMode::corners) {
      const double turn_rad = options.corner_yaw_deg[i] * kPi / 180;
      add_leg("turn at " + waypoint, here, yaw + turn_rad, kMinimumJerkPeakOverMean * std::abs(turn_rad) / (options.yaw_rate_deg_s * kPi / 180));
    }
  }
  move("return", Eigen::Vector3d(0, 0, altitude), options.speed_mps);
  move("landing", Eigen::Vector3d(0, 0, options.start_height_m), options.climb_speed_mps);
  plan.duration_s = time;

  if (options.frames > 0) {
    for (int i = 0; i < options.frames; ++i) plan.frame_times_s.push_back(plan.duration_s * i / (options.frames - 1));
  } else {
    const auto count = static_cast<int64_t>(std::ceil(plan.duration_s * options.fps - 1e-9)) + 1;
    for (int64_t i = 0; i < count; ++i) plan.frame_times_s.push_back(static_cast<double>(i) / options.fps);
  }
  return plan;
}

FlightState flight_state_at(const StereoFlightOptions& options, const FlightPlan& plan, double time_s) {
  FlightState state;
  state.time_s = time_s;
  const double t = std::clamp(time_s, 0.0, plan.duration_s);
  const FlightLeg* leg = &plan.legs.back();
  for (const FlightLeg& candidate : plan.legs) {
    if (t <= candidate.end_s) {
      leg = &candidate;
      break;
    }
  }
  const double s = minimum_jerk((t - leg->start_s) / (leg->end_s - leg->start_s));
  state.rig_m = leg->from_m + s * (leg->to_m - leg->from_m);
  state.yaw_rad = leg->from_yaw_rad + s * (leg->to_yaw_rad - leg->from_yaw_rad);
  if (options.yaw_mode == FlightYawMode::continuous) {
    // The integral of a rate envelope that ramps linearly 0 -> 1 over r, stays 1, ramps 1 -> 0 over
    // the last r (r shrinks for a flight shorter than two ramps, which only extreme speeds give).
    const double end = plan.duration_s, r = std::min(kContinuousYawRamp_s, end / 2);
    double integral = t - r / 2;
    if (t < r) integral = t * t / (2 * r);
    if (t > end - r) integral = (end - r) - (end - t) * (end - t) / (2 * r);
    state.yaw_rad = options.continuous_yaw_deg_s * kPi / 180 * integral;
  }
  state.left_camera = left_camera_pose(state.rig_m, state.yaw_rad, options.baseline_m);
  state.height_m = state.left_camera.translation().z();
  return state;
}

FlightState flight_state_at_pose(const StereoFlightOptions& options, const Eigen::Vector3d& rig_m, double yaw_rad) {
  FlightState state;
  state.rig_m = rig_m;
  state.yaw_rad = yaw_rad;
  state.left_camera = left_camera_pose(rig_m, yaw_rad, options.baseline_m);
  state.height_m = state.left_camera.translation().z();
  return state;
}

double flight_focal_px(const StereoFlightOptions& options) {
  return options.width / 2.0 / std::tan(options.hfov_deg * kPi / 360.0);
}

StereoFlightFrame render_flight_frame(const StereoFlightOptions& options, const FlightState& state, int frame_index) {
  validate_flight_options(options);
  const int width = options.width, height = options.height, samples = options.samples_per_axis;
  const double focal = flight_focal_px(options), cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
  const Eigen::Matrix3d rotation = state.left_camera.linear();
  const Eigen::Vector3d centres[2] = {state.left_camera.translation(),
                                      state.left_camera.translation() + options.baseline_m * rotation.col(0)};
  const uint64_t seed = options.seed;
  const uint64_t noise_seed = mix64(uint64_t{options.seed} * 0x2545F4914F6CDD1Dull + static_cast<uint64_t>(frame_index));
  const synth_detail::SensorModel sensors[2] = {{options.noise_sigma, 1.0, 0.0},
                                                {options.noise_sigma, options.right_gain, options.right_offset}};
  StereoFlightFrame frame;
  cv::Mat views[2] = {cv::Mat(height, width, CV_8UC1), cv::Mat(height, width, CV_8UC1)};
  // The camera looks straight down at the plane Z = 0 and stays level: every ray (scaled to camera
  // depth 1) meets the ground at camera depth = the camera's height, the same for every pixel.
  const double depth_m = centres[0].z();
  frame.disparity_px = cv::Mat(height, width, CV_32FC1, cv::Scalar(static_cast<float>(focal * options.baseline_m / depth_m)));

  auto render_row = [&](int v) {
    std::vector<Rgb> row(static_cast<size_t>(width));
    for (int view = 0; view < 2; ++view) {
      const Eigen::Vector3d& centre = centres[view];
      for (int u = 0; u < width; ++u) {
        Rgb sum;
        for (int j = 0; j < samples; ++j) {
          for (int i = 0; i < samples; ++i) {
            const double x = (u + (i + 0.5) / samples - 0.5 - cx) / focal, y = (v + (j + 0.5) / samples - 0.5 - cy) / focal;
            const Eigen::Vector3d direction = rotation * Eigen::Vector3d(x, y, 1);  // direction.z() = -1
            const double t = centre.z();
            const double length = std::sqrt(x * x + y * y + 1);
            // Footprint as on the road: depth x length / f, widened by 1 / sqrt(cos) off the axis.
            const double footprint_m = t * length * std::sqrt(length) / focal;
            sum = sum + ground_albedo(centre.x() + t * direction.x(), centre.y() + t * direction.y(), footprint_m, seed);
          }
        }
        row[static_cast<size_t>(u)] = sum * (1.0 / (samples * samples));
      }
      synth_detail::expose_row(row.data(), width, sensors[view], noise_seed, view, v, views[view].ptr<uint8_t>(v), nullptr);
    }
  };
  synth_detail::render_rows(height, options.threads, render_row, {});
  frame.left = views[0];
  frame.right = views[1];
  return frame;
}

StereoCalibration flight_calibration(const StereoFlightOptions& options) {
  return synth_detail::pinhole_pair_calibration(options.width, options.height, flight_focal_px(options), (options.width - 1) / 2.0,
                                                (options.height - 1) / 2.0, options.baseline_m);
}

void write_stereo_flight(const std::string& directory, const StereoFlightOptions& options, bool write_disparity,
                         const std::function<void(double)>& progress) {
  const FlightPlan plan = plan_flight(options);
  synth_detail::write_folder_atomically(directory, [&](const std::filesystem::path& folder) {
    using synth_detail::number;
    for (const char* sub : {"left", "right"}) std::filesystem::create_directory(folder / sub);
    if (write_disparity) std::filesystem::create_directory(folder / "disparity");
    std::vector<Eigen::Isometry3d> poses;
    std::string times, heights;
    Eigen::Isometry3d first_inverse = Eigen::Isometry3d::Identity();
    const size_t count = plan.frame_times_s.size();
    for (size_t i = 0; i < count; ++i) {
      const FlightState state = flight_state_at(options, plan, plan.frame_times_s[i]);
      if (i == 0) first_inverse = state.left_camera.inverse();
      poses.push_back(first_inverse * state.left_camera);
      times += number(state.time_s) + "\n";
      heights += number(state.height_m) + "\n";
      const StereoFlightFrame frame = render_flight_frame(options, state, static_cast<int>(i));
      char name[32];
      std::snprintf(name, sizeof name, "%06zu.png", i);
      synth_detail::write_png(folder / "left" / name, frame.left);
      synth_detail::write_png(folder / "right" / name, frame.right);
      if (write_disparity) synth_detail::write_png(folder / "disparity" / name, synth_detail::kitti_disparity_truth(frame.disparity_px));
      if (progress) progress(static_cast<double>(i + 1) / static_cast<double>(count));
    }
    write_kitti_poses((folder / "poses.txt").string(), poses);
    synth_detail::write_text(folder / "times.txt", times);
    synth_detail::write_text(folder / "heights.txt", heights);

    const StereoCalibration calibration = flight_calibration(options);
    const double f = flight_focal_px(options), cx = calibration.left.cx_px, cy = calibration.left.cy_px;
    synth_detail::write_text(folder / "calib.txt", synth_detail::kitti_projection_line("P0", f, cx, cy, 0) +
                                                       synth_detail::kitti_projection_line("P1", f, cx, cy, options.baseline_m));
    write_opencv_yaml((folder / "calib.yaml").string(), calibration,
                      "lpstereo synth --flight: downward-looking rectified pinhole pair, baseline " + number(options.baseline_m) + " m");

    nlohmann::json json;
    json["width"] = options.width;
    json["height"] = options.height;
    json["focal_px"] = f;
    json["hfov_deg"] = options.hfov_deg;
    json["baseline_m"] = options.baseline_m;
    json["start_height_m"] = options.start_height_m;
    json["altitude_m"] = options.altitude_m;
    json["side_m"] = options.side_m;
    json["speed_mps"] = options.speed_mps;
    json["climb_speed_mps"] = options.climb_speed_mps;
    json["yaw_mode"] = options.yaw_mode == FlightYawMode::none ? "none" : options.yaw_mode == FlightYawMode::corners ? "corners" : "continuous";
    if (options.yaw_mode == FlightYawMode::corners) {
      json["corner_yaw_deg"] = {options.corner_yaw_deg[0], options.corner_yaw_deg[1], options.corner_yaw_deg[2], options.corner_yaw_deg[3]};
      json["yaw_rate_deg_s"] = options.yaw_rate_deg_s;
    }
    if (options.yaw_mode == FlightYawMode::continuous) json["continuous_yaw_deg_s"] = options.continuous_yaw_deg_s;
    json["frames"] = count;
    json["fps"] = options.frames > 0 ? (count - 1) / plan.duration_s : options.fps;
    json["duration_s"] = plan.duration_s;
    synth_detail::add_sensor_settings(json, options.samples_per_axis, options.noise_sigma, options.right_gain, options.right_offset,
                                      options.seed);
    json["ground_frame"] = "origin at the pad centre on the ground, Z up, X right and Y up in the first image, metres";
    json["camera_frame"] = "left camera: x right, y down, z forward (looking down), metres; poses.txt maps it into the first frame's";
    json["pad"] = {{"centre_m", {0, 0, 0}}, {"size_m", kPadSide_m}};
    const Eigen::Isometry3d first = first_inverse.inverse();
    json["start_rig_m"] = {0, 0, options.start_height_m};
    json["start_left_camera_m"] = {first.translation().x(), first.translation().y(), first.translation().z()};
    json["waypoints_m"] = nlohmann::json::array();
    json["waypoints_first_camera_m"] = nlohmann::json::array();
    for (const Eigen::Vector3d& w : plan.waypoints_m) {
      json["waypoints_m"].push_back({w.x(), w.y(), w.z()});
      const Eigen::Vector3d c = first_inverse * w;
      json["waypoints_first_camera_m"].push_back({c.x(), c.y(), c.z()});
    }
    json["legs"] = nlohmann::json::array();
    for (const FlightLeg& leg : plan.legs) {
      json["legs"].push_back({{"name", leg.name},
                              {"start_s", leg.start_s},
                              {"end_s", leg.end_s},
                              {"to_m", {leg.to_m.x(), leg.to_m.y(), leg.to_m.z()}},
                              {"to_yaw_deg", options.yaw_mode == FlightYawMode::continuous ? nlohmann::json()  // yaw follows the clock
                                                                                            : nlohmann::json(leg.to_yaw_rad * 180 / kPi)}});
    }
    synth_detail::write_text(folder / "flight.json", json.dump(2) + "\n");
  });
}

}  // namespace lpstereo::io
