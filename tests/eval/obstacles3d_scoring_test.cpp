// The scoring rules of bench/obstacles3d_eval (eval/obstacles3d_scoring.h) on hand-built cases: the
// gate, whether a hanging object's lower edge is seen, which obstacle is scored as its lower edge,
// the free space under it, and the half-occlusion test of the measurable pixels. Every expected value
// is worked out in the comment beside it from the rule's text, not read off the code.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "eval/obstacles3d_scoring.h"

namespace lpstereo {
namespace {

namespace o3 = arm::obstacles3d;

// f = 554.3 px, B = 0.3 m: sigma_Z(z) = z^2 0.25 / 166.29.
o3::StereoErrorModel error_model() {
  o3::StereoErrorModel model;
  model.focal_px = 554.3;
  model.baseline_m = 0.3;
  return model;
}

io::SynthObjectTruth truth_of(io::SynthClass object_class, double x_m, double z_m) {
  io::SynthObjectTruth truth;
  truth.id = 1;
  truth.object = io::synth_object(object_class, x_m, z_m);
  truth.position_m[0] = x_m;
  truth.position_m[2] = z_m;
  truth.distance_m = z_m;
  truth.min_height_m = io::synth_object_min_height_m(truth.object);
  truth.max_height_m = truth.object.height_m;
  return truth;
}

o3::Obstacle3d obstacle_at(double x_m, double z_m, double min_height_m, double max_height_m) {
  o3::Obstacle3d obstacle;
  obstacle.position_m = {x_m, 0, z_m};
  obstacle.min_height_m = min_height_m;
  obstacle.max_height_m = max_height_m;
  return obstacle;
}

// ---- the gate ----

TEST(Obstacles3dScoring, GateIsOneMetreBesideTheObjectAndOneMetreOrThreeDepthSigmasDeep) {
  // A box 0.40 m wide and 0.30 m long at 3 m: sigma_Z = 9 x 0.25 / 166.29 = 0.0135 m, so the depth
  // gate is the 1 m floor + 0.15 m; the lateral one 1 m + 0.20 m.
  const io::SynthObjectTruth box = truth_of(io::SynthClass::box, 0.5, 3.0);
  const eval::ObstacleGate near_gate = eval::gate_of(box, error_model());
  EXPECT_TRUE(eval::in_gate(obstacle_at(0.5 + 1.19, 3.0, 0, 0.4), box, near_gate));
  EXPECT_FALSE(eval::in_gate(obstacle_at(0.5 + 1.21, 3.0, 0, 0.4), box, near_gate));
  EXPECT_TRUE(eval::in_gate(obstacle_at(0.5 - 1.19, 3.0, 0, 0.4), box, near_gate));
  EXPECT_FALSE(eval::in_gate(obstacle_at(0.5 - 1.21, 3.0, 0, 0.4), box, near_gate));
  EXPECT_TRUE(eval::in_gate(obstacle_at(0.5, 3.0 + 1.14, 0, 0.4), box, near_gate));
  EXPECT_FALSE(eval::in_gate(obstacle_at(0.5, 3.0 + 1.16, 0, 0.4), box, near_gate));
  EXPECT_FALSE(eval::in_gate(obstacle_at(0.5, 3.0 - 1.16, 0, 0.4), box, near_gate));
  // The same box at 30 m: 3 sigma_Z = 3 x 900 x 0.25 / 166.29 = 4.059 m, + 0.15 m.
  const io::SynthObjectTruth far_box = truth_of(io::SynthClass::box, 0.5, 30.0);
  const eval::ObstacleGate far_gate = eval::gate_of(far_box, error_model());
  EXPECT_TRUE(eval::in_gate(obstacle_at(0.5, 30.0 + 4.19, 0, 0.4), far_box, far_gate));
  EXPECT_FALSE(eval::in_gate(obstacle_at(0.5, 30.0 + 4.23, 0, 0.4), far_box, far_gate));
  EXPECT_TRUE(eval::in_gate(obstacle_at(0.5, 30.0 - 4.19, 0, 0.4), far_box, far_gate));
  EXPECT_FALSE(eval::in_gate(obstacle_at(0.5, 30.0 - 4.23, 0, 0.4), far_box, far_gate));
  // Not wider for the range: 1 m + 0.2 m still.
  EXPECT_FALSE(eval::in_gate(obstacle_at(0.5 + 1.21, 30.0, 0, 0.4), far_box, far_gate));
}

TEST(Obstacles3dScoring, FloatingClassesAreTheBoardTheSignAndTheBall) {
  EXPECT_TRUE(eval::is_floating(io::SynthClass::board_on_poles));
  EXPECT_TRUE(eval::is_floating(io::SynthClass::hanging_sign));
  EXPECT_TRUE(eval::is_floating(io::SynthClass::ball_on_post));
  EXPECT_FALSE(eval::is_floating(io::SynthClass::box));
  EXPECT_FALSE(eval::is_floating(io::SynthClass::pedestrian));
  EXPECT_FALSE(eval::is_floating(io::SynthClass::car));
}

// ---- is the lower edge seen ----

TEST(Obstacles3dScoring, LowerEdgeIsSeenWithAQuarterOfItsBandOrTenPixels) {
  // A sign 1.2 m wide; its lowest 0.1 m covers 1.2 x 0.1 x f^2 / z^2 pixels.
  // At 10 m: 368.7 px, a quarter 92.2: 92 pixels are not enough, 93 are.
  const io::SynthObjectTruth sign_at_10 = truth_of(io::SynthClass::hanging_sign, 0, 10.0);
  EXPECT_FALSE(eval::lower_edge_seen(92, sign_at_10, 554.3));
  EXPECT_TRUE(eval::lower_edge_seen(93, sign_at_10, 554.3));
  // At 30 m: 40.97 px, a quarter 10.24: 10 are not enough, 11 are.
  const io::SynthObjectTruth sign_at_30 = truth_of(io::SynthClass::hanging_sign, 0, 30.0);
  EXPECT_FALSE(eval::lower_edge_seen(10, sign_at_30, 554.3));
  EXPECT_TRUE(eval::lower_edge_seen(11, sign_at_30, 554.3));
  // At 60 m: 10.24 px, a quarter 2.6: the floor of 10 pixels holds.
  const io::SynthObjectTruth sign_at_60 = truth_of(io::SynthClass::hanging_sign, 0, 60.0);
  EXPECT_FALSE(eval::lower_edge_seen(9, sign_at_60, 554.3));
  EXPECT_TRUE(eval::lower_edge_seen(10, sign_at_60, 554.3));
}

// ---- the lower edge and the free space of a hanging object ----

// A board on two poles at x 0, 15 m: 2 m wide, lower edge 0.9 m, top 1.6 m; the probe height is
// 0.9 + 0.2 = 1.1 m, the free space is checked within |dx| <= 1.0 - 0.3 = 0.7 m, below 0.8 m.
class HangingBoard : public ::testing::Test {
 protected:
  io::SynthObjectTruth board = truth_of(io::SynthClass::board_on_poles, 0, 15.0);
  eval::ObstacleGate gate = eval::gate_of(board, error_model());
  o3::Obstacle3d pole = obstacle_at(0.95, 15.0, 0.2, 0.85);           // under the probe height, beside the inner part
  o3::Obstacle3d board_report = obstacle_at(0.0, 15.1, 0.93, 1.6);    // spans 1.1 m
  o3::Obstacle3d arm_fragment = obstacle_at(0.2, 15.0, 2.4, 3.0);     // the highest lower edge, spans nothing of the board
};

TEST_F(HangingBoard, TheReportSpanningTheProbeHeightIsScoredNotTheHighestLowerEdge) {
  ASSERT_DOUBLE_EQ(board.min_height_m, 0.9);
  const std::vector<o3::Obstacle3d> obstacles{pole, board_report, arm_fragment};
  const eval::HangingObjectScore score = eval::score_hanging_object(obstacles, board, gate);
  ASSERT_EQ(score.scored, &obstacles[1]);
  EXPECT_TRUE(score.scored_spans_probe);
  EXPECT_NEAR(score.error_m, 0.03, 1e-12);
  EXPECT_TRUE(score.within_tolerance());
  // The former rule takes the fragment: 2.4 - 0.9 = 1.5 m off.
  ASSERT_EQ(score.highest_lower_edge, &obstacles[2]);
  EXPECT_NEAR(score.highest_lower_edge_error_m, 1.5, 1e-12);
  // Nothing lower than 0.8 m within 0.7 m of the board's centre: the pole is 0.95 m out.
  EXPECT_TRUE(score.free_space_checked);
  EXPECT_TRUE(score.free_space_kept());
}

TEST_F(HangingBoard, OfTwoSpanningReportsTheHigherLowerEdgeIsScored) {
  const o3::Obstacle3d board_and_pole = obstacle_at(0.8, 15.0, 0.2, 1.6);  // spans 1.1 m too, lower edge 0.2 m
  const std::vector<o3::Obstacle3d> obstacles{board_and_pole, board_report};
  const eval::HangingObjectScore score = eval::score_hanging_object(obstacles, board, gate);
  ASSERT_EQ(score.scored, &obstacles[1]);
  EXPECT_NEAR(score.error_m, 0.03, 1e-12);
}

TEST_F(HangingBoard, WithoutASpanningReportTheHighestLowerEdgeIsScoredAndIsOff) {
  const std::vector<o3::Obstacle3d> obstacles{pole, arm_fragment};
  const eval::HangingObjectScore score = eval::score_hanging_object(obstacles, board, gate);
  ASSERT_EQ(score.scored, &obstacles[1]);
  EXPECT_FALSE(score.scored_spans_probe);
  EXPECT_NEAR(score.error_m, 1.5, 1e-12);
  EXPECT_FALSE(score.within_tolerance());
}

TEST_F(HangingBoard, ALowerEdgeMoreThanTenCentimetresOffIsOutsideTheTolerance) {
  const std::vector<o3::Obstacle3d> low{obstacle_at(0, 15, 0.79, 1.6)}, high{obstacle_at(0, 15, 1.01, 1.6)},
      just_low{obstacle_at(0, 15, 0.81, 1.6)};
  EXPECT_FALSE(eval::score_hanging_object(low, board, gate).within_tolerance());   // -0.11
  EXPECT_FALSE(eval::score_hanging_object(high, board, gate).within_tolerance());  // +0.11
  EXPECT_TRUE(eval::score_hanging_object(just_low, board, gate).within_tolerance());  // -0.09
}

TEST_F(HangingBoard, AnObstacleOutsideTheGateIsNeitherScoredNorTakesTheFreeSpace) {
  // 5 m behind: 3 sigma_Z at 15 m is 1.01 m, + 0.03 m: out of the gate.
  const o3::Obstacle3d behind = obstacle_at(0, 20.0, 0.3, 1.5);
  const std::vector<o3::Obstacle3d> obstacles{behind, board_report};
  const eval::HangingObjectScore score = eval::score_hanging_object(obstacles, board, gate);
  EXPECT_EQ(score.scored, &obstacles[1]);
  EXPECT_TRUE(score.free_space_kept());
  const std::vector<o3::Obstacle3d> only_behind{behind};
  const eval::HangingObjectScore nothing = eval::score_hanging_object(only_behind, board, gate);
  EXPECT_EQ(nothing.scored, nullptr);
  EXPECT_EQ(nothing.highest_lower_edge, nullptr);
  EXPECT_FALSE(nothing.free_space_checked);
  EXPECT_FALSE(nothing.free_space_kept());
}

TEST_F(HangingBoard, AnObstacleUnderTheBoardAwayFromThePolesTakesTheFreeSpace) {
  const o3::Obstacle3d junk_under = obstacle_at(0.5, 15.0, 0.3, 0.6);   // |dx| 0.5 <= 0.7, 0.3 < 0.8
  const std::vector<o3::Obstacle3d> obstacles{board_report, junk_under};
  const eval::HangingObjectScore score = eval::score_hanging_object(obstacles, board, gate);
  EXPECT_TRUE(score.within_tolerance());  // the edge is still reported right
  EXPECT_FALSE(score.free_space_kept());
  EXPECT_EQ(score.under, &obstacles[1]);
  // Beside a pole (|dx| 0.75 > 0.7) it does not.
  const std::vector<o3::Obstacle3d> by_the_pole{board_report, obstacle_at(-0.75, 15.0, 0.3, 0.6)};
  EXPECT_TRUE(eval::score_hanging_object(by_the_pole, board, gate).free_space_kept());
  // A lower edge 0.81 m high is within 10 cm of the board's: no loss; 0.79 m is one.
  const std::vector<o3::Obstacle3d> just_under{board_report, obstacle_at(0.0, 15.0, 0.81, 1.6)};
  EXPECT_TRUE(eval::score_hanging_object(just_under, board, gate).free_space_kept());
  const std::vector<o3::Obstacle3d> under{board_report, obstacle_at(0.0, 15.0, 0.79, 1.6)};
  EXPECT_FALSE(eval::score_hanging_object(under, board, gate).free_space_kept());
}

TEST(Obstacles3dScoring, TheBallsFreeSpaceIsNotCheckedItsPostStandsUnderIt) {
  // A ball 0.4 m across on a post, 1.2 m high: lower edge 0.8 m.
  const io::SynthObjectTruth ball = truth_of(io::SynthClass::ball_on_post, 1.0, 12.0);
  ASSERT_DOUBLE_EQ(ball.min_height_m, 0.8);
  const eval::ObstacleGate gate = eval::gate_of(ball, error_model());
  const std::vector<o3::Obstacle3d> obstacles{obstacle_at(1.0, 12.0, 0.0, 1.2)};
  const eval::HangingObjectScore score = eval::score_hanging_object(obstacles, ball, gate);
  ASSERT_EQ(score.scored, &obstacles[0]);  // spans 1.0 m
  EXPECT_NEAR(score.error_m, -0.8, 1e-12);
  EXPECT_FALSE(score.free_space_checked);
}

// ---- measurable pixels ----

// One image row of 80 pixels, background disparity 1 px (id 0). Object 1 at u 2-3 with d = 1 (far),
// object 2 at u 6-7 with d = 5 (near): its matches in the right view are u - 5 = 1, 2.
// Object 1's pixel u = 3 matches x_r = 2, and object 2's u = 6 lies right of it with u - d = 1 <
// 2 - 0.5: the right view sees object 2 there, so u = 3 is half-occluded. u = 2 (x_r = 1): the
// smallest u' - d' right of it is 1, not below 0.5: measurable.
// Object 3 at u = 0 with d = 2 matches outside the right image (u - d < 0): not in range. Object 4
// at u 75-76 with d = 70 (matches 5, 6, right of every other object's) is beyond the engine's 64
// disparities; object 5 at u = 79 has no truth (sky).
io::StereoSynthScene one_row_scene() {
  io::StereoSynthScene scene;
  scene.object_ids = cv::Mat(1, 80, CV_16UC1, cv::Scalar(0));
  scene.disparity_px = cv::Mat(1, 80, CV_32FC1, cv::Scalar(1.0));
  const auto set = [&](int u, uint16_t id, float d) {
    scene.object_ids.at<uint16_t>(0, u) = id;
    scene.disparity_px.at<float>(0, u) = d;
  };
  set(2, 1, 1), set(3, 1, 1);
  set(6, 2, 5), set(7, 2, 5);
  set(0, 3, 2);
  set(75, 4, 70), set(76, 4, 70);
  set(79, 5, std::numeric_limits<float>::infinity());
  return scene;
}

TEST(Obstacles3dScoring, MeasurablePixelsLeaveOutHalfOccludedAndOutOfRangePixels) {
  const eval::MeasurablePixels counts = eval::measurable_pixels(one_row_scene(), 0, 64);
  EXPECT_EQ(counts.in_range_of(1), 2);
  EXPECT_EQ(counts.measurable_of(1), 1);
  EXPECT_EQ(counts.in_range_of(2), 2);
  EXPECT_EQ(counts.measurable_of(2), 2);
  EXPECT_EQ(counts.in_range_of(3), 0);
  EXPECT_EQ(counts.in_range_of(4), 0);
  EXPECT_EQ(counts.in_range_of(5), 0);
  EXPECT_EQ(counts.measurable_of(99), 0);  // an id never seen
  EXPECT_EQ(counts.lower_edge_of(1), 0);   // no probe
  // With 70 px in the search range object 4 counts.
  EXPECT_EQ(eval::measurable_pixels(one_row_scene(), 0, 128).measurable_of(4), 2);
  // A minimum disparity of 2 leaves out the far object 1.
  EXPECT_EQ(eval::measurable_pixels(one_row_scene(), 2, 64).in_range_of(1), 0);
}

TEST(Obstacles3dScoring, PixelsNearerThanTheRangeAreCountedAndMarkAFrameFromOnePercentOfTheView) {
  // One row of 80: object 4's two pixels at 70 px lie beyond [0, 63]; object 5's sky (+inf) does not
  // count, nor does the road (id 0). With 128 disparities nothing is nearer than the range.
  EXPECT_EQ(eval::measurable_pixels(one_row_scene(), 0, 64).nearer_than_range, 2);
  EXPECT_EQ(eval::measurable_pixels(one_row_scene(), 0, 128).nearer_than_range, 0);
  // A range ending at 69 (min 6, 64 disparities) leaves 70 just outside; one ending at 70 holds it.
  EXPECT_EQ(eval::measurable_pixels(one_row_scene(), 6, 64).nearer_than_range, 2);
  EXPECT_EQ(eval::measurable_pixels(one_row_scene(), 7, 64).nearer_than_range, 0);
  // 1 % of the view: 2 of 200 pixels mark the frame, 2 of 201 do not.
  eval::MeasurablePixels pixels;
  pixels.nearer_than_range = 2;
  EXPECT_TRUE(eval::view_partly_nearer_than_range(pixels, 200));
  EXPECT_FALSE(eval::view_partly_nearer_than_range(pixels, 201));
  EXPECT_FALSE(eval::view_partly_nearer_than_range(pixels, 0));
}

TEST(Obstacles3dScoring, LowerEdgePixelsAreTheMeasurableOnesInTheHangingPartsLowestBand) {
  // f = 100 px, B = 0.1 m, principal point (0, 0), camera frame = road frame: d = 1 px is 10 m away,
  // a pixel at row 0 is level with the camera, 1.0 m above the flat true ground; at u its road x is
  // u x 10 / 100 = 0.1 u m. A hanging part 0.95 m up over road x [0, 0.45]: its band is 0.95-1.05 m.
  io::StereoSynthScene scene;
  scene.object_ids = cv::Mat(2, 8, CV_16UC1, cv::Scalar(1));
  scene.disparity_px = cv::Mat(2, 8, CV_32FC1, cv::Scalar(1.0));
  const io::SynthGroundTruth flat{io::StereoSynthOptions{}};
  eval::LowerEdgeProbe probe;
  probe.focal_px = 100, probe.baseline_m = 0.1, probe.camera_height_m = 1.0, probe.ground = &flat;
  io::SynthObjectTruth sign = truth_of(io::SynthClass::hanging_sign, 0.225, 10.0);
  sign.object.width_m = 0.45;
  sign.min_height_m = 0.95;
  probe.add_part(sign);
  const io::SynthObjectTruth box = truth_of(io::SynthClass::box, 0, 10.0);  // not hanging: no part
  probe.add_part(box);
  ASSERT_EQ(probe.parts.size(), 2u);
  const eval::MeasurablePixels counts = eval::measurable_pixels(scene, 0, 64, &probe);
  // Row 0, u = 1 .. 4 (x 0.1 .. 0.4; u = 0 matches x_r = -1, outside): 4 pixels at 1.0 m. Row 1 is
  // 1.0 - 1 x 10 / 100 = 0.9 m up, under the band.
  EXPECT_EQ(counts.measurable_of(1), 14);
  EXPECT_EQ(counts.lower_edge_of(1), 4);
}

// ---- moving (voxels) ----

o3::Obstacle3d obstacle_in_box(double x_m, double z_m, int u0, int v0, int u1, int v1) {
  o3::Obstacle3d obstacle = obstacle_at(x_m, z_m, 0, 1.5);
  obstacle.bbox_px = {u0, v0, u1, v1};
  return obstacle;
}

TEST(Obstacles3dScoring, AnObstacleShowsTheObjectWithMostPixelsInItsBox) {
  // 10 x 6 ids: object 1 fills columns 0-5, object 2 a 2 x 2 patch at columns 6-7, rows 0-1, the
  // rest 0 (road, sky).
  cv::Mat ids(6, 10, CV_16UC1, cv::Scalar(0));
  ids(cv::Rect(0, 0, 6, 6)).setTo(1);
  ids(cv::Rect(6, 0, 2, 2)).setTo(2);
  // Columns 4-9, rows 0-5: object 1 has 2 x 6 = 12 pixels, object 2 has 4: object 1.
  EXPECT_EQ(eval::object_shown(obstacle_in_box(0, 10, 4, 0, 9, 5), ids), 1);
  // Columns 5-7, rows 0-1: object 1 has 2, object 2 has 4: object 2.
  EXPECT_EQ(eval::object_shown(obstacle_in_box(0, 10, 5, 0, 7, 1), ids), 2);
  // Columns 4-7, rows 0-1: 4 each, a tie: the smaller id.
  EXPECT_EQ(eval::object_shown(obstacle_in_box(0, 10, 4, 0, 7, 1), ids), 1);
  // Columns 8-9, rows 2-5: road only.
  EXPECT_EQ(eval::object_shown(obstacle_in_box(0, 10, 8, 2, 9, 5), ids), 0);
  // A box reaching past the image is clipped (columns 8-9, rows 0-5 remain: road); one wholly
  // outside, or the "no box" value -1, shows nothing.
  EXPECT_EQ(eval::object_shown(obstacle_in_box(0, 10, 8, -3, 14, 20), ids), 0);
  EXPECT_EQ(eval::object_shown(obstacle_in_box(0, 10, 12, 0, 14, 5), ids), 0);
  EXPECT_EQ(eval::object_shown(obstacle_in_box(0, 10, -1, -1, -1, -1), ids), 0);
}

TEST(Obstacles3dScoring, MovingIsReadFromTheNearestInGateObstacleThatShowsTheObject) {
  // A parked car (id 1, 1.8 m wide, 4.5 m long) at x -4.4, z 27.4: its gate is |dx| <= 1.9 m, |dz|
  // <= max(1, 3 x 27.4^2 x 0.25 / 166.29 = 3.39) + 2.25 = 5.64 m. Its own obstacle, the rear face,
  // at (-4.2, 25.2) is 2.21 m from its centre; a pedestrian's (id 2) head above the roof at (-5.3,
  // 27.7) is 0.95 m from it, inside its gate, and moving.
  io::SynthObjectTruth car = truth_of(io::SynthClass::car, -4.4, 27.4);
  car.id = 1;
  const eval::ObstacleGate gate = eval::gate_of(car, error_model());
  cv::Mat ids(40, 60, CV_16UC1, cv::Scalar(0));
  ids(cv::Rect(0, 10, 50, 30)).setTo(1);  // the car: columns 0-49, rows 10-39
  ids(cv::Rect(10, 6, 8, 4)).setTo(2);    // the head: columns 10-17, rows 6-9
  std::vector<o3::Obstacle3d> obstacles{obstacle_in_box(-4.2, 25.2, 0, 10, 49, 39), obstacle_in_box(-5.3, 27.7, 10, 6, 17, 10)};
  obstacles[1].moving = true;
  ASSERT_TRUE(eval::in_gate(obstacles[1], car, gate));
  // The head's box holds 32 head pixels and 8 car pixels (row 10): it shows the pedestrian. The car
  // is scored from its own obstacle, which is farther from its centre.
  EXPECT_EQ(eval::moving_scored_obstacle(obstacles, car, gate, ids), &obstacles[0]);
  // No obstacle shows the car (its own is gone): the former rule, the nearest in-gate one.
  const std::vector<o3::Obstacle3d> head_only{obstacles[1]};
  EXPECT_EQ(eval::moving_scored_obstacle(head_only, car, gate, ids), &head_only[0]);
  // Of two obstacles that show the car, the nearer; one outside the gate (x -4.4 + 2.0) is never taken.
  std::vector<o3::Obstacle3d> two{obstacle_in_box(-4.4, 23.0, 0, 10, 49, 39), obstacle_in_box(-4.4, 24.0, 0, 10, 49, 39),
                                  obstacle_in_box(-2.4, 27.4, 0, 10, 49, 39)};
  EXPECT_EQ(eval::moving_scored_obstacle(two, car, gate, ids), &two[1]);
  // An empty gate: nothing to score.
  const std::vector<o3::Obstacle3d> outside{two[2]};
  EXPECT_EQ(eval::moving_scored_obstacle(outside, car, gate, ids), nullptr);
}

TEST(Obstacles3dScoring, AMovingFlagIsScoredSettledFromAnObjectsSeventhCountedFrameInARow) {
  eval::CountedRuns runs;
  // Object 3 counted in frames 0-6, lost in frame 7, back from frame 8; object 5 from frame 2.
  for (int frame = 0; frame < 7; ++frame) {
    runs.next_frame(frame >= 2 ? std::vector<int>{3, 5} : std::vector<int>{3});
    EXPECT_EQ(runs.frames_in_row(3), frame + 1);
    // Settled from the run's 7th frame on (more than kMovingSettleFrames = 6), not before.
    EXPECT_EQ(runs.settled(3), frame + 1 > eval::kMovingSettleFrames) << "frame " << frame;
  }
  EXPECT_EQ(runs.frames_in_row(5), 5);
  EXPECT_FALSE(runs.settled(5));
  runs.next_frame({5});
  EXPECT_EQ(runs.frames_in_row(3), 0);
  EXPECT_FALSE(runs.settled(3));
  EXPECT_EQ(runs.frames_in_row(5), 6);
  runs.next_frame({3, 5});
  // A gap restarts the run: object 3 counts from 1 again.
  EXPECT_EQ(runs.frames_in_row(3), 1);
  EXPECT_FALSE(runs.settled(3));
  EXPECT_EQ(runs.frames_in_row(5), 7);
  EXPECT_TRUE(runs.settled(5));
  // An id never counted.
  EXPECT_EQ(runs.frames_in_row(99), 0);
}

}  // namespace
}  // namespace lpstereo
