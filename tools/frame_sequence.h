// What the commands that read a frame sequence by --left/--right patterns share (`lpstereo odometry`,
// `lpstereo obstacles` sequence mode): the patterns' check with the flag's name, and the progress
// bar on stderr when it is a terminal.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

#include <vector>

#include "io/frame_pattern.h"
#include "io/rectification.h"
#include "tools/command_error.h"
#include "tools/rectified_pair.h"

namespace lpstereo::tools {

// Throws CommandError(kExitUsage, "--left <what is wrong>") unless each pattern holds exactly one
// frame-number conversion (io/frame_pattern.h).
inline void check_frame_patterns(const std::string& left_pattern, const std::string& right_pattern) {
  for (const auto& [flag, pattern] : {std::pair{"--left", &left_pattern}, std::pair{"--right", &right_pattern}}) {
    try {
      io::FramePattern{*pattern};
    } catch (const std::invalid_argument& error) {
      throw CommandError(kExitUsage, std::string(flag) + " " + error.what());
    }
  }
}

// The rectified pinhole geometry of a sequence's calibration (--calib: one file or two) for
// width x height views. Throws CommandError(kExitInput, "calibration <files>: ...") for a
// latitude-longitude rectification or a baseline that is not positive (rectified_geometry's own
// errors for a missing or unreadable file).
inline io::RectifiedGeometry sequence_pinhole_geometry(const std::vector<std::string>& calibration_files, int width, int height) {
  const io::RectifiedGeometry geometry = rectified_geometry(calibration_files, width, height);
  const std::string calibration_name = calibration_files.size() == 1 ? calibration_files[0]
                                                                     : calibration_files[0] + "," + calibration_files[1];
  if (geometry.projection != io::RectifiedProjection::pinhole) {
    throw CommandError(kExitInput, "calibration " + calibration_name + ": expected a pinhole rectification, got latitude-longitude");
  }
  if (!(geometry.baseline_m > 0)) {
    throw CommandError(kExitInput, "calibration " + calibration_name + ": expected a baseline > 0 m, got " +
                                       std::to_string(geometry.baseline_m));
  }
  return geometry;
}

// "frames [#####     ] 12 / 51" redrawn in place on stderr, on a terminal only (logs and pipes get
// the command's summary line alone); a newline after the last frame.
class ProgressBar {
 public:
  explicit ProgressBar(int total_frames) : terminal_(::isatty(STDERR_FILENO) != 0), total_frames_(total_frames) {}
  void show(int frames_done) const {
    if (!terminal_ || total_frames_ <= 0) return;
    const int filled = frames_done * 40 / total_frames_;
    std::fprintf(stderr, "\rframes [%-40s] %d / %d", std::string(static_cast<size_t>(filled), '#').c_str(), frames_done,
                 total_frames_);
    if (frames_done == total_frames_) std::fprintf(stderr, "\n");
  }

 private:
  bool terminal_;
  int total_frames_;
};

}  // namespace lpstereo::tools
