// What the commands that read a frame sequence by --left/--right patterns share (`lpstereo odometry`,
// `lpstereo obstacles` sequence mode): the patterns' check with the flag's name, and the progress
// bar on stderr when it is a terminal.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

#include "io/frame_pattern.h"
#include "tools/command_error.h"

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
