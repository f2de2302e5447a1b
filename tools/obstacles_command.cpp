#include "tools/obstacles_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>

#include <unistd.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arm/disparity_engine.h"
#include "arm/obstacle_detector.h"
#include "dag/atomic_file.h"
#include "io/camera/file_source.h"
#include "io/frame_pattern.h"
#include "io/image_io.h"
#include "io/rectification.h"
#include "kernels/obstacle_mask.h"
#include "tools/command_error.h"
#include "tools/frame_sequence.h"
#include "tools/rectified_pair.h"

namespace lpstereo::tools {

namespace {

// Red (near) through yellow and green to blue (far), by distance: 0 .. 10 .. 40 .. 150 m and beyond.
cv::Scalar distance_colour(double distance_m) {
  const double stops_m[] = {0.0, 10.0, 40.0, 150.0};
  const cv::Vec3d colours[] = {{0, 0, 255}, {0, 255, 255}, {0, 200, 0}, {255, 80, 0}};  // BGR
  if (distance_m >= stops_m[3]) return cv::Scalar(colours[3][0], colours[3][1], colours[3][2]);
  int segment = 0;
  while (distance_m > stops_m[segment + 1]) ++segment;
  const double t = std::clamp((distance_m - stops_m[segment]) / (stops_m[segment + 1] - stops_m[segment]), 0.0, 1.0);
  const cv::Vec3d colour = colours[segment] * (1.0 - t) + colours[segment + 1] * t;
  return cv::Scalar(colour[0], colour[1], colour[2]);
}

std::string distance_label(double distance_m) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f m", distance_m);
  return text;
}

cv::Mat overlay_picture(const std::string& left_path, const std::vector<arm::Obstacle>& obstacles) {
  cv::Mat picture = io::decode_image(left_path, cv::IMREAD_COLOR);
  if (picture.depth() != CV_8U) picture.convertTo(picture, CV_8U, 1.0 / 256);
  const int thickness = std::max(1, picture.cols / 640);
  const double font_scale = 0.4 * thickness;
  for (const arm::Obstacle& obstacle : obstacles) {
    const cv::Scalar colour = distance_colour(obstacle.distance_m);
    const cv::Point top_left(obstacle.bbox_px[0], obstacle.bbox_px[1]);
    cv::rectangle(picture, top_left, cv::Point(obstacle.bbox_px[2], obstacle.bbox_px[3]), colour, thickness);
    cv::putText(picture, distance_label(obstacle.distance_m), top_left + cv::Point(0, -3 * thickness), cv::FONT_HERSHEY_SIMPLEX,
                font_scale, colour, thickness, cv::LINE_AA);
  }
  return picture;
}

// The grid as a top view: row 0 (far) at the top, `scale` px per cell; grey = the cell's votes (log),
// white = occupied (at or above its row's eq. 4.3 threshold), each obstacle's occupied cells in its colour.
cv::Mat grid_picture(const Plane& grid, const arm::ObstacleParameters& parameters, const std::vector<arm::Obstacle>& obstacles) {
  const std::vector<uint32_t> thresholds =
      arm::obstacle_cell_thresholds(parameters.grid.geometry, parameters.grid.columns_per_cell, parameters.grid.obstacle_weight,
                                    parameters.clusters, parameters.focal_px, parameters.baseline_m);
  const int scale = std::max(1, 1024 / std::max(grid.width(), grid.height()));
  cv::Mat picture(grid.height() * scale, grid.width() * scale, CV_8UC3, cv::Scalar(0, 0, 0));
  for (int r = 0; r < grid.height(); ++r) {
    for (int c = 0; c < grid.width(); ++c) {
      const uint16_t votes = grid.at<uint16_t>(c, r);
      cv::Scalar colour;
      if (votes >= thresholds[static_cast<size_t>(r)]) {
        colour = cv::Scalar(255, 255, 255);
        for (const arm::Obstacle& obstacle : obstacles) {
          if (c >= obstacle.cell_box[0] && c <= obstacle.cell_box[2] && r >= obstacle.cell_box[1] && r <= obstacle.cell_box[3]) {
            colour = distance_colour(obstacle.distance_m);
          }
        }
      } else {
        const double grey = votes == 0 ? 0.0 : 40.0 + 120.0 * std::log1p(votes) / std::log1p(65535.0);
        colour = cv::Scalar(grey, grey, grey);
      }
      cv::rectangle(picture, cv::Rect(c * scale, r * scale, scale, scale), colour, cv::FILLED);
    }
  }
  return picture;
}

cv::Mat mask_picture(const Plane& mask) {
  cv::Mat picture(mask.height(), mask.width(), CV_8UC3);
  for (int v = 0; v < mask.height(); ++v) {
    for (int u = 0; u < mask.width(); ++u) {
      const uint8_t value = mask.at<uint8_t>(u, v);
      picture.at<cv::Vec3b>(v, u) = value == kernels::kMaskObstacle ? cv::Vec3b(0, 0, 255)
                                    : value == kernels::kMaskFree   ? cv::Vec3b(0, 110, 0)
                                                                    : cv::Vec3b(0, 0, 0);
    }
  }
  return picture;
}

// V-disparity: bins across (scaled to at least 256 px), rows down; grey = log count; the road line in red.
cv::Mat vdisp_picture(const Plane& vdisp, const arm::RoadProfile& road, int min_disparity) {
  const int scale = std::max(1, 256 / vdisp.width());
  cv::Mat grey(vdisp.height(), vdisp.width(), CV_8UC1);
  uint16_t largest = 1;
  for (int v = 0; v < vdisp.height(); ++v) {
    for (int b = 0; b < vdisp.width(); ++b) largest = std::max(largest, vdisp.at<uint16_t>(b, v));
  }
  for (int v = 0; v < vdisp.height(); ++v) {
    for (int b = 0; b < vdisp.width(); ++b) {
      grey.at<uint8_t>(v, b) = static_cast<uint8_t>(std::lround(255.0 * std::log1p(vdisp.at<uint16_t>(b, v)) / std::log1p(largest)));
    }
  }
  cv::Mat picture;
  cv::resize(grey, picture, cv::Size(vdisp.width() * scale, vdisp.height()), 0, 0, cv::INTER_NEAREST);
  cv::cvtColor(picture, picture, cv::COLOR_GRAY2BGR);
  if (road.valid) {
    // d(v) = slope v + intercept; bin b holds [b + min, b + min + 1) px, so x = (d - min) * scale.
    const auto x_of = [&](double v) { return (road.slope * v + road.intercept_px - min_disparity) * scale; };
    const double v0 = 0, v1 = vdisp.height() - 1;
    cv::line(picture, cv::Point2d(x_of(v0), v0), cv::Point2d(x_of(v1), v1), cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  }
  return picture;
}

nlohmann::json road_json(const arm::RoadProfile& road) {
  if (!road.valid) return {{"valid", false}, {"confidence", road.confidence}};
  // A climb ahead: rows above break_row follow the far line (arm/tasks/road_profile.h); null if none.
  const nlohmann::json far = road.far_valid ? nlohmann::json{{"slope_px_per_row", road.far_slope},
                                                             {"intercept_px", road.far_intercept_px},
                                                             {"break_row_px", road.far_break_row},
                                                             {"inlier_rows", road.far_inlier_count}}
                                            : nlohmann::json(nullptr);
  return {{"valid", true},
          {"far_segment", far},
          {"carried", road.carried},
          {"confidence", road.confidence},
          {"slope_px_per_row", road.slope},
          {"intercept_px", road.intercept_px},
          {"horizon_row_px", road.horizon_row},
          {"camera_height_m", road.camera_height_mm / 1000.0},
          {"pitch_rad", road.pitch_rad},
          {"inlier_rows", road.inlier_count},
          {"point_rows", road.point_count},
          {"rms_residual_px", road.rms_residual_px}};
}

// One obstacle record; "track_id" and "velocity_mps" are null unless the records were tracked.
nlohmann::json obstacle_json(const arm::Obstacle& obstacle, bool features_counted, bool tracked) {
  return {{"id", obstacle.id},
          {"bbox_px", {obstacle.bbox_px[0], obstacle.bbox_px[1], obstacle.bbox_px[2], obstacle.bbox_px[3]}},
          {"disparity", obstacle.disparity_px},
          {"distance_m", obstacle.distance_m},
          {"position_m", {obstacle.position_m[0], obstacle.position_m[1], obstacle.position_m[2]}},
          {"width_m", obstacle.width_m},
          {"height_m", obstacle.height_m},
          {"pixels", obstacle.pixels},
          {"features", features_counted ? nlohmann::json(obstacle.features) : nlohmann::json(nullptr)},
          {"track_id", tracked ? nlohmann::json(obstacle.track_id) : nlohmann::json(nullptr)},
          {"velocity_mps", tracked ? nlohmann::json{obstacle.velocity_mps[0], obstacle.velocity_mps[1], obstacle.velocity_mps[2]}
                                   : nlohmann::json(nullptr)}};
}

}  // namespace

nlohmann::json obstacle_frame_json(int width, int height, const arm::ObstacleFrame& frame, const arm::ObstacleParameters& parameters) {
  nlohmann::json obstacles = nlohmann::json::array();
  for (const arm::Obstacle& obstacle : frame.obstacles) {
    obstacles.push_back(obstacle_json(obstacle, parameters.feature_validation, parameters.tracking));
  }
  return {{"width", width}, {"height", height}, {"road", road_json(frame.road)}, {"obstacles", obstacles}};
}

void check_obstacle_geometry(const io::RectifiedGeometry& geometry, const std::vector<std::string>& calibration_files) {
  const std::string calibration_name = calibration_files[0] + (calibration_files.size() == 2 ? "," + calibration_files[1] : "");
  if (!(geometry.baseline_m > 0.0) || !std::isfinite(geometry.baseline_m)) {
    throw CommandError(kExitInput, "calibration " + calibration_name +
                                       ": expected a stereo baseline > 0 m (the right camera's translation), got " +
                                       std::to_string(geometry.baseline_m) + " m");
  }
  if (geometry.projection != io::RectifiedProjection::pinhole) {
    throw CommandError(kExitInput, "calibration " + calibration_name + ": expected a pinhole rectification, got latitude-longitude");
  }
}

arm::ObstacleParameters detector_parameters_for(arm::ObstacleParameters parameters, const io::RectifiedGeometry& geometry,
                                                const arm::DisparityParameters& disparity_parameters) {
  parameters.focal_px = geometry.focal_px;
  parameters.baseline_m = geometry.baseline_m;
  parameters.principal_point_x_px = geometry.cx_left_px;
  parameters.principal_point_y_px = geometry.cy_px;
  return parameters.for_disparity_range(disparity_parameters.min_disparity, disparity_parameters.num_disparities);
}

namespace {

double milliseconds(std::chrono::steady_clock::duration duration) {
  return std::chrono::duration<double, std::milli>(duration).count();
}

}  // namespace

void add_obstacle_tuning_options(CLI::App& command, arm::ObstacleParameters& p) {
  // arm/obstacle_detector.h, arm/tasks/obstacle_clusters.h, kernels/vldh_mask.cpp say what each does.
  command.add_option("--near-height-m", p.clusters.near_min_height_m, "eq. 4.3: smallest obstacle height near the vehicle, m")
      ->capture_default_str();
  command.add_option("--far-height-m", p.clusters.far_min_height_m, "eq. 4.3: smallest obstacle height far away, m")
      ->capture_default_str();
  command.add_option("--switch-distance-m", p.clusters.height_switch_distance_m, "eq. 4.3: where far begins, m")
      ->capture_default_str();
  command.add_option("--min-width-m", p.clusters.min_width_m, "smallest obstacle width for the cell threshold, m (0 = off)")
      ->capture_default_str();
  command.add_option("--min-cells", p.clusters.min_cells, "clusters with fewer grid cells are dropped")->capture_default_str();
  command.add_option("--min-pixels", p.clusters.min_pixels, "clusters with fewer mask pixels are dropped")->capture_default_str();
  command.add_option("--columns-per-cell", p.grid.columns_per_cell, "image columns per grid cell")->capture_default_str();
  command.add_option("--grid-rows", p.grid.geometry.grid_rows, "grid rows (log-scaled in disparity, eq. 4.2)")->capture_default_str();
  command.add_option("--grid-k", p.grid.geometry.exponent_k, "eq. 4.2's k (> 1: more rows far away)")->capture_default_str();
  command.add_option("--obstacle-weight", p.grid.obstacle_weight, "grid vote of an obstacle pixel")->capture_default_str();
  command.add_option("--free-weight", p.grid.free_weight, "grid penalty of a free-space pixel")->capture_default_str();
  command.add_option("--vldh-rows", p.vldh.window_rows, "VLDH window: rows below a pixel")->capture_default_str();
  command.add_option("--vldh-min-count", p.vldh.min_count, "VLDH: rows of the window that must match")->capture_default_str();
  command.add_option("--vldh-tolerance-q4", p.vldh.match_tolerance_q4, "VLDH: match tolerance, 1/16 px")->capture_default_str();
  command.add_option("--road-margin-q4", p.vldh.road_margin_q4, "VLDH: height above the road's disparity, 1/16 px")
      ->capture_default_str();
  command.add_option("--road-margin-per-mille", p.vldh.road_margin_per_mille, "VLDH: plus this share of the road's disparity")
      ->capture_default_str();
  command.add_option("--feature-validation", p.feature_validation,
                       "drop clusters without a Harris corner on their obstacle pixels (true/false)")
      ->capture_default_str();
  command.add_option("--harris-threshold", p.features.harris_threshold, "feature validation: Harris response threshold")
      ->capture_default_str();
  command.add_option("--min-features", p.validation.min_features, "feature validation: corners a cluster needs")
      ->capture_default_str();
  command.add_option("--mask-radius", p.validation.mask_radius_px,
                       "feature validation: a corner counts with an obstacle pixel this near (-1: anywhere in the box)")
      ->capture_default_str();
}

ObstaclesCommand::ObstaclesCommand(CLI::App& app) {
  command_ = app.add_subcommand("obstacles",
                                "obstacles in front of the vehicle from a rectified pair: disparity engine, then V-disparity road "
                                "profile, VLDH mask, Advanced U-disparity grid and clusters (arm/obstacle_detector.h)");
  command_->add_option("LEFT", left_, "rectified left image (single-frame mode)");
  command_->add_option("RIGHT", right_, "rectified right image, same size (single-frame mode)");
  command_->add_option("--left", left_pattern_, "sequence mode: the left frames, a printf pattern such as 'dir/%06d.png'");
  command_->add_option("--right", right_pattern_, "sequence mode: the right frames, a pattern like --left");
  command_->add_option("--first", first_frame_, "sequence mode: the first frame's number")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--frames", frame_limit_, "sequence mode: at most this many frames (0 = until the first missing file)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--fps", fps_, "sequence mode: frames per second (the tracker's frame period is 1 / fps)")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 10000.0));
  command_->add_option("--calib", calibration_files_,
                       "calibration file, or two (intrinsics + extrinsics, or left + right); its rectified geometry gives "
                       "focal length, baseline and principal point")
      ->required();
  command_->add_option("-o,--output", output_, "obstacle JSON file to write (sequence mode: JSON lines, one per frame)")->required();
  command_->add_option("--overlay", overlay_path_, "also write the left image with the obstacles' boxes and distances (PNG)");
  command_->add_option("--grid", grid_path_, "also write the Advanced U-disparity grid as a top view (PNG)");
  command_->add_option("--mask", mask_path_, "also write the VLDH obstacle mask (PNG)");
  command_->add_option("--vdisp", vdisp_path_, "also write the V-disparity image with the road line (PNG)");
  command_->add_option("--threads", threads_, "worker threads (0 = one per hardware thread)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  add_disparity_engine_options(*command_, engine_options_,
                               "disparities searched: [min-disp, min-disp + num-disp) (default 64)");
  add_obstacle_tuning_options(*command_, detector_parameters_);
}

int ObstaclesCommand::run() const {
  const bool sequence = !left_pattern_.empty() || !right_pattern_.empty();
  if (sequence && (!left_.empty() || !right_.empty())) {
    throw CommandError(kExitUsage, "give LEFT RIGHT (one frame) or --left and --right patterns (a sequence), not both");
  }
  if (sequence) return run_sequence();
  if (left_.empty() || right_.empty()) {
    throw CommandError(kExitUsage, "give LEFT RIGHT (one frame) or --left and --right patterns (a sequence)");
  }
  for (const char* flag : {"--first", "--frames", "--fps"}) {
    if (command_->count(flag) > 0) throw CommandError(kExitUsage, std::string(flag) + " is a sequence-mode option (with --left and --right)");
  }
  return run_single_frame();
}

int ObstaclesCommand::run_single_frame() const {
  const RectifiedPair pair = read_rectified_pair(left_, right_, calibration_files_);
  const Plane& left = pair.left;
  const Plane& right = pair.right;
  const io::RectifiedGeometry& geometry = pair.geometry;
  check_obstacle_geometry(geometry, calibration_files_);

  const arm::DisparityParameters disparity_parameters =
      tools::disparity_parameters(engine_options_, left.width(), arm::DisparityParameters{}.num_disparities);
  arm::DisparityEngine engine(left.width(), left.height(), disparity_parameters, {}, threads_);
  const auto started = std::chrono::steady_clock::now();
  const Plane& disparity = engine.compute(left, right);
  const auto disparity_done = std::chrono::steady_clock::now();

  const arm::ObstacleParameters parameters = detector_parameters_for(detector_parameters_, geometry, disparity_parameters);
  arm::ObstacleDetector detector(left.width(), left.height(), parameters, {}, threads_);
  const arm::ObstacleFrame frame = detector.run(disparity, left);
  const auto obstacles_done = std::chrono::steady_clock::now();
  const double disparity_ms = milliseconds(disparity_done - started);
  const double obstacle_stage_ms = milliseconds(obstacles_done - disparity_done);

  write_file_atomically(output_, obstacle_frame_json(left.width(), left.height(), frame, parameters).dump(2) + "\n");
  if (!overlay_path_.empty()) io::write_image(overlay_path_, overlay_picture(left_, frame.obstacles));
  if (!grid_path_.empty()) io::write_image(grid_path_, grid_picture(*frame.grid, parameters, frame.obstacles));
  if (!mask_path_.empty()) io::write_image(mask_path_, mask_picture(*frame.mask));
  if (!vdisp_path_.empty()) io::write_image(vdisp_path_, vdisp_picture(*frame.vdisp, frame.road, parameters.v_disparity_min_px()));

  int64_t valid = 0;
  const int16_t invalid_q4 = engine.invalid_disparity_q4();
  for (int v = 0; v < disparity.height(); ++v) {
    for (int u = 0; u < disparity.width(); ++u) valid += disparity.at<int16_t>(u, v) != invalid_q4 ? 1 : 0;
  }
  const double density_pct = 100.0 * static_cast<double>(valid) / (static_cast<double>(left.width()) * left.height());
  if (frame.road.valid) {
    std::printf("%zu obstacles; road: camera height %.2f m, pitch %.4f rad, confidence %d%s; disparity density %.1f %% -> %s\n",
                frame.obstacles.size(), frame.road.camera_height_mm / 1000.0, frame.road.pitch_rad, frame.road.confidence,
                frame.road.carried ? " (carried)" : "", density_pct, output_.c_str());
  } else {
    std::printf("no road found (confidence %d, disparity density %.1f %%): no obstacles -> %s\n", frame.road.confidence,
                density_pct, output_.c_str());
  }
  // First frame of a fresh engine and detector: includes their first-touch costs.
  std::printf("disparity %.1f ms, obstacle stage %.1f ms (first frame, %d threads)\n", disparity_ms, obstacle_stage_ms, threads_);
  return 0;
}

int ObstaclesCommand::run_sequence() const {
  if (left_pattern_.empty() || right_pattern_.empty()) {
    throw CommandError(kExitUsage, std::string("--left and --right go together (sequence mode reads both views), got only ") +
                                       (left_pattern_.empty() ? "--right" : "--left"));
  }
  for (const char* flag : {"--overlay", "--grid", "--mask", "--vdisp"}) {
    if (command_->count(flag) > 0) throw CommandError(kExitUsage, std::string(flag) + " is a single-frame option (with LEFT RIGHT)");
  }
  check_frame_patterns(left_pattern_, right_pattern_);
  // The frames through the image-sequence source (io/camera/file_source.h), as `lpstereo run
  // --source files:` reads them: from --first to the first number with a view missing, at most --frames.
  // A SourceError (no first frame, a size change, an unreadable file) ends the command with its line, exit 1.
  const auto source = std::make_unique<io::ImageSequenceSource>(left_pattern_, right_pattern_, io::SourceOptions{}, first_frame_,
                                                                frame_limit_);
  const int frame_count = source->frame_count();
  const int width = source->width(), height = source->height();
  const io::RectifiedGeometry geometry = rectified_geometry(calibration_files_, width, height);
  check_obstacle_geometry(geometry, calibration_files_);
  const arm::DisparityParameters disparity_parameters =
      tools::disparity_parameters(engine_options_, width, arm::DisparityParameters{}.num_disparities);
  arm::ObstacleParameters parameters = detector_parameters_for(detector_parameters_, geometry, disparity_parameters);
  parameters.tracking = true;
  parameters.tracking_settings.frame_period_s = 1.0 / fps_;
  arm::DisparityEngine engine(width, height, disparity_parameters, {}, threads_);
  arm::ObstacleDetector detector(width, height, parameters, {}, threads_);

  const ProgressBar progress(frame_count);  // on a terminal only
  progress.show(0);

  std::string lines;  // every frame's line, written at the end in one atomic step: no half-written file
  std::set<int> track_ids;
  double processing_ms = 0.0;
  for (int i = 0; i < frame_count; ++i) {
    const int index = first_frame_ + i;
    const io::SourceResult pair = source->next(std::chrono::milliseconds(0));  // frame_count pairs are there by name
    const Plane& left = pair.frame.left;
    const Plane& right = pair.frame.right;
    const auto started = std::chrono::steady_clock::now();
    const arm::ObstacleFrame frame = detector.run(engine.compute(left, right), left);
    processing_ms += milliseconds(std::chrono::steady_clock::now() - started);
    nlohmann::json line = obstacle_frame_json(width, height, frame, parameters);
    line["frame"] = index;
    lines += line.dump() + "\n";
    for (const arm::Obstacle& obstacle : frame.obstacles) {
      if (obstacle.track_id > 0) track_ids.insert(obstacle.track_id);
    }
    progress.show(i + 1);
  }
  write_file_atomically(output_, lines);
  std::printf("%d frames (%d .. %d) at %.3g fps, %zu tracks, mean %.1f ms per frame (disparity + obstacles, %d threads) -> %s\n",
              frame_count, first_frame_, first_frame_ + frame_count - 1, fps_, track_ids.size(), processing_ms / frame_count,
              threads_, output_.c_str());
  return 0;
}

}  // namespace lpstereo::tools
