// graphs/disparity-multires-wta.json end to end: loaded from the file, verified, run natively by
// arm::FrameRunner on the synthetic scene (io/synthetic_scene), and compared with a single
// full-resolution winner-takes-all over the same total range (256 px). The graph's own
// parameters are used as they are (no scaling to the test size): the scene is sized so that its
// disparities span the graph's range (up to 240 px at 960 wide).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "arm/scheduler.h"
#include "dag/graph.h"
#include "io/synthetic_scene.h"

namespace lpstereo {
namespace {

const std::string kGraphPath = std::string(LPSTEREO_SOURCE_DIR) + "/graphs/disparity-multires-wta.json";

struct Accuracy {
  double valid_share = 0;   // valid pixels / all pixels
  double within_1px = 0;    // pixels within 1 px of the truth / all pixels
};

Accuracy accuracy(const Plane& disparity, const Plane& truth, int16_t invalid_q4) {
  int64_t valid = 0, good = 0;
  for (int y = 0; y < truth.height(); ++y) {
    for (int x = 0; x < truth.width(); ++x) {
      const int value = disparity.at<int16_t>(x, y);
      if (value == invalid_q4) continue;
      ++valid;
      good += std::abs(value - truth.at<int16_t>(x, y)) <= 16 ? 1 : 0;
    }
  }
  const double pixels = static_cast<double>(truth.width()) * truth.height();
  return {static_cast<double>(valid) / pixels, static_cast<double>(good) / pixels};
}

// The single-pass baseline with the same total range as the multi-resolution graph: [0, 256) px.
const char* kSingleGraph = R"({"name": "single", "inputs": [{"name": "left", "format": "u8"}, {"name": "right", "format": "u8"}],
  "nodes": [
    {"name": "census_left", "kernel": "census5x5", "inputs": {"input": "left"}, "outputs": {"output": "left_census"}},
    {"name": "census_right", "kernel": "census5x5", "inputs": {"input": "right"}, "outputs": {"output": "right_census"}},
    {"name": "match", "kernel": "census_wta_disparity", "inputs": {"left": "left_census", "right": "right_census"},
     "outputs": {"disparity": "disparity"}, "params": {"min_disparity": 0, "num_disparities": 256, "max_cost_bits": 6}}],
  "outputs": ["disparity"]})";

class MultiresGraph : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    io::SyntheticSceneOptions options;
    options.width = 960;
    options.height = 432;
    options.max_disparity_fraction = 0.25;  // up to 240 px: both the far and the near range are used
    scene_ = new io::SyntheticStereoScene(io::make_synthetic_stereo_scene(options));
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  static Plane run(const GraphSpec& spec, const char* output) {
    Graph graph(spec);
    VerifyOptions options;
    options.frame_width = scene_->left.width();
    options.frame_height = scene_->left.height();
    graph.verify(options);
    arm::FrameRunner runner(graph, 2);
    runner.process({{"left", &scene_->left}, {"right", &scene_->right}});
    return runner.buffer(output);
  }
  static io::SyntheticStereoScene* scene_;
};

io::SyntheticStereoScene* MultiresGraph::scene_ = nullptr;

TEST_F(MultiresGraph, FusedMapIsAtLeastAsAccurateAsOneFullResolutionPassOverTheSameRange) {
  const Plane multires = run(load_graph_spec(kGraphPath), "disparity");
  const Plane fused = run(load_graph_spec(kGraphPath), "disparity_fused");
  const Plane single = run(parse_graph_spec(kSingleGraph, "single.json"), "disparity");
  const Accuracy multi = accuracy(multires, scene_->disparity_q4, -16);
  const Accuracy fuse_only = accuracy(fused, scene_->disparity_q4, -16);
  const Accuracy one = accuracy(single, scene_->disparity_q4, -16);
  std::printf("multires (fused, median, speckle): valid %.4f within 1 px %.4f\n", multi.valid_share, multi.within_1px);
  std::printf("multires fused only:               valid %.4f within 1 px %.4f\n", fuse_only.valid_share, fuse_only.within_1px);
  std::printf("single full-resolution [0, 256):   valid %.4f within 1 px %.4f\n", one.valid_share, one.within_1px);
  // Measured (the same bits on every ISA level): within 1 px of the truth, share of all pixels:
  //   fused 0.4524, after median and speckle filter 0.5203, single pass over [0, 256) 0.4372.
  // (With the half-resolution pass over the near range [56, 128) half px only, the fused map
  // scored 0.2711 with this rule and 0.3395 with the far value first: see the kernel's header.)
  EXPECT_GE(fuse_only.within_1px, one.within_1px + 0.01);
  EXPECT_GE(multi.within_1px, one.within_1px + 0.06);
  EXPECT_GE(multi.within_1px, 0.50);
}

}  // namespace
}  // namespace lpstereo
