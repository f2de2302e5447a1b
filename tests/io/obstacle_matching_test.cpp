// The range test's scoring rules (io/obstacle_matching.h) on hand-made boxes.
#include "io/obstacle_matching.h"

#include <gtest/gtest.h>

namespace lpstereo::io {
namespace {

SynthObjectTruth truth_at(int x0, int y0, int x1, int y1, double distance_m) {
  SynthObjectTruth object;
  object.bbox_px[0] = x0;
  object.bbox_px[1] = y0;
  object.bbox_px[2] = x1;
  object.bbox_px[3] = y1;
  object.distance_m = distance_m;
  object.visible_pixels = int64_t{x1 - x0 + 1} * (y1 - y0 + 1);
  return object;
}

DetectedBox box_at(int x0, int y0, int x1, int y1, double distance_m) {
  DetectedBox box;
  box.bbox_px[0] = x0;
  box.bbox_px[1] = y0;
  box.bbox_px[2] = x1;
  box.bbox_px[3] = y1;
  box.distance_m = distance_m;
  return box;
}

TEST(ObstacleMatching, BoxesWithinTwoPixelsOverlapAndFartherOnesDoNot) {
  const MatchRule rule;
  const SynthObjectTruth object = truth_at(100, 50, 120, 80, 40.0);
  EXPECT_TRUE(detection_matches(box_at(110, 60, 115, 70, 40.0), object, rule));   // inside
  EXPECT_TRUE(detection_matches(box_at(122, 50, 130, 80, 40.0), object, rule));   // 2 px right of x1
  EXPECT_FALSE(detection_matches(box_at(123, 50, 130, 80, 40.0), object, rule));  // 3 px right
  EXPECT_TRUE(detection_matches(box_at(90, 20, 98, 48, 40.0), object, rule));     // 2 px left and above
  EXPECT_FALSE(detection_matches(box_at(90, 20, 97, 48, 40.0), object, rule));    // 3 px left
  EXPECT_FALSE(detection_matches(box_at(100, 83, 120, 90, 40.0), object, rule));  // 3 px below
}

TEST(ObstacleMatching, DistanceMustBeWithinTenPercentPlusHalfAMetre) {
  const MatchRule rule;
  const SynthObjectTruth object = truth_at(0, 0, 10, 10, 40.0);  // allowed: 4.5 m
  EXPECT_TRUE(detection_matches(box_at(0, 0, 10, 10, 44.49), object, rule));
  EXPECT_TRUE(detection_matches(box_at(0, 0, 10, 10, 35.51), object, rule));
  EXPECT_FALSE(detection_matches(box_at(0, 0, 10, 10, 44.51), object, rule));
  EXPECT_FALSE(detection_matches(box_at(0, 0, 10, 10, 35.49), object, rule));
}

TEST(ObstacleMatching, AnInvisibleObjectIsNeverMatched) {
  SynthObjectTruth object = truth_at(0, 0, 10, 10, 40.0);
  object.visible_pixels = 0;
  EXPECT_FALSE(detection_matches(box_at(0, 0, 10, 10, 40.0), object, MatchRule{}));
}

TEST(ObstacleMatching, ScoreCountsMissesAndOnlyNearUnmatchedDetectionsAsFalse) {
  const std::vector<SynthObjectTruth> objects = {truth_at(0, 0, 10, 10, 20.0), truth_at(100, 0, 110, 10, 20.0)};
  const std::vector<DetectedBox> detections = {
      box_at(2, 2, 8, 8, 20.5),        // the first object
      box_at(500, 0, 510, 10, 60.0),   // nothing there, 60 m: false
      box_at(600, 0, 610, 10, 151.0),  // nothing there but beyond 150 m: not counted
      box_at(100, 0, 110, 10, 30.0),   // at the second object's box but 10 m too far: false
  };
  const FrameScore score = score_frame(objects, detections, MatchRule{});
  ASSERT_EQ(score.detection_of_object.size(), 2u);
  EXPECT_EQ(score.detection_of_object[0], 0);
  EXPECT_EQ(score.detection_of_object[1], -1);
  EXPECT_EQ(score.false_positives(), 2);
  EXPECT_EQ(score.false_detections, (std::vector<int>{1, 3}));
}

TEST(ObstacleMatching, RangeIsTheLastDistanceOfTheUnbrokenRunFromTheNearest) {
  const std::map<std::string, std::map<double, bool>> detected = {
      {"cone", {{20, true}, {25, true}, {30, false}, {35, true}}},  // a gap at 30: range 25
      {"bin", {{20, true}, {25, true}, {30, true}, {35, true}}},
      {"tape_roll", {{20, false}, {25, true}}},
  };
  const auto range = detection_range_by_class(detected);
  EXPECT_DOUBLE_EQ(range.at("cone"), 25);
  EXPECT_DOUBLE_EQ(range.at("bin"), 35);
  EXPECT_DOUBLE_EQ(range.at("tape_roll"), 0);
}

}  // namespace
}  // namespace lpstereo::io
