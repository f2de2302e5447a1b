// The reduced range test of issue 6 (bench/obstacle_range_bench.cpp is the full sweep): the issue's
// camera and scene (3840x1728, hfov 60 degrees, 0.30 m baseline, 1.5 m high, noise sigma 2), two
// frames instead of forty: the lineup at 40 m, where the smallest objects must still be found (can
// 0.19 m, box 0.43 m, tape roll 0.07 m: 5.8 rows), and an obstacle-free flat road, which must give no
// detection within 150 m. The whole chain: rendering, the DisparityEngine with the detector's matcher,
// the detector with its defaults, the matching rule (io/obstacle_matching.h).
// (A half-resolution scene at 20 m has the same disparities and heights in pixels but not the same
// texture: its small objects show fewer Harris corners than at 4K, so it would test other tuning.)
#include <gtest/gtest.h>

#include <string>

#include "eval/obstacle_range.h"

namespace lpstereo {
namespace {

TEST(ObstacleRange, LineupAt40mIsDetectedWhole) {
  eval::RangeTestRunner runner{eval::RangeTestSetup{}};
  const eval::SceneResult result = runner.run_lineup(40.0, 1);
  ASSERT_TRUE(result.road.valid);
  EXPECT_NEAR(result.road.camera_height_mm, 1500, 30);
  ASSERT_EQ(result.truth.size(), 6u);
  for (size_t i = 0; i < result.truth.size(); ++i) {
    EXPECT_GE(result.score.detection_of_object[i], 0)
        << io::synth_class_name(result.truth[i].object.object_class) << " at 40 m not detected";
  }
  for (const arm::Obstacle& obstacle : result.obstacles) EXPECT_GE(obstacle.features, 1);
}

TEST(ObstacleRange, EmptyFlatRoadHasNoDetectionWithin150m) {
  eval::RangeTestRunner runner{eval::RangeTestSetup{}};
  const eval::SceneResult result = runner.run_empty_road(1001, 0.0);
  ASSERT_TRUE(result.road.valid);
  EXPECT_EQ(result.score.false_positives(), 0);
  for (const arm::Obstacle& obstacle : result.obstacles) {
    EXPECT_GT(obstacle.distance_m, 150.0) << "a false obstacle at " << obstacle.distance_m << " m, box " << obstacle.bbox_px[0]
                                          << " " << obstacle.bbox_px[1] << " " << obstacle.bbox_px[2] << " " << obstacle.bbox_px[3];
  }
}

}  // namespace
}  // namespace lpstereo
