#include "dag/constant_generators.h"

namespace lpstereo {

std::vector<BuiltinConstantGenerator> builtin_constant_generators() {
  std::vector<BuiltinConstantGenerator> generators;
  // identity_rectification: an all-zero remap_q4 map (the views are already rectified).
  generators.push_back({"identity_rectification", {ElementType::remap_q4, 0},
                        [](const nlohmann::json& params, int width, int height) {
                          check_param_names(params, {});
                          return Plane(width, height, {ElementType::remap_q4, 0});
                        }});
  return generators;
}

}  // namespace lpstereo
