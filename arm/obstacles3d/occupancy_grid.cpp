// Occupancy grids: the model, steps and counted work are in occupancy_grid.h.
#include "arm/obstacles3d/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "arm/fork_join.h"

namespace lpstereo::arm::obstacles3d {
namespace {

constexpr double kHalfPi = std::numbers::pi / 2;
constexpr double kInverseSqrt2 = 1 / std::numbers::sqrt2;

// Standard normal CDF. The likelihood only evaluates it within the window, |t| <= window_sigmas <= 6,
// so a table over [-6, 6] with linear interpolation replaces erf (the per-cell cost of the far points,
// spread over tens of rows): step h = 12 / 4096, interpolation error <= h^2 / 8 max|phi'| = 2.6e-7.
// The table's values are erf's at the knots, so the window's mass (2 Phi(k) - 1)^2 is exact for
// k on a knot (every k = n / 4096 * 12 - 6, e.g. 3).
constexpr int kCdfTableSteps = 4096;
constexpr double kCdfTableLimit = 6.0;
const std::vector<double> kCdfTable = [] {
  std::vector<double> values(kCdfTableSteps + 1);
  for (int i = 0; i <= kCdfTableSteps; ++i) {
    const double knot = -kCdfTableLimit + 2 * kCdfTableLimit * i / kCdfTableSteps;
    values[static_cast<size_t>(i)] = 0.5 * (1.0 + std::erf(knot * kInverseSqrt2));
  }
  return values;
}();
// Beyond +-6 (never inside a window; only rounding can get there) Phi is 0 or 1 within 1e-9.
inline double normal_cdf(double t) {
  const double position = std::clamp((t + kCdfTableLimit) * (kCdfTableSteps / (2 * kCdfTableLimit)), 0.0,
                                     static_cast<double>(kCdfTableSteps));
  const int index = std::min(static_cast<int>(position), kCdfTableSteps - 1);
  const double fraction = position - index;
  const double* table = kCdfTable.data();
  return table[index] + fraction * (table[index + 1] - table[index]);
}
double normal_pdf(double t) { return 0.3989422804014327 * std::exp(-0.5 * t * t); }

std::string number_text(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

// Cells [first, last] of an axis whose intervals meet [low, high], clamped to the grid; false when none.
bool axis_window(double low, double high, double axis_min, double cell, int cells, int* first, int* last) {
  const double first_cell = std::floor((low - axis_min) / cell);
  const double last_cell = std::floor((high - axis_min) / cell);
  if (!(last_cell >= 0) || !(first_cell < cells)) return false;
  *first = static_cast<int>(std::max(0.0, first_cell));
  *last = static_cast<int>(std::min<double>(cells - 1, last_cell));
  return *first <= *last;
}

constexpr uint64_t kOpsPerPoint = 40, kOpsPerWindowRow = 30, kOpsPerWindowCell = 16;
constexpr uint64_t kOpsPerSeparableColumn = 14, kOpsPerSeparableRow = 12, kOpsPerSeparableCell = 4;
constexpr uint64_t kOpsPerCellWarp = 20, kOpsPerCellUpdate = 24, kOpsPerCellCluster = 12;
constexpr uint64_t kOpsPerMemberCell = 10, kOpsPerHullStep = 6, kOpsPerPointDescribe = 10, kOpsPerCornerTest = 4;
constexpr uint64_t kOpsPerPointInlier = 12, kOpsPerGroupCellMode = 6, kOpsPerClimbStep = 8, kOpsPerModePair = 6,
                   kOpsPerRangeComparison = 20;

}  // namespace

void throw_invalid_parameter(const std::string& name, const std::string& expected, double actual) {
  throw std::invalid_argument(name + ": expected " + expected + ", got " + number_text(actual));
}

const char* grid_kind_name(GridKind kind) {
  switch (kind) {
    case GridKind::cartesian: return "cartesian";
    case GridKind::column_disparity: return "coldisp";
    case GridKind::polar: return "polar";
  }
  return "?";
}

Eigen::Isometry3d OccupancyGridParameters::level_camera() {
  // arm::optical_to_body(): camera z -> vehicle x, camera x -> vehicle -y, camera y -> vehicle -z.
  Eigen::Matrix3d rotation;
  rotation << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = rotation;
  return transform;
}

OccupancyGridParameters OccupancyGridParameters::defaults(GridKind kind, int image_width_px) {
  OccupancyGridParameters parameters;
  parameters.kind = kind;
  switch (kind) {
    case GridKind::cartesian:
      parameters.column_min = -10, parameters.column_max = 10, parameters.column_cell = 0.2;
      parameters.row_min = 0.5, parameters.row_max = 40.5, parameters.row_cell = 0.2;
      break;
    case GridKind::column_disparity:
      parameters.column_min = 0, parameters.column_max = image_width_px, parameters.column_cell = 4;
      parameters.row_min = 0, parameters.row_max = 128, parameters.row_cell = 0.5;
      parameters.principal_u_px = (image_width_px - 1) / 2.0;
      break;
    case GridKind::polar:
      parameters.column_min = -0.6, parameters.column_max = 0.6, parameters.column_cell = 0.01;
      parameters.row_min = 0.5, parameters.row_max = 40.5, parameters.row_cell = 0.2;
      break;
  }
  return parameters;
}

void OccupancyGridParameters::validate() const {
  if (!(column_cell > 0) || !std::isfinite(column_cell)) throw_invalid_parameter("column_cell", "> 0 (cell width)", column_cell);
  if (!(row_cell > 0) || !std::isfinite(row_cell)) throw_invalid_parameter("row_cell", "> 0 (cell depth)", row_cell);
  if (!(column_max > column_min) || !std::isfinite(column_max) || !std::isfinite(column_min))
    throw_invalid_parameter("column_max", "> column_min = " + number_text(column_min), column_max);
  if (!(row_max > row_min) || !std::isfinite(row_max) || !std::isfinite(row_min))
    throw_invalid_parameter("row_max", "> row_min = " + number_text(row_min), row_max);
  if ((column_max - column_min) / column_cell > 100000)
    throw_invalid_parameter("column_cell", ">= (column_max - column_min) / 100000", column_cell);
  if ((row_max - row_min) / row_cell > 100000) throw_invalid_parameter("row_cell", ">= (row_max - row_min) / 100000", row_cell);
  if (kind == GridKind::polar && (column_min < -kHalfPi || column_max > kHalfPi))
    throw_invalid_parameter(column_min < -kHalfPi ? "column_min" : "column_max", "an angle within [-pi/2, pi/2] rad",
                  column_min < -kHalfPi ? column_min : column_max);
  if (kind == GridKind::polar && row_min < 0) throw_invalid_parameter("row_min", ">= 0 (a range)", row_min);
  if (!(error_model.focal_px > 0)) throw_invalid_parameter("error_model.focal_px", "> 0", error_model.focal_px);
  if (!(error_model.baseline_m > 0)) throw_invalid_parameter("error_model.baseline_m", "> 0", error_model.baseline_m);
  if (!(error_model.disparity_sigma_px > 0))
    throw_invalid_parameter("error_model.disparity_sigma_px", "> 0", error_model.disparity_sigma_px);
  if (!(error_model.pixel_sigma_px > 0)) throw_invalid_parameter("error_model.pixel_sigma_px", "> 0", error_model.pixel_sigma_px);
  if (!(window_sigmas >= 1 && window_sigmas <= 6)) throw_invalid_parameter("window_sigmas", "in [1, 6]", window_sigmas);
  if (!(hit_probability_max > 0.5 && hit_probability_max < 1))
    throw_invalid_parameter("hit_probability_max", "in (0.5, 1)", hit_probability_max);
  if (!(miss_probability > 0 && miss_probability <= 0.5)) throw_invalid_parameter("miss_probability", "in (0, 0.5]", miss_probability);
  if (!(points_for_full_evidence > 0)) throw_invalid_parameter("points_for_full_evidence", "> 0", points_for_full_evidence);
  if (!(log_odds_min < 0)) throw_invalid_parameter("log_odds_min", "< 0", log_odds_min);
  if (!(log_odds_max > 0)) throw_invalid_parameter("log_odds_max", "> 0", log_odds_max);
  if (!(occupied_probability > 0.5 && occupied_probability < 1))
    throw_invalid_parameter("occupied_probability", "in (0.5, 1)", occupied_probability);
  if (min_cluster_cells < 1) throw_invalid_parameter("min_cluster_cells", ">= 1", min_cluster_cells);
  if (min_obstacle_points < 1) throw_invalid_parameter("min_obstacle_points", ">= 1", min_obstacle_points);
  if (!(min_depth_gap_m >= 0 && min_depth_gap_m <= 10))
    throw_invalid_parameter("min_depth_gap_m", "in [0, 10] m", min_depth_gap_m);
  if (min_column_gap_px < 0 || min_column_gap_px > 64)
    throw_invalid_parameter("min_column_gap_px", "in [0, 64] px", min_column_gap_px);
  if (max_range_step_columns_px < 0 || max_range_step_columns_px > 16)
    throw_invalid_parameter("max_range_step_columns_px", "in [0, 16] px (0 = off)", max_range_step_columns_px);
  if (!(min_concavity_px >= 0 && min_concavity_px <= 8))
    throw_invalid_parameter("min_concavity_px", "in [0, 8] px (0 = off)", min_concavity_px);
  if (threads < 1 || threads > 16) throw_invalid_parameter("threads", "in [1, 16]", threads);
}

int OccupancyGridParameters::columns() const {
  return static_cast<int>(std::ceil((column_max - column_min) / column_cell - 1e-9));
}
int OccupancyGridParameters::rows() const { return static_cast<int>(std::ceil((row_max - row_min) / row_cell - 1e-9)); }

OccupancyGrid::OccupancyGrid(const OccupancyGridParameters& parameters) : parameters_(parameters) {
  parameters_.validate();
  rows_ = parameters_.rows();
  columns_ = parameters_.columns();
  log_odds_ = GridMatrix::Zero(rows_, columns_);
  evidence_ = GridMatrix::Zero(rows_, columns_);
}

void OccupancyGrid::reset() {
  log_odds_.setZero();
  evidence_.setZero();
  clusters_.clear();
  obstacles_.clear();
}

float OccupancyGrid::probability(int row, int column) const {
  return 1.0f / (1.0f + std::exp(-log_odds_(row, column)));
}

bool OccupancyGrid::cell_of(double column_coordinate, double row_coordinate, int* row, int* column) const {
  const double c = std::floor((column_coordinate - parameters_.column_min) / parameters_.column_cell);
  const double r = std::floor((row_coordinate - parameters_.row_min) / parameters_.row_cell);
  if (!(c >= 0 && c < columns_ && r >= 0 && r < rows_)) return false;  // also rejects NaN
  *row = static_cast<int>(r);
  *column = static_cast<int>(c);
  return true;
}

Eigen::Vector2d OccupancyGrid::camera_xz_of(double column_coordinate, double row_coordinate) const {
  const StereoErrorModel& model = parameters_.error_model;
  switch (parameters_.kind) {
    case GridKind::cartesian: return {column_coordinate, row_coordinate};
    case GridKind::column_disparity: {
      if (!(row_coordinate > 0)) return {0.0, std::numeric_limits<double>::infinity()};
      const double z = model.focal_px * model.baseline_m / row_coordinate;
      return {(column_coordinate - parameters_.principal_u_px) * z / model.focal_px, z};
    }
    case GridKind::polar: return {row_coordinate * std::sin(column_coordinate), row_coordinate * std::cos(column_coordinate)};
  }
  return {0, 0};
}

Eigen::Vector2d OccupancyGrid::grid_coordinates_of(double x_m, double z_m) const {
  const StereoErrorModel& model = parameters_.error_model;
  switch (parameters_.kind) {
    case GridKind::cartesian: return {x_m, z_m};
    case GridKind::column_disparity:
      return {parameters_.principal_u_px + model.focal_px * x_m / z_m, model.focal_px * model.baseline_m / z_m};
    case GridKind::polar: return {std::atan2(x_m, z_m), std::hypot(x_m, z_m)};
  }
  return {0, 0};
}

Eigen::Vector2d OccupancyGrid::picture_plane_of(double column_coordinate, double row_coordinate) const {
  if (parameters_.kind == GridKind::column_disparity) return {column_coordinate, row_coordinate};
  return camera_xz_of(column_coordinate, row_coordinate);
}

GridGaussian OccupancyGrid::measurement_gaussian(const ObstaclePoint& point) const {
  const StereoErrorModel& model = parameters_.error_model;
  const double x = point.camera_m.x(), z = point.camera_m.z();
  GridGaussian gaussian;
  switch (parameters_.kind) {
    case GridKind::cartesian: {
      const double sigma_z = model.depth_sigma_m(z), sigma_x = model.lateral_sigma_m(z);
      const double slope = x / z;  // the ray's lateral slope: a disparity error moves x by slope * dz
      gaussian.mean = {x, z};
      gaussian.covariance << sigma_x * sigma_x + slope * slope * sigma_z * sigma_z, slope * sigma_z * sigma_z,
          slope * sigma_z * sigma_z, sigma_z * sigma_z;
      break;
    }
    case GridKind::column_disparity:
      gaussian.mean = {static_cast<double>(point.u_px), static_cast<double>(point.disparity_px)};
      gaussian.covariance << model.pixel_sigma_px * model.pixel_sigma_px, 0, 0,
          model.disparity_sigma_px * model.disparity_sigma_px;
      break;
    case GridKind::polar: {
      const double range = std::sqrt(x * x + z * z);
      const double theta = std::atan2(x, z), cos_theta = z / range;
      const double sigma_theta = model.pixel_sigma_px * cos_theta * cos_theta / model.focal_px;
      const double sigma_range = model.depth_sigma_m(z) / cos_theta;
      gaussian.mean = {theta, range};
      gaussian.covariance << sigma_theta * sigma_theta, 0, 0, sigma_range * sigma_range;
      break;
    }
  }
  return gaussian;
}

double OccupancyGrid::row_sigma_at(int row, int column) const {
  const StereoErrorModel& model = parameters_.error_model;
  const double a = parameters_.column_min + (column + 0.5) * parameters_.column_cell;
  const double b = parameters_.row_min + (row + 0.5) * parameters_.row_cell;
  switch (parameters_.kind) {
    case GridKind::cartesian: return model.depth_sigma_m(b);
    case GridKind::column_disparity: return model.disparity_sigma_px;
    case GridKind::polar: return model.depth_sigma_m(b * std::cos(a)) / std::cos(a);
  }
  return 0;
}

double OccupancyGrid::add_likelihood(const GridGaussian& gaussian, GridMatrix& evidence, ArmWork* work) const {
  const double k = parameters_.window_sigmas;
  const double mean_a = gaussian.mean(0), mean_b = gaussian.mean(1);
  const double var_a = gaussian.covariance(0, 0), cov_ab = gaussian.covariance(0, 1), var_b = gaussian.covariance(1, 1);
  const double sigma_b = std::sqrt(var_b);
  const double regression = cov_ab / var_b;  // E[a | b] = mean_a + regression (b - mean_b)
  const double sigma_a_given_b = std::sqrt(std::max(var_a - cov_ab * regression, 1e-30));
  const double b_low = mean_b - k * sigma_b, b_high = mean_b + k * sigma_b;
  const double a_cell = parameters_.column_cell, b_cell = parameters_.row_cell;
  const double a_min = parameters_.column_min, b_min = parameters_.row_min;
  uint64_t window_rows = 0, window_cells = 0;
  double mass = 0;
  int row_first = 0, row_last = -1;
  // Uncorrelated grids (column_disparity, polar): the column masses are the same on every row, so
  // they are computed once and the row loop is an outer product.
  const bool separable = cov_ab == 0;
  thread_local std::vector<double> column_masses;  // per thread: update() splits points over threads
  column_masses.clear();
  int separable_first = 0, separable_last = -1;
  if (separable && axis_window(mean_a - k * sigma_a_given_b, mean_a + k * sigma_a_given_b, a_min, a_cell, columns_,
                               &separable_first, &separable_last)) {
    const double a_low = mean_a - k * sigma_a_given_b, a_high = mean_a + k * sigma_a_given_b;
    double left_cdf = normal_cdf((std::max(a_low, a_min + separable_first * a_cell) - mean_a) / sigma_a_given_b);
    for (int column = separable_first; column <= separable_last; ++column) {
      const double right_cdf = normal_cdf((std::min(a_high, a_min + (column + 1) * a_cell) - mean_a) / sigma_a_given_b);
      column_masses.push_back(right_cdf - left_cdf);
      left_cdf = right_cdf;
    }
  }
  const bool any_column = !separable || !column_masses.empty();
  if (any_column && axis_window(b_low, b_high, b_min, b_cell, rows_, &row_first, &row_last)) {
    double lower_t = (std::max(b_low, b_min + row_first * b_cell) - mean_b) / sigma_b;
    double lower_cdf = normal_cdf(lower_t);
    for (int row = row_first; row <= row_last; ++row) {
      const double upper_t = (std::min(b_high, b_min + (row + 1) * b_cell) - mean_b) / sigma_b;
      const double upper_cdf = normal_cdf(upper_t);
      const double row_mass = upper_cdf - lower_cdf;
      ++window_rows;
      if (separable) {
        float* row_evidence = &evidence(row, separable_first);
        for (size_t i = 0; i < column_masses.size(); ++i) {
          const double cell_mass = row_mass * column_masses[i];
          row_evidence[i] += static_cast<float>(cell_mass);
          mass += cell_mass;
        }
        window_cells += column_masses.size();
      } else if (row_mass > 0) {
        // The row's conditional mean of b (truncated normal), then a | b on the columns.
        const double b_mean_in_row = mean_b + sigma_b * (normal_pdf(lower_t) - normal_pdf(upper_t)) / row_mass;
        const double a_mean = mean_a + regression * (b_mean_in_row - mean_b);
        const double a_low = a_mean - k * sigma_a_given_b, a_high = a_mean + k * sigma_a_given_b;
        int column_first = 0, column_last = -1;
        if (axis_window(a_low, a_high, a_min, a_cell, columns_, &column_first, &column_last)) {
          double left_cdf = normal_cdf((std::max(a_low, a_min + column_first * a_cell) - a_mean) / sigma_a_given_b);
          for (int column = column_first; column <= column_last; ++column) {
            const double right_cdf =
                normal_cdf((std::min(a_high, a_min + (column + 1) * a_cell) - a_mean) / sigma_a_given_b);
            const double cell_mass = row_mass * (right_cdf - left_cdf);
            evidence(row, column) += static_cast<float>(cell_mass);
            mass += cell_mass;
            left_cdf = right_cdf;
          }
          window_cells += static_cast<uint64_t>(column_last - column_first + 1);
        }
      }
      lower_t = upper_t;
      lower_cdf = upper_cdf;
    }
  }
  if (work != nullptr && separable) {
    work->scalar_ops += kOpsPerPoint + kOpsPerSeparableColumn * column_masses.size() +
                        kOpsPerSeparableRow * window_rows + kOpsPerSeparableCell * window_cells;
    work->memory_bytes += sizeof(ObstaclePoint) + 8 * window_cells;
  } else if (work != nullptr) {
    work->scalar_ops += kOpsPerPoint + kOpsPerWindowRow * window_rows + kOpsPerWindowCell * window_cells;
    work->memory_bytes += sizeof(ObstaclePoint) + 8 * window_cells;
  }
  return mass;
}

void OccupancyGrid::compensate_ego_motion(const EgoMotion& ego_motion) {
  const Eigen::Isometry3d& vehicle_from_camera = parameters_.vehicle_from_camera;
  const Eigen::Isometry3d previous_from_current_camera =
      vehicle_from_camera.inverse() * ego_motion.previous_from_current * vehicle_from_camera;
  GridMatrix warped = GridMatrix::Zero(rows_, columns_);
  // The polar grid's cell centres from each column's (sin a, cos a), taken once per column and not
  // per cell (the values camera_xz_of gives): two of a cell's four transcendental calls.
  const bool polar = parameters_.kind == GridKind::polar;
  std::vector<double> column_sin(polar ? static_cast<size_t>(columns_) : 0), column_cos(column_sin.size());
  for (size_t column = 0; column < column_sin.size(); ++column) {
    const double a = parameters_.column_min + (static_cast<double>(column) + 0.5) * parameters_.column_cell;
    column_sin[column] = std::sin(a);
    column_cos[column] = std::cos(a);
  }
  // The rows dealt over the threads in blocks (arm/fork_join.h), each thread writing its own rows:
  // the same grid with any thread count. Serial, it was a third of a driving stixel update.
  constexpr size_t kRowsPerBlock = 8;
  const int thread_count = std::clamp(rows_ / static_cast<int>(2 * kRowsPerBlock), 1, parameters_.threads);
  fork_join(thread_count, [&](int share) {
    for_each_dealt(static_cast<size_t>(rows_), kRowsPerBlock, share, thread_count, [&](size_t row_index) {
      const int row = static_cast<int>(row_index);
      const double b = parameters_.row_min + (row + 0.5) * parameters_.row_cell;
      for (int column = 0; column < columns_; ++column) {
        const Eigen::Vector2d xz =
            polar ? Eigen::Vector2d(b * column_sin[static_cast<size_t>(column)], b * column_cos[static_cast<size_t>(column)])
                  : camera_xz_of(parameters_.column_min + (column + 0.5) * parameters_.column_cell, b);
        if (!std::isfinite(xz(1))) {  // d = 0: at infinity, the motion does not move it
          warped(row, column) = log_odds_(row, column);
          continue;
        }
        const Eigen::Vector3d previous = previous_from_current_camera * Eigen::Vector3d(xz(0), 0.0, xz(1));
        if (parameters_.kind != GridKind::cartesian && !(previous.z() > 0)) continue;  // behind the camera
        const Eigen::Vector2d source = grid_coordinates_of(previous.x(), previous.z());
        int source_row = 0, source_column = 0;
        if (cell_of(source(0), source(1), &source_row, &source_column))
          warped(row, column) = log_odds_(source_row, source_column);
      }
    });
  });
  log_odds_.swap(warped);
  const uint64_t cells = static_cast<uint64_t>(rows_) * columns_;
  work_.scalar_ops += kOpsPerCellWarp * cells;
  work_.memory_bytes += 8 * cells;
}

void OccupancyGrid::update(const std::vector<ObstaclePoint>& points, const EgoMotion& ego_motion, GridDescription description) {
  work_ = ArmWork{};
  statistics_ = OccupancyGridStatistics{};
  statistics_.points_in = static_cast<int64_t>(points.size());
  statistics_.ego_motion_used = ego_motion.available;
  if (ego_motion.available) compensate_ego_motion(ego_motion);

  // This frame's evidence, the points dealt over the threads in blocks of kPointsPerBlock, block b to
  // thread b mod threads (fork_join.h; each with its own evidence matrix, summed in thread order: the
  // result does not depend on scheduling). Dealt, not cut in halves: a point's window grows with its range, and
  // a frame's points come in image rows, far objects first, so of two halves the first held most of
  // the work (bench/obstacles3d_bench, polar, candidates: 2 threads took as long as one).
  point_cells_.assign(points.size(), -1);
  point_row_means_.resize(points.size());
  point_row_sigmas_.resize(points.size());
  const int thread_count =
      static_cast<int>(std::min<size_t>(static_cast<size_t>(parameters_.threads), std::max<size_t>(1, points.size() / 4096)));
  std::vector<GridMatrix> partial(static_cast<size_t>(thread_count));
  std::vector<ArmWork> partial_work(static_cast<size_t>(thread_count));
  std::vector<int64_t> used(static_cast<size_t>(thread_count), 0), clipped(used), rejected(used);
  auto accumulate = [&](int chunk) {
    GridMatrix& evidence = partial[static_cast<size_t>(chunk)];
    evidence = GridMatrix::Zero(rows_, columns_);
    ArmWork work;  // counters in locals until the end (fork_join.h)
    int64_t used_here = 0, clipped_here = 0, rejected_here = 0;
    constexpr size_t kPointsPerBlock = 256;
    for_each_dealt(points.size(), kPointsPerBlock, chunk, thread_count, [&](size_t i) {
      const ObstaclePoint& point = points[i];
      if (!point.camera_m.allFinite() || !(point.disparity_px > 0) || !(point.camera_m.z() > 0)) {
        ++rejected_here;
        return;
      }
      const GridGaussian gaussian = measurement_gaussian(point);
      int row = 0, column = 0;
      if (!cell_of(gaussian.mean(0), gaussian.mean(1), &row, &column)) {
        ++clipped_here;
        return;
      }
      point_cells_[i] = row * columns_ + column;
      point_row_means_[i] = gaussian.mean(1);
      point_row_sigmas_[i] = std::sqrt(gaussian.covariance(1, 1));
      ++used_here;
      add_likelihood(gaussian, evidence, &work);
    });
    partial_work[static_cast<size_t>(chunk)] = work;
    used[static_cast<size_t>(chunk)] = used_here;
    clipped[static_cast<size_t>(chunk)] = clipped_here;
    rejected[static_cast<size_t>(chunk)] = rejected_here;
  };
  fork_join(thread_count, accumulate);
  evidence_ = partial[0];
  for (int chunk = 1; chunk < thread_count; ++chunk) evidence_ += partial[static_cast<size_t>(chunk)];
  for (int chunk = 0; chunk < thread_count; ++chunk) {
    work_ += partial_work[static_cast<size_t>(chunk)];
    statistics_.points_used += used[static_cast<size_t>(chunk)];
    statistics_.points_clipped += clipped[static_cast<size_t>(chunk)];
    statistics_.points_rejected += rejected[static_cast<size_t>(chunk)];
  }

  // Fusion in log-odds with the inverse sensor model p(D).
  const float miss = static_cast<float>(parameters_.miss_probability);
  const float hit_span = static_cast<float>(parameters_.hit_probability_max - parameters_.miss_probability);
  const float inverse_full = static_cast<float>(1.0 / parameters_.points_for_full_evidence);
  const float low = static_cast<float>(parameters_.log_odds_min), high = static_cast<float>(parameters_.log_odds_max);
  const float miss_log_odds = std::log(miss / (1 - miss));
  for (int row = 0; row < rows_; ++row) {
    for (int column = 0; column < columns_; ++column) {
      const float d = evidence_(row, column);
      float step = miss_log_odds;
      if (d > 0) {
        const float p = miss + hit_span * (1 - std::exp(-d * inverse_full));
        step = std::log(p / (1 - p));
      }
      log_odds_(row, column) = std::clamp(log_odds_(row, column) + step, low, high);
    }
  }
  const uint64_t cells = static_cast<uint64_t>(rows_) * columns_;
  work_.scalar_ops += kOpsPerCellUpdate * cells;
  work_.memory_bytes += 12 * cells;

  if (description == GridDescription::clusters_and_obstacles) {
    cluster_and_describe(points);
  } else {
    clusters_.clear();
    obstacles_.clear();
  }

  std::ostringstream status;
  status << grid_kind_name(parameters_.kind) << " grid " << columns_ << "x" << rows_ << ": ";
  if (points.empty()) status << "empty cloud; ";
  status << statistics_.points_used << " of " << statistics_.points_in << " points used";
  if (statistics_.points_clipped > 0) status << ", " << statistics_.points_clipped << " beyond the grid bounds (clipped)";
  if (statistics_.points_rejected > 0)
    status << ", " << statistics_.points_rejected << " rejected (non-finite or disparity <= 0)";
  if (description == GridDescription::clusters_and_obstacles)
    status << "; " << clusters_.size() << " clusters, " << obstacles_.size() << " obstacles";
  else
    status << "; occupancy only (no clusters described)";
  if (statistics_.clusters_without_points > 0)
    status << " (" << statistics_.clusters_without_points << " held by memory only)";
  status << (ego_motion.available ? "; ego-motion compensated" : "; static camera assumed (no ego-motion)");
  status_ = status.str();
}

void OccupancyGrid::cluster_and_describe(const std::vector<ObstaclePoint>& points) {
  clusters_.clear();
  obstacles_.clear();
  const float occupied_log_odds =
      static_cast<float>(std::log(parameters_.occupied_probability / (1 - parameters_.occupied_probability)));
  std::vector<uint8_t> mask(static_cast<size_t>(rows_) * columns_);
  for (int row = 0; row < rows_; ++row)
    for (int column = 0; column < columns_; ++column)
      mask[static_cast<size_t>(row) * columns_ + column] = log_odds_(row, column) > occupied_log_odds ? 1 : 0;
  std::vector<int> labels;
  std::vector<std::vector<int>> components =
      connected_components_8(mask, rows_, columns_, parameters_.min_cluster_cells, &labels, &work_);

  // Obstacles: within each cluster, the 8-connected groups of the cells holding this frame's points
  // (their means). The likelihood's window spreads an object over +-3 sigma_Z in range (3.6 m at
  // 30 m), so objects on one bearing a few metres apart share a cluster; the points themselves stay
  // at their means, so the groups split them again. Groups under min_obstacle_points are dropped.
  std::vector<int> cell_points(static_cast<size_t>(rows_) * columns_, 0);
  for (int cell : point_cells_)
    if (cell >= 0) ++cell_points[static_cast<size_t>(cell)];
  std::vector<uint8_t> held(cell_points.size(), 0);
  for (size_t cell = 0; cell < held.size(); ++cell) held[cell] = labels[cell] >= 0 && cell_points[cell] > 0 ? 1 : 0;
  std::vector<int> group_of_cell;
  const std::vector<std::vector<int>> groups = connected_components_8(held, rows_, columns_, 1, &group_of_cell, &work_);
  std::vector<std::vector<int>> group_points(groups.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const int cell = point_cells_[i];
    if (cell >= 0 && group_of_cell[static_cast<size_t>(cell)] >= 0)
      group_points[static_cast<size_t>(group_of_cell[static_cast<size_t>(cell)])].push_back(static_cast<int>(i));
  }
  std::vector<std::vector<int>> groups_of_cluster(components.size());
  for (size_t group = 0; group < groups.size(); ++group)
    groups_of_cluster[static_cast<size_t>(labels[static_cast<size_t>(groups[group].front())])].push_back(static_cast<int>(group));
  work_.scalar_ops += kOpsPerPointDescribe * points.size();
  work_.memory_bytes += sizeof(ObstaclePoint) * points.size();

  // Each group's points along its bearings: the rows of highest evidence D along a column (the
  // modes of the point density smoothed by the likelihood, Badino's obstacle position along a
  // column) are where objects are. Every cell holding points climbs along its column to the mode
  // above it (the nearest local maximum of D uphill), so a column crossing two objects at different
  // ranges (a pedestrian 1.5 m behind a parked car on one bearing) has two modes, not one. D is summed
  // over the column and its two neighbours: a thin pole at a board's end fills one column with more
  // smear than pole points, and the board beside it marks the depth.
  auto row_evidence = [&](int row, int column) {
    double sum = evidence_(row, column);
    if (column > 0) sum += evidence_(row, column - 1);
    if (column + 1 < columns_) sum += evidence_(row, column + 1);
    return sum;
  };
  std::vector<int> mode_row_of_cell(static_cast<size_t>(rows_) * columns_, -1);
  std::vector<int> climb_path;
  uint64_t climb_steps = 0;
  auto mode_row_of = [&](int row, int column) {
    climb_path.clear();
    int current = row;
    double value = row_evidence(current, column);
    while (mode_row_of_cell[static_cast<size_t>(current) * columns_ + column] < 0) {
      climb_path.push_back(current);
      int best = current;
      double best_value = value;
      for (int next : {current - 1, current + 1}) {
        if (next < 0 || next >= rows_) continue;
        const double next_value = row_evidence(next, column);
        if (next_value > best_value) best = next, best_value = next_value;
      }
      ++climb_steps;
      if (best == current) break;  // a local maximum (strictly uphill steps: the climb ends)
      current = best;
      value = best_value;
    }
    const int mode = mode_row_of_cell[static_cast<size_t>(current) * columns_ + column] >= 0
                         ? mode_row_of_cell[static_cast<size_t>(current) * columns_ + column]
                         : current;
    for (int visited : climb_path) mode_row_of_cell[static_cast<size_t>(visited) * columns_ + column] = mode;
    return mode;
  };
  // The modes of a group are joined into objects: two modes in the same or neighbouring columns whose
  // rows differ by at most one likelihood window (window_sigmas of the row sigma at the farther mode,
  // plus a cell) are one surface; a larger jump in depth between neighbouring bearings, or a second
  // mode further along a column, separates two objects at different ranges (a single obstacle for
  // both has its centre between them, in neither's gate). Points further than their own window
  // (window_sigmas of their row sigma, plus half a cell) from their cell's mode are mismatches
  // smeared along the ray (a thin pole's or a board border's disparity taken from the background,
  // 2-5 m behind at 17 m) and do not move the obstacle's box.
  struct Mode {
    int row, column, parent;
  };
  // A polar or column/disparity column is a ray: its modes are objects one behind the other. A
  // Cartesian column (constant x) is not: a wall, a berm or a car's side running in depth lies along
  // it as a ridge of evidence whose local maxima are not objects (mining seed 1, first 68 frames:
  // the split gave 279 instead of 243 Cartesian false positives along the berm), so the Cartesian
  // grid keeps one mode per column (the group's row of highest evidence) and one object per group.
  const bool columns_are_rays = parameters_.kind != GridKind::cartesian;
  std::vector<int> column_mode_row(static_cast<size_t>(columns_), -1);
  std::vector<double> column_mode_evidence(static_cast<size_t>(columns_), 0.0);
  uint64_t mode_pairs = 0, range_comparisons = 0;
  // Within a window of the farther mode (its row sigma; the column/disparity grid's row is
  // disparity, the farther mode the smaller), or closer in range than min_depth_gap_m (one body's
  // own depth: a car's bumper and windscreen, a pedestrian's front and back, where near points'
  // windows are centimetres).
  auto same_object = [&](int row_a, int column_a, int row_b, int column_b) {
    const bool b_farther = parameters_.kind == GridKind::column_disparity ? row_b < row_a : row_b > row_a;
    const double window = parameters_.window_sigmas * (b_farther ? row_sigma_at(row_b, column_b) : row_sigma_at(row_a, column_a)) +
                          parameters_.row_cell;
    if (std::abs(row_a - row_b) * parameters_.row_cell <= window) return true;
    ++range_comparisons;
    auto range_of = [&](int row, int column) {
      return camera_xz_of(parameters_.column_min + (column + 0.5) * parameters_.column_cell,
                          parameters_.row_min + (row + 0.5) * parameters_.row_cell)
          .norm();
    };
    return std::abs(range_of(row_a, column_a) - range_of(row_b, column_b)) <= parameters_.min_depth_gap_m;
  };
  std::vector<int> mode_of_mode_cell(static_cast<size_t>(rows_) * columns_, -1);
  std::vector<std::vector<int>> group_objects_inliers;  // per object of all groups
  std::vector<int> first_object_of_group(groups.size() + 1, 0);
  for (size_t group = 0; group < groups.size(); ++group) {
    first_object_of_group[group] = static_cast<int>(group_objects_inliers.size());
    std::vector<Mode> modes;
    if (!columns_are_rays) {
      // Cartesian: one mode per column, the group's row of highest evidence, and one object.
      for (int cell : groups[group]) {
        const int row = cell / columns_, column = cell % columns_;
        int& mode_row = column_mode_row[static_cast<size_t>(column)];
        const double value = row_evidence(row, column);
        if (mode_row < 0 || value > column_mode_evidence[static_cast<size_t>(column)]) {
          mode_row = row;
          column_mode_evidence[static_cast<size_t>(column)] = value;
        }
      }
      for (int cell : groups[group])
        mode_row_of_cell[static_cast<size_t>(cell)] = column_mode_row[static_cast<size_t>(cell % columns_)];
      for (int cell : groups[group]) column_mode_row[static_cast<size_t>(cell % columns_)] = -1;
    }
    for (int cell : groups[group]) {
      const int row = cell / columns_, column = cell % columns_;
      const int mode_row = columns_are_rays ? mode_row_of(row, column) : mode_row_of_cell[static_cast<size_t>(cell)];
      int& mode_index = mode_of_mode_cell[static_cast<size_t>(mode_row) * columns_ + column];
      if (mode_index < 0) {
        mode_index = static_cast<int>(modes.size());
        modes.push_back({mode_row, column, mode_index});
      }
    }
    auto root_of = [&](int index) {
      while (modes[static_cast<size_t>(index)].parent != index) {
        Mode& mode = modes[static_cast<size_t>(index)];
        mode.parent = modes[static_cast<size_t>(mode.parent)].parent;
        index = mode.parent;
      }
      return index;
    };
    // Rays: pairs within one column of each other, the modes in column order, each against the
    // following ones up to the next column. Cartesian: one object.
    if (!columns_are_rays) {
      for (Mode& mode : modes) mode.parent = 0;
    }
    std::vector<int> by_column(columns_are_rays ? modes.size() : 0);
    for (size_t i = 0; i < by_column.size(); ++i) by_column[i] = static_cast<int>(i);
    std::stable_sort(by_column.begin(), by_column.end(),
                     [&](int p, int q) { return modes[static_cast<size_t>(p)].column < modes[static_cast<size_t>(q)].column; });
    for (size_t i = 0; i < by_column.size(); ++i) {
      const size_t a = static_cast<size_t>(by_column[i]);
      for (size_t j = i + 1; j < by_column.size() && modes[static_cast<size_t>(by_column[j])].column <= modes[a].column + 1; ++j) {
        const size_t b = static_cast<size_t>(by_column[j]);
        ++mode_pairs;
        if (!same_object(modes[a].row, modes[a].column, modes[b].row, modes[b].column)) continue;
        const int root_a = root_of(static_cast<int>(a)), root_b = root_of(static_cast<int>(b));
        if (root_a != root_b) modes[static_cast<size_t>(std::max(root_a, root_b))].parent = std::min(root_a, root_b);
      }
    }
    std::vector<int> object_of_root(modes.size(), -1);
    for (int index : group_points[group]) {
      const int cell = point_cells_[static_cast<size_t>(index)];
      const int column = cell % columns_;
      const int mode_row = mode_row_of_cell[static_cast<size_t>(cell)];
      const int mode_index = mode_of_mode_cell[static_cast<size_t>(mode_row) * columns_ + column];
      const double mode_b = parameters_.row_min + (mode_row + 0.5) * parameters_.row_cell;
      if (std::abs(point_row_means_[static_cast<size_t>(index)] - mode_b) >
          parameters_.window_sigmas * point_row_sigmas_[static_cast<size_t>(index)] + 0.5 * parameters_.row_cell)
        continue;
      int& object = object_of_root[static_cast<size_t>(root_of(mode_index))];
      if (object < 0) {
        object = static_cast<int>(group_objects_inliers.size());
        group_objects_inliers.emplace_back();
      }
      group_objects_inliers[static_cast<size_t>(object)].push_back(index);
    }
    for (const Mode& mode : modes) mode_of_mode_cell[static_cast<size_t>(mode.row) * columns_ + mode.column] = -1;
  }
  first_object_of_group[groups.size()] = static_cast<int>(group_objects_inliers.size());
  size_t group_cells = 0;
  for (const std::vector<int>& group : groups) group_cells += group.size();
  work_.scalar_ops += kOpsPerPointInlier * points.size() + kOpsPerGroupCellMode * group_cells +
                      kOpsPerClimbStep * climb_steps + kOpsPerModePair * mode_pairs +
                      kOpsPerRangeComparison * range_comparisons;

  for (size_t index = 0; index < components.size(); ++index) {
    GridCluster cluster;
    cluster.cells = std::move(components[index]);
    std::vector<Eigen::Vector2d> corners;
    corners.reserve(cluster.cells.size() * 4);
    // A corner shared by four cells of the cluster lies inside their union, so it cannot be a hull
    // vertex: only the other corners go to the gift wrapping (n ~ the perimeter, not 4 x the area).
    auto member = [&](int row, int column) {
      return row >= 0 && row < rows_ && column >= 0 && column < columns_ &&
             labels[static_cast<size_t>(row) * columns_ + column] == static_cast<int>(index);
    };
    for (int cell : cluster.cells) {
      const int row = cell / columns_, column = cell % columns_;
      for (int corner = 0; corner < 4; ++corner) {
        const int corner_row = row + (corner >> 1), corner_column = column + (corner & 1);
        if (member(corner_row - 1, corner_column - 1) && member(corner_row - 1, corner_column) &&
            member(corner_row, corner_column - 1) && member(corner_row, corner_column))
          continue;
        const double a = parameters_.column_min + (column + (corner & 1)) * parameters_.column_cell;
        const double b = parameters_.row_min + (row + (corner >> 1)) * parameters_.row_cell;
        corners.push_back(picture_plane_of(a, b));
      }
    }
    work_.scalar_ops += kOpsPerCornerTest * 4 * cluster.cells.size();
    cluster.hull = gift_wrapping_hull(corners, &work_);
    for (int group : groups_of_cluster[index]) {
      cluster.point_count += static_cast<int>(group_points[static_cast<size_t>(group)].size());
      for (int object = first_object_of_group[static_cast<size_t>(group)]; object < first_object_of_group[static_cast<size_t>(group) + 1];
           ++object) {
        const std::vector<int>& inliers = group_objects_inliers[static_cast<size_t>(object)];
        if (static_cast<int>(inliers.size()) < parameters_.min_obstacle_points) continue;
        for (const std::vector<int>& members : split_object(points, inliers, parameters_, &work_)) {
          if (static_cast<int>(members.size()) < parameters_.min_obstacle_points) continue;
          if (cluster.obstacle_count == 0) cluster.obstacle_index = static_cast<int>(obstacles_.size());
          ++cluster.obstacle_count;
          obstacles_.push_back(obstacle_from_points(points, members, static_cast<int>(obstacles_.size()), &work_));
        }
      }
    }
    if (cluster.obstacle_count == 0) ++statistics_.clusters_without_points;
    clusters_.push_back(std::move(cluster));
  }
}

std::vector<Eigen::Vector2d> gift_wrapping_hull(const std::vector<Eigen::Vector2d>& points, ArmWork* work) {
  std::vector<Eigen::Vector2d> hull;
  if (points.empty()) return hull;
  double scale = 0;
  for (const Eigen::Vector2d& point : points) scale = std::max(scale, point.cwiseAbs().maxCoeff());
  // Collinearity tolerance: a cross product is a product of two coordinate differences.
  const double tolerance = 1e-12 * std::max(1.0, scale * scale);
  auto same = [&](const Eigen::Vector2d& p, const Eigen::Vector2d& q) { return (p - q).cwiseAbs().maxCoeff() <= 1e-12 * std::max(1.0, scale); };
  size_t start = 0;
  for (size_t i = 1; i < points.size(); ++i) {
    const Eigen::Vector2d& p = points[i];
    const Eigen::Vector2d& s = points[start];
    if (p.y() < s.y() || (p.y() == s.y() && p.x() < s.x())) start = i;
  }
  size_t current = start;
  uint64_t examined = 0;
  for (size_t step = 0; step <= points.size(); ++step) {
    hull.push_back(points[current]);
    // The next vertex: the point with every other point on its left (counter-clockwise), the
    // farthest among collinear candidates so that points inside an edge are skipped.
    size_t candidate = points.size();
    for (size_t i = 0; i < points.size(); ++i) {
      ++examined;
      if (same(points[i], points[current])) continue;
      if (candidate == points.size()) {
        candidate = i;
        continue;
      }
      const Eigen::Vector2d to_candidate = points[candidate] - points[current];
      const Eigen::Vector2d to_point = points[i] - points[current];
      const double cross = to_candidate.x() * to_point.y() - to_candidate.y() * to_point.x();
      if (cross < -tolerance || (std::abs(cross) <= tolerance && to_point.squaredNorm() > to_candidate.squaredNorm()))
        candidate = i;
    }
    if (candidate == points.size()) break;                 // every point equals the first: one vertex
    if (same(points[candidate], points[start])) break;     // closed
    current = candidate;
  }
  if (work != nullptr) {
    work->scalar_ops += kOpsPerHullStep * examined;
    work->memory_bytes += 16 * examined;
  }
  return hull;
}

std::vector<std::vector<int>> connected_components_8(const std::vector<uint8_t>& mask, int rows, int columns,
                                                     int min_cells, std::vector<int>* labels, ArmWork* work) {
  const size_t cells = static_cast<size_t>(rows) * static_cast<size_t>(columns);
  std::vector<int> local_labels;
  std::vector<int>& label = labels != nullptr ? *labels : local_labels;
  label.assign(cells, -1);
  std::vector<int> visited(cells, 0);
  std::vector<std::vector<int>> components;
  std::vector<int> stack;
  uint64_t member_cells = 0;
  for (size_t seed = 0; seed < cells; ++seed) {
    if (mask[seed] == 0 || visited[seed] != 0) continue;
    std::vector<int> component;
    visited[seed] = 1;
    stack.push_back(static_cast<int>(seed));
    while (!stack.empty()) {
      const int cell = stack.back();
      stack.pop_back();
      component.push_back(cell);
      const int row = cell / columns, column = cell % columns;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int r = row + dr, c = column + dc;
          if ((dr == 0 && dc == 0) || r < 0 || r >= rows || c < 0 || c >= columns) continue;
          const size_t neighbour = static_cast<size_t>(r) * columns + c;
          if (mask[neighbour] != 0 && visited[neighbour] == 0) {
            visited[neighbour] = 1;
            stack.push_back(static_cast<int>(neighbour));
          }
        }
      }
    }
    member_cells += component.size();
    if (static_cast<int>(component.size()) < min_cells) continue;
    std::sort(component.begin(), component.end());
    for (int cell : component) label[static_cast<size_t>(cell)] = static_cast<int>(components.size());
    components.push_back(std::move(component));
  }
  if (work != nullptr) {
    work->scalar_ops += kOpsPerCellCluster * cells + kOpsPerMemberCell * member_cells;
    work->memory_bytes += cells;
  }
  return components;
}

namespace {
// The smallest and largest left-image column (u_px) of the selected points (indices not empty).
std::pair<int, int> column_span_of(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices) {
  int u_min = std::numeric_limits<int>::max(), u_max = std::numeric_limits<int>::min();
  for (int index : indices) {
    const int u = points[static_cast<size_t>(index)].u_px;
    u_min = std::min(u_min, u);
    u_max = std::max(u_max, u);
  }
  return {u_min, u_max};
}

// The profiles of the occlusion and concavity splits: the median of value(point) over the selected
// points of each left-image column u_min .. u_min + span - 1 (a counting sort by column, then a
// selection per column); `none` for a column with fewer than min_points points.
constexpr int kMinPointsPerColumn = 3;  // the occlusion split: a column's median from fewer is noise
// The concavity split: a column's median disparity from fewer points follows the matcher's streaks.
// SGM aggregates along image paths, so its errors are correlated along rows, and on a surface seen
// at a grazing angle it leaves fronto-parallel terraces (plateaus of 10-20 columns, 0.5-1 px steps
// between them): each step followed by a plateau is a concavity. A low surface 0.2-0.6 m above the
// terrain fit at 15-30 m (the mining scene's berm along the road) holds 4-8 points per column, and
// with 3 its profile was cut 57 times in 12 frames of bench/obstacles3d_eval (mining seed 1, polar:
// the false positives along it 231 -> 317 in 100 frames, main -> the split); with 10, 5 of those
// cuts remain (231 -> 247). A standing object's columns hold dozens (a car's side or a pedestrian at
// 15 m: 40-60), the median spanning many rows' streaks.
constexpr int kMinPointsPerConcavityColumn = 10;
// The range-step split: each side of a step keeps at least this many measured columns, so the
// silhouette of one object, whose one or two border columns mix its range with the background's,
// is not cut off as an object of its own.
constexpr int kMinStepSideColumns = 3;
// The range-step split: a step must also exceed this many disparity sigmas (1.25 px at 0.25 px):
// SGM leaves a surface seen at a grazing angle as fronto-parallel terraces with steps of up to
// 1 px (see kMinPointsPerConcavityColumn), 2 m of depth at 9 px, beyond the window there.
constexpr double kMinStepSigmas = 5.0;
// The fewest points a part needs for each cut to be tried: the step split's measured columns on
// both sides, the concavity split's three columns (two sides and the dip).
constexpr size_t kMinRangeStepPoints = 2 * kMinStepSideColumns * kMinPointsPerConcavityColumn;
constexpr size_t kMinConcavityPoints = 3 * kMinPointsPerConcavityColumn;
template <typename Value>
std::vector<float> column_medians(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices, int u_min, size_t span,
                                  int min_points, float none, Value value) {
  std::vector<int> first(span + 1, 0);
  for (int index : indices) ++first[static_cast<size_t>(points[static_cast<size_t>(index)].u_px - u_min) + 1];
  for (size_t column = 0; column < span; ++column) first[column + 1] += first[column];
  std::vector<float> values(indices.size());
  std::vector<int> next(first.begin(), first.end() - 1);
  for (int index : indices) {
    const ObstaclePoint& point = points[static_cast<size_t>(index)];
    values[static_cast<size_t>(next[static_cast<size_t>(point.u_px - u_min)]++)] = value(point);
  }
  std::vector<float> profile(span, none);
  for (size_t column = 0; column < span; ++column) {
    const int count = first[column + 1] - first[column];
    if (count < min_points) continue;
    auto begin = values.begin() + first[column], middle = begin + count / 2;
    std::nth_element(begin, middle, begin + count);
    profile[column] = *middle;
  }
  return profile;
}

// The profile of the range-step and concavity splits: the median disparity of each left-image
// column holding at least kMinPointsPerConcavityColumn of the points, in increasing column order;
// span = the columns from the points' smallest to largest u (indices not empty). A cut at a column
// leaves each side's columns whole, so a piece's profile is a run of its part's.
struct DisparityProfile {
  size_t span = 0;
  std::vector<int> u;    // absolute left-image columns
  std::vector<float> d;  // their median disparity
};
DisparityProfile disparity_profile(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices) {
  DisparityProfile profile;
  const auto [u_min, u_max] = column_span_of(points, indices);
  profile.span = static_cast<size_t>(u_max - u_min) + 1;
  // 0: fewer than kMinPointsPerConcavityColumn points (disparities are > 0).
  const std::vector<float> medians = column_medians(points, indices, u_min, profile.span, kMinPointsPerConcavityColumn, 0.0f,
                                                    [](const ObstaclePoint& point) { return point.disparity_px; });
  for (size_t column = 0; column < profile.span; ++column) {
    if (medians[column] <= 0) continue;
    profile.u.push_back(u_min + static_cast<int>(column));
    profile.d.push_back(medians[column]);
  }
  return profile;
}

// The range-step split's rule (split_at_range_step) on the profile's measured columns [first, last):
// the last column of the left part, -1 for no cut.
int range_step_cut(const DisparityProfile& profile, size_t first, size_t last, const StereoErrorModel& error_model, double window_sigmas,
                   double row_cell_m, double min_depth_gap_m, int max_step_columns_px) {
  const std::vector<int>& profile_u = profile.u;
  const std::vector<float>& profile_d = profile.d;
  if (last - first < 2 * static_cast<size_t>(kMinStepSideColumns)) return -1;
  // The largest jump between a column a and a column b at most max_step_columns_px to its right
  // (the columns in between are the matcher's mix of the two surfaces), each side keeping
  // kMinStepSideColumns measured columns: beyond a window in depth at the farther one, and beyond
  // kMinStepSigmas disparity sigmas (the matcher's terraces on one surface step by up to 1 px).
  const double focal_baseline = error_model.focal_px * error_model.baseline_m;
  const double min_step_px = kMinStepSigmas * error_model.disparity_sigma_px;
  size_t best_a = last, best_b = last;
  double best_excess_m = 0;
  for (size_t a = first + kMinStepSideColumns - 1; a + kMinStepSideColumns < last; ++a) {
    for (size_t b = a + 1; b + kMinStepSideColumns <= last && profile_u[b] - profile_u[a] <= max_step_columns_px; ++b) {
      if (std::abs(profile_d[a] - profile_d[b]) <= min_step_px) continue;
      const double near_m = focal_baseline / std::max(profile_d[a], profile_d[b]);
      const double far_m = focal_baseline / std::min(profile_d[a], profile_d[b]);
      const double threshold_m = std::max(window_sigmas * error_model.depth_sigma_m(far_m) + row_cell_m, min_depth_gap_m);
      const double excess_m = far_m - near_m - threshold_m;
      if (excess_m > best_excess_m) best_excess_m = excess_m, best_a = a, best_b = b;
    }
  }
  if (best_a == last) return -1;
  // The cut: after the column of the largest change between consecutive measured columns in [a, b].
  size_t last_left = best_a;
  for (size_t k = best_a + 1; k < best_b; ++k)
    if (std::abs(profile_d[k + 1] - profile_d[k]) > std::abs(profile_d[last_left + 1] - profile_d[last_left])) last_left = k;
  return profile_u[last_left];
}

// The concavity split's rule (split_at_concavity) on the profile's measured columns [first, last):
// the last column of the left part, -1 for no cut.
int concavity_cut(const DisparityProfile& profile, size_t first, size_t last, const StereoErrorModel& error_model, double min_concavity_px,
                  double min_depth_gap_m) {
  const std::vector<int>& profile_u = profile.u;
  const std::vector<float>& profile_d = profile.d;
  // The concave envelope: the upper hull of the profile's (u, d) points (Andrew's monotone chain;
  // the points come sorted by u). A hull vertex b stays when it lies strictly above the chord from
  // the previous vertex a to the next point k.
  std::vector<size_t> hull;
  for (size_t k = first; k < last; ++k) {
    while (hull.size() >= 2) {
      const size_t a = hull[hull.size() - 2], b = hull.back();
      const double cross = static_cast<double>(profile_u[b] - profile_u[a]) * (profile_d[k] - profile_d[a]) -
                           static_cast<double>(profile_d[b] - profile_d[a]) * (profile_u[k] - profile_u[a]);
      if (cross < 0) break;
      hull.pop_back();
    }
    hull.push_back(k);
  }
  // Each column's depth under the envelope, in disparity and in metres along its ray; the deepest
  // column beyond both thresholds (by its excess in pixels) is where two objects meet.
  const double focal_baseline = error_model.focal_px * error_model.baseline_m;
  size_t deepest = last;
  double best_excess_px = 0;
  size_t edge = 0;
  for (size_t k = first + 1; k + 1 < last; ++k) {
    while (edge + 2 < hull.size() && hull[edge + 1] <= k) ++edge;
    const size_t a = hull[edge], b = hull[edge + 1];
    if (k <= a || k >= b) continue;  // a hull vertex: on the envelope
    const double chord_px = profile_d[a] + (profile_d[b] - profile_d[a]) * static_cast<double>(profile_u[k] - profile_u[a]) /
                                               static_cast<double>(profile_u[b] - profile_u[a]);
    const double excess_px = chord_px - profile_d[k] - min_concavity_px;
    if (excess_px <= best_excess_px) continue;
    if (focal_baseline / profile_d[k] - focal_baseline / chord_px <= min_depth_gap_m) continue;  // within one body's depth
    best_excess_px = excess_px;
    deepest = k;
  }
  if (deepest == last) return -1;
  // The deepest column goes with the side whose neighbouring column is nearer to it in disparity
  // (the surface it belongs to).
  const bool with_left = std::abs(profile_d[deepest - 1] - profile_d[deepest]) <= std::abs(profile_d[deepest + 1] - profile_d[deepest]);
  return with_left ? profile_u[deepest] : profile_u[deepest - 1];
}

// The two parts of a cut: the points in columns up to last_left_u and those after, each in the order
// of `indices`.
std::vector<std::vector<int>> cut_after_column(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices, int last_left_u) {
  std::vector<std::vector<int>> parts(2);
  for (int index : indices) parts[points[static_cast<size_t>(index)].u_px <= last_left_u ? 0 : 1].push_back(index);
  return parts;
}
}  // namespace

std::vector<std::vector<int>> split_at_column_gaps(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                   int min_column_gap_px, ArmWork* work) {
  if (min_column_gap_px <= 0 || indices.size() < 2) return {indices};
  const auto [u_min, u_max] = column_span_of(points, indices);
  const size_t span = static_cast<size_t>(u_max - u_min) + 1;
  std::vector<int> part_of_column(span, -1);  // -1: no point; first a mark (0), then the part
  for (int index : indices) part_of_column[static_cast<size_t>(points[static_cast<size_t>(index)].u_px - u_min)] = 0;
  int part = 0;
  size_t previous = 0;  // the last column holding a point (column 0 holds one: u_min)
  for (size_t column = 0; column < span; ++column) {
    if (part_of_column[column] < 0) continue;
    if (column > previous + static_cast<size_t>(min_column_gap_px)) ++part;  // column - previous - 1 empty columns
    part_of_column[column] = part;
    previous = column;
  }
  if (work != nullptr) {
    work->scalar_ops += 4 * indices.size() + 2 * span;
    work->memory_bytes += 2 * indices.size() + 5 * span;
  }
  if (part == 0) return {indices};
  std::vector<std::vector<int>> parts(static_cast<size_t>(part) + 1);
  for (int index : indices)
    parts[static_cast<size_t>(part_of_column[static_cast<size_t>(points[static_cast<size_t>(index)].u_px - u_min)])].push_back(index);
  return parts;
}

std::vector<std::vector<int>> split_at_range_peak(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                  const StereoErrorModel& error_model, double window_sigmas, double row_cell_m,
                                                  double min_depth_gap_m, ArmWork* work) {
  if (indices.size() < 2 * kMinPointsPerColumn) return {indices};
  const auto [u_min, u_max] = column_span_of(points, indices);
  const size_t span = static_cast<size_t>(u_max - u_min) + 1;
  const float kNone = std::numeric_limits<float>::infinity();
  // Median range per column, +inf: fewer than kMinPointsPerColumn points.
  const std::vector<float> profile =
      column_medians(points, indices, u_min, span, kMinPointsPerColumn, kNone,
                     [](const ObstaclePoint& point) { return static_cast<float>(std::hypot(point.camera_m.x(), point.camera_m.z())); });
  // Prefix and suffix minima of the profile; a column's prominence is how far both sides fall from it.
  std::vector<float> prefix_min(span), suffix_min(span);
  for (size_t column = 0; column < span; ++column) prefix_min[column] = std::min(profile[column], column > 0 ? prefix_min[column - 1] : kNone);
  for (size_t column = span; column-- > 0;) suffix_min[column] = std::min(profile[column], column + 1 < span ? suffix_min[column + 1] : kNone);
  size_t peak = span;
  double best_excess_m = 0;
  for (size_t column = 1; column + 1 < span; ++column) {
    if (profile[column] == kNone || prefix_min[column - 1] == kNone || suffix_min[column + 1] == kNone) continue;
    const double peak_m = profile[column];
    const double prominence_m = peak_m - std::max(prefix_min[column - 1], suffix_min[column + 1]);
    const double threshold_m = std::max(window_sigmas * error_model.depth_sigma_m(peak_m) + row_cell_m, min_depth_gap_m);
    if (prominence_m - threshold_m > best_excess_m) best_excess_m = prominence_m - threshold_m, peak = column;
  }
  if (work != nullptr) {
    work->scalar_ops += 6 * indices.size() + 12 * span;
    work->memory_bytes += 8 * indices.size() + 24 * span;
  }
  if (peak == span) return {indices};
  // The peak column goes with the side whose nearest measured neighbour is closer to it in range
  // (the far surface it ends).
  auto neighbour_range = [&](size_t column, int step) {
    for (size_t c = column + step; c < span; c += step)
      if (profile[c] != kNone) return static_cast<double>(profile[c]);
    return std::numeric_limits<double>::infinity();
  };
  const double left_m = neighbour_range(peak, -1), right_m = neighbour_range(peak, +1);
  const int last_left = static_cast<int>(std::abs(left_m - profile[peak]) <= std::abs(right_m - profile[peak]) ? peak : peak - 1) + u_min;
  return cut_after_column(points, indices, last_left);
}

std::vector<std::vector<int>> split_at_range_step(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                  const StereoErrorModel& error_model, double window_sigmas, double row_cell_m,
                                                  double min_depth_gap_m, int max_step_columns_px, ArmWork* work) {
  if (max_step_columns_px <= 0 || indices.size() < kMinRangeStepPoints) return {indices};
  const DisparityProfile profile = disparity_profile(points, indices);
  if (work != nullptr) {
    work->scalar_ops += 6 * indices.size() + 8 * profile.span;
    work->memory_bytes += 8 * indices.size() + 12 * profile.span;
  }
  const int last_left_u =
      range_step_cut(profile, 0, profile.u.size(), error_model, window_sigmas, row_cell_m, min_depth_gap_m, max_step_columns_px);
  if (last_left_u < 0) return {indices};
  return cut_after_column(points, indices, last_left_u);
}

std::vector<std::vector<int>> split_at_concavity(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                 const StereoErrorModel& error_model, double min_concavity_px, double min_depth_gap_m,
                                                 ArmWork* work) {
  if (min_concavity_px <= 0 || indices.size() < kMinConcavityPoints) return {indices};
  const DisparityProfile profile = disparity_profile(points, indices);
  if (work != nullptr) {
    work->scalar_ops += 6 * indices.size() + 20 * profile.span;
    work->memory_bytes += 8 * indices.size() + 20 * profile.span;
  }
  const int last_left_u = concavity_cut(profile, 0, profile.u.size(), error_model, min_concavity_px, min_depth_gap_m);
  if (last_left_u < 0) return {indices};
  return cut_after_column(points, indices, last_left_u);
}

std::vector<std::vector<int>> split_object(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                           const OccupancyGridParameters& parameters, ArmWork* work) {
  std::vector<std::vector<int>> parts = split_at_column_gaps(points, indices, parameters.min_column_gap_px, work);
  // Applies one cut to every part so far, the pieces in order.
  const auto cut_each = [&parts](auto&& cut) {
    std::vector<std::vector<int>> pieces;
    for (const std::vector<int>& part : parts)
      for (std::vector<int>& piece : cut(part)) pieces.push_back(std::move(piece));
    parts = std::move(pieces);
  };
  const double row_cell_m = parameters.kind == GridKind::column_disparity ? 0.0 : parameters.row_cell;
  if (parameters.split_at_range_peaks) {
    cut_each([&](const std::vector<int>& part) {
      return split_at_range_peak(points, part, parameters.error_model, parameters.window_sigmas, row_cell_m, parameters.min_depth_gap_m, work);
    });
  }
  // The range-step and concavity cuts read one disparity profile per part: a cut leaves each side's
  // columns whole, so each piece's profile is a run of its part's (split_at_range_step and
  // split_at_concavity give the same parts).
  const bool step_on = parameters.max_range_step_columns_px > 0, concavity_on = parameters.min_concavity_px > 0;
  if (step_on || concavity_on) {
    cut_each([&](const std::vector<int>& part) -> std::vector<std::vector<int>> {
      const bool step_here = step_on && part.size() >= kMinRangeStepPoints, concavity_here = concavity_on && part.size() >= kMinConcavityPoints;
      if (!step_here && !concavity_here) return {part};
      const DisparityProfile profile = disparity_profile(points, part);
      const size_t columns = profile.u.size();
      if (work != nullptr) {
        work->scalar_ops += 6 * part.size() + (step_here ? 8 : 0) * profile.span + (concavity_here ? 20 : 0) * profile.span;
        work->memory_bytes += 8 * part.size() + (step_here ? 12 : 0) * profile.span + (concavity_here ? 20 : 0) * profile.span;
      }
      // (piece, its run [first, last) of the profile's columns)
      std::vector<std::pair<std::vector<int>, std::pair<size_t, size_t>>> pieces;
      const int step_u = step_here ? range_step_cut(profile, 0, columns, parameters.error_model, parameters.window_sigmas, row_cell_m,
                                                    parameters.min_depth_gap_m, parameters.max_range_step_columns_px)
                                   : -1;
      if (step_u < 0) {
        pieces.push_back({part, {0, columns}});
      } else {
        std::vector<std::vector<int>> two = cut_after_column(points, part, step_u);
        const size_t split = static_cast<size_t>(std::upper_bound(profile.u.begin(), profile.u.end(), step_u) - profile.u.begin());
        pieces.push_back({std::move(two[0]), {0, split}});
        pieces.push_back({std::move(two[1]), {split, columns}});
      }
      std::vector<std::vector<int>> result;
      for (auto& [piece, run] : pieces) {
        const int concavity_u = concavity_on && piece.size() >= kMinConcavityPoints
                                    ? concavity_cut(profile, run.first, run.second, parameters.error_model, parameters.min_concavity_px,
                                                    parameters.min_depth_gap_m)
                                    : -1;
        if (concavity_u < 0) {
          result.push_back(std::move(piece));
          continue;
        }
        for (std::vector<int>& side : cut_after_column(points, piece, concavity_u)) result.push_back(std::move(side));
      }
      return result;
    });
  }
  return parts;
}

// obstacle_from_points: the share of an object's points left out at each end of x and of z of its box.
constexpr double kBoxTrimFraction = 0.01;

Obstacle3d obstacle_from_points(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices, int id, ArmWork* work) {
  Obstacle3d obstacle;
  obstacle.id = id;
  if (indices.empty()) return obstacle;
  Eigen::Vector3d low = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d high = -low;
  double min_height = std::numeric_limits<double>::infinity(), max_height = -min_height;
  int u0 = std::numeric_limits<int>::max(), v0 = u0, u1 = -1, v1 = -1;
  for (int index : indices) {
    const ObstaclePoint& point = points[static_cast<size_t>(index)];
    const Eigen::Vector3d position = point.camera_m.cast<double>();
    low = low.cwiseMin(position);
    high = high.cwiseMax(position);
    min_height = std::min<double>(min_height, point.height_above_ground_m);
    max_height = std::max<double>(max_height, point.height_above_ground_m);
    u0 = std::min<int>(u0, point.u_px), u1 = std::max<int>(u1, point.u_px);
    v0 = std::min<int>(v0, point.v_px), v1 = std::max<int>(v1, point.v_px);
  }
  // The box on the ground plane (x, z) trimmed by kBoxTrimFraction of the points at each end: a few
  // mismatches chained into an object through neighbouring modes stretch the full box by metres
  // along the ray. The vertical extent keeps every point, as the height range does.
  const size_t trim = static_cast<size_t>(kBoxTrimFraction * static_cast<double>(indices.size()));
  if (trim > 0) {
    std::vector<float> values(indices.size());
    for (int axis : {0, 2}) {
      for (size_t k = 0; k < indices.size(); ++k) values[k] = points[static_cast<size_t>(indices[k])].camera_m[axis];
      const auto low_slot = values.begin() + static_cast<std::ptrdiff_t>(trim);
      const auto high_slot = values.end() - 1 - static_cast<std::ptrdiff_t>(trim);
      std::nth_element(values.begin(), low_slot, values.end());
      std::nth_element(low_slot + 1, high_slot, values.end());  // the rest are >= the low one
      low[axis] = *low_slot;
      high[axis] = *high_slot;
    }
    if (work != nullptr) {
      work->scalar_ops += 16 * indices.size();
      work->memory_bytes += 8 * indices.size();
    }
  }
  obstacle.position_m = (low + high) / 2;
  obstacle.size_m = high - low;
  obstacle.min_height_m = min_height;
  obstacle.max_height_m = max_height;
  obstacle.bbox_px = {u0, v0, u1, v1};
  return obstacle;
}

}  // namespace lpstereo::arm::obstacles3d
