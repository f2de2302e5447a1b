// graphs/features.json end to end (harris_response -> harris_nms -> select_keypoints, median3x3 ->
// brief256) on bright squares on black: the keypoint list holds one keypoint within 1 px of every
// square corner and nothing else, strongest first, and each descriptor row is the brief256
// reference's on the graph's smoothed view; the native and counting back ends agree.
#include <gtest/gtest.h>

#include <cstdlib>

#include "arm/scheduler.h"
#include "arm/tasks/keypoint_record.h"
#include "dag/graph.h"
#include "kernels/brief_pattern.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

TEST(FeaturesGraph, SquaresGiveTheirCornersAsKeypointsWithDescriptors) {
  constexpr int kWidth = 257, kHeight = 181;
  struct Square {
    int x0, y0, size;
  };
  const std::vector<Square> squares = {{30, 30, 20}, {150, 40, 25}, {60, 110, 30}, {190, 120, 17}};
  Plane image(kWidth, kHeight, {ElementType::u8, 0}, kWidth + 15);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      bool inside = false;
      for (const Square& s : squares) inside = inside || (x >= s.x0 && x < s.x0 + s.size && y >= s.y0 && y < s.y0 + s.size);
      image.at<uint8_t>(x, y) = inside ? 220 : 20;
    }
  }
  std::vector<std::pair<int, int>> square_corners;
  for (const Square& s : squares) {
    for (int cy : {s.y0, s.y0 + s.size - 1}) {
      for (int cx : {s.x0, s.x0 + s.size - 1}) square_corners.emplace_back(cx, cy);
    }
  }

  Graph graph(load_graph_spec(std::string(LPSTEREO_SOURCE_DIR) + "/graphs/features.json"));
  VerifyOptions options;
  options.frame_width = kWidth;
  options.frame_height = kHeight;
  graph.verify(options);

  std::vector<Plane> descriptor_runs;
  for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
    arm::FrameRunner runner(graph, 2, backend);
    runner.process({{"image", &image}});
    const Plane& keypoints = runner.buffer("keypoints");
    const Plane& descriptors = runner.buffer("descriptors");
    std::vector<int> hits(square_corners.size(), 0);
    int listed = 0;
    int32_t previous_response = INT32_MAX;
    for (int row = 0; row < keypoints.height(); ++row) {
      const int32_t* word = keypoints.row<const int32_t>(row);
      if (word[arm::kKeypointValid] == 0) continue;
      ++listed;
      EXPECT_LE(word[arm::kKeypointResponse], previous_response) << "strongest first";
      previous_response = word[arm::kKeypointResponse];
      bool near = false;
      for (size_t i = 0; i < square_corners.size(); ++i) {
        if (std::abs(word[arm::kKeypointXPx] - square_corners[i].first) <= 1 &&
            std::abs(word[arm::kKeypointYPx] - square_corners[i].second) <= 1) {
          ++hits[i];
          near = true;
        }
      }
      EXPECT_TRUE(near) << "keypoint " << word[arm::kKeypointXPx] << "," << word[arm::kKeypointYPx];
    }
    EXPECT_EQ(listed, static_cast<int>(square_corners.size()));
    for (size_t i = 0; i < square_corners.size(); ++i) EXPECT_EQ(hits[i], 1) << "square corner " << i;

    // The descriptors are brief256's reference on the graph's smoothed view.
    const KernelDescriptor& brief = testing::kernel_named("brief256");
    const Plane& smoothed = runner.buffer("smoothed");
    const PreparedKernel prepared = brief.prepare({{"yaw_sector", 0}}, {{kWidth, kHeight}, {keypoints.width(), keypoints.height()}});
    Plane expected(kernels::kBriefWords, keypoints.height(), {ElementType::u32, 0});
    brief.reference({smoothed.view(), keypoints.view()}, {expected.view()}, prepared.params.get(), BorderMode::replicate, 0);
    EXPECT_TRUE(testing::planes_equal(expected, descriptors));
    int nonzero_rows = 0;
    for (int row = 0; row < descriptors.height(); ++row) {
      bool nonzero = false;
      for (int w = 0; w < kernels::kBriefWords; ++w) nonzero = nonzero || descriptors.at<uint32_t>(w, row) != 0;
      nonzero_rows += nonzero ? 1 : 0;
    }
    EXPECT_EQ(nonzero_rows, listed);
    descriptor_runs.push_back(descriptors.clone());
  }
  EXPECT_TRUE(testing::planes_equal(descriptor_runs[0], descriptor_runs[1]));
}

}  // namespace
}  // namespace lpstereo
