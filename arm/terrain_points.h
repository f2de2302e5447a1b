// Camera points to the terrain model (issue 9): the glue the `lpstereo terrain` command, the terrain
// evaluations and the KITTI acceptance share, between the disparity_to_points planes (arm/point_cloud.h)
// and arm/terrain/terrain_model.h.
//
//   estimate_ground_mount  the camera mount (height, pitch, roll) from a RANSAC plane through the
//                          points of the lower image half, for a camera whose mount is not given;
//   bin_points             the point_cell_binning kernel (kernels/point_cell_binning.cpp) over the
//                          three planes with the mount's rotation in Q14 and the grid's area in mm;
//   accumulate_binned      its two planes summed into a HeightGridAccumulator (add_to_cell).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "arm/point_cloud.h"
#include "arm/terrain/terrain_model.h"
#include "dag/plane.h"
#include "dag/tile_executor.h"

namespace lpstereo::arm {

struct GroundMountEstimate {
  bool found = false;
  std::string reason;        // one line when !found
  CameraMount mount;         // yaw 0, position (0, 0, camera height)
  double camera_height_m = 0;
  int inliers = 0, candidates = 0;
};

struct GroundMountSettings {
  double min_depth_m = 1.0, max_depth_m = 40.0;  // camera z of the points considered
  double inlier_distance_m = 0.1;                // RANSAC band about the plane
  int iterations = 300;
  int max_candidates = 20000;                    // points sampled (a regular stride over the lower half)
  double max_tilt_rad = 0.5;                     // the plane's normal within this of the camera's -y
  double min_height_m = 0.2, max_height_m = 10.0;
  double min_inlier_share = 0.25;                // of the candidates
  int min_inliers = 200;
};

// RANSAC (Fischler and Bolles 1981; 3-point planes drawn by a fixed LCG, deterministic) then least
// squares (the inliers' centroid and smallest principal axis). Ground plane n . p + h = 0 in the camera
// frame with n the upward unit normal (n_y < 0) and h the camera height; with yaw 0 the mount of
// arm/point_cloud.h has n = (-sin r cos p, -cos r cos p, -sin p), so pitch = asin(-n_z), roll =
// atan2(-n_x, -n_y). A wall, the sky or too few points fail the plausibility gate: found = false.
GroundMountEstimate estimate_ground_mount(const CameraPoints& points, const GroundMountSettings& settings = {});

// The kernel's parameters for a mount and a grid: R C in Q14 (round(16384 r)), T in mm, the area in mm.
nlohmann::json binning_params(const CameraToVehicle& to_vehicle, const terrain::TerrainGridSpec& grid);

struct BinnedPoints {
  Plane cell, height_mm;  // kernels/point_cell_binning.h
};
// Throws KernelError (naming the parameter) when the grid or the mount is outside the kernel's range.
BinnedPoints bin_points(const CameraPoints& points, const CameraToVehicle& to_vehicle, const terrain::TerrainGridSpec& grid,
                        KernelBackend backend = KernelBackend::native);

// Every pixel with a cell into the accumulator (heights in metres); `grid` is the binning's and the
// accumulator's. over_occluder (may be null): pixels_over_occluder's flags of the same pixels.
void accumulate_binned(const BinnedPoints& binned, const terrain::TerrainGridSpec& grid, terrain::HeightGridAccumulator& accumulator,
                       const std::vector<uint8_t>* over_occluder = nullptr);

// A grid whose points lie in fewer than min_rows forward rows or fewer than min_columns lateral
// columns of cells (a row or column counting when it holds at least 1 % of the points) has no
// ground extent to fit: a wall filling the view bins into one or two forward rows (its distance),
// a single line of points into one row or column. The fill would widen such a strip and the fit
// would then return a made-up surface. Returns the one-line reason, or empty when the extent is enough.
std::string ground_extent_problem(const terrain::HeightGrid& grid, int min_rows = 4, int min_columns = 4);

// Foreground fattening at depth discontinuities (a window matcher gives the background pixels next
// to a nearer object the object's disparity; Hirschmueller and Scharstein 2009, §2; Scharstein and
// Szeliski 2002, §5.2 "depth discontinuity" regions): invalidates, in place, every valid pixel of
// disparity_q4 (s16 Q4) with a valid pixel within radius_px (square window) whose disparity is more
// than jump_px smaller, i.e. the near side of every jump of more than jump_px, radius_px wide. Their
// 3D points would stand in the air beside the object, above any ground surface: the false obstacle
// points of terrain segmentation. A ground surface seen by a level camera 1.5 m up changes its
// disparity by baseline / height = 0.2 px a row, far below the jump. Returns the pixels invalidated.
// Throws std::invalid_argument unless radius_px >= 1 and jump_px > 0, or for a non-s16 plane.
int64_t invalidate_near_side_of_discontinuities(Plane& disparity_q4, int16_t invalid_q4, int radius_px, double jump_px);

// The filter's settings as the terrain uses them: `lpstereo terrain`, bench/terrain_synth_eval and
// bench/terrain_kitti_eval (docs/terrain.md, "invalidate_near_side_of_discontinuities": most
// fattened ground points lay within 3 px of their object; a flat ground seen from 1.5 m changes by
// 0.2 px a row, far below the 2 px jump). radius_px 0 turns it off.
struct DiscontinuityFilter {
  int radius_px = 3;
  double jump_px = 2.0;
  // invalidate_near_side_of_discontinuities with these settings, in place; radius_px 0 leaves the
  // map as it is. Returns the pixels invalidated.
  int64_t apply(Plane& disparity_q4, int16_t invalid_q4) const {
    return radius_px > 0 ? invalidate_near_side_of_discontinuities(disparity_q4, invalid_q4, radius_px, jump_px) : 0;
  }
};

// The image test of the occlusion-aware terrain sampling (terrain::TerrainGridSpec::
// occlusion_upper_bounds; arm/terrain/height_grid.cpp has the model). A valid pixel p lies "over an
// occluder" when, within rows_below_px rows below it in its image column, there is the top of a
// nearer surface: a valid pixel q whose disparity is more than jump_px larger than that of the next
// valid pixel above q (a jump up between neighbours, invalid pixels stepped over) and more than
// jump_px larger than p's own. So the bottom rows_below_px rows of a sign seen just above a nearer
// board are flagged, also across a strip of a farther background or of pixels the discontinuity
// filter invalidated (thinner than rows_below_px) between them; the board's own bottom rows are not
// (what lies under a board on poles is the farther road); nor is ground, which changes its
// disparity by baseline / camera height between neighbouring rows (0.2 px for 0.3 m at 1.5 m, 0.33
// px for KITTI's 0.54 m at 1.65 m), never by a jump, however far down it is followed; ground seen
// just above a low box is (it is seen over the box: its sample is an upper bound, which is right).
// Same columns: a camera rolled by a few degrees shifts an occluder's edge by under a pixel over
// rows_below_px rows.
struct OccluderTest {
  int rows_below_px = 6;  // [1, 64]: > the discontinuity filter's 3 px radius, so its gap is stepped over
  double jump_px = 2.0;   // > 0: the discontinuity filter's jump (docs/terrain.md)
  // Throws std::invalid_argument "<name>: expected ..., got ..." when out of range.
  void validate() const;
};
// The flags, row-major (index v * width + u), 1 over an occluder, 0 otherwise (and at invalid
// pixels: disparity_q4 <= invalid_q4). One pass up the image; per column the nearest valid pixel
// below and the tops of nearer surfaces within rows_below_px rows (a queue, oldest dropped first).
// Counted ARM work (for a caller that counts it): 10 scalar ops per pixel (read, validity, the jump
// test, the queue's expiry and the comparison with its tops; a top is rare: one per occluding edge
// per column) and 3 bytes (the s16 read, the flag written), plus 8 (1 + rows_below_px) bytes of
// state per column.
// Throws std::invalid_argument for a bad test or a non-s16 plane.
std::vector<uint8_t> pixels_over_occluder(const Plane& disparity_q4, int16_t invalid_q4, const OccluderTest& test = {});

// The far side of a nearer surface's edge: a valid pixel p is flagged when a valid pixel within
// rows_above_px rows above it in its column, or within columns_beside_px columns beside it in its
// row, has a disparity more than jump_px larger than p's. The census window and SGM's smoothness
// carry a nearer surface's disparity into the farther one seen next to it for a few pixels,
// decaying (foreground fattening), and those points stand between the two surfaces, often above
// the ground. Under a lower edge (a board on poles, a hanging sign, a car's body): floating seed 2
// frame 12, a board at 15 m over road at 32 m, the road reads 2.6-3.9 px too large one row under
// the edge and 0.5-1.3 px six rows under it: points 0.26-0.49 m up at 24 m, under a sign standing
// there. Ground never triggers the column test: going down an image column, ground (and whatever
// stands on it, whose foot meets the ground at its disparity) only gets nearer; only a surface
// hanging over a farther one makes the disparity fall. Beside a side edge: floating seed 1 frame 44,
// board 4 at 19.2 m (8.7 px) beside a pedestrian at 13.2 m (12.7 px) reads 9.0-11.0 px over the
// seven columns next to the pedestrian, a smooth ramp with no 2 px step within 3 columns. The row
// test flags the ground beside every standing object too, above its foot (those are ground points;
// a caller keeps them as ground). The near surface's own fattened border is kept (within jump_px of
// its neighbours).
struct FarSideTest {
  // The defaults are the measured setting (arm/obstacles3d/obstacle_candidates.h, CandidateParameters).
  int rows_above_px = 6;      // [0, 64]: the rows looked up; 0: no column test
  int columns_beside_px = 6;  // [0, 64]: the columns looked at on either side; 0: no row test
  double jump_px = 2.0;       // > 0: the discontinuity filter's jump (a flat ground changes 0.2 px a row)
  // Throws std::invalid_argument "<name>: expected ..., got ..." when out of range.
  void validate() const;
  bool enabled() const { return rows_above_px > 0 || columns_beside_px > 0; }
};
// The flags of rows [first_row, end_row) (end_row -1: the last row), row-major (index (v - first_row)
// width + u), 1 on the far side, 0 otherwise (and at invalid pixels: disparity_q4 <= invalid_q4;
// invalid pixels are stepped over, being below every valid value); the rows above first_row are
// read, so bands of rows give the whole image's flags. Per row, the element-wise maximum of the
// rows_above_px rows above and of the row shifted by -columns_beside_px .. columns_beside_px, then
// one comparison.
// Counted ARM work (for a caller that counts it): rows_above_px + 2 columns_beside_px + 3 scalar ops
// per pixel (the maxima, the validity and the comparison; the vector engine would take them 16
// lanes at a time), 3 bytes (the s16 read, the flag written).
// Throws std::invalid_argument for a bad test, a non-s16 plane or rows outside the plane.
std::vector<uint8_t> pixels_on_far_side(const Plane& disparity_q4, int16_t invalid_q4, const FarSideTest& test, int first_row = 0,
                                           int end_row = -1);

// The camera-frame y (down, metres) of the fitted surface on the camera's vertical line through
// (x_c, ., z_c): the y with p_vehicle = R C (x_c, y, z_c) + T on z = S(x, y), by Newton steps along
// that line (dz_v / dy_c is the constant (R C)(2, 1); S's own slope enters through a secant
// correction). Empty when the terrain is unknown, the line leaves the surface's domain, the step
// does not converge (|residual| <= 1e-4 m within 30 steps), or the point's grid cell is invalid
// (no data there: the spline is only an extrapolation) when require_valid_cell.
std::optional<double> surface_camera_y_m(const terrain::TerrainEstimate& terrain, const CameraToVehicle& to_vehicle, double x_c_m,
                                         double z_c_m, bool require_valid_cell = true);

}  // namespace lpstereo::arm
