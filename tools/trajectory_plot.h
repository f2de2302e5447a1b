// The top view of an estimated trajectory against its ground truth (lpstereo eval odometry --plot):
// the ground plane of the KITTI camera frame, x (right) to the right and z (forward) up, in metres
// at the same scale on both axes, with a grid, ticks, start and end markers and a legend to the
// right of the plot (where no path can run under it). Colours
// are the Okabe-Ito palette's blue and vermillion (told apart with any colour vision) and the two
// lines also differ in pattern (solid ground truth, dashed estimate), so the plot reads in grey too.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace lpstereo::tools {

struct TrajectoryPlotLabels {
  std::string title;             // first line above the plot (e.g. the scores)
  std::string estimate_name;     // legend: "estimate (<name>)"
  std::string ground_truth_name; // legend: "ground truth (<name>)"
};

// The plot as a BGR image, 900 px high; the width grows with the legend's names.
cv::Mat draw_trajectory_plot(const std::vector<Eigen::Isometry3d>& estimate, const std::vector<Eigen::Isometry3d>& ground_truth,
                             const TrajectoryPlotLabels& labels);

// The tick spacing for `span` units: 1, 2 or 5 times a power of ten, the smallest giving at most
// `max_ticks` intervals.
double tick_spacing(double span, int max_ticks);

}  // namespace lpstereo::tools
