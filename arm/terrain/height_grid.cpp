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
// Steps: add_point (cell of (x, y), reject outside or non-finite) / add_to_cell (the cell given by
// the binning), each summing count, sum z, sum z^2 and min z; finish() applies eq. 3.2 per measured
// cell and the neighbour fill per empty cell.
//
// Counted work (ArmWork), with P accepted points, R rejected points, C = m0 m1 cells:
//   scalar_ops   = 10 per add_point call (finite checks, two subtract-multiply-floor, range compares)
//                  + 6 per accepted point (count, two sums with a multiply, a min compare)
//                  + 2 per add_to_cell call (range compares), accepted or not
//                  + 12 C in finish() (eq. 3.2: two divides, a square root, a max; or the 8-neighbour
//                  mean of an empty cell)
//   memory_bytes = 12 P (the point read from a DRAM buffer, three floats on the chip) + 28 C (the
//                  accumulator cells, 4 + 3 x 8 bytes, read once by finish; they stay in the cache
//                  while binning: 68 x 44 cells are 84 KiB) + 8 C (the heights written).
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "arm/localization/ransac_sampling.h"
#include "arm/terrain/terrain_model.h"

namespace lpstereo::arm::terrain {

namespace {

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
  for (Eigen::Index i = 0; i < m0; ++i) {
    for (Eigen::Index j = 0; j < m1; ++j) {
      const int count = count_(i, j);
      if (count == 0) continue;
      const double mean = sum_z_(i, j) / count;
      // Rounding can make the variance of equal heights slightly negative.
      const double variance = std::max(0.0, sum_z2_(i, j) / count - mean * mean);
      grid.height_m(i, j) = std::max(min_z_(i, j), mean - std::sqrt(variance));  // thesis eq. 3.2
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
  work.scalar_ops = 10 * static_cast<uint64_t>(add_point_calls_) + 6 * static_cast<uint64_t>(accepted_) +
                    2 * static_cast<uint64_t>(add_to_cell_calls_) + 12 * cells;
  work.memory_bytes = 12 * static_cast<uint64_t>(accepted_) + (28 + 8) * cells;
  return work;
}

}  // namespace lpstereo::arm::terrain
