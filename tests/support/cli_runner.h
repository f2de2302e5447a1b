// Runs the lpstereo binary (LPSTEREO_BINARY, set by CMake) as a user would, capturing stdout,
// stderr and the exit code. Shared by the command-line tests.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/scratch_directory.h"

namespace lpstereo::testing {

struct Result {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// Runs lpstereo with the arguments (a shell word list), capturing stdout and stderr.
inline Result run(const std::string& arguments) {
  namespace fs = std::filesystem;
  const fs::path directory = fs::temp_directory_path() / ("lpstereo_cli_" + std::to_string(::getpid()));
  fs::create_directories(directory);
  const std::string out_file = (directory / "stdout").string();
  const std::string err_file = (directory / "stderr").string();
  const std::string command = std::string(LPSTEREO_BINARY) + " " + arguments + " >" + out_file + " 2>" + err_file;
  const int status = std::system(command.c_str());
  Result result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::string& path) {
    std::ifstream file(path);
    std::ostringstream text;
    text << file.rdbuf();
    return text.str();
  };
  result.out = slurp(out_file);
  result.err = slurp(err_file);
  std::error_code ignored;  // the capture folder is this call's own: leave nothing behind in the temp folder
  fs::remove_all(directory, ignored);
  return result;
}

// Lines in a command's output or a written text file (newline characters).
inline int count_lines(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

// The command-line tests' common scene: `lpstereo synth` of the range-test lineup at 15 m, 640x288,
// hfov 60 deg, baseline 0.30 m, camera 1.5 m high, noise 1, written to `folder`.
inline Result render_lineup_15m(const std::string& folder) {
  return run("synth -o " + folder +
             " --width 640 --height 288 --hfov-deg 60 --baseline-m 0.30 --camera-height-m 1.5 --noise-sigma 1 --lineup 15");
}

// A fixture for the tests that run commands on the lineup: a scratch folder, and the lineup rendered
// once per test binary (again if an earlier test's scratch folder, which held it, is gone).
class LineupCliTest : public ::testing::Test {
 protected:
  explicit LineupCliTest(const std::string& scratch_name) : scratch_(scratch_name) {}
  std::string path(const std::string& name) const { return scratch_.path(name); }
  // A 640x288 lineup at 15 m (hfov 60 deg, baseline 0.30 m, camera 1.5 m high, noise 1).
  const std::string& lineup() {
    static std::string folder;
    if (folder.empty() || !std::filesystem::exists(folder)) {
      folder = path("lineup");
      const Result result = render_lineup_15m(folder);
      EXPECT_EQ(result.exit_code, 0) << result.err;
    }
    return folder;
  }
  ScratchDirectory scratch_;
};

}  // namespace lpstereo::testing
