// rgb888_to_luma: every back end against the kernel's reference and the test's own scalar formula
// at odd sizes and tile shapes in padded buffers (the input is a whole-access u8 plane of 3 W bytes
// per row), golden colours from the BT.601 weights, the extremes of the bound, source_rect, the
// closed-form op count of kernels/rgb888_to_luma.cpp, the refused parameters and shapes, and (with
// OpenCV) agreement with cv::cvtColor(COLOR_RGB2GRAY / COLOR_BGR2GRAY) on all 2^24 colours.
#include <gtest/gtest.h>

#include <cmath>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

#ifdef LPSTEREO_TEST_WITH_OPENCV
#include <opencv2/imgproc.hpp>
#endif

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

constexpr BufferFormat kU8{ElementType::u8, 0};

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {631, 16}, {64, 16}, {105, 37}, {33, 7}, {7, 5}, {1, 1}};

// The test's own scalar formula (OpenCV's 8-bit BT.601 weights in Q15, rounded half up).
uint8_t bt601_luma(int red, int green, int blue) {
  return static_cast<uint8_t>((9798 * red + 19235 * green + 3735 * blue + 16384) >> 15);
}

// The luma of a packed plane of 3 W bytes per row; red_byte 0 (rgb) or 2 (bgr).
Plane luma_of_packed(const Plane& packed, int red_byte) {
  Plane luma(packed.width() / 3, packed.height(), kU8);
  for (int y = 0; y < packed.height(); ++y) {
    for (int x = 0; x < luma.width(); ++x) {
      const uint8_t* pixel = packed.row<uint8_t>(y) + 3 * x;
      luma.at<uint8_t>(x, y) = bt601_luma(pixel[red_byte], pixel[1], pixel[2 - red_byte]);
    }
  }
  return luma;
}

// Runs the kernel over `packed` (3 W bytes per row) in tiles of tile_width x tile_height.
Plane run_kernel(const Plane& packed, const std::string& order, int tile_width, int tile_height, KernelBackend backend,
                 simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("rgb888_to_luma");
  const PreparedKernel prepared = kernel.prepare({{"order", order}}, {{packed.width(), packed.height()}});
  Plane luma(packed.width() / 3, packed.height(), kU8);
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {packed.view()}, {luma.view()}};
  run_vector_node(binding, tile_width, tile_height, backend, isa);
  return luma;
}

TEST(Rgb888ToLuma, MatchesReferenceAndTheFormulaAtOddSizeInPaddedBuffer) {
  for (const auto& [order, red_byte] : std::vector<std::pair<std::string, int>>{{"rgb", 0}, {"bgr", 2}}) {
    KernelCase test_case{"rgb888_to_luma", {{"order", order}}, {}, 9};
    test_case.inputs.push_back(random_plane(3 * 631, 479, kU8, 3 * 640 + 1, 51));
    const std::vector<Plane> outputs = expect_all_back_ends_match_reference(test_case, kTileShapes);
    EXPECT_TRUE(testing::planes_equal(luma_of_packed(test_case.inputs[0], red_byte), outputs.at(0))) << order;
  }
}

TEST(Rgb888ToLuma, MatchesReferenceAtTinyAndVectorEdgeSizes) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {3, 2}, {4, 3}, {5, 1}, {15, 2}, {16, 2}, {17, 3}, {63, 1}, {64, 2}, {65, 2}, {129, 1}}) {
    for (const auto& [order, red_byte] : std::vector<std::pair<std::string, int>>{{"rgb", 0}, {"bgr", 2}}) {
      KernelCase test_case{"rgb888_to_luma", {{"order", order}}, {}, 3};
      test_case.inputs.push_back(random_plane(3 * width, height, kU8, 3 * width + 2, 52));
      const std::vector<Plane> outputs = expect_all_back_ends_match_reference(test_case, {{width, height}, {1, 1}, {33, 2}});
      EXPECT_TRUE(testing::planes_equal(luma_of_packed(test_case.inputs[0], red_byte), outputs.at(0)))
          << order << " " << width << "x" << height;
    }
  }
}

// Colours whose luma follows from Y = 0.299 R + 0.587 G + 0.114 B rounded to the nearest integer
// (none lies near a half): the extremes of the bound (black 0, white 255: no saturation) and the
// primaries. Red 76.245 -> 76, green 149.685 -> 150, blue 29.07 -> 29, (100, 150, 200) 140.75
// -> 141, (1, 1, 1) -> 1, (128, 128, 128) -> 128, (255, 255, 0) 225.93 -> 226, (0, 255, 255)
// 178.755 -> 179.
TEST(Rgb888ToLuma, GoldenColoursAndTheExtremesOfTheBound) {
  const int colours[][3] = {{0, 0, 0}, {255, 255, 255}, {255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {100, 150, 200},
                            {1, 1, 1}, {128, 128, 128}, {255, 255, 0}, {0, 255, 255}};
  const int expected[] = {0, 255, 76, 150, 29, 141, 1, 128, 226, 179};
  const int count = static_cast<int>(std::size(expected));
  for (const auto& [order, red_byte] : std::vector<std::pair<std::string, int>>{{"rgb", 0}, {"bgr", 2}}) {
    Plane packed(3 * count, 1, kU8);
    for (int i = 0; i < count; ++i) {
      packed.row<uint8_t>(0)[3 * i + red_byte] = static_cast<uint8_t>(colours[i][0]);
      packed.row<uint8_t>(0)[3 * i + 1] = static_cast<uint8_t>(colours[i][1]);
      packed.row<uint8_t>(0)[3 * i + 2 - red_byte] = static_cast<uint8_t>(colours[i][2]);
    }
    auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
      const Plane luma = run_kernel(packed, order, count, 1, backend, isa);
      for (int i = 0; i < count; ++i) EXPECT_EQ(luma.at<uint8_t>(i, 0), expected[i]) << order << " " << label << " colour " << i;
    };
    for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
    check(KernelBackend::counting, simd::Isa::scalar, "counting");
  }
}

// The DMA window of a tile: its own pixels' bytes, 3 per pixel, the same rows.
TEST(Rgb888ToLuma, SourceRectIsTheTilesBytes) {
  const KernelDescriptor& kernel = testing::kernel_named("rgb888_to_luma");
  const PreparedKernel prepared = kernel.prepare({{"order", "rgb"}}, {{3 * 631, 479}});
  ASSERT_EQ(prepared.output_shapes, (std::vector<PlaneShape>{{631, 479}}));
  ASSERT_TRUE(kernel.source_rect);
  const PixelRect rect = kernel.source_rect(0, {600, 448, 631, 479}, {3 * 631, 479}, prepared.params.get());
  EXPECT_EQ(rect.x0, 1800);
  EXPECT_EQ(rect.x1, 1893);  // the last byte of the row, 3 x 631
  EXPECT_EQ(rect.y0, 448);
  EXPECT_EQ(rect.y1, 479);
}

// The closed form of kernels/rgb888_to_luma.cpp: per chunk of 64 pixels (the counting back end's u8
// lanes, 4 quarters of 16 s32 lanes) 12 gathers, 12 multiplies, 20 arith, 4 shifts, 3 narrows
// (permute), 1 store; per tile 1 load (the lane offset table) and 6 broadcasts (permute).
TEST(Rgb888ToLuma, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64 && simd::Counting::kLanesU32 == 16, "the closed form assumes 512-bit vectors");
  struct Shape {
    int width, height, tile_width, tile_height;  // pixels
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 64, 16}, {1, 1, 1, 1}, {257, 7, 65, 3}, {631, 479, 100, 37}}) {
    for (const std::string order : {"rgb", "bgr"}) {
      KernelCase test_case{"rgb888_to_luma", {{"order", order}}, {}, 0};
      test_case.inputs.push_back(random_plane(3 * shape.width, shape.height, kU8, 0, 53));
      const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 64);
      simd::OpCounts expected;
      expected[simd::OpClass::gather] = 12 * work.chunks;
      expected[simd::OpClass::multiply] = 12 * work.chunks;
      expected[simd::OpClass::arith] = 20 * work.chunks;
      expected[simd::OpClass::shift] = 4 * work.chunks;
      expected[simd::OpClass::permute] = 3 * work.chunks + 6 * work.tiles;
      expected[simd::OpClass::store] = work.chunks;
      expected[simd::OpClass::load] = work.tiles;
      EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
          << order << " " << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height;
    }
  }
}

TEST(Rgb888ToLumaMustFail, RefusesABadOrderAWidthNotOfWholePixelsAndUnknownParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("rgb888_to_luma");
  for (const nlohmann::json& params : {nlohmann::json::object(), nlohmann::json{{"order", "RGB"}}, nlohmann::json{{"order", "rgba"}},
                                       nlohmann::json{{"order", 0}}, nlohmann::json{{"order", "rgb"}, {"weights", "bt709"}}}) {
    EXPECT_THROW(kernel.prepare(params, {{30, 10}}), KernelError) << params.dump();
  }
  try {
    kernel.prepare({{"order", "rgb"}}, {{31, 10}});
    FAIL() << "a 31-byte row accepted";
  } catch (const KernelError& error) {
    EXPECT_NE(std::string(error.what()).find("multiple of 3"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("31"), std::string::npos) << error.what();
  }
}

#ifdef LPSTEREO_TEST_WITH_OPENCV
// Every colour once: a 4096 x 4096 image whose pixel i is (i & 255, (i >> 8) & 255, i >> 16).
TEST(Rgb888ToLuma, EqualsOpenCvCvtColorOnAllColours) {
  Plane packed(3 * 4096, 4096, kU8);
  for (int y = 0; y < 4096; ++y) {
    uint8_t* row = packed.row<uint8_t>(y);
    for (int x = 0; x < 4096; ++x) {
      const uint32_t colour = static_cast<uint32_t>(y) * 4096u + static_cast<uint32_t>(x);
      row[3 * x] = static_cast<uint8_t>(colour);
      row[3 * x + 1] = static_cast<uint8_t>(colour >> 8);
      row[3 * x + 2] = static_cast<uint8_t>(colour >> 16);
    }
  }
  const cv::Mat source(4096, 4096, CV_8UC3, packed.row<uint8_t>(0), static_cast<size_t>(packed.stride_bytes()));
  for (const auto& [order, code] : std::vector<std::pair<std::string, int>>{{"rgb", cv::COLOR_RGB2GRAY}, {"bgr", cv::COLOR_BGR2GRAY}}) {
    cv::Mat expected;
    cv::cvtColor(source, expected, code);
    const Plane luma = run_kernel(packed, order, 256, 64, KernelBackend::native, simd::active_isa());
    int64_t differing = 0;
    for (int y = 0; y < 4096; ++y) {
      for (int x = 0; x < 4096; ++x) differing += luma.at<uint8_t>(x, y) != expected.at<uint8_t>(y, x);
    }
    EXPECT_EQ(differing, 0) << order << ": colours whose luma differs from cv::cvtColor";
  }
}

// Random bytes at an odd size in a padded buffer, on every back end, against cv::cvtColor.
TEST(Rgb888ToLuma, EqualsOpenCvCvtColorAtOddSizeOnEveryBackEnd) {
  const Plane packed = random_plane(3 * 631, 479, kU8, 3 * 640 + 1, 54);
  const cv::Mat source(479, 631, CV_8UC3, const_cast<uint8_t*>(packed.row<uint8_t>(0)), static_cast<size_t>(packed.stride_bytes()));
  for (const auto& [order, code] : std::vector<std::pair<std::string, int>>{{"rgb", cv::COLOR_RGB2GRAY}, {"bgr", cv::COLOR_BGR2GRAY}}) {
    cv::Mat expected;
    cv::cvtColor(source, expected, code);
    Plane expected_plane(631, 479, kU8);
    for (int y = 0; y < 479; ++y) std::memcpy(expected_plane.row<uint8_t>(y), expected.ptr<uint8_t>(y), 631);
    for (simd::Isa isa : simd::available_isas()) {
      EXPECT_TRUE(testing::planes_equal(expected_plane, run_kernel(packed, order, 100, 37, KernelBackend::native, isa)))
          << order << " " << simd::isa_name(isa);
    }
    EXPECT_TRUE(testing::planes_equal(expected_plane, run_kernel(packed, order, 100, 37, KernelBackend::counting, simd::Isa::scalar)))
        << order << " counting";
  }
}
#endif

}  // namespace
}  // namespace lpstereo
