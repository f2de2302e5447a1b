#include "dag/plane.h"

#include "dag/zeroed_block.h"

#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <utility>

namespace lpstereo {

Plane::Plane(int width, int height, BufferFormat format, ptrdiff_t stride_bytes) : format_(format) {
  const int element_size = element_bytes(format.type);
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("plane size: expected width and height > 0, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  const ptrdiff_t row_bytes = static_cast<ptrdiff_t>(width) * element_size;
  if (stride_bytes == 0) stride_bytes = (row_bytes + 63) / 64 * 64;
  if (stride_bytes < row_bytes) {
    throw std::invalid_argument("plane stride: expected >= " + std::to_string(row_bytes) + " bytes, got " +
                                std::to_string(stride_bytes));
  }
  size_bytes_ = static_cast<size_t>(stride_bytes) * static_cast<size_t>(height);
  ZeroedBlock block(size_bytes_);
  uint8_t* memory = block.get();
  storage_ = std::move(block).share();
  view_ = PlaneView{memory, stride_bytes, width, height};
}

Plane Plane::clone() const {
  if (empty()) return Plane();
  Plane copy(width(), height(), format_, stride_bytes());
  std::memcpy(copy.view_.origin, view_.origin, size_bytes_);
  return copy;
}

}  // namespace lpstereo
