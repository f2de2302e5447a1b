#include "kernels/census_cost.h"

#include <algorithm>

namespace lpstereo::kernels {

int census_cost_reference(const PlaneView& left, const PlaneView& right, int word_bytes, int x, int y, int d) {
  const int right_x = std::clamp(x - d, 0, right.width - 1);  // replicate border
  if (word_bytes == 4) {
    return __builtin_popcount(plane_row<const uint32_t>(left, y)[x] ^ plane_row<const uint32_t>(right, y)[right_x]);
  }
  return __builtin_popcountll(plane_row<const uint64_t>(left, y)[x] ^ plane_row<const uint64_t>(right, y)[right_x]);
}

}  // namespace lpstereo::kernels
