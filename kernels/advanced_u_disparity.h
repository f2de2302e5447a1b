// The row geometry of the Advanced U-disparity grid (thesis 003 §4.2.3, eq. 4.2), shared by the
// advanced_u_disparity kernel (which turns it into a lookup table from Q4 disparity to grid row in
// prepare) and the ARM tasks that read the grid (thresholds, clusters, the top-view picture).
//
// Eq. 4.2: row(d) = (ln(d / d_min))^k / ((ln(d_max / d_min))^k / N_rows), floored: rows are
// log-scaled in disparity, row 0 = d_min (far), row N_rows - 1 = near; k > 1 gives the far range more
// rows, k < 1 the near range.
//
// Exactness: the table is built from the row boundaries rounded UP to Q4,
//   boundary_q4[r] = ceil(16 d_min exp(ln(d_max / d_min) (r / N_rows)^(1 / k))),   r = 0 .. N_rows,
// and a Q4 disparity D belongs to row r when boundary_q4[r] <= D < boundary_q4[r + 1] (the floor of
// eq. 4.2 at D / 16). A libm that differs in the last bit moves a boundary only when 16 d_r lies
// within ~1e-12 of an integer, so x86 and aarch64 builds give the same table (the golden test checks it).
// Disparities below d_min or at or above d_max (boundary_q4[N_rows]) belong to no row (-1).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace lpstereo::kernels {

struct AudGridGeometry {
  double min_disparity_px = 2.0;   // d_min (dsi_min), > 0
  double max_disparity_px = 128.0; // d_max (dsi_max), > d_min
  double exponent_k = 1.0;         // k, > 0
  int grid_rows = 128;             // N_rows, 1 .. 4096
};

// boundary_q4[r] for r = 0 .. grid_rows (grid_rows + 1 values, non-decreasing).
inline std::vector<int32_t> aud_row_boundaries_q4(const AudGridGeometry& geometry) {
  std::vector<int32_t> boundaries(static_cast<size_t>(geometry.grid_rows) + 1);
  const double log_range = std::log(geometry.max_disparity_px / geometry.min_disparity_px);
  for (int row = 0; row <= geometry.grid_rows; ++row) {
    const double fraction = std::pow(static_cast<double>(row) / geometry.grid_rows, 1.0 / geometry.exponent_k);
    // 1e-9 of slack: a boundary that is an integer Q4 value up to rounding (d_min itself, say) stays on it.
    boundaries[static_cast<size_t>(row)] =
        static_cast<int32_t>(std::ceil(16.0 * geometry.min_disparity_px * std::exp(log_range * fraction) - 1e-9));
  }
  return boundaries;
}

// The grid row of a Q4 disparity, -1 for none (below d_min, at or above d_max).
inline int aud_grid_row_of_q4(const std::vector<int32_t>& boundaries_q4, int32_t disparity_q4) {
  if (disparity_q4 < boundaries_q4.front() || disparity_q4 >= boundaries_q4.back()) return -1;
  int low = 0, high = static_cast<int>(boundaries_q4.size()) - 1;  // boundaries[low] <= D < boundaries[high]
  while (high - low > 1) {
    const int middle = (low + high) / 2;
    if (boundaries_q4[static_cast<size_t>(middle)] <= disparity_q4) low = middle; else high = middle;
  }
  return low;
}

// The disparity (px) a grid row stands for: eq. 4.2 inverted at the row's centre (row + 0.5), used
// as the cell's disparity d in the threshold n_min = (Y_min / B) d (eq. 4.3) and for the picture.
inline double aud_row_centre_disparity_px(const AudGridGeometry& geometry, int row) {
  const double log_range = std::log(geometry.max_disparity_px / geometry.min_disparity_px);
  const double fraction = std::pow((row + 0.5) / geometry.grid_rows, 1.0 / geometry.exponent_k);
  return geometry.min_disparity_px * std::exp(log_range * fraction);
}

}  // namespace lpstereo::kernels
