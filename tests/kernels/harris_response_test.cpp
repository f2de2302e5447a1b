// harris_response: bit-exact against the reference on every back end at odd sizes in padded
// buffers (both window sizes, both border modes, which must not matter), against an independent
// 64-bit recomputation at the extreme inputs (0/255 checkerboards, stripes, corners) with the
// no-overflow bounds of kernels/harris_response.cpp checked, the sign of R on corners, edges and
// flat areas, the closed-form op count and refused parameters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}};

TEST(HarrisResponse, MatchesReferenceAtOddSizeInPaddedBuffer) {
  for (int window : {3, 5}) {
    KernelCase test_case{"harris_response", {{"window_size", window}}, {}, 12};
    test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 21));
    expect_all_back_ends_match_reference(test_case, kTileShapes);
  }
  // Other k at a smaller odd size: the extreme k = 1 (256 / 2^8) and 1/16.
  for (const nlohmann::json& params : {nlohmann::json{{"window_size", 5}, {"k_numerator", 1}, {"k_shift", 4}},
                                       nlohmann::json{{"k_numerator", 256}, {"k_shift", 8}}}) {
    KernelCase test_case{"harris_response", params, {}, 12};
    test_case.inputs.push_back(random_plane(203, 97, {ElementType::u8, 0}, 224, 25));
    expect_all_back_ends_match_reference(test_case, {{203, 97}, {64, 16}, {7, 5}});
  }
}

TEST(HarrisResponse, TinyImages) {
  for (int window : {3, 5}) {
    for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {5, 5}, {7, 7}, {8, 3}, {65, 9}, {33, 2}}) {
      KernelCase test_case{"harris_response", {{"window_size", window}}, {}, 4};
      test_case.inputs.push_back(random_plane(width, height, {ElementType::u8, 0}, width + 5, 22));
      expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}, {3, 4}, {1, 1}});
    }
  }
}

Plane run_harris(const Plane& image, const nlohmann::json& params, BorderMode mode, KernelBackend backend, simd::Isa isa,
                 int tile_width = 64, int tile_height = 16) {
  const KernelDescriptor& kernel = testing::kernel_named("harris_response");
  const PreparedKernel prepared = kernel.prepare(params, {{image.width(), image.height()}});
  Plane output(image.width(), image.height(), {ElementType::s32, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), mode, 200, {image.view()}, {output.view()}, prepared.input_halos};
  run_vector_node(binding, tile_width, tile_height, backend, isa);
  return output;
}

template <class Check>
void on_every_back_end(const Check& check) {
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The header's steps in 64 bits, written from the formulas (not from the kernel), with the header's
// bounds checked on every pixel: 0 <= a, c <= A, -(A + 1) <= b <= A, t t < 2^31, R in s32.
struct WideHarris {
  Plane response;
  int64_t largest_trace_squared = 0;
  int64_t smallest_response = 0;
};

WideHarris wide_harris(const Plane& image, int window, int k_numerator, int k_shift) {
  const int half = window / 2;
  const int radius = half + 1;
  const int shift = window == 3 ? 9 : 11;
  const int64_t bound = (window == 3 ? 9 : 25) * int64_t{1020} * 1020 >> shift;  // A
  EXPECT_EQ(bound, window == 3 ? 18288 : 12700);
  WideHarris result{Plane(image.width(), image.height(), {ElementType::s32, 0})};
  auto pixel = [&](int x, int y) -> int64_t { return image.at<uint8_t>(x, y); };
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      int64_t response = 0;
      if (x >= radius && y >= radius && x < image.width() - radius && y < image.height() - radius) {
        int64_t xx = 0, yy = 0, xy = 0;
        for (int v = y - half; v <= y + half; ++v) {
          for (int u = x - half; u <= x + half; ++u) {
            const int64_t gx = pixel(u + 1, v - 1) + 2 * pixel(u + 1, v) + pixel(u + 1, v + 1) - pixel(u - 1, v - 1) -
                               2 * pixel(u - 1, v) - pixel(u - 1, v + 1);
            const int64_t gy = pixel(u - 1, v + 1) + 2 * pixel(u, v + 1) + pixel(u + 1, v + 1) - pixel(u - 1, v - 1) -
                               2 * pixel(u, v - 1) - pixel(u + 1, v - 1);
            xx += gx * gx;
            yy += gy * gy;
            xy += gx * gy;
          }
        }
        // floor division by 2^shift (the arithmetic shift of the kernel)
        auto floor_shift = [&](int64_t value) { return value >= 0 ? value / (int64_t{1} << shift) : -((-value + (int64_t{1} << shift) - 1) / (int64_t{1} << shift)); };
        const int64_t a = floor_shift(xx), c = floor_shift(yy), b = floor_shift(xy);
        EXPECT_GE(a, 0);
        EXPECT_LE(a, bound);
        EXPECT_LE(c, bound);
        EXPECT_GE(b, -(bound + 1));
        EXPECT_LE(b, bound);
        const int64_t trace = a + c;
        result.largest_trace_squared = std::max(result.largest_trace_squared, trace * trace);
        response = a * c - b * b - k_numerator * (trace * trace / (int64_t{1} << k_shift));
        EXPECT_LT(trace * trace, int64_t{1} << 31);
      }
      EXPECT_GE(response, std::numeric_limits<int32_t>::min());
      EXPECT_LE(response, std::numeric_limits<int32_t>::max());
      result.smallest_response = std::min(result.smallest_response, response);
      result.response.at<int32_t>(x, y) = static_cast<int32_t>(response);
    }
  }
  return result;
}

// 0/255 patterns: the largest gradients a u8 image has (|Ix| or |Iy| = 1020 on a step edge).
std::vector<Plane> extreme_images() {
  std::vector<Plane> images;
  auto make = [&](auto value) {
    Plane image(53, 41, {ElementType::u8, 0}, 64);
    for (int y = 0; y < 41; ++y) {
      for (int x = 0; x < 53; ++x) image.at<uint8_t>(x, y) = value(x, y) ? 255 : 0;
    }
    images.push_back(std::move(image));
  };
  for (int cell : {1, 2, 3, 5}) make([cell](int x, int y) { return (x / cell + y / cell) % 2 == 1; });
  make([](int x, int /*y*/) { return x % 4 < 2; });                  // vertical stripes, 2 px
  make([](int x, int y) { return x >= 26 && y >= 20; });             // one step corner
  make([](int x, int y) { return (x + y) % 3 == 0 || x % 5 == 0; });  // diagonal and vertical lines
  return images;
}

TEST(HarrisResponse, ExtremeInputsStayInsideTheProvenBoundsAndMatchSixtyFourBits) {
  for (int window : {3, 5}) {
    for (auto [k_numerator, k_shift] : std::vector<std::pair<int, int>>{{3, 6}, {256, 8}, {1, 0}}) {
      int64_t largest_trace_squared = 0;
      for (const Plane& image : extreme_images()) {
        const WideHarris wide = wide_harris(image, window, k_numerator, k_shift);
        largest_trace_squared = std::max(largest_trace_squared, wide.largest_trace_squared);
        const nlohmann::json params{{"window_size", window}, {"k_numerator", k_numerator}, {"k_shift", k_shift}};
        on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
          EXPECT_TRUE(testing::planes_equal(wide.response, run_harris(image, params, BorderMode::replicate, backend, isa)))
              << label << " window " << window << " k " << k_numerator << "/2^" << k_shift;
        });
      }
      // The stripes reach the largest trace a window can hold: a = A, c = 0 (t^2 = A^2).
      EXPECT_GE(largest_trace_squared, int64_t{window == 3 ? 18288 : 12700} * (window == 3 ? 18288 : 12700));
    }
  }
}

// R > 0 at a corner of a bright square, R < 0 on the middle of its edges, 0 on flat areas and in
// the border band; the same whatever the border mode.
TEST(HarrisResponse, SignOnCornersEdgesAndFlatAreasAndZeroBorderBand) {
  Plane image(61, 47, {ElementType::u8, 0}, 70);
  for (int y = 0; y < 47; ++y) {
    for (int x = 0; x < 61; ++x) image.at<uint8_t>(x, y) = (x >= 20 && x < 40 && y >= 15 && y < 35) ? 200 : 10;
  }
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    for (int window : {3, 5}) {
      const nlohmann::json params{{"window_size", window}};
      const Plane response = run_harris(image, params, BorderMode::replicate, backend, isa, 16, 8);
      const Plane constant = run_harris(image, params, BorderMode::constant, backend, isa, 16, 8);
      EXPECT_TRUE(testing::planes_equal(response, constant)) << label;
      EXPECT_GT(response.at<int32_t>(20, 15), 0) << label;  // corners (inner pixel)
      EXPECT_GT(response.at<int32_t>(39, 34), 0) << label;
      EXPECT_LT(response.at<int32_t>(30, 15), 0) << label;  // edge middles
      EXPECT_LT(response.at<int32_t>(20, 25), 0) << label;
      EXPECT_EQ(response.at<int32_t>(30, 25), 0) << label;  // flat inside and outside
      EXPECT_EQ(response.at<int32_t>(5, 5), 0) << label;
      const int radius = window / 2 + 1;
      for (int y = 0; y < 47; ++y) {
        for (int x = 0; x < 61; ++x) {
          if (x < radius || y < radius || x >= 61 - radius || y >= 47 - radius) {
            EXPECT_EQ(response.at<int32_t>(x, y), 0) << label << " border pixel " << x << "," << y;
          }
        }
      }
    }
  });
}

// A random image with a bright border band: had the kernel let the halo (border mode) into R, the
// constant border 200 against replicate would change pixels next to the band of zeros.
TEST(HarrisResponse, BorderModeNeverChangesTheResponse) {
  const Plane image = random_plane(97, 61, {ElementType::u8, 0}, 100, 23);
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    for (int window : {3, 5}) {
      const nlohmann::json params{{"window_size", window}};
      EXPECT_TRUE(testing::planes_equal(run_harris(image, params, BorderMode::replicate, backend, isa, 40, 16),
                                        run_harris(image, params, BorderMode::constant, backend, isa, 40, 16)))
          << label;
    }
  });
}

// The closed form of kernels/harris_response.cpp for the counting back end (L8 = 64, L32 = 16).
TEST(HarrisResponse, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64 && simd::Counting::kLanesU32 == 16, "the closed form assumes 512-bit vectors");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (int window : {3, 5}) {
    for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 64, 16}, {1, 1, 1, 1}, {65, 7, 65, 7},
                                                 {631, 479, 100, 37}, {200, 3, 7, 5}}) {
      KernelCase test_case{"harris_response", {{"window_size", window}}, {}, 0};
      test_case.inputs.push_back(random_plane(shape.width, shape.height, {ElementType::u8, 0}, 0, 24));
      const int64_t w = window, h = window / 2;
      simd::OpCounts expected;
      for (const TileRect& tile : make_tiles(shape.width, shape.height, shape.tile_width, shape.tile_height)) {
        const int64_t rows = tile.height, extended_rows = tile.height + 2 * h, warm_up_rows = 2 * h;
        const int64_t c1 = (tile.width + 2 * h + 63) / 64, c2 = (tile.width + 15) / 16;
        expected[simd::OpClass::load] += 1 + extended_rows * c1 * 8 + warm_up_rows * c2 * 3 * w + rows * c2 * (3 * w + 3 * (w - 1) + 1);
        expected[simd::OpClass::store] += c2 + extended_rows * c1 * 12 + warm_up_rows * c2 * 3 + rows * c2 * 4;
        expected[simd::OpClass::arith] += c2 + extended_rows * c1 * 20 + warm_up_rows * c2 * 3 * (w - 1) + rows * c2 * (6 * (w - 1) + 3);
        expected[simd::OpClass::shift] += extended_rows * c1 * 8 + rows * c2 * 4;
        expected[simd::OpClass::multiply] += extended_rows * c1 * 12 + rows * c2 * 4;
        expected[simd::OpClass::permute] += 3 + c2 + extended_rows * c1 * 24 + rows;
        expected[simd::OpClass::compare] += 2 * c2;
        expected[simd::OpClass::logic] += c2 + rows * c2 * 2;
      }
      EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
          << "window " << window << " " << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x"
          << shape.tile_height;
    }
  }
}

TEST(HarrisResponseMustFail, RefusesBadParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("harris_response");
  EXPECT_THROW(kernel.prepare({{"window", 3}}, {{10, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"k_shift", 9}}, {{10, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"k_shift", 4}, {"k_numerator", 17}}, {{10, 10}}), KernelError);
  try {
    kernel.prepare({{"window_size", 4}}, {{10, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "parameter 'window_size': expected 3 or 5, got 4");
  }
}

}  // namespace
}  // namespace lpstereo
