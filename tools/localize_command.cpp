#include "tools/localize_command.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
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

namespace localization = arm::localization;

LocalizeCommand::LocalizeCommand(CLI::App& app) {
  command_ = app.add_subcommand("localize",
                                "keyframe localization of a downward-looking stereo camera (visual odometry, visual height and "
                                "keyframe corrections fused by an EKF; docs/localization.md); writes the trajectory in the KITTI "
                                "pose format and the keyframe database");
  command_->add_option("--left", left_pattern_, "the left frames, a printf pattern such as 'dir/left/%06d.png'")->required();
  command_->add_option("--right", right_pattern_, "the right frames, a pattern like --left")->required();
  command_->add_option("--calib", calibration_files_,
                       "calibration file, or two; its rectified geometry gives focal length, principal point and baseline")
      ->required();
  command_->add_option("-o,--output", output_, "trajectory to write (KITTI poses: left camera relative to the first frame)")
      ->required();
  command_->add_option("--keyframes", keyframes_path_,
                       "keyframe database written at the end; an existing file is loaded first as the map")
      ->required();
  command_->add_option("--log", log_path_, "the filter's state and covariance per frame, one JSON line per frame");
  command_->add_flag("--vo-only", vo_only_, "visual odometry alone: no visual height, no keyframe corrections");
  command_->add_option("--first", first_frame_, "the first frame's number")->capture_default_str()->check(CLI::NonNegativeNumber);
  command_->add_option("--frames", frame_limit_, "at most this many frames (0 = until the first missing file)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--threads", threads_, "worker threads for the feature graphs (0 = one per hardware thread)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  localization::KeyframeLocalizerParameters& p = parameters_;
  command_->add_option("--start-height-m", p.start_height_m, "the left camera's height above the ground at the first frame, m")
      ->capture_default_str();
  command_->add_option("--start-yaw-rad", p.start_yaw_rad, "the yaw at the first frame, rad")->capture_default_str();
  command_->add_option("--harris-threshold", p.harris_threshold, "Harris response threshold (kernels/harris_nms.cpp units)")
      ->capture_default_str();
  command_->add_option("--cell-size", p.cell_size_px, "keypoint bucketing cell, px")->capture_default_str();
  command_->add_option("--num-disparities", p.num_disparities, "sparse disparity search range, px")->capture_default_str();
  command_->add_option("--keyframe-distance-m", p.keyframe_policy.new_keyframe_distance_m,
                       "a new keyframe when the nearest is farther than this, m")
      ->capture_default_str();
  command_->add_option("--gate", p.filter.gate_chi_square, "keyframe correction gate, chi-square with 4 degrees of freedom")
      ->capture_default_str();
}

int LocalizeCommand::run() const {
  check_frame_patterns(left_pattern_, right_pattern_);
  // The map first: a corrupt database must stop the command before any work.
  localization::KeyframeDatabase map(parameters_.keyframe_policy);
  bool loaded_map = false;
  if (!vo_only_ && std::filesystem::exists(keyframes_path_)) {
    try {
      map = localization::KeyframeDatabase::load(keyframes_path_, parameters_.keyframe_policy);
      loaded_map = true;
    } catch (const localization::KeyframeDatabaseError& error) {
      throw CommandError(kExitInput, error.what());
    }
  }
  // A SourceError (no first frame, a size change, an unreadable file) ends the command with its line, exit 1.
  const auto source = std::make_unique<io::ImageSequenceSource>(left_pattern_, right_pattern_, io::SourceOptions{}, first_frame_,
                                                                frame_limit_);
  const int frame_count = source->frame_count();
  const int width = source->width(), height = source->height();
  const io::RectifiedGeometry geometry = sequence_pinhole_geometry(calibration_files_, width, height);
  localization::KeyframeLocalizerParameters parameters = parameters_;
  parameters.focal_px = geometry.focal_px;
  parameters.principal_point_x_px = geometry.cx_left_px;
  parameters.principal_point_y_px = geometry.cy_px;
  parameters.baseline_m = geometry.baseline_m;
  if (vo_only_) {
    parameters.keyframe_corrections = false;
    parameters.height_updates = false;
  }
  try {
    parameters.validate();
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, error.what());
  }
  std::unique_ptr<localization::KeyframeLocalizer> localizer;
  try {
    localizer = std::make_unique<localization::KeyframeLocalizer>(width, height, parameters, threads_);
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, error.what());
  }
  if (loaded_map) localizer->use_map(std::move(map));
  std::printf("localize: %dx%d, %s%s\n", width, height, parameters.summary().c_str(),
              loaded_map ? (", map " + keyframes_path_ + " (" + std::to_string(localizer->database().size()) + " keyframes)").c_str()
                         : "");

  const ProgressBar progress(frame_count);  // on a terminal only
  progress.show(0);
  std::vector<Eigen::Isometry3d> poses;
  std::string log;
  int invalid_odometry = 0, accepted = 0, low_confidence = 0;
  double processing_ms = 0;
  localization::LocalizerFrame frame;
  for (int i = 0; i < frame_count; ++i) {
    const io::SourceResult pair = source->next(std::chrono::milliseconds(0));  // frame_count pairs are there by name
    const auto started = std::chrono::steady_clock::now();
    frame = localizer->process(pair.frame.left, pair.frame.right);
    processing_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();
    invalid_odometry += frame.odometry_valid || i == 0 ? 0 : 1;
    accepted += frame.correction_accepted ? 1 : 0;
    low_confidence += frame.low_confidence ? 1 : 0;
    poses.push_back(frame.pose);
    if (!log_path_.empty()) {
      std::vector<double> covariance(frame.covariance.data(), frame.covariance.data() + 16);  // symmetric: row-major = column-major
      const nlohmann::json line = {{"frame", first_frame_ + i},
                                   {"state", {frame.state(0), frame.state(1), frame.state(2), frame.state(3)}},
                                   {"covariance", covariance},
                                   {"position_sigma_m", frame.position_sigma_m},
                                   {"confidence", frame.confidence},
                                   {"low_confidence", frame.low_confidence},
                                   {"odometry_valid", frame.odometry_valid},
                                   {"odometry_inliers", frame.odometry_inliers},
                                   {"keypoints", frame.keypoints},
                                   {"validated_features", frame.validated_features},
                                   {"matches_with_previous", frame.matches_with_previous},
                                   {"visual_height_m", frame.visual_height_m},
                                   {"height_accepted", frame.height_accepted},
                                   {"keyframe_id", frame.keyframe_id},
                                   {"yaw_sector", frame.yaw_sector},
                                   {"keyframe_matches", frame.keyframe_matches},
                                   {"correction_inliers", frame.correction_inliers},
                                   {"correction_accepted", frame.correction_accepted},
                                   {"correction_note", frame.correction_note},
                                   {"keyframe_decision", localization::to_string(frame.keyframe_decision)},
                                   {"stored_keyframe_id", frame.stored_keyframe_id}};
      log += line.dump() + "\n";
    }
    progress.show(i + 1);
  }
  io::write_kitti_poses(output_, poses);
  if (!log_path_.empty()) write_file_atomically(log_path_, log);
  if (!vo_only_) {
    try {
      localizer->database().save(keyframes_path_);
    } catch (const localization::KeyframeDatabaseError& error) {
      throw CommandError(kExitInput, error.what());
    }
  }
  const Eigen::Vector3d end = poses.back().translation();
  std::printf("%d frames (%d .. %d), %d invalid odometry (predicted), %zu keyframes, %d corrections accepted, %d low-confidence "
              "frames, end (%.3f, %.3f, %.3f) m, sigma %.3f m, mean %.1f ms per frame (%d threads) -> %s%s\n",
              frame_count, first_frame_, first_frame_ + frame_count - 1, invalid_odometry, localizer->database().size(), accepted,
              low_confidence, end.x(), end.y(), end.z(), frame.position_sigma_m, processing_ms / frame_count, threads_, output_.c_str(),
              vo_only_ ? "" : (", " + keyframes_path_).c_str());
  return 0;
}

}  // namespace lpstereo::tools
