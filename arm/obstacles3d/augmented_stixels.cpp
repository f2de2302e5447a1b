// Augmented stixels: the model, steps and counted work are in augmented_stixels.h.
#include "arm/obstacles3d/augmented_stixels.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "arm/fork_join.h"

namespace lpstereo::arm::obstacles3d {
namespace {

OccupancyGridParameters validated_grid(const AugmentedStixelParameters& parameters) {
  parameters.validate();
  return parameters.grid;
}

// The per-cluster steps run on up to grid.threads threads, one per this many of the frame's stixel
// points (a thread costs tens of microseconds to start; a few clusters are not worth it).
constexpr size_t kStixelPointsPerThread = 4096;

// Two height intervals [low, high] closer than gap (overlapping intervals are at distance 0) whose
// lower edges differ by at most lower_edge_step (an obstacle has one height interval: a board and
// the poles it hangs on are separate obstacles, so the board's keeps its free space under it).
bool heights_join(const AugmentedStixel& a, const AugmentedStixel& b, double gap_m, double lower_edge_step_m) {
  const double distance = std::max<double>(a.min_height_m, b.min_height_m) - std::min<double>(a.max_height_m, b.max_height_m);
  return distance <= gap_m && std::abs(a.min_height_m - b.min_height_m) <= lower_edge_step_m;
}

// The support split of a cell's part [begin, end) of points sorted by height (header, step 3): the
// index i (begin < i < end, at least min_points on each side) where the points per metre of height
// below, (i - begin) / (h[i-1] - h[begin] + row), divided by those above, (end - i) / (h[end-1] -
// h[i] + row), is smallest, both parts spanning at least kSupportSplitMinRows image rows (row = one
// row's height at the cell's range, Z / f; added to each span so that a part on one row has a
// finite density); returns it when that ratio is below max_ratio, else -1.
constexpr double kSupportSplitMinRows = 3;
int support_split(const std::vector<std::pair<float, int>>& by_height, int begin, int end, double row_m, double max_ratio, int min_points) {
  double best_ratio = max_ratio;
  int best_cut = -1;
  for (int i = begin + min_points; i <= end - min_points; ++i) {
    const double lower_span_m = by_height[static_cast<size_t>(i - 1)].first - by_height[static_cast<size_t>(begin)].first + row_m;
    const double upper_span_m = by_height[static_cast<size_t>(end - 1)].first - by_height[static_cast<size_t>(i)].first + row_m;
    if (lower_span_m < kSupportSplitMinRows * row_m || upper_span_m < kSupportSplitMinRows * row_m) continue;
    const double ratio = ((i - begin) / lower_span_m) / ((end - i) / upper_span_m);
    if (ratio < best_ratio) best_ratio = ratio, best_cut = i;
  }
  return best_cut;
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
  if (min_points_unoccupied < 1) throw_invalid_parameter("min_points_unoccupied", ">= 1", min_points_unoccupied);
  if (!(lower_edge_fattening_px >= 0 && lower_edge_fattening_px <= 16))
    throw_invalid_parameter("lower_edge_fattening_px", "in [0, 16]", lower_edge_fattening_px);
  if (!(support_density_ratio >= 0 && support_density_ratio < 1))
    throw_invalid_parameter("support_density_ratio", "in [0, 1)", support_density_ratio);
  if (!(max_fragment_fraction >= 0 && max_fragment_fraction < 1))
    throw_invalid_parameter("max_fragment_fraction", "in [0, 1)", max_fragment_fraction);
  if (!(max_height_gap_m >= 0)) throw_invalid_parameter("max_height_gap_m", ">= 0", max_height_gap_m);
  if (!(max_lower_edge_step_m >= 0)) throw_invalid_parameter("max_lower_edge_step_m", ">= 0", max_lower_edge_step_m);
  if (min_obstacle_points < 1) throw_invalid_parameter("min_obstacle_points", ">= 1", min_obstacle_points);
  if (!(range_join_sigmas >= 0 && range_join_sigmas <= 6)) throw_invalid_parameter("range_join_sigmas", "in [0, 6]", range_join_sigmas);
  if (min_cluster_stixels < 1) throw_invalid_parameter("min_cluster_stixels", ">= 1", min_cluster_stixels);
}

AugmentedStixels::AugmentedStixels(const AugmentedStixelParameters& parameters)
    : parameters_(parameters), grid_(validated_grid(parameters)) {}

void AugmentedStixels::update(const std::vector<ObstaclePoint>& points, const EgoMotion& ego_motion) {
  // A lower edge from the lower_edge_fraction percentile and the median of heights spread evenly up
  // from the edge, moved up by the fattening term at the points' mean range (header, step 3).
  const auto lower_edge_m = [this](double lower_percentile_m, double median_m, double range_sum_m, double count) {
    const double q = parameters_.lower_edge_fraction;
    return lower_percentile_m - q / (0.5 - q) * (median_m - lower_percentile_m) +
           parameters_.lower_edge_fattening_px * range_sum_m / count / parameters_.grid.error_model.focal_px;
  };
  grid_.update(points, ego_motion, GridDescription::occupancy_only);  // the stixels describe the obstacles
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

  // 3. Stixels in occupied cells with enough points: the cell's points sorted by height and split
  // where consecutive heights lie more than max_height_gap_m apart (the parts could not join as
  // neighbours either); each part with at least min_points points is a stixel of the cell.
  point_indices_.clear();
  first_stixel_of_cell_.assign(cells, 0);
  stixel_count_of_cell_.assign(cells, 0);
  std::vector<std::pair<float, int>> by_height;
  std::vector<int> cuts;
  for (size_t cell = 0; cell < cells; ++cell) {
    first_stixel_of_cell_[cell] = static_cast<int>(stixels_.size());
    const int count = cell_counts_[cell];
    if (count < parameters_.min_points) continue;
    const int row = static_cast<int>(cell) / columns, column = static_cast<int>(cell) % columns;
    if (parameters_.require_occupied_cell && !grid_.occupied(row, column) && count < parameters_.min_points_unoccupied) continue;
    by_height.clear();
    for (int k = cell_offsets_[cell]; k < cell_offsets_[cell + 1]; ++k) {
      const int index = sorted[static_cast<size_t>(k)];
      by_height.emplace_back(points[static_cast<size_t>(index)].height_above_ground_m, index);
    }
    std::sort(by_height.begin(), by_height.end());
    work_.scalar_ops += 12 * static_cast<uint64_t>(count);
    work_.memory_bytes += 16 * static_cast<uint64_t>(count);
    // Cut points: the height gaps, and in each part the support split (header, step 3).
    cuts.clear();
    int part_begin = 0;
    for (int part_end = 1; part_end <= count; ++part_end) {
      if (part_end < count &&
          by_height[static_cast<size_t>(part_end)].first - by_height[static_cast<size_t>(part_end - 1)].first <= parameters_.max_height_gap_m)
        continue;
      if (parameters_.support_density_ratio > 0) {
        const double cell_range_m = parameters_.grid.row_min + (row + 0.5) * parameters_.grid.row_cell;
        const int cut = support_split(by_height, part_begin, part_end, cell_range_m / parameters_.grid.error_model.focal_px,
                                      parameters_.support_density_ratio, std::max(parameters_.min_points, 3));
        if (cut > part_begin) cuts.push_back(cut);
        work_.scalar_ops += 8 * static_cast<uint64_t>(part_end - part_begin);
      }
      cuts.push_back(part_end);
      part_begin = part_end;
    }
    int begin = 0;
    for (int end : cuts) {
      const int segment = end - begin;
      if (segment >= parameters_.min_points) {
        AugmentedStixel stixel;
        stixel.angle_cell = column;
        stixel.range_cell = row;
        stixel.angle_min_rad = parameters_.grid.column_min + column * parameters_.grid.column_cell;
        stixel.angle_max_rad = stixel.angle_min_rad + parameters_.grid.column_cell;
        stixel.range_min_m = parameters_.grid.row_min + row * parameters_.grid.row_cell;
        stixel.range_max_m = stixel.range_min_m + parameters_.grid.row_cell;
        stixel.first_point = static_cast<int>(point_indices_.size());
        stixel.point_count = segment;
        stixel.occupancy_probability = grid_.probability(row, column);
        double range_sum = 0;
        uint64_t rgb_sum[3] = {0, 0, 0};
        for (int k = begin; k < end; ++k) {
          const int index = by_height[static_cast<size_t>(k)].second;
          const ObstaclePoint& point = points[static_cast<size_t>(index)];
          point_indices_.push_back(index);
          range_sum += std::hypot(point.camera_m.x(), point.camera_m.z());
          for (int channel = 0; channel < 3; ++channel) rgb_sum[channel] += point.rgb[static_cast<size_t>(channel)];
        }
        const int trim = static_cast<int>(std::floor(parameters_.height_trim_fraction * segment));
        const int lower = static_cast<int>(std::floor(parameters_.lower_edge_fraction * segment));
        const float lower_percentile_m = by_height[static_cast<size_t>(begin + lower)].first;
        const float median_m = by_height[static_cast<size_t>(begin + segment / 2)].first;
        stixel.max_height_m = by_height[static_cast<size_t>(end - 1 - trim)].first;
        const double edge_m = lower_edge_m(lower_percentile_m, median_m, range_sum, segment);
        // Not above the upper edge (a thin part at range: the fattening term can pass its top).
        stixel.min_height_m = static_cast<float>(std::min<double>(edge_m, stixel.max_height_m));
        stixel.mean_range_m = static_cast<float>(range_sum / segment);
        for (int channel = 0; channel < 3; ++channel)
          stixel.mean_rgb[static_cast<size_t>(channel)] = static_cast<uint8_t>((rgb_sum[channel] + segment / 2) / static_cast<uint64_t>(segment));
        stixels_.push_back(stixel);
        ++stixel_count_of_cell_[cell];
      }
      begin = end;
    }
  }

  // 4. Clusters of neighbouring stixels with compatible heights (explicit stack, stixel order).
  // Neighbours: the 8 neighbouring cells and, along the bearing, the range cells within
  // range_join_sigmas depth sigmas (at 27 m sigma_Z is 1.3 m, 6 cells: one surface's points scatter
  // over that many range cells).
  uint64_t pairs = 0;
  auto for_each_neighbour = [&](int index, int column_reach, auto&& visit) {
    const AugmentedStixel& stixel = stixels_[static_cast<size_t>(index)];
    const double sigma_range_m = parameters_.grid.error_model.depth_sigma_m(stixel.mean_range_m);
    const int range_reach = std::max(1, static_cast<int>(std::ceil(parameters_.range_join_sigmas * sigma_range_m / parameters_.grid.row_cell)));
    for (int dr = -range_reach; dr <= range_reach; ++dr) {
      for (int dc = -column_reach; dc <= column_reach; ++dc) {
        const int r = stixel.range_cell + dr, c = stixel.angle_cell + dc;
        if (r < 0 || r >= rows || c < 0 || c >= columns) continue;  // the own cell too: its other segments
        const size_t neighbour_cell = static_cast<size_t>(r) * static_cast<size_t>(columns) + static_cast<size_t>(c);
        const int first = first_stixel_of_cell_[neighbour_cell];
        for (int neighbour = first; neighbour < first + stixel_count_of_cell_[neighbour_cell]; ++neighbour) {
          if (neighbour == index) continue;
          ++pairs;
          visit(neighbour);
        }
      }
    }
  };
  std::vector<int> cluster_of(stixels_.size(), -1), stack;
  std::vector<std::vector<int>> clusters;
  for (size_t seed = 0; seed < stixels_.size(); ++seed) {
    if (cluster_of[seed] != -1) continue;
    std::vector<int> members;
    const int id = static_cast<int>(clusters.size());
    cluster_of[seed] = id;
    stack.push_back(static_cast<int>(seed));
    while (!stack.empty()) {
      const int current = stack.back();
      stack.pop_back();
      members.push_back(current);
      const AugmentedStixel& stixel = stixels_[static_cast<size_t>(current)];
      for_each_neighbour(current, 1, [&](int neighbour) {
        if (cluster_of[static_cast<size_t>(neighbour)] != -1) return;
        if (!heights_join(stixel, stixels_[static_cast<size_t>(neighbour)], parameters_.max_height_gap_m, parameters_.max_lower_edge_step_m))
          return;
        cluster_of[static_cast<size_t>(neighbour)] = id;
        stack.push_back(neighbour);
      });
    }
    std::sort(members.begin(), members.end());
    clusters.push_back(std::move(members));
  }

  // Each cluster's height interval: the upper edge is the highest stixel upper edge; the lower edge
  // starts from the point-weighted lower tercile of its stixels' lower edges (sorted by lower edge,
  // the first stixel at which the stixels so far hold more than a third of the cluster's points),
  // which picks the stixels the edge is then measured on (their pooled points, below). Weighted by
  // points because the stixels that pull a hanging obstacle's edge down are thin and sparse: a
  // pole's or a post's (8 and 5 cm in the floating scene, one angular cell, a few points per range
  // cell) chain into a board's cluster through stixels whose lower edges step down by less than
  // max_lower_edge_step_m (0.9 -> 0.69 -> 0.42 -> 0.22 m at 16 m in obstacles3d_eval, floating,
  // seed 1, frame 5: 30 of the cluster's 95 stixels had a lower edge under 0.75 m, so the plain
  // tercile, k = n / 3, gave 0.69 m for a 0.9 m edge; they held 452 of its 1859 points, 24 %). The tercile
  // itself: one stixel pulled down by a fattened border does not move it, and a ball's side stixels
  // (higher than its bottom) do not lift it as the median did. Eval (obstacles3d_eval, floating, 150
  // frames, seeds 1 and 2, VO): within 10 cm 83.0 / 82.1 % by count, 83.0 / 83.4 % by points; free
  // space under a board kept 105/120 and 104/124 by count, 108/120 and 110/124 by points. The
  // stixels keep their own lower edges (free_below_m): under a pole's sparse stixels the obstacle's
  // interval says free, its stixels do not.
  const size_t cluster_count = clusters.size();
  std::vector<float> cluster_lower(cluster_count), cluster_upper(cluster_count);
  std::vector<int> cluster_points(cluster_count, 0);
  // The clusters are dealt over the threads (one at a time: their sizes differ by orders of
  // magnitude), each writing only its own clusters' entries: the result does not depend on them.
  const int thread_count =
      static_cast<int>(std::clamp<size_t>(point_indices_.size() / kStixelPointsPerThread, 1, static_cast<size_t>(parameters_.grid.threads)));
  std::vector<ArmWork> share_work(static_cast<size_t>(thread_count));
  fork_join(thread_count, [&](int share) {
    std::vector<std::pair<float, int>> lower_edges;  // (a member stixel's lower edge, its points)
    std::vector<float> pooled_heights;
    ArmWork work;
    for_each_dealt(cluster_count, 1, share, thread_count, [&](size_t index) {
      lower_edges.clear();
      float upper = -std::numeric_limits<float>::infinity();
      int points_of_cluster = 0;
      for (int member : clusters[index]) {
        const AugmentedStixel& stixel = stixels_[static_cast<size_t>(member)];
        lower_edges.emplace_back(stixel.min_height_m, stixel.point_count);
        upper = std::max(upper, stixel.max_height_m);
        points_of_cluster += stixel.point_count;
      }
      cluster_points[index] = points_of_cluster;
      std::sort(lower_edges.begin(), lower_edges.end());
      const int tercile_points = points_of_cluster / 3;
      int points_below = 0;
      size_t k = 0;
      while (k + 1 < lower_edges.size() && points_below + lower_edges[k].second <= tercile_points) points_below += lower_edges[k++].second;
      cluster_lower[index] = lower_edges[k].first;
      cluster_upper[index] = upper;
      // The edge itself from the pooled points of the member stixels whose own edge lies within
      // max_lower_edge_step_m of that tercile (the chained pole's foot left out, as the tercile
      // leaves it): the matcher gives a hanging board's bottom rows a disparity 0.1-0.25 px lower
      // than the rest (mixed with the road under them), 0.2-0.5 m of range at 17 m, so they fall in
      // farther range cells than the rows above, and most of the board's stixels hold no bottom row:
      // their edges lay 0.9-1.16 m for a 0.9 m edge and the tercile at 1.01 m (floating seed 1 frame
      // 3). Pooled, the rows are whole again.
      pooled_heights.clear();
      double range_sum = 0;
      const float floor_m = cluster_lower[index] - static_cast<float>(parameters_.max_lower_edge_step_m);
      for (int member : clusters[index]) {
        const AugmentedStixel& stixel = stixels_[static_cast<size_t>(member)];
        if (stixel.min_height_m < floor_m) continue;
        for (int slot = stixel.first_point; slot < stixel.first_point + stixel.point_count; ++slot)
          pooled_heights.push_back(points[static_cast<size_t>(point_indices_[static_cast<size_t>(slot)])].height_above_ground_m);
        range_sum += static_cast<double>(stixel.mean_range_m) * stixel.point_count;
      }
      const size_t n = pooled_heights.size();
      const size_t lower = static_cast<size_t>(std::floor(parameters_.lower_edge_fraction * static_cast<double>(n)));
      const auto lower_slot = pooled_heights.begin() + static_cast<std::ptrdiff_t>(lower);
      std::nth_element(pooled_heights.begin(), lower_slot, pooled_heights.end());
      const float lower_percentile_m = *lower_slot;
      const auto median_slot = pooled_heights.begin() + static_cast<std::ptrdiff_t>(n / 2);
      if (median_slot > lower_slot) std::nth_element(lower_slot + 1, median_slot, pooled_heights.end());  // the rest are >= it
      const float median_m = *median_slot;
      cluster_lower[index] = static_cast<float>(std::min<double>(lower_edge_m(lower_percentile_m, median_m, range_sum, static_cast<double>(n)), upper));
      work.scalar_ops += 10 * static_cast<uint64_t>(n);
      work.memory_bytes += 8 * static_cast<uint64_t>(n);
    });
    share_work[static_cast<size_t>(share)] = work;
  });
  for (const ArmWork& work : share_work) work_ += work;

  // A fragment joins its host: a cluster next to a bigger one (more points) whose height interval
  // holds it (lower edge not below the host's, upper edge at most max_lower_edge_step_m above) is a
  // piece of that obstacle cut off by the lower-edge step, not an obstacle of its own: the top rows
  // of a board whose points scattered into other range cells, a sign's arm between the sign and its
  // post. Of several hosts the one with the highest lower edge (the hanging one, not the pole
  // beside it: the pole's interval holds the board's too, but the pole is the smaller). The host
  // keeps its own height interval (eval, floating, 60 frames x 2 seeds, true ego-motion: such
  // fragments were the obstacle with the highest lower edge in 68 of 216 board and sign frames).
  std::vector<int> host(cluster_count, -1);
  for (size_t index = 0; index < stixels_.size(); ++index) {
    const int fragment = cluster_of[index];
    for_each_neighbour(static_cast<int>(index), 2, [&](int neighbour) {
      const int candidate = cluster_of[static_cast<size_t>(neighbour)];
      if (candidate == fragment) return;
      const size_t f = static_cast<size_t>(fragment), c = static_cast<size_t>(candidate);
      const bool much_bigger = cluster_points[f] <= parameters_.max_fragment_fraction * cluster_points[c];
      if (!much_bigger || cluster_lower[f] <= cluster_lower[c] + parameters_.max_lower_edge_step_m ||
          cluster_lower[f] > cluster_upper[c] + parameters_.max_height_gap_m)
        return;
      const int current = host[f];
      if (current < 0 || cluster_lower[c] > cluster_lower[static_cast<size_t>(current)] ||
          (cluster_lower[c] == cluster_lower[static_cast<size_t>(current)] && candidate < current))
        host[f] = candidate;
    });
  }
  work_.scalar_ops += 20 * pairs;
  // Hosts are bigger (acyclic): follow each chain to its root.
  std::vector<int> root(cluster_count);
  for (size_t index = 0; index < cluster_count; ++index) {
    int r = static_cast<int>(index);
    while (host[static_cast<size_t>(r)] >= 0) r = host[static_cast<size_t>(r)];
    root[index] = r;
  }
  std::vector<std::vector<int>> merged(cluster_count);
  for (size_t index = 0; index < cluster_count; ++index) {
    std::vector<int>& into = merged[static_cast<size_t>(root[index])];
    into.insert(into.end(), clusters[index].begin(), clusters[index].end());
  }

  // Each kept cluster's obstacles, described on the threads (the clusters dealt one at a time, each
  // description written to its own slot), then numbered in cluster order.
  struct Description {
    bool kept = false;
    std::vector<Obstacle3d> obstacles;       // its parts' with enough points, in part order
    std::vector<int> obstacle_of_part;       // index into obstacles, -1: none
    std::vector<std::pair<int, int>> stixel_obstacle;  // a split cluster's: (member stixel, its part's obstacle)
    ArmWork work;
  };
  std::vector<Description> descriptions(cluster_count);
  fork_join(thread_count, [&](int share) {
    std::vector<int> part_of_point;  // per point: its part in the cluster being split
    for_each_dealt(cluster_count, 1, share, thread_count, [&](size_t index) {
      if (root[index] != static_cast<int>(index)) return;
      Description& description = descriptions[index];
      ArmWork& work = description.work;
      std::vector<int>& members = merged[index];
      std::sort(members.begin(), members.end());
      std::vector<int> obstacle_points;
      for (int member : members) {
        const AugmentedStixel& stixel = stixels_[static_cast<size_t>(member)];
        obstacle_points.insert(obstacle_points.end(), point_indices_.begin() + stixel.first_point,
                               point_indices_.begin() + stixel.first_point + stixel.point_count);
      }
      // Clusters smaller than min_cluster_stixels or with fewer than min_obstacle_points points
      // (scattered terrain-fit outliers, mismatches) give no obstacle.
      if (static_cast<int>(members.size()) < parameters_.min_cluster_stixels ||
          static_cast<int>(obstacle_points.size()) < parameters_.min_obstacle_points)
        return;
      description.kept = true;
      // The grids' four cuts (occupancy_grid.h, split_object). The image-column gap split: neighbouring cells
      // join stixels whose points lie up to two 0.01 rad cells apart in the image; a run of at least
      // grid.min_column_gap_px columns without a point between them makes two obstacles. Then the
      // occlusion split (split_at_range_peak): a range peak over the image columns that both sides
      // fall from by more than a window is a far surface's end beside a nearer object. Then the
      // range-step split (split_at_range_step): such an end left at the part's edge. Then the
      // concavity split (split_at_concavity): a dip of the disparity profile under its concave
      // envelope is where two objects meet (one convex object's profile is concave). Each part
      // keeps the cluster's height interval clamped to its own points' heights; a stixel belongs to
      // the part holding most of its points.
      const std::vector<std::vector<int>> parts = split_object(points, obstacle_points, parameters_.grid, &work);
      description.obstacle_of_part.assign(parts.size(), -1);
      for (size_t part = 0; part < parts.size(); ++part) {
        if (static_cast<int>(parts[part].size()) < parameters_.min_obstacle_points) continue;
        description.obstacle_of_part[part] = static_cast<int>(description.obstacles.size());
        Obstacle3d obstacle = obstacle_from_points(points, parts[part], -1, &work);  // numbered below
        obstacle.min_height_m = cluster_lower[index];  // trimmed, as the stixels'
        obstacle.max_height_m = cluster_upper[index];
        if (parts.size() > 1) {
          // A part keeps the cluster's interval only as far as its own points reach: a fragment of a
          // board's top rows that joined the board's pole and was then cut off at a column gap holds
          // points at 1.6 m only, and with the pole's 0.2 m lower edge it took the free space under
          // the board (floating seed 1 frame 24; the clamp measured in docs/obstacles3d.md).
          float lowest_m = std::numeric_limits<float>::infinity(), highest_m = -lowest_m;
          for (int point : parts[part]) {
            lowest_m = std::min(lowest_m, points[static_cast<size_t>(point)].height_above_ground_m);
            highest_m = std::max(highest_m, points[static_cast<size_t>(point)].height_above_ground_m);
          }
          obstacle.min_height_m = std::max<double>(obstacle.min_height_m, lowest_m);
          obstacle.max_height_m = std::max(obstacle.min_height_m, std::min<double>(obstacle.max_height_m, highest_m));
          work.scalar_ops += 2 * parts[part].size();
        }
        description.obstacles.push_back(std::move(obstacle));
      }
      if (parts.size() > 1) {
        if (part_of_point.empty()) part_of_point.assign(points.size(), -1);  // only this cluster's entries are read
        for (size_t part = 0; part < parts.size(); ++part)
          for (int point : parts[part]) part_of_point[static_cast<size_t>(point)] = static_cast<int>(part);
        std::vector<int> points_in_part(parts.size());
        for (int member : members) {
          const AugmentedStixel& stixel = stixels_[static_cast<size_t>(member)];
          std::fill(points_in_part.begin(), points_in_part.end(), 0);
          for (int k = stixel.first_point; k < stixel.first_point + stixel.point_count; ++k)
            ++points_in_part[static_cast<size_t>(part_of_point[static_cast<size_t>(point_indices_[static_cast<size_t>(k)])])];
          const size_t most = static_cast<size_t>(std::max_element(points_in_part.begin(), points_in_part.end()) - points_in_part.begin());
          description.stixel_obstacle.emplace_back(member, description.obstacle_of_part[most]);
        }
      }
      work.scalar_ops += 10 * obstacle_points.size();
      work.memory_bytes += sizeof(ObstaclePoint) * obstacle_points.size();
    });
  });
  std::vector<int> obstacle_of_cluster(cluster_count, -1);
  // A stixel of a cluster split at a column gap: its part's obstacle (or -1); kNotSplit: its cluster's.
  constexpr int kNotSplit = -2;
  std::vector<int> stixel_obstacle(stixels_.size(), kNotSplit);
  for (size_t index = 0; index < cluster_count; ++index) {
    Description& description = descriptions[index];
    work_ += description.work;
    if (!description.kept) continue;
    const int first_id = static_cast<int>(obstacles_.size());
    const auto id_of = [first_id](int local) { return local < 0 ? -1 : first_id + local; };
    for (Obstacle3d& obstacle : description.obstacles) {
      obstacle.id = static_cast<int>(obstacles_.size());
      obstacles_.push_back(std::move(obstacle));
    }
    if (description.obstacle_of_part.size() == 1) obstacle_of_cluster[index] = id_of(description.obstacle_of_part[0]);
    for (const auto& [member, local] : description.stixel_obstacle) stixel_obstacle[static_cast<size_t>(member)] = id_of(local);
  }
  for (size_t i = 0; i < stixels_.size(); ++i) {
    if (stixel_obstacle[i] == kNotSplit)
      stixels_[i].cluster = obstacle_of_cluster[static_cast<size_t>(root[static_cast<size_t>(cluster_of[i])])];
    else
      stixels_[i].cluster = stixel_obstacle[i];
  }

  std::ostringstream status;
  status << grid_.status() << "; " << stixels_.size() << " stixels, " << obstacles_.size() << " stixel obstacles";
  status_ = status.str();
}

}  // namespace lpstereo::arm::obstacles3d
