// The numeric value of a bench program's command-line flag: argv[i] is the flag, argv[i + 1] its
// value. A missing value or one that is not wholly a number ("abc", "3x", "") prints one line naming
// the program, the flag and the text, and exits with 2: std::atof would have read it as 0 and run
// with that.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace lpstereo::bench {

// Advances i past the value.
inline double number_argument(int& i, int argc, char** argv) {
  const char* slash = std::strrchr(argv[0], '/');
  const char* program = slash != nullptr ? slash + 1 : argv[0];
  if (i + 1 >= argc) {
    std::fprintf(stderr, "%s: %s: expected a value\n", program, argv[i]);
    std::exit(2);
  }
  char* end = nullptr;
  const double value = std::strtod(argv[++i], &end);
  if (end == argv[i] || *end != 0) {
    std::fprintf(stderr, "%s: %s: expected a number, got '%s'\n", program, argv[i - 1], argv[i]);
    std::exit(2);
  }
  return value;
}

}  // namespace lpstereo::bench
