// The local ground of the obstacle candidates (issue 10; used by extract_obstacle_candidates): a
// candidate's height taken above the ground points seen around it, where the fitted terrain surface
// stands above them.
//
// Why. The surface is a smooth B-spline through the 2.5D cells' samples (arm/terrain). Where a
// cell's points are mostly an obstacle's and its ground points few, the cell's sample stands above
// the ground and the re-weighting does not always pull it down: at 25-30 m a hanging sign's points
// scatter over several forward cells (the depth sigma there is 1.3 m at 640x480) with 3-8 road
// points each against 14-81 of the sign's, and the surface stands 0.10-0.13 m above the true ground
// there (docs/obstacles3d.md, "The far sign's surface"). The sign's lower edge, measured above that
// surface, is then read 0.12 m low (1.78 m for 1.90 m) and the free space under it is lost. The road
// points seen under the sign still lie on the true ground: 0.12 m under the surface. Measuring the
// candidates from them mends the reading without changing the fit or the candidate set.
//
// Model. Per cell of the 2.5D grid (TerrainGridSpec) that holds at least one candidate, the points
// of the (2 reach + 1)^2 cells around it whose height above the surface h = z - S(x, y) lies in
// [-band_below_m, obstacle_height_m] (the terrain's inliers: a ditch's points farther under the
// surface and the candidates themselves are not ground samples of that cell) give the median m of
// their h. When at least min_points do and m < 0 (the surface stands above the ground seen there),
// every candidate of the cell gets h - m. A surface below the seen ground (m >= 0) is left alone:
// there the inliers may be an obstacle's foot, 0-0.2 m up, and lowering a candidate by it would
// take height the obstacle has.
//
// Counted work (ArmWork, the ARM side's model of the three steps): marking, 6 ops per candidate and
// 2 per cell of its (2 reach + 1)^2 window, a byte per grid cell; the gather, 4 ops per point (the
// cell index and the mark), plus for each point in a marked cell the surface evaluation
// (terrain::surface_evaluation_ops, as the ARM task augmented_stixels counts it) and 4 bytes per
// inlier kept (no evaluation for a point whose height the caller gives); the median, 4 ops per pooled
// value (copy and selection) per candidate cell; the re-reference, 6 ops per candidate. The gather
// may be split into shares run on threads: each share keeps its own inliers and its own count, so
// the result and the counted work do not depend on how many shares there are or how the points are
// dealt to them (the median is the same order statistic of the same values).
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "arm/obstacles3d/obstacle_points.h"
#include "arm/terrain/terrain_model.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::obstacles3d {

struct LocalGroundParameters {
  int reach_cells = 1;         // [0, 8]: the window's half width in cells (0: the cell alone)
  double band_below_m = 0.4;   // (0, 10): how far under the surface a point still samples its ground
  int min_points = 8;          // [1, 100000]: fewer inliers in the window leave the cell's candidates alone
  // Throws std::invalid_argument naming the parameter, the expected range and the value.
  void validate() const;
};

class LocalGround {
 public:
  // `surface` must outlive this; obstacle_height_m is the candidates' threshold (the band's top);
  // `shares` (>= 1) is how many gathers may run at once (step 2).
  LocalGround(const terrain::TerrainGridSpec& spec, const terrain::BsplineSurface& surface, double obstacle_height_m,
              const LocalGroundParameters& parameters, int shares = 1);

  // 1. The cells holding the candidates, and the windows around them.
  void mark_candidates(const std::vector<ObstaclePoint>& candidates);
  // 2. Every point of the frame, in any order and dealt to the shares in any way (the candidates may
  // be among them: they lie above the band). Calls with different shares may run on different
  // threads at once; one share's calls must not. height_above_m: z - S(x, y) when the caller has it
  // (CandidateTest::classify evaluates it for every candidate and for the terrain points its bound
  // cannot decide), which saves the evaluation and its counted work; NaN: evaluated here.
  void add_point(const Eigen::Vector3d& vehicle_m, int share = 0, double height_above_m = std::numeric_limits<double>::quiet_NaN());
  // The same for a point whose cell the caller has found (TerrainGridSpec::cell_of of its x and y;
  // forward_cell -1: outside the area), which saves finding it again; the same result and counted work.
  void add_point_in_cell(const Eigen::Vector3d& vehicle_m, int forward_cell, int lateral_cell, int share, double height_above_m);
  // 3. The candidates of step 1 measured from their cell's local ground where it lies under the
  // surface; returns how many cells were. Call once.
  int apply(std::vector<ObstaclePoint>& candidates);

  // The work of the three steps, every share's gather included.
  ArmWork work() const;

 private:
  size_t index(int forward_cell, int lateral_cell) const;

  const terrain::TerrainGridSpec& spec_;
  const terrain::BsplineSurface& surface_;
  double obstacle_height_m_;
  LocalGroundParameters parameters_;
  int forward_cells_ = 0, lateral_cells_ = 0;
  std::vector<uint8_t> holds_candidates_, in_window_;
  // One gather's state: per cell in a window, h of the inliers it gathered there; and its work. On a
  // cache line of its own: the shares' counters are written per point from different threads.
  struct alignas(64) Share {
    std::vector<std::vector<float>> inlier_heights_m;
    ArmWork work;
  };
  std::vector<Share> shares_;
  uint64_t surface_evaluation_ops_ = 0;
  ArmWork work_;  // marking, median, re-reference
};

}  // namespace lpstereo::arm::obstacles3d
