// decode_obstacles (arm/tasks/obstacle_record.h): the valid rows of an obstacle record plane as
// Obstacle structs, millimetres to metres.
#include "arm/tasks/obstacle_record.h"

#include <stdexcept>
#include <string>

namespace lpstereo::arm {

std::vector<Obstacle> decode_obstacles(const Plane& records) {
  if (records.width() != kObstacleWords || records.format().type != ElementType::s32) {
    throw std::runtime_error("obstacle records: expected " + std::to_string(int(kObstacleWords)) + "xN s32, got " +
                             std::to_string(records.width()) + "x" + std::to_string(records.height()) + " " +
                             format_name(records.format()));
  }
  std::vector<Obstacle> obstacles;
  for (int row = 0; row < records.height(); ++row) {
    const int32_t* word = records.row<const int32_t>(row);
    if (word[kObstacleValid] == 0) break;  // unused rows come after the used ones
    Obstacle obstacle;
    obstacle.id = word[kObstacleId];
    for (int i = 0; i < 4; ++i) obstacle.bbox_px[i] = word[kObstacleX0 + i];
    obstacle.pixels = word[kObstaclePixels];
    obstacle.disparity_px = word[kObstacleDisparityQ4] / 16.0;
    obstacle.distance_m = word[kObstacleDistanceMm] / 1000.0;
    obstacle.position_m[0] = word[kObstaclePositionXMm] / 1000.0;
    obstacle.position_m[1] = word[kObstaclePositionYMm] / 1000.0;
    obstacle.position_m[2] = obstacle.distance_m;
    obstacle.width_m = word[kObstacleWidthMm] / 1000.0;
    obstacle.height_m = word[kObstacleHeightMm] / 1000.0;
    obstacle.cells = word[kObstacleCells];
    for (int i = 0; i < 4; ++i) obstacle.cell_box[i] = word[kObstacleCellColumn0 + i];
    obstacle.features = word[kObstacleFeatures];
    obstacle.track_id = word[kObstacleTrackId];
    obstacle.track_age_frames = word[kObstacleTrackAgeFrames];
    obstacle.velocity_mps[0] = word[kObstacleVelocityXMmPerS] / 1000.0;
    obstacle.velocity_mps[1] = word[kObstacleVelocityYMmPerS] / 1000.0;
    obstacle.velocity_mps[2] = word[kObstacleVelocityZMmPerS] / 1000.0;
    obstacles.push_back(obstacle);
  }
  return obstacles;
}

}  // namespace lpstereo::arm
