// median3x3: bit-exact against the sorting reference on every back end and border mode, golden
// values, and the closed-form op count of kernels/median3x3.cpp.
#include <gtest/gtest.h>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}, {1, 1}};

TEST(Median3x3, MatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"median3x3", {}, {}, 9};
  test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 11));
  expect_all_back_ends_match_reference(test_case, kTileShapes);
}

// Few distinct values make ties common, which is where a wrong network shows.
TEST(Median3x3, MatchesReferenceWithManyTies) {
  KernelCase test_case{"median3x3", {}, {}, 5};
  Plane input = random_plane(203, 97, {ElementType::u8, 0}, 224, 12);
  for (int y = 0; y < input.height(); ++y) {
    for (int x = 0; x < input.width(); ++x) input.at<uint8_t>(x, y) = static_cast<uint8_t>(input.at<uint8_t>(x, y) % 3 * 100);
  }
  test_case.inputs.push_back(std::move(input));
  expect_all_back_ends_match_reference(test_case, {{203, 97}, {16, 8}, {3, 2}});
}

TEST(Median3x3, TinyImages) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {65, 2}, {129, 1}}) {
    KernelCase test_case{"median3x3", {}, {}, 7};
    test_case.inputs.push_back(random_plane(width, height, {ElementType::u8, 0}, width + 3, 13));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
}

Plane run_median(const Plane& input, BorderMode mode, uint32_t border_value, KernelBackend backend, simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("median3x3");
  Plane output(input.width(), input.height(), {ElementType::u8, 0});
  VectorNodeBinding binding{&kernel, nullptr, mode, border_value, {input.view()}, {output.view()}};
  run_vector_node(binding, input.width(), input.height(), backend, isa);
  return output;
}

// Golden values: the window {9, 1, 8, 2, 7, 3, 6, 4, 5} has median 5; an impulse of 255 in a flat
// field of 10 disappears; at a corner of a 3x3 image of 1..9 the replicate border gives the window
// {1,1,2, 1,1,2, 4,4,5} (median 2) and a constant border of 200 gives {200 x5, 1, 2, 4, 5} (median 200).
TEST(Median3x3, GoldenValues) {
  Plane window(3, 3, {ElementType::u8, 0});
  const uint8_t values[9] = {9, 1, 8, 2, 7, 3, 6, 4, 5};
  for (int i = 0; i < 9; ++i) window.at<uint8_t>(i % 3, i / 3) = values[i];
  Plane ramp(3, 3, {ElementType::u8, 0});
  for (int i = 0; i < 9; ++i) ramp.at<uint8_t>(i % 3, i / 3) = static_cast<uint8_t>(i + 1);
  Plane impulse(70, 3, {ElementType::u8, 0});
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 70; ++x) impulse.at<uint8_t>(x, y) = 10;
  }
  impulse.at<uint8_t>(66, 1) = 255;

  auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    EXPECT_EQ(run_median(window, BorderMode::replicate, 0, backend, isa).at<uint8_t>(1, 1), 5) << label;
    EXPECT_EQ(run_median(ramp, BorderMode::replicate, 0, backend, isa).at<uint8_t>(0, 0), 2) << label;
    EXPECT_EQ(run_median(ramp, BorderMode::constant, 200, backend, isa).at<uint8_t>(0, 0), 200) << label;
    const Plane filtered = run_median(impulse, BorderMode::replicate, 0, backend, isa);
    EXPECT_EQ(filtered.at<uint8_t>(66, 1), 10) << label;
    EXPECT_EQ(filtered.at<uint8_t>(69, 2), 10) << label;
  };
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The closed form of kernels/median3x3.cpp: every tile row is ceil(tile width / 64) chunks (64 =
// the counting back end's u8 lanes), each chunk 9 loads, 30 min/max and 1 store; nothing else.
simd::OpCounts median3x3_closed_form(const testing::TileWork& work) {
  simd::OpCounts counts;
  counts[simd::OpClass::load] = 9 * work.chunks;
  counts[simd::OpClass::arith] = 30 * work.chunks;
  counts[simd::OpClass::store] = work.chunks;
  return counts;
}

TEST(Median3x3, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64, "the closed form assumes 64 u8 lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 640, 480}, {1, 1, 1, 1},
                                               {65, 7, 65, 7}, {631, 479, 100, 37}, {200, 3, 7, 5}}) {
    KernelCase test_case{"median3x3", {}, {}, 0};
    test_case.inputs.push_back(random_plane(shape.width, shape.height, {ElementType::u8, 0}, 0, 14));
    for (BorderMode mode : {BorderMode::replicate, BorderMode::constant}) {
      EXPECT_TRUE(testing::op_counts_equal(
          median3x3_closed_form(testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 64)),
          testing::count_ops(test_case, shape.tile_width, shape.tile_height, mode)))
          << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height
          << " border " << border_mode_name(mode);
    }
  }
}

TEST(Median3x3, RefusesParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("median3x3");
  EXPECT_THROW(kernel.prepare({{"radius", 2}}, {{10, 10}}), KernelError);
}

}  // namespace
}  // namespace lpstereo
