// The obstacle detector after the disparity map (issue 6; thesis 003 chapter 4) as a small API, in
// the DisparityEngine's style: one parameters struct, a graph built in C++ by a static graph_spec(),
// verified once, run frame after frame with the ARM-side scheduler.
//
// The graph (input "disparity", s16 Q4, the DisparityEngine's output):
//   v_disparity (vector)              "disparity" -> "vdisp" (u16 num_bins x H)
//   road_profile (ARM)                "vdisp" + "road" of the previous frame (delayed edge) -> "road"
//   vldh_mask (vector)                "disparity" + "road" -> "mask" (u8, kernels/obstacle_mask.h)
//   advanced_u_disparity (vector)     "disparity" + "mask" -> "grid" (u16, grid_columns x grid_rows)
//   obstacle_clusters (ARM)           "grid" + "disparity" + "mask" -> "clusters" (records)
//   harris_response, harris_nms (vector), select_keypoints (ARM)
//                                     graph input "left" (u8) -> "keypoints" (with feature_validation)
//   obstacle_feature_validation (ARM, only with feature_validation = true, the default)
//                                     "clusters" + "keypoints" + "mask" -> "obstacles"
//   obstacle_tracker (ARM, only with tracking = true)
//                                     "validated" + "tracks" of the previous frame (delayed edge)
//                                     -> "obstacles" (tracked) + "tracks" (arm/tasks/obstacle_tracker.h)
// Without feature validation obstacle_clusters writes the stage's result directly. The last stage
// present writes "obstacles": validation's "validated" feeds the tracker with tracking on. Outputs:
// "obstacles" (kObstacleWords x max_obstacles s32, arm/tasks/obstacle_record.h; with tracking the
// track id, age and velocity filled), "road" (arm/tasks/road_profile.h), "vdisp", "mask", "grid" (for
// pictures), and "tracks" with tracking.
//
// Feature validation needs "keypoints" (arm/tasks/keypoint_record.h) from the left image:
// add_keypoint_nodes() adds the Harris nodes of graphs/features.json. A cluster is kept when a corner
// stands on (within mask_radius_px of) one of its obstacle-mask pixels (thesis 003 §4.2.4, fig. 4.8).
//
// Defaults: ObstacleParameters is the single source for the detector, the CLI and graphs built from
// it; it aggregates the stage settings of arm/tasks/obstacle_clusters.h (which the ARM tasks also use
// as their own defaults) and writes every value into the graph. road_profile's tuning stays the
// task's own (arm/tasks/road_profile.cpp): the graph passes only the camera and the map's range.
#pragma once

#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arm/disparity_engine.h"
#include "arm/tasks/obstacle_clusters.h"
#include "arm/tasks/obstacle_record.h"
#include "arm/tasks/obstacle_tracker.h"
#include "arm/tasks/road_profile.h"
#include "dag/graph.h"
#include "dag/plane.h"

namespace lpstereo::arm {

class FrameRunner;

// vldh_mask's parameters (kernels/vldh_mask.cpp documents each).
struct VldhSettings {
  // The kernel's own defaults, chosen on the 4K range test (docs/obstacles.md "Tuning"): 6
  // rows of one disparity within 6/16 px is more than the ~5-row plateaus of SGM's staircase on a road
  // sloping 0.2 px per row, and no more than a 0.07 m object at 40 m shows (5.8 rows). A margin of
  // 2/16 px + 0.5 % over a road line fitted on hundreds of rows; the vertical test keeps the road out.
  int window_rows = 6;             // N: rows below a pixel (itself included) that may share its disparity
  int match_tolerance_q4 = 6;      // |D(u, v + j) - D(u, v)| <= this counts (Q4)
  int min_count = 6;               // of the window_rows rows, this many must match
  int road_margin_q4 = 2;          // a pixel must stand this far above the road's disparity (Q4) ...
  int road_margin_per_mille = 5;   // ... plus this share of the road's disparity
  int rows_above_horizon = 64;     // rows above the horizon that may still hold obstacles
};

// The Harris corners that validate clusters (kernels/harris_response.cpp, harris_nms.cpp,
// arm/tasks/select_keypoints.cpp document each).
struct FeatureSettings {
  int harris_threshold = 3000;   // harris_nms: R above this (a step corner of about 25 grey levels; kernels/harris_nms.cpp)
  int cell_size_px = 32;         // select_keypoints: the strongest per_cell_k corners of every cell
  int per_cell_k = 4;
  int max_keypoints = 32768;
  int border_px = 2;
};

// The matcher the detector's defaults were chosen with (the 4K range test, docs/obstacles.md): the
// DisparityEngine's defaults (8-path SGM, census 5x5). The 9x7 census was tried: fewer artefacts
// above lane-marking dashes, but its wider window fattened far objects into the background (the
// cone's range fell from 100 to 75 m) and merged a bin and a pedestrian 1.2 m apart at 1280x576.
// `lpstereo obstacles` and the range test use it.
DisparityParameters obstacle_disparity_defaults();

inline constexpr int kMaxVDisparityBins = 128;  // for_disparity_range's cap (see there)

struct ObstacleParameters {
  // The rectified camera (from the calibration): focal length and baseline are required (> 0).
  double focal_px = 0.0;
  double baseline_m = 0.0;
  std::optional<double> principal_point_x_px;  // default: the image centre (W - 1) / 2
  std::optional<double> principal_point_y_px;  // default: (H - 1) / 2; also the road profile's v0
  // The disparity map's range, as the DisparityEngine searched it: bin 0 of the V-disparity, the
  // invalid value (min_disparity - 1) * 16, and the grid's top (see for_disparity_range).
  int min_disparity = 0;
  int v_disparity_bins = 128;      // V-disparity bins, 1 px each from min_disparity
  // The V-disparity (and so the road fit) starts at max(min_disparity, road_min_disparity_px): the
  // sky and the far background (d < 2 px, beyond f B / 2) cannot define the road line, and their
  // near-zero bins, one per row over the whole upper image, let RANSAC fit a near-vertical line
  // through them (bin noise 0 / 1 px gives it a slope > 0) that beats the road and then fails the
  // height gate: no road at all (seen on `lpstereo synth` scenes). v_disparity allows a larger
  // min_disparity than the map's (it only drops the near-zero bins).
  int road_min_disparity_px = 2;
  int v_disparity_min_px() const { return std::max(min_disparity, road_min_disparity_px); }
  int v_disparity_bin_count() const { return std::max(1, v_disparity_bins - (v_disparity_min_px() - min_disparity)); }
  VldhSettings vldh;
  AudGridSettings grid;
  int grid_tile_columns = 16;      // advanced_u_disparity's tile width in cells (a 4K frame must not sit in SRAM)
  ObstacleClusterSettings clusters;
  // Feature validation (thesis 003 §4.2.4): a cluster without a Harris corner standing on its
  // obstacle pixels is dropped. Off: every cluster is kept (the left view is not read).
  bool feature_validation = true;
  FeatureSettings features;
  FeatureValidationSettings validation;
  // Tracking across frames (thesis 003 §4.2.4; arm/tasks/obstacle_tracker.cpp, docs/obstacles.md
  // "Tracking"): off, every run() is a single frame and the records' track fields stay 0. On, each
  // run() is the next frame of one sequence, frame_period_s apart: the tracker keeps its state on a
  // delayed edge and fills track_id, track_age_frames and velocity_mps.
  bool tracking = false;
  TrackerSettings tracking_settings;

  // These parameters with the V-disparity bins and the grid's top disparity set to the search
  // range [min_disparity, min_disparity + num_disparities) px.
  ObstacleParameters for_disparity_range(int min_disparity_px, int num_disparities) const;
};

// One line naming every setting, for reports and benchmarks ("VLDH 6 rows, 6 matching within 6/16 px, ...").
std::string settings_text(const ObstacleParameters& parameters);

// One frame's results. The planes are the detector's buffers: valid until the next run().
struct ObstacleFrame {
  RoadProfile road;
  std::vector<Obstacle> obstacles;
  const Plane* vdisp = nullptr;  // u16 v_disparity_bins x H
  const Plane* mask = nullptr;   // u8 W x H
  const Plane* grid = nullptr;   // u16 grid_columns x grid_rows
};

class ObstacleDetector {
 public:
  // Builds and verifies the graph for width x height disparity maps. Throws std::invalid_argument
  // (a parameter out of range, naming it, the expected and the actual value) or VerifyError.
  ObstacleDetector(int width, int height, const ObstacleParameters& parameters, const MemoryBudget& memory = {},
                   int worker_threads = 0);
  ~ObstacleDetector();
  ObstacleDetector(const ObstacleDetector&) = delete;
  ObstacleDetector& operator=(const ObstacleDetector&) = delete;

  // disparity: s16 Q4 of the detector's size (the DisparityEngine's output); left: the u8 left view,
  // same size (read only with feature validation). The road carries over frames (delayed edge), and
  // with tracking so do the tracks: obstacles then hold the tracked records.
  ObstacleFrame run(const Plane& disparity, const Plane& left);

  const ObstacleParameters& parameters() const { return parameters_; }
  const Graph& graph() const { return *graph_; }

  static GraphSpec graph_spec(const ObstacleParameters& parameters);

 private:
  ObstacleParameters parameters_;
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<FrameRunner> runner_;
};

// The feature stage: adds to `spec` the nodes that turn the graph input "left" (u8) into the buffer
// "keypoints" (arm/tasks/keypoint_record.h): harris_response, harris_nms, select_keypoints.
void add_keypoint_nodes(GraphSpec& spec, const ObstacleParameters& parameters);

}  // namespace lpstereo::arm
