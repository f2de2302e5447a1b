// OpenCV's StereoSGBM as the reference the evaluation and the benchmark compare with, configured in
// one place so both use the same settings (issue 4's acceptance settings, and OpenCV's own
// samples/cpp/stereo_match.cpp where the issue is silent):
//   blockSize 5; P1 = 8 * 5 * 5 = 200; P2 = 32 * 5 * 5 = 800 (one channel: the same u8 luma lpstereo
//   gets); uniquenessRatio 10 (%); speckleWindowSize 100 px; speckleRange 2 (px; OpenCV compares
//   it x16 against its Q4 values); disp12MaxDiff 1 px (left-right check; 0 would also mean 1
//   inside OpenCV); preFilterCap 63.
// Output: CV_16S, disparity x 16 (Q4), invalid = (minDisparity - 1) * 16: the same convention as
// lpstereo's engine, so the planes are interchangeable.
#pragma once

#include <string>

#include <opencv2/calib3d.hpp>

#include "dag/plane.h"

namespace lpstereo::io {

enum class SgbmMode { sgbm, sgbm_3way, hh };

struct SgbmSettings {
  int block_size_px = 5;
  int p1 = 8 * 5 * 5;
  int p2 = 32 * 5 * 5;
  int uniqueness_pct = 10;
  int speckle_window_px = 100;
  int speckle_range_px = 2;
  int disp12_max_diff_px = 1;
  int prefilter_cap = 63;
};

// "MODE_SGBM", "MODE_SGBM_3WAY", "MODE_HH".
const char* sgbm_mode_name(SgbmMode mode);
// One line with every setting, for reports and benchmark contexts.
std::string sgbm_settings_text(const SgbmSettings& settings);

// The matcher with these settings (num_disparities: a positive multiple of 16, else
// std::invalid_argument).
cv::Ptr<cv::StereoSGBM> make_opencv_sgbm(int min_disparity_px, int num_disparities, SgbmMode mode,
                                         const SgbmSettings& settings = {});

// Left/right u8 views of the same size; num_disparities must be a positive multiple of 16
// (OpenCV's requirement; std::invalid_argument otherwise). Returns s16 Q4.
Plane run_opencv_sgbm(const Plane& left, const Plane& right, int min_disparity_px, int num_disparities, SgbmMode mode,
                      const SgbmSettings& settings = {});

}  // namespace lpstereo::io
