// An owning 2-D buffer of elements with a padded row stride, for frames and graph buffers on the
// host. Rows start at 64-byte aligned addresses (the widest vector); the stride may be set larger
// than the row to test kernels in padded buffers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>

#include "dag/format.h"
#include "kernels/kernel.h"

namespace lpstereo {

class Plane {
 public:
  Plane() = default;
  // stride_bytes 0 = the row size rounded up to 64 bytes. Contents are zero.
  Plane(int width, int height, BufferFormat format, ptrdiff_t stride_bytes = 0);

  int width() const { return view_.width; }
  int height() const { return view_.height; }
  ptrdiff_t stride_bytes() const { return view_.stride_bytes; }
  const BufferFormat& format() const { return format_; }
  int element_size() const { return element_bytes(format_.type); }
  bool empty() const { return view_.origin == nullptr; }
  size_t size_bytes() const { return size_bytes_; }

  PlaneView view() const { return view_; }
  // Copies share the buffer (cheap handles); clone() makes an independent copy of the pixels.
  Plane clone() const;
  template <class Element>
  Element* row(int y) const { return plane_row<Element>(view_, y); }
  template <class Element>
  Element& at(int x, int y) const { return row<Element>(y)[x]; }

 private:
  std::shared_ptr<uint8_t> storage_;  // dag/zeroed_block.h: huge-page advised from 2 MiB on
  PlaneView view_{};
  BufferFormat format_{};
  size_t size_bytes_ = 0;
};

}  // namespace lpstereo
