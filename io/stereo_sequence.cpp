#include "io/stereo_sequence.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "io/kitti_poses.h"
#include "io/synth_render.h"

namespace lpstereo::io {

namespace {

using synth_detail::require;

// The camera's road-frame pose at time t: heading yaw0 + rate t; position integrated along the
// heading (forward (sin yaw, cos yaw) in X, Z): a straight line, or the arc of radius v / rate.
void camera_at(const StereoSequenceOptions& options, double t_s, double& x_m, double& z_m, double& yaw_rad) {
  const StereoSynthOptions& b = options.base;
  const double v = options.camera_speed_mps, rate = options.yaw_rate_rad_s;
  yaw_rad = b.camera_yaw_rad + rate * t_s;
  if (rate == 0) {
    x_m = b.camera_x_m + v * t_s * std::sin(b.camera_yaw_rad);
    z_m = b.camera_z_m + v * t_s * std::cos(b.camera_yaw_rad);
  } else {
    x_m = b.camera_x_m + v / rate * (std::cos(b.camera_yaw_rad) - std::cos(yaw_rad));
    z_m = b.camera_z_m + v / rate * (std::sin(yaw_rad) - std::sin(b.camera_yaw_rad));
  }
}

}  // namespace

Eigen::Isometry3d road_from_camera(const SynthCameraPose& pose) {
  Eigen::Isometry3d result = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) result.linear()(i, j) = pose.rotation[i][j];
    result.translation()(i) = pose.centre_m[i];
  }
  return result;
}

Eigen::Isometry3d camera_previous_from_current(const SynthCameraPose& previous, const SynthCameraPose& current) {
  return road_from_camera(previous).inverse() * road_from_camera(current);
}

StereoSynthOptions sequence_frame_options(const StereoSequenceOptions& options, int frame) {
  StereoSynthOptions result = options.base;
  const double t_s = frame / options.fps;
  double yaw = 0;
  camera_at(options, t_s, result.camera_x_m, result.camera_z_m, yaw);
  // Keep the heading within [-pi, pi] (the options' range) for long turning sequences.
  result.camera_yaw_rad = std::remainder(yaw, 2 * synth_detail::kPi);
  for (const SynthMovingObject& moving : options.moving) {
    SynthObject object = moving.object;
    object.x_m += moving.velocity_x_mps * t_s;
    object.z_m += moving.velocity_z_mps * t_s;
    result.objects.push_back(object);
  }
  return result;
}

void validate_stereo_sequence(const StereoSequenceOptions& options) {
  require(options.camera_speed_mps >= 0 && options.camera_speed_mps <= 60, "camera-speed-mps", "[0, 60] m/s", options.camera_speed_mps);
  require(std::abs(options.yaw_rate_rad_s) <= 1, "yaw-rate", "|rate| <= 1 rad/s", options.yaw_rate_rad_s);
  require(options.fps > 0 && options.fps <= 1000, "fps", "(0, 1000] frames per second", options.fps);
  require(options.frames >= 1 && options.frames <= 100000, "frames", "[1, 100000]", options.frames);
  for (const SynthMovingObject& moving : options.moving) {
    const double speed = std::hypot(moving.velocity_x_mps, moving.velocity_z_mps);
    require(speed <= 100, std::string("moving ") + synth_class_name(moving.object.object_class) + " speed", "<= 100 m/s", speed);
  }
  // The camera and the objects move on straight lines or an arc: checking the first and the last
  // frame bounds every object's z (linear in t); the camera's z on an arc is checked per frame.
  validate_synth_options(sequence_frame_options(options, 0));
  validate_synth_options(sequence_frame_options(options, options.frames - 1));
  if (options.yaw_rate_rad_s != 0) {
    for (int frame = 1; frame + 1 < options.frames; ++frame) validate_synth_options(sequence_frame_options(options, frame));
  }
}

StereoSequenceFrame render_sequence_frame(const StereoSequenceOptions& options, int frame) {
  const StereoSynthOptions frame_options = sequence_frame_options(options, frame);
  StereoSequenceFrame result;
  result.scene = render_stereo_synth(frame_options);
  result.pose = synth_camera_pose(frame_options);
  const size_t static_count = options.base.objects.size();
  for (size_t i = 0; i < result.scene.objects.size(); ++i) {
    SequenceObjectTruth truth;
    truth.truth = result.scene.objects[i];
    if (i >= static_count) {
      const SynthMovingObject& moving = options.moving[i - static_count];
      truth.moving = true;
      // Camera axes: v_camera = R^T v_road (R = camera-to-road rotation).
      const double road[3] = {moving.velocity_x_mps, 0, moving.velocity_z_mps};
      for (int j = 0; j < 3; ++j) {
        truth.velocity_mps[j] = 0;
        for (int k = 0; k < 3; ++k) truth.velocity_mps[j] += result.pose.rotation[k][j] * road[k];
      }
    }
    result.objects.push_back(truth);
  }
  return result;
}

namespace {

nlohmann::json frame_truth_json(int frame, const StereoSequenceFrame& rendered) {
  nlohmann::json line;
  line["frame"] = frame;
  line["objects"] = nlohmann::json::array();
  for (const SequenceObjectTruth& object : rendered.objects) {
    const SynthObjectTruth& t = object.truth;
    nlohmann::json o;
    o["id"] = t.id;
    o["class"] = synth_class_name(t.object.object_class);
    o["position_m"] = {t.position_m[0], t.position_m[1], t.position_m[2]};
    o["size_m"] = {{"w", t.object.width_m}, {"h", t.object.height_m}, {"l", t.object.length_m}};
    o["min_height_m"] = t.min_height_m;
    o["max_height_m"] = t.max_height_m;
    o["velocity_mps"] = {object.velocity_mps[0], object.velocity_mps[1], object.velocity_mps[2]};
    o["moving"] = object.moving;
    o["bbox_px"] = t.visible_pixels > 0 ? nlohmann::json{t.bbox_px[0], t.bbox_px[1], t.bbox_px[2], t.bbox_px[3]} : nlohmann::json();
    o["visible_pixels"] = t.visible_pixels;
    line["objects"].push_back(o);
  }
  return line;
}

std::string frame_name(int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "%06d.png", frame);
  return name;
}

}  // namespace

void write_stereo_sequence(const std::string& directory, const StereoSequenceOptions& options,
                           const std::function<void(double)>& progress) {
  validate_stereo_sequence(options);
  using synth_detail::number;
  using synth_detail::write_png;
  using synth_detail::write_text;
  synth_detail::write_folder_atomically(directory, [&](const std::filesystem::path& folder) {
    const bool colour = options.base.colour;
    for (const char* sub : {"left", "right", "disparity", "object_ids"}) std::filesystem::create_directories(folder / sub);
    if (colour) {
      std::filesystem::create_directories(folder / "left_colour");
      std::filesystem::create_directories(folder / "right_colour");
    }
    std::vector<Eigen::Isometry3d> poses;
    Eigen::Isometry3d first_inverse = Eigen::Isometry3d::Identity();
    std::string truth_lines, times;
    StereoSynthScene first;
    for (int frame = 0; frame < options.frames; ++frame) {
      const StereoSequenceFrame rendered = render_sequence_frame(options, frame);
      const std::string name = frame_name(frame);
      write_png(folder / "left" / name, rendered.scene.left);
      write_png(folder / "right" / name, rendered.scene.right);
      if (colour) {
        write_png(folder / "left_colour" / name, rendered.scene.left_colour);
        write_png(folder / "right_colour" / name, rendered.scene.right_colour);
      }
      write_png(folder / "disparity" / name, synth_detail::kitti_disparity_truth(rendered.scene.disparity_px));
      write_png(folder / "object_ids" / name, rendered.scene.object_ids);
      const Eigen::Isometry3d camera_to_road = road_from_camera(rendered.pose);
      if (frame == 0) {
        first_inverse = camera_to_road.inverse();
        first = rendered.scene;
      }
      poses.push_back(first_inverse * camera_to_road);  // this frame's camera in the first's
      truth_lines += frame_truth_json(frame, rendered).dump() + "\n";
      times += number(frame / options.fps) + "\n";
      if (progress) progress(static_cast<double>(frame + 1) / options.frames);
    }
    write_kitti_poses((folder / "poses.txt").string(), poses);
    write_text(folder / "truth.jsonl", truth_lines);
    write_text(folder / "times.txt", times);

    const StereoSynthOptions& b = options.base;
    write_opencv_yaml((folder / "calib.yaml").string(), first.calibration,
                      "lpstereo synth --sequence: rectified pinhole pair, baseline " + number(b.baseline_m) + " m");
    const double f = first.focal_px, cx = first.calibration.left.cx_px, cy = first.calibration.left.cy_px;
    const std::string size = number(b.width) + " " + number(b.height) + "\n";
    write_text(folder / "calib_cam_to_cam.txt", "S_rect_02: " + size + synth_detail::kitti_projection_line("P_rect_02", f, cx, cy, 0) +
                                                     "S_rect_03: " + size +
                                                     synth_detail::kitti_projection_line("P_rect_03", f, cx, cy, b.baseline_m));
    write_text(folder / "calib.txt",
               synth_detail::kitti_projection_line("P0", f, cx, cy, 0) + synth_detail::kitti_projection_line("P1", f, cx, cy, b.baseline_m));

    nlohmann::json json;
    json["width"] = b.width;
    json["height"] = b.height;
    json["focal_px"] = f;
    json["baseline_m"] = b.baseline_m;
    json["hfov_deg"] = b.hfov_deg;
    json["camera_height_m"] = b.camera_height_m;
    json["pitch_rad"] = b.pitch_rad;
    json["roll_rad"] = b.roll_rad;
    json["camera_speed_mps"] = options.camera_speed_mps;
    json["yaw_rate_rad_s"] = options.yaw_rate_rad_s;
    json["fps"] = options.fps;
    json["frames"] = options.frames;
    json["ground"] = {{"hills_amplitude_m", b.ground.hills_amplitude_m}, {"ditch_depth_m", b.ground.ditch_depth_m},
                      {"berm_height_m", b.ground.berm_height_m}, {"rough_amplitude_m", b.ground.rough_amplitude_m}};
    synth_detail::add_sensor_settings(json, b.samples_per_axis, b.noise_sigma, b.right_gain, b.right_offset, b.seed);
    synth_detail::add_surface_and_lens_settings(json, synth_road_surface_name(b.road_surface), b.vignetting,
                                                b.vignetting * kRightVignettingRatio, b.blur_sigma_px);
    json["camera_frame"] = "left camera: x right, y down, z forward, metres; poses.txt maps it into the first frame's";
    json["truth"] = "truth.jsonl: per frame, position_m = base centre in that frame's left camera frame, velocity_mps = world "
                    "velocity in that frame's camera axes, min/max_height_m above the ground under the base centre";
    nlohmann::json objects = nlohmann::json::array();
    const size_t static_count = b.objects.size();
    const StereoSynthOptions frame0 = sequence_frame_options(options, 0);
    for (size_t i = 0; i < frame0.objects.size(); ++i) {
      const SynthObject& o = frame0.objects[i];
      nlohmann::json item{{"id", i + 1}, {"class", synth_class_name(o.object_class)}, {"road_position_m", {o.x_m, o.z_m}}};
      if (i >= static_count) {
        item["road_velocity_mps"] = {options.moving[i - static_count].velocity_x_mps, options.moving[i - static_count].velocity_z_mps};
      }
      objects.push_back(item);
    }
    json["objects_at_frame_0"] = objects;
    write_text(folder / "sequence.json", json.dump(2) + "\n");
  });
}

StereoSequenceOptions preset_stereo_sequence(const std::string& name, uint32_t seed) {
  StereoSequenceOptions options;
  StereoSynthOptions& b = options.base;
  b.width = 640;
  b.height = 480;
  b.seed = seed;
  b.background_distance_m = 1000;  // room to drive: the camera and an oncoming car stay before it for tens of seconds
  synth_detail::SplitMix random{uint64_t{seed} * 0x632BE59BD9B4E5ull + 0x51};
  auto jitter = [&](double metres) { return random.uniform(-metres, metres); };
  auto place = [&](SynthClass object_class, double x_m, double z_m) {
    b.objects.push_back(synth_object(object_class, x_m + jitter(0.5), z_m + jitter(2.0)));
  };
  auto move = [&](SynthClass object_class, double x_m, double z_m, double velocity_x_mps, double velocity_z_mps) {
    options.moving.push_back({synth_object(object_class, x_m + jitter(0.3), z_m + jitter(2.0)), velocity_x_mps, velocity_z_mps});
  };
  if (name == "urban") {
    options.camera_speed_mps = 8;
    place(SynthClass::car, -4.2, 28);  // parked
    place(SynthClass::bin, 4.6, 20);
    place(SynthClass::cone, 1.2, 35);
    place(SynthClass::cone, 1.6, 38);
    place(SynthClass::box, -1.0, 55);
    move(SynthClass::pedestrian, -5.5, 30, 1.5, 0);  // crossing left to right
    move(SynthClass::pedestrian, 5.5, 45, -1.3, 0);  // right to left
    move(SynthClass::car, 0, 25, 0, 10);             // ahead in the lane, a little faster than the camera
    move(SynthClass::car, -3.5, 320, 0, -10);        // oncoming in the left lane (still at z > 0 after 30 s)
  } else if (name == "country") {
    options.camera_speed_mps = 12;
    b.ground.hills_amplitude_m = 0.6;
    place(SynthClass::cone, 2.0, 30);
    place(SynthClass::box, -1.5, 45);
    place(SynthClass::bin, 4.8, 60);
    move(SynthClass::pedestrian, 5.5, 50, -1.5, 0);
    move(SynthClass::car, -3.5, 380, 0, -12);  // oncoming (still at z > 0 after 30 s)
  } else if (name == "mining") {
    options.camera_speed_mps = 5;
    b.ground.rough_amplitude_m = 0.25;
    b.ground.berm_height_m = 0.8;
    place(SynthClass::box, 1.5, 18);
    place(SynthClass::bin, -2.5, 26);
    place(SynthClass::box, -0.5, 40);
    place(SynthClass::tape_roll, 0.8, 12);
    move(SynthClass::pedestrian, 4.5, 25, -1.2, 0);
    SynthObject truck = synth_object(SynthClass::car, 0, 35);
    truck.width_m = 3.0, truck.height_m = 3.0, truck.length_m = 8.0;  // a haul truck as a box
    options.moving.push_back({truck, 0, 6});
  } else if (name == "floating") {
    options.camera_speed_mps = 5;
    place(SynthClass::board_on_poles, 0, 20);
    place(SynthClass::hanging_sign, -1.0, 30);
    place(SynthClass::ball_on_post, 2.0, 15);
    place(SynthClass::board_on_poles, -3.0, 42);
    move(SynthClass::pedestrian, 5.0, 35, -1.5, 0);
  } else {
    throw std::invalid_argument("sequence: expected urban, country, mining or floating, got '" + name + "'");
  }
  return options;
}

}  // namespace lpstereo::io
