// A required string parameter that names one of a few choices (the byte order of a camera format:
// "yuyv" / "uyvy", "rgb" / "bgr"), for prepare() in the baseline unit of a kernel file (it needs
// the full JSON header, which per-ISA units do not include). The numeric helpers are in
// kernels/kernel.h.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "kernels/kernel.h"

namespace lpstereo::kernels {

// The value of `name` in `params`, which must be one of `choices` (exact spelling); throws
// KernelError naming the parameter, the choices and what was given (or "nothing").
inline std::string param_choice(const nlohmann::json& params, const char* name, const std::vector<std::string>& choices) {
  const bool given = params.is_object() && params.contains(name);
  const std::string value = given && params.at(name).is_string() ? params.at(name).get<std::string>() : "";
  for (const std::string& choice : choices) {
    if (value == choice) return value;
  }
  std::string expected;
  for (const std::string& choice : choices) expected += (expected.empty() ? "\"" : " or \"") + choice + "\"";
  throw KernelError(std::string("parameter '") + name + "': expected " + expected + ", got " +
                    (given ? params.at(name).dump() : std::string("nothing")));
}

}  // namespace lpstereo::kernels
