// The whole chain (points -> grid -> fit -> classify) on a ground that is not flat: a 5 % climb, a
// 4 deg roll (lateral tilt), a hill, a ditch and a berm beside the track, with boxes standing on it.
// The surface must follow the ground (not the boxes) and the points must split into terrain and
// obstacles by their height above it.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "arm/terrain/terrain_model.h"

namespace lpstereo::arm::terrain {
namespace {

// The true ground height (vehicle frame, metres).
double ground_m(double x, double y) {
  const double climb = 0.05 * x;
  const double roll = std::tan(4.0 * M_PI / 180.0) * y;
  const double hill = 0.8 * std::exp(-((x - 22) * (x - 22) + (y - 4) * (y - 4)) / 40.0);
  const double ditch = -0.3 * std::exp(-(y + 5) * (y + 5) / 0.8);  // along x, 5 m to the right
  const double berm = 0.4 * std::exp(-(y - 7) * (y - 7) / 8.0);    // a bank along x, 7 m to the left, 4.7 m wide at half height
  return climb + roll + hill + ditch + berm;
}

struct Box {
  double x, y, half_width, height;
};
const Box kBoxes[] = {{10, 0, 0.4, 1.7}, {16, -3, 1.0, 1.2}, {26, 2, 0.75, 2.0}, {6, 6, 0.3, 1.0}};

const Box* box_at(double x, double y) {
  for (const Box& box : kBoxes) {
    if (std::abs(x - box.x) < box.half_width && std::abs(y - box.y) < box.half_width) return &box;
  }
  return nullptr;
}

void check_rough_ground(unsigned seed) {
  SCOPED_TRACE("seed " + std::to_string(seed));
  TerrainGridSpec spec;  // 34 m x 22 m, 0.5 m cells
  HeightGridAccumulator accumulator(spec);
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<Eigen::Vector3d> points;
  std::vector<bool> on_obstacle;
  for (double x = 0.05; x < 34; x += 0.1) {
    for (double y = -10.95; y < 11; y += 0.1) {
      const double ground = ground_m(x, y);
      const Box* box = box_at(x, y);
      // Box tops and, on its sides facing the camera, a column of points up to its top.
      const double z = box != nullptr ? ground + box->height * (0.3 + 0.7 * std::uniform_real_distribution<double>(0, 1)(random))
                                      : ground + noise(random);
      points.emplace_back(x, y, z);
      on_obstacle.push_back(box != nullptr);
      accumulator.add_point(points.back());
    }
  }
  const HeightGrid grid = accumulator.finish();
  const TerrainFitParameters fit_parameters;  // the defaults
  const TerrainEstimate terrain = fit_terrain(grid, fit_parameters);
  ASSERT_TRUE(terrain.known) << terrain.reason;

  // RMS against the true ground at the cell centres away from the boxes (a cell under a box has no
  // visible ground; 1 m margin) and its worst cell.
  double sum_squares = 0, worst = 0;
  int cells = 0;
  for (int i = 0; i < spec.forward_cells(); ++i) {
    for (int j = 0; j < spec.lateral_cells(); ++j) {
      const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
      bool near_box = false;
      for (const Box& box : kBoxes) near_box |= std::abs(x - box.x) < box.half_width + 1 && std::abs(y - box.y) < box.half_width + 1;
      if (near_box) continue;
      const double error = terrain.surface.height_m(x, y) - ground_m(x, y);
      sum_squares += error * error;
      worst = std::max(worst, std::abs(error));
      ++cells;
    }
  }
  const double rms = std::sqrt(sum_squares / cells);
  EXPECT_LT(rms, 0.05);   // issue 9: 5 cm
  EXPECT_LT(worst, 0.12);  // the ditch's bottom is the hardest place (samples below get low weights)
  // Under the boxes the surface stays near the ground, far below the box tops.
  for (const Box& box : kBoxes) {
    EXPECT_LT(terrain.surface.height_m(box.x, box.y) - ground_m(box.x, box.y), 0.05 * box.height) << box.x << " " << box.y;
  }

  // Points more than 20 cm above the surface are obstacles.
  const std::vector<PointClass> classes = classify_points(points, terrain, 0.2);
  int true_positive = 0, false_positive = 0, false_negative = 0;
  for (size_t k = 0; k < points.size(); ++k) {
    const bool truth = on_obstacle[k] && points[k].z() - ground_m(points[k].x(), points[k].y()) > 0.2;
    const bool found = classes[k] == PointClass::obstacle;
    true_positive += truth && found ? 1 : 0;
    false_positive += !truth && found ? 1 : 0;
    false_negative += truth && !found ? 1 : 0;
  }
  const double precision = double(true_positive) / (true_positive + false_positive);
  const double recall = double(true_positive) / (true_positive + false_negative);
  EXPECT_GE(precision, 0.95);
  EXPECT_GE(recall, 0.95);
  std::printf("rough ground, seed %u: rms %.4f m, worst %.4f m over %d cells; obstacles precision %.4f recall %.4f\n", seed, rms, worst, cells,
              precision, recall);
}

TEST(RoughGround, SurfaceFollowsTheGroundAndPointsSplitIntoTerrainAndObstacles) {
  for (const unsigned seed : {11u, 12u, 13u}) check_rough_ground(seed);
}

}  // namespace
}  // namespace lpstereo::arm::terrain
