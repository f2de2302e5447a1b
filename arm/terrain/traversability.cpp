// Slope, traversability cost and the terrain/obstacle segmentation of the points (issue 9
// deliverable 4; thesis 000 = Sabbatelli 2015, ../shared/theses/000_*.txt, §3.1.2 steps 3-5).
//
// Model. Slope: |grad S| at each cell centre from the surface's first derivatives (the thesis's
// "slope ... computed ... just by derivation"; bspline_surface.cpp has the basis derivatives), so
// a 10 % grade gives 0.1 whatever the grid's resolution. Occupancy ("isOcc", a normalized
// likelihood that is at its maximum on an obstacle): 1 when the cell's height in the grid before
// equalisation is more than obstacle_height_m above S, else 0; filled cells (no points, height from
// their neighbours) follow the same rule (a gap inside an obstacle is likely the obstacle); invalid
// cells are unknown (NaN). Cost (thesis eq. 3.1):
//     Tc(x, y) = w_occ isOcc(x, y) + w_slope |S'(x, y)|
// NaN where the occupancy or the slope is unknown; every cell NaN when the terrain is unknown.
// Segmentation (§3.1.2 step 4): a point is an obstacle candidate when z - S(x, y) >
// obstacle_height_m, terrain otherwise, outside when S does not cover (x, y) or the point is not
// finite or the terrain unknown. With a StereoRayModel (optional; off in every caller by default):
// a candidate stays an obstacle only when the same point with its disparity disparity_margin_px
// smaller (pushed along its viewing ray from the camera centre by d / (d - margin)) is still more
// than obstacle_height_m above S. A ground point that stereo placed too near is too high by about
// r h delta_d / (f B) (r its range, h the camera height above it); the push undoes that share.
// Measured on bench/terrain_synth_eval (640x480): 1 px lifts precision by 3-15 points but costs
// recall 8-17 points (every low obstacle point far away falls back too), 0.5 px half of both.
// Support (support_reach_cells >= 0; hysteresis, as Canny's two thresholds): a candidate that fell
// back is an obstacle again when a candidate that stood the push lies in its grid cell
// (terrain.grid.spec) or within support_reach_cells cells (Chebyshev) of it: the obstacle's higher
// points vouch for its low ones, an isolated ground point lifted by a disparity error has none.
// 1 px with support in the own cell on the same 15 scenes: precision 88.9 -> 92.6 %, recall 95.8 ->
// 95.5 % (means; docs/terrain.md). Counted by the caller as well: two passes over the points and
// (2 reach + 1)^2 cell looks per fallen-back candidate.
//
// Counted work (ArmWork), with C = m0 m1 cells, n0 x n1 control points, degrees d0, d1:
//   compute_traversability: scalar_ops = 6 d0 (d0 + 1) m0 + 6 d1 (d1 + 1) m1 (basis values and
//     derivatives) + 3 (2 m0 n0 n1 + 2 m0 n1 m1) (S, dS/dx, dS/dy at every cell: B0 Q B1^T,
//     B0' Q B1^T, B0 Q B1'^T) + 12 C (norm with a square root, the occupancy compare, the cost);
//     memory_bytes = 12 C (measured heights and states) + 8 n0 n1 (control points) + 24 C (slope,
//     occupancy, cost written).
//   classify_points is counted by its caller: per point ~ 6 d (d + 1) + 2 (d0 + 1)(d1 + 1) + 8, twice
//   that for a candidate with a StereoRayModel (the pushed point's surface height) plus 20.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/localization/ransac_sampling.h"
#include "arm/terrain/terrain_model.h"

namespace lpstereo::arm::terrain {

namespace {

double quiet_nan() { return std::numeric_limits<double>::quiet_NaN(); }

// The repository's number format for error messages (%.6g).
using localization::format_number;

void check_obstacle_height(double obstacle_height_m) {
  if (!(obstacle_height_m > 0) || !std::isfinite(obstacle_height_m)) {
    throw std::invalid_argument("obstacle_height_m: expected a finite value > 0, got " + format_number(obstacle_height_m));
  }
}

}  // namespace

TraversabilityMap compute_traversability(const TerrainEstimate& terrain, const HeightGrid& measured,
                                         const TraversabilityParameters& parameters) {
  if (!(parameters.occupancy_weight >= 0) || !std::isfinite(parameters.occupancy_weight)) {
    throw std::invalid_argument("occupancy_weight: expected a finite value >= 0, got " + format_number(parameters.occupancy_weight));
  }
  if (!(parameters.slope_weight >= 0) || !std::isfinite(parameters.slope_weight)) {
    throw std::invalid_argument("slope_weight: expected a finite value >= 0, got " + format_number(parameters.slope_weight));
  }
  check_obstacle_height(parameters.obstacle_height_m);
  const TerrainGridSpec& spec = measured.spec;
  spec.validate();
  const int m0 = spec.forward_cells(), m1 = spec.lateral_cells();
  if (measured.height_m.rows() != m0 || measured.height_m.cols() != m1 || measured.state.rows() != m0 ||
      measured.state.cols() != m1) {
    throw std::invalid_argument("measured: expected " + std::to_string(m0) + "x" + std::to_string(m1) +
                                " height and state matrices (the spec's cells), got " + std::to_string(measured.height_m.rows()) +
                                "x" + std::to_string(measured.height_m.cols()));
  }
  TraversabilityMap map;
  map.slope = Eigen::MatrixXd::Constant(m0, m1, quiet_nan());
  map.occupancy = Eigen::MatrixXd::Constant(m0, m1, quiet_nan());
  map.cost = Eigen::MatrixXd::Constant(m0, m1, quiet_nan());
  if (!terrain.known || terrain.surface.control_z_m.size() == 0) return map;

  const BsplineSurface& surface = terrain.surface;
  const int d0 = surface.degree_forward, d1 = surface.degree_lateral;
  const Eigen::Index n0 = surface.control_z_m.rows(), n1 = surface.control_z_m.cols();
  std::vector<double> xs(static_cast<size_t>(m0)), ys(static_cast<size_t>(m1));
  for (int i = 0; i < m0; ++i) xs[static_cast<size_t>(i)] = spec.cell_centre_x_m(i);
  for (int j = 0; j < m1; ++j) ys[static_cast<size_t>(j)] = spec.cell_centre_y_m(j);
  Eigen::MatrixXd heights, slope_x, slope_y;
  if (surface.control_weights.size() == 0) {
    const Eigen::MatrixXd basis0 = basis_matrix(surface.knots_forward_m, d0, xs);
    const Eigen::MatrixXd basis1 = basis_matrix(surface.knots_lateral_m, d1, ys);
    const Eigen::MatrixXd derivative0 = basis_matrix(surface.knots_forward_m, d0, xs, true);
    const Eigen::MatrixXd derivative1 = basis_matrix(surface.knots_lateral_m, d1, ys, true);
    const Eigen::MatrixXd q_b1 = surface.control_z_m * basis1.transpose();  // n0 x m1
    heights = basis0 * q_b1;
    slope_x = derivative0 * q_b1;
    slope_y = basis0 * surface.control_z_m * derivative1.transpose();
  } else {  // the rational form: per cell, with the quotient rule
    heights.resize(m0, m1);
    slope_x.resize(m0, m1);
    slope_y.resize(m0, m1);
    for (int i = 0; i < m0; ++i) {
      for (int j = 0; j < m1; ++j) {
        heights(i, j) = surface.height_m(xs[static_cast<size_t>(i)], ys[static_cast<size_t>(j)]);
        const Eigen::Vector2d gradient = surface.gradient(xs[static_cast<size_t>(i)], ys[static_cast<size_t>(j)]);
        slope_x(i, j) = gradient.x();
        slope_y(i, j) = gradient.y();
      }
    }
  }
  for (int i = 0; i < m0; ++i) {
    for (int j = 0; j < m1; ++j) {
      if (!surface.contains(xs[static_cast<size_t>(i)], ys[static_cast<size_t>(j)])) continue;
      const double slope = std::hypot(slope_x(i, j), slope_y(i, j));
      map.slope(i, j) = slope;
      if (measured.state(i, j) == kCellInvalid || !std::isfinite(measured.height_m(i, j))) continue;
      const double occupancy = measured.height_m(i, j) - heights(i, j) > parameters.obstacle_height_m ? 1.0 : 0.0;
      map.occupancy(i, j) = occupancy;
      map.cost(i, j) = parameters.occupancy_weight * occupancy + parameters.slope_weight * slope;  // eq. 3.1
    }
  }
  const uint64_t cells = static_cast<uint64_t>(m0) * static_cast<uint64_t>(m1);
  map.work.scalar_ops = static_cast<uint64_t>(6 * d0 * (d0 + 1) * m0 + 6 * d1 * (d1 + 1) * m1) +
                        3 * static_cast<uint64_t>(2 * m0 * n0 * n1 + 2 * m0 * n1 * m1) + 12 * cells;
  map.work.memory_bytes = 12 * cells + 8 * static_cast<uint64_t>(n0 * n1) + 24 * cells;
  return map;
}

std::vector<PointClass> classify_points(const std::vector<Eigen::Vector3d>& points_vehicle_m, const TerrainEstimate& terrain,
                                        double obstacle_height_m) {
  check_obstacle_height(obstacle_height_m);
  std::vector<PointClass> classes(points_vehicle_m.size(), PointClass::outside);
  if (!terrain.known || terrain.surface.control_z_m.size() == 0) return classes;
  for (size_t k = 0; k < points_vehicle_m.size(); ++k) {
    const Eigen::Vector3d& point = points_vehicle_m[k];
    if (!point.allFinite() || !terrain.surface.contains(point.x(), point.y())) continue;
    const double above_m = point.z() - terrain.surface.height_m(point.x(), point.y());
    classes[k] = above_m > obstacle_height_m ? PointClass::obstacle : PointClass::terrain;
  }
  return classes;
}

std::vector<PointClass> classify_points(const std::vector<Eigen::Vector3d>& points_vehicle_m, const TerrainEstimate& terrain,
                                        double obstacle_height_m, const StereoRayModel& stereo) {
  check_obstacle_height(obstacle_height_m);
  if (!(stereo.focal_baseline_px_m > 0) || !std::isfinite(stereo.focal_baseline_px_m)) {
    throw std::invalid_argument("focal_baseline_px_m: expected a finite value > 0, got " + format_number(stereo.focal_baseline_px_m));
  }
  if (!(stereo.disparity_margin_px >= 0) || !std::isfinite(stereo.disparity_margin_px)) {
    throw std::invalid_argument("disparity_margin_px: expected a finite value >= 0, got " + format_number(stereo.disparity_margin_px));
  }
  if (!stereo.camera_centre_m.allFinite() || !(std::abs(stereo.optical_axis.norm() - 1) < 1e-6)) {
    throw std::invalid_argument("optical_axis: expected a finite unit vector and a finite camera centre, got |axis| " +
                                format_number(stereo.optical_axis.norm()));
  }
  if (stereo.support_reach_cells < -1) {
    throw std::invalid_argument("support_reach_cells: expected -1 (off) or >= 0, got " + std::to_string(stereo.support_reach_cells));
  }
  std::vector<PointClass> classes = classify_points(points_vehicle_m, terrain, obstacle_height_m);
  std::vector<uint8_t> fell_back(stereo.support_reach_cells >= 0 ? points_vehicle_m.size() : 0, 0);
  const auto fall_back = [&](size_t k) {
    classes[k] = PointClass::terrain;
    if (!fell_back.empty()) fell_back[k] = 1;
  };
  for (size_t k = 0; k < points_vehicle_m.size(); ++k) {
    if (classes[k] != PointClass::obstacle) continue;
    const Eigen::Vector3d ray = points_vehicle_m[k] - stereo.camera_centre_m;
    const double depth_m = ray.dot(stereo.optical_axis);
    const double disparity_px = depth_m > 0 ? stereo.focal_baseline_px_m / depth_m : 0.0;
    if (disparity_px <= stereo.disparity_margin_px) {
      fall_back(k);
      continue;
    }
    // The same ray at depth f B / (d - margin): scale d / (d - margin) from the camera centre.
    const Eigen::Vector3d pushed = stereo.camera_centre_m + ray * (disparity_px / (disparity_px - stereo.disparity_margin_px));
    const double surface_m = terrain.surface.height_m(pushed.x(), pushed.y());
    // Beyond the surface's domain the pushed point cannot be judged: keep the plain test's answer.
    if (std::isfinite(surface_m) && pushed.z() - surface_m <= obstacle_height_m) fall_back(k);
  }
  if (fell_back.empty()) return classes;
  // Support: a candidate that fell back is an obstacle again when a point that stood the push (a
  // "sure" obstacle point) lies in its grid cell or within support_reach_cells cells of it.
  const TerrainGridSpec& spec = terrain.grid.spec;
  const int m0 = spec.forward_cells(), m1 = spec.lateral_cells();
  std::vector<uint8_t> sure_cell(static_cast<size_t>(m0 * m1), 0);
  for (size_t k = 0; k < points_vehicle_m.size(); ++k) {
    int i = 0, j = 0;
    if (classes[k] == PointClass::obstacle && spec.cell_of(points_vehicle_m[k].x(), points_vehicle_m[k].y(), &i, &j)) {
      sure_cell[static_cast<size_t>(i * m1 + j)] = 1;
    }
  }
  const int reach = stereo.support_reach_cells;
  for (size_t k = 0; k < points_vehicle_m.size(); ++k) {
    int i = 0, j = 0;
    if (fell_back[k] == 0 || !spec.cell_of(points_vehicle_m[k].x(), points_vehicle_m[k].y(), &i, &j)) continue;
    bool supported = false;
    for (int a = std::max(0, i - reach); a <= std::min(m0 - 1, i + reach) && !supported; ++a) {
      for (int b = std::max(0, j - reach); b <= std::min(m1 - 1, j + reach); ++b) {
        if (sure_cell[static_cast<size_t>(a * m1 + b)] != 0) {
          supported = true;
          break;
        }
      }
    }
    if (supported) classes[k] = PointClass::obstacle;
  }
  return classes;
}

}  // namespace lpstereo::arm::terrain
