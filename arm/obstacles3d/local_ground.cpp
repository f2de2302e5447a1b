#include "arm/obstacles3d/local_ground.h"

#include <algorithm>
#include <cmath>

#include "arm/obstacles3d/parameter_check.h"

namespace lpstereo::arm::obstacles3d {

void LocalGroundParameters::validate() const {
  require_parameter(reach_cells >= 0 && reach_cells <= 8, "reach_cells", "a count of cells in [0, 8]", reach_cells);
  require_parameter(band_below_m > 0 && band_below_m < 10, "band_below_m", "a height in (0, 10) m", band_below_m);
  require_parameter(min_points >= 1 && min_points <= 100000, "min_points", "a count in [1, 100000]", min_points);
}

LocalGround::LocalGround(const terrain::TerrainGridSpec& spec, const terrain::BsplineSurface& surface, double obstacle_height_m,
                         const LocalGroundParameters& parameters, int shares)
    : spec_(spec), surface_(surface), obstacle_height_m_(obstacle_height_m), parameters_(parameters) {
  parameters.validate();
  require_parameter(shares >= 1 && shares <= 1024, "shares", "a count in [1, 1024]", shares);
  forward_cells_ = spec.forward_cells();
  lateral_cells_ = spec.lateral_cells();
  const size_t cells = static_cast<size_t>(forward_cells_) * static_cast<size_t>(lateral_cells_);
  holds_candidates_.assign(cells, 0);
  in_window_.assign(cells, 0);
  shares_.resize(static_cast<size_t>(shares));
  for (Share& share : shares_) share.inlier_heights_m.resize(cells);
  work_.memory_bytes += 2 * cells;
  surface_evaluation_ops_ = terrain::surface_evaluation_ops(surface.degree_forward, surface.degree_lateral);
}

size_t LocalGround::index(int forward_cell, int lateral_cell) const {
  return static_cast<size_t>(forward_cell) * static_cast<size_t>(lateral_cells_) + static_cast<size_t>(lateral_cell);
}

void LocalGround::mark_candidates(const std::vector<ObstaclePoint>& candidates) {
  const int reach = parameters_.reach_cells;
  for (const ObstaclePoint& candidate : candidates) {
    work_.scalar_ops += 6;
    int i = 0, j = 0;
    if (!spec_.cell_of(candidate.vehicle_m.x(), candidate.vehicle_m.y(), forward_cells_, lateral_cells_, &i, &j)) continue;
    if (holds_candidates_[index(i, j)]) continue;
    holds_candidates_[index(i, j)] = 1;
    for (int a = std::max(0, i - reach); a <= std::min(forward_cells_ - 1, i + reach); ++a) {
      for (int b = std::max(0, j - reach); b <= std::min(lateral_cells_ - 1, j + reach); ++b) {
        in_window_[index(a, b)] = 1;
        work_.scalar_ops += 2;
      }
    }
  }
}

void LocalGround::add_point(const Eigen::Vector3d& vehicle_m, int share, double height_above_m) {
  int i = -1, j = -1;
  if (!spec_.cell_of(vehicle_m.x(), vehicle_m.y(), forward_cells_, lateral_cells_, &i, &j)) i = -1;
  add_point_in_cell(vehicle_m, i, j, share, height_above_m);
}

void LocalGround::add_point_in_cell(const Eigen::Vector3d& vehicle_m, int i, int j, int share, double height_above_m) {
  Share& state = shares_.at(static_cast<size_t>(share));
  ArmWork& work = state.work;
  work.scalar_ops += 4;
  if (i < 0 || !in_window_[index(i, j)]) return;
  if (!surface_.contains(vehicle_m.x(), vehicle_m.y())) return;
  double above_m = height_above_m;
  if (std::isnan(above_m)) {
    work.scalar_ops += surface_evaluation_ops_;
    above_m = vehicle_m.z() - surface_.height_m(vehicle_m.x(), vehicle_m.y());
  }
  if (!(above_m >= -parameters_.band_below_m && above_m <= obstacle_height_m_)) return;
  state.inlier_heights_m[index(i, j)].push_back(static_cast<float>(above_m));
  work.memory_bytes += 4;
}

ArmWork LocalGround::work() const {
  ArmWork total = work_;
  for (const Share& share : shares_) total += share.work;
  return total;
}

int LocalGround::apply(std::vector<ObstaclePoint>& candidates) {
  const int reach = parameters_.reach_cells;
  std::vector<float> offset_m(holds_candidates_.size(), 0.0f);
  std::vector<float> pooled;
  int cells = 0;
  for (int i = 0; i < forward_cells_; ++i) {
    for (int j = 0; j < lateral_cells_; ++j) {
      if (!holds_candidates_[index(i, j)]) continue;
      pooled.clear();
      for (int a = std::max(0, i - reach); a <= std::min(forward_cells_ - 1, i + reach); ++a) {
        for (int b = std::max(0, j - reach); b <= std::min(lateral_cells_ - 1, j + reach); ++b) {
          for (const Share& share : shares_) {
            const std::vector<float>& heights = share.inlier_heights_m[index(a, b)];
            pooled.insert(pooled.end(), heights.begin(), heights.end());
          }
        }
      }
      work_.scalar_ops += 4 * pooled.size();
      if (pooled.empty() || static_cast<int64_t>(pooled.size()) < parameters_.min_points) continue;
      // The median (the upper one of an even count): order-free, so the result does not depend on
      // the order the points came in.
      const auto middle = pooled.begin() + static_cast<std::ptrdiff_t>(pooled.size() / 2);
      std::nth_element(pooled.begin(), middle, pooled.end());
      if (*middle < 0) {
        offset_m[index(i, j)] = *middle;
        ++cells;
      }
    }
  }
  for (ObstaclePoint& candidate : candidates) {
    work_.scalar_ops += 6;
    int i = 0, j = 0;
    if (spec_.cell_of(candidate.vehicle_m.x(), candidate.vehicle_m.y(), forward_cells_, lateral_cells_, &i, &j)) candidate.height_above_ground_m -= offset_m[index(i, j)];
  }
  return cells;
}

}  // namespace lpstereo::arm::obstacles3d
