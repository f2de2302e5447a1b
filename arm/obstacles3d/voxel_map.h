// The voxel map of issue 10 deliverable 3 (thesis 000, Sabbatelli 2015, §3.2.3.2 "Voxel-based space
// partitioning"): the obstacle candidate points (obstacle_points.h) binned into cubic voxels of edge
// voxel_size_m, kept in a hash map of the occupied voxels only, in world coordinates so that a
// voxel persists while the camera moves.
//
// World frame. The vehicle frame (x forward, y left, z up, metres) of the first frame the map saw.
// Each later frame's ego-motion (EgoMotion::previous_from_current, vehicle frames) is chained:
//     world_from_current(k) = world_from_current(k - 1) * previous_from_current(k),
// and each point enters as p_world = world_from_current(k) * p_vehicle. The ego-motion passed with the
// first frame is ignored (there is no previous frame). A frame without ego-motion (available = false)
// chains the identity: the camera is assumed static for that frame, and the status says so.
//
// Voxel keys. key = floor(p_world / voxel_size_m) per axis (voxel (i, j, k) covers
// [i s, (i + 1) s) x [j s, (j + 1) s) x [k s, (k + 1) s), centre ((i, j, k) + 0.5) s). Keys are int32
// per axis and hashed with the spatial hash of Teschner et al., "Optimized spatial hashing for
// collision detection of deformable objects", VMV 2003 (x 73856093 xor y 19349663 xor z 83492791).
//
// Per voxel (the thesis's list: centroid, number of points, colour mean and variance in RGB and HSL):
//   over its whole life (every point that fell in it since it was created): point_count, the world
//   centroid, ColourStatistics (RGB and HSL means and variances);
//   over the current frame only (reset when the voxel is first hit in a frame): the frame's point count,
//   world and camera-frame sums and extents, height above the terrain (from the points' own
//   height_above_ground_m), left-image pixel box, largest disparity. Clustering and the Obstacle3d fields use these.
//
// Life rule (the thesis: "new voxels are created only when a previously empty volume of the space is
// now occupied by a new 3D point; similarly, voxels are removed if no 3D points fall into it"):
//   - a point in a voxel that does not exist creates it;
//   - after the frame's points, every voxel not hit this frame is tested against the view: in view
//     when its centre, in the current vehicle frame, lies inside the map bounds, ahead
//     (x >= min_forward_m) and within |atan2(y, x)| <= view_half_angle_rad (the camera looks along
//     the vehicle's x). A voxel in view and not hit gets unobserved_frames + 1 and is removed when
//     unobserved_frames > max_unobserved_frames (default 0: removed in the first frame that sees its
//     volume empty, the thesis's rule; 1 or 2 tolerates dropped disparities). A hit resets it to 0;
//   - a voxel out of view (behind, beside) but inside the bounds is kept unchanged (nothing says it
//     is empty); one whose centre leaves the bounds is removed (counted apart).
//
// Bounds (the thesis's volume of interest was 28.7 x 16.4 x 3.5 m): a box in the current vehicle
// frame, min_forward_m <= x <= max_forward_m, |y| <= max_lateral_m, min_up_m <= z <= max_up_m. Points
// outside it, and points with a non-finite coordinate, are clipped: not inserted, counted in the
// status. A point whose world key would not fit int32 is clipped too (only after ~10^8 voxels of
// travel).
//
// Counted work (ArmWork, deterministic) per update, with N input points, I inserted points, C created
// voxels, V voxels in the map after insertion, R removed voxels:
//   scalar_ops   = 24 (chaining the ego-motion: a 4x4 product, 3x3 rotation + translation, and the
//                  status) + 12 N (finiteness and bounds) + I (18 world transform + 6 key + 10 hash
//                  and probe + 24 HSL conversion + 40 statistics) + 16 C (voxel creation)
//                  + 20 V (hit test, view test: the inverse transform of the centre and the angle)
//                  + 8 R (erase);
//   memory_bytes = sizeof(ObstaclePoint) N (points read) + sizeof(Voxel) (2 I + C + V + R)
//                  (each inserted point reads and writes its voxel; creation, the sweep and erasure
//                  touch a voxel once).
// VoxelMap::expected_work gives these from the status's counts (tests check the counts against it).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "arm/obstacles3d/obstacle_points.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::obstacles3d {

// HSL (hue, saturation, lightness) of an 8-bit RGB colour, all three in [0, 1] (hue in turns: 0 red,
// 1/3 green, 2/3 blue). The hexcone double-cone model of Joblove and Greenberg, "Color spaces for
// computer graphics", SIGGRAPH 1978 (also Foley, van Dam et al., "Computer Graphics: Principles and
// Practice", 2nd ed., §13.3.5, RGB_To_HLS): with r, g, b = R/255, G/255, B/255, M = max, m = min,
// C = M - m:
//     L = (M + m) / 2;
//     S = 0 when C = 0, else C / (1 - |2 L - 1|);
//     H = 0 when C = 0 (achromatic: hue undefined, 0 by convention), else
//         ((g - b) / C mod 6) / 6 when M = r, ((b - r) / C + 2) / 6 when M = g, ((r - g) / C + 4) / 6 when M = b.
struct Hsl {
  double hue = 0;         // turns, [0, 1)
  double saturation = 0;  // [0, 1]
  double lightness = 0;   // [0, 1]
};
Hsl hsl_from_rgb(const std::array<uint8_t, 3>& rgb);

// The circular mean of hues (turns) from the sums of cos(2 pi h) and sin(2 pi h), in [0, 1).
double hue_from_circular_sums(double cos_sum, double sin_sum);

// Running colour statistics of a set of points. RGB normalised to [0, 1]. Hue is an angle: its mean
// is the circular mean atan2(sum sin, sum cos) and its variance the circular variance 1 - |mean
// resultant| in [0, 1] (Mardia and Jupp, "Directional Statistics", 2000, §2.2 and §2.3.1); saturation
// and lightness have ordinary means and (population) variances.
struct ColourStatistics {
  int64_t count = 0;
  Eigen::Vector3d rgb_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d rgb_square_sum = Eigen::Vector3d::Zero();
  double hue_cos_sum = 0, hue_sin_sum = 0;
  double saturation_sum = 0, saturation_square_sum = 0;
  double lightness_sum = 0, lightness_square_sum = 0;

  void add(const std::array<uint8_t, 3>& rgb, const Hsl& hsl);
  Eigen::Vector3d rgb_mean() const;      // zeros when empty
  Eigen::Vector3d rgb_variance() const;  // per channel
  Hsl hsl_mean() const;
  Eigen::Vector3d hsl_variance() const;  // (circular hue variance, saturation variance, lightness variance)
};

struct VoxelKey {
  int32_t x = 0, y = 0, z = 0;
  bool operator==(const VoxelKey& other) const { return x == other.x && y == other.y && z == other.z; }
};
// Deterministic order (flood fill seeds, tests): lexicographic x, y, z.
inline bool operator<(const VoxelKey& a, const VoxelKey& b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

struct VoxelKeyHash {
  size_t operator()(const VoxelKey& key) const {
    return static_cast<size_t>((static_cast<uint64_t>(static_cast<uint32_t>(key.x)) * 73856093u) ^
                               (static_cast<uint64_t>(static_cast<uint32_t>(key.y)) * 19349663u) ^
                               (static_cast<uint64_t>(static_cast<uint32_t>(key.z)) * 83492791u));
  }
};

struct Voxel {
  VoxelKey key;
  // Over the voxel's life.
  int64_t point_count = 0;
  Eigen::Vector3d world_sum_m = Eigen::Vector3d::Zero();
  ColourStatistics colour;
  int64_t first_seen_frame = 0;
  int64_t last_seen_frame = 0;
  int frames_observed = 0;
  int unobserved_frames = 0;  // consecutive frames in view without a point (life rule above)
  // The current frame (valid when last_seen_frame is the map's frame_index()).
  int frame_point_count = 0;
  Eigen::Vector3d frame_world_sum_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d frame_camera_sum_m = Eigen::Vector3d::Zero();
  Eigen::Vector3f frame_camera_min_m = Eigen::Vector3f::Zero();
  Eigen::Vector3f frame_camera_max_m = Eigen::Vector3f::Zero();
  double frame_height_sum_m = 0;
  float frame_min_height_m = 0, frame_max_height_m = 0;
  float frame_max_disparity_px = 0;  // largest disparity of the frame's points (voxel_clustering.h: left-border truncation)
  std::array<int, 4> frame_bbox_px{-1, -1, -1, -1};  // x0, y0, x1, y1 inclusive

  Eigen::Vector3d centroid_world_m() const { return point_count > 0 ? Eigen::Vector3d(world_sum_m / double(point_count)) : Eigen::Vector3d::Zero(); }
  Eigen::Vector3d frame_centroid_world_m() const {
    return frame_point_count > 0 ? Eigen::Vector3d(frame_world_sum_m / double(frame_point_count)) : Eigen::Vector3d::Zero();
  }
  double frame_mean_height_m() const { return frame_point_count > 0 ? frame_height_sum_m / frame_point_count : 0.0; }
};

struct VoxelMapParameters {
  double voxel_size_m = 0.25;  // [0.05, 0.5] (issue 10); the thesis chose 0.25 m
  // Bounds in the current vehicle frame (header comment), metres.
  double min_forward_m = 0.0;
  double max_forward_m = 40.0;
  double max_lateral_m = 20.0;
  double min_up_m = -3.0;
  double max_up_m = 5.0;
  double view_half_angle_rad = 0.6;  // (0, pi/2]: half the camera's horizontal field of view, for decay
  int max_unobserved_frames = 0;     // >= 0: frames in view without points a voxel survives
};

struct VoxelMapStatus {
  int64_t frame_index = -1;  // 0 for the first update
  bool ego_motion_available = false;
  // "ego-motion applied", "no ego-motion: static camera assumed", or on the first frame "first frame: world =
  // this vehicle frame" (followed by "; no ego-motion: static camera assumed" when none came with it).
  std::string ego_motion_note;
  int64_t points_in = 0;
  int64_t points_inserted = 0;
  int64_t points_clipped_out_of_bounds = 0;
  int64_t points_not_finite = 0;
  int64_t voxels_created = 0;
  int64_t voxels_removed_unobserved = 0;
  int64_t voxels_removed_out_of_bounds = 0;
  int64_t voxels_swept = 0;  // V of the work model: voxels in the map after insertion
  int64_t voxel_count = 0;   // after the update
  int64_t voxels_observed = 0;  // hit this frame
  ArmWork work;
  std::string text() const;  // one line
};

class VoxelMap {
 public:
  // Throws std::invalid_argument naming the parameter, the expected range and the value.
  explicit VoxelMap(const VoxelMapParameters& parameters = {});

  // Adds one frame's candidate points. Empty input is fine (voxels in view decay).
  const VoxelMapStatus& update(const std::vector<ObstaclePoint>& points, const EgoMotion& ego_motion);

  const VoxelMapParameters& parameters() const { return parameters_; }
  const VoxelMapStatus& status() const { return status_; }
  int64_t frame_index() const { return status_.frame_index; }
  const Eigen::Isometry3d& world_from_current() const { return world_from_current_; }
  const std::unordered_map<VoxelKey, Voxel, VoxelKeyHash>& voxels() const { return voxels_; }
  const Voxel* find(const VoxelKey& key) const;
  bool observed_this_frame(const Voxel& voxel) const { return voxel.last_seen_frame == status_.frame_index && voxel.frame_point_count > 0; }

  // Key of a world point (floor division); the point must be finite and its key must fit int32.
  VoxelKey key_of(const Eigen::Vector3d& world_m) const;
  Eigen::Vector3d centre_of(const VoxelKey& key) const;

  // Whether a voxel's centre, in the current vehicle frame, lies within margin_m of a face of the map
  // bounds: an object there may be cut by the clipping (voxel_clustering.h marks its cluster truncated).
  bool near_bounds(const VoxelKey& key, double margin_m) const;

  // The work model of the header comment from a status's counts.
  static ArmWork expected_work(const VoxelMapStatus& status);

 private:
  bool inside_bounds(const Eigen::Vector3d& vehicle_m) const;
  bool in_view(const Eigen::Vector3d& vehicle_m) const;

  VoxelMapParameters parameters_;
  VoxelMapStatus status_;
  Eigen::Isometry3d world_from_current_ = Eigen::Isometry3d::Identity();
  std::unordered_map<VoxelKey, Voxel, VoxelKeyHash> voxels_;
};

}  // namespace lpstereo::arm::obstacles3d
