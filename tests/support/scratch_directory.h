// A fresh, empty folder for one test, removed afterwards:
// <temp>/<prefix>_<pid>_<test name>, where a value-parameterised test's "Name/3" becomes "Name_3" (a
// '/' would make the folder a child of one that is never removed).
#pragma once

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <string>

namespace lpstereo::testing {

class ScratchDirectory {
 public:
  explicit ScratchDirectory(const std::string& prefix)
      : root_(std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(::getpid()) + "_" + current_test_name())) {
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  ~ScratchDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(root_, ignored);
  }
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  const std::filesystem::path& root() const { return root_; }
  std::string path(const std::string& name) const { return (root_ / name).string(); }

 private:
  static std::string current_test_name() {
    std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    for (char& character : name) {
      if (character == '/') character = '_';
    }
    return name;
  }
  std::filesystem::path root_;
};

}  // namespace lpstereo::testing
