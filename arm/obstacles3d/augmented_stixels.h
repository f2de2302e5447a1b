// Augmented stixels on the polar occupancy grid (issue 10 deliverable 2; thesis 004 §3.2.4): the
// polar grid of occupancy_grid.h with its convex hulls replaced by stixels that keep the 3D points,
// after Badino, Franke, Pfeiffer, "The stixel world - a compact medium level representation of the
// 3D world", DAGM 2009, modified as the thesis does:
//   - fixed size in both directions: one stixel per polar cell (angular width column_cell rad x
//     depth row_cell m);
//   - the textured points it holds (indices into the frame's points, their colour averaged);
//   - the minimum AND the maximum height above the fitted terrain (ObstaclePoint::
//     height_above_ground_m), so that a hanging or concave obstacle (a board on two poles, a sign, a
//     branch) keeps the free space under it: free_below_m = max(0, min height). A classic stixel (and
//     any 2D grid cell) spans ground to top and calls that space occupied.
//
// Steps, per frame:
//   1. the polar grid's update (occupancy_grid.h: likelihoods, log-odds, ego-motion), occupancy only
//      (GridDescription::occupancy_only: the grid's own clusters and obstacles are not described);
//   2. binning: each point whose mean lies in a cell (the grid's point_cells()) is counted per cell,
//      then placed by a counting sort in point order (one thread: the order of a stixel's points is
//      the frame's);
//   3. stixels: in each cell that is occupied in the grid (require_occupied_cell; otherwise any cell)
//      or holds at least min_points_unoccupied points this frame (the grid's log-odds need a few
//      frames for an object that just came into view: in obstacles3d_eval, 150 frames, seed 1,
//      30 points gave urban 93.3 % instead of 91.3 %, floating 93.3 % instead of 92.7 %, country
//      96.7 % instead of 95.1 %, for 0.04, 0.49 and 0.03 more false positives a frame), and holds
//      at least min_points points, the points sorted by height are split where two
//      consecutive heights lie more than max_height_gap_m apart (multi-layer stixels, after
//      Pfeiffer and Franke, "Towards a global optimal multi-layer stixel representation of dense 3D
//      data", BMVC 2011, thesis 003 ref. [2]: a sign above a low box in the same cells is two
//      stixels per cell, and the free space between them is kept); then each part is cut once more
//      where a thin support meets a wide part above it (the support split): at the index where the
//      points per metre of height below, divided by those above, is smallest (both sides with at
//      least max(min_points, 3) points and 3 image rows, a row being Z / f at the cell's range),
//      when that ratio is below support_density_ratio. A 5 cm post under a 0.4 m ball, an 8 cm pole
//      under a board's end share their cells with the ball and the board with no height gap;
//      split, the post's stixel keeps its ground contact and the ball's starts at the ball. Only
//      where the post is thin against the cell: one row of a 5 cm post at 14 m is 2 px against the
//      0.01 rad cell's 5.5 px, a ratio of 0.36, so at that range the ball and its post mostly stay
//      one stixel (eval, floating, 150 frames, seeds 1 and 2, VO, with the point-weighted tercile
//      of step 4: lower edge within 10 cm 83.0 -> 83.8 % and 83.4 -> 85.4 %, 4 and 5 object-frames
//      right that were wrong, 3 and 2 wrong that were right; free space kept 108 -> 109 of 120 and
//      110 -> 112 of 124; detection 99.4 -> 100 % and 100 %; false positives 2.47 -> 2.44 and
//      2.33 -> 2.26 a frame; urban and mining seed 1 unchanged). A standing object as wide at its
//      foot as above (a box, a car's side) has a ratio near 1 and is not cut. Each part with at
//      least min_points points is a stixel. Upper edge = the k-th highest height, k = floor(
//      height_trim_fraction * n). Lower edge: q = lower_edge_fraction, p_q the k-th lowest height
//      (k = floor(q n)) and p_50 the median; for points spread evenly over [edge, top] p_q =
//      edge + q (p_50 - edge) / 0.5, so edge = p_q - q / (0.5 - q) (p_50 - p_q) (the plain
//      percentile sat 0.1 x the board's height, 7 cm, above a near board's edge); plus
//      lower_edge_fattening_px * mean range / f: stereo fattens a hanging board's lower border (the
//      aggregation window gives the board's disparity to the road pixels just under it, about
//      1.5 px, 4-8 cm at 16-28 m in bench/obstacles3d_eval), which pulls p_q down by that much.
//      A robust percentile rather than the minimum: a stray point of the terrain fit under a
//      board does not move it. Mean range, mean colour;
//   4. obstacles: stixels join when they are neighbours (8-neighbouring cells, and along a bearing
//      any range cell within range_join_sigmas depth sigmas of the stereo error model, sigma_Z =
//      Z^2 sigma_d / (f B), since one surface's points scatter over that many 0.2 m cells at range:
//      1.3 m at 27 m), their height intervals overlap or lie within max_height_gap_m, and their lower
//      edges differ by at most max_lower_edge_step_m. An obstacle has one height interval, so a
//      board and the poles it hangs on are three obstacles and the board's keeps the free space
//      under it; a sign next to a low box are two. Each cluster's interval: the highest stixel
//      upper edge, and the point-weighted lower tercile of its stixels' lower edges (sorted by
//      lower edge, the first stixel at which the stixels so far hold more than a third of the
//      cluster's points: one stixel pulled down by a fattened border does not move it, and the
//      thin, sparse stixels of a pole's foot or a post that chain into a board's or a ball's
//      cluster in steps under max_lower_edge_step_m count by their few points, not as stixels),
//      and the lower edge itself is step 3's estimate on the pooled points of the member stixels
//      whose own edge lies within max_lower_edge_step_m of that tercile (a hanging board's bottom
//      rows, given a slightly lower disparity by the matcher, fall in farther range cells than the
//      rows above, so most of its stixels hold no bottom row and their edges lie above its edge).
//      Fragments: the lower-edge step also cuts pieces off a hanging obstacle: the top rows of a
//      board whose points scattered into other range cells ([1.5, 1.6] m beside a [0.9, 1.6] m
//      board), a sign's arm between the sign and its post ([2.9, 3.0] m beside a [1.9, 3.0] m
//      sign). A cluster is a fragment of a neighbouring one (stixels within 2 columns, the same
//      range reach) when it has at most max_fragment_fraction of its points, its lower edge lies
//      more than max_lower_edge_step_m above the host's (it was cut off by the step, not a
//      grounded object beside a bigger one) and at most max_height_gap_m above the host's upper
//      edge; of several hosts the one with the highest lower edge (the board, not the pole, whose
//      interval also holds the fragment). It joins the host, which keeps its own interval.
//      Clusters with fewer than min_cluster_stixels stixels or min_obstacle_points points
//      (scattered terrain-fit outliers, mismatches) give no obstacle. Each cluster's points are
//      split at gaps in the image columns (occupancy_grid.h, split_at_column_gaps with
//      grid.min_column_gap_px, default 3 px): 8-neighbouring cells join stixels up to two 0.01 rad
//      cells (about 10 px) apart in the image, and at least that many columns without a point
//      between them say they are two objects; then each part is cut at an occlusion peak of its
//      range profile over the image columns (split_at_range_peak, grid.split_at_range_peaks: a
//      car's side receding to its far end with a pedestrian nearer beside it, the gap between them
//      filled by stereo fattening), then at a step of its disparity profile (split_at_range_step,
//      grid.max_range_step_columns_px: a far surface's end left at a part's edge with a nearer
//      object beside it), and then where its disparity profile over the image columns dips
//      under its concave envelope (split_at_concavity, grid.min_concavity_px: a pedestrian touching
//      the far end of a car's side at the side's range); each part of at least min_obstacle_points points is
//      an obstacle with the cluster's height interval, clamped when the cluster was split to the
//      part's own lowest and highest point (a fragment of a board's top rows that joined the
//      board's pole, cut off at a column gap, held points at 1.6 m only and took the pole's 0.2 m
//      lower edge: an obstacle under the board that is not there, floating seed 1 frame 24), and a
//      stixel takes the obstacle of the part holding most of its points. Each part's points give
//      its Obstacle3d (occupancy_grid.h, obstacle_from_points) with the interval above as its
//      min_height_m and max_height_m.
//
// Threads (grid.threads): the grid's evidence and its ego-motion resampling (occupancy_grid.h), and,
// one per 4096 stixel points at most, in step 4 the clusters' height intervals and their obstacles'
// descriptions (the splits and boxes), the clusters dealt one at a time (arm/fork_join.h) and the
// obstacles numbered in cluster order afterwards: the stixels and obstacles do not depend on the
// thread count (test TwoThreadsGiveTheOneThreadStixelsAndObstacles). Binning, step 3 and the
// clustering are serial.
//
// Counted work (ArmWork): the grid's own (occupancy_grid.h), plus per point 8 ops + 8 bytes (count)
// and 6 ops + 8 bytes (placement); per cell 4 ops + 4 bytes (prefix sum); per point of a stixel
// cell 12 ops (the height sort, ~log2 of a cell's few dozen points, sums) + 16 bytes, and 8 ops for
// the support split's scan when support_density_ratio > 0 (two spans, two densities, a compare); per
// point pooled for an obstacle's lower edge 10 ops + 8 bytes (the gather, two selections); clustering
// and the fragment test 20 ops per stixel pair tested (the stixels of the (2 n + 1) x 3 cells
// around, n range cells reached along the bearing, and of (2 n + 1) x 5 for fragments) and the
// Obstacle3d's 10 ops + sizeof(ObstaclePoint) per point, and the column gap split's (occupancy_grid.h:
// 4 ops + 2 bytes per point, 2 ops + 5 bytes per image column spanned), the occlusion split's
// (6 ops + 8 bytes per point, 12 ops + 24 bytes per column spanned), the range-step split's (6 ops +
// 8 bytes per point, 8 ops + 12 bytes per column spanned), the concavity split's (6 ops + 8 bytes
// per point, 20 ops + 20 bytes per column spanned), the trimmed box's (16 ops + 8 bytes per
// point of an obstacle of 100 points or more) and the split parts' clamp (2 ops per point of a
// cluster split in two or more parts).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "arm/obstacles3d/obstacle_points.h"
#include "arm/obstacles3d/occupancy_grid.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::obstacles3d {

struct AugmentedStixelParameters {
  OccupancyGridParameters grid = OccupancyGridParameters::defaults(GridKind::polar);  // kind must be polar
  int min_points = 3;                 // >= 1
  bool require_occupied_cell = true;  // a stixel only where the polar grid says occupied ...
  int min_points_unoccupied = 30;     // ... or where the cell holds at least this many points (>= 1)
  double height_trim_fraction = 0.02; // in [0, 0.25): the upper edge, the k-th highest
  double lower_edge_fraction = 0.10;  // in [0, 0.5): q of the lower edge's percentile p_q (step 3)
  double lower_edge_fattening_px = 1.5;  // in [0, 16]: stereo fattening under an edge, px (added: px * range / f)
  double support_density_ratio = 0.3;  // in [0, 1), 0 = off: a sparser lower part (points per metre of height) splits a cell's part (step 3)
  double max_height_gap_m = 0.5;      // >= 0: a larger gap splits a cell's points; neighbours join when closer
  double max_lower_edge_step_m = 0.3; // >= 0: ... and their lower edges differ by at most this
  double max_fragment_fraction = 0.25;  // in [0, 1): a cluster with at most this fraction of a neighbour's points may be its fragment
  double range_join_sigmas = 1.0;     // in [0, 6]: neighbours along a bearing reach this many sigma_Z
  int min_cluster_stixels = 1;        // >= 1
  int min_obstacle_points = 10;       // >= 1: a cluster with fewer points gives no obstacle
  // Throws std::invalid_argument "<parameter>: expected ..., got ..." (grid parameters prefixed "grid.").
  void validate() const;
};

struct AugmentedStixel {
  int angle_cell = 0, range_cell = 0;      // polar grid column and row
  double angle_min_rad = 0, angle_max_rad = 0;
  double range_min_m = 0, range_max_m = 0;
  int first_point = 0, point_count = 0;    // into AugmentedStixels::point_indices()
  float min_height_m = 0, max_height_m = 0;  // above the terrain, trimmed extremes
  float mean_range_m = 0;
  std::array<uint8_t, 3> mean_rgb{};
  float occupancy_probability = 0;         // the polar grid cell's
  int cluster = -1;                        // obstacle index, -1 when its cluster was dropped
  float free_below_m() const { return min_height_m > 0 ? min_height_m : 0.0f; }
};

class AugmentedStixels {
 public:
  explicit AugmentedStixels(const AugmentedStixelParameters& parameters);  // validates

  void update(const std::vector<ObstaclePoint>& points, const EgoMotion& ego_motion);

  const AugmentedStixelParameters& parameters() const { return parameters_; }
  const OccupancyGrid& grid() const { return grid_; }
  const std::vector<AugmentedStixel>& stixels() const { return stixels_; }  // by (range, angle) cell, then height
  const std::vector<int>& point_indices() const { return point_indices_; }   // grouped by stixel, by height in one
  const std::vector<Obstacle3d>& obstacles() const { return obstacles_; }
  // The grid's status, then stixels and obstacles.
  const std::string& status() const { return status_; }
  ArmWork work() const { return work_; }  // of the last update(), grid included

 private:
  AugmentedStixelParameters parameters_;
  OccupancyGrid grid_;
  std::vector<AugmentedStixel> stixels_;
  std::vector<int> point_indices_;
  std::vector<Obstacle3d> obstacles_;
  std::vector<int> cell_counts_, cell_offsets_;
  std::vector<int> first_stixel_of_cell_, stixel_count_of_cell_;  // stixels_ of a cell: [first, + count)
  std::string status_;
  ArmWork work_;
};

}  // namespace lpstereo::arm::obstacles3d
