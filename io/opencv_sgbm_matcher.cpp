// The matcher half of io/opencv_sgbm.h (settings, names, cv::StereoSGBM::create) in a library of
// its own that needs only OpenCV's core and calib3d: bench/opencv_disparity_oneshot links it and
// nothing of lpstereo's, so OpenCV's whole-process figures carry only the libraries an OpenCV
// program needs.
#include "io/opencv_sgbm.h"

#include <stdexcept>

namespace lpstereo::io {

const char* sgbm_mode_name(SgbmMode mode) {
  switch (mode) {
    case SgbmMode::sgbm: return "MODE_SGBM";
    case SgbmMode::sgbm_3way: return "MODE_SGBM_3WAY";
    case SgbmMode::hh: return "MODE_HH";
  }
  return "?";
}

std::string sgbm_settings_text(const SgbmSettings& settings) {
  return "OpenCV " CV_VERSION " StereoSGBM: blockSize " + std::to_string(settings.block_size_px) + ", P1 " +
         std::to_string(settings.p1) + ", P2 " + std::to_string(settings.p2) + ", uniquenessRatio " +
         std::to_string(settings.uniqueness_pct) + ", speckleWindowSize " + std::to_string(settings.speckle_window_px) +
         ", speckleRange " + std::to_string(settings.speckle_range_px) + ", disp12MaxDiff " +
         std::to_string(settings.disp12_max_diff_px) + ", preFilterCap " + std::to_string(settings.prefilter_cap);
}

cv::Ptr<cv::StereoSGBM> make_opencv_sgbm(int min_disparity_px, int num_disparities, SgbmMode mode,
                                         const SgbmSettings& settings) {
  if (num_disparities <= 0 || num_disparities % 16 != 0) {
    throw std::invalid_argument("OpenCV StereoSGBM: num_disparities must be a positive multiple of 16, got " +
                                std::to_string(num_disparities));
  }
  const int cv_mode = mode == SgbmMode::sgbm ? cv::StereoSGBM::MODE_SGBM
                      : mode == SgbmMode::sgbm_3way ? cv::StereoSGBM::MODE_SGBM_3WAY
                                                    : cv::StereoSGBM::MODE_HH;
  return cv::StereoSGBM::create(min_disparity_px, num_disparities, settings.block_size_px, settings.p1, settings.p2,
                                settings.disp12_max_diff_px, settings.prefilter_cap, settings.uniqueness_pct,
                                settings.speckle_window_px, settings.speckle_range_px, cv_mode);
}

}  // namespace lpstereo::io
