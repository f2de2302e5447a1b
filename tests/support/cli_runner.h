// Runs the lpstereo binary (LPSTEREO_BINARY, set by CMake) as a user would, capturing stdout,
// stderr and the exit code. Shared by the command-line tests.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

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
  return result;
}

// The command-line tests' common scene: `lpstereo synth` of the range-test lineup at 15 m, 640x288,
// hfov 60 deg, baseline 0.30 m, camera 1.5 m high, noise 1, written to `folder`.
inline Result render_lineup_15m(const std::string& folder) {
  return run("synth -o " + folder +
             " --width 640 --height 288 --hfov-deg 60 --baseline-m 0.30 --camera-height-m 1.5 --noise-sigma 1 --lineup 15");
}

}  // namespace lpstereo::testing
