// Probabilistic occupancy grids from the obstacle candidate points (issue 10 deliverable 1; thesis 004
// §3.2.1.1 and §3.2.2, after Badino, Franke, Mester, "Free space computation using stochastic
// occupancy grids and dynamic programming", ICCV workshop on dynamical vision 2007).
//
// Three tessellations of the top view, one class (OccupancyGrid) with a kind:
//   cartesian         column axis x (m, camera x, lateral, + right), row axis z (m, camera depth);
//   column_disparity  column axis u (px, left-image column), row axis d (px, disparity);
//   polar             column axis theta = atan2(x, z) (rad, + right), row axis r = sqrt(x^2 + z^2)
//                     (m, range in the camera's horizontal plane). Badino's polar grid is column u x
//                     depth z; a cell of constant angle is a cell of constant column (u - u0 = f tan
//                     theta), and range instead of depth keeps the cells' radial size constant.
// Cell (row, column) covers [row_min + row * row_cell, + row_cell) x [column_min + column *
// column_cell, + column_cell); log_odds() is rows x columns.
//
// Likelihood (Badino eq. 3.13-3.16 in the thesis): each point is a measurement m_k with a Gaussian
// error; the cell's evidence this frame is D(i, j) = sum_k L_ij(m_k), L_ij the Gaussian's mass over
// the cell. The covariance comes from StereoErrorModel (sigma_d = disparity_sigma_px, sigma_u =
// pixel_sigma_px) through the Jacobian of each grid's coordinates w.r.t. (u, d):
//   cartesian: x = B (u - u0) / d, z = f B / d, J = [[B/d, -x/d], [0, -z/d]], so
//     var_z = sigma_Z^2 (depth_sigma_m), cov_xz = (x / z) sigma_Z^2,
//     var_x = sigma_X^2 (lateral_sigma_m) + (x / z)^2 sigma_Z^2     (the ellipse points at the camera);
//   column_disparity: diag(sigma_u^2, sigma_d^2) (the measurement space itself);
//   polar: theta = atan((u - u0) / f), r = z / cos theta: sigma_theta = sigma_u cos^2 theta / f,
//     sigma_r = sigma_Z / cos theta, uncorrelated (a disparity error moves the point along its ray).
// The mass over a cell is integrated, not sampled at the centre (a near point's sigma is far below
// a cell): the row axis exactly, Phi((b1 - mu_b) / sigma_b) - Phi((b0 - mu_b) / sigma_b); the column
// axis with the conditional Gaussian given the row, x | z ~ N(mu_x + (cov_xz / var_z)(z - mu_z),
// var_x - cov_xz^2 / var_z), at the row's conditional mean of z (the truncated normal's mean). Cells
// beyond window_sigmas standard deviations on either axis get nothing (each cell's interval is cut at
// the window), so a point whose window lies inside the grid gives a mass of exactly (2 Phi(k) - 1)^2
// (k = window_sigmas; 0.9946 at k = 3), peaking at the cell holding its mean; less near the edges.
//
// Evidence to probability (inverse sensor model): p(D) = miss + (hit_max - miss)(1 - exp(-D / D_full))
// with miss = miss_probability (a cell with no evidence this frame: mild free evidence, so memory of
// a moving object fades), hit_max = hit_probability_max, D_full = points_for_full_evidence.
// Fusion (Thrun, Burgard, Fox, "Probabilistic Robotics", 2005, §9.2; thesis eq. 3.11) with prior 0.5:
//   l_t = clamp(l_{t-1} + log(p(D) / (1 - p(D))), log_odds_min, log_odds_max),  P = 1 / (1 + e^-l).
// The clamp keeps a cell able to change its mind within (log_odds_max - log_odds_min) / |step| frames.
// The lower clamp is shallow (-1, P = 0.27) on purpose: the grid sees only obstacle candidates, so a
// cell without evidence is not observed free (it may be occluded, outside the view, or just
// untextured), and one frame of full evidence must make it occupied again:
// log_odds_min + logit(hit_probability_max) > logit(occupied_probability) (-1 + 1.73 > 0.62). With
// -4, every cell the moving camera had seen empty for 20 frames needed 3 frames of evidence, so an
// object appearing there (a pedestrian stepping out, an object uncovered after an occlusion) was
// missed for its first 2 frames (bench/obstacles3d_eval, urban seed 1: polar 90.9 -> 94.4 %).
//
// Ego-motion (before this frame's evidence): the previous grid is resampled into the current
// frame, each current cell centre c (on the camera's horizontal plane, y = 0) taking the nearest
// previous cell of T c, T = camera_previous_from_camera_current = V^-1 E V with E =
// EgoMotion::previous_from_current (vehicle frames) and V = vehicle_from_camera (parameters). Cells
// whose source lies outside the grid start at the prior (l = 0). Without ego-motion (available =
// false) the camera is assumed static (T = identity) and the status says so.
//
// Clusters: cells with P > occupied_probability, 8-connected components (raster order, explicit
// stack), fewer than min_cluster_cells cells dropped. Each cluster's outline is the convex hull (gift
// wrapping: Jarvis, "On the identification of the convex hull of a finite set of points in the
// plane", Information Processing Letters 2(1), 1973) of its cells' corners in the picture plane: the
// camera's (x, z) in metres for the cartesian and polar grids, (u, d) for the column/disparity grid
// (corners shared by four cells of the cluster are interior and skipped).
// Obstacles: the likelihood's window spreads an object over +-3 sigma_Z in range (3 m at 25 m, 4.8 m
// at 31 m), so objects on one bearing a few metres apart share a cluster, and one obstacle from all
// its points would have its centre between them. So each cluster's cells that hold this frame's
// points (their means) are split into 8-connected groups, and each group into objects at their
// ranges. Along each column the evidence D (summed with the two neighbouring columns, so that a thin
// pole's column, which holds more smear than pole points, takes the depth of the board beside it)
// is the point density smoothed by the likelihood; its local maxima are where objects stand
// (Badino's obstacle position along a column, one per object on the bearing). Every cell holding
// points climbs along its column to the mode uphill of it (strictly increasing D; the mode's row).
// This needs columns that are rays (polar, column_disparity); a Cartesian column (constant x) holds a
// wall, a berm or a car's side running in depth as a ridge of evidence whose local maxima are not
// objects (mining seed 1, 68 frames: 279 instead of 243 Cartesian false positives along the berm),
// so the Cartesian grid keeps one mode per column (the group's row of highest D) and one object per
// group.
// Rays: a group's modes in the same or neighbouring columns whose rows differ by at most one window
// (window_sigmas row_sigma_at(farther mode) + row_cell), or whose ranges differ by at most
// min_depth_gap_m (1 m: one body's own depth, a car's bumper and windscreen, a pedestrian's front
// and back; near points' windows are centimetres, and junk a few metres ahead fell into pieces), are
// one object (union-find); a larger depth jump between neighbouring bearings, or a second mode
// further along a column, separates two objects (a pedestrian 2-4 m behind a parked car on one bearing: one obstacle for both had its
// centre between them, in neither's gate; bench/obstacles3d_eval, urban seed 1 frames 13-15). A
// surface seen obliquely (a car's side, 0.6 m of range per 0.01 rad bearing at 12 m) stays one
// object: its neighbouring modes are within the window. A point whose row coordinate lies more than
// window_sigmas of its own row sigma (plus half a cell) from its cell's mode is a mismatch smeared
// along its ray (a thin pole's or a border's disparity taken from the background) and is left out
// of the box, which it would stretch by metres. Every object of at least min_obstacle_points such
// inlier points gives an Obstacle3d (GridCluster: obstacle_index, obstacle_count): position = centre
// of the inliers' camera-frame bounding box (1 % left out at each end of x and z, obstacle_from_points), size =
// its extent, min/max height above the terrain,
// bbox_px from their pixels. Before that, each object is split at gaps in the image columns
// (split_at_column_gaps, min_column_gap_px, default 3 px): a run of at least that many left-image
// columns holding none of its points between two parts of it. Cells are 0.01 rad wide (5 px at
// f = 500 px) and 8-connected, so two objects whose points lie up to two cells (about 10 px) apart
// in the image join in one group and, at the same range, in one object (their modes within a
// window); the empty columns between them say they are two. A single object's points fill its
// columns (a column of it with no textured point over its whole height is rare), and stereo's
// fattening fills gaps narrower than a few pixels anyway. Then each part is cut once more where it
// occludes itself (split_at_range_peak, split_at_range_peaks): the median range of its points per
// image column is, for one convex object (a box, a car, a pedestrian), falling to its nearest point
// and rising again; an interior peak that both sides fall from by more than a window (window_sigmas
// sigma_Z at the peak plus a cell, at least min_depth_gap_m) is the far end of a surface with a
// nearer object beside it (urban: a car's side receding to 16 m, a pedestrian at 14.2 m next to it,
// 0.3-0.8 m from the side, the gap filled by stereo fattening so no column is empty;
// bench/obstacles3d_eval, urban, 60 frames: polar 98.5 -> 99.2 % on seed 2 and 96.4 -> 97.1 % on
// seed 3, the false positives added all in the frames of terrain-fit junk). Then at a step of its
// disparity profile (split_at_range_step, max_range_step_columns_px, default 4 px, 0 = off; see its
// comment): such a far end left at the edge of a part, beside a nearer object. Then each piece is cut
// once more where it is concave (split_at_concavity, min_concavity_px, default 0.5 px, 0 = off): the
// map (x, z) -> (u, d) = (u0 + f x / z, f B / z) is a projective map of the half-plane z > 0, so it
// takes lines to lines and convex sets to convex sets (a vertical plane's disparity is affine in u;
// Bleyer, Rhemann, Rother, "PatchMatch Stereo - Stereo Matching with Slanted Support Windows", BMVC
// 2011: a plane's disparity is d = a u + b v + c). The near side of one convex object (a box, a car
// seen at its corner, a pedestrian) is therefore the upper boundary of a convex set in (u, d): the
// median disparity per image column (of the columns holding at least 10 of its points: from fewer,
// the median follows the matcher's streaks and terraces; a low berm's columns hold 4-8) is a
// concave function of u. Where the profile dips under its
// concave envelope (its upper hull), the top view turns away from the camera and back: two objects
// meet there, the farther one's end in the pocket. The cut needs that dip to exceed
// min_concavity_px (0.5 px = 2 disparity_sigma_px; a column's median scatters 0.06 px about a planar
// face, so 8 of those) and min_depth_gap_m along the ray (f B / d - f B / d_envelope > 1 m, one
// body's own depth: at 5 m, 0.5 px is 8 cm). It is what separates a pedestrian touching the far end
// of a parked car's side in the image: the side's disparity falls linearly in u to its far end, the
// pedestrian's stays flat beside it, no column is empty and no range falls after the side's end (the
// occlusion cut's case), but the knee between them lies 0.6-2 px under the chord from the car's
// corner to the pedestrian's far edge (bench/obstacles3d_eval, urban, 60 frames, seeds 1-3: polar
// 99.3 / 99.2 / 97.1 -> 99.3 / 100.0 / 100.0 %, stixels 97.8 / 97.7 / 97.1 -> 99.3 / 99.2 / 100.0 %,
// false positives within 0.05 a frame). It also cuts a depth step down to a farther object beside a
// nearer one (the flat far part after the step lies under the chord), which the Cartesian grid's
// one object per group kept together. Parts under min_obstacle_points give no obstacle. A cluster
// with no such object (held only by memory, or a few scattered points) is kept (hull, cells) but
// gives no Obstacle3d (counted in clusters_without_points).
//
// Bad input: points with a non-finite position or disparity <= 0 are rejected; points whose mean
// lies outside the grid are clipped; both counted and reported in status(). An empty cloud is a
// frame with no evidence (memory decays). Parameters are validated on construction:
// std::invalid_argument "<parameter>: expected ..., got ...".
//
// Counted work (ArmWork, the chip's ARM model; a model of the operations, counted as they happen):
//   per point: 40 scalar ops (coordinates, covariance, window bounds) + 30 per window row (a normal
//     CDF from a 4097-entry table with linear interpolation, 8 ops; the truncated-normal mean with two
//     exp; the conditional column window) + 16 per window cell (a CDF lookup, the mass, the
//     accumulation), memory sizeof(ObstaclePoint) read + 8 bytes per window cell (evidence read and
//     written; the 32 KiB CDF table is taken as cache-resident). The uncorrelated grids
//     (column_disparity, polar) compute the column masses once per point (14 ops per window column)
//     and then 12 ops per window row and 4 per window cell (an outer product);
//   per cell: ego-motion resampling 20 ops (transform, rounding, bounds) + 8 bytes, when the motion
//     is available; update 24 ops (exp, log, clamp) + 12 bytes (evidence read, log-odds read and
//     written); clustering 12 ops + 1 byte, plus 10 ops per occupied cell (stack, 8 neighbours); the
//     point groups' components the same again (12 ops + 1 byte, 10 per cell holding points);
//   per cluster: 4 ops per cell corner (is it shared by four member cells?), hull 6 ops per
//     (remaining corner x hull vertex) visited;
//   per object: the column gap split's 4 ops + 2 bytes per inlier and 2 ops + 5 bytes per image
//     column between its smallest and largest u; the occlusion split's 6 ops + 8 bytes per point
//     and 12 ops + 24 bytes per column of each part; the concavity split's 6 ops + 8 bytes per point
//     and 20 ops + 20 bytes per column of each piece (counts, medians' bookkeeping, hull, depths);
//   per object: the range-step split's 6 ops + 8 bytes per point and 8 ops + 12 bytes per column;
//     the trimmed box's 16 ops + 8 bytes per point of an object of 100 points or more;
//   per point again: 10 ops + sizeof(ObstaclePoint) for the obstacles' statistics, and 12 ops for
//     the inlier test (its row mean and sigma, kept from the evidence pass, against its cell's
//     mode); 6 ops per cell holding points (rays: its mode looked up; Cartesian: its column's mode,
//     three columns' evidence summed and compared); rays also 8 ops per climbing step along a
//     column (two rows' three-column evidence sums, the comparisons; each cell climbed at most once
//     per frame) and 6 ops per pair
//     of a group's modes compared (columns, the window at the farther mode, the union), 20 more
//     when they lie beyond the window (the two cells' ranges: sin, cos or a division, a root).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "arm/obstacles3d/obstacle_points.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::obstacles3d {

enum class GridKind { cartesian, column_disparity, polar };
// Cells in memory as the cell index row * columns + column.
using GridMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
const char* grid_kind_name(GridKind kind);  // "cartesian", "coldisp", "polar" (the --method names)

// Throws std::invalid_argument "<name>: expected <expected>, got <actual>" (the parameter checks here
// and in augmented_stixels.h).
[[noreturn]] void throw_invalid_parameter(const std::string& name, const std::string& expected, double actual);

struct OccupancyGridParameters {
  GridKind kind = GridKind::polar;
  // Column axis: x_m (cartesian), u_px (column_disparity), theta_rad (polar).
  double column_min = -0.6, column_max = 0.6, column_cell = 0.01;
  // Row axis: z_m (cartesian), disparity_px (column_disparity), range_m (polar).
  double row_min = 0.5, row_max = 40.0, row_cell = 0.2;
  StereoErrorModel error_model;        // focal_px, baseline_m > 0 (the likelihoods)
  double principal_u_px = 0;           // u0 of the rectified left view (column_disparity cell -> 3D)
  double window_sigmas = 3.0;          // k: the likelihood's window, in [1, 6]
  double hit_probability_max = 0.85;   // p(D -> infinity), in (0.5, 1)
  double miss_probability = 0.45;      // p(D = 0), in (0, 0.5]
  double points_for_full_evidence = 2.0;  // D_full (> 0): expected points for 63 % of the way to hit_max
  double log_odds_min = -1.0, log_odds_max = 4.0;  // clamp, min < 0 < max (see the header comment)
  double occupied_probability = 0.65;  // a cell above it is occupied, in (0.5, 1)
  int min_cluster_cells = 1;           // >= 1
  int min_obstacle_points = 20;        // >= 1: a cluster's point group with fewer gives no obstacle
  // [0, 10] m: modes on neighbouring bearings closer than this in range are one object even beyond
  // a window (one body's own depth; near points' windows are centimetres). See the header comment.
  double min_depth_gap_m = 1.0;
  // [0, 64] image columns (px), 0 = off: an object whose points leave at least this many
  // consecutive left-image columns without a point is split there (split_at_column_gaps; see the
  // header comment). 3 px: stereo fills narrower gaps by fattening anyway, and a single object's
  // points leave no column wholly empty.
  int min_column_gap_px = 3;
  // The occlusion split (split_at_range_peak; see the header comment): an object whose range
  // profile over the image columns rises to a peak and falls again by more than a window is cut at
  // the peak. false: off.
  bool split_at_range_peaks = true;
  // The range-step split (split_at_range_step; see its comment): [0, 16] image columns (px), 0 = off.
  // An object whose range profile jumps by more than a window within this many columns, with at
  // least 3 measured columns on each side, is cut at the jump.
  int max_range_step_columns_px = 4;
  // The concavity split (split_at_concavity; see the header comment): [0, 8] disparity px, 0 = off.
  // A column whose median disparity lies more than this below the concave envelope of the object's
  // disparity profile over the image columns (and more than min_depth_gap_m behind it along its
  // ray) is where two objects meet. 0.5 px = 2 disparity_sigma_px, 8x the scatter of one column's
  // median about a planar face (0.06 px; bench/obstacles3d_eval, urban: a car's rear and side).
  double min_concavity_px = 0.5;
  int threads = 1;                     // 1..16: the evidence's points and the ego-motion resampling's rows dealt over this many threads (and the stixels' clusters)
  // V: the camera in the vehicle frame (arm::CameraToVehicle's rotation and translation). Default:
  // a level camera looking forward at the vehicle origin (arm::optical_to_body()).
  Eigen::Isometry3d vehicle_from_camera = level_camera();

  static Eigen::Isometry3d level_camera();
  // Defaults for each kind over a 640x480-class camera (f ~ 500 px, B ~ 0.3 m): cartesian x in
  // [-10, 10) m, z in [0.5, 40.5) m, 0.2 m cells; column_disparity u in [0, image_width_px) 4 px cells,
  // d in [0, 128) 0.5 px cells; polar theta in [-0.6, 0.6) rad, 0.01 rad cells, r in [0.5, 40.5) m,
  // 0.2 m cells. The caller sets error_model (and principal_u_px).
  static OccupancyGridParameters defaults(GridKind kind, int image_width_px = 640);
  // Throws std::invalid_argument "<parameter>: expected ..., got ..." (names like "row_cell").
  void validate() const;
  int columns() const;  // ceil((column_max - column_min) / column_cell)
  int rows() const;
};

// A cluster of occupied cells (see the header comment).
struct GridCluster {
  std::vector<int> cells;                 // row * columns + column
  std::vector<Eigen::Vector2d> hull;      // convex hull, counter-clockwise, picture plane
  int point_count = 0;                    // this frame's points in its cells
  int obstacle_index = -1;                // its first obstacle in OccupancyGrid::obstacles(), -1: none
  int obstacle_count = 0;                 // its obstacles are [obstacle_index, + obstacle_count)
};

struct OccupancyGridStatistics {
  int64_t points_in = 0;        // points given to update()
  int64_t points_used = 0;      // added as evidence
  int64_t points_clipped = 0;   // mean outside the grid's area
  int64_t points_rejected = 0;  // non-finite or disparity <= 0
  int clusters_without_points = 0;
  bool ego_motion_used = false;
};

// The Gaussian of one measurement in a grid's coordinates: mean (column, row) and covariance.
struct GridGaussian {
  Eigen::Vector2d mean;        // (column coordinate, row coordinate)
  Eigen::Matrix2d covariance;  // same order
};

// What an update describes after the fusion. occupancy_only leaves clusters() and obstacles() empty
// (and counts no work for them): for a user of the occupancy alone, the augmented stixels, which
// describe the obstacles from the cells' points themselves. The grid's clusters and obstacles were a
// third of the stixel method's instructions (callgrind, bench/obstacles3d_bench) and nothing read them.
enum class GridDescription { clusters_and_obstacles, occupancy_only };

class OccupancyGrid {
 public:
  explicit OccupancyGrid(const OccupancyGridParameters& parameters);  // validates

  // One frame: ego-motion compensation of the memory, this frame's evidence, fusion, clusters and
  // obstacles (unless occupancy_only). `points` are the frame's obstacle candidates.
  void update(const std::vector<ObstaclePoint>& points, const EgoMotion& ego_motion,
              GridDescription description = GridDescription::clusters_and_obstacles);
  void reset();  // back to the prior (l = 0 everywhere)

  const OccupancyGridParameters& parameters() const { return parameters_; }
  int rows() const { return rows_; }
  int columns() const { return columns_; }
  const GridMatrix& log_odds() const { return log_odds_; }        // rows x columns
  const GridMatrix& evidence() const { return evidence_; }        // D of the last frame
  float probability(int row, int column) const;
  bool occupied(int row, int column) const { return probability(row, column) > parameters_.occupied_probability; }
  const std::vector<GridCluster>& clusters() const { return clusters_; }
  const std::vector<Obstacle3d>& obstacles() const { return obstacles_; }
  const OccupancyGridStatistics& statistics() const { return statistics_; }
  // Per point of the last update(): its mean's cell (row * columns + column), -1 clipped or rejected.
  const std::vector<int>& point_cells() const { return point_cells_; }
  // One line: points used / clipped / rejected, clusters, obstacles, ego-motion or "static camera
  // assumed (no ego-motion)", "empty cloud" when there were no points.
  const std::string& status() const { return status_; }
  ArmWork work() const { return work_; }  // of the last update()

  // Geometry helpers (also used by the pictures and the stixels).
  GridGaussian measurement_gaussian(const ObstaclePoint& point) const;
  // The cell of grid coordinates (column coordinate, row coordinate); false outside.
  bool cell_of(double column_coordinate, double row_coordinate, int* row, int* column) const;
  // A grid coordinate pair (column, row) -> camera (x, z) in metres; for the column_disparity grid
  // through principal_u_px, focal and baseline (d <= 0 gives z = +inf).
  Eigen::Vector2d camera_xz_of(double column_coordinate, double row_coordinate) const;
  // Camera (x, z) -> grid coordinates (column, row).
  Eigen::Vector2d grid_coordinates_of(double x_m, double z_m) const;
  // The picture plane of the hulls: camera (x, z) for cartesian and polar, (u, d) for column_disparity.
  Eigen::Vector2d picture_plane_of(double column_coordinate, double row_coordinate) const;
  // Adds one measurement's Gaussian mass to `evidence` (rows x columns); returns the mass added.
  // Exposed for the tests (a single point's likelihood).
  double add_likelihood(const GridGaussian& gaussian, GridMatrix& evidence, ArmWork* work) const;
  // The standard deviation of a measurement's row coordinate at the centre of cell (row, column):
  // sigma_Z (cartesian), sigma_d (column_disparity), sigma_Z / cos theta (polar).
  double row_sigma_at(int row, int column) const;

 private:
  void compensate_ego_motion(const EgoMotion& ego_motion);
  void cluster_and_describe(const std::vector<ObstaclePoint>& points);

  OccupancyGridParameters parameters_;
  int rows_ = 0, columns_ = 0;
  GridMatrix log_odds_, evidence_;
  std::vector<GridCluster> clusters_;
  std::vector<Obstacle3d> obstacles_;
  std::vector<int> point_cells_;
  // Each used point's measurement along the grid's row axis (mean, standard deviation), kept from
  // update() for the depth-jump split, which would otherwise compute the Gaussian (an atan2 and a
  // square root per point on the polar grid) a second time.
  std::vector<double> point_row_means_, point_row_sigmas_;
  OccupancyGridStatistics statistics_;
  std::string status_;
  ArmWork work_;
};

// Convex hull by gift wrapping (Jarvis march, 1973): the extreme vertices counter-clockwise (y up)
// from the lowest-leftmost point; points on a hull edge between two vertices and duplicates are not
// vertices. Degenerate sets: 0 points -> empty, all equal -> 1 point, all collinear -> the 2 ends.
// O(n h). `work` (optional) gets 6 scalar ops per point examined per hull vertex.
std::vector<Eigen::Vector2d> gift_wrapping_hull(const std::vector<Eigen::Vector2d>& points, ArmWork* work = nullptr);

// 8-connected components of `mask` (rows x columns, row-major, nonzero = member) in raster order;
// returns each component's cells (row * columns + column), components smaller than min_cells dropped.
// `labels` (optional) gets the component index per cell, -1 for none. `work` gets 12 ops and 1 byte
// per cell plus 10 ops per member cell.
std::vector<std::vector<int>> connected_components_8(const std::vector<uint8_t>& mask, int rows, int columns,
                                                     int min_cells, std::vector<int>* labels, ArmWork* work);

// The image-column gap split (see the header comment): `indices` (points of one object) split where
// at least min_column_gap_px consecutive left-image columns (u_px) between their smallest and largest
// u hold none of them; parts in increasing u, each point in the part of its column, the order of
// `indices` kept within a part. min_column_gap_px <= 0 or no such gap: one part, `indices` itself.
// `work` (optional) gets 4 ops and 2 bytes per point (the column mark, the part look-up) and 2 ops
// and 5 bytes per column spanned (the scan, the mark and the part index).
std::vector<std::vector<int>> split_at_column_gaps(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                   int min_column_gap_px, ArmWork* work = nullptr);

// The occlusion split (see the header comment): the range profile of `indices` over the left-image
// columns is the median range sqrt(x^2 + z^2) of each column holding at least 3 of them. A convex
// object's profile falls to its nearest point and rises again, with no interior maximum; a range
// peak that both sides fall from by more than max(window_sigmas sigma_Z(peak) + row_cell_m,
// min_depth_gap_m) is the far end of a surface occluded by a nearer object beside it. The points
// are cut once, at the most prominent such peak: columns up to the peak (it goes with its nearer
// neighbour's side) and after it, each part in the order of `indices`. None: one part, `indices`.
// `work` (optional) gets 6 ops and 8 bytes per point (its column, its range, the median selection)
// and 12 ops and 24 bytes per column spanned (the prefix and suffix minima, the prominence).
std::vector<std::vector<int>> split_at_range_peak(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                  const StereoErrorModel& error_model, double window_sigmas, double row_cell_m,
                                                  double min_depth_gap_m, ArmWork* work = nullptr);

// The range-step split: the disparity profile of `indices` over the left-image columns is the
// median disparity_px of each column holding at least 10 of them (as the concavity split's, for the
// same reason: from fewer it follows the matcher's streaks). The occlusion split needs a range peak
// with both sides falling; after the column-gap split has cut a far surface apart, its end can be
// left at the edge of a part with a nearer object beside it, the columns between them filled by
// stereo fattening (urban: a parked car's side receding to 15 m, a pedestrian at 12.7 m beside its
// far end, one obstacle whose centre lay 1.3 m behind the pedestrian, outside its gate). Where the
// depths f B / d of two measured columns at most max_step_columns_px apart differ by more than
// max(window_sigmas sigma_Z(the farther) + row_cell_m, min_depth_gap_m), their disparities by more
// than 5 disparity_sigma_px (SGM's terraces on one surface step by up to 1 px), and at least 3
// measured columns lie on each side, two surfaces meet: one object's surface seen obliquely changes
// depth by a fraction of that over a few columns (a car's side at 12-16 m: 0.08 m per column). The
// points are cut once, at the largest such jump (its excess over the depth threshold), after the
// column of the largest change between consecutive measured columns inside it; each part in the
// order of `indices`. None or max_step_columns_px <= 0: one part, `indices`. `work` (optional) gets
// 6 ops and 8 bytes per point (its column, its disparity, the median selection) and 8 ops and 12
// bytes per column spanned.
std::vector<std::vector<int>> split_at_range_step(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                  const StereoErrorModel& error_model, double window_sigmas, double row_cell_m,
                                                  double min_depth_gap_m, int max_step_columns_px, ArmWork* work = nullptr);

// The concavity split (see the header comment): the disparity profile of `indices` over the
// left-image columns is the median disparity_px of each column holding at least 10 of them (from
// fewer it follows the matcher's row-correlated streaks: SGM's terraces on a low surface seen at a
// grazing angle are a concavity at every step; occupancy_grid.cpp, kMinPointsPerConcavityColumn).
// One convex object's profile is a concave function of u (the upper boundary of the object's image
// in (u, d), which is convex); a column lying more than min_concavity_px below the profile's concave
// envelope (its upper hull) and more than min_depth_gap_m behind it along its ray (f B / d - f B /
// d_envelope) is where two objects meet. The points are cut once, at the column deepest in pixels
// beyond min_concavity_px: the columns up to it (it goes with the neighbour nearer to it in
// disparity) and after it, each part in the order of `indices`. None, fewer than 30 points, or
// min_concavity_px <= 0: one part, `indices`. `work` (optional) gets 6 ops and 8 bytes per point (its
// column, its disparity, the median selection) and 20 ops and 20 bytes per column spanned (the
// counts, the profile, the hull, the depth).
std::vector<std::vector<int>> split_at_concavity(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                                 const StereoErrorModel& error_model, double min_concavity_px, double min_depth_gap_m,
                                                 ArmWork* work = nullptr);

// The four cuts as the grids and the stixels apply them to one object's points: split_at_column_gaps
// (parameters.min_column_gap_px), then, when parameters.split_at_range_peaks, split_at_range_peak on
// each part with the grid's error model, window and row cell (0 for the column/disparity grid, whose
// rows are disparities, not metres) and min_depth_gap_m, then, when parameters.max_range_step_columns_px
// > 0, split_at_range_step on each piece (the same window), then, when parameters.min_concavity_px > 0,
// split_at_concavity on each piece (min_concavity_px, min_depth_gap_m). Parts in that order; `work`
// gets the cuts'.
std::vector<std::vector<int>> split_object(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices,
                                           const OccupancyGridParameters& parameters, ArmWork* work = nullptr);

// An Obstacle3d from points (camera-frame bounding box centre and extent, height range, pixel box).
// The box leaves out 1 % of the points (rounded down) at each end of x and of z: a few mismatches
// chained into an object through neighbouring modes (22 of a board's 3754 points 2 m behind it,
// bench/obstacles3d_eval floating seed 2 frame 58) stretched it by metres along the ray and moved
// its centre out of the object's gate; its vertical extent, the height range and the pixel box keep
// every point. `indices` selects the points; empty selection -> nothing changed but id. Used by the
// grids and the stixels. `work` (optional) gets the trimmed box's 16 ops and 8 bytes per point (two
// axes copied, two selections each) when it leaves any point out (100 points or more).
Obstacle3d obstacle_from_points(const std::vector<ObstaclePoint>& points, const std::vector<int>& indices, int id,
                                ArmWork* work = nullptr);

}  // namespace lpstereo::arm::obstacles3d
