// Tracking of voxel clusters: filter, association, queues, motion and counted work in obstacle_tracking.h.
#include "arm/obstacles3d/obstacle_tracking.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/Dense>

#include "arm/obstacles3d/parameter_check.h"

namespace lpstereo::arm::obstacles3d {

ConstantVelocityFilter3d::ConstantVelocityFilter3d(const Eigen::Vector3d& position_m, const Eigen::Matrix3d& position_covariance,
                                                   double initial_speed_sigma_mps) {
  state_.head<3>() = position_m;
  state_.tail<3>().setZero();
  covariance_.setZero();
  covariance_.topLeftCorner<3, 3>() = position_covariance;
  covariance_.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * initial_speed_sigma_mps * initial_speed_sigma_mps;
}

void ConstantVelocityFilter3d::predict(double period_s, double accel_sigma_mps2) {
  const double t = period_s;
  Matrix6d transition = Matrix6d::Identity();
  transition.topRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * t;
  const double q = accel_sigma_mps2 * accel_sigma_mps2;
  Matrix6d process = Matrix6d::Zero();
  process.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * (q * t * t * t * t / 4.0);
  process.topRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * (q * t * t * t / 2.0);
  process.bottomLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * (q * t * t * t / 2.0);
  process.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * (q * t * t);
  state_ = transition * state_;
  covariance_ = transition * covariance_ * transition.transpose() + process;
}

namespace {

// The linear update with one 3-vector block of the state observed directly (H = [I 0] for the
// position, offset 0; [0 I] for the velocity, offset 3), Joseph form; returns the normalized
// innovation squared before the update.
double update_block(Vector6d& state, Matrix6d& covariance, int offset, const Eigen::Vector3d& measured,
                    const Eigen::Matrix3d& measurement_covariance) {
  Eigen::Matrix<double, 3, 6> observation = Eigen::Matrix<double, 3, 6>::Zero();
  observation.block<3, 3>(0, offset).setIdentity();
  const Eigen::Vector3d innovation = measured - state.segment<3>(offset);
  const Eigen::Matrix3d innovation_covariance = covariance.block<3, 3>(offset, offset) + measurement_covariance;
  const Eigen::Matrix3d inverse = innovation_covariance.inverse();
  const Eigen::Matrix<double, 6, 3> gain = covariance * observation.transpose() * inverse;
  state += gain * innovation;
  const Matrix6d reduce = Matrix6d::Identity() - gain * observation;
  covariance = reduce * covariance * reduce.transpose() + gain * measurement_covariance * gain.transpose();
  covariance = (0.5 * (covariance + covariance.transpose())).eval();
  return innovation.dot(inverse * innovation);
}

double block_innovation_squared(const Vector6d& state, const Matrix6d& covariance, int offset, const Eigen::Vector3d& measured,
                                const Eigen::Matrix3d& measurement_covariance) {
  const Eigen::Vector3d innovation = measured - state.segment<3>(offset);
  const Eigen::Matrix3d innovation_covariance = covariance.block<3, 3>(offset, offset) + measurement_covariance;
  return innovation.dot(innovation_covariance.inverse() * innovation);
}

}  // namespace

double ConstantVelocityFilter3d::update(const Eigen::Vector3d& measured_position_m, const Eigen::Matrix3d& measurement_covariance) {
  return update_block(state_, covariance_, 0, measured_position_m, measurement_covariance);
}

double ConstantVelocityFilter3d::update_velocity(const Eigen::Vector3d& measured_velocity_mps, const Eigen::Matrix3d& measurement_covariance) {
  return update_block(state_, covariance_, 3, measured_velocity_mps, measurement_covariance);
}

double ConstantVelocityFilter3d::normalized_innovation_squared(const Eigen::Vector3d& measured_position_m,
                                                               const Eigen::Matrix3d& measurement_covariance) const {
  return block_innovation_squared(state_, covariance_, 0, measured_position_m, measurement_covariance);
}

double ConstantVelocityFilter3d::normalized_velocity_innovation_squared(const Eigen::Vector3d& measured_velocity_mps,
                                                                        const Eigen::Matrix3d& measurement_covariance) const {
  return block_innovation_squared(state_, covariance_, 3, measured_velocity_mps, measurement_covariance);
}

void validate_tracking_parameters(const ObstacleTrackingParameters& p) {
  require_parameter(p.frame_period_s > 0 && p.frame_period_s <= 10, "frame_period_s", "(0, 10] s", p.frame_period_s);
  require_parameter(p.accel_sigma_mps2 >= 0 && p.accel_sigma_mps2 <= 100, "accel_sigma_mps2", "[0, 100] m/s^2", p.accel_sigma_mps2);
  require_parameter(p.centroid_sigma_m > 0 && p.centroid_sigma_m <= 10, "centroid_sigma_m", "(0, 10] m", p.centroid_sigma_m);
  require_parameter(p.far_edge_forward_sigma_m >= 0 && p.far_edge_forward_sigma_m <= 1000, "far_edge_forward_sigma_m", "[0, 1000] m",
                    p.far_edge_forward_sigma_m);
  require_parameter(p.stereo_error.focal_px >= 0 && std::isfinite(p.stereo_error.focal_px), "stereo_error.focal_px", ">= 0 px", p.stereo_error.focal_px);
  require_parameter(p.stereo_error.baseline_m >= 0 && std::isfinite(p.stereo_error.baseline_m), "stereo_error.baseline_m", ">= 0 m",
          p.stereo_error.baseline_m);
  require_parameter(p.initial_speed_sigma_mps > 0 && p.initial_speed_sigma_mps <= 100, "initial_speed_sigma_mps", "(0, 100] m/s",
          p.initial_speed_sigma_mps);
  require_parameter(p.max_position_distance_m > 0 && p.max_position_distance_m <= 100, "max_position_distance_m", "(0, 100] m",
          p.max_position_distance_m);
  require_parameter(p.position_weight >= 0 && std::isfinite(p.position_weight), "position_weight", ">= 0", p.position_weight);
  require_parameter(p.size_weight >= 0 && std::isfinite(p.size_weight), "size_weight", ">= 0", p.size_weight);
  require_parameter(p.colour_weight >= 0 && std::isfinite(p.colour_weight), "colour_weight", ">= 0", p.colour_weight);
  require_parameter(p.density_weight >= 0 && std::isfinite(p.density_weight), "density_weight", ">= 0", p.density_weight);
  require_parameter(p.max_association_distance > 0 && std::isfinite(p.max_association_distance), "max_association_distance", "> 0",
          p.max_association_distance);
  require_parameter(p.acceptance_frames >= 1 && p.acceptance_frames <= 1000, "acceptance_frames", "[1, 1000]", p.acceptance_frames);
  require_parameter(p.ghost_frames >= 0 && p.ghost_frames <= 1000, "ghost_frames", "[0, 1000]", p.ghost_frames);
  require_parameter(p.moving_speed_mps >= 0 && p.moving_speed_mps <= 100, "moving_speed_mps", "[0, 100] m/s", p.moving_speed_mps);
  require_parameter(p.moving_min_updates >= 2 && p.moving_min_updates <= 1000, "moving_min_updates", "[2, 1000]", p.moving_min_updates);
  require_parameter(p.moving_consistency_frames >= 1 && p.moving_consistency_frames <= 1000, "moving_consistency_frames", "[1, 1000]",
          p.moving_consistency_frames);
  require_parameter(p.adoption_updates >= 0 && p.adoption_updates <= 1000, "adoption_updates", "[0, 1000]", p.adoption_updates);
  require_parameter(p.adoption_pixel_gap_px >= 0 && p.adoption_pixel_gap_px <= 1000, "adoption_pixel_gap_px", "[0, 1000] px",
                    p.adoption_pixel_gap_px);
  require_parameter(p.adoption_margin_m >= 0 && p.adoption_margin_m <= 100, "adoption_margin_m", "[0, 100] m", p.adoption_margin_m);
  require_parameter(p.innovation_gate_chi2 >= 0 && p.innovation_gate_chi2 <= 1000, "innovation_gate_chi2", "[0, 1000]", p.innovation_gate_chi2);
  require_parameter(p.moving_disparity_bias_px >= 0 && p.moving_disparity_bias_px <= 10, "moving_disparity_bias_px", "[0, 10] px",
                    p.moving_disparity_bias_px);
  require_parameter(p.feature_motion_min_features >= 0 && p.feature_motion_min_features <= 1000, "feature_motion_min_features", "[0, 1000]",
                    p.feature_motion_min_features);
  require_parameter(p.feature_pixel_sigma_px > 0 && p.feature_pixel_sigma_px <= 10, "feature_pixel_sigma_px", "(0, 10] px", p.feature_pixel_sigma_px);
  require_parameter(p.feature_disparity_sigma_px > 0 && p.feature_disparity_sigma_px <= 10, "feature_disparity_sigma_px", "(0, 10] px",
                    p.feature_disparity_sigma_px);
  require_parameter(p.feature_motion_sigma_mps >= 0 && p.feature_motion_sigma_mps <= 100, "feature_motion_sigma_mps", "[0, 100] m/s",
                    p.feature_motion_sigma_mps);
  require_parameter(p.feature_motion_gate_chi2 >= 0 && p.feature_motion_gate_chi2 <= 1000, "feature_motion_gate_chi2", "[0, 1000]",
                    p.feature_motion_gate_chi2);
  validate_fragment_merge_parameters(p.fragment_merge);
  require_parameter(p.moving_significance_chi2 >= 0 && p.moving_significance_chi2 <= 1000, "moving_significance_chi2", "[0, 1000]",
          p.moving_significance_chi2);
}

const char* track_queue_name(TrackQueue queue) {
  switch (queue) {
    case TrackQueue::acceptance: return "acceptance";
    case TrackQueue::tracked: return "tracked";
    case TrackQueue::ghost: return "ghost";
  }
  return "?";
}

ObstacleTracker3d::ObstacleTracker3d(const ObstacleTrackingParameters& parameters) : parameters_(parameters) {
  validate_tracking_parameters(parameters);
  camera_from_vehicle_ = CameraToVehicle(parameters.camera_mount).rotation().transpose();
}

namespace {

// The robust update (header, "Jumps"): a measurement whose normalized innovation squared exceeds
// the gate gets its noise scaled by NIS / gate, and is counted.
void scale_beyond_gate(double normalized_innovation_squared, double gate_chi2, Eigen::Matrix3d& noise, int64_t& gated_count) {
  if (normalized_innovation_squared <= gate_chi2) return;
  noise *= normalized_innovation_squared / gate_chi2;
  ++gated_count;
}

// A cluster's camera depth for the stereo terms, kept off zero (a cluster at the camera's plane).
double cluster_depth_m(const VoxelCluster& cluster) { return std::max(cluster.obstacle.position_m.z(), 0.1); }

}  // namespace

Eigen::Matrix3d ObstacleTracker3d::measurement_covariance(const VoxelCluster& cluster, const Eigen::Matrix3d& world_from_camera) const {
  const double centroid_variance = parameters_.centroid_sigma_m * parameters_.centroid_sigma_m;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity() * centroid_variance;
  const StereoErrorModel& stereo = parameters_.stereo_error;
  if (stereo.defined()) {
    const double depth_m = cluster_depth_m(cluster);
    const double lateral = stereo.lateral_sigma_m(depth_m), depth = stereo.depth_sigma_m(depth_m);
    const Eigen::Vector3d camera_variances(lateral * lateral, lateral * lateral, depth * depth);
    covariance += world_from_camera * camera_variances.asDiagonal() * world_from_camera.transpose();
  }
  return covariance;
}

double ObstacleTracker3d::association_distance(const Track3d& track, const VoxelCluster& cluster, double position_distance_m) const {
  const ObstacleTrackingParameters& p = parameters_;
  return p.position_weight * position_distance_m + p.size_weight * (track.size_world_m - cluster.size_world_m).cwiseAbs().sum() +
         p.colour_weight * colour_distance(track.rgb_mean, track.hsl_mean, cluster.rgb_mean, cluster.hsl_mean) +
         p.density_weight * std::abs(track.density - cluster.density);
}

ObstacleTracker3d::FeatureVelocity ObstacleTracker3d::feature_velocity(const VoxelCluster& cluster,
                                                                       const std::vector<FeatureMotion>& feature_motions,
                                                                       const Eigen::Matrix3d& world_from_camera, double voxel_size_m) const {
  const ObstacleTrackingParameters& p = parameters_;
  FeatureVelocity measurement;
  const std::array<int, 4>& box = cluster.obstacle.bbox_px;
  const double f = p.stereo_error.focal_px;
  // The median's axes (header): across the cluster's line of sight (horizontal, then the third
  // axis) and along it. A feature's error lies almost along its ray, and the rays of one cluster are
  // nearly parallel, so the two medians across the ray keep the lateral precision.
  const Eigen::Vector3d along = cluster.obstacle.position_m.norm() > 1e-6 ? Eigen::Vector3d(cluster.obstacle.position_m.normalized())
                                                                          : Eigen::Vector3d::UnitZ();
  Eigen::Vector3d across = along.cross(Eigen::Vector3d::UnitY());  // camera y is down: horizontal when the ray is not vertical
  if (across.norm() < 1e-6) across = Eigen::Vector3d::UnitX();
  across.normalize();
  Eigen::Matrix3d ray_axes;  // columns: across (horizontal), across (the third), along; camera frame
  ray_axes.col(0) = across;
  ray_axes.col(1) = along.cross(across).normalized();
  ray_axes.col(2) = along;
  std::array<std::vector<double>, 3> displacement_ray_m;
  Eigen::Matrix3d covariance_sum = Eigen::Matrix3d::Zero();  // camera frame
  for (const FeatureMotion& feature : feature_motions) {
    if (feature.left_px.x() < box[0] || feature.left_px.x() > box[2] + 1 || feature.left_px.y() < box[1] || feature.left_px.y() > box[3] + 1) {
      continue;
    }
    const Eigen::Vector3d& point = feature.position_m;
    const double d = feature.disparity_px, depth_margin_m = voxel_size_m + 2.0 * point.z() * p.feature_disparity_sigma_px / d;
    if (point.x() < cluster.camera_min_m.x() - voxel_size_m || point.x() > cluster.camera_max_m.x() + voxel_size_m ||
        point.y() < cluster.camera_min_m.y() - voxel_size_m || point.y() > cluster.camera_max_m.y() + voxel_size_m ||
        point.z() < cluster.camera_min_m.z() - depth_margin_m || point.z() > cluster.camera_max_m.z() + depth_margin_m) {
      continue;
    }
    const Eigen::Vector3d displacement = ray_axes.transpose() * feature.displacement_m;
    for (int axis = 0; axis < 3; ++axis) displacement_ray_m[static_cast<size_t>(axis)].push_back(displacement[axis]);
    Eigen::Matrix3d jacobian;  // d(X, Y, Z) / d(u, v, d)
    jacobian << point.z() / f, 0, -point.x() / d, 0, point.z() / f, -point.y() / d, 0, 0, -point.z() / d;
    const Eigen::Vector3d variances(p.feature_pixel_sigma_px * p.feature_pixel_sigma_px, p.feature_pixel_sigma_px * p.feature_pixel_sigma_px,
                                    p.feature_disparity_sigma_px * p.feature_disparity_sigma_px);
    covariance_sum += 2.0 * jacobian * variances.asDiagonal() * jacobian.transpose();
  }
  measurement.features = static_cast<int>(displacement_ray_m[0].size());
  if (measurement.features == 0) return measurement;
  const size_t middle = displacement_ray_m[0].size() / 2;
  Eigen::Vector3d median_ray_m;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double>& values = displacement_ray_m[static_cast<size_t>(axis)];
    std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle), values.end());
    median_ray_m[axis] = values[middle];
  }
  measurement.velocity_mps = world_from_camera * ray_axes * median_ray_m / p.frame_period_s;
  const double n = measurement.features;
  measurement.covariance = (M_PI / 2.0) * world_from_camera * covariance_sum * world_from_camera.transpose() /
                               (n * n * p.frame_period_s * p.frame_period_s) +
                           Eigen::Matrix3d::Identity() * p.feature_motion_sigma_mps * p.feature_motion_sigma_mps;
  return measurement;
}

void ObstacleTracker3d::apply_feature_velocity(Track3d& track, const FeatureVelocity& measurement) {
  const ObstacleTrackingParameters& p = parameters_;
  if (p.feature_motion_min_features == 0 || measurement.features < p.feature_motion_min_features) return;
  Eigen::Matrix3d noise = measurement.covariance;
  if (p.feature_motion_gate_chi2 > 0) {
    scale_beyond_gate(track.filter.normalized_velocity_innovation_squared(measurement.velocity_mps, noise), p.feature_motion_gate_chi2, noise,
                      result_.gated_velocity_updates);
  }
  track.filter.update_velocity(measurement.velocity_mps, noise);
  ++result_.feature_velocity_updates;
}

void ObstacleTracker3d::report(Track3d& track, const VoxelCluster& cluster, const Eigen::Matrix3d& camera_from_world) {
  track.size_world_m = cluster.size_world_m;
  track.rgb_mean = cluster.rgb_mean;
  track.hsl_mean = cluster.hsl_mean;
  track.density = cluster.density;
  track.obstacle = cluster.obstacle;
  track.obstacle.track_id = track.id;
  track.obstacle.velocity_mps = camera_from_world * track.filter.velocity_mps();
  track.obstacle.moving = track.moving;
}

const TrackingResult& ObstacleTracker3d::update(const std::vector<VoxelCluster>& input_clusters, const Eigen::Isometry3d& world_from_current,
                                                const std::vector<FeatureMotion>& feature_motions) {
  const ObstacleTrackingParameters& p = parameters_;
  result_ = TrackingResult{};
  // The voxel edge from a cluster's key box and its extent in metres (size_world_m = extent voxel_size_m).
  const double voxel_size_m =
      input_clusters.empty() ? 0.25 : input_clusters.front().size_world_m.x() / double(input_clusters.front().max_key.x - input_clusters.front().min_key.x + 1);
  const FragmentMergeResult fragments = merge_stereo_fragments(input_clusters, p.stereo_error, voxel_size_m, p.fragment_merge);
  const std::vector<VoxelCluster>& clusters = fragments.clusters;
  result_.merged_fragments = fragments.merged;
  const Eigen::Matrix3d world_from_camera = world_from_current.linear() * camera_from_vehicle_.transpose();
  const Eigen::Matrix3d camera_from_world = world_from_camera.transpose();
  const uint64_t previous_tracks = tracks_.size();
  // The vehicle's ground velocity from the last two poses (zero on the first frame).
  const Eigen::Vector3d vehicle_position_world_m = world_from_current.translation();
  const Eigen::Vector3d vehicle_velocity_world_mps =
      has_previous_pose_ ? Eigen::Vector3d((vehicle_position_world_m - previous_vehicle_position_world_m_) / p.frame_period_s) : Eigen::Vector3d::Zero();
  previous_vehicle_position_world_m_ = vehicle_position_world_m;
  has_previous_pose_ = true;
  uint64_t drift_terms = 0;

  for (Track3d& track : tracks_) {
    track.filter.predict(p.frame_period_s, p.accel_sigma_mps2);
    track.associated_this_frame = false;
  }
  std::vector<Eigen::Matrix3d> noise;
  noise.reserve(clusters.size());
  // A cluster at the candidates' far edge (voxel_clustering.h) has a forward position that says where
  // the candidates end, not where the object is: its forward coordinate gets far_edge_forward_sigma_m
  // more, so the filter keeps its lateral and vertical information and learns no depth motion from it.
  const Eigen::Vector3d world_forward = world_from_current.linear() * Eigen::Vector3d::UnitX();
  uint64_t far_edge_clusters = 0;
  for (const VoxelCluster& cluster : clusters) {
    noise.push_back(measurement_covariance(cluster, world_from_camera));
    if (cluster.at_candidate_far_edge) {
      noise.back() += p.far_edge_forward_sigma_m * p.far_edge_forward_sigma_m * world_forward * world_forward.transpose();
      ++far_edge_clusters;
    }
  }

  // Feature motion (header): each cluster's velocity measured by the odometry's points inside it.
  result_.feature_motions = static_cast<int64_t>(feature_motions.size());
  std::vector<FeatureVelocity> feature_velocities(clusters.size());
  uint64_t features_inside = 0, median_work = 0;
  const bool use_features = p.feature_motion_min_features > 0 && p.stereo_error.defined() && !feature_motions.empty();
  if (use_features) {
    for (size_t c = 0; c < clusters.size(); ++c) {
      feature_velocities[c] = feature_velocity(clusters[c], feature_motions, world_from_camera, voxel_size_m);
      const uint64_t m = static_cast<uint64_t>(feature_velocities[c].features);
      features_inside += m;
      median_work += 3 * m * (m > 1 ? static_cast<uint64_t>(std::bit_width(m - 1)) : 0);
    }
  }

  // Algorithm 3.2.3.4: greedy by increasing distance.
  struct Pair {
    double distance;
    int track, cluster;
  };
  std::vector<Pair> pairs;
  for (int t = 0; t < static_cast<int>(tracks_.size()); ++t) {
    for (int c = 0; c < static_cast<int>(clusters.size()); ++c) {
      const double position_distance = (clusters[c].centroid_world_m - tracks_[t].filter.position_m()).norm();
      if (position_distance > p.max_position_distance_m) continue;
      const double distance = association_distance(tracks_[t], clusters[c], position_distance);
      if (distance < p.max_association_distance) pairs.push_back(Pair{distance, t, c});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [&](const Pair& a, const Pair& b) {
    return std::tie(a.distance, tracks_[a.track].id, a.cluster) < std::tie(b.distance, tracks_[b.track].id, b.cluster);
  });
  result_.candidate_pairs = static_cast<int64_t>(pairs.size());
  std::vector<char> cluster_used(clusters.size(), 0);
  for (const Pair& pair : pairs) {
    Track3d& track = tracks_[pair.track];
    if (track.associated_this_frame || cluster_used[pair.cluster]) continue;
    track.associated_this_frame = true;
    cluster_used[pair.cluster] = 1;
    const VoxelCluster& cluster = clusters[pair.cluster];
    Eigen::Matrix3d measurement_noise = noise[pair.cluster];
    if (p.innovation_gate_chi2 > 0) {
      scale_beyond_gate(track.filter.normalized_innovation_squared(cluster.centroid_world_m, measurement_noise), p.innovation_gate_chi2,
                        measurement_noise, result_.gated_updates);
    }
    track.filter.update(cluster.centroid_world_m, measurement_noise);
    apply_feature_velocity(track, feature_velocities[static_cast<size_t>(pair.cluster)]);
    ++track.updates;
    ++track.consecutive_updates;
    track.misses = 0;
    ++result_.associations;
    if (track.queue == TrackQueue::ghost) {
      track.queue = TrackQueue::tracked;
      ++result_.revived;
    } else if (track.queue == TrackQueue::acceptance && track.consecutive_updates >= p.acceptance_frames) {
      track.queue = TrackQueue::tracked;
      ++result_.confirmed;
    }
    if (track.updates >= p.moving_min_updates && !cluster.truncated) {
      const Eigen::Vector2d velocity = track.filter.velocity_mps().head<2>();
      Eigen::Matrix2d velocity_covariance = track.filter.covariance().block<2, 2>(3, 3);
      if (p.moving_disparity_bias_px > 0 && p.stereo_error.defined()) {  // the range drift of a disparity bias (header)
        ++drift_terms;
        const Eigen::Vector2d line_of_sight = (track.filter.position_m() - vehicle_position_world_m).head<2>();
        if (line_of_sight.norm() > 1e-6) {
          const Eigen::Vector2d along = line_of_sight.normalized();
          const double drift_mps = p.stereo_error.range_drift_mps(cluster_depth_m(cluster), vehicle_velocity_world_mps.head<2>().dot(along),
                                                                  p.moving_disparity_bias_px);
          velocity_covariance += drift_mps * drift_mps * along * along.transpose();
        }
      }
      const bool fast = velocity.norm() > p.moving_speed_mps &&
                        velocity.dot(velocity_covariance.inverse() * velocity) > p.moving_significance_chi2;
      track.moving_votes = fast ? track.moving_votes + 1 : 0;
      track.static_votes = fast ? 0 : track.static_votes + 1;
      if (track.moving_votes >= p.moving_consistency_frames) track.moving = true;
      if (track.static_votes >= p.moving_consistency_frames) track.moving = false;
    }
    report(track, cluster, camera_from_world);
  }

  // Misses: acceptance -> discarded, tracked -> ghost, ghost -> deleted after ghost_frames.
  std::vector<Track3d> kept;
  kept.reserve(tracks_.size() + clusters.size());
  for (Track3d& track : tracks_) {
    ++track.age_frames;
    if (!track.associated_this_frame) {
      ++track.misses;
      track.consecutive_updates = 0;
      if (track.queue == TrackQueue::acceptance) {
        ++result_.discarded;
        continue;
      }
      if (track.queue == TrackQueue::tracked) {
        track.queue = TrackQueue::ghost;
        ++result_.ghosted;
      } else if (track.misses > p.ghost_frames) {
        ++result_.deleted;
        continue;
      }
    }
    kept.push_back(std::move(track));
  }
  tracks_ = std::move(kept);

  // New tracks from the clusters nobody took.
  for (int c = 0; c < static_cast<int>(clusters.size()); ++c) {
    if (cluster_used[c]) continue;
    Track3d track;
    track.id = next_id_++;
    track.age_frames = 1;
    track.updates = track.consecutive_updates = 1;
    track.associated_this_frame = true;
    track.filter = ConstantVelocityFilter3d(clusters[c].centroid_world_m, noise[c], p.initial_speed_sigma_mps);
    apply_feature_velocity(track, feature_velocities[static_cast<size_t>(c)]);
    track.queue = p.acceptance_frames <= 1 ? TrackQueue::tracked : TrackQueue::acceptance;
    if (track.queue == TrackQueue::tracked) ++result_.confirmed;
    report(track, clusters[c], camera_from_world);
    tracks_.push_back(std::move(track));
    ++result_.new_tracks;
  }

  // Fragment adoption (header): a young reported track reports the motion of the established track it
  // is a piece of.
  uint64_t adoption_tests = 0;
  if (p.adoption_updates > 0) {
    for (Track3d& track : tracks_) {
      if (track.queue != TrackQueue::tracked || !track.associated_this_frame || track.updates >= p.adoption_updates) continue;
      const Track3d* parent = nullptr;
      double parent_distance_m = 0;
      for (const Track3d& candidate : tracks_) {
        ++adoption_tests;
        if (candidate.queue != TrackQueue::tracked || !candidate.associated_this_frame || candidate.updates < p.adoption_updates) continue;
        // At most adoption_pixel_gap_px empty pixels between the boxes: grown by the gap plus one.
        if (!pixel_boxes_within(candidate.obstacle.bbox_px, track.obstacle.bbox_px, p.adoption_pixel_gap_px + 1)) continue;
        const double distance_m = (track.filter.position_m() - candidate.filter.position_m()).head<2>().norm();
        const double reach_m =
            0.5 * candidate.size_world_m.head<2>().norm() + 0.5 * track.size_world_m.head<2>().norm() + p.adoption_margin_m;
        if (distance_m <= reach_m && (parent == nullptr || distance_m < parent_distance_m)) parent = &candidate, parent_distance_m = distance_m;
      }
      if (parent != nullptr) {
        track.obstacle.moving = parent->obstacle.moving;
        track.obstacle.velocity_mps = parent->obstacle.velocity_mps;
        ++result_.adopted;
      }
    }
  }
  for (const Track3d& track : tracks_) {
    if (track.queue == TrackQueue::tracked && track.associated_this_frame) result_.obstacles.push_back(track.obstacle);
  }
  for (size_t i = 0; i < result_.obstacles.size(); ++i) result_.obstacles[i].id = static_cast<int>(i);

  const uint64_t t = previous_tracks, c = clusters.size(), g = pairs.size(), u = static_cast<uint64_t>(result_.associations),
                 n = static_cast<uint64_t>(result_.new_tracks), o = result_.obstacles.size();
  const uint64_t log_g = g > 1 ? static_cast<uint64_t>(std::bit_width(g - 1)) : 0;
  const uint64_t gate_tests = parameters_.innovation_gate_chi2 > 0 ? u : 0;
  result_.work.scalar_ops = 16 + 150 * t + 60 * c + 15 * far_edge_clusters + 40 * t * c + 4 * g * log_g + 4 * g + 45 * gate_tests + 400 * u + 25 * drift_terms +
                            60 * n + 30 * o + 8 * t + 20 * adoption_tests +
                            (use_features ? 12 * feature_motions.size() * c : 0) + 60 * features_inside + median_work +
                            350 * static_cast<uint64_t>(result_.feature_velocity_updates);
  result_.work.memory_bytes = sizeof(Track3d) * 2 * (t + n) + sizeof(VoxelCluster) * c;
  result_.work.scalar_ops += fragments.work.scalar_ops;
  result_.work.memory_bytes += fragments.work.memory_bytes;
  return result_;
}

}  // namespace lpstereo::arm::obstacles3d
