// Augmented stixels: the model, steps and counted work are in augmented_stixels.h.
#include "arm/obstacles3d/augmented_stixels.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace lpstereo::arm::obstacles3d {
namespace {

OccupancyGridParameters validated_grid(const AugmentedStixelParameters& parameters) {
  parameters.validate();
  return parameters.grid;
}

// Two height intervals [low, high] closer than gap (overlapping intervals are at distance 0) whose
// lower edges differ by at most lower_edge_step (an obstacle has one height interval: a board and
// the poles it hangs on are separate obstacles, so the board's keeps its free space under it).
bool heights_join(const AugmentedStixel& a, const AugmentedStixel& b, double gap_m, double lower_edge_step_m) {
  const double distance = std::max<double>(a.min_height_m, b.min_height_m) - std::min<double>(a.max_height_m, b.max_height_m);
  return distance <= gap_m && std::abs(a.min_height_m - b.min_height_m) <= lower_edge_step_m;
}

}  // namespace

void AugmentedStixelParameters::validate() const {
  if (grid.kind != GridKind::polar)
    throw std::invalid_argument(std::string("grid.kind: expected polar, got ") + grid_kind_name(grid.kind));
  try {
    grid.validate();
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(std::string("grid.") + error.what());
  }
  if (min_points < 1) throw_invalid_parameter("min_points", ">= 1", min_points);
  if (!(height_trim_fraction >= 0 && height_trim_fraction < 0.25))
    throw_invalid_parameter("height_trim_fraction", "in [0, 0.25)", height_trim_fraction);
  if (!(lower_edge_fraction >= 0 && lower_edge_fraction < 0.5))
    throw_invalid_parameter("lower_edge_fraction", "in [0, 0.5)", lower_edge_fraction);
  if (!(max_height_gap_m >= 0)) throw_invalid_parameter("max_height_gap_m", ">= 0", max_height_gap_m);
  if (!(max_lower_edge_step_m >= 0)) throw_invalid_parameter("max_lower_edge_step_m", ">= 0", max_lower_edge_step_m);
  if (min_obstacle_points < 1) throw_invalid_parameter("min_obstacle_points", ">= 1", min_obstacle_points);
  if (!(range_join_sigmas >= 0 && range_join_sigmas <= 6)) throw_invalid_parameter("range_join_sigmas", "in [0, 6]", range_join_sigmas);
  if (min_cluster_stixels < 1) throw_invalid_parameter("min_cluster_stixels", ">= 1", min_cluster_stixels);
}

AugmentedStixels::AugmentedStixels(const AugmentedStixelParameters& parameters)
    : parameters_(parameters), grid_(validated_grid(parameters)) {}

void AugmentedStixels::update(const std::vector<ObstaclePoint>& points, const EgoMotion& ego_motion) {
  grid_.update(points, ego_motion);
  work_ = grid_.work();
  stixels_.clear();
  obstacles_.clear();
  const int rows = grid_.rows(), columns = grid_.columns();
  const size_t cells = static_cast<size_t>(rows) * static_cast<size_t>(columns);
  const std::vector<int>& point_cells = grid_.point_cells();

  // 2. Counting sort of the points by cell.
  cell_counts_.assign(cells, 0);
  for (int cell : point_cells)
    if (cell >= 0) ++cell_counts_[static_cast<size_t>(cell)];
  cell_offsets_.assign(cells + 1, 0);
  for (size_t cell = 0; cell < cells; ++cell) cell_offsets_[cell + 1] = cell_offsets_[cell] + cell_counts_[cell];
  std::vector<int> sorted(static_cast<size_t>(cell_offsets_[cells]));
  {
    std::vector<int> cursor(cell_offsets_.begin(), cell_offsets_.end() - 1);
    for (size_t i = 0; i < point_cells.size(); ++i)
      if (point_cells[i] >= 0) sorted[static_cast<size_t>(cursor[static_cast<size_t>(point_cells[i])]++)] = static_cast<int>(i);
  }
  work_.scalar_ops += 14 * point_cells.size() + 4 * cells;
  work_.memory_bytes += 16 * point_cells.size() + 4 * cells;

  // 3. Stixels in occupied cells with enough points.
  point_indices_.clear();
  std::vector<int> stixel_of_cell(cells, -1);
  std::vector<float> heights;
  for (size_t cell = 0; cell < cells; ++cell) {
    const int count = cell_counts_[cell];
    if (count < parameters_.min_points) continue;
    const int row = static_cast<int>(cell) / columns, column = static_cast<int>(cell) % columns;
    if (parameters_.require_occupied_cell && !grid_.occupied(row, column)) continue;
    AugmentedStixel stixel;
    stixel.angle_cell = column;
    stixel.range_cell = row;
    stixel.angle_min_rad = parameters_.grid.column_min + column * parameters_.grid.column_cell;
    stixel.angle_max_rad = stixel.angle_min_rad + parameters_.grid.column_cell;
    stixel.range_min_m = parameters_.grid.row_min + row * parameters_.grid.row_cell;
    stixel.range_max_m = stixel.range_min_m + parameters_.grid.row_cell;
    stixel.first_point = static_cast<int>(point_indices_.size());
    stixel.point_count = count;
    stixel.occupancy_probability = grid_.probability(row, column);
    heights.clear();
    double range_sum = 0;
    uint64_t rgb_sum[3] = {0, 0, 0};
    for (int k = cell_offsets_[cell]; k < cell_offsets_[cell + 1]; ++k) {
      const int index = sorted[static_cast<size_t>(k)];
      const ObstaclePoint& point = points[static_cast<size_t>(index)];
      point_indices_.push_back(index);
      heights.push_back(point.height_above_ground_m);
      range_sum += std::hypot(point.camera_m.x(), point.camera_m.z());
      for (int channel = 0; channel < 3; ++channel) rgb_sum[channel] += point.rgb[static_cast<size_t>(channel)];
    }
    const int trim = static_cast<int>(std::floor(parameters_.height_trim_fraction * count));
    const int lower = static_cast<int>(std::floor(parameters_.lower_edge_fraction * count));
    std::nth_element(heights.begin(), heights.begin() + lower, heights.end());
    stixel.min_height_m = heights[static_cast<size_t>(lower)];
    std::nth_element(heights.begin(), heights.end() - 1 - trim, heights.end());
    stixel.max_height_m = heights[static_cast<size_t>(count - 1 - trim)];
    stixel.mean_range_m = static_cast<float>(range_sum / count);
    for (int channel = 0; channel < 3; ++channel)
      stixel.mean_rgb[static_cast<size_t>(channel)] = static_cast<uint8_t>((rgb_sum[channel] + count / 2) / static_cast<uint64_t>(count));
    stixel_of_cell[cell] = static_cast<int>(stixels_.size());
    stixels_.push_back(stixel);
    work_.scalar_ops += 12 * static_cast<uint64_t>(count);
    work_.memory_bytes += 16 * static_cast<uint64_t>(count);
  }

  // 4. Clusters of neighbouring stixels with compatible heights (explicit stack, stixel order).
  std::vector<int> cluster_of(stixels_.size(), -1), stack;
  std::vector<std::vector<int>> clusters;
  uint64_t pairs = 0;
  for (size_t seed = 0; seed < stixels_.size(); ++seed) {
    if (cluster_of[seed] != -1) continue;
    std::vector<int> members;
    cluster_of[seed] = -2;  // visited, not yet numbered
    stack.push_back(static_cast<int>(seed));
    while (!stack.empty()) {
      const int current = stack.back();
      stack.pop_back();
      members.push_back(current);
      const AugmentedStixel& stixel = stixels_[static_cast<size_t>(current)];
      // Along the bearing, stixels within range_join_sigmas depth sigmas are neighbours: at 27 m
      // sigma_Z is 1.3 m (6 cells), and one surface's points scatter over that many range cells.
      const double sigma_range_m = parameters_.grid.error_model.depth_sigma_m(stixel.mean_range_m);
      const int range_reach = std::max(1, static_cast<int>(std::ceil(parameters_.range_join_sigmas * sigma_range_m / parameters_.grid.row_cell)));
      for (int dr = -range_reach; dr <= range_reach; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int r = stixel.range_cell + dr, c = stixel.angle_cell + dc;
          if ((dr == 0 && dc == 0) || r < 0 || r >= rows || c < 0 || c >= columns) continue;
          const int neighbour = stixel_of_cell[static_cast<size_t>(r) * columns + c];
          ++pairs;
          if (neighbour < 0 || cluster_of[static_cast<size_t>(neighbour)] != -1) continue;
          if (!heights_join(stixel, stixels_[static_cast<size_t>(neighbour)], parameters_.max_height_gap_m,
                            parameters_.max_lower_edge_step_m))
            continue;
          cluster_of[static_cast<size_t>(neighbour)] = -2;
          stack.push_back(neighbour);
        }
      }
    }
    std::sort(members.begin(), members.end());
    int member_points = 0;
    for (int member : members) member_points += stixels_[static_cast<size_t>(member)].point_count;
    if (static_cast<int>(members.size()) < parameters_.min_cluster_stixels || member_points < parameters_.min_obstacle_points) {
      for (int member : members) cluster_of[static_cast<size_t>(member)] = -3;  // dropped
      continue;
    }
    for (int member : members) cluster_of[static_cast<size_t>(member)] = static_cast<int>(clusters.size());
    clusters.push_back(std::move(members));
  }
  work_.scalar_ops += 20 * pairs;
  for (size_t i = 0; i < stixels_.size(); ++i) stixels_[i].cluster = cluster_of[i] >= 0 ? cluster_of[i] : -1;

  for (size_t index = 0; index < clusters.size(); ++index) {
    std::vector<int> cluster_points;
    float min_height = std::numeric_limits<float>::infinity(), max_height = -min_height;
    std::vector<float> lower_edges;
    for (int member : clusters[index]) {
      const AugmentedStixel& stixel = stixels_[static_cast<size_t>(member)];
      cluster_points.insert(cluster_points.end(), point_indices_.begin() + stixel.first_point,
                            point_indices_.begin() + stixel.first_point + stixel.point_count);
      lower_edges.push_back(stixel.min_height_m);
      max_height = std::max(max_height, stixel.max_height_m);
    }
    // The obstacle's lower edge: the lower tercile of its stixels' (the k-th lowest, k = n / 3): a
    // stixel whose lower edge a fattened border or a pole's foot pulled down does not move it, and
    // a ball's side stixels (higher than its bottom) do not lift it as the median did (eval,
    // floating, 30 frames x 2 seeds: within 10 cm 63 % with the median, 75 % with the tercile, 77 %
    // with the quartile, which loses the free space under a board more often: 95 against 99 of 119).
    std::nth_element(lower_edges.begin(), lower_edges.begin() + static_cast<long>(lower_edges.size() / 3), lower_edges.end());
    min_height = lower_edges[lower_edges.size() / 3];
    Obstacle3d obstacle = obstacle_from_points(points, cluster_points, static_cast<int>(index));
    obstacle.min_height_m = min_height;  // trimmed, as the stixels'
    obstacle.max_height_m = max_height;
    obstacles_.push_back(obstacle);
    work_.scalar_ops += 10 * cluster_points.size();
    work_.memory_bytes += sizeof(ObstaclePoint) * cluster_points.size();
  }

  std::ostringstream status;
  status << grid_.status() << "; " << stixels_.size() << " stixels, " << obstacles_.size() << " stixel obstacles";
  status_ = status.str();
}

}  // namespace lpstereo::arm::obstacles3d
