// The voxel map: model, life rule and counted work in voxel_map.h.
#include "arm/obstacles3d/voxel_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "arm/obstacles3d/parameter_check.h"

namespace lpstereo::arm::obstacles3d {

namespace {

std::string number_text(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

// value in [minimum, maximum] (NaN refused), else "<name>: expected [minimum, maximum] unit, got value".
void require_range(const char* name, double value, double minimum, double maximum, const char* unit) {
  require_parameter(value >= minimum && value <= maximum, name, "[" + number_text(minimum) + ", " + number_text(maximum) + "]" + unit,
                    value);
}

void require_less(const char* lower_name, double lower, const char* upper_name, double upper) {
  require_parameter(lower < upper, lower_name, std::string("< ") + upper_name + " (" + number_text(upper) + ")", lower);
}

}  // namespace

double hue_from_circular_sums(double cos_sum, double sin_sum) {
  double hue = std::atan2(sin_sum, cos_sum) / (2.0 * std::numbers::pi);
  if (hue < 0) hue += 1.0;
  return hue >= 1.0 ? 0.0 : hue;
}

Hsl hsl_from_rgb(const std::array<uint8_t, 3>& rgb) {
  const double r = rgb[0] / 255.0, g = rgb[1] / 255.0, b = rgb[2] / 255.0;
  const double maximum = std::max({r, g, b}), minimum = std::min({r, g, b});
  const double chroma = maximum - minimum;
  Hsl hsl;
  hsl.lightness = (maximum + minimum) / 2.0;
  if (chroma <= 0.0) return hsl;  // achromatic: hue and saturation 0
  hsl.saturation = chroma / (1.0 - std::abs(2.0 * hsl.lightness - 1.0));
  double sector;  // hue in sixths of a turn
  if (maximum == r) {
    sector = std::fmod((g - b) / chroma, 6.0);
    if (sector < 0) sector += 6.0;
  } else if (maximum == g) {
    sector = (b - r) / chroma + 2.0;
  } else {
    sector = (r - g) / chroma + 4.0;
  }
  hsl.hue = sector / 6.0;
  if (hsl.hue >= 1.0) hsl.hue -= 1.0;
  hsl.saturation = std::min(hsl.saturation, 1.0);  // rounding at L = 0 or 1
  return hsl;
}

void ColourStatistics::add(const std::array<uint8_t, 3>& rgb, const Hsl& hsl) {
  ++count;
  const Eigen::Vector3d value(rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
  rgb_sum += value;
  rgb_square_sum += value.cwiseProduct(value);
  const double angle = 2.0 * std::numbers::pi * hsl.hue;
  hue_cos_sum += std::cos(angle);
  hue_sin_sum += std::sin(angle);
  saturation_sum += hsl.saturation;
  saturation_square_sum += hsl.saturation * hsl.saturation;
  lightness_sum += hsl.lightness;
  lightness_square_sum += hsl.lightness * hsl.lightness;
}

Eigen::Vector3d ColourStatistics::rgb_mean() const { return count > 0 ? Eigen::Vector3d(rgb_sum / double(count)) : Eigen::Vector3d::Zero(); }

Eigen::Vector3d ColourStatistics::rgb_variance() const {
  if (count == 0) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d mean = rgb_mean();
  return (rgb_square_sum / double(count) - mean.cwiseProduct(mean)).cwiseMax(0.0);
}

Hsl ColourStatistics::hsl_mean() const {
  Hsl mean;
  if (count == 0) return mean;
  mean.hue = hue_from_circular_sums(hue_cos_sum, hue_sin_sum);
  mean.saturation = saturation_sum / double(count);
  mean.lightness = lightness_sum / double(count);
  return mean;
}

Eigen::Vector3d ColourStatistics::hsl_variance() const {
  if (count == 0) return Eigen::Vector3d::Zero();
  const double n = double(count);
  const double resultant = std::hypot(hue_cos_sum, hue_sin_sum) / n;
  const double saturation_mean = saturation_sum / n, lightness_mean = lightness_sum / n;
  return Eigen::Vector3d(std::max(0.0, 1.0 - resultant), std::max(0.0, saturation_square_sum / n - saturation_mean * saturation_mean),
                         std::max(0.0, lightness_square_sum / n - lightness_mean * lightness_mean));
}

std::string VoxelMapStatus::text() const {
  std::ostringstream line;
  line << "voxel map frame " << frame_index << ": " << ego_motion_note << "; points " << points_in << " in, " << points_inserted
       << " inserted, " << points_clipped_out_of_bounds << " clipped beyond the map bounds, " << points_not_finite
       << " not finite; voxels " << voxel_count << " (" << voxels_observed << " observed, " << voxels_created << " created, "
       << voxels_removed_unobserved << " removed unobserved in view, " << voxels_removed_out_of_bounds << " left the bounds)";
  return line.str();
}

VoxelMap::VoxelMap(const VoxelMapParameters& parameters) : parameters_(parameters) {
  require_range("voxel_size_m", parameters.voxel_size_m, 0.05, 0.5, " m");
  require_range("max_forward_m", parameters.max_forward_m, 0.1, 1e4, " m");
  require_range("min_forward_m", parameters.min_forward_m, -1e4, 1e4, " m");
  require_less("min_forward_m", parameters.min_forward_m, "max_forward_m", parameters.max_forward_m);
  require_range("max_lateral_m", parameters.max_lateral_m, 0.1, 1e4, " m");
  require_range("min_up_m", parameters.min_up_m, -1e4, 1e4, " m");
  require_range("max_up_m", parameters.max_up_m, -1e4, 1e4, " m");
  require_less("min_up_m", parameters.min_up_m, "max_up_m", parameters.max_up_m);
  require_range("view_half_angle_rad", parameters.view_half_angle_rad, 1e-3, std::numbers::pi / 2, " rad");
  require_range("max_unobserved_frames", parameters.max_unobserved_frames, 0, 1000000, " frames");
}

const Voxel* VoxelMap::find(const VoxelKey& key) const {
  const auto found = voxels_.find(key);
  return found == voxels_.end() ? nullptr : &found->second;
}

VoxelKey VoxelMap::key_of(const Eigen::Vector3d& world_m) const {
  const Eigen::Vector3d scaled = (world_m / parameters_.voxel_size_m).array().floor();
  return VoxelKey{static_cast<int32_t>(scaled.x()), static_cast<int32_t>(scaled.y()), static_cast<int32_t>(scaled.z())};
}

Eigen::Vector3d VoxelMap::centre_of(const VoxelKey& key) const {
  return (Eigen::Vector3d(key.x, key.y, key.z) + Eigen::Vector3d::Constant(0.5)) * parameters_.voxel_size_m;
}

bool VoxelMap::inside_bounds(const Eigen::Vector3d& vehicle_m) const {
  const VoxelMapParameters& p = parameters_;
  return vehicle_m.x() >= p.min_forward_m && vehicle_m.x() <= p.max_forward_m && std::abs(vehicle_m.y()) <= p.max_lateral_m &&
         vehicle_m.z() >= p.min_up_m && vehicle_m.z() <= p.max_up_m;
}

bool VoxelMap::near_bounds(const VoxelKey& key, double margin_m) const {
  const VoxelMapParameters& p = parameters_;
  const Eigen::Vector3d vehicle = world_from_current_.inverse() * centre_of(key);
  return vehicle.x() < p.min_forward_m + margin_m || vehicle.x() > p.max_forward_m - margin_m ||
         std::abs(vehicle.y()) > p.max_lateral_m - margin_m || vehicle.z() < p.min_up_m + margin_m || vehicle.z() > p.max_up_m - margin_m;
}

bool VoxelMap::in_view(const Eigen::Vector3d& vehicle_m) const {
  return vehicle_m.x() > 0.0 && std::abs(std::atan2(vehicle_m.y(), vehicle_m.x())) <= parameters_.view_half_angle_rad;
}

const VoxelMapStatus& VoxelMap::update(const std::vector<ObstaclePoint>& points, const EgoMotion& ego_motion) {
  const int64_t frame = status_.frame_index + 1;
  status_ = VoxelMapStatus{};
  status_.frame_index = frame;
  status_.ego_motion_available = ego_motion.available;
  if (frame == 0) {
    world_from_current_ = Eigen::Isometry3d::Identity();
    status_.ego_motion_note = ego_motion.available ? "first frame: world = this vehicle frame"
                                                   : "first frame: world = this vehicle frame; no ego-motion: static camera assumed";
  } else if (ego_motion.available) {
    world_from_current_ = world_from_current_ * ego_motion.previous_from_current;
    status_.ego_motion_note = "ego-motion applied";
  } else {
    status_.ego_motion_note = "no ego-motion: static camera assumed";
  }
  status_.points_in = static_cast<int64_t>(points.size());

  // Keys must fit int32 with a margin (the neighbourhood of the clustering adds 1).
  const double key_limit = static_cast<double>(std::numeric_limits<int32_t>::max() - 2);
  for (const ObstaclePoint& point : points) {
    const Eigen::Vector3d vehicle = point.vehicle_m.cast<double>();
    if (!vehicle.allFinite() || !point.camera_m.allFinite() || !std::isfinite(point.height_above_ground_m)) {
      ++status_.points_not_finite;
      continue;
    }
    if (!inside_bounds(vehicle)) {
      ++status_.points_clipped_out_of_bounds;
      continue;
    }
    const Eigen::Vector3d world = world_from_current_ * vehicle;
    if ((world / parameters_.voxel_size_m).cwiseAbs().maxCoeff() > key_limit) {
      ++status_.points_clipped_out_of_bounds;
      continue;
    }
    const VoxelKey key = key_of(world);
    auto [slot, created] = voxels_.try_emplace(key);
    Voxel& voxel = slot->second;
    if (created) {
      voxel.key = key;
      voxel.first_seen_frame = frame;
      ++status_.voxels_created;
    }
    if (created || voxel.last_seen_frame != frame || voxel.frame_point_count == 0) {
      // First point of this frame in this voxel: reset the frame's statistics.
      voxel.last_seen_frame = frame;
      ++voxel.frames_observed;
      voxel.unobserved_frames = 0;
      voxel.frame_point_count = 0;
      voxel.frame_world_sum_m.setZero();
      voxel.frame_camera_sum_m.setZero();
      voxel.frame_camera_min_m = voxel.frame_camera_max_m = point.camera_m;
      voxel.frame_height_sum_m = 0;
      voxel.frame_min_height_m = voxel.frame_max_height_m = point.height_above_ground_m;
      voxel.frame_max_disparity_px = point.disparity_px;
      voxel.frame_bbox_px = {point.u_px, point.v_px, point.u_px, point.v_px};
      ++status_.voxels_observed;
    }
    ++voxel.point_count;
    voxel.world_sum_m += world;
    voxel.colour.add(point.rgb, hsl_from_rgb(point.rgb));
    ++voxel.frame_point_count;
    voxel.frame_world_sum_m += world;
    voxel.frame_camera_sum_m += point.camera_m.cast<double>();
    voxel.frame_camera_min_m = voxel.frame_camera_min_m.cwiseMin(point.camera_m);
    voxel.frame_camera_max_m = voxel.frame_camera_max_m.cwiseMax(point.camera_m);
    voxel.frame_height_sum_m += point.height_above_ground_m;
    voxel.frame_min_height_m = std::min(voxel.frame_min_height_m, point.height_above_ground_m);
    voxel.frame_max_height_m = std::max(voxel.frame_max_height_m, point.height_above_ground_m);
    voxel.frame_max_disparity_px = std::max(voxel.frame_max_disparity_px, point.disparity_px);
    voxel.frame_bbox_px = {std::min<int>(voxel.frame_bbox_px[0], point.u_px), std::min<int>(voxel.frame_bbox_px[1], point.v_px),
                           std::max<int>(voxel.frame_bbox_px[2], point.u_px), std::max<int>(voxel.frame_bbox_px[3], point.v_px)};
    ++status_.points_inserted;
  }

  // The sweep: decay in view, removal out of bounds (life rule, header comment).
  status_.voxels_swept = static_cast<int64_t>(voxels_.size());
  const Eigen::Isometry3d current_from_world = world_from_current_.inverse();
  for (auto it = voxels_.begin(); it != voxels_.end();) {
    Voxel& voxel = it->second;
    if (voxel.last_seen_frame == frame) {
      ++it;
      continue;
    }
    voxel.frame_point_count = 0;  // its frame statistics are stale
    const Eigen::Vector3d vehicle = current_from_world * centre_of(voxel.key);
    bool remove = false;
    if (!inside_bounds(vehicle)) {
      remove = true;
      ++status_.voxels_removed_out_of_bounds;
    } else if (in_view(vehicle) && vehicle.x() >= parameters_.min_forward_m) {
      ++voxel.unobserved_frames;
      if (voxel.unobserved_frames > parameters_.max_unobserved_frames) {
        remove = true;
        ++status_.voxels_removed_unobserved;
      }
    }
    it = remove ? voxels_.erase(it) : std::next(it);
  }
  status_.voxel_count = static_cast<int64_t>(voxels_.size());
  status_.work = expected_work(status_);
  return status_;
}

ArmWork VoxelMap::expected_work(const VoxelMapStatus& status) {
  const uint64_t n = static_cast<uint64_t>(status.points_in), i = static_cast<uint64_t>(status.points_inserted),
                 c = static_cast<uint64_t>(status.voxels_created), v = static_cast<uint64_t>(status.voxels_swept),
                 r = static_cast<uint64_t>(status.voxels_removed_unobserved + status.voxels_removed_out_of_bounds);
  ArmWork work;
  work.scalar_ops = 24 + 12 * n + (18 + 6 + 10 + 24 + 40) * i + 16 * c + 20 * v + 8 * r;
  work.memory_bytes = sizeof(ObstaclePoint) * n + sizeof(Voxel) * (2 * i + c + v + r);
  return work;
}

}  // namespace lpstereo::arm::obstacles3d
