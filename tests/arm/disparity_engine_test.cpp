// DisparityEngine: the SGM graphs (4 paths in one pass, 8 in two, census 5x5 and 9x7) on the
// synthetic scene against its ground truth and against the unaggregated winner-takes-all baseline;
// the graph each parameter set builds; parameter errors.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "arm/disparity_engine.h"
#include "io/synthetic_scene.h"

namespace lpstereo {
namespace {

struct Score {
  double bad2_percent = 0;     // valid pixels off by more than 2 px
  double density_percent = 0;  // valid pixels
};

// Scored over x >= num_disparities (the left band has no match in the right view).
Score score(const Plane& disparity, const Plane& truth_q4, int16_t invalid, int first_column) {
  int64_t total = 0, valid = 0, bad = 0;
  for (int y = 0; y < truth_q4.height(); ++y) {
    for (int x = first_column; x < truth_q4.width(); ++x) {
      ++total;
      const int16_t value = disparity.at<int16_t>(x, y);
      if (value == invalid) continue;
      ++valid;
      if (std::abs(value - truth_q4.at<int16_t>(x, y)) > 2 * 16) ++bad;
    }
  }
  return {100.0 * bad / std::max<int64_t>(1, valid), 100.0 * valid / std::max<int64_t>(1, total)};
}

io::SyntheticStereoScene scene() {
  io::SyntheticSceneOptions options;
  options.width = 192;
  options.height = 144;
  options.max_disparity_fraction = 0.15;  // up to ~29 px
  return io::make_synthetic_stereo_scene(options);
}

TEST(DisparityEngine, SgmIsDenseAndAccurateOnTheSyntheticSceneAndHalvesTheWinnerTakesAllError) {
  const io::SyntheticStereoScene stereo = scene();
  arm::DisparityParameters wta;
  wta.num_disparities = 32;
  wta.paths = 0;
  arm::DisparityEngine baseline(stereo.left.width(), stereo.left.height(), wta);
  const Score baseline_score = score(baseline.compute(stereo.left, stereo.right), stereo.disparity_q4,
                                     baseline.invalid_disparity_q4(), 32);
  for (int paths : {4, 8}) {
    for (int census : {5, 9}) {
      arm::DisparityParameters parameters;
      parameters.num_disparities = 32;
      parameters.paths = paths;
      parameters.census_width = census;
      arm::DisparityEngine engine(stereo.left.width(), stereo.left.height(), parameters);
      const Score s = score(engine.compute(stereo.left, stereo.right), stereo.disparity_q4, engine.invalid_disparity_q4(), 32);
      SCOPED_TRACE(std::to_string(paths) + " paths, census " + std::to_string(census));
      EXPECT_LT(s.bad2_percent, 6.0);
      EXPECT_GT(s.density_percent, 90.0);
      EXPECT_LT(s.bad2_percent, baseline_score.bad2_percent / 2) << "winner takes all: " << baseline_score.bad2_percent;
    }
  }
}

TEST(DisparityEngine, BuildsTheGraphOfItsParameters) {
  arm::DisparityParameters parameters;
  const GraphSpec defaults = arm::DisparityEngine::graph_spec(parameters);
  ASSERT_EQ(defaults.nodes.size(), 7u);
  EXPECT_EQ(defaults.nodes[2].kernel, "sgm_8path_forward");
  EXPECT_EQ(defaults.nodes[3].kernel, "sgm_8path_backward_sums");
  EXPECT_EQ(defaults.nodes[4].kernel, "sgm_8path_select");
  EXPECT_EQ(defaults.nodes[4].inputs.at("backward").buffer, "backward_sums");
  EXPECT_EQ(defaults.nodes[5].kernel, "median3x3_s16");
  EXPECT_EQ(defaults.nodes[6].task, "speckle_filter");
  EXPECT_EQ(defaults.nodes[6].params.at("max_difference_q4"), 32);
  EXPECT_EQ(defaults.nodes[6].outputs.at("filtered"), "disparity");
  parameters.paths = 4;
  parameters.median = false;
  parameters.speckle_max_size_px = 0;
  const GraphSpec four = arm::DisparityEngine::graph_spec(parameters);
  ASSERT_EQ(four.nodes.size(), 3u);
  EXPECT_EQ(four.nodes.back().kernel, "sgm_4path");
  EXPECT_EQ(four.nodes.back().outputs.at("disparity"), "disparity");
  parameters.speckle_max_size_px = 100;
  EXPECT_EQ(arm::DisparityEngine::graph_spec(parameters).nodes.back().task, "speckle_filter");
  parameters.paths = 8;
  parameters.census_width = 9;
  parameters.median = true;
  parameters.speckle_max_size_px = 0;
  parameters.parallel_8path_passes = false;
  const GraphSpec eight = arm::DisparityEngine::graph_spec(parameters);
  ASSERT_EQ(eight.nodes.size(), 5u);
  EXPECT_EQ(eight.nodes[0].kernel, "census9x7");
  EXPECT_EQ(eight.nodes[2].kernel, "sgm_8path_forward_census64");
  EXPECT_EQ(eight.nodes[3].kernel, "sgm_8path_backward_census64");
  EXPECT_EQ(eight.nodes[4].kernel, "median3x3_s16");
  EXPECT_EQ(eight.nodes[4].outputs.at("output"), "disparity");
  parameters.paths = 0;
  parameters.census_width = 5;
  EXPECT_EQ(arm::DisparityEngine::graph_spec(parameters).nodes.back().kernel, "census_wta_disparity");
}

TEST(DisparityEngineMustFail, RefusesBadParameters) {
  arm::DisparityParameters parameters;
  parameters.paths = 3;
  EXPECT_THROW(arm::DisparityEngine::graph_spec(parameters), std::invalid_argument);
  parameters.paths = 8;
  parameters.speckle_max_difference_px = -1;
  EXPECT_THROW(arm::DisparityEngine::graph_spec(parameters), std::invalid_argument);
  parameters.speckle_max_difference_px = 2;
  parameters.speckle_max_size_px = -5;
  EXPECT_THROW(arm::DisparityEngine::graph_spec(parameters), std::invalid_argument);
  parameters.speckle_max_size_px = 100;
  parameters.paths = 4;
  parameters.census_width = 7;
  EXPECT_THROW(arm::DisparityEngine::graph_spec(parameters), std::invalid_argument);
  parameters.census_width = 9;
  parameters.paths = 0;  // the winner-takes-all baseline exists for census 5x5 only
  EXPECT_THROW(arm::DisparityEngine::graph_spec(parameters), std::invalid_argument);
  parameters.paths = 4;
  parameters.p1 = 90;
  parameters.p2 = 10;  // p2 < p1: the kernel refuses it in verify
  EXPECT_ANY_THROW(arm::DisparityEngine(64, 32, parameters));
}

}  // namespace
}  // namespace lpstereo
