// Parameter validation shared by the voxel map, its clustering and the tracking (issue 10): one
// std::invalid_argument message shape, "<name>: expected <expected>, got <value>".
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace lpstereo::arm::obstacles3d {

inline void require_parameter(bool ok, const std::string& name, const std::string& expected, double value) {
  if (!ok) {
    std::ostringstream text;
    text << name << ": expected " << expected << ", got " << value;
    throw std::invalid_argument(text.str());
  }
}

}  // namespace lpstereo::arm::obstacles3d
