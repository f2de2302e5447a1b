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

  void add(const Eigen::Vector3d& rgb, const Hsl& hsl, int weight = 1) {
    rgb_sum += weight * rgb;
    const double angle = 2.0 * std::numbers::pi * hsl.hue;
    hue_cos_sum += weight * std::cos(angle);
    hue_sin_sum += weight * std::sin(angle);
    saturation_sum += weight * hsl.saturation;
    lightness_sum += weight * hsl.lightness;
    count += weight;
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
  require_parameter(p.candidate_forward_max_m == 0.0 || (p.candidate_forward_max_m > 0.0 && p.candidate_forward_max_m <= 1000.0),
                    "candidate_forward_max_m", "0 (not tested) or (0, 1000] m", p.candidate_forward_max_m);
  require_parameter(p.candidate_far_edge_margin_m >= 0.0 && p.candidate_far_edge_margin_m <= 100.0, "candidate_far_edge_margin_m", "[0, 100] m",
                    p.candidate_far_edge_margin_m);
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
  const Eigen::Isometry3d current_from_world = map.world_from_current().inverse();  // for the candidates' far edge
  for (std::vector<int>& cluster_members : members) {
    if (cluster_members.empty()) continue;
    if (static_cast<int>(cluster_members.size()) < parameters.min_cluster_voxels) {
      ++result.removed_small;
      continue;
    }
    std::sort(cluster_members.begin(), cluster_members.end());  // increasing key order (candidates are sorted)
    VoxelCluster cluster;
    ColourMean mean;
    Eigen::Vector3d world_sum = Eigen::Vector3d::Zero(), camera_sum = Eigen::Vector3d::Zero();
    Eigen::Vector3f camera_min = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
    Eigen::Vector3f camera_max = Eigen::Vector3f::Constant(std::numeric_limits<float>::lowest());
    float min_height = std::numeric_limits<float>::max(), max_height = std::numeric_limits<float>::lowest();
    std::array<int, 4> box{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(), -1, -1};
    float max_disparity_px = 0;
    cluster.min_key = cluster.max_key = candidates[cluster_members.front()].voxel->key;
    for (const int member : cluster_members) {
      const Candidate& candidate = candidates[member];
      const Voxel& voxel = *candidate.voxel;
      cluster.voxels.push_back(voxel.key);
      cluster.truncated = cluster.truncated || map.near_bounds(voxel.key, map.parameters().voxel_size_m);
      if (parameters.candidate_forward_max_m > 0.0 &&
          (current_from_world * map.centre_of(voxel.key)).x() > parameters.candidate_forward_max_m - parameters.candidate_far_edge_margin_m) {
        cluster.at_candidate_far_edge = true;
      }
      mean.add(candidate.rgb, candidate.hsl);
      cluster.frame_points += voxel.frame_point_count;
      world_sum += voxel.frame_world_sum_m;
      camera_sum += voxel.frame_camera_sum_m;
      camera_min = camera_min.cwiseMin(voxel.frame_camera_min_m);
      camera_max = camera_max.cwiseMax(voxel.frame_camera_max_m);
      min_height = std::min(min_height, voxel.frame_min_height_m);
      max_height = std::max(max_height, voxel.frame_max_height_m);
      max_disparity_px = std::max(max_disparity_px, voxel.frame_max_disparity_px);
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
    cluster.truncated = cluster.truncated || cluster.at_candidate_far_edge;
    cluster.size_world_m = extent_voxels * map.parameters().voxel_size_m;
    cluster.centroid_world_m = world_sum / double(std::max<int64_t>(1, cluster.frame_points));
    cluster.rgb_mean = mean.rgb();
    cluster.hsl_mean = mean.hsl();
    const int margin = parameters.border_margin_px;
    if (parameters.image_width_px > 0 && parameters.image_height_px > 0 &&
        (box[0] <= margin + max_disparity_px || box[1] <= margin || box[2] >= parameters.image_width_px - 1 - margin ||
         box[3] >= parameters.image_height_px - 1 - margin)) {
      cluster.truncated = true;
    }
    Obstacle3d& obstacle = cluster.obstacle;
    obstacle.id = static_cast<int>(result.clusters.size());
    obstacle.bbox_px = box;
    cluster.camera_min_m = camera_min.cast<double>();
    cluster.camera_max_m = camera_max.cast<double>();
    obstacle.position_m = camera_sum / double(std::max<int64_t>(1, cluster.frame_points));
    obstacle.size_m = (camera_max - camera_min).cast<double>();
    obstacle.min_height_m = min_height;
    obstacle.max_height_m = max_height;
    result.clusters.push_back(std::move(cluster));
  }

  const uint64_t v = map.voxels().size(), k = static_cast<uint64_t>(candidate_count);
  const uint64_t log_k = k > 1 ? static_cast<uint64_t>(std::bit_width(k - 1)) : 0;
  result.work.scalar_ops = 4 * v + 4 * k * log_k + 8 * static_cast<uint64_t>(result.neighbour_probes) +
                           36 * static_cast<uint64_t>(result.similarity_tests) + 16 * k + 8 * static_cast<uint64_t>(result.aggregated_clusters) +
                           40 * static_cast<uint64_t>(result.flood_fill_clusters) + 30 * k +
                           (parameters.candidate_forward_max_m > 0.0 ? 12 * k : 0);
  result.work.memory_bytes = sizeof(Voxel) * (v + 2 * k);
  return result;
}

bool pixel_boxes_within(const std::array<int, 4>& a, const std::array<int, 4>& b, int margin_px) {
  return a[0] <= b[2] + margin_px && b[0] <= a[2] + margin_px && a[1] <= b[3] + margin_px && b[1] <= a[3] + margin_px;
}

namespace {

// Whether `part` belongs to `host` (FragmentMergeParameters in voxel_clustering.h): `fragment` says
// whether part is small enough to be a stereo fragment of host.
bool parts_of_one_object(const VoxelCluster& host, const VoxelCluster& part, bool fragment, const StereoErrorModel& stereo,
                         const FragmentMergeParameters& p) {
  if (!pixel_boxes_within(host.obstacle.bbox_px, part.obstacle.bbox_px, p.pixel_margin_px)) return false;
  const Eigen::Vector3d &low_a = host.camera_min_m, &high_a = host.camera_max_m;
  const Eigen::Vector3d &low_b = part.camera_min_m, &high_b = part.camera_max_m;
  const double gap_m = std::max({0.0, low_b.z() - high_a.z(), low_a.z() - high_b.z()});
  const double lateral_overlap_m = std::min(high_a.x(), high_b.x()) - std::max(low_a.x(), low_b.x());
  const double wider_m = std::max(high_a.x() - low_a.x(), high_b.x() - low_b.x());
  if (gap_m <= p.min_depth_gap_m && lateral_overlap_m >= 0.5 * wider_m) return true;  // one surface: stacked parts of about one width
  if (!fragment) return false;
  const double depth_m = std::max(0.1, std::min(host.obstacle.position_m.z(), part.obstacle.position_m.z()));
  return gap_m <= p.min_depth_gap_m + p.depth_sigmas * stereo.depth_sigma_m(depth_m);
}

}  // namespace

void validate_fragment_merge_parameters(const FragmentMergeParameters& p) {
  require_parameter(p.pixel_margin_px >= 0 && p.pixel_margin_px <= 1000, "pixel_margin_px", "[0, 1000] px", p.pixel_margin_px);
  require_parameter(p.depth_sigmas >= 0 && p.depth_sigmas <= 100, "depth_sigmas", "[0, 100]", p.depth_sigmas);
  require_parameter(p.max_fragment_width_px >= 1 && p.max_fragment_width_px <= 100000, "max_fragment_width_px", "[1, 100000] px", p.max_fragment_width_px);
  require_parameter(p.max_fragment_fraction >= 0 && p.max_fragment_fraction <= 1, "max_fragment_fraction", "[0, 1]", p.max_fragment_fraction);
  require_parameter(p.min_depth_gap_m >= 0 && p.min_depth_gap_m <= 100, "min_depth_gap_m", "[0, 100] m", p.min_depth_gap_m);
}

FragmentMergeResult merge_stereo_fragments(const std::vector<VoxelCluster>& clusters, const StereoErrorModel& stereo, double voxel_size_m,
                                           const FragmentMergeParameters& parameters) {
  const int count = static_cast<int>(clusters.size());
  FragmentMergeResult result;
  // Hosts in decreasing voxel count (ties: input order); each cluster joins the first host it is a
  // fragment of, tested against the host's own cluster (no chains), or becomes a host.
  std::vector<int> order(clusters.size());
  for (int i = 0; i < count; ++i) order[static_cast<size_t>(i)] = i;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return clusters[static_cast<size_t>(a)].voxels.size() > clusters[static_cast<size_t>(b)].voxels.size(); });
  std::vector<int> host_of(clusters.size(), -1);
  std::vector<int> hosts;
  const bool enabled = parameters.enabled && stereo.defined();
  for (const int i : order) {
    const VoxelCluster& cluster = clusters[static_cast<size_t>(i)];
    for (const int h : hosts) {
      if (!enabled) break;
      ++result.pair_tests;
      const VoxelCluster& host = clusters[static_cast<size_t>(h)];
      const bool fragment = double(cluster.voxels.size()) <= parameters.max_fragment_fraction * double(host.voxels.size()) &&
                            cluster.obstacle.bbox_px[2] - cluster.obstacle.bbox_px[0] + 1 <= parameters.max_fragment_width_px;
      if (parts_of_one_object(host, cluster, fragment, stereo, parameters)) {
        host_of[static_cast<size_t>(i)] = h;
        break;
      }
    }
    if (host_of[static_cast<size_t>(i)] < 0) {
      host_of[static_cast<size_t>(i)] = i;
      hosts.push_back(i);
    }
  }
  auto root = [&](int i) { return host_of[static_cast<size_t>(i)]; };
  std::vector<int> output_of(clusters.size(), -1);
  std::vector<ColourMean> colours;
  std::vector<std::array<Eigen::Vector3d, 2>> camera_boxes;
  // Hosts first (input order: the output keeps the clusters' order), then the fragments into them.
  for (int pass = 0, step = 0; step < 2 * count; ++step) {
    pass = step < count ? 0 : 1;
    const int i = step % count;
    const VoxelCluster& cluster = clusters[static_cast<size_t>(i)];
    const int r = root(i);
    if ((r == i) != (pass == 0)) continue;
    const Eigen::Vector3d &low = cluster.camera_min_m, &high = cluster.camera_max_m;
    const int weight = static_cast<int>(cluster.voxels.size());
    if (output_of[static_cast<size_t>(r)] < 0) {
      output_of[static_cast<size_t>(r)] = static_cast<int>(result.clusters.size());
      result.clusters.push_back(cluster);
      colours.emplace_back();
      colours.back().add(cluster.rgb_mean, cluster.hsl_mean, weight);
      camera_boxes.push_back({low, high});
      continue;
    }
    ++result.merged;
    const size_t o = static_cast<size_t>(output_of[static_cast<size_t>(r)]);
    VoxelCluster& merged = result.clusters[o];
    const int64_t points = merged.frame_points + cluster.frame_points;
    merged.centroid_world_m = (merged.centroid_world_m * double(merged.frame_points) + cluster.centroid_world_m * double(cluster.frame_points)) /
                              double(std::max<int64_t>(1, points));
    merged.obstacle.position_m =
        (merged.obstacle.position_m * double(merged.frame_points) + cluster.obstacle.position_m * double(cluster.frame_points)) /
        double(std::max<int64_t>(1, points));
    merged.frame_points = points;
    merged.voxels.insert(merged.voxels.end(), cluster.voxels.begin(), cluster.voxels.end());
    merged.min_key = VoxelKey{std::min(merged.min_key.x, cluster.min_key.x), std::min(merged.min_key.y, cluster.min_key.y),
                              std::min(merged.min_key.z, cluster.min_key.z)};
    merged.max_key = VoxelKey{std::max(merged.max_key.x, cluster.max_key.x), std::max(merged.max_key.y, cluster.max_key.y),
                              std::max(merged.max_key.z, cluster.max_key.z)};
    merged.truncated = merged.truncated || cluster.truncated;
    merged.at_candidate_far_edge = merged.at_candidate_far_edge || cluster.at_candidate_far_edge;
    colours[o].add(cluster.rgb_mean, cluster.hsl_mean, weight);
    camera_boxes[o][0] = camera_boxes[o][0].cwiseMin(low);
    camera_boxes[o][1] = camera_boxes[o][1].cwiseMax(high);
    Obstacle3d& obstacle = merged.obstacle;
    const std::array<int, 4>& box = cluster.obstacle.bbox_px;
    obstacle.bbox_px = {std::min(obstacle.bbox_px[0], box[0]), std::min(obstacle.bbox_px[1], box[1]), std::max(obstacle.bbox_px[2], box[2]),
                        std::max(obstacle.bbox_px[3], box[3])};
    obstacle.min_height_m = std::min(obstacle.min_height_m, cluster.obstacle.min_height_m);
    obstacle.max_height_m = std::max(obstacle.max_height_m, cluster.obstacle.max_height_m);
  }
  for (size_t o = 0; o < result.clusters.size(); ++o) {
    VoxelCluster& merged = result.clusters[o];
    std::sort(merged.voxels.begin(), merged.voxels.end());
    merged.rgb_mean = colours[o].rgb();
    merged.hsl_mean = colours[o].hsl();
    const Eigen::Vector3d extent_voxels(double(merged.max_key.x) - merged.min_key.x + 1, double(merged.max_key.y) - merged.min_key.y + 1,
                                        double(merged.max_key.z) - merged.min_key.z + 1);
    merged.density = double(merged.voxels.size()) / extent_voxels.prod();
    merged.size_world_m = extent_voxels * voxel_size_m;
    merged.camera_min_m = camera_boxes[o][0];
    merged.camera_max_m = camera_boxes[o][1];
    merged.obstacle.size_m = camera_boxes[o][1] - camera_boxes[o][0];
    merged.obstacle.id = static_cast<int>(o);
  }
  const uint64_t c = clusters.size(), m = static_cast<uint64_t>(result.merged), t = static_cast<uint64_t>(result.pair_tests);
  result.work.scalar_ops = 4 * c + 16 * t + 40 * m + 12 * result.clusters.size();
  result.work.memory_bytes = sizeof(VoxelCluster) * 2 * c;
  return result;
}

}  // namespace lpstereo::arm::obstacles3d
