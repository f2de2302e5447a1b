// The constant generators graph files can name in "constants": frame-constant buffers made at
// verify phase 5 (node init) from parameters, such as rectification maps.
#pragma once

#include <string>
#include <vector>

#include "dag/graph.h"

namespace lpstereo {

struct BuiltinConstantGenerator {
  std::string name;
  BufferFormat format;
  ConstantGenerator generate;
};

std::vector<BuiltinConstantGenerator> builtin_constant_generators();

}  // namespace lpstereo
