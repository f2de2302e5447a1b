// Shared checks for vector kernels: every back end (each native ISA level available here, and the
// counting back end), run through the tile executor at odd sizes in padded buffers with several tile
// shapes, must give the scalar reference's bits for every border mode the kernel supports.
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "dag/plane.h"
#include "dag/tile_executor.h"
#include "kernels/kernel.h"
#include "kernels/simd/isa.h"

namespace lpstereo::testing {

inline const KernelDescriptor& kernel_named(const std::string& name) {
  const KernelDescriptor* kernel = KernelRegistry::instance().find(name);
  if (kernel == nullptr) throw std::runtime_error("kernel '" + name + "' is not registered");
  return *kernel;
}

// A plane of random bytes (every byte of every element random), in a buffer wider than the image.
inline Plane random_plane(int width, int height, BufferFormat format, ptrdiff_t stride_bytes, uint32_t seed) {
  Plane plane(width, height, format, stride_bytes);
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int y = 0; y < height; ++y) {
    uint8_t* row = plane.row<uint8_t>(y);
    for (ptrdiff_t i = 0; i < plane.stride_bytes(); ++i) row[i] = static_cast<uint8_t>(byte(generator));
  }
  return plane;
}

// Index of the first differing element in the image area, or -1; reports the position.
inline ::testing::AssertionResult planes_equal(const Plane& expected, const Plane& actual) {
  const size_t row_bytes = static_cast<size_t>(expected.width()) * expected.element_size();
  if (expected.width() != actual.width() || expected.height() != actual.height()) {
    return ::testing::AssertionFailure() << "size " << actual.width() << "x" << actual.height() << ", expected "
                                         << expected.width() << "x" << expected.height();
  }
  for (int y = 0; y < expected.height(); ++y) {
    const uint8_t* a = expected.row<uint8_t>(y);
    const uint8_t* b = actual.row<uint8_t>(y);
    if (std::memcmp(a, b, row_bytes) != 0) {
      for (size_t i = 0; i < row_bytes; ++i) {
        if (a[i] != b[i]) {
          return ::testing::AssertionFailure()
                 << "first difference at x=" << i / expected.element_size() << " y=" << y << " (byte "
                 << i % expected.element_size() << "): expected " << int(a[i]) << ", got " << int(b[i]);
        }
      }
    }
  }
  return ::testing::AssertionSuccess();
}

// The bytes of the padding (past the row, up to the stride) must be untouched by a kernel.
inline ::testing::AssertionResult padding_untouched(const Plane& plane, uint8_t fill) {
  const size_t row_bytes = static_cast<size_t>(plane.width()) * plane.element_size();
  for (int y = 0; y < plane.height(); ++y) {
    const uint8_t* row = plane.row<uint8_t>(y);
    for (ptrdiff_t i = static_cast<ptrdiff_t>(row_bytes); i < plane.stride_bytes(); ++i) {
      if (row[i] != fill) return ::testing::AssertionFailure() << "padding byte " << i << " of row " << y << " written";
    }
  }
  return ::testing::AssertionSuccess();
}

struct KernelCase {
  std::string kernel;
  nlohmann::json params = nlohmann::json::object();
  std::vector<Plane> inputs;         // full planes
  int output_stride_padding = 0;     // extra bytes per output row beyond the row size
};

// Runs the reference and every back end, with each tile shape, and compares. Returns the output of
// the reference for further checks.
inline std::vector<Plane> expect_all_back_ends_match_reference(const KernelCase& test_case,
                                                               const std::vector<std::pair<int, int>>& tile_shapes) {
  const KernelDescriptor& kernel = kernel_named(test_case.kernel);
  std::vector<PlaneShape> input_shapes;
  std::vector<PlaneView> input_views;
  for (const Plane& input : test_case.inputs) {
    input_shapes.push_back({input.width(), input.height()});
    input_views.push_back(input.view());
  }
  const PreparedKernel prepared = kernel.prepare(test_case.params, input_shapes);
  std::vector<BufferFormat> output_formats;
  for (const PortSpec& port : kernel.ports) {
    if (port.direction == PortDirection::output) output_formats.push_back(port.format);
  }
  auto make_outputs = [&](uint8_t fill) {
    std::vector<Plane> outputs;
    for (size_t i = 0; i < output_formats.size(); ++i) {
      const PlaneShape& shape = prepared.output_shapes.at(i);
      const ptrdiff_t row_bytes = static_cast<ptrdiff_t>(shape.width) * element_bytes(output_formats[i].type);
      outputs.emplace_back(shape.width, shape.height, output_formats[i], row_bytes + test_case.output_stride_padding);
      for (int y = 0; y < shape.height; ++y) std::memset(outputs.back().row<uint8_t>(y), fill, outputs.back().stride_bytes());
    }
    return outputs;
  };
  auto views = [](const std::vector<Plane>& planes) {
    std::vector<PlaneView> result;
    for (const Plane& plane : planes) result.push_back(plane.view());
    return result;
  };

  std::vector<BorderMode> modes = kernel.border_modes.empty() ? std::vector<BorderMode>{BorderMode::replicate}
                                                               : kernel.border_modes;
  std::vector<Plane> last_reference;
  for (BorderMode mode : modes) {
    const uint32_t border_value = 77;
    std::vector<Plane> expected = make_outputs(0xA5);
    kernel.reference(input_views, views(expected), prepared.params.get(), mode, border_value);
    for (const auto& [tile_width, tile_height] : tile_shapes) {
      auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
        std::vector<Plane> actual = make_outputs(0x5A);
        VectorNodeBinding binding{&kernel, prepared.params.get(), mode, border_value, input_views, views(actual),
                                  prepared.input_halos};
        run_vector_node(binding, tile_width, tile_height, backend, isa);
        for (size_t i = 0; i < actual.size(); ++i) {
          EXPECT_TRUE(planes_equal(expected[i], actual[i]))
              << test_case.kernel << " " << label << " output " << i << " border " << border_mode_name(mode) << " tile "
              << tile_width << "x" << tile_height;
          EXPECT_TRUE(padding_untouched(actual[i], 0x5A)) << test_case.kernel << " " << label;
        }
      };
      for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
      check(KernelBackend::counting, simd::Isa::scalar, "counting");
    }
    last_reference = std::move(expected);
  }
  return last_reference;
}

}  // namespace lpstereo::testing
