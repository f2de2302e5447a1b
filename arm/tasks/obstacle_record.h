// The obstacle records the obstacle stage's ARM tasks pass along (obstacle_clusters writes them,
// obstacle_feature_validation fills "features" and drops clusters without any, obstacle_tracker fills
// the track fields): one row of kObstacleWords s32 words per obstacle (BufferFormat {s32, 0}), a
// plane of kObstacleWords x max_obstacles; rows with kObstacleValid = 0 are unused and come after the
// used ones. Fixed layout, so a consumer (a task, a JSON writer, a test) reads it without parsing.
//
// Frames: image pixels (x right, y down, inclusive bounding boxes); camera frame in millimetres
// (x right, y down, z forward, DESIGN.md §4).
#pragma once

#include <cstdint>
#include <vector>

#include "dag/plane.h"

namespace lpstereo::arm {

enum ObstacleWord : int {
  kObstacleValid = 0,          // 1: a record; 0: unused row
  kObstacleId = 1,             // 1-based within the frame, in the clusters' flood-fill order
  kObstacleX0 = 2,             // image bounding box of the obstacle's mask pixels, inclusive, px
  kObstacleY0 = 3,
  kObstacleX1 = 4,
  kObstacleY1 = 5,
  kObstaclePixels = 6,         // obstacle-mask pixels that fell in the cluster's grid cells
  kObstacleDisparityQ4 = 7,    // mean disparity of those pixels, Q4 (px * 16), rounded
  kObstacleDistanceMm = 8,     // camera-frame z at the mean disparity, mm
  kObstaclePositionXMm = 9,    // camera-frame point of the bounding box's bottom centre (the foot)
  kObstaclePositionYMm = 10,   //   at the mean disparity, mm
  kObstacleWidthMm = 11,       // bounding box width and height at the mean disparity, mm
  kObstacleHeightMm = 12,
  kObstacleCells = 13,         // occupied AUD grid cells in the cluster
  kObstacleCellColumn0 = 14,   // the cluster's box in the AUD grid, inclusive (column, row)
  kObstacleCellRow0 = 15,
  kObstacleCellColumn1 = 16,
  kObstacleCellRow1 = 17,
  kObstacleFeatures = 18,      // keypoints inside the bounding box (0 before feature validation)
  kObstacleTrackId = 19,       // 0 = not tracked (single frame); else the track's id, >= 1
  kObstacleTrackAgeFrames = 20,  // frames the track has existed, this one included
  kObstacleVelocityXMmPerS = 21, // the track's velocity, camera frame, mm/s (0 when not tracked)
  kObstacleVelocityYMmPerS = 22,
  kObstacleVelocityZMmPerS = 23,
  kObstacleWords = 24,
};

struct Obstacle {
  int id = 0;
  int bbox_px[4] = {0, 0, 0, 0};  // x0, y0, x1, y1 inclusive
  int64_t pixels = 0;
  double disparity_px = 0;
  double distance_m = 0;
  double position_m[3] = {0, 0, 0};
  double width_m = 0, height_m = 0;
  int cells = 0;
  int cell_box[4] = {0, 0, 0, 0};  // column0, row0, column1, row1
  int features = 0;
  int track_id = 0;
  int track_age_frames = 0;
  double velocity_mps[3] = {0, 0, 0};
};

// The valid rows of a record plane (kObstacleWords wide, s32), in order. Throws std::runtime_error on
// another shape. Defined in arm/tasks/obstacle_record.cpp.
std::vector<Obstacle> decode_obstacles(const Plane& records);

}  // namespace lpstereo::arm
