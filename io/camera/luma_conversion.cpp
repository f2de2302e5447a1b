// convert_to_luma (io/camera/pixel_format.h): the camera's buffer wrapped in a PlaneView in place
// (origin = data, stride = bytes_per_line) and converted by the vector kernel of its format, run
// through the tile executor on the native back end at the active ISA level (LPSTEREO_ISA caps it),
// as a graph node would run:
//   GREY, NV12 (its Y plane: the first height rows) -> copy_u8 (kernels/copy_u8.cpp)
//   YUYV, UYVY -> yuv422_to_luma with order yuyv / uyvy, the rows as u16 byte pairs (kernels/yuv422_to_luma.cpp)
//   RGB888, BGR888 -> rgb888_to_luma with order rgb / bgr, the rows as 3 W bytes (kernels/rgb888_to_luma.cpp)
// The whole image is one tile: a window input without halo inside the image is read in place (no
// staging copy), and every kernel reads only the bytes of the image's own rows, so a buffer that ends
// with the last pixel's last byte (no padding after the last row, as V4L2 buffers may) is never read
// past (tests/io/luma_conversion_test.cpp puts such buffers against a guard page).
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "dag/tile_executor.h"
#include "io/camera/pixel_format.h"
#include "kernels/kernel.h"
#include "kernels/simd/isa.h"

namespace lpstereo::io {
namespace {

struct LumaKernelChoice {
  const char* kernel;
  nlohmann::json params;
  int elements_per_pixel;  // elements of the input view per pixel: u8 bytes, or u16 byte pairs for 4:2:2
};

LumaKernelChoice luma_kernel_for(CameraPixelFormat format) {
  switch (format) {
    case CameraPixelFormat::grey:
    case CameraPixelFormat::nv12: return {"copy_u8", nlohmann::json::object(), 1};
    case CameraPixelFormat::yuyv: return {"yuv422_to_luma", {{"order", "yuyv"}}, 1};
    case CameraPixelFormat::uyvy: return {"yuv422_to_luma", {{"order", "uyvy"}}, 1};
    case CameraPixelFormat::rgb888: return {"rgb888_to_luma", {{"order", "rgb"}}, 3};
    case CameraPixelFormat::bgr888: return {"rgb888_to_luma", {{"order", "bgr"}}, 3};
  }
  throw std::invalid_argument("convert_to_luma: unknown pixel format " + std::to_string(static_cast<int>(format)));
}

}  // namespace

void convert_to_luma(CameraPixelFormat format, const uint8_t* data, size_t bytes_per_line, int width, int height,
                     Plane& luma) {
  const std::string name(pixel_format_name(format));
  if (width <= 0 || height <= 0 || width > std::numeric_limits<int32_t>::max() / 3) {
    throw std::invalid_argument("convert_to_luma: " + name + " expected a size of at least 1x1 (width under 2^31 / 3), got " +
                                std::to_string(width) + "x" + std::to_string(height));
  }
  if (data == nullptr) throw std::invalid_argument("convert_to_luma: " + name + " expected frame data, got a null pointer");
  if (luma.width() != width || luma.height() != height || luma.format().type != ElementType::u8) {
    throw std::invalid_argument("convert_to_luma: expected a u8 luma plane of " + std::to_string(width) + "x" +
                                std::to_string(height) + ", got " + std::string(element_type_name(luma.format().type)) + " " +
                                std::to_string(luma.width()) + "x" + std::to_string(luma.height()));
  }
  const size_t row_bytes = static_cast<size_t>(width) * static_cast<size_t>(pixel_format_bytes_per_pixel(format));
  if (bytes_per_line < row_bytes || bytes_per_line > static_cast<size_t>(std::numeric_limits<ptrdiff_t>::max())) {
    throw std::invalid_argument("convert_to_luma: " + name + " bytes per line " + std::to_string(bytes_per_line) +
                                " is less than a row of " + std::to_string(width) + " px (" + std::to_string(row_bytes) +
                                " bytes) or too large");
  }

  const LumaKernelChoice choice = luma_kernel_for(format);
  const KernelDescriptor* kernel = KernelRegistry::instance().find(choice.kernel);
  if (kernel == nullptr) throw std::logic_error(std::string("convert_to_luma: kernel '") + choice.kernel + "' is not linked in");
  // The kernels only read their inputs; PlaneView has no const variant.
  const PlaneView input{const_cast<uint8_t*>(data), static_cast<ptrdiff_t>(bytes_per_line), width * choice.elements_per_pixel, height};
  const PreparedKernel prepared = kernel->prepare(choice.params, {{input.width, input.height}});
  VectorNodeBinding binding{kernel, prepared.params.get(), BorderMode::replicate, 0, {input}, {luma.view()},
                            prepared.input_halos, prepared.input_scales};
  run_vector_node(binding, width, height, KernelBackend::native, simd::active_isa());
}

}  // namespace lpstereo::io
