// Colour-based flood-fill clustering of the voxel map (issue 10 deliverable 4; thesis 000, Sabbatelli
// 2015, §3.2.3.3, eq. 3.17 and Algorithms 3.2.3.1-3), and each cluster's Obstacle3d.
//
// Candidates: the voxels observed in the map's current frame whose points' mean height above the
// terrain (ObstaclePoint::height_above_ground_m) is at least min_height_above_ground_m (the thesis:
// "only the voxels with positive z", above the road).
//
// Similarity (eq. 3.17) between a voxel v and the running mean of a cluster c:
//     f(v, c) = ||rgb(v) - rgb(c)||_2 + |dh(v, c)| min(s(v), s(c)) + |s(v) - s(c)| + |l(v) - l(c)|
// with RGB normalised to [0, 1] (the thesis: "normalized means of the RGB and HSL components") and HSL
// from hsl_from_rgb (voxel_map.h). The HSL part is the L1 distance of eq. 3.17 with two changes,
// both because hue is an angle that is undefined for greys: the hue difference is circular,
// dh = min(|h_v - h_c|, 1 - |h_v - h_c|) in turns (hue 0.95 and 0.05 are 0.1 apart, not 0.9), and it
// is weighted by the smaller saturation (a grey's hue, 0 by convention, must not split two grey
// voxels; two saturated colours keep the full hue term). A voxel's colour is its ColourStatistics mean
// (its whole life); a cluster's running mean is the mean of its voxels' colours, each voxel counting
// once (the thesis: "the colors associated to each already-inserted voxel"), hue averaged
// circularly. A voxel joins when f(v, c) < similarity_threshold.
//
// Algorithm 3.2.3.1 (flood fill): seeds in increasing key order (deterministic), breadth-first over
// the 26-neighbourhood (the Chebyshev closed unit ball: keys differing by at most 1 on every axis).
// A neighbour not yet in a cluster that fails the similarity stays free for later seeds.
// Algorithm 3.2.3.2 (aggregation): each small cluster (fewer than small_cluster_voxels voxels), in
// increasing label order, that touches (26-neighbourhood) at least one big cluster (at least
// small_cluster_voxels voxels) is merged into the big cluster with the most voxels adjacent to it.
// Algorithm 3.2.3.3 (noise removal): clusters with fewer than min_cluster_voxels voxels, or with a
// density (voxels / the volume of its key bounding box, in voxels) below min_density, are removed.
//
// Obstacle3d per cluster (obstacle_points.h), from the current frame's points of its voxels:
// position_m = the mean of the points' camera-frame positions (not the centre of their bounding box:
// stereo smears an object's depth into a tail behind it, sigma_Z growing as Z^2, and the box centre
// follows the tail), size_m the extent of their camera-frame bounding box (width x, height y, length
// z; the box is kept as camera_min_m / camera_max_m), min/max_height_m the lowest and highest point above the terrain, bbox_px the
// union of the points' pixels; id = index in the result, track_id = -1, velocity 0, moving = false
// (obstacle_tracking.h fills those).
//
// Truncation. A cluster is marked truncated when one of its voxels lies within one voxel of the map
// bounds (VoxelMap::near_bounds: the clipping may cut the object) or, when the image size is given,
// its pixel box comes within border_margin_px of the image border (the object leaves the field of
// view). On the left the border is further in: a left-image pixel u with disparity d is matched at
// u - d in the right image, so an object is cut where u - d < 0, i.e. within d of the left border (a
// point near that border is only seen by the left camera): the left test is x0 <= border_margin_px + the
// cluster's largest disparity. A truncated cluster's centroid moves as the cut moves, not as the object does: the tracker
// takes no motion decision from it.
// The candidates' far edge (candidate_forward_max_m > 0): the obstacle candidates end where the
// terrain area ends (obstacle_candidates.h: a point beyond the fitted surface has no height above the
// ground; 34 m forward by default), and stereo smears depth there by sigma_Z = Z^2 sigma_d / (f B)
// (1.7 m at 34 m for the 640x480, 60 degree, 0.3 m rig at 0.25 px; mismatched points several times
// that). An object beyond the edge is then seen only through those of its points that the disparity
// error pulls inside, and their centroid stays just inside the edge while the camera drives on: a
// static object that approaches at the camera's speed is seen at constant range, i.e. moving with the
// camera. bench/obstacles3d_eval, country seed 2 (the pedestrian and then a static bin, true range
// 44 -> 35 m over frames 13-21): the bin's candidates stayed at 30.2-33.4 m measured range for those
// 9 frames, while the terrain fit there agreed with the true ground (points on ground pixels: mean
// height above the fit within 0.1 m of their height above the true ground); a track took ~9.6 m/s
// over the ground from them and kept flagging the bin moving after it came inside. So a cluster with
// a voxel centre less than candidate_far_edge_margin_m before the edge (current vehicle frame,
// forward) is marked truncated and at_candidate_far_edge (the tracker also ignores its forward
// position, obstacle_tracking.h). The margin, 1.5 m (6 voxels): the stuck clusters reach near the edge (country
// seed 2 kept the same 3 of 31 false flags as with 3.5 m), while an object truly inside, at the eval's 30 m, has its depth tail
// (sigma_Z 1.4 m at 30 m) mostly before 32.5 m. 3.5 m (2 sigma_Z at 34 m) also cut such objects and
// cost urban seed 2 four false flags at 100 frames (docs/obstacles3d-voxels.md has both).
//
// Counted work (ArmWork) per call, with V voxels in the map, K candidates, E neighbour probes
// (26 per dequeued voxel in the flood fill and in the aggregation's adjacency count), J = K voxels
// joined, A aggregated clusters, L clusters after the flood fill:
//   scalar_ops   = 4 V (candidate test) + 4 K ceil(log2 K) (seed order) + 8 E (key arithmetic, hash and
//                  probe) + 36 E_similarity (eq. 3.17 for each probe that reaches a free candidate) + 16 J
//                  (running mean) + 8 A + 40 L (density, removal, obstacle fields) + 30 K (obstacle sums, bounds test)
//                  + 12 K when candidate_forward_max_m > 0 (a voxel centre's forward coordinate in the current
//                  vehicle frame: key to centre 6, one row of the rigid transform 6; at most K: only the
//                  candidates that joined a cluster are tested);
//   memory_bytes = sizeof(Voxel) (V + 2 K).
// The result's counts give the figures (ClusteringResult::work).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "arm/obstacles3d/obstacle_points.h"
#include "arm/obstacles3d/voxel_map.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::obstacles3d {

struct VoxelClusteringParameters {
  double min_height_above_ground_m = 0.1;  // candidate voxels: mean point height above the terrain >= this
  double similarity_threshold = 0.3;       // epsilon of Algorithm 3.2.3.1, units of eq. 3.17 (RGB and HSL in [0, 1])
  int small_cluster_voxels = 4;            // fewer voxels: small (aggregated if it touches a big cluster)
  int min_cluster_voxels = 3;              // fewer voxels after aggregation: removed as noise
  double min_density = 0.05;               // voxels / key-box volume; below: removed as sparse
  int image_width_px = 0;                  // left image size for the truncation test; 0: not tested
  int image_height_px = 0;
  int border_margin_px = 2;                // [0, 1000]
  // The forward end of the area the candidates come from (CandidateParameters::grid.forward_max_m),
  // current vehicle frame; 0: not tested (header: the candidates' far edge).
  double candidate_forward_max_m = 0;      // 0 or (0, 1000] m
  double candidate_far_edge_margin_m = 1.5;  // [0, 100] m
};

// The similarity of eq. 3.17 as defined in the header comment.
double colour_distance(const Eigen::Vector3d& rgb_a, const Hsl& hsl_a, const Eigen::Vector3d& rgb_b, const Hsl& hsl_b);

struct VoxelCluster {
  std::vector<VoxelKey> voxels;                                 // increasing key order
  int64_t frame_points = 0;                                     // this frame's points in its voxels
  Eigen::Vector3d centroid_world_m = Eigen::Vector3d::Zero();   // mean of this frame's points, world frame
  Eigen::Vector3d rgb_mean = Eigen::Vector3d::Zero();           // mean of the voxels' RGB means, [0, 1]
  Hsl hsl_mean;                                                 // mean of the voxels' HSL means (hue circular)
  VoxelKey min_key, max_key;                                    // key bounding box
  double density = 0;                                           // voxels / key-box volume, (0, 1]
  bool truncated = false;                                       // cut by the map bounds, the image border or the candidates' far edge (header)
  bool at_candidate_far_edge = false;                           // within candidate_far_edge_margin_m of the candidates' far edge (header)
  Eigen::Vector3d size_world_m = Eigen::Vector3d::Zero();       // key box extent, metres
  Eigen::Vector3d camera_min_m = Eigen::Vector3d::Zero();       // this frame's points' camera-frame bounding box
  Eigen::Vector3d camera_max_m = Eigen::Vector3d::Zero();
  Obstacle3d obstacle;
};

struct ClusteringResult {
  std::vector<VoxelCluster> clusters;  // in increasing order of their smallest key
  int64_t candidate_voxels = 0;
  int64_t flood_fill_clusters = 0;
  int64_t aggregated_clusters = 0;
  int64_t removed_small = 0;
  int64_t removed_sparse = 0;
  int64_t neighbour_probes = 0;
  int64_t similarity_tests = 0;
  ArmWork work;
};

// Throws std::invalid_argument for a parameter out of range (name, expected, value).
void validate_clustering_parameters(const VoxelClusteringParameters& parameters);

ClusteringResult cluster_voxels(const VoxelMap& map, const VoxelClusteringParameters& parameters = {});

// Stereo fragments (after the clustering, before the tracking). Stereo smears an object's depth at
// its silhouette (the matching window straddles the edge: "edge fattening") and its depth noise grows
// as sigma_Z = Z^2 sigma_d / (f B) (obstacle_points.h), about 1 m at 25 m for a 640x480, 60 degree,
// 0.3 m rig: the voxels of one car then split into the main cluster and thin slivers a few voxels
// away in depth, which no 26-neighbourhood reaches; a tracker sees them as objects of their own that
// appear and vanish; colour also splits one object into stacked parts (a pedestrian's legs and
// torso). The clusters are taken in decreasing voxel count; each joins the first earlier host it is a
// part of, tested against that host's own cluster (no chains through fragments), or becomes a host.
// A cluster is a part of a host when their left-image pixel boxes overlap once grown by
// pixel_margin_px, and either
//     (same surface) the gap between their camera depth ranges (camera_min_m.z .. camera_max_m.z) is at
//     most min_depth_gap_m and they overlap laterally (camera x) over at least half the wider (parts of about one width), or
//     (fragment) it has at most max_fragment_fraction of the host's voxels, its pixel box is at most
//     max_fragment_width_px wide (a sliver: a silhouette's smear or a side seen at a grazing angle; a
//     pedestrian beside a car is wider and stays apart) and the depth gap is at most
//     min_depth_gap_m + depth_sigmas sigma_Z(Z), Z the nearer of the two centres' depths.
// The output keeps the hosts in input order (ids renumbered). The merged cluster: voxels (key order), frame points,
// centroid and position_m (point-weighted), colour means (voxel-weighted, hue circular), key box,
// density and size_world_m from the key box, truncated (and at_candidate_far_edge) if any member is, the union of the camera
// boxes (size_m its extent) and of the pixel boxes, and the lowest and highest
// heights. Disabled (clusters returned unchanged) when the error model has no focal_px or baseline_m.
// Counted work: scalar_ops = 4 C + 16 P (P host tests, at most C (C - 1) / 2) + 40 M (merges) + 12 C_out,
// memory_bytes = sizeof(VoxelCluster) 2 C.
struct FragmentMergeParameters {
  bool enabled = true;
  int pixel_margin_px = 2;       // [0, 1000]
  double depth_sigmas = 2.0;     // [0, 100]
  double min_depth_gap_m = 0.5;  // [0, 100]: two voxels at 0.25 m
  double max_fragment_fraction = 0.25;  // [0, 1]: a fragment has at most this share of its host's voxels
  int max_fragment_width_px = 16;       // [1, 100000]: and is at most this wide in the image (a sliver)
};

struct FragmentMergeResult {
  std::vector<VoxelCluster> clusters;
  int64_t pair_tests = 0;
  int64_t merged = 0;  // input clusters folded into an earlier one
  ArmWork work;
};

// Whether the inclusive pixel boxes a and b (x0, y0, x1, y1) overlap when one of them is grown by
// margin_px on every side (margin 1: adjacent boxes count; the fragment merge and the tracker's
// fragment adoption use it).
bool pixel_boxes_within(const std::array<int, 4>& a, const std::array<int, 4>& b, int margin_px);

// Throws std::invalid_argument for a parameter out of range (name, expected, value).
void validate_fragment_merge_parameters(const FragmentMergeParameters& parameters);

FragmentMergeResult merge_stereo_fragments(const std::vector<VoxelCluster>& clusters, const StereoErrorModel& stereo, double voxel_size_m,
                                           const FragmentMergeParameters& parameters = {});

}  // namespace lpstereo::arm::obstacles3d
