// Writes a file so that a reader never sees it half-written: the content goes to a temporary name
// in the same directory, then is renamed over the destination. On failure nothing is left behind.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>

namespace lpstereo {

class FileWriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

void write_file_atomically(const std::string& path, const std::string& content);

// For writers that need a path (image codecs): `write` writes to the given temporary path and
// returns false on failure; the file is then renamed to `path`.
void write_file_atomically_with(const std::string& path, const std::string& temporary_suffix,
                                const std::function<bool(const std::string& temporary_path)>& write);

}  // namespace lpstereo
