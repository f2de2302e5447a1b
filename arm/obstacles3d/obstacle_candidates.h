// The obstacle candidates of one frame (issue 10: "obstacle candidates are the terrain's outliers"),
// one implementation for `lpstereo obstacles3d`, bench/obstacles3d_eval and the full-chain bench.
//
// Steps: (1) every valid disparity's camera point (arm::triangulate, millimetres) becomes an
// ObstaclePoint in metres, with its vehicle-frame position (CameraToVehicle), its disparity, pixel
// and colour; (2) the vehicle points are condensed into the 2.5D grid and the terrain is fitted
// (arm/terrain: height_grid, fit_terrain; with grid.occlusion_upper_bounds each point carries
// arm::pixels_over_occluder's flag of its pixel into the grid); (3) classify_points's rule keeps the points more than
// obstacle_height_m above the fitted surface, with their height above it (CandidateTest: S evaluated
// only where the control heights' bound cannot decide; the same classes), except the points on the
// far side of a nearer surface's edge (arm::pixels_on_far_side: they sample the terrain, they are
// never candidates). Step 1 runs on `threads`
// bands of rows (balanced by valid disparities), step 3 on `threads` equal shares of the points,
// both joined in row order. When the terrain is
// unknown (too few cells, a wall filling the view ...) there are no candidates and `note` says why.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "arm/disparity_engine.h"
#include "arm/obstacles3d/local_ground.h"
#include "arm/obstacles3d/obstacle_points.h"
#include "arm/point_cloud.h"
#include "arm/terrain_points.h"
#include "arm/terrain/terrain_model.h"
#include "dag/plane.h"

namespace lpstereo::arm::obstacles3d {

// An 8-bit, 3-channel interleaved image the size of the disparity map (a cv::Mat CV_8UC3's data,
// say), or none: then every point gets the grey of `grey` (u8 plane) repeated.
struct ColourView {
  const uint8_t* pixels = nullptr;
  size_t row_stride_bytes = 0;
  bool blue_first = true;  // OpenCV's BGR order; false for RGB
};

struct CandidateParameters {
  double obstacle_height_m = 0.2;  // a point this far above the fitted surface is a candidate, (0, 10)
  terrain::TerrainGridSpec grid;   // default: x 0..34 m forward, y -11..11 m, 0.5 m cells
  // The terrain fit, with the membrane over holes on (hole_membrane 1, terrain_fit.cpp): a nearer
  // object hides the ground under what stands behind it, and without the membrane the surface
  // follows that object up into the hole (a sign over a board: its heights 0.3-0.4 m low).
  terrain::TerrainFitParameters fit{.hole_membrane = 1.0};
  // With grid.occlusion_upper_bounds (off by default, as in TerrainGridSpec: it measured no better on
  // the floating scene, docs/obstacles3d.md): the image test that flags each point over a nearer
  // occluder (arm::pixels_over_occluder on the disparity map), for the 2.5D grid's upper-bound cells.
  OccluderTest occluder;
  // The far side of a nearer surface's edge (arm::pixels_on_far_side: under its lower edge within
  // rows_above_px rows, beside its side edges within columns_beside_px columns, more than jump_px
  // nearer): those points sample the terrain but are never candidates. The matcher carries a hanging
  // board's disparity down into the road seen under it, and a pedestrian's into the board seen
  // beside it, for a few pixels, decaying; those points stand between the two surfaces, 0.2-1.4 m
  // up, where a farther sign or board stands: obstacles under it that are not there. As ground
  // samples they stay, because in a board's shadow they are the only ones near the road (without
  // them a sign farther back pulls the surface up under itself: +0.1 m under a sign at 28 m,
  // floating seed 2, and the sign then reads as low). Measured (bench/obstacles3d_eval, floating, 300
  // frames, seeds 1-3, stixels, free space kept under the hanging objects, of 111 / 118 / 115): none
  // 105 / 110 / 109, 6 rows 105 / 113 / 110, 6 rows and 6 columns 109 / 115 / 112 (docs/obstacles3d.md);
  // dropping the points altogether instead: 105 / 109 on seeds 1-2 (the surface rose).
  // The default: 6 rows, 6 columns, 2 px; rows_above_px and columns_beside_px 0: off.
  FarSideTest far_side;
  // The cells whose ground lies below the image are upper bounds (terrain::HeightGrid::upper_bound,
  // the fit's one-sided rule, arm/terrain/terrain_fit.cpp): the vehicle frame's ground plane (z = 0)
  // at the cell's centre projects below the image's last row, so whatever the cell holds stands
  // above ground the camera cannot see (a level camera 1.5 m up, f = 554 px, 480 rows sees the road
  // from 3.47 m on). Unmarked, such a cell is a ground sample at the height of what stands there: a
  // board on two poles at 2.8 m (floating seed 3 frame 33) fills the cells at 2.5-3.5 m with the
  // board's 0.9-1.6 m and its poles' 0.29-0.9 m, the fitted surface rose to about 0.45 m there, the
  // board read 0.43-1.26 m joined with its poles as one obstacle (free space lost); marked, the
  // first surface fitted to the seen ground sets them aside and the board reads 0.92-1.61 m, its
  // poles apart. Ground that rises into view nearer (a hill, a ramp) is marked too and counts as
  // any sample while it lies under or within the fit's tolerance of that surface.
  bool ground_below_view_upper_bounds = true;
  // The local ground (local_ground.h): each candidate measured from the terrain inliers seen around
  // it where the fitted surface stands above them (a far sign's points lift the surface 0.1 m under
  // it, and the sign then reads 0.1 m low). The candidate set and the fit are unchanged; only the
  // candidates' heights (height_above_ground_m) are. On by default (docs/obstacles3d.md, "The local
  // ground": floating, 300 frames, seeds 1-3, free space kept under the hanging objects 111 / 114 /
  // 113 -> 111 / 117 / 114 of 111 / 118 / 115; detection and the moving flag unchanged on the 12
  // sequences).
  bool local_ground_reference = true;
  LocalGroundParameters local_ground;
  // [1, 16]: steps 1 and 3 run on this many threads (step 1 on bands of rows, at most one band per 16
  // rows; step 3 on shares of the points); the result is the same for any count (joined in row order).
  int threads = 1;
};

struct CandidatePoints {
  std::vector<ObstaclePoint> points;  // the candidates, height_above_ground_m set
  int64_t cloud_points = 0;           // valid disparities triangulated
  int64_t outside_area = 0;           // not covered by the terrain area (no height above ground)
  int64_t far_side = 0;               // above obstacle_height_m but on the far side of an edge: not candidates
  int below_view_cells = 0;           // 2.5D cells whose ground lies below the image, marked upper bounds
  int local_ground_cells = 0;         // candidate cells measured from their local ground (local_ground_reference)
  terrain::TerrainEstimate terrain;   // the fit (terrain.known false: no candidates)
  // The 2.5D grid before the fit's equalisation (empty when the cloud was empty): what
  // terrain::compute_traversability takes beside the fit (terrain.grid is the equalised one).
  terrain::HeightGrid measured_grid;
  std::string note;                   // one line for a status or log
};

// terrain::classify_points's rule for one vehicle-frame point (outside when the surface does not
// cover it, candidate when z - S(x, y) > obstacle_height_m, terrain otherwise), with a shortcut that
// cannot change a class: S is a convex combination of the (d0 + 1)(d1 + 1) control heights of the
// knot spans holding (x, y) (the basis functions are >= 0 and sum to 1; rational weights > 0 keep
// it one), so a point with z - obstacle_height_m below the smallest of them (less 1e-9 m for the
// rounding of the sums) is terrain without evaluating S. Most points of a frame are ground points
// within centimetres of the surface, 0.2 m below the threshold: S is evaluated for the others only.
// Shared by extract_obstacle_candidates and the ARM task augmented_stixels.
class CandidateTest {
 public:
  enum class Class : uint8_t { outside, terrain, candidate };
  // `surface` must outlive the test; obstacle_height_m as in CandidateParameters.
  CandidateTest(const terrain::BsplineSurface& surface, double obstacle_height_m);
  // The point's class; *height_above_m = z - S(x, y) whenever S was evaluated (every candidate, and
  // the terrain points the control heights' bound could not decide), else left alone. *evaluated
  // (may be null) says whether S was (the ARM task counts that work).
  Class classify(const Eigen::Vector3d& vehicle_m, double* height_above_m, bool* evaluated = nullptr) const;

 private:
  const terrain::BsplineSurface& surface_;
  double obstacle_height_m_;
  Eigen::MatrixXd span_minimum_m_;  // (n0 - d0) x (n1 - d1): the smallest control height per span pair
};

// The matcher of the chain (`lpstereo obstacles3d`, bench/obstacles3d_eval, bench/obstacles3d_chain_bench):
// the engine's defaults, 64 px at full resolution (nearer than f B / 64 = 2.6 m at 640x480, f 554 px,
// B 0.3 m, a surface gets whatever value the search finds). Measured and not the default: the near
// guard, 128 px with 64 at full resolution and the whole range again at half resolution
// (`--num-disp 128 --multires on --multires-far 64`): floating's false positives fall by 32-51 % (with
// the fusion's left-band rule) and the chain runs at 39-40 fps instead of 48-50, but the boards it then
// measures at 1.3-2.6 m lose the free space in some frames, and seed 2 keeps it in 94 % (line 99 %)
// (docs/obstacles3d.md, "The near guard").
DisparityParameters obstacles3d_disparity_defaults();
// The near guard: obstacles3d_disparity_defaults searched over [0, 128) px, 64 of them at full resolution.
DisparityParameters obstacles3d_near_guard_disparity_parameters();

// `camera` holds the points arm::triangulate made from the disparity map with `view` (its focal
// length and principal point also say where the image ends); `grey` (u8) and the colour view, when
// given, are the left image the disparity map belongs to. Throws std::invalid_argument when the
// planes' sizes disagree, view.focal_px is not positive or obstacle_height_m, threads, occluder,
// far_side, local_ground or the grid is out of range.
CandidatePoints extract_obstacle_candidates(const Plane& disparity_q4, int16_t invalid_disparity_q4, const CameraPoints& camera,
                                            const TriangulationParameters& view, const Plane& grey, const ColourView& colour,
                                            const CameraToVehicle& to_vehicle, const CandidateParameters& parameters);

}  // namespace lpstereo::arm::obstacles3d
