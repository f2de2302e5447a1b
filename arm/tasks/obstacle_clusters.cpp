// ARM task "obstacle_clusters": the Advanced U-disparity grid (kernels/advanced_u_disparity.cpp)
// thresholded with eq. 4.3 and clustered by an 8-connected flood fill into obstacles (thesis 003
// §4.2.3, §4.2.4); per obstacle its image bounding box, mean disparity, distance, foot position and
// size in metres. Record layout: arm/tasks/obstacle_record.h. Defaults: arm/tasks/obstacle_clusters.h.
//
// Model. A vertical object of height Y (m) at disparity d (px) stands Y d / B pixels tall in the
// image (f Y / Z with Z = f B / d), so a grid column one image column wide collects that many
// obstacle votes at its disparity. Eq. 4.3 asks for at least n_min = (Y_min / B) d of them:
//     occupied(c, r)  <=>  grid(c, r) >= T_r = ceil(obstacle_weight * max(1, n_min(r)) * w_r)
//     n_min(r) = Y_min(Z_r) / B * d_r,  d_r = aud_row_centre_disparity_px(r),  Z_r = f B / d_r,
//     Y_min(Z) = near_min_height_m when Z < height_switch_distance_m, else far_min_height_m,
//     w_r = 1 (min_width_m = 0, the thesis' threshold) or clamp(min_width_m d_r / B, 1, columns_per_cell).
// max(1, .): at least one vote, whatever the height. Why w_r: a cell sums columns_per_cell image
// columns, so with w_r = 1 an object one column wide and Y_min tall just reaches T_r, and an object
// as wide as the cell reaches it when it is only Y_min / columns_per_cell tall: the cell is
// columns_per_cell times more sensitive than the thesis' one-column U-disparity, and so is the noise.
// Setting min_width_m (an obstacle's smallest width) asks for as many columns as such an object
// covers, at most the cell's: the same physical object passes at every range. It stays off by
// default because the range test's smallest objects (a 0.07 m tape roll at 40 m) cover only a few
// columns, and the free-space penalty (free_weight) already removes most road noise; the lead tunes it.
// Why the switch at 50 m (default): the range test asks for 0.07 m objects at 40 m, which
// only the near height (0.03 m) lets through, so the switch must lie beyond 40 m plus a grid row's
// depth extent and the 10 % distance tolerance; the far height (default 0.20 m, "about 30 cm" in the
// thesis) from 50 m on removes the road's disparity noise far away (±0.25 px at d = 20 px is ±0.4 m
// of apparent height at 1.5 m camera height) and still lets a 0.30 m cone through at 92 m, whose
// lowest rows lie within the road margin (0.25 m measured the cone's upper 0.24 m against 0.25).
//
// Steps, per frame:
//   1. threshold every cell with T_r (T_r is computed once, in prepare);
//   2. 8-connected flood fill of the occupied cells, "from the top-left cell, oil-stain growth"
//      (thesis §4.2.4): cells visited in raster order (row 0 = far first, columns left to right),
//      each unlabelled occupied cell starts a cluster grown with an explicit stack (no recursion, so
//      a grid-sized cluster cannot overflow the ARM's stack); clusters numbered in fill order;
//      clusters with fewer than min_cells cells dropped;
//   3. one scan over the mask and the disparity map (for all clusters at once): each kMaskObstacle
//      pixel (u, v) with Q4 disparity D whose cell (u / columns_per_cell, aud_grid_row_of_q4(D))
//      belongs to a kept cluster extends that cluster's bounding box and adds to its pixel count and
//      disparity sum;
//   4. per cluster with at least min_pixels pixels: mean disparity d = sum / (16 count), distance
//      z = f B / d, the foot (bounding box bottom centre u_f = (x0 + x1) / 2, v_f = y1) at
//      x = (u_f - cx) z / f, y = (v_f - cy) z / f, width (x1 - x0 + 1) z / f and height (y1 - y0 + 1)
//      z / f (pinhole, DESIGN.md §4), in mm, rounded;
//   5. ids 1, 2, ... in fill order over the clusters left after steps 2 and 4. Records are written in
//      fill order (far to near by their first cell, then left to right): a consumer that wants the
//      nearest first sorts by distance. When more than max_obstacles clusters are left, the
//      max_obstacles nearest (largest mean disparity, then lower id) are kept, still in fill order,
//      with their ids (so ids may have gaps): the nearest obstacles matter most to the vehicle.
//
// Ports: "grid" u16 (grid_columns x grid_rows, grid_columns = ceil(W / columns_per_cell)), "disparity"
// s16 Q4 (W x H), "mask" u8 (W x H, kernels/obstacle_mask.h); output "obstacles" s32 kObstacleWords x
// max_obstacles.
//
// Parameters: the grid's, named as the kernel's: columns_per_cell, grid_rows, min_disparity_px,
// max_disparity_px, exponent_k, obstacle_weight; focal_px and baseline_m (> 0, required);
// principal_point_x_px, principal_point_y_px (default the image centre (W - 1) / 2, (H - 1) / 2);
// near_min_height_m, far_min_height_m, height_switch_distance_m, min_width_m, min_cells, min_pixels,
// max_obstacles (defaults: ObstacleClusterSettings and AudGridSettings in obstacle_clusters.h).
//
// Counted work (deterministic, ArmWork), with C x R grid cells, O occupied cells, K clusters found
// by the fill, W x H pixels, P obstacle-mask pixels, Q of them in a kept cluster, N records written,
// L clusters left after the filters, M = max_obstacles:
//   scalar_ops   = 2 C R (load, compare with T_r) + 28 O (per occupied cell: push and pop 4, eight
//                  neighbours of bounds check, label load and compare 3 each) + 8 K (start, size
//                  check) + 2 W H (mask load, compare) + 5 P (disparity load, row lookup, column,
//                  label load, compare) + 6 Q (four bounding-box min/max, count, sum) + 48 K (mean,
//                  distance, position, size, filters) + 4 L when L > M (choosing the nearest);
//   memory_bytes = 2 C R (grid) + 4 C R (labels written) + 3 W H (mask and disparity) + 4
//                  kObstacleWords M (records).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "arm/tasks/obstacle_clusters.h"
#include "arm/tasks/obstacle_record.h"
#include "dag/arm_task.h"
#include "kernels/advanced_u_disparity.h"
#include "kernels/obstacle_mask.h"

namespace lpstereo::arm {

std::vector<uint32_t> obstacle_cell_thresholds(const kernels::AudGridGeometry& geometry, int columns_per_cell,
                                               int obstacle_weight, const ObstacleClusterSettings& settings,
                                               double focal_px, double baseline_m) {
  // T_r per row (eq. 4.3 with the two heights, see the header comment).
  std::vector<uint32_t> thresholds(static_cast<size_t>(geometry.grid_rows));
  for (int row = 0; row < geometry.grid_rows; ++row) {
    const double disparity_px = kernels::aud_row_centre_disparity_px(geometry, row);
    const double distance_m = focal_px * baseline_m / disparity_px;
    const double min_height_m =
        distance_m < settings.height_switch_distance_m ? settings.near_min_height_m : settings.far_min_height_m;
    const double min_votes = std::max(1.0, min_height_m / baseline_m * disparity_px);
    const double columns = settings.min_width_m > 0.0
                               ? std::clamp(settings.min_width_m * disparity_px / baseline_m, 1.0, double(columns_per_cell))
                               : 1.0;
    // 1e-9 of slack: a product that is an integer up to rounding stays on it.
    const double threshold = std::ceil(obstacle_weight * min_votes * columns - 1e-9);
    thresholds[static_cast<size_t>(row)] = static_cast<uint32_t>(std::min(threshold, 65536.0));  // 65536: never
  }
  return thresholds;
}

namespace {

struct ObstacleClustersParams {
  int columns_per_cell = 0;
  int grid_columns = 0;
  int grid_rows = 0;
  double focal_px = 0.0;
  double baseline_m = 0.0;
  double principal_point_x_px = 0.0;
  double principal_point_y_px = 0.0;
  int min_cells = 0;
  int min_pixels = 0;
  int max_obstacles = 0;
  std::vector<uint32_t> threshold;   // T_r per grid row
  int32_t first_row_q4 = 0;          // boundary_q4[0]: row_of_q4[D - first_row_q4] for D in [first, last)
  std::vector<int16_t> row_of_q4;    // aud_grid_row_of_q4 as a table
};

double required_positive(const nlohmann::json& params, const char* name) {
  if (!params.contains(name)) throw KernelError(std::string("parameter '") + name + "': expected a number > 0, got none");
  const double value = param_double(params, name, 0.0, -1e9, 1e9);
  if (!(value > 0.0)) throw KernelError(std::string("parameter '") + name + "': expected a number > 0, got " + std::to_string(value));
  return value;
}

std::string shape_text(const PlaneShape& shape) { return std::to_string(shape.width) + "x" + std::to_string(shape.height); }

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"columns_per_cell", "grid_rows", "min_disparity_px", "max_disparity_px", "exponent_k",
                             "obstacle_weight", "focal_px", "baseline_m", "principal_point_x_px", "principal_point_y_px",
                             "near_min_height_m", "far_min_height_m", "height_switch_distance_m", "min_width_m", "min_cells",
                             "min_pixels", "max_obstacles"});
  if (input_shapes.size() != 3) {
    throw KernelError("inputs: expected 3 (grid, disparity, mask), got " + std::to_string(input_shapes.size()));
  }
  const AudGridSettings grid_defaults;
  const ObstacleClusterSettings defaults;
  const PlaneShape& grid = input_shapes[0];
  const PlaneShape& disparity = input_shapes[1];
  const PlaneShape& mask = input_shapes[2];
  auto prepared = std::make_shared<ObstacleClustersParams>();
  ObstacleClustersParams& p = *prepared;
  p.columns_per_cell = param_int(params, "columns_per_cell", grid_defaults.columns_per_cell, 1, 4096);
  kernels::AudGridGeometry geometry;
  geometry.grid_rows = param_int(params, "grid_rows", grid_defaults.geometry.grid_rows, 1, 4096);
  geometry.min_disparity_px = param_double(params, "min_disparity_px", grid_defaults.geometry.min_disparity_px, 1.0 / 16, 2047.0);
  geometry.max_disparity_px = param_double(params, "max_disparity_px", grid_defaults.geometry.max_disparity_px, 1.0 / 16, 2048.0);
  if (!(geometry.max_disparity_px > geometry.min_disparity_px)) {
    throw KernelError("parameter 'max_disparity_px': expected more than min_disparity_px = " +
                      std::to_string(geometry.min_disparity_px) + ", got " + std::to_string(geometry.max_disparity_px));
  }
  geometry.exponent_k = param_double(params, "exponent_k", grid_defaults.geometry.exponent_k, 0.01, 100.0);
  const int obstacle_weight = param_int(params, "obstacle_weight", grid_defaults.obstacle_weight, 1, 65535);
  p.focal_px = required_positive(params, "focal_px");
  p.baseline_m = required_positive(params, "baseline_m");
  p.principal_point_x_px = param_double(params, "principal_point_x_px", (disparity.width - 1) / 2.0, -1e6, 1e6);
  p.principal_point_y_px = param_double(params, "principal_point_y_px", (disparity.height - 1) / 2.0, -1e6, 1e6);
  ObstacleClusterSettings settings;
  settings.near_min_height_m = param_double(params, "near_min_height_m", defaults.near_min_height_m, 0.0, 100.0);
  settings.far_min_height_m = param_double(params, "far_min_height_m", defaults.far_min_height_m, 0.0, 100.0);
  settings.height_switch_distance_m =
      param_double(params, "height_switch_distance_m", defaults.height_switch_distance_m, 0.0, 1e6);
  settings.min_width_m = param_double(params, "min_width_m", defaults.min_width_m, 0.0, 100.0);
  p.min_cells = param_int(params, "min_cells", defaults.min_cells, 1, 1 << 30);
  p.min_pixels = param_int(params, "min_pixels", defaults.min_pixels, 1, 1 << 30);
  p.max_obstacles = param_int(params, "max_obstacles", defaults.max_obstacles, 1, 65535);

  if (mask != disparity) {
    throw KernelError("input 'mask': expected the disparity map's size " + shape_text(disparity) + ", got " + shape_text(mask));
  }
  p.grid_columns = (disparity.width + p.columns_per_cell - 1) / p.columns_per_cell;
  p.grid_rows = geometry.grid_rows;
  const PlaneShape expected_grid{p.grid_columns, p.grid_rows};
  if (grid != expected_grid) {
    throw KernelError("input 'grid': expected ceil(" + std::to_string(disparity.width) + " / columns_per_cell " +
                      std::to_string(p.columns_per_cell) + ") x grid_rows = " + shape_text(expected_grid) + ", got " +
                      shape_text(grid));
  }

  p.threshold = obstacle_cell_thresholds(geometry, p.columns_per_cell, obstacle_weight, settings, p.focal_px, p.baseline_m);
  // The grid row of each Q4 disparity in [boundary_q4[0], boundary_q4[R]), as a table.
  const std::vector<int32_t> boundaries = kernels::aud_row_boundaries_q4(geometry);
  p.first_row_q4 = boundaries.front();
  p.row_of_q4.resize(static_cast<size_t>(std::max(0, boundaries.back() - boundaries.front())));
  for (int32_t d = boundaries.front(); d < boundaries.back(); ++d) {
    p.row_of_q4[static_cast<size_t>(d - p.first_row_q4)] = static_cast<int16_t>(kernels::aud_grid_row_of_q4(boundaries, d));
  }
  return PreparedKernel{prepared, {{kObstacleWords, p.max_obstacles}}};
}

struct Cluster {
  int cells = 0;
  int cell_column0 = 0, cell_row0 = 0, cell_column1 = 0, cell_row1 = 0;
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  int64_t pixels = 0;
  int64_t disparity_sum_q4 = 0;
  int id = 0;
  double disparity_px = 0.0;
};

int32_t round_to_s32(double value) {
  return static_cast<int32_t>(std::llround(std::clamp(value, -2147483648.0, 2147483647.0)));
}

void run(const ArmTaskArgs& args) {
  const auto& p = *static_cast<const ObstacleClustersParams*>(args.params);
  const Plane& grid = *args.inputs.at(0);
  const Plane& disparity = *args.inputs.at(1);
  const Plane& mask = *args.inputs.at(2);
  Plane& output = *args.outputs.at(0);
  const int columns = p.grid_columns;
  const int rows = p.grid_rows;
  const int width = disparity.width();
  const int height = disparity.height();
  uint64_t ops = 0;

  // 1. Threshold.
  std::vector<int32_t> label(static_cast<size_t>(columns) * rows, 0);  // -1 occupied, unlabelled; > 0 cluster index + 1
  int occupied = 0;
  for (int r = 0; r < rows; ++r) {
    const uint16_t* cell = grid.row<const uint16_t>(r);
    const uint32_t threshold = p.threshold[static_cast<size_t>(r)];
    for (int c = 0; c < columns; ++c) {
      if (cell[c] >= threshold) {
        label[static_cast<size_t>(r) * columns + c] = -1;
        ++occupied;
      }
    }
  }
  ops += 2ull * columns * rows + 28ull * occupied;

  // 2. Flood fill, raster order, explicit stack.
  std::vector<Cluster> clusters;
  std::vector<int> stack;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      if (label[static_cast<size_t>(r) * columns + c] != -1) continue;
      const int number = static_cast<int>(clusters.size()) + 1;
      Cluster cluster;
      cluster.cell_column0 = cluster.cell_column1 = c;
      cluster.cell_row0 = cluster.cell_row1 = r;
      label[static_cast<size_t>(r) * columns + c] = number;
      stack.assign(1, r * columns + c);
      while (!stack.empty()) {
        const int index = stack.back();
        stack.pop_back();
        const int cell_row = index / columns, cell_column = index % columns;
        ++cluster.cells;
        cluster.cell_column0 = std::min(cluster.cell_column0, cell_column);
        cluster.cell_column1 = std::max(cluster.cell_column1, cell_column);
        cluster.cell_row0 = std::min(cluster.cell_row0, cell_row);
        cluster.cell_row1 = std::max(cluster.cell_row1, cell_row);
        for (int dr = -1; dr <= 1; ++dr) {
          for (int dc = -1; dc <= 1; ++dc) {
            const int nr = cell_row + dr, nc = cell_column + dc;
            if ((dr == 0 && dc == 0) || nr < 0 || nr >= rows || nc < 0 || nc >= columns) continue;
            int32_t& neighbour = label[static_cast<size_t>(nr) * columns + nc];
            if (neighbour == -1) {
              neighbour = number;
              stack.push_back(nr * columns + nc);
            }
          }
        }
      }
      clusters.push_back(cluster);
    }
  }
  ops += 8ull * clusters.size();
  // Clusters under min_cells: their cells take no pixels.
  std::vector<uint8_t> kept(clusters.size() + 1, 0);
  for (size_t i = 0; i < clusters.size(); ++i) kept[i + 1] = clusters[i].cells >= p.min_cells ? 1 : 0;

  // 3. One scan over the mask and disparity map.
  uint64_t obstacle_pixels = 0, cluster_pixels = 0;
  const int32_t first_q4 = p.first_row_q4;
  const int32_t table_size = static_cast<int32_t>(p.row_of_q4.size());
  for (int v = 0; v < height; ++v) {
    const uint8_t* mask_row = mask.row<const uint8_t>(v);
    const int16_t* disparity_row = disparity.row<const int16_t>(v);
    for (int u = 0; u < width; ++u) {
      if (mask_row[u] != kernels::kMaskObstacle) continue;
      ++obstacle_pixels;
      const int32_t offset = int32_t{disparity_row[u]} - first_q4;
      if (offset < 0 || offset >= table_size) continue;  // outside the grid's disparity range
      const int r = p.row_of_q4[static_cast<size_t>(offset)];
      const int32_t number = label[static_cast<size_t>(r) * columns + u / p.columns_per_cell];
      if (number <= 0 || !kept[static_cast<size_t>(number)]) continue;
      Cluster& cluster = clusters[static_cast<size_t>(number - 1)];
      if (cluster.pixels == 0) {
        cluster.x0 = cluster.x1 = u;
        cluster.y0 = cluster.y1 = v;
      } else {
        cluster.x0 = std::min(cluster.x0, u);
        cluster.x1 = std::max(cluster.x1, u);
        cluster.y0 = std::min(cluster.y0, v);
        cluster.y1 = std::max(cluster.y1, v);
      }
      ++cluster.pixels;
      cluster.disparity_sum_q4 += disparity_row[u];
      ++cluster_pixels;
    }
  }
  ops += 2ull * width * height + 5ull * obstacle_pixels + 6ull * cluster_pixels;

  // 4-5. Filters, ids in fill order, the nearest max_obstacles.
  std::vector<Cluster*> records;
  int next_id = 1;
  for (size_t i = 0; i < clusters.size(); ++i) {
    Cluster& cluster = clusters[i];
    if (!kept[i + 1] || cluster.pixels < p.min_pixels) continue;
    cluster.id = next_id++;
    cluster.disparity_px = static_cast<double>(cluster.disparity_sum_q4) / (16.0 * static_cast<double>(cluster.pixels));
    if (!(cluster.disparity_px > 0.0)) continue;  // no distance (only with a grid reaching d <= 0, which prepare refuses)
    records.push_back(&cluster);
  }
  ops += 48ull * clusters.size();
  if (static_cast<int>(records.size()) > p.max_obstacles) {
    ops += 4ull * records.size();
    std::vector<Cluster*> nearest = records;
    std::stable_sort(nearest.begin(), nearest.end(),
                     [](const Cluster* a, const Cluster* b) { return a->disparity_px > b->disparity_px; });
    nearest.resize(static_cast<size_t>(p.max_obstacles));
    std::sort(nearest.begin(), nearest.end(), [](const Cluster* a, const Cluster* b) { return a->id < b->id; });
    records = std::move(nearest);
  }

  for (int row = 0; row < p.max_obstacles; ++row) {
    int32_t* word = output.row<int32_t>(row);
    std::fill(word, word + kObstacleWords, 0);
    if (row >= static_cast<int>(records.size())) continue;
    const Cluster& cluster = *records[static_cast<size_t>(row)];
    const double distance_m = p.focal_px * p.baseline_m / cluster.disparity_px;
    const double metres_per_px = distance_m / p.focal_px;
    const double foot_u = (cluster.x0 + cluster.x1) / 2.0;
    word[kObstacleValid] = 1;
    word[kObstacleId] = cluster.id;
    word[kObstacleX0] = cluster.x0;
    word[kObstacleY0] = cluster.y0;
    word[kObstacleX1] = cluster.x1;
    word[kObstacleY1] = cluster.y1;
    word[kObstaclePixels] = static_cast<int32_t>(std::min<int64_t>(cluster.pixels, INT32_MAX));
    word[kObstacleDisparityQ4] = round_to_s32(cluster.disparity_px * 16.0);
    word[kObstacleDistanceMm] = round_to_s32(distance_m * 1000.0);
    word[kObstaclePositionXMm] = round_to_s32((foot_u - p.principal_point_x_px) * metres_per_px * 1000.0);
    word[kObstaclePositionYMm] = round_to_s32((cluster.y1 - p.principal_point_y_px) * metres_per_px * 1000.0);
    word[kObstacleWidthMm] = round_to_s32((cluster.x1 - cluster.x0 + 1) * metres_per_px * 1000.0);
    word[kObstacleHeightMm] = round_to_s32((cluster.y1 - cluster.y0 + 1) * metres_per_px * 1000.0);
    word[kObstacleCells] = cluster.cells;
    word[kObstacleCellColumn0] = cluster.cell_column0;
    word[kObstacleCellRow0] = cluster.cell_row0;
    word[kObstacleCellColumn1] = cluster.cell_column1;
    word[kObstacleCellRow1] = cluster.cell_row1;
  }
  if (args.work != nullptr) {
    args.work->scalar_ops += ops;
    args.work->memory_bytes += 6ull * columns * rows + 3ull * width * height + 4ull * kObstacleWords * p.max_obstacles;
  }
}

ArmTaskDescriptor make_obstacle_clusters() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "obstacle_clusters";
  descriptor.summary =
      "AUD grid thresholded with n_min = (Y_min / B) d (near / far heights), 8-connected flood fill into obstacles: "
      "bounding box, mean disparity, distance, foot position, size";
  descriptor.ports = {{"grid", PortDirection::input, {ElementType::u16, 0}, PortAccess::whole},
                      {"disparity", PortDirection::input, {ElementType::s16, 4}, PortAccess::whole},
                      {"mask", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"obstacles", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(obstacle_clusters, lpstereo::arm::make_obstacle_clusters);
