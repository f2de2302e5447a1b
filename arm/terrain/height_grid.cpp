// The 2.5D sampling of terrain estimation (issue 9 deliverable 1; thesis 000 = Sabbatelli 2015,
// ../shared/theses/000_*.txt, §3.1.3): vehicle-frame points are binned into the m0 x m1 cells of a
// TerrainGridSpec and each cell is condensed into one height sample.
//
// Model (thesis eq. 3.2): for the points z_j binned into a cell,
//     Z = max(min z_j, mean z_j - sigma),   sigma = sqrt(mean z_j^2 - (mean z_j)^2)  (population)
// so the low points of a cell (the ground under a bush, a pole or a noisy stereo return) dominate,
// while a single low outlier far under the others cannot drag the cell below mean - sigma; Z always
// stays within [min z_j, max z_j]. A cell without points takes the mean of its measured
// 8-neighbours (only measured ones: a fill from already-filled cells would depend on the scan order
// and spread a single return over the whole area); without any, it is invalid (height NaN, weight 0
// in the fit; the thesis sets Z := 0 and leaves the cell out of the fit, which is the same thing).
//
// The noise-floor rule (TerrainGridSpec::CellRule::noise_floor, the default). Under stereo, eq. 3.2's
// sigma is mostly the height noise of the points, not an obstacle's spread: a ground point at range
// r seen from a camera h up has a depth error of r^2 sigma_d / (f B) (the stereo error model, e.g.
// Chang et al. 1994; Gallup et al. 2008), which moves it along its ray by h / r of that in height:
// sigma_h = r h sigma_d / (f B), 2-5 cm at 10-20 m for 640 px, 0.30 m and sigma_d ~ 0.25 px. Eq. 3.2
// then puts every ground cell about sigma_h below the ground (bench/terrain_synth_eval: bias -1 to
// -4 cm within 20 m, the largest share of its RMS). Cells at one range share sigma_h, and most
// cells of a forward row are ground, so the rule estimates the noise from the data instead of a
// camera model: sigma_noise^2 = the noise_floor_quantile (median by default) of the variances of
// the measured cells with at least kMinNoisePoints points in rows i - 1 .. i + 1, and subtracts only
// the spread in excess of it (a noise-only cell keeps its mean; an obstacle cell still loses its
// spread, and stays within [min z, max z]):
//     Z = max(min z_j, mean z_j - sqrt(max(0, sigma^2 - sigma_noise^2)))
// Without such cells in the three rows sigma_noise = 0: eq. 3.2. With exact (noise-free) points
// the floor is the median spread of the row's ground cells (their slope), so the rule is eq. 3.2
// wherever the ground is flat (the deviation test of bench/terrain_bench is unchanged). The figures:
// docs/terrain.md.
//
// Steps: add_point (cell of (x, y), reject outside or non-finite) / add_to_cell (the cell given by
// the binning), each summing count, sum z, sum z^2 and min z; finish() applies the cell rule per
// measured cell (the noise floor: each forward row's first) and the neighbour fill per empty cell.
//
// Counted work (ArmWork), with P accepted points, R rejected points, C = m0 m1 cells:
//   scalar_ops   = 10 per add_point call (finite checks, two subtract-multiply-floor, range compares)
//                  + 6 per accepted point (count, two sums with a multiply, a min compare)
//                  + 2 per add_to_cell call (range compares), accepted or not
//                  + 12 C in finish() (eq. 3.2: two divides, a square root, a max; or the 8-neighbour
//                  mean of an empty cell)
//                  + 8 C more with the noise-floor rule (each cell's variance collected for three
//                  rows, a linear-time selection, the subtraction)
//   memory_bytes = 12 P (the point read from a DRAM buffer, three floats on the chip) + 28 C (the
//                  accumulator cells, 4 + 3 x 8 bytes, read once by finish; they stay in the cache
//                  while binning: 68 x 44 cells are 84 KiB) + 8 C (the heights written).
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

// A cell with fewer points gives no useful sigma for the noise floor (one point: sigma 0).
constexpr int kMinNoisePoints = 4;
constexpr int64_t kMaxCells = 4 * 1024 * 1024;  // a grid beyond this is a mistake in the spec (16 M cells of doubles)

// The repository's number format for error messages (%.6g).
using localization::format_number;

int cells_over(double min_m, double max_m, double cell_m) {
  // Relative slack: 22 / 0.5 must give 44 cells, not 45 from rounding.
  const double cells = (max_m - min_m) / cell_m;
  return static_cast<int>(std::ceil(cells - 1e-9 * std::max(1.0, cells)));
}

}  // namespace

int TerrainGridSpec::forward_cells() const { return cells_over(forward_min_m, forward_max_m, cell_m); }
int TerrainGridSpec::lateral_cells() const { return cells_over(lateral_min_m, lateral_max_m, cell_m); }

bool TerrainGridSpec::cell_of(double x_m, double y_m, int* forward_cell, int* lateral_cell) const {
  if (!std::isfinite(x_m) || !std::isfinite(y_m)) return false;
  if (x_m < forward_min_m || y_m < lateral_min_m || x_m >= forward_max_m || y_m >= lateral_max_m) return false;
  const int i = static_cast<int>(std::floor((x_m - forward_min_m) / cell_m));
  const int j = static_cast<int>(std::floor((y_m - lateral_min_m) / cell_m));
  if (i < 0 || j < 0 || i >= forward_cells() || j >= lateral_cells()) return false;
  *forward_cell = i;
  *lateral_cell = j;
  return true;
}

double TerrainGridSpec::cell_centre_x_m(int forward_cell) const { return forward_min_m + (forward_cell + 0.5) * cell_m; }
double TerrainGridSpec::cell_centre_y_m(int lateral_cell) const { return lateral_min_m + (lateral_cell + 0.5) * cell_m; }

void TerrainGridSpec::validate() const {
  const auto finite = [](const char* name, double value) {
    if (!std::isfinite(value)) throw std::invalid_argument(std::string(name) + ": expected a finite value, got " + format_number(value));
  };
  finite("forward_min_m", forward_min_m);
  finite("forward_max_m", forward_max_m);
  finite("lateral_min_m", lateral_min_m);
  finite("lateral_max_m", lateral_max_m);
  finite("cell_m", cell_m);
  if (!(noise_floor_quantile >= 0 && noise_floor_quantile <= 1)) {
    throw std::invalid_argument("noise_floor_quantile: expected in [0, 1], got " + format_number(noise_floor_quantile));
  }
  if (!(cell_m > 0)) throw std::invalid_argument("cell_m: expected > 0, got " + format_number(cell_m));
  if (!(forward_max_m > forward_min_m)) {
    throw std::invalid_argument("forward_max_m: expected > forward_min_m = " + format_number(forward_min_m) + ", got " +
                                format_number(forward_max_m));
  }
  if (!(lateral_max_m > lateral_min_m)) {
    throw std::invalid_argument("lateral_max_m: expected > lateral_min_m = " + format_number(lateral_min_m) + ", got " +
                                format_number(lateral_max_m));
  }
  const double cells = std::ceil((forward_max_m - forward_min_m) / cell_m) * std::ceil((lateral_max_m - lateral_min_m) / cell_m);
  if (cells > static_cast<double>(kMaxCells)) {
    throw std::invalid_argument("cell_m: expected at most " + std::to_string(kMaxCells) + " cells over the area, got " +
                                format_number(cells) + " with cell_m = " + format_number(cell_m));
  }
}

int HeightGrid::valid_cells() const {
  int valid = 0;
  for (Eigen::Index k = 0; k < state.size(); ++k) valid += state.data()[k] != kCellInvalid ? 1 : 0;
  return valid;
}

HeightGridAccumulator::HeightGridAccumulator(const TerrainGridSpec& spec) : spec_(spec) {
  spec_.validate();
  const int m0 = spec_.forward_cells(), m1 = spec_.lateral_cells();
  count_ = Eigen::MatrixXi::Zero(m0, m1);
  sum_z_ = Eigen::MatrixXd::Zero(m0, m1);
  sum_z2_ = Eigen::MatrixXd::Zero(m0, m1);
  min_z_ = Eigen::MatrixXd::Constant(m0, m1, std::numeric_limits<double>::infinity());
}

bool HeightGridAccumulator::add_point(const Eigen::Vector3d& point_vehicle_m) {
  ++add_point_calls_;
  int i = 0, j = 0;
  if (!std::isfinite(point_vehicle_m.z()) || !spec_.cell_of(point_vehicle_m.x(), point_vehicle_m.y(), &i, &j)) {
    ++rejected_;
    return false;
  }
  accumulate(i, j, point_vehicle_m.z());
  return true;
}

bool HeightGridAccumulator::add_to_cell(int forward_cell, int lateral_cell, double z_m) {
  ++add_to_cell_calls_;
  if (forward_cell < 0 || lateral_cell < 0 || forward_cell >= count_.rows() || lateral_cell >= count_.cols() ||
      !std::isfinite(z_m)) {
    ++rejected_;
    return false;
  }
  accumulate(forward_cell, lateral_cell, z_m);
  return true;
}

void HeightGridAccumulator::accumulate(int forward_cell, int lateral_cell, double z_m) {
  ++accepted_;
  count_(forward_cell, lateral_cell) += 1;
  sum_z_(forward_cell, lateral_cell) += z_m;
  sum_z2_(forward_cell, lateral_cell) += z_m * z_m;
  double& lowest = min_z_(forward_cell, lateral_cell);
  if (z_m < lowest) lowest = z_m;
}

HeightGrid HeightGridAccumulator::finish() const {
  const Eigen::Index m0 = count_.rows(), m1 = count_.cols();
  HeightGrid grid;
  grid.spec = spec_;
  grid.height_m = Eigen::MatrixXd::Constant(m0, m1, std::numeric_limits<double>::quiet_NaN());
  grid.point_count = count_;
  grid.state = Eigen::MatrixXi::Constant(m0, m1, kCellInvalid);
  // Per measured cell: mean and population variance (rounding can make the variance of equal heights
  // slightly negative).
  Eigen::MatrixXd variance = Eigen::MatrixXd::Constant(m0, m1, std::numeric_limits<double>::quiet_NaN());
  for (Eigen::Index i = 0; i < m0; ++i) {
    for (Eigen::Index j = 0; j < m1; ++j) {
      const int count = count_(i, j);
      if (count == 0) continue;
      const double mean = sum_z_(i, j) / count;
      variance(i, j) = std::max(0.0, sum_z2_(i, j) / count - mean * mean);
    }
  }
  // The noise floor of each forward row (noise_floor rule): the quantile of the variances (the same
  // rank as of the sigmas) of the measured cells with at least kMinNoisePoints points in rows
  // i - 1 .. i + 1.
  Eigen::VectorXd noise_variance = Eigen::VectorXd::Zero(m0);
  if (spec_.cell_rule == TerrainGridSpec::CellRule::noise_floor) {
    std::vector<double> row_variances;
    for (Eigen::Index i = 0; i < m0; ++i) {
      row_variances.clear();
      for (Eigen::Index r = std::max<Eigen::Index>(0, i - 1); r <= std::min<Eigen::Index>(m0 - 1, i + 1); ++r) {
        for (Eigen::Index j = 0; j < m1; ++j) {
          if (count_(r, j) >= kMinNoisePoints) row_variances.push_back(variance(r, j));
        }
      }
      if (row_variances.empty()) continue;
      const size_t rank = static_cast<size_t>(std::lround(spec_.noise_floor_quantile * static_cast<double>(row_variances.size() - 1)));
      std::nth_element(row_variances.begin(), row_variances.begin() + static_cast<std::ptrdiff_t>(rank), row_variances.end());
      noise_variance(i) = row_variances[rank];
    }
  }
  for (Eigen::Index i = 0; i < m0; ++i) {
    for (Eigen::Index j = 0; j < m1; ++j) {
      const int count = count_(i, j);
      if (count == 0) continue;
      const double mean = sum_z_(i, j) / count;
      // thesis eq. 3.2 (noise_variance 0), or the spread in excess of the row's noise floor
      const double excess_sigma = std::sqrt(std::max(0.0, variance(i, j) - noise_variance(i)));
      grid.height_m(i, j) = std::max(min_z_(i, j), mean - excess_sigma);
      grid.state(i, j) = kCellMeasured;
    }
  }
  for (Eigen::Index i = 0; i < m0; ++i) {
    for (Eigen::Index j = 0; j < m1; ++j) {
      if (count_(i, j) != 0) continue;
      double sum = 0;
      int neighbours = 0;
      for (Eigen::Index di = -1; di <= 1; ++di) {
        for (Eigen::Index dj = -1; dj <= 1; ++dj) {
          const Eigen::Index ni = i + di, nj = j + dj;
          if ((di == 0 && dj == 0) || ni < 0 || nj < 0 || ni >= m0 || nj >= m1 || count_(ni, nj) == 0) continue;
          sum += grid.height_m(ni, nj);
          ++neighbours;
        }
      }
      if (neighbours == 0) continue;
      grid.height_m(i, j) = sum / neighbours;
      grid.state(i, j) = kCellFilled;
    }
  }
  return grid;
}

ArmWork HeightGridAccumulator::work() const {
  const uint64_t cells = static_cast<uint64_t>(count_.size());
  ArmWork work;
  const uint64_t per_cell = spec_.cell_rule == TerrainGridSpec::CellRule::noise_floor ? 12 + 8 : 12;
  work.scalar_ops = 10 * static_cast<uint64_t>(add_point_calls_) + 6 * static_cast<uint64_t>(accepted_) +
                    2 * static_cast<uint64_t>(add_to_cell_calls_) + per_cell * cells;
  work.memory_bytes = 12 * static_cast<uint64_t>(accepted_) + (28 + 8) * cells;
  return work;
}

}  // namespace lpstereo::arm::terrain
