#include "io/row_alignment.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "io/calibration.h"

namespace lpstereo::io {

namespace {

double percentile(std::vector<double> values, double fraction) {
  std::sort(values.begin(), values.end());
  const double position = fraction * static_cast<double>(values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(below + 1, values.size() - 1);
  return values[below] + (position - static_cast<double>(below)) * (values[above] - values[below]);
}

}  // namespace

RowAlignment measure_row_alignment(const cv::Mat& left, const cv::Mat& right, const std::string& detector_name) {
  cv::Ptr<cv::Feature2D> detector;
  if (detector_name == "orb") {
    detector = cv::ORB::create(5000);
  } else if (detector_name == "akaze") {
    detector = cv::AKAZE::create(cv::AKAZE::DESCRIPTOR_MLDB, 0, 3, 0.0005f);
  } else {
    throw CalibrationError("feature detector '" + detector_name + "': expected akaze or orb");
  }
  std::vector<cv::KeyPoint> left_points, right_points;
  cv::Mat left_descriptors, right_descriptors;
  detector->detectAndCompute(left, cv::noArray(), left_points, left_descriptors);
  detector->detectAndCompute(right, cv::noArray(), right_points, right_descriptors);
  std::vector<cv::Point2f> left_matched, right_matched;
  if (!left_descriptors.empty() && !right_descriptors.empty()) {
    cv::BFMatcher matcher(cv::NORM_HAMMING);
    std::vector<std::vector<cv::DMatch>> forward, backward;
    matcher.knnMatch(left_descriptors, right_descriptors, forward, 2);
    matcher.knnMatch(right_descriptors, left_descriptors, backward, 2);
    auto good = [](const std::vector<cv::DMatch>& pair) {
      return !pair.empty() && (pair.size() < 2 || pair[0].distance < 0.8f * pair[1].distance);
    };
    for (const std::vector<cv::DMatch>& pair : forward) {
      if (!good(pair)) continue;
      const cv::DMatch& match = pair[0];
      const std::vector<cv::DMatch>& reverse = backward[static_cast<size_t>(match.trainIdx)];
      if (!good(reverse) || reverse[0].trainIdx != match.queryIdx) continue;
      left_matched.push_back(left_points[static_cast<size_t>(match.queryIdx)].pt);
      right_matched.push_back(right_points[static_cast<size_t>(match.trainIdx)].pt);
    }
  }
  RowAlignment alignment;
  alignment.candidates = left_matched.size();
  if (alignment.candidates < 8) {
    throw CalibrationError("too few matched features (" + std::to_string(alignment.candidates) +
                           ", need 8) to measure the rectification");
  }
  std::vector<uchar> inliers;
  cv::findFundamentalMat(left_matched, right_matched, cv::FM_RANSAC, 1.0, 0.999, inliers);
  std::vector<double> offsets;
  for (size_t i = 0; i < inliers.size(); ++i) {
    if (inliers[i]) offsets.push_back(std::abs(static_cast<double>(left_matched[i].y) - right_matched[i].y));
  }
  if (offsets.size() < 8) {
    throw CalibrationError("too few epipolar-consistent matches (" + std::to_string(offsets.size()) +
                           ", need 8) to measure the rectification");
  }
  alignment.matches = offsets.size();
  alignment.median_px = percentile(offsets, 0.5);
  alignment.p95_px = percentile(offsets, 0.95);
  return alignment;
}

}  // namespace lpstereo::io
