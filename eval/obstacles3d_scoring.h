// The scoring rules of bench/obstacles3d_eval (issue 10's acceptance: detection per object, the
// lower edge of a hanging object and the free space under it), apart from the program so that each
// rule is tested on hand-built cases (tests/eval/obstacles3d_scoring_test.cpp): the figures of
// docs/obstacles3d.md are only as good as these rules. The program keeps the tallies, the CSV logs
// and the printing.
//
// Frames: the truth's position_m is the object's base centre and an Obstacle3d's position_m its
// centre, both in the frame's left camera frame (x right, y down, z forward, metres); heights are
// above the ground (truth) or the fitted terrain (obstacle).
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "arm/obstacles3d/obstacle_points.h"
#include "io/stereo_synth.h"

namespace lpstereo::eval {

// ---- detection -------------------------------------------------------------------------------

// An object counts as detected in a frame when an obstacle's centre lies within its gate:
// |dx| <= 1 m + width / 2 and |dz| <= max(1 m, 3 sigma_Z(z)) + length / 2 (sigma_Z: the stereo
// error model's depth sigma at the object's depth, at least 0.1 m).
struct ObstacleGate {
  double lateral_m = 0;  // the largest |dx| in the gate
  double depth_m = 0;    // the largest |dz| in the gate
};
ObstacleGate gate_of(const io::SynthObjectTruth& object, const arm::obstacles3d::StereoErrorModel& error_model);
bool in_gate(const arm::obstacles3d::Obstacle3d& obstacle, const io::SynthObjectTruth& object, const ObstacleGate& gate);

// The hanging objects of io/stereo_synth.h: a board on two poles, a hanging sign, a ball on a post.
bool is_floating(io::SynthClass object_class);

// ---- what stereo can measure -----------------------------------------------------------------

// Per object id (the object_ids value), the pixels of the left view whose true disparity the engine
// can find: d in [min_disparity, min_disparity + num_disparities - 1] and u - d >= 0 (`in_range`),
// and of those the ones the right camera sees (`measurable`): no nearer surface covers the match
// x_r = u - d in the right view. A left pixel u' > u whose match u' - d' lies left of x_r crossed
// it and is nearer (d' > d), so the pixel is half-occluded when the smallest u' - d' over u' > u in
// its row is below x_r - 0.5 px (the same surface seen obliquely keeps u' - d' increasing); the
// occluder of a right-view pixel always shows in the left view or is itself covered there by a
// nearer one that passes the same test. No stereo method measures a half-occluded pixel; KITTI
// scores disparity on the non-occluded ones ("noc"). Sky (+inf) occludes nothing.
// lower_edge (with a LowerEdgeProbe): per hanging object, its measurable pixels whose true point lies
// in the hanging part's lowest kLowerEdgeBandM (height above the true ground within [edge, edge +
// band], road x within the part's width): whether its lower edge is seen at all.
struct MeasurablePixels {
  std::vector<int64_t> in_range, measurable, lower_edge;  // by object id; ids past the end: 0
  // Object pixels whose true disparity exceeds the search range (min_disparity + num_disparities -
  // 1): a surface nearer than the engine reaches. No stereo method of that range measures them, and
  // where they fill part of the view the matcher returns scattered wrong disparities instead.
  int64_t nearer_than_range = 0;
  int64_t measurable_of(int id) const;
  int64_t in_range_of(int id) const;
  int64_t lower_edge_of(int id) const;
};

// What the lower-edge count needs: the frame's geometry and, per object id, the hanging part's lateral
// span (road x) and lower edge (none for the other objects).
struct LowerEdgeProbe {
  double focal_px = 0, cx_px = 0, cy_px = 0, baseline_m = 0, camera_height_m = 0;
  Eigen::Isometry3d road_from_camera = Eigen::Isometry3d::Identity();
  const io::SynthGroundTruth* ground = nullptr;  // the true ground height; must be set with parts
  struct Part {
    bool hanging = false;
    double x_min_m = 0, x_max_m = 0, edge_m = 0;
  };
  std::vector<Part> parts;  // by object id
  // The object's part when it is a hanging one (its road-frame x span and true lower edge); other
  // objects are left out.
  void add_part(const io::SynthObjectTruth& object);
  // Height of a road-frame point (road_from_camera x a camera-frame one) above the true ground under
  // it: the road frame has Y down and the ground at Y = camera_height_m - its height
  // (io/stereo_synth.h). Needs ground.
  double height_above_true_ground_m(const Eigen::Vector3d& road_m) const;
};

inline constexpr double kLowerEdgeBandM = 0.10;
// The lower edge counts as seen when at least this share of the band's pixels (width x band at the
// object's range) is measurable, and at least kLowerEdgeMinPixels of them.
inline constexpr double kLowerEdgeMinShare = 0.25, kLowerEdgeMinPixels = 10;

MeasurablePixels measurable_pixels(const io::StereoSynthScene& scene, int min_disparity, int num_disparities,
                                   const LowerEdgeProbe* probe = nullptr);

// A frame whose view is partly nearer than the search range: at least kNearerThanRangeShare of the
// image's pixels (MeasurablePixels::nearer_than_range). The eval prints the false positives of such
// frames apart (floating: the camera driving into a board, 0-3 m ahead, half the image).
inline constexpr double kNearerThanRangeShare = 0.01;
bool view_partly_nearer_than_range(const MeasurablePixels& pixels, int64_t image_pixels);

// Whether a hanging object's lower edge is seen: its measurable band pixels (MeasurablePixels::
// lower_edge) against max(kLowerEdgeMinPixels, kLowerEdgeMinShare x the band's pixel area width x
// kLowerEdgeBandM x f^2 / distance^2). One that is not (the bottom hidden behind a nearer object)
// is not scored for its lower edge nor the free space under it.
bool lower_edge_seen(int64_t lower_edge_pixels, const io::SynthObjectTruth& object, double focal_px);

// ---- hanging objects ---------------------------------------------------------------------------

// The report of a hanging object's hanging part spans this height above its true lower edge: inside
// every hanging part of io/stereo_synth.h (a board's 0.7 m, a sign's 0.7 m, a ball's 0.4 m).
inline constexpr double kHangingPartProbeM = 0.2;
// A lower edge within this of the truth counts; an obstacle this far below the truth's lower edge
// takes the free space.
inline constexpr double kLowerEdgeToleranceM = 0.10;
// The free space is checked in the inner part of the gate, this far inside the object's lateral
// ends (away from a board's posts, which do stand on the ground).
inline constexpr double kPostMarginM = 0.3;

struct HangingObjectScore {
  // The scored obstacle: of the in-gate obstacles whose height interval spans kHangingPartProbeM
  // above the truth's lower edge (the report of the hanging part), the one with the highest
  // min_height_m; when none spans it, the in-gate obstacle with the highest min_height_m. Null
  // when the gate is empty (a miss: nothing to score).
  const arm::obstacles3d::Obstacle3d* scored = nullptr;
  bool scored_spans_probe = false;
  double error_m = 0;  // scored->min_height_m - the truth's min_height_m
  bool within_tolerance() const;
  // The former rule, printed beside: the in-gate obstacle with the highest min_height_m, whatever it spans.
  const arm::obstacles3d::Obstacle3d* highest_lower_edge = nullptr;
  double highest_lower_edge_error_m = 0;
  // The free space under it (not for a ball on a post: its post stands under it): checked, and the
  // first obstacle (in the order given) in the gate within width / 2 - kPostMarginM of the object's
  // x whose min_height_m is more than kLowerEdgeToleranceM below the truth's lower edge; null: kept.
  bool free_space_checked = false;
  const arm::obstacles3d::Obstacle3d* under = nullptr;
  bool free_space_kept() const { return free_space_checked && under == nullptr; }
};
HangingObjectScore score_hanging_object(const std::vector<arm::obstacles3d::Obstacle3d>& obstacles, const io::SynthObjectTruth& object,
                                        const ObstacleGate& gate);

// ---- moving (voxels) ----------------------------------------------------------------------------

// The object an obstacle shows in the image: of the object ids (object_ids, 0 = road, background
// or sky: not counted) inside its bbox_px (clipped to the image), the one with the most pixels (a
// tie: the smaller id); 0 when the box is empty, outside the image or holds no object pixel.
int object_shown(const arm::obstacles3d::Obstacle3d& obstacle, const cv::Mat& object_ids);

// The obstacle whose moving flag and velocity are scored for a detected object: of the in-gate
// obstacles, the nearest (horizontal distance of the centres) that shows this object
// (object_shown); when none does, the nearest in-gate obstacle (the former rule, printed beside).
// Null when the gate is empty. Why: gates overlap. A pedestrian walking behind a parked car, its
// head above the car's roof, is an obstacle 1 m from the car's centre and within the car's gate,
// nearer to that centre than the car's own obstacle (its rear face, 2.25 m from the centre of a
// 4.5 m car); the nearest-obstacle rule scored the parked car with the pedestrian's (true) "moving"
// flag (urban seed 2, frames 2-17: 9 of the 10 false flags).
const arm::obstacles3d::Obstacle3d* moving_scored_obstacle(const std::vector<arm::obstacles3d::Obstacle3d>& obstacles,
                                                           const io::SynthObjectTruth& object, const ObstacleGate& gate,
                                                           const cv::Mat& object_ids);

// Which object-frames the moving flag is also scored on ("settled", printed beside the figure over
// every counted object-frame): the object has been counted (in view, measurable, in range) in more
// than kMovingSettleFrames frames in a row, this one included. Why: no tracker can say "moving"
// honestly earlier. A track is reported after acceptance_frames (3) associations, and its speed is
// significant only after a few more: at 0.2-0.3 m of centroid noise a walker's 1.2-1.5 m/s needs
// about 5 updates at 10 Hz (obstacle_tracking.h, fragment adoption). An object in view from a
// sequence's first frame is otherwise scored before any track of it can exist. bench/voxels_bench
// counts its moving figures by the same rule.
constexpr int kMovingSettleFrames = 6;

// The run lengths behind that rule, per object id over a sequence's frames.
class CountedRuns {
 public:
  // Once per frame, with the ids counted in it; an id not in the list starts again from 0.
  void next_frame(const std::vector<int>& counted_ids);
  // Frames in a row the object has been counted, this frame included; 0 when it is not counted now.
  int frames_in_row(int id) const;
  bool settled(int id) const { return frames_in_row(id) > kMovingSettleFrames; }

 private:
  std::unordered_map<int, int> runs_;
};

}  // namespace lpstereo::eval
