// Terrain estimation for any ground (issue 9; thesis 004, the B-spline terrain model): the public
// contract shared by the fit (arm/terrain/*.cpp), the `lpstereo terrain` command, the terrain graph's
// ARM task, the synthetic evaluations and the 3D obstacle representations of issue 10.
//
// Frame: the vehicle frame of arm/point_cloud.h (x forward, y left, z up, metres; ISO 8855). The
// terrain is a height field z = S(x, y) over a rectangular area of that frame. A camera mounted with
// roll and pitch is handled by converting its points with arm::CameraToVehicle first: the fit never
// assumes a flat or level road.
//
// Pipeline (issue 9 deliverables 1-4):
//   points (vehicle frame) -> HeightGridAccumulator (2.5D sampling: per cell count, min, mean, sigma
//   of z) -> HeightGrid (cell height Z = max(min z, mean z - sigma), or by default sigma less the
//   row's stereo noise floor (height_grid.cpp), empty cells filled from the mean
//   of measured 8-neighbours, else invalid) -> fit_terrain (iterative re-weighted B-spline fit with
//   equalisation) -> TerrainEstimate (surface, per-cell weights) -> compute_traversability (slope
//   from the surface's derivatives, cost Tc = w_occ occupancy + w_slope |grad S|) and
//   classify_points (height above the surface > obstacle threshold: obstacle candidates).
//
// Unknown terrain: a fit that cannot be trusted (too few valid cells, all cells on one line, the
// system singular, non-finite input) returns known = false with one line in `reason` and never a
// made-up surface; every consumer must check `known`.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dag/arm_task.h"

namespace lpstereo::arm::terrain {

// The area and its cells. Cell (i, j): i along x (forward), j along y (lateral); cell (i, j) covers
// x in [forward_min_m + i cell_m, forward_min_m + (i + 1) cell_m), y likewise from lateral_min_m.
struct TerrainGridSpec {
  double forward_min_m = 0.0;    // x range of the area
  double forward_max_m = 34.0;
  double lateral_min_m = -11.0;  // y range (y left)
  double lateral_max_m = 11.0;
  double cell_m = 0.5;           // > 0
  // The 2.5D sampling's cell rule (arm/terrain/height_grid.cpp has the model and the figures):
  // thesis = eq. 3.2, Z = max(min z, mean z - sigma); noise_floor = the spread subtracted is only the
  // part in excess of the stereo noise of the cell's range, Z = max(min z, mean z - sqrt(max(0,
  // sigma^2 - sigma_noise^2))), sigma_noise the noise_floor_quantile of the measured cells' sigma over
  // the cell's forward row and its two neighbours (cells at one range share the stereo noise).
  enum class CellRule : uint8_t { thesis, noise_floor };
  CellRule cell_rule = CellRule::noise_floor;
  double noise_floor_quantile = 0.5;  // in [0, 1]
  // The vertical-gap rule (height_grid.cpp has the model): > 0, a cell's heights sorted up from the
  // lowest are cut at the first gap wider than vertical_gap_m between consecutive heights that has
  // at least kVerticalGapMinPoints points under it, and the points above it (a hanging sign, a
  // board or a branch over visible ground) are left out of the cell rule's count, mean, sigma and
  // min; 0 = off (every point counts, the thesis's eq. 3.2 input), the default: it also keeps the
  // lower level of a step whose face is hidden (a ditch's near wall). Finite, >= 0; 0.5 m measured.
  double vertical_gap_m = 0.0;
  // Occlusion-aware sampling (height_grid.cpp has the model): with it, a point may come with the
  // flag "over an occluder" (its image column continues downwards, along its own surface, into a
  // nearer surface: arm::pixels_over_occluder), and a measured cell whose lowest point carries the
  // flag did not see its own ground: its sample is marked in HeightGrid::upper_bound, and
  // fit_terrain treats it one-sided (TerrainFitParameters::upper_bound_tolerance_m). An empty cell
  // filled only from such cells is marked too. false (default): no flags, every sample two-sided.
  // Off because it measured no better: issue 10's floating scene, stixels' lower edge within 10 cm
  // 86.6 / 84.8 / 79.1 -> 83.1 / 83.4 / 77.1 % (seeds 1-3, 100 frames; the sign's island is set
  // aside, but the board's shadow is then a hole the spline extrapolates, 0.2-0.4 m off); issue 9's
  // 15 scenes, mean RMS within 20 m 5.91 -> 6.23 cm (better on 8, worse on 7); docs/obstacles3d.md,
  // docs/terrain.md.
  bool occlusion_upper_bounds = false;

  int forward_cells() const;  // ceil((forward_max_m - forward_min_m) / cell_m)
  int lateral_cells() const;
  // The cell holding (x, y), or false outside the area (or non-finite).
  bool cell_of(double x_m, double y_m, int* forward_cell, int* lateral_cell) const;
  // The same cell, with the counts forward_cells() and lateral_cells() given: they cost two divides a
  // call, which a loop over every point of a frame computes once.
  bool cell_of(double x_m, double y_m, int forward_cells, int lateral_cells, int* forward_cell, int* lateral_cell) const;
  double cell_centre_x_m(int forward_cell) const;
  double cell_centre_y_m(int lateral_cell) const;
  // Throws std::invalid_argument "<name>: expected ..., got ..." for a bad area or cell size.
  void validate() const;
};

// The 2.5D grid (deliverable 1). Matrices are forward_cells x lateral_cells (row i, column j).
struct HeightGrid {
  TerrainGridSpec spec;
  Eigen::MatrixXd height_m;     // cell height Z; NaN where invalid
  Eigen::MatrixXi point_count;  // points binned into the cell (0 for filled or invalid cells)
  Eigen::MatrixXi state;        // kCellMeasured, kCellFilled or kCellInvalid
  // 1 where the cell's height is only an upper bound on the ground (TerrainGridSpec::
  // occlusion_upper_bounds: its lowest point lies over a nearer occluder in the image, or the cell is
  // filled from such cells only), else 0. Empty (0 x 0) = no cell marked (a grid built by hand, or
  // the rule off).
  Eigen::MatrixXi upper_bound;
  // The highest point binned into each cell (vehicle-frame z, metres); NaN where none was (filled
  // and invalid cells). Read by the fit's obstacle refit (TerrainFitParameters::
  // obstacle_refit_height_m). Empty (0 x 0) = not recorded (a grid built by hand): the refit then
  // reads height_m.
  Eigen::MatrixXd max_height_m;
  int valid_cells() const;      // measured + filled
};
inline constexpr int kCellInvalid = 0, kCellMeasured = 1, kCellFilled = 2;
// The vertical-gap rule cuts only above a group of at least this many points (a few low mismatches
// under the ground must not replace it).
inline constexpr int kVerticalGapMinPoints = 4;

// Accumulates points one at a time (the ARM side of the binning: the vector kernel gives each point
// its cell, this sums them), then finish() applies the cell rule and the neighbour fill.
class HeightGridAccumulator {
 public:
  explicit HeightGridAccumulator(const TerrainGridSpec& spec);  // validates spec
  // Bins a vehicle-frame point; false (and counted in rejected()) when outside the area or not finite.
  // over_occluder: the point's pixel lies over a nearer occluder (arm::pixels_over_occluder); read
  // only with TerrainGridSpec::occlusion_upper_bounds.
  bool add_point(const Eigen::Vector3d& point_vehicle_m, bool over_occluder = false);
  // A point whose cell is already known (from the binning kernel); cells outside the grid are rejected.
  bool add_to_cell(int forward_cell, int lateral_cell, double z_m, bool over_occluder = false);
  int64_t accepted() const { return accepted_; }
  int64_t rejected() const { return rejected_; }
  HeightGrid finish() const;
  // Work counted for the chip model (ArmWork units, documented in the implementation's header comment).
  ArmWork work() const;

 private:
  void accumulate(int forward_cell, int lateral_cell, double z_m, bool over_occluder);

  TerrainGridSpec spec_;
  Eigen::MatrixXi count_;
  Eigen::MatrixXd sum_z_, sum_z2_, min_z_, max_z_;
  // With occlusion_upper_bounds: 1 when the cell's lowest point so far (min_z_) is over an occluder.
  Eigen::MatrixXi lowest_over_occluder_;
  // With the vertical-gap rule: every accepted point's cell (row-major index) and height, for
  // finish()'s per-cell sort; empty when the rule is off.
  std::vector<int32_t> point_cell_;
  std::vector<float> point_z_m_;
  int64_t accepted_ = 0, rejected_ = 0;
  int64_t add_point_calls_ = 0, add_to_cell_calls_ = 0;  // for work()
};

// A tensor-product B-spline surface z = S(x, y) (deliverable 2): degrees, clamped uniform knot
// vectors over the area, control points (forward_control x lateral_control), optional weights for the
// rational form (empty = polynomial).
struct BsplineSurface {
  int degree_forward = 3, degree_lateral = 3;
  std::vector<double> knots_forward_m, knots_lateral_m;  // clamped uniform, n + degree + 1 knots each
  Eigen::MatrixXd control_z_m;                           // n0 x n1 control heights
  Eigen::MatrixXd control_weights;                       // n0 x n1 or empty
  double forward_min_m = 0, forward_max_m = 0, lateral_min_m = 0, lateral_max_m = 0;  // the domain

  bool contains(double x_m, double y_m) const;
  double height_m(double x_m, double y_m) const;  // NaN outside the domain
  // dS/dx and dS/dy (dimensionless slopes); NaN outside the domain.
  Eigen::Vector2d gradient(double x_m, double y_m) const;
};

// The counted scalar operations of one S(x, y) evaluation on the ARM side (ArmWork): the basis
// values of both axes by the Cox-de Boor triangle, 6 d (d + 1) each, the (d0 + 1)(d1 + 1) tensor
// product's multiply-adds, and 8 for the subtraction and compare around it. The model the callers
// that evaluate the surface per point count with (the ARM task augmented_stixels, LocalGround).
uint64_t surface_evaluation_ops(int degree_forward, int degree_lateral);

// B-spline basis helpers (arm/terrain/bspline_surface.cpp; Cox-de Boor, thesis eq. 3.4-3.5).
// Clamped uniform knots: degree + 1 copies of each end, control_points - degree - 1 interior knots
// evenly spaced. Throws std::invalid_argument unless control_points > degree >= 1 and min_m < max_m.
std::vector<double> clamped_uniform_knots(int control_points, int degree, double min_m, double max_m);
// The knot span s with knots[s] <= t < knots[s + 1] (the last non-empty span for t == the domain's
// end; t is clamped into the domain). The non-zero basis functions at t are N_{s-degree..s}.
int knot_span(const std::vector<double>& knots, int degree, double t);
// The degree + 1 non-zero basis values N_{span-degree+r,degree}(t), r = 0..degree, and optionally
// their first derivatives (same indexing; may be null), by the Cox-de Boor triangle.
void basis_functions(const std::vector<double>& knots, int degree, int span, double t, double* values,
                     double* derivatives);
// One basis function N_{index,degree}(t) straight from the recursion (eq. 3.4, 3.5), with 0/0 = 0
// and the right end of the domain belonging to the last span. Slow; for tests and checks.
double basis_function_recursive(const std::vector<double>& knots, int index, int degree, double t);
// Rows: the basis values (or with derivative = true their first derivatives) of each sample position,
// dense (samples x control points; degree + 1 non-zeros per row).
Eigen::MatrixXd basis_matrix(const std::vector<double>& knots, int degree, const std::vector<double>& samples,
                             bool derivative = false);
// The surface's heights at every cell centre of `spec` (forward_cells x lateral_cells), by the
// tensor product: B0 (R o Q) B1^T / B0 R B1^T. Cells whose centre lies outside the domain are NaN.
Eigen::MatrixXd surface_heights_at_cells(const BsplineSurface& surface, const TerrainGridSpec& spec);

struct TerrainFitParameters {
  int degree_forward = 3, degree_lateral = 3;
  int control_forward = 25, control_lateral = 25;   // n_max: the final fit's control points
  int initial_control_forward = 5, initial_control_lateral = 5;  // the first iteration's
  // Re-weighting iterations before the final fit; the control points grow from initial to n_max
  // over them (20: one per axis per iteration from 5 to 25, the thesis's schedule).
  int max_iterations = 20;
  double threshold_factor = 1.0;   // th(e) = threshold_factor * e, e the mean absolute error
  double alpha_initial = 1.0;      // alpha of the first iteration, growing by alpha_step per iteration
  double alpha_step = 1.0;
  // Tikhonov term on the control points (keeps empty spans solvable and control points that few
  // samples touch bounded), relative to the normal equations' mean diagonal; terrain_fit.cpp has the
  // form. It biases an exact fit by about regularisation x the surface's slope x the area (a 10 %
  // plane over 34 m x 22 m: under 0.5 mm at 3e-4). 3e-4: the former 1e-8 let the weighted fit run
  // away on grids with holes (terrain_fit_test: 8-315 m off at seen cells; bench/terrain_synth_eval
  // at 640x480 with uniqueness 35: up to 17 m RMS within 20 m); 3e-4 measured RMS within 20 m
  // 6.45 -> 5.91 cm, within 34 m 19 -> 11 cm, precision 92.8 -> 93.2 %, recall 95.6 -> 96.2 %
  // (means of 15 scenes; docs/terrain.md has 1e-4 .. 3e-2).
  double regularisation = 3e-4;
  // The membrane over holes (terrain_fit.cpp has the model and the figures): a first-difference
  // term, relative to the normal equations' mean diagonal, between control points that the samples
  // hardly touch, so a region with no ground sample (the road hidden behind a board) is held at the
  // level of the ground around it. Finite, >= 0; 0 = off (default: issue 9's terrain scenes measured
  // 5.91 -> 6.10 cm RMS within 20 m with 1); the obstacle candidates use 1.
  double hole_membrane = 0.0;
  int min_valid_cells = 16;        // fewer: unknown terrain
  // Added by the implementation (arm/terrain/terrain_fit.cpp explains each):
  double maximum_weight = 1000.0;         // eq. 3.6 caps here (|dz| -> 0 would give an infinite weight)
  double equalisation_tolerance_m = 0.001; // samples less than this above the surface are not equalised
  // Nor those less than this x th(e) above it (0: every sample above, as the thesis). 3 keeps the
  // noise and the smooth bumps the coarse first surfaces cannot follow (hills, banks) from being
  // shaved off (terrain_fit.cpp has the figures).
  double equalisation_threshold_factor = 3.0;
  // Step-limited equalisation (not in the thesis; terrain_fit.cpp has the model and the figures): a
  // sample more than equalisation_step_m above the surface is equalised only when it lies within
  // equalisation_step_reach_cells cells (8-connected, over valid cells) of an edge cell, a cell more
  // than equalisation_step_m above one of its 4 neighbours in the input grid; samples less high are
  // equalised as the thesis does. Ground rises by at most (steepest slope x cell) between neighbours
  // (a 0.8 m x 3 m raised-cosine berm: 0.42 m at 0.5 m cells) while an obstacle stands up within a
  // cell, so a tall smooth bump is left to the re-weighting and only what has a vertical side is cut
  // down. 0 (default): every sample (the thesis). 0.45 is the measured setting (terrain_synth_eval
  // uses it); off by default because issue 10's candidates, which share this fit, got slightly more
  // false positives in urban scenes with it (docs/terrain.md).
  double equalisation_step_m = 0.0;
  int equalisation_step_reach_cells = 4;
  // Patch limit of the step rule (only with equalisation_step_m > 0; terrain_fit.cpp has the model):
  // a sample at most equalisation_step_m above the surface and away from every edge cell is equalised
  // only when its patch, the 4-connected cells above the equalisation threshold in that iteration,
  // has at most this many cells: a mixed cell of a narrow box or a rough-ground bump forms a small
  // patch and is cut, the crest of a long berm or a hill forms a large one and is left to the
  // re-weighting. 0 (default): no limit (every such sample, as before).
  int equalisation_patch_max_cells = 0;
  // One-sided samples (only for the cells of HeightGrid::upper_bound; terrain_fit.cpp has the model):
  // such a sample is an upper bound on the ground, so in each iteration one more than this above
  // the surface is set aside (weight 0, not equalised, left out of the mean error), one below or
  // within it counts as any sample. A few times the cell samples' stereo noise (2-5 cm within 20 m
  // at 640 px), so noisy ground seen behind an object is not pushed low. Finite, >= 0.
  double upper_bound_tolerance_m = 0.15;
  // Eq. 3.7: never_overshoot = Z -= dz W / (W + 1) (the thesis's prose: moved towards the surface,
  // never past it); as_printed = Z -= dz (1 + 1/W) (the formula as the text conversion prints it,
  // which puts the sample below the surface; kept to show the difference in bench/terrain_bench).
  enum class Equalisation : uint8_t { never_overshoot, as_printed };
  Equalisation equalisation = Equalisation::never_overshoot;
  // Obstacle refit (not in the thesis; terrain_fit.cpp has the model and the figures): after the fit,
  // the cells whose highest point stands more than this above the surface are left out and the fit
  // runs again, so a large obstacle's footprint is bridged from the ground around it instead of
  // holding the surface up under it. Finite, >= 0 (metres); 0 (default): off, the thesis's single
  // fit. Measured at 0.45 (bench/terrain_synth_eval --obstacle-refit-m 0.45): it mends the surface
  // under large obstacles but moves as many scenes out of issue 9's line as into it, so it is off.
  double obstacle_refit_height_m = 0.0;
};

struct TerrainEstimate {
  bool known = false;
  std::string reason;              // one line when !known
  BsplineSurface surface;
  HeightGrid grid;                 // the input grid after equalisation
  Eigen::MatrixXd weights;         // final per-cell weights (0 for invalid cells)
  int iterations = 0;              // re-weighting iterations run (both fits' with the obstacle refit)
  int equalised_cells_last = 0;    // cells pulled down in the last iteration
  double mean_abs_error_m = 0;     // over valid cells, final fit
  int obstacle_refit_left_out_cells = 0;  // cells the obstacle refit left out (0: no refit made)
  ArmWork work;                    // counted, for the chip model
};

// The iterative re-weighted fit with equalisation (deliverable 3). Never throws on data; throws
// std::invalid_argument for parameters out of range (naming the parameter, range and value).
TerrainEstimate fit_terrain(const HeightGrid& grid, const TerrainFitParameters& parameters);

struct TraversabilityParameters {
  double occupancy_weight = 1.0;  // w_occ
  double slope_weight = 1.0;      // w_slope (per unit of |grad S|)
  double obstacle_height_m = 0.2; // a cell is occupied when its measured height is this far above S
};

struct TraversabilityMap {
  Eigen::MatrixXd slope;      // |grad S| at cell centres, NaN where unknown
  Eigen::MatrixXd occupancy;  // 0 or 1 (cell height - S > obstacle_height_m), NaN where unknown
  Eigen::MatrixXd cost;       // w_occ occupancy + w_slope slope, NaN where unknown
  ArmWork work;
};

// Deliverable 4. `measured` is the grid before equalisation (what fit_terrain took).
TraversabilityMap compute_traversability(const TerrainEstimate& terrain, const HeightGrid& measured,
                                         const TraversabilityParameters& parameters);

enum class PointClass : uint8_t { outside = 0, terrain = 1, obstacle = 2 };
// Each point by its height above the surface: obstacle when > obstacle_height_m, terrain otherwise,
// outside when the surface does not cover it (or terrain unknown, or the point is not finite).
std::vector<PointClass> classify_points(const std::vector<Eigen::Vector3d>& points_vehicle_m, const TerrainEstimate& terrain,
                                        double obstacle_height_m);

// The stereo camera the points came from, for a classification that allows for the disparity's
// uncertainty: a stereo point moves along its viewing ray when its disparity changes.
struct StereoRayModel {
  Eigen::Vector3d camera_centre_m = Eigen::Vector3d::Zero();         // left camera centre, vehicle frame
  Eigen::Vector3d optical_axis = Eigen::Vector3d::UnitX();           // unit, vehicle frame (R C (0, 0, 1))
  double focal_baseline_px_m = 0;                                    // f B (> 0): disparity = f B / depth
  double disparity_margin_px = 1.0;                                  // >= 0
  // Support (hysteresis, like Canny's two thresholds): a candidate that falls back is kept as an
  // obstacle when a candidate that stood the push lies in its grid cell (terrain.grid.spec) or within
  // this many cells (Chebyshev) of it: an obstacle's low points beside its sure ones stay, an isolated
  // ground point lifted by a disparity error does not. -1: off (every point that falls back is terrain).
  int support_reach_cells = -1;
};
// As above, but a point is an obstacle only when it would still be more than obstacle_height_m above
// the surface with its disparity disparity_margin_px smaller (the point pushed away along its ray to
// depth f B / (d - margin); a ground point that stereo placed too near, hence too high, falls back
// onto the surface; terrain when d <= margin). Throws std::invalid_argument for a bad model.
std::vector<PointClass> classify_points(const std::vector<Eigen::Vector3d>& points_vehicle_m, const TerrainEstimate& terrain,
                                        double obstacle_height_m, const StereoRayModel& stereo);

}  // namespace lpstereo::arm::terrain
