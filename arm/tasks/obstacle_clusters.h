// The parameters of the obstacle stage's grid and its two ARM tasks, with their defaults: the one
// place the defaults live. The ARM tasks "obstacle_clusters" (arm/tasks/obstacle_clusters.cpp) and
// "obstacle_feature_validation" (arm/tasks/obstacle_feature_validation.cpp) take a missing parameter
// from here, and arm/obstacle_detector.h aggregates these structs and passes every value to the
// graph, so a graph file, the detector and the tasks agree.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/advanced_u_disparity.h"

namespace lpstereo::arm {

// The Advanced U-disparity grid (thesis 003 §4.2.3): the kernel "advanced_u_disparity" builds it and
// obstacle_clusters reads it, so both must get the same values (the detector passes one struct to
// both). Parameter names are the kernel's.
struct AudGridSettings {
  // min_disparity_px, max_disparity_px, exponent_k, grid_rows: 256 rows from 2 px (1.6 % of the
  // disparity per row); 128 rows merged a 0.07 m object's cell at 40 m with twice as much road
  // (free votes) on the 4K range test and lost it.
  kernels::AudGridGeometry geometry{2.0, 128.0, 1.0, 256};
  int columns_per_cell = 8;           // image columns summed into one grid column
  int obstacle_weight = 2;            // vote of an obstacle-mask pixel
  int free_weight = 1;                // penalty of a free-space pixel (thesis: free votes penalised)
};

// obstacle_clusters' own parameters (thresholds, cluster filters, output size).
struct ObstacleClusterSettings {
  // Y_min of eq. 4.3, two heights (thesis 003 §4.2.3: ~3 cm near the vehicle, ~30 cm far away).
  double near_min_height_m = 0.03;
  double far_min_height_m = 0.20;
  // A cell whose row centre lies nearer than this uses near_min_height_m. Above 40 m because the
  // issue's range test asks for 0.07 m objects at 40 m, with margin for a grid row's depth extent
  // and the 10 % distance tolerance (a 40 m object measured at 44 m must still use the near height);
  // below the cone test's 92 m, where the far height still lets a 0.30 m cone through.
  double height_switch_distance_m = 50.0;
  // Optional normalisation (0 = off, the thesis' per-column threshold): a minimum obstacle width; the
  // threshold is multiplied by the columns an object that wide covers in the cell, clamp(min_width_m
  // d / B, 1, columns_per_cell). See arm/tasks/obstacle_clusters.cpp.
  double min_width_m = 0.0;
  int min_cells = 1;        // clusters with fewer occupied cells are dropped
  int min_pixels = 11;      // clusters with fewer obstacle-mask pixels are dropped: on the 4K range
                            // test a far road artefact had 10 (at 114 m) while a 0.30 m cone at 100 m
                            // has 12 or more and the 0.07 m tape roll at 45 m ~40; 15 lost the cone at
                            // 95 m (docs/obstacles.md)
  int max_obstacles = 512;  // record rows; with more clusters the nearest are kept. Room for the
                            // clusters feature validation drops: with 64 the nearer road specks of a
                            // 4K frame filled the list and the 130 m objects never reached validation
};

// obstacle_feature_validation's parameters.
struct FeatureValidationSettings {
  int margin_px = 2;      // the bounding box grown by this on every side before counting keypoints
  int min_features = 2;   // records nearer than far_distance_m with fewer corners are dropped (thesis
                          // 003 §4.2.4); see arm/tasks/obstacle_feature_validation.cpp for near / far
  int far_min_features = 1;      // ... and farther records with fewer than this
  double far_distance_m = 60.0;
  int mask_radius_px = 1; // a keypoint counts only with an obstacle-mask pixel this near (-1: any keypoint;
                          // 0 (the corner itself) lost the corners on far objects' outlines)
};

// T_r of eq. 4.3 for every grid row r (the occupancy threshold of a cell in row r, 65536 = never):
// what obstacle_clusters compares the grid with (the formula: arm/tasks/obstacle_clusters.cpp), also
// for pictures of the grid.
std::vector<uint32_t> obstacle_cell_thresholds(const kernels::AudGridGeometry& geometry, int columns_per_cell,
                                               int obstacle_weight, const ObstacleClusterSettings& settings,
                                               double focal_px, double baseline_m);

}  // namespace lpstereo::arm
