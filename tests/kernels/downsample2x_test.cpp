// downsample2x: bit-exact against the reference on every back end at odd sizes and tile shapes
// (the first kernel with a scaled input: input = 2 x output), golden values, the closed-form op
// count of kernels/downsample2x.cpp, and (with OpenCV) agreement with cv::resize INTER_AREA.
#include <gtest/gtest.h>

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

// Output tile shapes for a 316x240 output (631x479 input): the whole image, strips, odd shapes whose
// last tile is 1 or 2 pixels wide or tall, and 1x1.
const std::vector<std::pair<int, int>> kTileShapes = {{316, 240}, {316, 16}, {64, 16}, {105, 37}, {33, 7}, {7, 5}, {315, 239}, {1, 1}};

TEST(Downsample2x, MatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"downsample2x", {}, {}, 9};
  test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 21));
  expect_all_back_ends_match_reference(test_case, kTileShapes);
}

TEST(Downsample2x, MatchesReferenceAtEvenAndTinySizes) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{640, 480}, {1, 1}, {2, 1}, {1, 2}, {3, 3}, {129, 1}, {130, 5}, {257, 3}}) {
    KernelCase test_case{"downsample2x", {}, {}, 3};
    test_case.inputs.push_back(random_plane(width, height, {ElementType::u8, 0}, width + 5, 22));
    const int out_width = (width + 1) / 2, out_height = (height + 1) / 2;
    expect_all_back_ends_match_reference(test_case, {{out_width, out_height}, {2, 1}, {1, 2}, {64, 1}, {33, 2}});
  }
}

// An odd-width image: the input rect of every tile in the last tile column reaches one column past
// the image (the executor replicates it); with an odd height the same holds for the last tile row.
TEST(Downsample2x, EdgeTilesReadOnePastTheImageAndReplicateIt) {
  const KernelDescriptor& kernel = testing::kernel_named("downsample2x");
  const PreparedKernel prepared = kernel.prepare(nlohmann::json::object(), {{631, 479}});
  ASSERT_EQ(prepared.output_shapes.at(0), (PlaneShape{316, 240}));
  const PixelRect edge = tile_input_rect(kernel, prepared.input_halos, prepared.input_scales, 0, TileRect{300, 224, 16, 16});
  EXPECT_EQ(edge.x0, 600);
  EXPECT_EQ(edge.y0, 448);
  EXPECT_EQ(edge.x1, 632);  // one past the 631 columns
  EXPECT_EQ(edge.y1, 480);  // one past the 479 rows
  const PixelRect inner = tile_input_rect(kernel, prepared.input_halos, prepared.input_scales, 0, TileRect{33, 7, 10, 3});
  EXPECT_EQ(inner.x0, 66);
  EXPECT_EQ(inner.x1, 86);
  EXPECT_EQ(inner.y0, 14);
  EXPECT_EQ(inner.y1, 20);
  // A constant image with a different last column and row: the edge outputs average the last
  // column (row) with itself.
  Plane input(5, 3, {ElementType::u8, 0});
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 5; ++x) input.at<uint8_t>(x, y) = static_cast<uint8_t>(x == 4 ? 200 : (y == 2 ? 100 : 10));
  }
  for (simd::Isa isa : simd::available_isas()) {
    for (auto [tile_width, tile_height] : std::vector<std::pair<int, int>>{{3, 2}, {1, 1}, {2, 1}}) {
      Plane output(3, 2, {ElementType::u8, 0});
      VectorNodeBinding binding{&kernel, nullptr, BorderMode::replicate, 0, {input.view()}, {output.view()}, {}, prepared.input_scales};
      run_vector_node(binding, tile_width, tile_height, KernelBackend::native, isa);
      const std::string label = std::string(simd::isa_name(isa)) + " tile " + std::to_string(tile_width) + "x" + std::to_string(tile_height);
      EXPECT_EQ(output.at<uint8_t>(0, 0), 10) << label;
      EXPECT_EQ(output.at<uint8_t>(2, 0), 200) << label;   // (200 + 200 + 200 + 200 + 2) >> 2
      EXPECT_EQ(output.at<uint8_t>(0, 1), 100) << label;   // row 2 with itself
      EXPECT_EQ(output.at<uint8_t>(2, 1), 200) << label;   // the corner: one pixel four times
    }
  }
}

// Golden 2x2 blocks: the mean rounds halves up, (a + b + c + d + 2) >> 2.
TEST(Downsample2x, GoldenValues) {
  const int blocks[][4] = {{1, 2, 3, 4}, {0, 0, 0, 1}, {0, 0, 1, 1}, {1, 1, 1, 0}, {255, 255, 255, 255}, {255, 255, 255, 254}, {0, 0, 0, 2}};
  const int expected[] = {3, 0, 1, 1, 255, 255, 1};
  const int count = static_cast<int>(std::size(expected));
  Plane input(2 * count, 2, {ElementType::u8, 0});
  for (int block = 0; block < count; ++block) {
    input.at<uint8_t>(2 * block, 0) = static_cast<uint8_t>(blocks[block][0]);
    input.at<uint8_t>(2 * block + 1, 0) = static_cast<uint8_t>(blocks[block][1]);
    input.at<uint8_t>(2 * block, 1) = static_cast<uint8_t>(blocks[block][2]);
    input.at<uint8_t>(2 * block + 1, 1) = static_cast<uint8_t>(blocks[block][3]);
  }
  const KernelDescriptor& kernel = testing::kernel_named("downsample2x");
  const PreparedKernel prepared = kernel.prepare(nlohmann::json::object(), {{input.width(), input.height()}});
  auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    Plane output(count, 1, {ElementType::u8, 0});
    VectorNodeBinding binding{&kernel, nullptr, BorderMode::replicate, 0, {input.view()}, {output.view()}, {}, prepared.input_scales};
    run_vector_node(binding, count, 1, backend, isa);
    for (int block = 0; block < count; ++block) EXPECT_EQ(output.at<uint8_t>(block, 0), expected[block]) << label << " block " << block;
  };
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The closed form of kernels/downsample2x.cpp: per chunk of 64 output pixels (the counting back
// end's u8 lanes) 4 loads, 4 logic, 6 shifts, 8 adds, 1 narrow (permute), 1 store; per tile 2
// broadcasts (permute).
TEST(Downsample2x, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64, "the closed form assumes 64 u8 lanes");
  struct Shape {
    int width, height, tile_width, tile_height;  // input size, output tile size
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 316, 240}, {640, 480, 320, 16}, {1, 1, 1, 1}, {257, 7, 65, 3},
                                               {631, 479, 100, 37}, {200, 3, 7, 5}}) {
    KernelCase test_case{"downsample2x", {}, {}, 0};
    test_case.inputs.push_back(random_plane(shape.width, shape.height, {ElementType::u8, 0}, 0, 23));
    const testing::TileWork work =
        testing::tile_work((shape.width + 1) / 2, (shape.height + 1) / 2, shape.tile_width, shape.tile_height, 64);
    simd::OpCounts expected;
    expected[simd::OpClass::load] = 4 * work.chunks;
    expected[simd::OpClass::logic] = 4 * work.chunks;
    expected[simd::OpClass::shift] = 6 * work.chunks;
    expected[simd::OpClass::arith] = 8 * work.chunks;
    expected[simd::OpClass::permute] = work.chunks + 2 * work.tiles;
    expected[simd::OpClass::store] = work.chunks;
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height)))
        << shape.width << "x" << shape.height << " in output tiles of " << shape.tile_width << "x" << shape.tile_height;
  }
}

TEST(Downsample2xMustFail, RefusesParametersAndTheConstantBorder) {
  const KernelDescriptor& kernel = testing::kernel_named("downsample2x");
  EXPECT_THROW(kernel.prepare({{"factor", 2}}, {{10, 10}}), KernelError);
  EXPECT_EQ(kernel.border_modes, std::vector<BorderMode>{BorderMode::replicate});
}

#ifdef LPSTEREO_TEST_WITH_OPENCV
// On even sizes the 2x2 box mean rounding half up is what cv::resize(INTER_AREA) computes at scale 1/2.
TEST(Downsample2x, EqualsOpenCvResizeAreaAtEvenSizes) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{640, 480}, {98, 34}, {2, 2}}) {
    const Plane input = random_plane(width, height, {ElementType::u8, 0}, 0, 24);
    const cv::Mat source(height, width, CV_8UC1, input.row<uint8_t>(0), static_cast<size_t>(input.stride_bytes()));
    cv::Mat expected;
    cv::resize(source, expected, cv::Size(width / 2, height / 2), 0, 0, cv::INTER_AREA);
    const KernelDescriptor& kernel = testing::kernel_named("downsample2x");
    const PreparedKernel prepared = kernel.prepare(nlohmann::json::object(), {{width, height}});
    Plane output(width / 2, height / 2, {ElementType::u8, 0});
    VectorNodeBinding binding{&kernel, nullptr, BorderMode::replicate, 0, {input.view()}, {output.view()}, {}, prepared.input_scales};
    run_vector_node(binding, 64, 16, KernelBackend::native, simd::active_isa());
    for (int y = 0; y < height / 2; ++y) {
      for (int x = 0; x < width / 2; ++x) {
        ASSERT_EQ(output.at<uint8_t>(x, y), expected.at<uint8_t>(y, x)) << width << "x" << height << " at x=" << x << " y=" << y;
      }
    }
  }
}
#endif

}  // namespace
}  // namespace lpstereo
