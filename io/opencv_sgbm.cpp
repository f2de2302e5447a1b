#include "io/opencv_sgbm.h"

#include <stdexcept>

#include "io/image_io.h"

namespace lpstereo::io {

Plane run_opencv_sgbm(const Plane& left, const Plane& right, int min_disparity_px, int num_disparities, SgbmMode mode,
                      const SgbmSettings& settings) {
  if (left.width() != right.width() || left.height() != right.height()) {
    throw std::invalid_argument("OpenCV StereoSGBM: left and right sizes differ");
  }
  const cv::Ptr<cv::StereoSGBM> matcher = make_opencv_sgbm(min_disparity_px, num_disparities, mode, settings);
  cv::Mat disparity;
  matcher->compute(plane_to_mat(left), plane_to_mat(right), disparity);
  return mat_to_plane(disparity, {ElementType::s16, 4});
}

}  // namespace lpstereo::io
