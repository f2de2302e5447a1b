// Colour flood-fill clustering of the voxel map: model, algorithms and counted work in voxel_clustering.h.
#include "arm/obstacles3d/voxel_clustering.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <deque>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "arm/obstacles3d/parameter_check.h"

namespace lpstereo::arm::obstacles3d {

namespace {

// Running colour mean of a set of voxels (each voxel once), hue averaged on the circle.
struct ColourMean {
  Eigen::Vector3d rgb_sum = Eigen::Vector3d::Zero();
  double hue_cos_sum = 0, hue_sin_sum = 0, saturation_sum = 0, lightness_sum = 0;
  int count = 0;

  void add(const Eigen::Vector3d& rgb, const Hsl& hsl) {
    rgb_sum += rgb;
    const double angle = 2.0 * std::numbers::pi * hsl.hue;
    hue_cos_sum += std::cos(angle);
    hue_sin_sum += std::sin(angle);
    saturation_sum += hsl.saturation;
    lightness_sum += hsl.lightness;
    ++count;
  }
  Eigen::Vector3d rgb() const { return count > 0 ? Eigen::Vector3d(rgb_sum / count) : Eigen::Vector3d::Zero(); }
  Hsl hsl() const {
    Hsl mean;
    if (count == 0) return mean;
    mean.hue = hue_from_circular_sums(hue_cos_sum, hue_sin_sum);
    mean.saturation = saturation_sum / count;
    mean.lightness = lightness_sum / count;
    return mean;
  }
};

struct Candidate {
  const Voxel* voxel = nullptr;
  Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
  Hsl hsl;
  int label = -1;
};

// The 26 offsets of the Chebyshev unit ball without its centre.
std::array<Eigen::Vector3i, 26> neighbour_offsets() {
  std::array<Eigen::Vector3i, 26> offsets;
  int n = 0;
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        if (dx != 0 || dy != 0 || dz != 0) offsets[n++] = Eigen::Vector3i(dx, dy, dz);
      }
    }
  }
  return offsets;
}

VoxelKey offset_key(const VoxelKey& key, const Eigen::Vector3i& offset) {
  return VoxelKey{key.x + offset.x(), key.y + offset.y(), key.z + offset.z()};
}

}  // namespace

double colour_distance(const Eigen::Vector3d& rgb_a, const Hsl& hsl_a, const Eigen::Vector3d& rgb_b, const Hsl& hsl_b) {
  const double hue_step = std::abs(hsl_a.hue - hsl_b.hue);
  const double hue_difference = std::min(hue_step, 1.0 - hue_step);
  return (rgb_a - rgb_b).norm() + hue_difference * std::min(hsl_a.saturation, hsl_b.saturation) +
         std::abs(hsl_a.saturation - hsl_b.saturation) + std::abs(hsl_a.lightness - hsl_b.lightness);
}

void validate_clustering_parameters(const VoxelClusteringParameters& p) {
  require_parameter(std::isfinite(p.min_height_above_ground_m) && std::abs(p.min_height_above_ground_m) <= 100.0, "min_height_above_ground_m",
          "a finite height in [-100, 100] m", p.min_height_above_ground_m);
  require_parameter(p.similarity_threshold > 0.0 && p.similarity_threshold <= 10.0, "similarity_threshold", "(0, 10]", p.similarity_threshold);
  require_parameter(p.small_cluster_voxels >= 1 && p.small_cluster_voxels <= 1000000, "small_cluster_voxels", "[1, 1000000]",
          p.small_cluster_voxels);
  require_parameter(p.min_cluster_voxels >= 1 && p.min_cluster_voxels <= 1000000, "min_cluster_voxels", "[1, 1000000]", p.min_cluster_voxels);
  require_parameter(p.min_density >= 0.0 && p.min_density <= 1.0, "min_density", "[0, 1]", p.min_density);
  require_parameter(p.image_width_px >= 0 && p.image_width_px <= 100000, "image_width_px", "[0, 100000] (0: unknown)", p.image_width_px);
  require_parameter(p.image_height_px >= 0 && p.image_height_px <= 100000, "image_height_px", "[0, 100000] (0: unknown)", p.image_height_px);
  require_parameter(p.border_margin_px >= 0 && p.border_margin_px <= 1000, "border_margin_px", "[0, 1000]", p.border_margin_px);
}

ClusteringResult cluster_voxels(const VoxelMap& map, const VoxelClusteringParameters& parameters) {
  validate_clustering_parameters(parameters);
  ClusteringResult result;
  static const std::array<Eigen::Vector3i, 26> kOffsets = neighbour_offsets();

  // Candidates in increasing key order, and their index by key.
  std::vector<Candidate> candidates;
  for (const auto& [key, voxel] : map.voxels()) {
    if (map.observed_this_frame(voxel) && voxel.frame_mean_height_m() >= parameters.min_height_above_ground_m) {
      candidates.push_back(Candidate{&voxel, voxel.colour.rgb_mean(), voxel.colour.hsl_mean(), -1});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) { return a.voxel->key < b.voxel->key; });
  const int64_t candidate_count = static_cast<int64_t>(candidates.size());
  result.candidate_voxels = candidate_count;
  std::unordered_map<VoxelKey, int, VoxelKeyHash> index_of;
  index_of.reserve(candidates.size() * 2);
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) index_of.emplace(candidates[i].voxel->key, i);
  auto lookup = [&](const VoxelKey& key) {
    const auto found = index_of.find(key);
    return found == index_of.end() ? -1 : found->second;
  };

  // Algorithm 3.2.3.1: flood fill.
  std::vector<std::vector<int>> members;
  std::deque<int> queue;
  for (int seed = 0; seed < static_cast<int>(candidates.size()); ++seed) {
    if (candidates[seed].label >= 0) continue;
    const int label = static_cast<int>(members.size());
    members.emplace_back();
    ColourMean mean;
    candidates[seed].label = label;
    members[label].push_back(seed);
    mean.add(candidates[seed].rgb, candidates[seed].hsl);
    queue.push_back(seed);
    while (!queue.empty()) {
      const int current = queue.front();
      queue.pop_front();
      const VoxelKey key = candidates[current].voxel->key;
      for (const Eigen::Vector3i& offset : kOffsets) {
        ++result.neighbour_probes;
        const int neighbour = lookup(offset_key(key, offset));
        if (neighbour < 0 || candidates[neighbour].label >= 0) continue;
        ++result.similarity_tests;
        if (colour_distance(candidates[neighbour].rgb, candidates[neighbour].hsl, mean.rgb(), mean.hsl()) < parameters.similarity_threshold) {
          candidates[neighbour].label = label;
          members[label].push_back(neighbour);
          mean.add(candidates[neighbour].rgb, candidates[neighbour].hsl);
          queue.push_back(neighbour);
        }
      }
    }
  }
  result.flood_fill_clusters = static_cast<int64_t>(members.size());

  // Algorithm 3.2.3.2: small clusters into the big neighbour with the most voxels next to them.
  const size_t big = static_cast<size_t>(parameters.small_cluster_voxels);
  std::vector<int> adjacent_mark(candidates.size(), -1);  // the small cluster that last counted this voxel
  std::unordered_map<int, int> adjacent_count;
  for (int label = 0; label < static_cast<int>(members.size()); ++label) {
    if (members[label].empty() || members[label].size() >= big) continue;
    adjacent_count.clear();
    for (const int member : members[label]) {
      const VoxelKey key = candidates[member].voxel->key;
      for (const Eigen::Vector3i& offset : kOffsets) {
        ++result.neighbour_probes;
        const int neighbour = lookup(offset_key(key, offset));
        if (neighbour < 0 || adjacent_mark[neighbour] == label) continue;
        const int other = candidates[neighbour].label;
        if (other == label || members[other].size() < big) continue;
        adjacent_mark[neighbour] = label;
        ++adjacent_count[other];
      }
    }
    int target = -1, target_count = 0;
    for (const auto& [other, count] : adjacent_count) {
      if (count > target_count || (count == target_count && other < target)) target = other, target_count = count;
    }
    if (target < 0) continue;
    for (const int member : members[label]) candidates[member].label = target;
    members[target].insert(members[target].end(), members[label].begin(), members[label].end());
    members[label].clear();
    ++result.aggregated_clusters;
  }

  // Algorithm 3.2.3.3: noise removal, then the cluster's fields.
  for (std::vector<int>& cluster_members : members) {
    if (cluster_members.empty()) continue;
    if (static_cast<int>(cluster_members.size()) < parameters.min_cluster_voxels) {
      ++result.removed_small;
      continue;
    }
    std::sort(cluster_members.begin(), cluster_members.end());  // increasing key order (candidates are sorted)
    VoxelCluster cluster;
    ColourMean mean;
    Eigen::Vector3d world_sum = Eigen::Vector3d::Zero();
    Eigen::Vector3f camera_min = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    Eigen::Vector3f camera_max = Eigen::Vector3f::Constant(std::numeric_limits<float>::lowest());
    float min_height = std::numeric_limits<float>::max(), max_height = std::numeric_limits<float>::lowest();
    std::array<int, 4> box{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(), -1, -1};
    cluster.min_key = cluster.max_key = candidates[cluster_members.front()].voxel->key;
    for (const int member : cluster_members) {
      const Candidate& candidate = candidates[member];
      const Voxel& voxel = *candidate.voxel;
      cluster.voxels.push_back(voxel.key);
      cluster.truncated = cluster.truncated || map.near_bounds(voxel.key, map.parameters().voxel_size_m);
      mean.add(candidate.rgb, candidate.hsl);
      cluster.frame_points += voxel.frame_point_count;
      world_sum += voxel.frame_world_sum_m;
      camera_min = camera_min.cwiseMin(voxel.frame_camera_min_m);
      camera_max = camera_max.cwiseMax(voxel.frame_camera_max_m);
      min_height = std::min(min_height, voxel.frame_min_height_m);
      max_height = std::max(max_height, voxel.frame_max_height_m);
      box = {std::min(box[0], voxel.frame_bbox_px[0]), std::min(box[1], voxel.frame_bbox_px[1]), std::max(box[2], voxel.frame_bbox_px[2]),
             std::max(box[3], voxel.frame_bbox_px[3])};
      cluster.min_key = VoxelKey{std::min(cluster.min_key.x, voxel.key.x), std::min(cluster.min_key.y, voxel.key.y),
                                 std::min(cluster.min_key.z, voxel.key.z)};
      cluster.max_key = VoxelKey{std::max(cluster.max_key.x, voxel.key.x), std::max(cluster.max_key.y, voxel.key.y),
                                 std::max(cluster.max_key.z, voxel.key.z)};
    }
    const Eigen::Vector3d extent_voxels(double(cluster.max_key.x) - cluster.min_key.x + 1, double(cluster.max_key.y) - cluster.min_key.y + 1,
                                        double(cluster.max_key.z) - cluster.min_key.z + 1);
    cluster.density = double(cluster_members.size()) / extent_voxels.prod();
    if (cluster.density < parameters.min_density) {
      ++result.removed_sparse;
      continue;
    }
    cluster.size_world_m = extent_voxels * map.parameters().voxel_size_m;
    cluster.centroid_world_m = world_sum / double(std::max<int64_t>(1, cluster.frame_points));
    cluster.rgb_mean = mean.rgb();
    cluster.hsl_mean = mean.hsl();
    const int margin = parameters.border_margin_px;
    if (parameters.image_width_px > 0 && parameters.image_height_px > 0 &&
        (box[0] <= margin || box[1] <= margin || box[2] >= parameters.image_width_px - 1 - margin ||
         box[3] >= parameters.image_height_px - 1 - margin)) {
      cluster.truncated = true;
    }
    Obstacle3d& obstacle = cluster.obstacle;
    obstacle.id = static_cast<int>(result.clusters.size());
    obstacle.bbox_px = box;
    obstacle.position_m = ((camera_min + camera_max) / 2.0f).cast<double>();
    obstacle.size_m = (camera_max - camera_min).cast<double>();
    obstacle.min_height_m = min_height;
    obstacle.max_height_m = max_height;
    result.clusters.push_back(std::move(cluster));
  }

  const uint64_t v = map.voxels().size(), k = static_cast<uint64_t>(candidate_count);
  const uint64_t log_k = k > 1 ? static_cast<uint64_t>(std::bit_width(k - 1)) : 0;
  result.work.scalar_ops = 4 * v + 4 * k * log_k + 8 * static_cast<uint64_t>(result.neighbour_probes) +
                           36 * static_cast<uint64_t>(result.similarity_tests) + 16 * k + 8 * static_cast<uint64_t>(result.aggregated_clusters) +
                           40 * static_cast<uint64_t>(result.flood_fill_clusters) + 30 * k;
  result.work.memory_bytes = sizeof(Voxel) * (v + 2 * k);
  return result;
}

}  // namespace lpstereo::arm::obstacles3d
