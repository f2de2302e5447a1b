#include "tools/odometry_command.h"

#include <chrono>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "dag/atomic_file.h"
#include "io/camera/file_source.h"
#include "io/kitti_poses.h"
#include "io/rectification.h"
#include "tools/command_error.h"
#include "tools/frame_sequence.h"
#include "tools/rectified_pair.h"

namespace lpstereo::tools {

OdometryCommand::OdometryCommand(CLI::App& app) {
  command_ = app.add_subcommand("odometry",
                                "stereo visual odometry over a rectified sequence (libviso2-style: Harris + BRIEF, circle "
                                "matching, RANSAC + Gauss-Newton on the reprojection error; docs/odometry.md); writes the "
                                "trajectory in the KITTI pose format");
  command_->add_option("--left", left_pattern_, "the left frames, a printf pattern such as 'dir/%06d.png'")->required();
  command_->add_option("--right", right_pattern_, "the right frames, a pattern like --left")->required();
  command_->add_option("--calib", calibration_files_,
                       "calibration file, or two; its rectified geometry gives focal length, principal point and baseline")
      ->required();
  command_->add_option("-o,--output", output_, "trajectory to write (KITTI poses: 12 numbers per line, camera to first frame)")
      ->required();
  command_->add_option("--stats", stats_path_, "also write per-frame statistics, one JSON line per frame");
  command_->add_option("--first", first_frame_, "the first frame's number")->capture_default_str()->check(CLI::NonNegativeNumber);
  command_->add_option("--frames", frame_limit_, "at most this many frames (0 = until the first missing file)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--threads", threads_, "worker threads for the feature graph (0 = one per hardware thread)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  arm::StereoOdometryParameters& p = parameters_;
  command_->add_option("--harris-threshold", p.harris_threshold, "Harris response threshold (kernels/harris_nms.cpp units)")
      ->capture_default_str();
  command_->add_option("--cell-size", p.cell_size_px, "bucketing cell, px")->capture_default_str();
  command_->add_option("--per-cell", p.per_cell_k, "corners kept per cell")->capture_default_str();
  command_->add_option("--max-hamming", p.max_hamming_distance, "largest Hamming distance of a match, bits of 256")
      ->capture_default_str();
  command_->add_option("--ratio", p.ratio_test, "ratio test: best < ratio x second best")->capture_default_str();
  command_->add_option("--epipolar-tolerance", p.epipolar_tolerance_px, "stereo matches: row difference, px")->capture_default_str();
  command_->add_option("--max-disparity", p.max_disparity_px, "stereo matches: largest disparity, px")->capture_default_str();
  command_->add_option("--predicted-radius", p.predicted_radius_px, "temporal matches around the predicted position, px")
      ->capture_default_str();
  command_->add_option("--search-radius", p.search_radius_px, "temporal matches without a prediction, px")->capture_default_str();
  command_->add_option("--ransac-iterations", p.ransac_iterations, "RANSAC minimal sets of 3 points")->capture_default_str();
  command_->add_option("--inlier-threshold", p.inlier_threshold_px, "RANSAC inlier reprojection error, px")->capture_default_str();
  command_->add_option("--min-inliers", p.min_inliers, "fewer inliers: the frame is invalid and the pose held")
      ->capture_default_str();
}

int OdometryCommand::run() const {
  check_frame_patterns(left_pattern_, right_pattern_);
  // A SourceError (no first frame, a size change, an unreadable file) ends the command with its line, exit 1.
  const auto source = std::make_unique<io::ImageSequenceSource>(left_pattern_, right_pattern_, io::SourceOptions{}, first_frame_,
                                                                frame_limit_);
  const int frame_count = source->frame_count();
  const int width = source->width(), height = source->height();
  const io::RectifiedGeometry geometry = sequence_pinhole_geometry(calibration_files_, width, height);
  arm::StereoOdometryParameters parameters = parameters_;
  parameters.focal_px = geometry.focal_px;
  parameters.principal_point_x_px = geometry.cx_left_px;
  parameters.principal_point_y_px = geometry.cy_px;
  parameters.baseline_m = geometry.baseline_m;
  try {
    parameters.validate();
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, error.what());
  }
  arm::StereoOdometry odometry(width, height, parameters, threads_);
  std::printf("odometry: %dx%d, %s\n", width, height, parameters.summary().c_str());

  const ProgressBar progress(frame_count);  // on a terminal only
  progress.show(0);

  std::vector<Eigen::Isometry3d> poses;
  std::string stats;
  int invalid = 0;
  double processing_ms = 0, inliers = 0, path_m = 0;
  for (int i = 0; i < frame_count; ++i) {
    const io::SourceResult pair = source->next(std::chrono::milliseconds(0));  // frame_count pairs are there by name
    const auto started = std::chrono::steady_clock::now();
    const arm::StereoOdometryFrame frame = odometry.process(pair.frame.left, pair.frame.right);
    processing_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    const arm::StereoOdometryStatistics& s = frame.statistics;
    invalid += s.valid ? 0 : 1;
    inliers += s.inliers;
    path_m += frame.increment.translation().norm();
    poses.push_back(frame.pose);
    if (!stats_path_.empty()) {
      const nlohmann::json line = {{"frame", first_frame_ + i},
                                   {"valid", s.valid},
                                   {"confidence", s.confidence},
                                   {"left_features", s.left_features},
                                   {"right_features", s.right_features},
                                   {"stereo_matches", s.stereo_matches},
                                   {"circle_matches", s.circle_matches},
                                   {"inliers", s.inliers},
                                   {"reprojection_rms_px", s.reprojection_rms_px},
                                   {"predicted", s.predicted},
                                   {"hamming_distances", s.hamming_distances},
                                   {"arm_scalar_ops", s.work.scalar_ops}};
      stats += line.dump() + "\n";
    }
    progress.show(i + 1);
  }
  io::write_kitti_poses(output_, poses);
  if (!stats_path_.empty()) write_file_atomically(stats_path_, stats);
  const Eigen::Vector3d end = poses.back().translation();
  std::printf("%d frames (%d .. %d), %d invalid (pose held), path %.2f m, end (%.2f, %.2f, %.2f) m, mean %.0f inliers, "
              "mean %.1f ms per frame (%d threads) -> %s\n",
              frame_count, first_frame_, first_frame_ + frame_count - 1, invalid, path_m, end.x(), end.y(), end.z(),
              frame_count > 1 ? inliers / (frame_count - 1) : 0.0, processing_ms / frame_count, threads_, output_.c_str());
  return 0;
}

}  // namespace lpstereo::tools
