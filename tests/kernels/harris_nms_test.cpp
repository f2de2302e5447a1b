// harris_nms: bit-exact against the reference on every back end at odd sizes in padded buffers
// (random and tie-heavy responses, both radii, both border modes), the tie rule on plateaus by hand,
// the closed-form op count, refused parameters; and harris_response -> harris_nms on bright squares
// on black: a corner within 1 px of each square corner, none on the edges or flat areas.
#include <gtest/gtest.h>

#include <cstdlib>

#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}, {1, 1}};

TEST(HarrisNms, MatchesReferenceAtOddSizeInPaddedBuffer) {
  for (int radius : {1, 2}) {
    for (int threshold : {0, 1000000, 2147483647}) {
      KernelCase test_case{"harris_nms", {{"radius", radius}, {"threshold", threshold}}, {}, 9};
      test_case.inputs.push_back(random_plane(631, 479, {ElementType::s32, 0}, 640 * 4 + 12, 31));
      expect_all_back_ends_match_reference(test_case, {{631, 479}, {100, 37}, {7, 5}});
    }
  }
}

// Few distinct values (0 .. 3 x 10^6): plateaus and ties everywhere, which is where a wrong tie
// side shows.
TEST(HarrisNms, MatchesReferenceWithManyTies) {
  for (int radius : {1, 2}) {
    KernelCase test_case{"harris_nms", {{"radius", radius}, {"threshold", 5}}, {}, 3};
    Plane input = random_plane(203, 97, {ElementType::s32, 0}, 203 * 4 + 20, 32);
    for (int y = 0; y < input.height(); ++y) {
      for (int x = 0; x < input.width(); ++x) {
        input.at<int32_t>(x, y) = static_cast<int32_t>((static_cast<uint32_t>(input.at<int32_t>(x, y)) % 4) * 1000000);
      }
    }
    test_case.inputs.push_back(std::move(input));
    expect_all_back_ends_match_reference(test_case, kTileShapes);
  }
}

TEST(HarrisNms, TinyImages) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {17, 2}, {65, 1}}) {
    KernelCase test_case{"harris_nms", {{"radius", 2}, {"threshold", 0}}, {}, 5};
    test_case.inputs.push_back(random_plane(width, height, {ElementType::s32, 0}, width * 4 + 8, 33));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
}

Plane run_kernel(const std::string& name, const Plane& input, const nlohmann::json& params, ElementType output_type,
                 KernelBackend backend, simd::Isa isa, BorderMode mode = BorderMode::replicate) {
  const KernelDescriptor& kernel = testing::kernel_named(name);
  const PreparedKernel prepared = kernel.prepare(params, {{input.width(), input.height()}});
  Plane output(input.width(), input.height(), {output_type, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), mode, 0, {input.view()}, {output.view()}, prepared.input_halos};
  run_vector_node(binding, 48, 16, backend, isa);
  return output;
}

template <class Check>
void on_every_back_end(const Check& check) {
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

std::vector<std::pair<int, int>> corner_positions(const Plane& mask) {
  std::vector<std::pair<int, int>> corners;
  for (int y = 0; y < mask.height(); ++y) {
    for (int x = 0; x < mask.width(); ++x) {
      EXPECT_LE(mask.at<uint8_t>(x, y), 1) << "mask values are 0 or 1";
      if (mask.at<uint8_t>(x, y) == 1) corners.emplace_back(x, y);
    }
  }
  return corners;
}

// Plateaus by hand (threshold 10): a 3x3 block of 50 gives one corner at its first pixel; a
// horizontal run of 7 equal values gives one, at its left end; a single peak next to an equal
// value after it in raster order is kept (>= after), one with an equal value before it is not; a
// diagonal line gives one at its top; a U opening upwards gives one per arm (the documented limit).
TEST(HarrisNms, PlateausGiveOneCornerAtTheirFirstPixel) {
  Plane response(40, 20, {ElementType::s32, 0});
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 40; ++x) response.at<int32_t>(x, y) = 0;
  }
  for (int y = 5; y < 8; ++y) {
    for (int x = 5; x < 8; ++x) response.at<int32_t>(x, y) = 50;
  }
  for (int x = 15; x < 22; ++x) response.at<int32_t>(x, 10) = 70;
  response.at<int32_t>(30, 14) = 90;  // an equal pair on one row: the left one wins
  response.at<int32_t>(31, 14) = 90;
  for (int i = 0; i < 4; ++i) response.at<int32_t>(28 - i, 2 + i) = 60;  // a line down and to the left: its top
  for (int y = 2; y < 5; ++y) {  // a U opening upwards, arms 3 px apart: two tops, two corners
    response.at<int32_t>(34, y) = 40;
    response.at<int32_t>(37, y) = 40;
  }
  for (int x = 34; x < 38; ++x) response.at<int32_t>(x, 4) = 40;
  for (int radius : {1, 2}) {
    on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
      const Plane mask = run_kernel("harris_nms", response, {{"radius", radius}, {"threshold", 10}}, ElementType::u8, backend, isa);
      const std::vector<std::pair<int, int>> expected = {{28, 2}, {34, 2}, {37, 2}, {5, 5}, {15, 10}, {30, 14}};
      EXPECT_EQ(corner_positions(mask), expected) << label << " radius " << radius;
    });
  }
  // Nothing above a threshold of 90.
  const Plane none = run_kernel("harris_nms", response, {{"threshold", 90}}, ElementType::u8, KernelBackend::counting, simd::Isa::scalar);
  EXPECT_TRUE(corner_positions(none).empty());
}

// Bright squares (grey 200 on 10) far apart: harris_response then harris_nms. Every detection lies
// within 1 px (Chebyshev) of a square's corner pixel, every square corner has exactly one, and the
// middle of the edges and the flat areas have none.
TEST(HarrisNms, BrightSquaresGiveCornersAtTheirCornersOnly) {
  struct Square {
    int x0, y0, size;
  };
  const std::vector<Square> squares = {{12, 10, 20}, {50, 14, 9}, {80, 40, 15}, {20, 50, 12}};
  Plane image(113, 79, {ElementType::u8, 0}, 128);
  for (int y = 0; y < 79; ++y) {
    for (int x = 0; x < 113; ++x) {
      bool inside = false;
      for (const Square& s : squares) inside = inside || (x >= s.x0 && x < s.x0 + s.size && y >= s.y0 && y < s.y0 + s.size);
      image.at<uint8_t>(x, y) = inside ? 200 : 10;
    }
  }
  std::vector<std::pair<int, int>> square_corners;
  for (const Square& s : squares) {
    for (int cy : {s.y0, s.y0 + s.size - 1}) {
      for (int cx : {s.x0, s.x0 + s.size - 1}) square_corners.emplace_back(cx, cy);
    }
  }
  for (int window : {3, 5}) {
    for (int radius : {1, 2}) {
      on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
        const Plane response = run_kernel("harris_response", image, {{"window_size", window}}, ElementType::s32, backend, isa);
        const Plane mask = run_kernel("harris_nms", response, {{"radius", radius}}, ElementType::u8, backend, isa);
        const std::vector<std::pair<int, int>> corners = corner_positions(mask);
        std::vector<int> hits(square_corners.size(), 0);
        for (const auto& [x, y] : corners) {
          bool near = false;
          for (size_t i = 0; i < square_corners.size(); ++i) {
            if (std::abs(x - square_corners[i].first) <= 1 && std::abs(y - square_corners[i].second) <= 1) {
              ++hits[i];
              near = true;
            }
          }
          EXPECT_TRUE(near) << label << " window " << window << " radius " << radius << ": corner at " << x << "," << y
                            << " is near no square corner";
        }
        for (size_t i = 0; i < square_corners.size(); ++i) {
          EXPECT_EQ(hits[i], 1) << label << " window " << window << " radius " << radius << ": square corner "
                                << square_corners[i].first << "," << square_corners[i].second;
        }
      });
    }
  }
}

// The closed form of kernels/harris_nms.cpp for the counting back end (L8 = 64).
TEST(HarrisNms, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64, "the closed form assumes 64 u8 lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (int radius : {1, 2}) {
    for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 64, 16}, {1, 1, 1, 1}, {65, 7, 65, 7},
                                                 {631, 479, 100, 37}, {200, 3, 7, 5}}) {
      KernelCase test_case{"harris_nms", {{"radius", radius}}, {}, 0};
      test_case.inputs.push_back(random_plane(shape.width, shape.height, {ElementType::s32, 0}, 0, 34));
      const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 64);
      const int64_t n = (2 * radius + 1) * (2 * radius + 1) - 1;
      simd::OpCounts expected;
      expected[simd::OpClass::load] = 4 * (n + 1) * work.chunks;
      expected[simd::OpClass::compare] = 4 * (n + 1) * work.chunks;
      expected[simd::OpClass::logic] = (4 * n + 1) * work.chunks;
      expected[simd::OpClass::permute] = 3 * work.chunks + 2 * work.tiles;
      expected[simd::OpClass::store] = work.chunks;
      for (BorderMode mode : {BorderMode::replicate, BorderMode::constant}) {
        EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height, mode)))
            << "radius " << radius << " " << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x"
            << shape.tile_height;
      }
    }
  }
}

TEST(HarrisNmsMustFail, RefusesBadParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("harris_nms");
  EXPECT_THROW(kernel.prepare({{"size", 3}}, {{10, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"threshold", -1}}, {{10, 10}}), KernelError);
  try {
    kernel.prepare({{"radius", 3}}, {{10, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "parameter 'radius': expected an integer in [1, 2], got 3");
  }
}

}  // namespace
}  // namespace lpstereo
