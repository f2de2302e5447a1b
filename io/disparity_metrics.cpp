#include "io/disparity_metrics.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "io/disparity_io.h"

namespace lpstereo::io {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// Running sums of one region and one mode.
struct ErrorTally {
  int64_t pixels = 0, bad1 = 0, bad2 = 0, bad4 = 0, d1 = 0;
  double error_sum_px = 0;

  void add(double error_px, double truth_px) {
    ++pixels;
    bad1 += error_px > 1.0 ? 1 : 0;
    bad2 += error_px > 2.0 ? 1 : 0;
    bad4 += error_px > 4.0 ? 1 : 0;
    d1 += (error_px > 3.0 && error_px > 0.05 * std::abs(truth_px)) ? 1 : 0;
    error_sum_px += error_px;
  }
  ErrorMetrics metrics() const {
    ErrorMetrics result;
    result.pixels = pixels;
    if (pixels == 0) {
      result.bad1_pct = result.bad2_pct = result.bad4_pct = result.d1_pct = result.epe_px = kNaN;
      return result;
    }
    const auto pct = [&](int64_t count) { return 100.0 * static_cast<double>(count) / static_cast<double>(pixels); };
    result.bad1_pct = pct(bad1);
    result.bad2_pct = pct(bad2);
    result.bad4_pct = pct(bad4);
    result.d1_pct = pct(d1);
    result.epe_px = error_sum_px / static_cast<double>(pixels);
    return result;
  }
};

struct RegionTally {
  ErrorTally dense, valid;
  RegionMetrics metrics(bool available) const {
    RegionMetrics result;
    result.ground_truth_pixels = dense.pixels;
    result.density_pct = available && dense.pixels > 0
                             ? 100.0 * static_cast<double>(valid.pixels) / static_cast<double>(dense.pixels)
                             : kNaN;
    result.dense = dense.metrics();
    result.valid = valid.metrics();
    if (!available) result.dense = result.valid = ErrorTally{}.metrics();
    return result;
  }
};

}  // namespace

DisparityMetrics evaluate_disparity(const Plane& estimate_q4, int16_t invalid_q4, const cv::Mat& ground_truth_px,
                                    const cv::Mat& nonocc_mask) {
  if (ground_truth_px.type() != CV_32FC1) throw std::invalid_argument("evaluate_disparity: ground truth must be CV_32FC1");
  if (estimate_q4.width() != ground_truth_px.cols || estimate_q4.height() != ground_truth_px.rows) {
    throw std::invalid_argument("evaluate_disparity: estimate is " + size_text(estimate_q4.width(), estimate_q4.height()) +
                                ", ground truth is " + size_text(ground_truth_px.cols, ground_truth_px.rows));
  }
  const bool has_nonocc = !nonocc_mask.empty();
  if (has_nonocc && (nonocc_mask.type() != CV_8UC1 || nonocc_mask.size() != ground_truth_px.size())) {
    throw std::invalid_argument("evaluate_disparity: nonocc mask must be CV_8UC1 " +
                                size_text(ground_truth_px.cols, ground_truth_px.rows) + ", got type " +
                                std::to_string(nonocc_mask.type()) + " " + size_text(nonocc_mask.cols, nonocc_mask.rows));
  }
  Plane filled(estimate_q4.width(), estimate_q4.height(), estimate_q4.format());
  for (int y = 0; y < estimate_q4.height(); ++y) {
    std::copy(estimate_q4.row<int16_t>(y), estimate_q4.row<int16_t>(y) + estimate_q4.width(), filled.row<int16_t>(y));
  }
  fill_invalid_kitti(filled, invalid_q4);

  RegionTally nonocc, all;
  for (int y = 0; y < ground_truth_px.rows; ++y) {
    const float* truth = ground_truth_px.ptr<float>(y);
    const int16_t* produced = estimate_q4.row<int16_t>(y);
    const int16_t* dense = filled.row<int16_t>(y);
    const uint8_t* visible = has_nonocc ? nonocc_mask.ptr<uint8_t>(y) : nullptr;
    for (int x = 0; x < ground_truth_px.cols; ++x) {
      if (!std::isfinite(truth[x])) continue;
      const double dense_px = dense[x] == invalid_q4 ? 0.0 : dense[x] / 16.0;
      const double dense_error_px = std::abs(dense_px - truth[x]);
      const bool valid = produced[x] != invalid_q4;
      const double valid_error_px = std::abs(produced[x] / 16.0 - truth[x]);
      for (RegionTally* region : {&all, (visible != nullptr && visible[x] == 255) ? &nonocc : nullptr}) {
        if (region == nullptr) continue;
        region->dense.add(dense_error_px, truth[x]);
        if (valid) region->valid.add(valid_error_px, truth[x]);
      }
    }
  }
  DisparityMetrics result;
  result.has_nonocc = has_nonocc;
  result.nonocc = nonocc.metrics(has_nonocc);
  result.all = all.metrics(true);
  return result;
}

}  // namespace lpstereo::io
