// gaussian5x5: bit-exact against the reference on every back end and border mode at odd sizes in
// padded buffers, the extremes of its u16 bound (all 255 stays 255; 0/255 checkerboards against a
// separable recomputation), a flat image unchanged, the closed-form op count of
// kernels/gaussian5x5.cpp, and refused parameters.
#include <gtest/gtest.h>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

TEST(Gaussian5x5, MatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"gaussian5x5", {}, {}, 9};
  test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 81));
  expect_all_back_ends_match_reference(test_case, {{631, 479}, {64, 16}, {100, 37}, {7, 5}, {1, 1}});
}

TEST(Gaussian5x5, TinyImages) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {5, 5}, {65, 2}, {129, 1}}) {
    KernelCase test_case{"gaussian5x5", {}, {}, 7};
    test_case.inputs.push_back(random_plane(width, height, {ElementType::u8, 0}, width + 3, 82));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
}

Plane run_gaussian(const Plane& input, BorderMode mode, KernelBackend backend, simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("gaussian5x5");
  Plane output(input.width(), input.height(), {ElementType::u8, 0});
  VectorNodeBinding binding{&kernel, nullptr, mode, 255, {input.view()}, {output.view()}};
  run_vector_node(binding, 48, 16, backend, isa);
  return output;
}

// All 255 with a constant border of 255: the largest sum, 65,280 + 128, must give 255 everywhere
// (a u16 wrap would give 0). Checkerboards of cell 1 and 2: interior pixels against the separable
// sum (sum_dx w(dx) sum_dy w(dy) I) recomputed here, with its rounding (s + 128) / 256.
TEST(Gaussian5x5, ExtremeInputsAreExact) {
  Plane white(77, 23, {ElementType::u8, 0}, 80);
  for (int y = 0; y < 23; ++y) {
    for (int x = 0; x < 77; ++x) white.at<uint8_t>(x, y) = 255;
  }
  const int weights[5] = {1, 4, 6, 4, 1};
  for (simd::Isa isa : simd::available_isas()) {
    for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
      const Plane smoothed = run_gaussian(white, BorderMode::constant, backend, isa);
      for (int y = 0; y < 23; ++y) {
        for (int x = 0; x < 77; ++x) ASSERT_EQ(smoothed.at<uint8_t>(x, y), 255) << x << "," << y;
      }
      for (int cell : {1, 2}) {
        Plane board(77, 23, {ElementType::u8, 0}, 80);
        for (int y = 0; y < 23; ++y) {
          for (int x = 0; x < 77; ++x) board.at<uint8_t>(x, y) = ((x / cell + y / cell) % 2) ? 255 : 0;
        }
        const Plane out = run_gaussian(board, BorderMode::replicate, backend, isa);
        for (int y = 2; y < 21; ++y) {
          for (int x = 2; x < 75; ++x) {
            int sum = 0;
            for (int dx = -2; dx <= 2; ++dx) {
              int column = 0;
              for (int dy = -2; dy <= 2; ++dy) column += weights[dy + 2] * board.at<uint8_t>(x + dx, y + dy);
              sum += weights[dx + 2] * column;
            }
            ASSERT_EQ(out.at<uint8_t>(x, y), (sum + 128) / 256) << "cell " << cell << " at " << x << "," << y;
          }
        }
      }
    }
  }
}

// The closed form of kernels/gaussian5x5.cpp for the counting back end (L8 = 64).
TEST(Gaussian5x5, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64, "the closed form assumes 64 u8 lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 64, 16}, {1, 1, 1, 1}, {65, 7, 65, 7},
                                               {631, 479, 100, 37}, {200, 3, 7, 5}, {61, 4, 60, 4}}) {
    KernelCase test_case{"gaussian5x5", {}, {}, 0};
    test_case.inputs.push_back(random_plane(shape.width, shape.height, {ElementType::u8, 0}, 0, 83));
    simd::OpCounts expected;
    for (const TileRect& tile : make_tiles(shape.width, shape.height, shape.tile_width, shape.tile_height)) {
      const int64_t rows = tile.height, cv = (tile.width + 4 + 63) / 64, ch = (tile.width + 63) / 64;
      expected[simd::OpClass::load] += rows * (5 * cv + 10 * ch);
      expected[simd::OpClass::permute] += 1 + rows * (10 * cv + ch);
      expected[simd::OpClass::arith] += rows * (10 * cv + 12 * ch);
      expected[simd::OpClass::shift] += rows * (6 * cv + 8 * ch);
      expected[simd::OpClass::store] += rows * (2 * cv + ch);
    }
    for (BorderMode mode : {BorderMode::replicate, BorderMode::constant}) {
      EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height, mode)))
          << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
    }
  }
}

TEST(Gaussian5x5MustFail, RefusesParameters) {
  EXPECT_THROW(testing::kernel_named("gaussian5x5").prepare({{"sigma", 2}}, {{10, 10}}), KernelError);
}

}  // namespace
}  // namespace lpstereo
