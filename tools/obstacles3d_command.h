// lpstereo obstacles3d --left 'dir/%06d.png' --right 'dir/%06d.png' --calib C [--calib C2]
//     --method polar|cartesian|coldisp|stixels|voxels -o tracks.jsonl [--view DIR]
//     [--first N] [--frames N] [--fps F] [--voxel-m S] [--obstacle-height-m H]
//     [--camera-height-m H] [--pitch-deg P] [--roll-deg R] [--threads N] [disparity engine options]
// Issue 10 deliverable 6: the 3D obstacle representations over a rectified sequence
// (docs/obstacles3d.md "lpstereo obstacles3d"). Per frame:
//   1. the pair through the disparity engine and disparity_to_points (camera frame), each point with
//      the left image's colour (the left file decoded as colour; grey files give equal channels);
//   2. the vehicle frame through the camera mount (tools/camera_mount_options.h); with none of
//      --camera-height-m, --pitch-deg, --roll-deg given, the mount is estimated from the ground plane
//      (arm::estimate_ground_mount, as `lpstereo terrain` does) of the first frame where it is found,
//      printed, and kept; frames before it have no candidates and their "status" says why;
//   3. the terrain (arm/terrain/terrain_model.h): the points into the 2.5D grid of the default
//      TerrainGridSpec (x 0..34 m forward, y -11..11 m), fit_terrain, classify_points with
//      --obstacle-height-m: the obstacle candidates are the outliers, each with its height above the
//      fitted surface; points outside the area are not candidates (counted in "status");
//   4. the ego-motion from the stereo visual odometry (arm/odometry/stereo_odometry.h), whose
//      increment E_c maps camera t coordinates to camera t-1 coordinates; with V = CameraToVehicle
//      (p_vehicle = V p_camera) the vehicle-frame increment is previous_from_current = V E_c V^-1.
//      The first frame has none; a frame whose odometry fails (valid = false) gets none: the methods
//      assume a static camera for it, and stderr says so once per run;
//   5. the method: polar / cartesian / coldisp (arm/obstacles3d/occupancy_grid.h), stixels
//      (augmented_stixels.h), voxels (voxel_map.h + voxel_clustering.h + obstacle_tracking.h).
// tracks.jsonl: one JSON object per input frame,
//   {"frame": n, "status": "...", "ego_motion": bool, "obstacles": [{"id", "track_id", "bbox_px":
//    [x0, y0, x1, y1], "position_m": [x, y, z], "size_m": [w, h, l], "min_height_m", "max_height_m",
//    "velocity_mps": [vx, vy, vz], "moving"}]}
// positions in that frame's camera frame, heights above the fitted terrain, velocities relative to
// the ground in the camera's axes. The grid and stixel methods do not track: track_id -1, velocity
// 0, moving false. Written atomically once every frame is done.
// --view DIR: per frame DIR/top_NNNNNN.png (metric top view: obstacle footprints, track ids, velocity
// arrows over 1 s), DIR/overlay_NNNNNN.png (left image: boxes, distance, track id, velocity arrow
// projected) and for the grid and stixel methods DIR/grid_NNNNNN.png (the representation's picture,
// io/obstacles3d_pictures.h).
// Bad input: an unknown method, --voxel-m outside [0.05, 0.5] m, --fps <= 0, missing first frame,
// a calibration without a baseline: one line, non-zero exit, no output file. An empty cloud, an
// unknown terrain, clipped points: the frame's "status" says so, exit 0.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "arm/obstacles3d/obstacle_candidates.h"
#include "tools/camera_mount_options.h"
#include "tools/disparity_options.h"

namespace lpstereo::tools {

class Obstacles3dCommand {
 public:
  explicit Obstacles3dCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run() const;  // throws CommandError (one line) on bad input

 private:
  CLI::App* command_ = nullptr;
  std::string left_pattern_, right_pattern_, output_, view_directory_;
  std::string method_ = "polar";
  std::vector<std::string> calibration_files_;
  int first_frame_ = 0;
  int frame_limit_ = 0;
  double fps_ = 10.0;
  double voxel_m_ = 0.25;
  double obstacle_height_m_ = 0.2;
  int acceptance_frames_ = 3;
  int threads_ = 2;
  CameraMountOptions mount_options_;
  DisparityEngineOptions engine_options_{arm::obstacles3d::obstacles3d_disparity_defaults()};
};

}  // namespace lpstereo::tools
