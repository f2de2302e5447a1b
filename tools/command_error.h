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

}  // namespace lpstereo::tools
