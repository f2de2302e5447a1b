// The records the ARM task "augmented_stixels" writes (arm/tasks/augmented_stixels.cpp), fixed layout
// s32 words (BufferFormat {s32, 0}), read without parsing like arm/tasks/terrain_record.h's:
//
// "stixels": kStixelWords x (1 + max_stixels). Row 0 is the header (kStixelHeader* words); rows
// 1 .. kStixelHeaderWritten hold one augmented stixel each (arm/obstacles3d/augmented_stixels.h) in
// the library's order (sorted by range cell, then angle cell), the kStixel* words. Lengths are
// millimetres, angles microradians, heights above the fitted terrain surface (a hanging obstacle's
// stixel has min height > 0: the free space under it). Stixels beyond max_stixels are counted in
// the header (kStixelHeaderTotal) but not written. Unused rows are 0.
//
// "obstacles": kObstacle3dWords x (1 + max_obstacles). Row 0: word 0 the rows written, word 1 the
// obstacles found; rows 1 .. written: one Obstacle3d each (arm/obstacles3d/obstacle_points.h), in the
// camera frame of the disparity map (x right, y down, z forward), mm, heights above the terrain, the
// left-image bounding box in pixels.
//
// Ranges: every length is clamped to +-2e6 m before scaling to mm (|word| <= 2e9 < 2^31; a real
// one is below 1e3 m); angles are within the polar grid's +-pi rad (3.2e6 urad); counts are clamped
// to 2^31 - 1.
#pragma once

#include <cstdint>

namespace lpstereo::arm {

enum StixelHeaderWord : int {
  kStixelHeaderWritten = 0,          // stixel rows that follow
  kStixelHeaderTotal = 1,            // stixels the frame produced (> written when max_stixels cut them)
  kStixelHeaderObstacles = 2,        // obstacles (clusters of stixels) the frame produced
  kStixelHeaderCandidatePoints = 3,  // points more than obstacle_height_m above the surface
  kStixelHeaderSampledPixels = 4,    // pixels read (every sample_step-th row and column)
  kStixelHeaderValidPoints = 5,      // sampled pixels with a 3D point
  kStixelHeaderOutsidePoints = 6,    // valid points the surface does not cover
  kStixelHeaderTerrainKnown = 7,     // the terrain record's known word (0: no candidates, no stixels)
};

enum StixelWord : int {
  kStixelAngleCell = 0,       // polar grid column
  kStixelRangeCell = 1,       // polar grid row
  kStixelAngleMinUrad = 2,
  kStixelAngleMaxUrad = 3,
  kStixelRangeMinMm = 4,
  kStixelRangeMaxMm = 5,
  kStixelMinHeightMm = 6,     // trimmed lowest point above the terrain
  kStixelMaxHeightMm = 7,     // trimmed highest point above the terrain
  kStixelMeanRangeMm = 8,
  kStixelPointCount = 9,
  kStixelOccupancyPermille = 10,  // the polar cell's occupancy probability, thousandths
  kStixelCluster = 11,        // obstacle row - 1 (0-based index), -1 when its cluster was dropped
  kStixelWords = 12,
};

enum Obstacle3dWord : int {
  kObstacle3dPositionXMm = 0,  // centre, camera frame
  kObstacle3dPositionYMm = 1,
  kObstacle3dPositionZMm = 2,
  kObstacle3dSizeXMm = 3,      // width
  kObstacle3dSizeYMm = 4,      // height
  kObstacle3dSizeZMm = 5,      // length
  kObstacle3dMinHeightMm = 6,  // lowest point above the terrain
  kObstacle3dMaxHeightMm = 7,
  kObstacle3dBboxX0 = 8,       // inclusive, left image pixels
  kObstacle3dBboxY0 = 9,
  kObstacle3dBboxX1 = 10,
  kObstacle3dBboxY1 = 11,
  kObstacle3dWords = 12,
};

}  // namespace lpstereo::arm
