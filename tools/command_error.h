// What the lpstereo sub-commands share: exit codes and the error that ends a command with one line.
#pragma once

#include <stdexcept>
#include <string>

namespace lpstereo::tools {

constexpr int kExitInput = 1;       // bad input: a file, a graph, a value that does not fit the data
constexpr int kExitUsage = 2;       // bad usage: flags and their values
constexpr int kExitOverBudget = 3;  // over budget with --enforce

// An error that ends the command with one line on stderr and an exit code.
struct CommandError : std::runtime_error {
  CommandError(int code, const std::string& message) : std::runtime_error(message), exit_code(code) {}
  int exit_code;
};

// The search range [min_disparity, min_disparity + num_disparities) checked against an image
// `width` px wide, as --min-disp / --num-disp: a non-positive count is bad usage, a range the image
// cannot hold is bad input. One line naming the flag, the expected and the actual value.
inline void check_disparity_range(int min_disparity, int num_disparities, int width) {
  const std::string w = std::to_string(width);
  if (num_disparities <= 0) {
    throw CommandError(kExitUsage, "--num-disp: expected a positive number, got " + std::to_string(num_disparities));
  }
  if (num_disparities > width) {
    throw CommandError(kExitInput, "--num-disp: expected at most " + w + " (the image width), got " + std::to_string(num_disparities));
  }
  if (min_disparity <= -width) {
    throw CommandError(kExitInput, "--min-disp: expected more than -" + w + " (minus the image width), got " +
                                       std::to_string(min_disparity));
  }
  if (min_disparity + num_disparities > width) {
    throw CommandError(kExitInput, "--min-disp + --num-disp: expected at most " + w + " (the image width), got " +
                                       std::to_string(min_disparity) + " + " + std::to_string(num_disparities) + " = " +
                                       std::to_string(min_disparity + num_disparities));
  }
}

}  // namespace lpstereo::tools
