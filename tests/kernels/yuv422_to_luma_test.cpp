// yuv422_to_luma: every back end against the reference and against the luma bytes read straight
// from the packed rows (YUYV: byte 2x, UYVY: byte 2x + 1) at odd sizes and tile shapes in padded
// buffers, a hand-written macropixel, the closed-form op count of kernels/yuv422_to_luma.cpp for
// both orders, and the refused parameters.
#include <gtest/gtest.h>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

constexpr BufferFormat kU16{ElementType::u16, 0};
constexpr BufferFormat kU8{ElementType::u8, 0};

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {631, 16}, {64, 16}, {105, 37}, {33, 7}, {7, 5}, {1, 1}};

// The luma of a packed plane, byte by byte: the test's own scalar reference.
Plane luma_bytes(const Plane& packed, int luma_byte) {
  Plane luma(packed.width(), packed.height(), kU8);
  for (int y = 0; y < packed.height(); ++y) {
    for (int x = 0; x < packed.width(); ++x) luma.at<uint8_t>(x, y) = packed.row<uint8_t>(y)[2 * x + luma_byte];
  }
  return luma;
}

TEST(Yuv422ToLuma, MatchesReferenceAndTheLumaBytesAtOddSizeInPaddedBuffer) {
  for (const auto& [order, luma_byte] : std::vector<std::pair<std::string, int>>{{"yuyv", 0}, {"uyvy", 1}}) {
    KernelCase test_case{"yuv422_to_luma", {{"order", order}}, {}, 9};
    test_case.inputs.push_back(random_plane(631, 479, kU16, 2 * 640 + 10, 41));
    const std::vector<Plane> outputs = expect_all_back_ends_match_reference(test_case, kTileShapes);
    EXPECT_TRUE(testing::planes_equal(luma_bytes(test_case.inputs[0], luma_byte), outputs.at(0))) << order;
  }
}

TEST(Yuv422ToLuma, MatchesReferenceAtTinyAndVectorEdgeSizes) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {7, 2}, {8, 3}, {9, 1}, {31, 2}, {32, 2}, {33, 3}, {65, 1}, {129, 2}}) {
    for (const auto& [order, luma_byte] : std::vector<std::pair<std::string, int>>{{"yuyv", 0}, {"uyvy", 1}}) {
      KernelCase test_case{"yuv422_to_luma", {{"order", order}}, {}, 3};
      test_case.inputs.push_back(random_plane(width, height, kU16, 2 * width + 6, 42));
      const std::vector<Plane> outputs = expect_all_back_ends_match_reference(test_case, {{width, height}, {1, 1}, {33, 2}});
      EXPECT_TRUE(testing::planes_equal(luma_bytes(test_case.inputs[0], luma_byte), outputs.at(0)))
          << order << " " << width << "x" << height;
    }
  }
}

// Two macropixels written by hand: Y0 U0 Y1 V0 Y2 U1 Y3 V1 = 10 200 20 100 0 255 255 0.
TEST(Yuv422ToLuma, GoldenMacropixels) {
  const uint8_t bytes[] = {10, 200, 20, 100, 0, 255, 255, 0};
  Plane packed(4, 1, kU16);
  for (int i = 0; i < 8; ++i) packed.row<uint8_t>(0)[i] = bytes[i];
  const KernelDescriptor& kernel = testing::kernel_named("yuv422_to_luma");
  for (const auto& [order, expected] : std::vector<std::pair<std::string, std::vector<int>>>{
           {"yuyv", {10, 20, 0, 255}}, {"uyvy", {200, 100, 255, 0}}}) {
    const PreparedKernel prepared = kernel.prepare({{"order", order}}, {{4, 1}});
    auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
      Plane luma(4, 1, kU8);
      VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {packed.view()}, {luma.view()}};
      run_vector_node(binding, 4, 1, backend, isa);
      for (int x = 0; x < 4; ++x) EXPECT_EQ(luma.at<uint8_t>(x, 0), expected[x]) << order << " " << label << " x=" << x;
    };
    for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
    check(KernelBackend::counting, simd::Isa::scalar, "counting");
  }
}

// The closed form of kernels/yuv422_to_luma.cpp: per chunk of 64 pixels (the counting back end's u8
// lanes, two loads of 32 u16 lanes) 2 loads, 1 narrow (permute), 1 store, and 2 ands (yuyv) or
// 2 shifts (uyvy); per tile one broadcast (permute) for yuyv, none for uyvy.
TEST(Yuv422ToLuma, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64 && simd::Counting::kLanesU16 == 32, "the closed form assumes 512-bit vectors");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 64, 16}, {1, 1, 1, 1}, {257, 7, 65, 3}, {631, 479, 100, 37}}) {
    for (const std::string order : {"yuyv", "uyvy"}) {
      KernelCase test_case{"yuv422_to_luma", {{"order", order}}, {}, 0};
      test_case.inputs.push_back(random_plane(shape.width, shape.height, kU16, 0, 43));
      const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 64);
      simd::OpCounts expected;
      expected[simd::OpClass::load] = 2 * work.chunks;
      expected[order == "yuyv" ? simd::OpClass::logic : simd::OpClass::shift] = 2 * work.chunks;
      expected[simd::OpClass::permute] = work.chunks + (order == "yuyv" ? work.tiles : 0);
      expected[simd::OpClass::store] = work.chunks;
      EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
          << order << " " << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
    }
  }
}

TEST(Yuv422ToLumaMustFail, RefusesAMissingOrWrongOrderAndUnknownParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("yuv422_to_luma");
  for (const nlohmann::json& params : {nlohmann::json::object(), nlohmann::json{{"order", "YUYV"}}, nlohmann::json{{"order", "nv12"}},
                                       nlohmann::json{{"order", 1}}, nlohmann::json{{"order", "yuyv"}, {"shift", 8}}}) {
    EXPECT_THROW(kernel.prepare(params, {{10, 10}}), KernelError) << params.dump();
  }
  try {
    kernel.prepare({{"order", "yvyu"}}, {{10, 10}});
    FAIL() << "order yvyu accepted";
  } catch (const KernelError& error) {
    EXPECT_NE(std::string(error.what()).find("parameter 'order'"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("yvyu"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace lpstereo
