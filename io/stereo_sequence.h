// A synthetic stereo sequence on the road (docs/synth.md): the road scene of io/stereo_synth.h
// rendered frame by frame while the camera drives through a fixed world (the ground's texture,
// height field and static objects stay put) and moving objects (pedestrians crossing, cars driving)
// advance at constant world velocities; exact ground truth per frame. For issue 10's evaluations of
// the obstacle detector and tracker on sequences (urban, country, mining, floating objects).
//
// Motion: at frame n (time t = n / fps) the camera heading is yaw0 + yaw_rate t and the camera centre
// moves along the heading at camera_speed_mps (a circle arc when yaw_rate != 0, a straight line
// otherwise), from the base options' camera_x_m / camera_z_m / camera_yaw_rad; it stays
// camera_height_m above the ground under it with the base pitch and roll. A moving object's base
// centre is its frame-0 position + velocity t (road frame); its id follows the static objects'.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "io/stereo_synth.h"

namespace lpstereo::io {

struct SynthMovingObject {
  SynthObject object;        // at frame 0, road frame
  double velocity_x_mps = 0;  // road frame: + = to the right
  double velocity_z_mps = 0;  // road frame: + = forward along the road
};

struct StereoSequenceOptions {
  StereoSynthOptions base;  // camera, sensor, ground, static objects (base.objects), frame 0's camera pose
  std::vector<SynthMovingObject> moving;
  double camera_speed_mps = 8;    // forward along the heading, [0, 60]
  double yaw_rate_rad_s = 0;      // |rate| <= 1
  double fps = 10;                // (0, 1000]
  int frames = 20;                // [1, 100000]
};

// Throws std::invalid_argument "<option>: expected ..., got ..." (the base's checks too, for the
// first and the last frame: every object must stay between the camera's road origin and the
// background, z in (0, background)).
void validate_stereo_sequence(const StereoSequenceOptions& options);

// The options of frame n alone (camera pose, every object where it is then, moving ones after the
// static ones).
StereoSynthOptions sequence_frame_options(const StereoSequenceOptions& options, int frame);

struct SequenceObjectTruth {
  SynthObjectTruth truth;    // position_m in this frame's left camera frame, bbox, visible pixels ...
  double velocity_mps[3] = {0, 0, 0};  // the object's world velocity in this frame's camera axes
  bool moving = false;
};

struct StereoSequenceFrame {
  StereoSynthScene scene;
  SynthCameraPose pose;  // the left camera in the road frame
  std::vector<SequenceObjectTruth> objects;
};

StereoSequenceFrame render_sequence_frame(const StereoSequenceOptions& options, int frame);

// A pose as a transform: p_road = R p_camera + c.
Eigen::Isometry3d road_from_camera(const SynthCameraPose& pose);

// The camera's motion between two frames as the obstacle methods take ego-motion: maps the current
// camera frame's coordinates into the previous one's (road_from_camera(previous)^-1
// road_from_camera(current)).
Eigen::Isometry3d camera_previous_from_current(const SynthCameraPose& previous, const SynthCameraPose& current);

// Renders every frame and writes `directory` (replaced only when every file is written; nothing left
// on failure): left/%06d.png, right/%06d.png (grey), left_colour/, right_colour/ (when
// base.colour), disparity/%06d.png (KITTI 16-bit), object_ids/%06d.png (16-bit), poses.txt (KITTI:
// each frame's left camera in the first frame's), times.txt, calib.yaml, calib_cam_to_cam.txt,
// calib.txt (KITTI odometry P0 P1), truth.jsonl (one line per frame: {"frame", "objects": [{"id",
// "class", "position_m", "size_m", "min_height_m", "max_height_m", "velocity_mps", "moving",
// "bbox_px", "visible_pixels"}]}), sequence.json (the settings). `progress` gets the fraction of
// frames done.
void write_stereo_sequence(const std::string& directory, const StereoSequenceOptions& options,
                           const std::function<void(double)>& progress = {});

// Preset scenes for issue 10's evaluations: "urban" (flat road: parked car, bin, cones, two
// pedestrians crossing, a car ahead and one oncoming), "country" (rolling hills: cones, a box,
// a pedestrian crossing, an oncoming car), "mining" (rough ground and a berm: boxes, bins, a truck-
// sized box ahead, a pedestrian), "floating" (flat: a board on two poles, a hanging sign, a ball on
// a post, a pedestrian crossing). Positions jitter with the seed. Every preset is valid for at least
// 300 frames at its 10 fps (issue 10's sequences; the oncoming cars start far enough to stay on the
// road, z > 0, for 30 s). Throws std::invalid_argument
// "sequence: expected urban, country, mining or floating, got '<name>'".
StereoSequenceOptions preset_stereo_sequence(const std::string& name, uint32_t seed);

}  // namespace lpstereo::io
