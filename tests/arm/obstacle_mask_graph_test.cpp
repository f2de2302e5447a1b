// graphs/obstacle-mask.json end to end on a synthetic disparity map: V-disparity -> road profile ->
// vldh_mask -> advanced_u_disparity, run by the ARM scheduler on the native and the counting back
// ends. A flat road seen by a 700 px camera 1.5 m high (0.30 m baseline, pitched 0.05 rad down) with
// one 1 m box 10 m ahead: the road is found, the box's pixels are obstacles and the road's are not,
// and the grid peaks in the box's cell (its columns, the grid row of its disparity, eq. 4.2).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "arm/scheduler.h"
#include "arm/tasks/road_profile.h"
#include "dag/graph.h"
#include "kernels/advanced_u_disparity.h"
#include "kernels/obstacle_mask.h"

namespace lpstereo {
namespace {

constexpr int kWidth = 641, kHeight = 481;
constexpr double kFocalPx = 700.0, kBaselineM = 0.30, kCameraHeightM = 1.5, kPitchRad = 0.05;
constexpr double kPrincipalRowPx = (kHeight - 1) / 2.0;
constexpr double kBoxDepthM = 10.0, kBoxSizeM = 1.0;

double road_slope() { return kBaselineM / kCameraHeightM * std::cos(kPitchRad); }  // px of disparity per row
double horizon_row() { return kPrincipalRowPx - kFocalPx * std::tan(kPitchRad); }
double box_disparity_px() { return kFocalPx * kBaselineM / kBoxDepthM; }            // 21 px
double box_foot_row() { return horizon_row() + box_disparity_px() / road_slope(); }
double box_top_row() { return box_foot_row() - kFocalPx * kBoxSizeM / kBoxDepthM; }  // 70 rows tall
double box_left_column() { return (kWidth - 1) / 2.0 - kFocalPx * kBoxSizeM / 2.0 / kBoxDepthM; }
double box_right_column() { return box_left_column() + kFocalPx * kBoxSizeM / kBoxDepthM; }

bool in_box(int u, int v) {
  return v >= box_top_row() && v <= box_foot_row() && u >= box_left_column() && u < box_right_column();
}

// Road below the horizon, invalid sky (-16), the box in front; noise +-2 Q4 (+-0.125 px).
Plane road_with_box(uint32_t seed) {
  Plane plane(kWidth, kHeight, {ElementType::s16, 4}, kWidth * 2 + 10);
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> noise_q4(-2, 2);
  for (int v = 0; v < kHeight; ++v) {
    const double road_px = road_slope() * (v - horizon_row());
    for (int u = 0; u < kWidth; ++u) {
      const double d = in_box(u, v) ? box_disparity_px() : road_px;
      plane.at<int16_t>(u, v) = d > 0.0 ? static_cast<int16_t>(std::lround(d * 16.0) + noise_q4(generator)) : int16_t{-16};
    }
  }
  return plane;
}

TEST(ObstacleMaskGraph, FindsTheRoadMarksTheBoxAndPeaksInItsGridCell) {
  GraphSpec spec = load_graph_spec(std::string(LPSTEREO_SOURCE_DIR) + "/graphs/obstacle-mask.json");
  nlohmann::json aud_params;
  for (NodeSpec& node : spec.nodes) {
    if (node.task == "road_profile") node.params["principal_row_px"] = kPrincipalRowPx;
    if (node.kernel == "advanced_u_disparity") aud_params = node.params;
  }
  Graph graph(spec);
  VerifyOptions options;
  options.frame_width = kWidth;
  options.frame_height = kHeight;
  graph.verify(options);

  const Plane disparity = road_with_box(7);
  const int columns_per_cell = aud_params.at("columns_per_cell").get<int>();
  const kernels::AudGridGeometry geometry{aud_params.at("min_disparity_px").get<double>(),
                                          aud_params.at("max_disparity_px").get<double>(),
                                          aud_params.at("exponent_k").get<double>(), aud_params.at("grid_rows").get<int>()};
  // Eq. 4.2 at the box's disparity (21 px +- 0.125): floor(128 ln(d / 2) / ln(64)) = 72 (71.9 .. 72.8).
  const double box_grid_row = geometry.grid_rows * std::log(box_disparity_px() / geometry.min_disparity_px) /
                              std::log(geometry.max_disparity_px / geometry.min_disparity_px);

  std::vector<Plane> masks, grids;
  for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
    arm::FrameRunner runner(graph, 2, backend);
    runner.process({{"disparity", &disparity}});
    const arm::RoadProfile road = arm::decode_road_profile(runner.buffer("road"));
    ASSERT_TRUE(road.valid);
    EXPECT_NEAR(road.slope, road_slope(), 0.01);
    const Plane& mask = runner.buffer("mask");
    const Plane& grid = runner.buffer("grid");

    // The box's pixels away from its edges and from its foot (within the road margin there): obstacles.
    int box_pixels = 0, box_obstacles = 0, road_pixels = 0, road_obstacles = 0;
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        const uint8_t value = mask.at<uint8_t>(u, v);
        if (in_box(u, v) && v <= box_foot_row() - 8) {
          ++box_pixels;
          box_obstacles += value == kernels::kMaskObstacle;
        } else if (!in_box(u, v) && v > horizon_row() + 2) {
          ++road_pixels;
          road_obstacles += value == kernels::kMaskObstacle;
          EXPECT_NE(value, kernels::kMaskNoVote) << "a valid road pixel in the region casts a vote: u=" << u << " v=" << v;
        }
      }
    }
    ASSERT_GT(box_pixels, 60 * 60);
    EXPECT_GE(box_obstacles, box_pixels * 97 / 100) << box_obstacles << " of " << box_pixels;
    EXPECT_LE(road_obstacles, road_pixels / 1000) << road_obstacles << " of " << road_pixels;

    // The grid's maximum: in the box's columns, in the row of its disparity.
    int best_column = -1, best_row = -1, best_value = -1;
    for (int row = 0; row < grid.height(); ++row) {
      for (int column = 0; column < grid.width(); ++column) {
        if (grid.at<uint16_t>(column, row) > best_value) best_column = column, best_row = row, best_value = grid.at<uint16_t>(column, row);
      }
    }
    EXPECT_GE(best_column, static_cast<int>(box_left_column()) / columns_per_cell);
    EXPECT_LE(best_column, static_cast<int>(box_right_column()) / columns_per_cell);
    EXPECT_NEAR(best_row, box_grid_row, 1.0);
    EXPECT_GT(best_value, 0);
    masks.push_back(mask);
    grids.push_back(grid);
  }
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) ASSERT_EQ(masks[0].at<uint8_t>(u, v), masks[1].at<uint8_t>(u, v)) << u << " " << v;
  }
  for (int row = 0; row < grids[0].height(); ++row) {
    for (int column = 0; column < grids[0].width(); ++column) {
      ASSERT_EQ(grids[0].at<uint16_t>(column, row), grids[1].at<uint16_t>(column, row)) << column << " " << row;
    }
  }
}

}  // namespace
}  // namespace lpstereo
