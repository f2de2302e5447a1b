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
// position_m = the centre of the points' camera-frame bounding box, size_m its extent (width x,
// height y, length z), min/max_height_m the lowest and highest point above the terrain, bbox_px the
// union of the points' pixels; id = index in the result, track_id = -1, velocity 0, moving = false
// (obstacle_tracking.h fills those).
//
// Truncation. A cluster is marked truncated when one of its voxels lies within one voxel of the map
// bounds (VoxelMap::near_bounds: the clipping may cut the object) or, when the image size is given,
// its pixel box comes within border_margin_px of the image border (the object leaves the field of
// view). A truncated cluster's centroid moves as the cut moves, not as the object does: the tracker
// takes no motion decision from it.
//
// Counted work (ArmWork) per call, with V voxels in the map, K candidates, E neighbour probes
// (26 per dequeued voxel in the flood fill and in the aggregation's adjacency count), J = K voxels
// joined, A aggregated clusters, L clusters after the flood fill:
//   scalar_ops   = 4 V (candidate test) + 4 K ceil(log2 K) (seed order) + 8 E (key arithmetic, hash and
//                  probe) + 36 E_similarity (eq. 3.17 for each probe that reaches a free candidate) + 16 J
//                  (running mean) + 8 A + 40 L (density, removal, obstacle fields) + 30 K (obstacle sums, bounds test);
//   memory_bytes = sizeof(Voxel) (V + 2 K).
// The result's counts give the figures (ClusteringResult::work).
#pragma once

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
  bool truncated = false;                                       // cut by the map bounds or the image border (header)
  Eigen::Vector3d size_world_m = Eigen::Vector3d::Zero();       // key box extent, metres
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

}  // namespace lpstereo::arm::obstacles3d
