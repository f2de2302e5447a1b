// lpstereo localize --left 'dir/left/%06d.png' --right 'dir/right/%06d.png' --calib dir/calib.txt -o TRAJ.txt
//     --keyframes DB.bin [--log FILTER.jsonl] [--vo-only] [--first N] [--frames N] [--threads N]
//     [--start-height-m H] [tuning flags]
// The keyframe localizer (arm/localization/localizer.h, docs/localization.md "The localizer") over a
// rectified sequence of a downward-looking stereo camera: frames --first, --first + 1, ... until the
// first frame whose left or right file is missing, or --frames frames, read as `lpstereo odometry`
// reads them (io/camera/file_source.h). The calibration's rectified geometry gives the focal length,
// principal point and baseline.
// Output: the trajectory in the KITTI pose format (io/kitti_poses.h: the left camera of each frame
// relative to the first frame's, as `lpstereo synth --flight` writes poses.txt), written atomically
// once every frame is done; the keyframe database (keyframe_database.h's file) written to --keyframes
// at the end. When --keyframes names an existing file, it is loaded first as the map of an earlier
// flight (the localizer corrects against it and adds new keyframes); a file that is not a valid
// database (magic, version, checksum, sizes) ends the command with its one line, exit 1, before any
// frame is read. --log: one JSON line per frame with the filter's state (x, y, z m, yaw rad), its
// covariance (the 4x4 row-major), position sigma, confidence, odometry, height and correction
// outcomes. --vo-only: the filter fed by the visual odometry alone (no height, no keyframe
// corrections, no keyframes stored): the comparison run of the homing acceptance.
// A progress bar on stderr when it is a terminal; a summary line (frames, invalid odometry frames,
// keyframes, corrections accepted, low-confidence frames, end position and sigma, ms per frame).
// Bad input (no first frame, a pattern without one %d, the size changing mid-sequence, a calibration
// that is missing, unreadable or without a baseline, a corrupt keyframe database): one line, exit 1
// (2 for bad usage), no output. Frames without texture or odometry are not errors: the filter keeps
// predicting, and the frame is counted and logged with its low confidence.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "arm/localization/localizer.h"

namespace lpstereo::tools {

class LocalizeCommand {
 public:
  explicit LocalizeCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run() const;  // throws CommandError (one line) on bad input

 private:
  CLI::App* command_ = nullptr;
  std::string left_pattern_, right_pattern_, output_, keyframes_path_, log_path_;
  std::vector<std::string> calibration_files_;
  bool vo_only_ = false;
  int first_frame_ = 0;
  int frame_limit_ = 0;  // 0: until the first missing frame
  int threads_ = 2;
  arm::localization::KeyframeLocalizerParameters parameters_;  // the tuning flags write into it
};

}  // namespace lpstereo::tools
