// Reads a JSON file a command wrote (the command-line tests).
#pragma once

#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace lpstereo::testing {

inline nlohmann::json read_json_file(const std::string& file) {
  std::ifstream stream(file);
  return nlohmann::json::parse(stream);
}

}  // namespace lpstereo::testing
