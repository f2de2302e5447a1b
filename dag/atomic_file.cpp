#include "dag/atomic_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>

namespace lpstereo {

namespace {
std::string temporary_name(const std::string& path, const std::string& suffix) {
  const std::filesystem::path target(path);
  return (target.parent_path() / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()) + suffix)).string();
}
}  // namespace

void write_file_atomically_with(const std::string& path, const std::string& temporary_suffix,
                                const std::function<bool(const std::string& temporary_path)>& write) {
  const std::string temporary = temporary_name(path, temporary_suffix);
  bool written = false;
  try {
    written = write(temporary);
  } catch (...) {
    std::remove(temporary.c_str());
    throw;
  }
  if (!written) {
    std::remove(temporary.c_str());
    throw FileWriteError(path + ": cannot write (directory missing or not writable?)");
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(temporary.c_str());
    throw FileWriteError(path + ": cannot rename the temporary file into place: " + reason);
  }
}

void write_file_atomically(const std::string& path, const std::string& content) {
  write_file_atomically_with(path, "", [&](const std::string& temporary) {
    std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
    if (!file) return false;
    file.write(content.data(), static_cast<std::streamsize>(content.size()));
    file.close();
    return static_cast<bool>(file);
  });
}

}  // namespace lpstereo
