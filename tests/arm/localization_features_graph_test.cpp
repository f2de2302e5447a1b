// graphs/localization-features.json end to end on the project's synthetic stereo pair, two frames:
// in the first the matcher's train set (the previous frame, over delayed edges) is all zeros, so no
// query finds a train; in the second, the same pair again, every keypoint finds its own row at
// distance 0 and is accepted; the sparse disparities lie within 1 px of the scene's truth at most
// keypoints (85 %: Harris corners sit on depth edges); native and counting back ends give the same bits.
#include <gtest/gtest.h>

#include <cstdlib>

#include "arm/scheduler.h"
#include "arm/tasks/keypoint_record.h"
#include "dag/graph.h"
#include "io/synthetic_scene.h"
#include "kernels/match_record.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

TEST(LocalizationFeaturesGraph, MatchesThePreviousFrameAndFindsDisparitiesAtTheKeypoints) {
  io::SyntheticSceneOptions scene_options;
  scene_options.width = 641;
  scene_options.height = 361;
  const io::SyntheticStereoScene scene = io::make_synthetic_stereo_scene(scene_options);
  ASSERT_LT(scene.max_disparity_px, 128);  // the graph searches [0, 128)

  Graph graph(load_graph_spec(std::string(LPSTEREO_SOURCE_DIR) + "/graphs/localization-features.json"));
  VerifyOptions options;
  options.frame_width = scene_options.width;
  options.frame_height = scene_options.height;
  graph.verify(options);

  std::vector<Plane> results;
  for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
    arm::FrameRunner runner(graph, 2, backend);
    runner.process({{"left", &scene.left}, {"right", &scene.right}});
    const Plane& keypoints = runner.buffer("left_keypoints");
    int listed = 0;
    for (int row = 0; row < keypoints.height(); ++row) listed += keypoints.at<int32_t>(arm::kKeypointValid, row) != 0;
    ASSERT_GT(listed, 50);
    const Plane& first_matches = runner.buffer("left_matches_previous");
    for (int row = 0; row < first_matches.height(); ++row) {
      ASSERT_EQ(first_matches.at<int32_t>(kernels::kMatchTrainIndex, row), kernels::kMatchNoTrain) << "frame 1, row " << row;
      ASSERT_EQ(first_matches.at<int32_t>(kernels::kMatchAccepted, row), 0);
    }

    runner.process({{"left", &scene.left}, {"right", &scene.right}});
    const Plane& matches = runner.buffer("left_matches_previous");
    for (int row = 0; row < matches.height(); ++row) {
      if (keypoints.at<int32_t>(arm::kKeypointValid, row) == 0) {
        EXPECT_EQ(matches.at<int32_t>(kernels::kMatchTrainIndex, row), kernels::kMatchNoTrain);
        continue;
      }
      EXPECT_EQ(matches.at<int32_t>(kernels::kMatchTrainIndex, row), row) << "frame 2, keypoint " << row;
      EXPECT_EQ(matches.at<int32_t>(kernels::kMatchBestDistance, row), 0);
      EXPECT_EQ(matches.at<int32_t>(kernels::kMatchAccepted, row), 1);
    }

    const Plane& disparity = runner.buffer("left_keypoint_disparity");
    ASSERT_EQ(disparity.width(), keypoints.height());
    int valid = 0, close = 0;
    for (int row = 0; row < keypoints.height(); ++row) {
      if (keypoints.at<int32_t>(arm::kKeypointValid, row) == 0) {
        EXPECT_EQ(disparity.at<int16_t>(row, 0), -16) << "unused row " << row;
        continue;
      }
      const int16_t value = disparity.at<int16_t>(row, 0);
      if (value == -16) continue;
      const int x = keypoints.at<int32_t>(arm::kKeypointXPx, row);
      const int truth = scene.disparity_q4.at<int16_t>(x, keypoints.at<int32_t>(arm::kKeypointYPx, row));
      if (16 * x - truth < 16 * 4) continue;  // the true match lies outside the right view (or its census border)
      ++valid;
      close += std::abs(value - truth) <= 16;
    }
    std::printf("%s: %d keypoints, %d with a disparity, %d of them within 1 px of the truth\n",
                backend == KernelBackend::native ? "native" : "counting", listed, valid, close);
    EXPECT_GE(valid * 10, listed * 8);
    // The misses are corners on depth edges, where the 3 x 3 window and the 5 x 5 census straddle
    // two surfaces (measured: about 10 % of the kept keypoints on this scene).
    EXPECT_GE(close * 100, valid * 85);
    results.push_back(disparity.clone());
    results.push_back(matches.clone());
  }
  EXPECT_TRUE(testing::planes_equal(results[0], results[2]));
  EXPECT_TRUE(testing::planes_equal(results[1], results[3]));
}

}  // namespace
}  // namespace lpstereo
