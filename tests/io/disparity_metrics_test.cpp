// Metrics on hand-made maps whose values are known.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "io/disparity_metrics.h"

namespace lpstereo::io {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr int16_t kInvalid = -16;  // min disparity 0

Plane q4_row(const std::vector<double>& disparity_px) {
  Plane plane(static_cast<int>(disparity_px.size()), 1, {ElementType::s16, 4});
  for (size_t x = 0; x < disparity_px.size(); ++x) {
    plane.at<int16_t>(static_cast<int>(x), 0) =
        std::isfinite(disparity_px[x]) ? static_cast<int16_t>(std::lround(disparity_px[x] * 16)) : kInvalid;
  }
  return plane;
}

cv::Mat px_row(const std::vector<float>& disparity_px) {
  cv::Mat row(1, static_cast<int>(disparity_px.size()), CV_32FC1);
  for (size_t x = 0; x < disparity_px.size(); ++x) row.at<float>(0, static_cast<int>(x)) = disparity_px[x];
  return row;
}

cv::Mat mask_row(const std::vector<int>& values) {
  cv::Mat row(1, static_cast<int>(values.size()), CV_8UC1);
  for (size_t x = 0; x < values.size(); ++x) row.at<uint8_t>(0, static_cast<int>(x)) = static_cast<uint8_t>(values[x]);
  return row;
}

TEST(DisparityMetrics, KnownErrorsGiveKnownBadPercentagesAndEpe) {
  // Errors 0, 0.5, 1.5, 2.5, 5 px (truth 10 everywhere) and no ground truth at the last pixel.
  const Plane estimate = q4_row({10, 10.5, 11.5, 7.5, 15, 3});
  const cv::Mat truth = px_row({10, 10, 10, 10, 10, kInf});
  const DisparityMetrics metrics = evaluate_disparity(estimate, kInvalid, truth, {});
  EXPECT_FALSE(metrics.has_nonocc);
  EXPECT_TRUE(std::isnan(metrics.nonocc.dense.bad2_pct));
  EXPECT_EQ(metrics.all.ground_truth_pixels, 5);
  EXPECT_DOUBLE_EQ(metrics.all.density_pct, 100.0);
  EXPECT_DOUBLE_EQ(metrics.all.dense.bad1_pct, 60.0);  // 1.5, 2.5, 5
  EXPECT_DOUBLE_EQ(metrics.all.dense.bad2_pct, 40.0);  // 2.5, 5
  EXPECT_DOUBLE_EQ(metrics.all.dense.bad4_pct, 20.0);  // 5
  EXPECT_DOUBLE_EQ(metrics.all.dense.d1_pct, 20.0);    // 5 > 3 and > 0.5
  EXPECT_DOUBLE_EQ(metrics.all.dense.epe_px, (0 + 0.5 + 1.5 + 2.5 + 5) / 5.0);
  EXPECT_DOUBLE_EQ(metrics.all.valid.bad2_pct, 40.0);  // everything was produced: dense = valid
}

TEST(DisparityMetrics, D1NeedsBothThreePixelsAndFivePercent) {
  // Truth 100: an error of 4 px is > 3 px but only 4 %, not D1; 6 px is both. Truth 20: 3.5 px is both.
  const Plane estimate = q4_row({104, 106, 23.5});
  const DisparityMetrics metrics = evaluate_disparity(estimate, kInvalid, px_row({100, 100, 20}), {});
  EXPECT_DOUBLE_EQ(metrics.all.dense.d1_pct, 100.0 * 2 / 3);
  EXPECT_DOUBLE_EQ(metrics.all.dense.bad4_pct, 100.0 * 1 / 3);  // only 6 > 4
}

TEST(DisparityMetrics, DenseFillsHolesFromTheLowerNeighbourValidSkipsThem) {
  // Truth: 20, 20, 20, 10, 10. Estimate: 20, hole, hole, 10, 10 -> the fill puts 10 (the lower
  // neighbour) in the holes: errors 10, 10 there.
  const Plane estimate = q4_row({20, kInf, kInf, 10, 10});
  const cv::Mat truth = px_row({20, 20, 20, 10, 10});
  const cv::Mat nonocc = mask_row({255, 255, 0, 255, 0});
  const DisparityMetrics metrics = evaluate_disparity(estimate, kInvalid, truth, nonocc);
  ASSERT_TRUE(metrics.has_nonocc);
  EXPECT_DOUBLE_EQ(metrics.all.density_pct, 60.0);
  EXPECT_DOUBLE_EQ(metrics.all.dense.bad2_pct, 40.0);
  EXPECT_DOUBLE_EQ(metrics.all.dense.epe_px, 20.0 / 5);
  EXPECT_EQ(metrics.all.valid.pixels, 3);
  EXPECT_DOUBLE_EQ(metrics.all.valid.bad2_pct, 0.0);
  EXPECT_DOUBLE_EQ(metrics.all.valid.epe_px, 0.0);
  // nonocc: pixels 0, 1, 3; one hole among them.
  EXPECT_EQ(metrics.nonocc.ground_truth_pixels, 3);
  EXPECT_DOUBLE_EQ(metrics.nonocc.density_pct, 100.0 * 2 / 3);
  EXPECT_DOUBLE_EQ(metrics.nonocc.dense.bad1_pct, 100.0 / 3);
  EXPECT_EQ(metrics.nonocc.valid.pixels, 2);
  EXPECT_DOUBLE_EQ(metrics.nonocc.valid.bad1_pct, 0.0);
}

TEST(DisparityMetrics, AnEmptyMapCountsAsZeroWhenDenseAndHasNoValidMetrics) {
  const DisparityMetrics metrics = evaluate_disparity(q4_row({kInf, kInf}), kInvalid, px_row({3, 1.5}), {});
  EXPECT_DOUBLE_EQ(metrics.all.density_pct, 0.0);
  EXPECT_DOUBLE_EQ(metrics.all.dense.bad2_pct, 50.0);
  EXPECT_DOUBLE_EQ(metrics.all.dense.epe_px, 2.25);
  EXPECT_EQ(metrics.all.valid.pixels, 0);
  EXPECT_TRUE(std::isnan(metrics.all.valid.bad2_pct));
}

TEST(DisparityMetrics, NegativeMinimumDisparityUsesItsOwnInvalidValue) {
  // min disparity -4: invalid is -80; -1 px (-16) is an ordinary value.
  Plane estimate(2, 1, {ElementType::s16, 4});
  estimate.at<int16_t>(0, 0) = -16;
  estimate.at<int16_t>(1, 0) = -80;
  const DisparityMetrics metrics = evaluate_disparity(estimate, -80, px_row({-1, -1}), {});
  EXPECT_DOUBLE_EQ(metrics.all.density_pct, 50.0);
  EXPECT_DOUBLE_EQ(metrics.all.dense.epe_px, 0.0);  // filled from -1
}

TEST(DisparityMetrics, SizeMismatchIsRefusedNamingBothSizes) {
  try {
    evaluate_disparity(q4_row({1, 2, 3}), kInvalid, px_row({1, 2}), {});
    FAIL() << "no error";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "evaluate_disparity: estimate is 3x1, ground truth is 2x1");
  }
}

}  // namespace
}  // namespace lpstereo::io
