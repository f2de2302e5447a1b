#include "tools/trajectory_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace lpstereo::tools {

namespace {

constexpr int kCanvasHeight_px = 900;
constexpr int kLegendGap_px = 24;  // between the plot area and the legend on its right
constexpr int kPlotLeft_px = 90, kPlotTop_px = 90, kPlotSize_px = 750;  // square: same metres per pixel on both axes
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.5;
// Okabe & Ito, "Color Universal Design" (2008): blue (0, 114, 178) and vermillion (213, 94, 0), as BGR.
const cv::Scalar kGroundTruthColour(178, 114, 0);
const cv::Scalar kEstimateColour(0, 94, 213);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGridGrey(225, 225, 225);
const cv::Scalar kWhite(255, 255, 255);
constexpr int kDash_px = 12, kGap_px = 7;

// Metres on the ground plane (x, z) to pixels of the plot area: z grows upwards.
struct GroundToPixel {
  double x_min_m, z_min_m, span_m;
  cv::Point2d operator()(double x_m, double z_m) const {
    const double scale = kPlotSize_px / span_m;
    return {kPlotLeft_px + (x_m - x_min_m) * scale, kPlotTop_px + kPlotSize_px - (z_m - z_min_m) * scale};
  }
};

std::vector<cv::Point2d> to_pixels(const std::vector<Eigen::Isometry3d>& poses, const GroundToPixel& project) {
  std::vector<cv::Point2d> points;
  points.reserve(poses.size());
  for (const Eigen::Isometry3d& pose : poses) points.push_back(project(pose.translation().x(), pose.translation().z()));
  return points;
}

// cv::Point from sub-pixel coordinates with 4 fractional bits (cv::line's `shift`), for smooth lines.
constexpr int kShift = 4;
cv::Point fixed(const cv::Point2d& point) {
  return {static_cast<int>(std::lround(point.x * (1 << kShift))), static_cast<int>(std::lround(point.y * (1 << kShift)))};
}

void draw_solid(cv::Mat& image, const std::vector<cv::Point2d>& points, const cv::Scalar& colour, int thickness) {
  for (size_t i = 1; i < points.size(); ++i) {
    cv::line(image, fixed(points[i - 1]), fixed(points[i]), colour, thickness, cv::LINE_AA, kShift);
  }
}

// A dashed polyline: the pattern runs on along the whole line, across its vertices.
void draw_dashed(cv::Mat& image, const std::vector<cv::Point2d>& points, const cv::Scalar& colour, int thickness) {
  const double period_px = kDash_px + kGap_px;
  double phase_px = 0;  // arc length since the start of the current period
  for (size_t i = 1; i < points.size(); ++i) {
    const cv::Point2d from = points[i - 1], to = points[i];
    const double length_px = std::hypot(to.x - from.x, to.y - from.y);
    double done_px = 0;
    while (done_px < length_px) {
      const bool on = phase_px < kDash_px;
      const double piece_px = std::min(length_px - done_px, (on ? kDash_px : period_px) - phase_px);
      if (on && length_px > 0) {
        const cv::Point2d a = from + (to - from) * (done_px / length_px);
        const cv::Point2d b = from + (to - from) * ((done_px + piece_px) / length_px);
        cv::line(image, fixed(a), fixed(b), colour, thickness, cv::LINE_AA, kShift);
      }
      done_px += piece_px;
      phase_px = std::fmod(phase_px + piece_px, period_px);
    }
  }
}

void draw_start_marker(cv::Mat& image, const cv::Point2d& at) {
  cv::circle(image, fixed(at), 8 << kShift, kWhite, cv::FILLED, cv::LINE_AA, kShift);
  cv::circle(image, fixed(at), 8 << kShift, kBlack, 2, cv::LINE_AA, kShift);
}

void draw_square_marker(cv::Mat& image, const cv::Point2d& at, const cv::Scalar& colour) {
  const cv::Point corner_offset(7, 7);
  const cv::Point centre(static_cast<int>(std::lround(at.x)), static_cast<int>(std::lround(at.y)));
  cv::rectangle(image, centre - corner_offset, centre + corner_offset, colour, cv::FILLED);
  cv::rectangle(image, centre - corner_offset, centre + corner_offset, kBlack, 1);
}

void draw_triangle_marker(cv::Mat& image, const cv::Point2d& at, const cv::Scalar& colour) {
  const std::vector<cv::Point> corners = {fixed(at + cv::Point2d(0, -9)), fixed(at + cv::Point2d(8, 6)),
                                          fixed(at + cv::Point2d(-8, 6))};
  cv::fillConvexPoly(image, corners, colour, cv::LINE_AA, kShift);
  cv::polylines(image, corners, true, kBlack, 1, cv::LINE_AA, kShift);
}

void put_text(cv::Mat& image, const std::string& text, cv::Point at, double scale = kFontScale, int thickness = 1) {
  cv::putText(image, text, at, kFont, scale, kBlack, thickness, cv::LINE_AA);
}

cv::Size text_size(const std::string& text, double scale = kFontScale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, thickness, &baseline);
}

std::string tick_label(double value_m, double spacing_m) {
  const int decimals = spacing_m >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(spacing_m) - 1e-9));
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", decimals, std::abs(value_m) < spacing_m * 1e-6 ? 0.0 : value_m);
  return text;
}

}  // namespace

double tick_spacing(double span, int max_ticks) {
  const double rough = span / max_ticks;
  const double power = std::pow(10.0, std::floor(std::log10(rough)));
  for (double multiple : {1.0, 2.0, 5.0, 10.0}) {
    if (multiple * power >= rough * (1 - 1e-12)) return multiple * power;
  }
  return 10 * power;
}

cv::Mat draw_trajectory_plot(const std::vector<Eigen::Isometry3d>& estimate, const std::vector<Eigen::Isometry3d>& ground_truth,
                             const TrajectoryPlotLabels& labels) {
  // The legend sits to the right of the plot area, where no path can run under it.
  const std::vector<std::string> entries = {"ground truth (" + labels.ground_truth_name + ")",
                                            "estimate (" + labels.estimate_name + ")", "start", "end (ground truth)",
                                            "end (estimate)"};
  int widest = 0;
  for (const std::string& entry : entries) widest = std::max(widest, text_size(entry).width);
  constexpr int kRow_px = 22, kSample_px = 44, kPadding_px = 10;
  const cv::Rect box(kPlotLeft_px + kPlotSize_px + kLegendGap_px, kPlotTop_px, kPadding_px * 3 + kSample_px + widest,
                     kPadding_px * 2 + kRow_px * static_cast<int>(entries.size()));
  cv::Mat image(kCanvasHeight_px, box.x + box.width + kLegendGap_px, CV_8UC3, kWhite);

  // The square of ground that holds both trajectories with a 5 % margin (at least 1 m across).
  double x_min = std::numeric_limits<double>::infinity(), x_max = -x_min, z_min = x_min, z_max = -x_min;
  for (const std::vector<Eigen::Isometry3d>* poses : {&estimate, &ground_truth}) {
    for (const Eigen::Isometry3d& pose : *poses) {
      x_min = std::min(x_min, pose.translation().x());
      x_max = std::max(x_max, pose.translation().x());
      z_min = std::min(z_min, pose.translation().z());
      z_max = std::max(z_max, pose.translation().z());
    }
  }
  if (!(x_min <= x_max)) x_min = x_max = z_min = z_max = 0;  // no pose: an empty frame around the origin
  const double span_m = std::max({x_max - x_min, z_max - z_min, 1.0}) * 1.1;
  const GroundToPixel project{(x_min + x_max - span_m) / 2, (z_min + z_max - span_m) / 2, span_m};

  // Grid, ticks and tick labels.
  const double spacing_m = tick_spacing(span_m, 8);
  const cv::Rect plot_area(kPlotLeft_px, kPlotTop_px, kPlotSize_px, kPlotSize_px);
  for (int axis = 0; axis < 2; ++axis) {
    const double low_m = axis == 0 ? project.x_min_m : project.z_min_m;
    for (double value_m = std::ceil(low_m / spacing_m) * spacing_m; value_m <= low_m + span_m; value_m += spacing_m) {
      const cv::Point2d at = axis == 0 ? project(value_m, project.z_min_m) : project(project.x_min_m, value_m);
      const std::string label = tick_label(value_m, spacing_m);
      const cv::Size size = text_size(label);
      if (axis == 0) {
        const int x = static_cast<int>(std::lround(at.x));
        cv::line(image, {x, kPlotTop_px}, {x, kPlotTop_px + kPlotSize_px}, kGridGrey, 1);
        cv::line(image, {x, kPlotTop_px + kPlotSize_px}, {x, kPlotTop_px + kPlotSize_px + 6}, kBlack, 1);
        put_text(image, label, {x - size.width / 2, kPlotTop_px + kPlotSize_px + 10 + size.height});
      } else {
        const int y = static_cast<int>(std::lround(at.y));
        cv::line(image, {kPlotLeft_px, y}, {kPlotLeft_px + kPlotSize_px, y}, kGridGrey, 1);
        cv::line(image, {kPlotLeft_px - 6, y}, {kPlotLeft_px, y}, kBlack, 1);
        put_text(image, label, {kPlotLeft_px - 10 - size.width, y + size.height / 2});
      }
    }
  }
  cv::rectangle(image, plot_area, kBlack, 1);
  const std::string x_title = "x [m] (right)";
  put_text(image, x_title, {kPlotLeft_px + (kPlotSize_px - text_size(x_title).width) / 2, kCanvasHeight_px - 14});
  put_text(image, "z [m] (forward)", {kPlotLeft_px - 60, kPlotTop_px - 10});
  put_text(image, labels.title, {kPlotLeft_px - 60, 26}, 0.6, 1);
  put_text(image, "top view of the camera path (KITTI camera frame), same scale on both axes", {kPlotLeft_px - 60, 50});

  // The trajectories, clipped to the plot area: ground truth below, the estimate over it.
  const std::vector<cv::Point2d> truth_px = to_pixels(ground_truth, project);
  const std::vector<cv::Point2d> estimate_px = to_pixels(estimate, project);
  cv::Mat plot = image(plot_area);
  const cv::Point2d origin(kPlotLeft_px, kPlotTop_px);
  auto shifted = [&](const std::vector<cv::Point2d>& points) {
    std::vector<cv::Point2d> local;
    for (const cv::Point2d& point : points) local.push_back(point - origin);
    return local;
  };
  draw_solid(plot, shifted(truth_px), kGroundTruthColour, 3);
  draw_dashed(plot, shifted(estimate_px), kEstimateColour, 2);
  if (!truth_px.empty()) draw_start_marker(image, truth_px.front());
  if (!estimate_px.empty() && (truth_px.empty() || cv::norm(estimate_px.front() - truth_px.front()) > 2)) {
    draw_start_marker(image, estimate_px.front());  // an estimate that does not start where the truth does
  }
  if (!truth_px.empty()) draw_square_marker(image, truth_px.back(), kGroundTruthColour);
  if (!estimate_px.empty()) draw_triangle_marker(image, estimate_px.back(), kEstimateColour);

  // Legend.
  cv::rectangle(image, box, kBlack, 1);
  for (size_t k = 0; k < entries.size(); ++k) {
    const int row_y = box.y + kPadding_px + kRow_px * static_cast<int>(k) + kRow_px / 2;
    const cv::Point2d sample_left(box.x + kPadding_px, row_y), sample_right(box.x + kPadding_px + kSample_px, row_y);
    const cv::Point2d sample_middle = (sample_left + sample_right) * 0.5;
    switch (k) {
      case 0: draw_solid(image, {sample_left, sample_right}, kGroundTruthColour, 3); break;
      case 1: draw_dashed(image, {sample_left, sample_right}, kEstimateColour, 2); break;
      case 2: draw_start_marker(image, sample_middle); break;
      case 3: draw_square_marker(image, sample_middle, kGroundTruthColour); break;
      default: draw_triangle_marker(image, sample_middle, kEstimateColour); break;
    }
    put_text(image, entries[k], {box.x + kPadding_px * 2 + kSample_px, row_y + text_size(entries[k]).height / 2});
  }
  return image;
}

}  // namespace lpstereo::tools
