// ARM tasks obstacle_clusters and obstacle_feature_validation on hand-built planes: a grid, a mask
// and a disparity map whose clusters, bounding boxes, distances and positions follow by hand from the
// pinhole model; eq. 4.3's threshold at its boundary and its near/far switch; the 8-connected flood
// fill (diagonal cells join, a U joins, a 1-cell speck is dropped); the nearest max_obstacles kept;
// the counted ArmWork closed forms; keypoint validation dropping a cluster without a keypoint.
#include <gtest/gtest.h>

#include <functional>

#include <array>
#include <string>
#include <vector>

#include "arm/tasks/keypoint_record.h"
#include "arm/tasks/obstacle_record.h"
#include "dag/arm_task.h"
#include "kernels/advanced_u_disparity.h"
#include "kernels/obstacle_mask.h"

namespace lpstereo {
namespace {

using arm::Obstacle;

constexpr int kWidth = 40;
constexpr int kHeight = 30;
constexpr int kColumnsPerCell = 4;
constexpr int kGridColumns = 10;  // ceil(40 / 4)
constexpr int kGridRows = 8;
constexpr int16_t kInvalidQ4 = -16;
// Grid geometry d_min 2 px, d_max 66 px, k 1, 8 rows: boundaries ceil(16 * 2 * 33^(r / 8)) =
// 32, 50, 77, 119, 184, 285, 441, 683, 1056 (Q4); so 6 px (96) is row 2, 10 px (160) row 3, 20 px
// (320) row 5.

struct Frame {
  Plane grid{kGridColumns, kGridRows, {ElementType::u16, 0}, kGridColumns * 2 + 6};
  Plane disparity{kWidth, kHeight, {ElementType::s16, 4}, kWidth * 2 + 10};
  Plane mask{kWidth, kHeight, {ElementType::u8, 0}, kWidth + 7};
  Frame() {
    for (int r = 0; r < kGridRows; ++r) {
      for (int c = 0; c < kGridColumns; ++c) grid.at<uint16_t>(c, r) = 0;
    }
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        disparity.at<int16_t>(u, v) = kInvalidQ4;
        mask.at<uint8_t>(u, v) = kernels::kMaskNoVote;
      }
    }
  }
  void paint(int x0, int y0, int x1, int y1, uint8_t value, int16_t disparity_q4) {
    for (int v = y0; v <= y1; ++v) {
      for (int u = x0; u <= x1; ++u) {
        mask.at<uint8_t>(u, v) = value;
        disparity.at<int16_t>(u, v) = disparity_q4;
      }
    }
  }
};

nlohmann::json base_params() {
  return {{"columns_per_cell", kColumnsPerCell}, {"grid_rows", kGridRows}, {"min_disparity_px", 2.0},
          {"max_disparity_px", 66.0},          {"exponent_k", 1.0},       {"obstacle_weight", 2},
          {"focal_px", 100.0},                 {"baseline_m", 0.5},       {"principal_point_x_px", 19.5},
          {"principal_point_y_px", 14.0},      {"max_obstacles", 4}};
}

const ArmTaskDescriptor& task_named(const std::string& name) {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find(name);
  if (task == nullptr) throw std::runtime_error("ARM task '" + name + "' is not registered");
  return *task;
}

struct TaskRun {
  Plane output;
  ArmWork work;
};

TaskRun run_clusters(const Frame& frame, const nlohmann::json& params) {
  const ArmTaskDescriptor& task = task_named("obstacle_clusters");
  const PreparedKernel prepared = task.prepare(
      params, {{frame.grid.width(), frame.grid.height()}, {kWidth, kHeight}, {frame.mask.width(), frame.mask.height()}});
  TaskRun result{Plane(prepared.output_shapes.at(0).width, prepared.output_shapes.at(0).height, {ElementType::s32, 0}), {}};
  ArmTaskArgs args{{&frame.grid, &frame.disparity, &frame.mask}, {&result.output}, prepared.params.get(), &result.work};
  task.run(args);
  return result;
}

std::vector<Obstacle> clusters(const Frame& frame, const nlohmann::json& params) {
  return arm::decode_obstacles(run_clusters(frame, params).output);
}

// Two objects: A (x 8..15, y 10..19, 20 px) in grid cells (2, 5) and (3, 5); B (x 28..35, y 5..9,
// 10 px) in cells (7, 3) and (8, 3). Around them, pixels that must not count: obstacle pixels in
// an unoccupied cell, free pixels inside A's cells, obstacle pixels in A's columns at a disparity
// whose row is not occupied, and an obstacle pixel with an invalid disparity.
Frame two_objects() {
  Frame frame;
  frame.paint(8, 10, 15, 19, kernels::kMaskObstacle, 320);
  frame.paint(28, 5, 35, 9, kernels::kMaskObstacle, 160);
  frame.grid.at<uint16_t>(2, 5) = frame.grid.at<uint16_t>(3, 5) = 60000;
  frame.grid.at<uint16_t>(7, 3) = frame.grid.at<uint16_t>(8, 3) = 60000;
  frame.paint(0, 0, 3, 3, kernels::kMaskObstacle, 320);   // cell (0, 5): not occupied
  frame.paint(8, 20, 15, 24, kernels::kMaskFree, 320);    // free pixels in A's cells
  frame.paint(8, 25, 15, 25, kernels::kMaskObstacle, 160);  // cells (2, 3), (3, 3): not occupied
  frame.paint(12, 28, 12, 28, kernels::kMaskObstacle, kInvalidQ4);
  return frame;
}

TEST(ObstacleClusters, TwoObjectsGiveTheirBoxesDistancesAndPositions) {
  const std::vector<Obstacle> obstacles = clusters(two_objects(), base_params());
  ASSERT_EQ(obstacles.size(), 2u);
  // Fill order: raster over the grid from row 0 (far), so B (row 3) is cluster 1, A (row 5) cluster 2.
  const Obstacle& b = obstacles[0];
  const Obstacle& a = obstacles[1];
  EXPECT_EQ(b.id, 1);
  EXPECT_EQ(a.id, 2);
  // A: 8 x 10 = 80 pixels at 20 px: z = f B / d = 100 * 0.5 / 20 = 2.5 m, 0.025 m per pixel; foot
  // u = (8 + 15) / 2 = 11.5, x = (11.5 - 19.5) 0.025 = -0.2 m; v = 19, y = (19 - 14) 0.025 = 0.125 m;
  // width 8 px = 0.2 m, height 10 px = 0.25 m.
  EXPECT_EQ(a.bbox_px[0], 8);
  EXPECT_EQ(a.bbox_px[1], 10);
  EXPECT_EQ(a.bbox_px[2], 15);
  EXPECT_EQ(a.bbox_px[3], 19);
  EXPECT_EQ(a.pixels, 80);
  EXPECT_DOUBLE_EQ(a.disparity_px, 20.0);
  EXPECT_DOUBLE_EQ(a.distance_m, 2.5);
  EXPECT_DOUBLE_EQ(a.position_m[0], -0.2);
  EXPECT_DOUBLE_EQ(a.position_m[1], 0.125);
  EXPECT_DOUBLE_EQ(a.position_m[2], 2.5);
  EXPECT_DOUBLE_EQ(a.width_m, 0.2);
  EXPECT_DOUBLE_EQ(a.height_m, 0.25);
  EXPECT_EQ(a.cells, 2);
  EXPECT_EQ(a.cell_box[0], 2);
  EXPECT_EQ(a.cell_box[1], 5);
  EXPECT_EQ(a.cell_box[2], 3);
  EXPECT_EQ(a.cell_box[3], 5);
  EXPECT_EQ(a.features, 0);
  EXPECT_EQ(a.track_id, 0);
  // B: 8 x 5 = 40 pixels at 10 px: z = 5 m, 0.05 m per pixel; foot u = 31.5, x = 12 * 0.05 = 0.6 m;
  // v = 9, y = -5 * 0.05 = -0.25 m (above the principal point); 0.4 m wide, 0.25 m tall.
  EXPECT_EQ(b.bbox_px[0], 28);
  EXPECT_EQ(b.bbox_px[1], 5);
  EXPECT_EQ(b.bbox_px[2], 35);
  EXPECT_EQ(b.bbox_px[3], 9);
  EXPECT_EQ(b.pixels, 40);
  EXPECT_DOUBLE_EQ(b.distance_m, 5.0);
  EXPECT_DOUBLE_EQ(b.position_m[0], 0.6);
  EXPECT_DOUBLE_EQ(b.position_m[1], -0.25);
  EXPECT_DOUBLE_EQ(b.width_m, 0.4);
  EXPECT_DOUBLE_EQ(b.height_m, 0.25);
  EXPECT_EQ(b.cells, 2);
  EXPECT_EQ(b.cell_box[0], 7);
  EXPECT_EQ(b.cell_box[1], 3);
  EXPECT_EQ(b.cell_box[2], 8);
  EXPECT_EQ(b.cell_box[3], 3);
}

TEST(ObstacleClusters, MeanDisparityAndDefaultPrincipalPoint) {
  Frame frame;
  // One cell (5, 5) with half its pixels at 20 px, half at 24 px: mean 22 px; z = 50 / 22 m.
  frame.paint(20, 0, 23, 3, kernels::kMaskObstacle, 320);
  frame.paint(20, 4, 23, 7, kernels::kMaskObstacle, 384);
  frame.grid.at<uint16_t>(5, 5) = 1000;
  nlohmann::json params = base_params();
  params.erase("principal_point_x_px");
  params.erase("principal_point_y_px");
  params["min_cells"] = 1;
  const std::vector<Obstacle> obstacles = clusters(frame, params);
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_EQ(obstacles[0].pixels, 32);
  EXPECT_DOUBLE_EQ(obstacles[0].disparity_px, 22.0);
  const double z = 50.0 / 22.0;
  EXPECT_NEAR(obstacles[0].distance_m, z, 0.0005);
  // Default principal point: the image centre (19.5, 14.5); foot (21.5, 7).
  EXPECT_NEAR(obstacles[0].position_m[0], 2.0 * z / 100.0, 0.0005);
  EXPECT_NEAR(obstacles[0].position_m[1], -7.5 * z / 100.0, 0.0005);
}

// Eq. 4.3 with focal 1000 px, baseline 0.3 m, obstacle weight 2, heights 0.03 / 0.25 m, switch 50 m.
// Row centres d_r = 2 * 33^((r + 0.5) / 8): row 2 d = 5.964 px (z = 300 / d = 50.30 m: far), row 3
// d = 9.234 px (32.49 m: near). Thresholds T = ceil(2 max(1, Y / 0.3 d)):
//   row 2 far:  2 * 0.25 / 0.3 * 5.964 = 9.94 -> 10;   row 2 near: 2 * max(1, 0.596) -> 2;
//   row 3 near: 2 * max(1, 0.923) -> 2;                 row 3 far:  2 * 0.25 / 0.3 * 9.234 = 15.39 -> 16.
Frame threshold_frame() {
  Frame frame;
  // One-cell clusters, never adjacent: (0, 2) = 10, (3, 2) = 9, (6, 3) = 2, (9, 3) = 1; each with
  // one obstacle pixel at its row's disparity (6 px in row 2, 10 px in row 3).
  const struct {
    int column, row;
    uint16_t votes;
    int16_t disparity_q4;
  } cells[] = {{0, 2, 10, 96}, {3, 2, 9, 96}, {6, 3, 2, 160}, {9, 3, 1, 160}};
  for (const auto& cell : cells) {
    frame.grid.at<uint16_t>(cell.column, cell.row) = cell.votes;
    frame.paint(cell.column * kColumnsPerCell, 0, cell.column * kColumnsPerCell, 0, kernels::kMaskObstacle, cell.disparity_q4);
  }
  return frame;
}

nlohmann::json threshold_params() {
  nlohmann::json params = base_params();
  params["focal_px"] = 1000.0;
  params["baseline_m"] = 0.3;
  params["min_cells"] = 1;
  params["min_pixels"] = 1;
  params["near_min_height_m"] = 0.03;
  params["far_min_height_m"] = 0.25;
  params["height_switch_distance_m"] = 50.0;
  return params;
}

std::vector<int> first_columns(const std::vector<Obstacle>& obstacles) {
  std::vector<int> columns;
  for (const Obstacle& obstacle : obstacles) columns.push_back(obstacle.cell_box[0]);
  return columns;
}

TEST(ObstacleClusters, ThresholdIsEq43WithTheNearAndFarHeights) {
  const Frame frame = threshold_frame();
  // Switch 50 m: row 2 far (T 10): 10 passes, 9 does not; row 3 near (T 2): 2 passes, 1 does not.
  EXPECT_EQ(first_columns(clusters(frame, threshold_params())), (std::vector<int>{0, 6}));
  // Switch 60 m: row 2 (50.3 m) is near now (T 2): 9 passes too.
  nlohmann::json params = threshold_params();
  params["height_switch_distance_m"] = 60.0;
  EXPECT_EQ(first_columns(clusters(frame, params)), (std::vector<int>{0, 3, 6}));
  // Switch 30 m: row 3 (32.5 m) is far now (T 16): 2 no longer passes.
  params["height_switch_distance_m"] = 30.0;
  EXPECT_EQ(first_columns(clusters(frame, params)), (std::vector<int>{0}));
}

TEST(ObstacleClusters, MinWidthScalesTheThresholdByTheColumnsAnObjectCovers) {
  // min_width_m 0.1: row 3 covers 0.1 * 9.234 / 0.3 = 3.08 columns -> T = ceil(2 * 1 * 3.08) = 7;
  // row 2 (far): 0.1 * 5.964 / 0.3 = 1.99 columns -> T = ceil(9.94 * 1.99) = 20. Votes 20 and 7 pass,
  // 19 and 6 do not.
  Frame frame = threshold_frame();
  frame.grid.at<uint16_t>(0, 2) = 20;
  frame.grid.at<uint16_t>(3, 2) = 19;
  frame.grid.at<uint16_t>(6, 3) = 7;
  frame.grid.at<uint16_t>(9, 3) = 6;
  nlohmann::json params = threshold_params();
  params["min_width_m"] = 0.1;
  EXPECT_EQ(first_columns(clusters(frame, params)), (std::vector<int>{0, 6}));
}

// Occupied cells (row, column), one obstacle pixel at the row's disparity in each.
Frame cell_frame(const std::vector<std::pair<int, int>>& cells) {
  Frame frame;
  const kernels::AudGridGeometry geometry{2.0, 66.0, 1.0, kGridRows};
  const std::vector<int32_t> boundaries = kernels::aud_row_boundaries_q4(geometry);
  for (const auto& [row, column] : cells) {
    frame.grid.at<uint16_t>(column, row) = 1000;
    frame.paint(column * kColumnsPerCell + 1, row, column * kColumnsPerCell + 1, row, kernels::kMaskObstacle,
                static_cast<int16_t>(boundaries[static_cast<size_t>(row)]));
  }
  return frame;
}

TEST(ObstacleClusters, FloodFillJoinsDiagonalCellsAndDropsASpeck) {
  // Cluster 1: (1, 1) and (2, 2), diagonal neighbours. Cluster 2: a U of 7 cells opening upwards,
  // (3, 5), (4, 5), (5, 5), (5, 6), (5, 7), (4, 7), (3, 7): its two arms meet only at the bottom, so a
  // single raster pass would label them apart. A speck (0, 9) alone: dropped with min_cells 2.
  const Frame frame = cell_frame({{1, 1}, {2, 2}, {3, 5}, {4, 5}, {5, 5}, {5, 6}, {5, 7}, {4, 7}, {3, 7}, {0, 9}});
  nlohmann::json params = base_params();
  params["min_cells"] = 2;
  params["min_pixels"] = 1;
  const std::vector<Obstacle> obstacles = clusters(frame, params);
  ASSERT_EQ(obstacles.size(), 2u);
  EXPECT_EQ(obstacles[0].cells, 2);
  EXPECT_EQ(obstacles[0].pixels, 2);
  EXPECT_EQ(obstacles[0].cell_box[0], 1);
  EXPECT_EQ(obstacles[0].cell_box[1], 1);
  EXPECT_EQ(obstacles[0].cell_box[2], 2);
  EXPECT_EQ(obstacles[0].cell_box[3], 2);
  EXPECT_EQ(obstacles[1].cells, 7);
  EXPECT_EQ(obstacles[1].pixels, 7);
  EXPECT_EQ(obstacles[1].cell_box[0], 5);
  EXPECT_EQ(obstacles[1].cell_box[1], 3);
  EXPECT_EQ(obstacles[1].cell_box[2], 7);
  EXPECT_EQ(obstacles[1].cell_box[3], 5);
  EXPECT_EQ(obstacles[0].id, 1);
  EXPECT_EQ(obstacles[1].id, 2);
  // With min_cells 1 the speck is a cluster of its own: it is filled first (row 0).
  params["min_cells"] = 1;
  const std::vector<Obstacle> with_speck = clusters(frame, params);
  ASSERT_EQ(with_speck.size(), 3u);
  EXPECT_EQ(with_speck[0].cells, 1);
  EXPECT_EQ(with_speck[0].cell_box[0], 9);
}

TEST(ObstacleClusters, MinPixelsDropsAClusterWithFewPixels) {
  Frame frame = two_objects();
  nlohmann::json params = base_params();
  params["min_pixels"] = 41;  // B has 40, A 80
  const std::vector<Obstacle> obstacles = clusters(frame, params);
  ASSERT_EQ(obstacles.size(), 1u);
  EXPECT_EQ(obstacles[0].pixels, 80);
  EXPECT_EQ(obstacles[0].id, 1);  // ids count the clusters left, in fill order
}

TEST(ObstacleClusters, MoreClustersThanRecordsKeepsTheNearestInFillOrder) {
  // Single cells in rows 1, 3, 5, 7 (far to near), one record less than clusters: the far one goes.
  const Frame frame = cell_frame({{1, 0}, {3, 3}, {5, 6}, {7, 9}});
  nlohmann::json params = base_params();
  params["min_cells"] = 1;
  params["min_pixels"] = 1;
  params["max_obstacles"] = 3;
  const std::vector<Obstacle> obstacles = clusters(frame, params);
  ASSERT_EQ(obstacles.size(), 3u);
  EXPECT_EQ(obstacles[0].id, 2);
  EXPECT_EQ(obstacles[1].id, 3);
  EXPECT_EQ(obstacles[2].id, 4);
  EXPECT_EQ(obstacles[0].cell_box[1], 3);
  EXPECT_EQ(obstacles[2].cell_box[1], 7);
}

TEST(ObstacleClusters, EmptyGridGivesNoRecords) {
  const TaskRun run = run_clusters(Frame(), base_params());
  EXPECT_TRUE(arm::decode_obstacles(run.output).empty());
  for (int row = 0; row < run.output.height(); ++row) {
    for (int word = 0; word < arm::kObstacleWords; ++word) EXPECT_EQ(run.output.at<int32_t>(word, row), 0);
  }
}

TEST(ObstacleClusters, CountedWorkIsTheClosedForm) {
  // two_objects: C R = 80 cells, O = 4 occupied, K = 2 clusters, W H = 1200 pixels, P = 80 + 40 + 16
  // + 8 + 1 = 145 obstacle pixels, Q = 120 in a cluster, L = 2 <= M = 4.
  const TaskRun run = run_clusters(two_objects(), base_params());
  EXPECT_EQ(run.work.scalar_ops, 2u * 80 + 28u * 4 + 8u * 2 + 2u * 1200 + 5u * 145 + 6u * 120 + 48u * 2);
  EXPECT_EQ(run.work.memory_bytes, 6u * 80 + 3u * 1200 + 4u * arm::kObstacleWords * 4);
}

TEST(ObstacleClusters, PrepareNamesTheBadParameterOrShape) {
  const ArmTaskDescriptor& task = task_named("obstacle_clusters");
  const std::vector<PlaneShape> shapes = {{kGridColumns, kGridRows}, {kWidth, kHeight}, {kWidth, kHeight}};
  nlohmann::json params = base_params();
  params.erase("baseline_m");
  try {
    task.prepare(params, shapes);
    FAIL() << "no baseline accepted";
  } catch (const KernelError& error) {
    EXPECT_NE(std::string(error.what()).find("'baseline_m'"), std::string::npos) << error.what();
  }
  try {
    task.prepare(base_params(), {{kGridColumns + 1, kGridRows}, {kWidth, kHeight}, {kWidth, kHeight}});
    FAIL() << "wrong grid accepted";
  } catch (const KernelError& error) {
    EXPECT_NE(std::string(error.what()).find("input 'grid': expected ceil(40 / columns_per_cell 4) x grid_rows = 10x8, got 11x8"),
              std::string::npos)
        << error.what();
  }
  params = base_params();
  params["max_disparity_px"] = 1.5;
  EXPECT_THROW(task.prepare(params, shapes), KernelError);
  params = base_params();
  params["columns_per_cel"] = 4;
  EXPECT_THROW(task.prepare(params, shapes), KernelError);
}

// Feature validation.

Plane obstacle_records(const std::vector<std::array<int, 5>>& boxes, int rows) {  // id, x0, y0, x1, y1
  Plane records(arm::kObstacleWords, rows, {ElementType::s32, 0});
  for (int row = 0; row < rows; ++row) {
    for (int word = 0; word < arm::kObstacleWords; ++word) records.at<int32_t>(word, row) = 0;
  }
  for (size_t i = 0; i < boxes.size(); ++i) {
    const int row = static_cast<int>(i);
    records.at<int32_t>(arm::kObstacleValid, row) = 1;
    records.at<int32_t>(arm::kObstacleId, row) = boxes[i][0];
    for (int k = 0; k < 4; ++k) records.at<int32_t>(arm::kObstacleX0 + k, row) = boxes[i][1 + k];
    records.at<int32_t>(arm::kObstaclePixels, row) = 100 + row;
    records.at<int32_t>(arm::kObstacleDistanceMm, row) = 5000 + row;
  }
  return records;
}

Plane keypoint_list(const std::vector<std::pair<int, int>>& points, int rows) {
  Plane keypoints(arm::kKeypointWords, rows, {ElementType::s32, 0});
  for (int row = 0; row < rows; ++row) {
    for (int word = 0; word < arm::kKeypointWords; ++word) keypoints.at<int32_t>(word, row) = 0;
  }
  for (size_t i = 0; i < points.size(); ++i) {
    const int row = static_cast<int>(i);
    keypoints.at<int32_t>(arm::kKeypointValid, row) = 1;
    keypoints.at<int32_t>(arm::kKeypointXPx, row) = points[i].first;
    keypoints.at<int32_t>(arm::kKeypointYPx, row) = points[i].second;
    keypoints.at<int32_t>(arm::kKeypointResponse, row) = 1000;
  }
  return keypoints;
}

// A 48 x 40 mask, all free, with obstacle pixels where `obstacle` says.
Plane validation_mask(const std::function<bool(int, int)>& obstacle) {
  Plane mask(48, 40, {ElementType::u8, 0});
  for (int y = 0; y < 40; ++y) {
    for (int x = 0; x < 48; ++x) mask.at<uint8_t>(x, y) = obstacle(x, y) ? kernels::kMaskObstacle : kernels::kMaskFree;
  }
  return mask;
}

// Without "mask_radius_px" in `params` the mask is not consulted (-1): the box tests below.
TaskRun run_validation(const Plane& records, const Plane& keypoints, nlohmann::json params,
                       const Plane& mask = validation_mask([](int, int) { return false; })) {
  if (!params.contains("mask_radius_px")) params["mask_radius_px"] = -1;
  if (!params.contains("min_features")) params["min_features"] = 1;  // the records below are all near (5 m)
  const ArmTaskDescriptor& task = task_named("obstacle_feature_validation");
  const PreparedKernel prepared = task.prepare(
      params, {{records.width(), records.height()}, {keypoints.width(), keypoints.height()}, {mask.width(), mask.height()}});
  TaskRun result{Plane(prepared.output_shapes.at(0).width, prepared.output_shapes.at(0).height, {ElementType::s32, 0}), {}};
  ArmTaskArgs args{{&records, &keypoints, &mask}, {&result.output}, prepared.params.get(), &result.work};
  task.run(args);
  return result;
}

TEST(ObstacleFeatureValidation, DropsTheClusterWithoutAKeypointAndCountsTheOthers) {
  // Three records; boxes grown by 2 px: id 1 [8, 18] x [8, 22], id 2 [28, 37] x [3, 11], id 5
  // [0, 6] x [23, 29]. Keypoints: (18, 22) on id 1's grown corner, (19, 15) one px outside it,
  // (12, 12) inside id 1; (30, 12) one px below id 2's grown box; (3, 26) inside id 5; a row with
  // valid = 0 and then a keypoint inside id 2 that must be ignored (the list ended).
  const Plane records = obstacle_records({{1, 10, 10, 16, 20}, {2, 30, 5, 35, 9}, {5, 2, 25, 4, 27}}, 5);
  Plane keypoints = keypoint_list({{18, 22}, {19, 15}, {12, 12}, {30, 12}, {3, 26}}, 8);
  keypoints.at<int32_t>(arm::kKeypointValid, 6) = 1;
  keypoints.at<int32_t>(arm::kKeypointXPx, 6) = 32;
  keypoints.at<int32_t>(arm::kKeypointYPx, 6) = 7;
  const TaskRun run = run_validation(records, keypoints, {{"margin_px", 2}});  // min_features 1 (run_validation)
  const std::vector<Obstacle> validated = arm::decode_obstacles(run.output);
  ASSERT_EQ(validated.size(), 2u);
  EXPECT_EQ(validated[0].id, 1);
  EXPECT_EQ(validated[0].features, 2);
  EXPECT_EQ(validated[0].pixels, 100);
  EXPECT_EQ(validated[1].id, 5);  // compacted into row 1, id kept
  EXPECT_EQ(validated[1].features, 1);
  EXPECT_EQ(validated[1].pixels, 102);
  EXPECT_DOUBLE_EQ(validated[1].distance_m, 5.002);
  for (int row = 2; row < run.output.height(); ++row) {
    for (int word = 0; word < arm::kObstacleWords; ++word) EXPECT_EQ(run.output.at<int32_t>(word, row), 0) << row;
  }
  // Counted work: O = 3 records, V = 5 keypoints, N = 5 rows, 2 kept.
  EXPECT_EQ(run.work.scalar_ops, 3u * (6 + 6 * 5) + 5 + 1 + 2u * arm::kObstacleWords);
  EXPECT_EQ(run.work.memory_bytes, 4u * arm::kKeypointWords * 5 + 2u * 4 * arm::kObstacleWords * 5);
  // min_features 2 keeps id 1 only; 0 keeps all three, counting.
  EXPECT_EQ(arm::decode_obstacles(run_validation(records, keypoints, {{"margin_px", 2}, {"min_features", 2}}).output).size(), 1u);
  const std::vector<Obstacle> all =
      arm::decode_obstacles(run_validation(records, keypoints, {{"margin_px", 2}, {"min_features", 0}}).output);
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[1].features, 0);
  // margin 0: (18, 22) falls outside id 1's box, (12, 12) stays.
  EXPECT_EQ(arm::decode_obstacles(run_validation(records, keypoints, {{"margin_px", 0}}).output)[0].features, 1);
}

// With the mask: a keypoint counts only when an obstacle-mask pixel lies within mask_radius_px of
// it. Record id 1's box [10, 16] x [10, 20] holds the keypoints (12, 12) and (15, 19); the mask marks
// obstacle pixels only on rows 10 .. 14 (the object's upper part; below, its foot and the road).
// Radius 1: (12, 12) counts, (15, 19) does not (nearest obstacle row 14 is 5 away); radius 0 the
// same; radius 5 both count. A box whose only keypoint stands on road pixels is dropped.
TEST(ObstacleFeatureValidation, CountsOnlyKeypointsOnObstaclePixels) {
  const Plane records = obstacle_records({{1, 10, 10, 16, 20}, {2, 30, 5, 35, 9}}, 3);
  const Plane keypoints = keypoint_list({{12, 12}, {15, 19}, {32, 7}}, 4);
  const Plane mask = validation_mask([](int x, int y) { return x >= 10 && x <= 16 && y >= 10 && y <= 14; });
  const std::vector<Obstacle> radius1 = arm::decode_obstacles(run_validation(records, keypoints, {{"margin_px", 0}, {"mask_radius_px", 1}}, mask).output);
  ASSERT_EQ(radius1.size(), 1u);  // id 2's keypoint (32, 7) stands on free pixels
  EXPECT_EQ(radius1[0].id, 1);
  EXPECT_EQ(radius1[0].features, 1);
  EXPECT_EQ(arm::decode_obstacles(run_validation(records, keypoints, {{"margin_px", 0}, {"mask_radius_px", 0}}, mask).output)[0].features, 1);
  EXPECT_EQ(arm::decode_obstacles(run_validation(records, keypoints, {{"margin_px", 0}, {"mask_radius_px", 5}}, mask).output)[0].features, 2);
  // Counted work with radius 1: the two keypoints inside id 1's box and the one inside id 2's each
  // look at up to 9 mask pixels (2 ops and 1 byte each; the search stops at the first obstacle
  // pixel only in the model's favour: the count is of the pixels the task reads, (2 r + 1)^2 always).
  const TaskRun run = run_validation(records, keypoints, {{"margin_px", 0}, {"mask_radius_px", 1}}, mask);
  EXPECT_EQ(run.work.scalar_ops, 2u * (6 + 6 * 3) + 3 + 1 + 1u * arm::kObstacleWords + 2u * 9 * 3);
  EXPECT_EQ(run.work.memory_bytes, 4u * arm::kKeypointWords * 3 + 2u * 4 * arm::kObstacleWords * 3 + 9u * 3);
}

// Near and far: a record nearer than far_distance_m needs min_features corners, a farther one
// far_min_features. Two records with one corner each, at 59.999 m and at 60.000 m: with min_features 2,
// far_min_features 1, far_distance_m 60 only the second stays.
TEST(ObstacleFeatureValidation, NearRecordsNeedMoreCornersThanFarOnes) {
  Plane records = obstacle_records({{1, 10, 10, 16, 20}, {2, 30, 5, 35, 9}}, 3);
  records.at<int32_t>(arm::kObstacleDistanceMm, 0) = 59999;
  records.at<int32_t>(arm::kObstacleDistanceMm, 1) = 60000;
  const Plane keypoints = keypoint_list({{12, 12}, {32, 7}}, 4);
  const std::vector<Obstacle> kept = arm::decode_obstacles(
      run_validation(records, keypoints, {{"margin_px", 0}, {"min_features", 2}, {"far_min_features", 1}, {"far_distance_m", 60.0}}).output);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_EQ(kept[0].id, 2);
  EXPECT_EQ(kept[0].features, 1);
  // With far_distance_m 61 both are near and both go.
  EXPECT_TRUE(arm::decode_obstacles(run_validation(records, keypoints,
                                                   {{"margin_px", 0}, {"min_features", 2}, {"far_min_features", 1}, {"far_distance_m", 61.0}})
                                        .output)
                  .empty());
}

TEST(ObstacleFeatureValidation, PrepareChecksTheRecordWidths) {
  const ArmTaskDescriptor& task = task_named("obstacle_feature_validation");
  EXPECT_THROW(task.prepare({}, {{arm::kObstacleWords - 1, 4}, {arm::kKeypointWords, 4}, {8, 8}}), KernelError);
  EXPECT_THROW(task.prepare({}, {{arm::kObstacleWords, 4}, {arm::kKeypointWords + 1, 4}, {8, 8}}), KernelError);
  EXPECT_THROW(task.prepare({{"margin_px", -1}}, {{arm::kObstacleWords, 4}, {arm::kKeypointWords, 4}, {8, 8}}), KernelError);
  EXPECT_THROW(task.prepare({{"mask_radius_px", 9}}, {{arm::kObstacleWords, 4}, {arm::kKeypointWords, 4}, {8, 8}}), KernelError);
  EXPECT_THROW(task.prepare({}, {{arm::kObstacleWords, 4}, {arm::kKeypointWords, 4}}), KernelError);  // no mask
}

}  // namespace
}  // namespace lpstereo
