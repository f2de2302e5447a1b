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

#include <nlohmann/json.hpp>
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

// Random census32 words with few set bits, so that Hamming costs spread and ties happen (the
// matchers' tests: both the valid and the invalid branches, uniqueness and sub-pixel cases).
inline Plane sparse_census(int width, int height, ptrdiff_t stride_bytes, uint32_t seed) {
  Plane plane = random_plane(width, height, {ElementType::census32, 0}, stride_bytes, seed);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) plane.at<uint32_t>(x, y) &= 0x00F0F0F0u & (plane.at<uint32_t>(x, y) >> 3);
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

// Output planes for a prepared kernel, each row padded by `stride_padding` bytes, every byte `fill`.
inline std::vector<Plane> make_output_planes(const KernelDescriptor& kernel, const PreparedKernel& prepared,
                                             int stride_padding, uint8_t fill) {
  std::vector<Plane> outputs;
  size_t index = 0;
  for (const PortSpec& port : kernel.ports) {
    if (port.direction != PortDirection::output) continue;
    const PlaneShape& shape = prepared.output_shapes.at(index++);
    const ptrdiff_t row_bytes = static_cast<ptrdiff_t>(shape.width) * element_bytes(port.format.type);
    outputs.emplace_back(shape.width, shape.height, port.format, row_bytes + stride_padding);
    for (int y = 0; y < shape.height; ++y) std::memset(outputs.back().row<uint8_t>(y), fill, outputs.back().stride_bytes());
  }
  return outputs;
}

inline std::vector<PlaneView> plane_views(const std::vector<Plane>& planes) {
  std::vector<PlaneView> result;
  for (const Plane& plane : planes) result.push_back(plane.view());
  return result;
}

inline PreparedKernel prepare_case(const KernelDescriptor& kernel, const KernelCase& test_case) {
  std::vector<PlaneShape> input_shapes;
  for (const Plane& input : test_case.inputs) input_shapes.push_back({input.width(), input.height()});
  return kernel.prepare(test_case.params, input_shapes);
}

// Runs the reference and every back end, with each tile shape, and compares. Returns the output of
// the reference for further checks.
inline std::vector<Plane> expect_all_back_ends_match_reference(const KernelCase& test_case,
                                                               const std::vector<std::pair<int, int>>& tile_shapes) {
  const KernelDescriptor& kernel = kernel_named(test_case.kernel);
  const std::vector<PlaneView> input_views = plane_views(test_case.inputs);
  const PreparedKernel prepared = prepare_case(kernel, test_case);
  auto make_outputs = [&](uint8_t fill) {
    return make_output_planes(kernel, prepared, test_case.output_stride_padding, fill);
  };

  std::vector<BorderMode> modes = kernel.border_modes.empty() ? std::vector<BorderMode>{BorderMode::replicate}
                                                               : kernel.border_modes;
  std::vector<Plane> last_reference;
  for (BorderMode mode : modes) {
    const uint32_t border_value = 77;
    std::vector<Plane> expected = make_outputs(0xA5);
    kernel.reference(input_views, plane_views(expected), prepared.params.get(), mode, border_value);
    for (const auto& [tile_width, tile_height] : tile_shapes) {
      auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
        std::vector<Plane> actual = make_outputs(0x5A);
        VectorNodeBinding binding{&kernel, prepared.params.get(), mode, border_value, input_views, plane_views(actual),
                                  prepared.input_halos, prepared.input_scales};
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

// Tiles, tile rows and vector chunks of a width x height plane cut into tiles of at most
// tile_width x tile_height (as make_tiles does), each tile row walked in chunks of chunk_pixels.
// The closed-form op counts of the kernels are in these terms.
struct TileWork {
  int64_t tiles = 0;
  int64_t rows = 0;    // tile rows, summed over tiles
  int64_t chunks = 0;  // chunks, summed over tile rows
};

inline TileWork tile_work(int width, int height, int tile_width, int tile_height, int chunk_pixels) {
  TileWork work;
  for (const TileRect& tile : make_tiles(width, height, tile_width, tile_height)) {
    ++work.tiles;
    work.rows += tile.height;
    work.chunks += static_cast<int64_t>(tile.height) * ((tile.width + chunk_pixels - 1) / chunk_pixels);
  }
  return work;
}

// The ops the counting back end tallies running the case's kernel over its inputs in tiles of
// tile_width x tile_height with the given border mode.
inline simd::OpCounts count_ops(const KernelCase& test_case, int tile_width, int tile_height,
                                BorderMode mode = BorderMode::replicate) {
  const KernelDescriptor& kernel = kernel_named(test_case.kernel);
  const PreparedKernel prepared = prepare_case(kernel, test_case);
  std::vector<Plane> outputs = make_output_planes(kernel, prepared, test_case.output_stride_padding, 0);
  VectorNodeBinding binding{&kernel, prepared.params.get(), mode, 0, plane_views(test_case.inputs), plane_views(outputs),
                            prepared.input_halos, prepared.input_scales};
  simd::OpCounts counts;
  run_vector_node(binding, tile_width, tile_height, KernelBackend::counting, simd::Isa::scalar, &counts);
  return counts;
}

// Equal op counts, class by class; the failure names every class that differs.
inline ::testing::AssertionResult op_counts_equal(const simd::OpCounts& expected, const simd::OpCounts& actual) {
  std::string differences;
  for (int op = 0; op < simd::kOpClassCount; ++op) {
    if (expected.by_class[op] != actual.by_class[op]) {
      differences += " " + std::string(simd::kOpClassNames[op]) + ": expected " + std::to_string(expected.by_class[op]) +
                     ", counted " + std::to_string(actual.by_class[op]) + ";";
    }
  }
  if (differences.empty()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "op counts differ:" << differences;
}

}  // namespace lpstereo::testing
