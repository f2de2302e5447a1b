// Tracking of the voxel clusters over frames and moving versus static obstacles (issue 10 deliverable
// 5; thesis 000, Sabbatelli 2015, §3.2.3.4 and Algorithm 3.2.3.4). The 2D ground-plane tracker of the
// obstacle detector (arm/tasks/obstacle_tracker.*, issue 6) is a DAG task over record planes; this one
// is a plain class over VoxelCluster lists, in 3D and in world coordinates, with the thesis's queues.
//
// Frame. Tracks live in the voxel map's world frame (voxel_map.h: the first frame's vehicle frame, x
// forward, y left, z up), so a filter's velocity is relative to the ground: the ego-motion is
// already removed by the map's world_from_current. Outputs are expressed in the current camera axes:
//     velocity_camera = R_camera_from_vehicle R_current_from_world v_world,
// R_camera_from_vehicle = CameraToVehicle(camera_mount).rotation()^T (arm/point_cloud.h).
//
// Filter (ConstantVelocityFilter3d): the linear Kalman filter (Kalman 1960) on the 6-state
// s = (p, v) in m and m/s, the discrete white noise acceleration model (Bar-Shalom, Li, Kirubarajan,
// "Estimation with Applications to Tracking and Navigation", 2001, §6.3.2), period T:
//     F = [I  T I; 0  I],   Q = accel_sigma_mps2^2 [T^4/4 I, T^3/2 I; T^3/2 I, T^2 I],
// measurement z = the cluster's centroid (this frame's points, world frame), H = [I 0], noise
//     R = centroid_sigma_m^2 I + R_wc diag(sigma_x^2, sigma_x^2, sigma_z^2) R_wc^T
// with sigma_z = Z^2 sigma_d / (f B), sigma_x = Z sigma_u / f at the cluster's camera depth Z (the
// StereoErrorModel of obstacle_points.h; its term is left out when focal_px or baseline_m is 0) and
// R_wc the world-from-camera rotation. Update in the Joseph form P = (I - K H) P (I - K H)^T + K R K^T
// (Bucy and Joseph 1968), as arm/tasks/obstacle_tracker.cpp does. A new track starts at (z, 0) with
// P = diag(R, initial_speed_sigma_mps^2 I).
//
// Jumps (robust update, innovation_gate_chi2 > 0): a cluster's centroid is the mean of whatever part
// of the object this frame's clustering holds, and a piece that joins for a frame (a fattened sliver
// at a near object's silhouette, a neighbour's part) moves it by metres, far outside the filter's
// model; the plain update turns that into a speed that votes "moving" for a frame or two (preset
// sequences: pieces of a parked car, a board whose pole joins it). An association whose normalized
// innovation squared NIS = nu^T S^-1 nu (S = P_pp + R) exceeds the gate is applied with R scaled by
// NIS / gate: a down-weighting of outliers in the spirit of robust (M-estimation) Kalman filtering
// (Masreliez and Martin, "Robust Bayesian estimation for the linear model and robustifying the Kalman
// filter", IEEE TAC 22(3), 1977), here as the covariance scaling of adaptive filters. A jump that
// persists (the piece stays) still pulls the filter over the next frames: the gate delays that, it
// does not remove it. A track's speed learned from consistent motion gives small NIS and is untouched;
// a new track's wide speed prior (initial_speed_sigma_mps) keeps its first innovations small.
//
// Fragments: before the association the clusters go through merge_stereo_fragments (voxel_clustering.h,
// fragment_merge, with stereo_error): the slivers stereo cuts off an object at its silhouette, and the
// stacked parts colour splits it into, join their object, so that one object feeds one track (a
// fragment would start a track of its own at velocity 0 every few frames). The merged clusters are the
// clusters below (their count C) and the reported obstacles.
//
// Feature motion (the visual odometry's evidence; update()'s feature_motions, arm::FeatureMotion of
// arm/odometry/stereo_odometry.h, given on frames whose ego-motion is that odometry's own increment):
// every circle of the odometry is a point seen at t-1 and at t, and its displacement_m is its own
// motion over the frame, zero on the static scene. A cluster's centroid moves whenever the clustering
// takes or drops a part (a pole joins a board, a pedestrian's legs split off), which a filter fed
// centroids alone reads as speed, and at 0.2-0.3 m of centroid noise a walker's 0.15 m a frame is not
// significant before about 5 updates (below, "Fragment adoption"); the features on the object measure
// its motion directly, at each frame, from its texture. The features of a cluster are those whose
// left pixel lies in its image box and whose point lies in its camera-frame box grown by one voxel
// (and in depth by 2 sigma_Z of the feature as well). With at least feature_motion_min_features of
// them, the median of their displacements, taken per axis of the cluster's line of sight (the
// horizontal across it, the third axis, and along it), rotated to the world frame and divided by the
// frame period, is a measurement of the track's velocity (H = [0 I]) with covariance
//     R_v = (pi / 2) sum_i C_i / (N^2 T^2) + feature_motion_sigma_mps^2 I,
// C_i = 2 R_wc J_i diag(sigma_u^2, sigma_u^2, sigma_d^2) J_i^T R_wc^T the displacement's covariance
// (the point's triangulation error at t and at t-1; J_i the derivative of (X, Y, Z) = ((u - cx) Z / f,
// (v - cy) Z / f, f B / d) by (u, v, d): rows (Z/f, 0, -X/d), (0, Z/f, -Y/d), (0, 0, -Z/d)), pi / 2 the
// median's variance over the mean's for Gaussian errors, and feature_motion_sigma_mps the model's
// error (points sliding along an occluding edge, non-rigid parts). Why the line of sight's axes: a
// feature's error lies along its ray (sigma_Z, 1.2 m at 20 m for 0.5 px, against 2 cm across it),
// and a median per world axis takes its x and its y from different features, which turns the depth
// error into a lateral one by the bearing (urban seed 2: a parked car at 20 m, 4.4 m to the side,
// read 0.6-0.9 m/s lateral and was flagged moving in 9 frames; with the ray's axes, in 2). The
// measurement is applied after the position's update, and at a new track's start, gated as the
// position is (feature_motion_gate_chi2: an innovation beyond it scales R_v by NIS / gate). Across
// the line of sight it is precise; along it, it is as weak as the stereo depth error and weighs
// accordingly. The moving vote below then tests a filter that knows the velocity from its first
// update.
//
// Association (Algorithm 3.2.3.4, greedy): every track is predicted one period; for each (track,
// cluster) pair the distance
//     d = position_weight |z - H s_predicted| + size_weight |size_t - size_c|_1
//         + colour_weight f(t, c) + density_weight |density_t - density_c|
// (f: the colour distance of eq. 3.17, voxel_clustering.h; size and density: the clusters' key-box
// extents in metres and voxel densities, the track keeping its last cluster's). A pair is a candidate
// when |z - H s_predicted| <= max_position_distance_m and d < max_association_distance; candidates
// are taken in increasing (d, track id, cluster index) while neither side is used.
//
// Queues (thesis §3.2.3.4):
//   acceptance: a cluster no track took starts a track here; it moves to tracked after
//     acceptance_frames consecutive associated frames (its first included); a miss discards it;
//   tracked: stays while associated; a miss moves it to ghost;
//   ghost: predicted only; associated again -> tracked; after more than ghost_frames consecutive
//     misses it is deleted.
// Output: one Obstacle3d per tracked-queue track associated this frame (the cluster's fields, track_id,
// velocity_mps, moving), in increasing track id; acceptance and ghost tracks are not reported.
//
// Moving versus static: at each association of a track with at least moving_min_updates updates with
// a cluster that is not truncated (voxel_clustering.h: cut by the map bounds, the image border or the
// candidates' far edge, so its centroid moves with the cut), the horizontal world velocity v_h = (v_x, v_y) (the vertical one
// is the cluster's height jitter, not motion on the ground) votes "moving" when
//     |v_h| > moving_speed_mps   and   v_h^T P_vh^-1 v_h > moving_significance_chi2
// (P_vh the filter's 2x2 covariance of v_h: the speed must also be significantly non-zero, which
// keeps a young track's uncertain velocity from voting; chi-square, 2 degrees of freedom), else
// "static". The track turns moving after moving_consistency_frames consecutive moving votes and back
// to static after as many consecutive static votes (a hysteresis when > 1).
// The range drift of a disparity bias (moving_disparity_bias_px = k > 0, with the stereo model's f B):
// a bias of k px puts a point at Z_m = f B / (f B / Z + k), short of its true range Z by about
// k Z^2 / (f B) along its ray, and while the range changes at Zdot the error changes at about
// 2 k Z Zdot / (f B) (the derivative). A static object approached at speed s therefore seems to
// move along the line of sight at up to that rate, which no noise term of the filter describes: the
// bias is systematic from frame to frame, so the filter learns it as velocity. Near the candidates'
// far edge k is large by selection (the points that stereo pulled inside the area are those with
// too much disparity, up to ~1.5 px; docs/obstacles3d-voxels.md, "Country seed 2"), and the cluster
// recedes at several m/s as the camera closes in (country seed 1: a static bin at 28 m read 5-6 m/s,
// flagged moving in 10 frames). The test therefore adds (2 k Z |v_vehicle . u| / (f B))^2 u u^T to
// P_vh, u the horizontal unit vector from the vehicle to the track, Z the cluster's camera depth and
// v_vehicle the vehicle's ground velocity from the last two poses (zero without ego-motion): a speed
// along the line of sight must stand out from the drift, one across it (a pedestrian crossing) is
// tested as before. The filter itself is untouched.
// Votes start at the second update (moving_min_updates = 2: a velocity exists once two positions were
// seen; the chi-square test keeps a young track's poorly known velocity from voting), so that a moving
// track can be reported moving from its first reported frame (after 3 acceptance frames).
// A cluster at the candidates' far edge (VoxelCluster::at_candidate_far_edge) also updates the filter
// with far_edge_forward_sigma_m added to its forward (vehicle x) noise: an object beyond the edge is
// seen only through its points pulled inside by stereo errors, at constant range while the camera
// drives on, and without the added noise the filter learns the camera's speed from them and keeps it,
// confident, after the object comes inside (country seed 2: a static bin flagged moving in 17 of 31
// frames, docs/obstacles3d-voxels.md). The
// defaults were chosen on the preset sequences of bench/obstacles3d_eval (docs/obstacles3d-voxels.md
// gives the figures): 0.7 m/s (a pedestrian walks at 1.2-1.5 m/s), chi-square 3.0 (78 %: the filter's
// covariance is conservative, its stereo term is a single point's error, not a centroid's), one
// consistent vote (no hysteresis: with 2 or 3 the first frames of every track, and of every track a
// fragment restarted, were reported static; the static objects' false flags stayed at 1-2 % either
// way). initial_speed_sigma_mps = 12 lets a new track of a car at urban speed reach its speed in a few
// frames instead of being pulled towards 0 by the prior.
//
// Fragment adoption (reporting only; the filters and votes are untouched): a reported track with fewer
// than adoption_updates updates (young) reports moving and velocity_mps of its parent, when it has
// one: the nearest (horizontal distance of the filters' positions) tracked track associated this frame
// with at least adoption_updates updates whose image box touches its own (at most adoption_pixel_gap_px
// empty pixels between them) and whose horizontal distance is at most half the sum of both key boxes'
// horizontal diagonals plus adoption_margin_m. Why: the fragment merge does not catch every piece
// (colour splits of a pedestrian passing in front of something, slivers of a parked car, a board's
// poles), and the pieces start tracks of their own. A young track cannot vote "moving" honestly: at
// 0.2-0.3 m centroid noise a pedestrian's 1.5 m/s is not significant before ~5 updates (least-squares
// velocity sigma = sigma_z / sqrt(sum (t - mean t)^2) = 1.8, 1.1, 0.8 m/s after 3, 4, 5 updates at
// 10 Hz), and a piece's centroid jumps when it grows or merges, which a young filter reads as speed.
// On the preset sequences (obstacles3d_eval, urban, 300 frames, seeds 1-3, visual odometry) all 26
// object-frames missed as "moving" were reported by tracks with <= 4 updates (15 with another obstacle
// in the object's gate), and 12 of the 15 false "moving" flags by tracks with <= 8 updates (12 with
// another obstacle in the gate). With adoption (8 updates, 0 px, 0.5 m): TP 89.4 -> 91.9 % (220 -> 226 of 246), FP
// 8.3 -> 5.0 % (15 -> 9 of 180), velocity error mean 1.78 -> 1.62 m/s; no seed worse; the detection
// rate is unchanged (reporting only). adoption_updates 6 and 10 gave 92.3 / 5.6 % and 91.1 / 5.6 %.
// Country seeds 1-3 (first ~150 frames): TP 83.0 -> 86.4 %, FP 27.0 % either way; floating seed 3:
// FP 25 -> 22 of 146 (docs/obstacles3d-voxels.md). Not caught: a track that hops onto another object
// keeps the first one's speed with a confident covariance. (Country seed 2's 17 false flags, a track
// on candidates that stayed 31-33 m ahead of the camera, were the static bin itself seen beyond the
// candidates' far edge: the far-edge rule above.)
//
// Counted work (ArmWork) per update, with T tracks before the update, C clusters, G candidate pairs,
// U associations, N new tracks, O reported obstacles:
//   scalar_ops   = 16 + 150 T (F P F^T + Q on 6x6 with F's block structure, F s) + 60 C (R: rotation
//                  and stereo terms) + 15 E (the far-edge term's outer product, E clusters at the candidates' far edge) + 40 T C (distance: innovation 6, norms 12, colour 16, gate 6)
//                  + 4 G ceil(log2 G) + 4 G (sort, greedy pass) + 45 U_g (the gate's NIS, U_g = U with innovation_gate_chi2 > 0, else 0) + 400 U (3x3 innovation inverse, 6x3
//                  gain, Joseph form on 6x6, votes and their 2x2 significance test) + 25 D (the range drift's term, D = votes with
//                  moving_disparity_bias_px > 0 and a stereo model) + 60 N (track start) + 30 O (velocity rotation, output)
//                  + 8 T (queue moves) + 20 A (fragment adoption: A = young reported tracks times the tracks after the
//                  update, each a queue test, a box test and a distance) + 12 F C (feature motion: F features tested
//                  against C clusters' boxes) + 60 M (M features inside: covariance and rotation) + 3 M ceil(log2 M)
//                  (medians) + 350 V (V velocity updates, gate included) + the fragment merge's (voxel_clustering.h, on the
//                  input clusters);
//   memory_bytes = sizeof(Track3d) 2 (T + N) + sizeof(VoxelCluster) C + the fragment merge's.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "arm/obstacles3d/obstacle_points.h"
#include "arm/obstacles3d/voxel_clustering.h"
#include "arm/obstacles3d/voxel_map.h"
#include "arm/odometry/stereo_odometry.h"
#include "arm/point_cloud.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::obstacles3d {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

// The constant-velocity Kalman filter of the header comment, on its own (the tracker holds one per track).
class ConstantVelocityFilter3d {
 public:
  ConstantVelocityFilter3d() = default;
  ConstantVelocityFilter3d(const Eigen::Vector3d& position_m, const Eigen::Matrix3d& position_covariance, double initial_speed_sigma_mps);
  void predict(double period_s, double accel_sigma_mps2);
  // Returns the innovation's squared Mahalanobis distance (before the update).
  double update(const Eigen::Vector3d& measured_position_m, const Eigen::Matrix3d& measurement_covariance);
  // That distance without updating: nu^T (P_pp + R)^-1 nu, nu = z - p (the normalized innovation squared).
  double normalized_innovation_squared(const Eigen::Vector3d& measured_position_m, const Eigen::Matrix3d& measurement_covariance) const;
  // The same two for a measurement of the velocity (H = [0 I]): the feature motion's (header).
  double update_velocity(const Eigen::Vector3d& measured_velocity_mps, const Eigen::Matrix3d& measurement_covariance);
  double normalized_velocity_innovation_squared(const Eigen::Vector3d& measured_velocity_mps, const Eigen::Matrix3d& measurement_covariance) const;
  Eigen::Vector3d position_m() const { return state_.head<3>(); }
  Eigen::Vector3d velocity_mps() const { return state_.tail<3>(); }
  const Vector6d& state() const { return state_; }
  const Matrix6d& covariance() const { return covariance_; }

 private:
  Vector6d state_ = Vector6d::Zero();
  Matrix6d covariance_ = Matrix6d::Identity();
};

struct ObstacleTrackingParameters {
  double frame_period_s = 0.1;          // (0, 10]
  double accel_sigma_mps2 = 2.0;        // process noise, [0, 100]
  double centroid_sigma_m = 0.2;        // cluster centroid jitter (voxel quantisation, partial views), (0, 10]
  // Added along the vehicle's forward axis to the measurement noise of a cluster at the candidates'
  // far edge (header), [0, 1000] m: 10 m, several times the band where such a centroid sticks, makes
  // its forward coordinate carry almost no weight.
  double far_edge_forward_sigma_m = 10.0;
  StereoErrorModel stereo_error;        // focal_px or baseline_m 0: no stereo term
  double initial_speed_sigma_mps = 12.0; // (0, 100]: a car at urban speed is within one sigma
  double max_position_distance_m = 3.0; // gate on |z - H s_predicted|, (0, 100]
  double position_weight = 1.0;         // per metre, >= 0
  double size_weight = 0.25;            // per metre of L1 size difference, >= 0
  double colour_weight = 1.0;           // per unit of eq. 3.17, >= 0
  double density_weight = 1.0;          // per unit of density, >= 0
  double max_association_distance = 6.0;  // > 0
  // Robust update (header, "Jumps"): an association whose normalized innovation squared exceeds this
  // chi-square (3 degrees of freedom; 7.81 is its 95 % point) is applied with its measurement noise
  // scaled by NIS / gate; 0: off (the plain Kalman update). [0, 1000].
  double innovation_gate_chi2 = 7.81;
  int acceptance_frames = 3;            // [1, 1000]
  int ghost_frames = 5;                 // [0, 1000]
  double moving_speed_mps = 0.7;        // horizontal ground speed threshold, [0, 100]
  int moving_min_updates = 2;           // a track votes from its moving_min_updates-th association on, [2, 1000]
  int moving_consistency_frames = 1;    // [1, 1000]
  double moving_significance_chi2 = 3.0;  // chi-square, 2 degrees of freedom, 0.78; [0, 1000]
  // The range drift of a disparity bias (header, "Moving versus static"): k px of bias moves a static
  // object's measured range by about k Z^2 / (f B), and by 2 k Z Zdot / (f B) per second while its
  // range changes at Zdot; that drift, along the line of sight, is added to the velocity's covariance
  // in the significance test (needs stereo_error's focal_px and baseline_m). 0: off; [0, 10] px. 1 px:
  // docs/obstacles3d-voxels.md, "The range drift of a disparity bias", has the figures.
  double moving_disparity_bias_px = 1.0;
  // Feature motion (header): the odometry's points inside a cluster measure its velocity. Needs
  // stereo_error's focal_px and baseline_m.
  int feature_motion_min_features = 3;       // fewer inside a cluster: no measurement; 0: off; [0, 1000]
  double feature_pixel_sigma_px = 0.5;       // a feature's image position error, (0, 10] px
  double feature_disparity_sigma_px = 0.5;   // its disparity error, (0, 10] px
  double feature_motion_sigma_mps = 0.2;     // the model's error added to the measurement, [0, 100] m/s
  double feature_motion_gate_chi2 = 7.81;    // as innovation_gate_chi2, on the velocity's innovation; 0: off; [0, 1000]
  int adoption_updates = 8;             // fragment adoption (header): young below, parents at or above; 0: off; [0, 1000]
  int adoption_pixel_gap_px = 0;        // empty pixels allowed between the image boxes (0: overlapping or adjacent), [0, 1000]
  double adoption_margin_m = 0.5;       // ground distance beyond the half key-box diagonals, [0, 100]
  FragmentMergeParameters fragment_merge;  // voxel_clustering.h: stereo fragments merged before association (uses stereo_error)
  CameraMount camera_mount;             // camera axes of the outputs (default: level, looking along the vehicle's x)
};

// Throws std::invalid_argument naming the parameter, the expected range and the value.
void validate_tracking_parameters(const ObstacleTrackingParameters& parameters);

enum class TrackQueue { acceptance, tracked, ghost };
const char* track_queue_name(TrackQueue queue);

struct Track3d {
  int id = 0;                      // >= 1, never reused
  TrackQueue queue = TrackQueue::acceptance;
  int age_frames = 0;              // frames since creation, creation included
  int updates = 0;                 // associated frames
  int consecutive_updates = 0;
  int misses = 0;                  // consecutive frames without an association
  bool associated_this_frame = false;
  ConstantVelocityFilter3d filter;  // world frame
  Eigen::Vector3d size_world_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d rgb_mean = Eigen::Vector3d::Zero();
  Hsl hsl_mean;
  double density = 0;
  int moving_votes = 0, static_votes = 0;
  bool moving = false;
  Obstacle3d obstacle;             // the last associated cluster's, with track fields
};

struct TrackingResult {
  std::vector<Obstacle3d> obstacles;  // tracked-queue tracks associated this frame, increasing track id
  int64_t associations = 0;
  int64_t new_tracks = 0;
  int64_t confirmed = 0;   // acceptance -> tracked
  int64_t discarded = 0;   // missed in acceptance
  int64_t ghosted = 0;     // tracked -> ghost
  int64_t revived = 0;     // ghost -> tracked
  int64_t deleted = 0;     // ghost too long
  int64_t candidate_pairs = 0;
  int64_t merged_fragments = 0;  // input clusters merged into another as stereo fragments
  int64_t adopted = 0;           // reported young tracks that report their parent's motion (fragment adoption)
  int64_t gated_updates = 0;     // associations applied with inflated noise (innovation_gate_chi2)
  int64_t feature_motions = 0;            // feature motions given
  int64_t feature_velocity_updates = 0;   // velocity measurements applied (feature motion, header)
  int64_t gated_velocity_updates = 0;     // of them, applied with inflated noise (feature_motion_gate_chi2)
  ArmWork work;
};

class ObstacleTracker3d {
 public:
  explicit ObstacleTracker3d(const ObstacleTrackingParameters& parameters = {});

  // One frame: the clusters of cluster_voxels and the map's world_from_current (vehicle frames);
  // feature_motions: the visual odometry's for this frame (header, "Feature motion"), only when the
  // map's ego-motion is that odometry's own increment; empty: none.
  const TrackingResult& update(const std::vector<VoxelCluster>& clusters, const Eigen::Isometry3d& world_from_current,
                               const std::vector<FeatureMotion>& feature_motions = {});

  const std::vector<Track3d>& tracks() const { return tracks_; }  // increasing id, every queue
  const TrackingResult& result() const { return result_; }
  const ObstacleTrackingParameters& parameters() const { return parameters_; }

 private:
  Eigen::Matrix3d measurement_covariance(const VoxelCluster& cluster, const Eigen::Matrix3d& world_from_camera) const;
  double association_distance(const Track3d& track, const VoxelCluster& cluster, double position_distance_m) const;
  struct FeatureVelocity {
    int features = 0;  // inside the cluster; a measurement when >= feature_motion_min_features
    Eigen::Vector3d velocity_mps = Eigen::Vector3d::Zero();  // world frame
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  };
  FeatureVelocity feature_velocity(const VoxelCluster& cluster, const std::vector<FeatureMotion>& feature_motions,
                                   const Eigen::Matrix3d& world_from_camera, double voxel_size_m) const;
  void apply_feature_velocity(Track3d& track, const FeatureVelocity& measurement);
  void report(Track3d& track, const VoxelCluster& cluster, const Eigen::Matrix3d& camera_from_world);

  ObstacleTrackingParameters parameters_;
  Eigen::Matrix3d camera_from_vehicle_ = Eigen::Matrix3d::Identity();
  std::vector<Track3d> tracks_;
  TrackingResult result_;
  int next_id_ = 1;
  Eigen::Vector3d previous_vehicle_position_world_m_ = Eigen::Vector3d::Zero();
  bool has_previous_pose_ = false;
};

}  // namespace lpstereo::arm::obstacles3d
