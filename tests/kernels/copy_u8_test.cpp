// copy_u8: every back end gives the input's bytes (and the reference's) at odd sizes and tile
// shapes in padded buffers, and the closed-form op count of kernels/copy_u8.cpp.
#include <gtest/gtest.h>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

constexpr BufferFormat kU8{ElementType::u8, 0};

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {631, 16}, {64, 16}, {105, 37}, {33, 7}, {7, 5}, {1, 1}};

// The output equals the input byte for byte (checked here directly, not only through the reference).
TEST(CopyU8, MatchesReferenceAndInputAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"copy_u8", {}, {}, 9};
  test_case.inputs.push_back(random_plane(631, 479, kU8, 640, 31));
  const std::vector<Plane> outputs = expect_all_back_ends_match_reference(test_case, kTileShapes);
  EXPECT_TRUE(testing::planes_equal(test_case.inputs[0], outputs.at(0)));
}

TEST(CopyU8, MatchesReferenceAtTinyAndVectorEdgeSizes) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {15, 2}, {16, 3}, {17, 1}, {63, 2}, {64, 2}, {65, 3}, {129, 1}}) {
    KernelCase test_case{"copy_u8", {}, {}, 3};
    test_case.inputs.push_back(random_plane(width, height, kU8, width + 7, 32));
    const std::vector<Plane> outputs = expect_all_back_ends_match_reference(test_case, {{width, height}, {1, 1}, {33, 2}});
    EXPECT_TRUE(testing::planes_equal(test_case.inputs[0], outputs.at(0))) << width << "x" << height;
  }
}

// The closed form of kernels/copy_u8.cpp: per chunk of 64 pixels (the counting back end's u8
// lanes) one load and one store; nothing else.
TEST(CopyU8, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64, "the closed form assumes 64 u8 lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 64, 16}, {1, 1, 1, 1}, {257, 7, 65, 3}, {631, 479, 100, 37}}) {
    KernelCase test_case{"copy_u8", {}, {}, 0};
    test_case.inputs.push_back(random_plane(shape.width, shape.height, kU8, 0, 33));
    const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 64);
    simd::OpCounts expected;
    expected[simd::OpClass::load] = work.chunks;
    expected[simd::OpClass::store] = work.chunks;
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
  }
}

TEST(CopyU8MustFail, RefusesParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("copy_u8");
  EXPECT_THROW(kernel.prepare({{"order", "yuyv"}}, {{10, 10}}), KernelError);
  EXPECT_EQ(kernel.prepare(nlohmann::json::object(), {{13, 7}}).output_shapes, (std::vector<PlaneShape>{{13, 7}}));
}

}  // namespace
}  // namespace lpstereo
