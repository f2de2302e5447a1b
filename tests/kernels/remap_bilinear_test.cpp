// remap_bilinear: bit-exact against the scalar reference on every back end and border mode, golden
// values (identity, whole-pixel shift, half-pixel average, floor of negative positions), the
// closed-form op count and source_rect of kernels/remap_bilinear.cpp, the float -> remap_q5
// conversion of dag/remap_table.h, and bit-exact agreement with OpenCV's cv::remap(INTER_LINEAR).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>

#include "dag/remap_table.h"
#include "dag/tile_executor.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

constexpr BufferFormat kU8{ElementType::u8, 0};
constexpr BufferFormat kMapFormat{ElementType::remap_q5, 0};

// A map of random displacements: most within +-max_px with random 1/32 fractions, one entry in 50
// anywhere in the Q10.5 range (far outside the source, exercising the border). Row stride padded.
Plane random_map(int width, int height, int max_px, uint32_t seed) {
  Plane map(width, height, kMapFormat, static_cast<ptrdiff_t>(width) * 4 + 36);
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> near(-32 * max_px, 32 * max_px);
  std::uniform_int_distribution<int> anywhere(-32768, 32767);
  std::uniform_int_distribution<int> percent(0, 99);
  for (int y = 0; y < height; ++y) {
    int16_t* row = map.row<int16_t>(y);
    for (int i = 0; i < 2 * width; ++i) {
      row[i] = static_cast<int16_t>(percent(generator) < 2 ? anywhere(generator) : near(generator));
    }
  }
  return map;
}

// A map with the same (dx, dy) in Q5 at every pixel.
Plane constant_map(int width, int height, int16_t dx_q5, int16_t dy_q5) {
  Plane map(width, height, kMapFormat);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      map.row<int16_t>(y)[2 * x] = dx_q5;
      map.row<int16_t>(y)[2 * x + 1] = dy_q5;
    }
  }
  return map;
}

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}};

TEST(RemapBilinear, MatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"remap_bilinear", {}, {}, 9};
  test_case.inputs.push_back(random_plane(631, 479, kU8, 640, 21));
  test_case.inputs.push_back(random_map(631, 479, 40, 22));
  expect_all_back_ends_match_reference(test_case, kTileShapes);
}

// The source smaller than the map (and not a multiple of any vector width): output = map size.
TEST(RemapBilinear, MatchesReferenceWithSourceAndMapOfDifferentSizes) {
  KernelCase test_case{"remap_bilinear", {{"max_displacement_px", 300}}, {}, 3};
  test_case.inputs.push_back(random_plane(317, 211, kU8, 320, 23));
  test_case.inputs.push_back(random_map(631, 479, 300, 24));
  const std::vector<Plane> output = expect_all_back_ends_match_reference(test_case, {{631, 479}, {64, 16}, {100, 37}});
  EXPECT_EQ(output.at(0).width(), 631);
  EXPECT_EQ(output.at(0).height(), 479);
}

TEST(RemapBilinear, MatchesReferenceOnSyntheticRectificationMap) {
  KernelCase test_case{"remap_bilinear", {}, {}, 0};
  test_case.inputs.push_back(random_plane(631, 479, kU8, 640, 25));
  test_case.inputs.push_back(make_synthetic_rectification_map(631, 479, {0.03, 0.95, -0.2, 0}));
  expect_all_back_ends_match_reference(test_case, {{631, 479}, {128, 32}});
}

TEST(RemapBilinear, TinyImagesAndTiles) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {17, 2}, {65, 3}, {130, 1}}) {
    KernelCase test_case{"remap_bilinear", {}, {}, 5};
    test_case.inputs.push_back(random_plane(width, height, kU8, width + 3, 26));
    test_case.inputs.push_back(random_map(width, height, 3, 27));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}, {1, 1}});
  }
}

Plane run_remap(const Plane& source, const Plane& map, BorderMode mode, uint32_t border_value, KernelBackend backend,
                simd::Isa isa, int tile_width = 64, int tile_height = 16) {
  const KernelDescriptor& kernel = testing::kernel_named("remap_bilinear");
  const PreparedKernel prepared = kernel.prepare({}, {{source.width(), source.height()}, {map.width(), map.height()}});
  Plane output(map.width(), map.height(), kU8);
  VectorNodeBinding binding{&kernel, prepared.params.get(), mode, border_value, {source.view(), map.view()},
                            {output.view()}};
  run_vector_node(binding, tile_width, tile_height, backend, isa);
  return output;
}

// Runs `check(backend, isa, label)` for every native level and the counting back end.
template <class Check>
void for_every_back_end(const Check& check) {
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, std::string("counting"));
}

TEST(RemapBilinear, GoldenZeroMapIsIdentity) {
  const Plane source = random_plane(97, 41, kU8, 128, 28);
  const Plane map = constant_map(97, 41, 0, 0);
  for_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    for (BorderMode mode : {BorderMode::replicate, BorderMode::constant}) {
      EXPECT_TRUE(testing::planes_equal(source, run_remap(source, map, mode, 7, backend, isa))) << label;
    }
  });
}

// dx = +32 (one pixel): out(x, y) = source(x + 1, y); the last column reads past the plane.
TEST(RemapBilinear, GoldenWholePixelShift) {
  const Plane source = random_plane(97, 41, kU8, 128, 29);
  const Plane map = constant_map(97, 41, 32, 0);
  for_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Plane replicate = run_remap(source, map, BorderMode::replicate, 0, backend, isa);
    const Plane constant = run_remap(source, map, BorderMode::constant, 200, backend, isa);
    for (int y = 0; y < 41; ++y) {
      for (int x = 0; x < 97; ++x) {
        const int inside = source.at<uint8_t>(std::min(x + 1, 96), y);
        ASSERT_EQ(replicate.at<uint8_t>(x, y), inside) << label << " x=" << x << " y=" << y;
        ASSERT_EQ(constant.at<uint8_t>(x, y), x == 96 ? 200 : inside) << label << " x=" << x << " y=" << y;
      }
    }
  });
}

// dx = 16 (half a pixel): (512 a + 512 b + 512) >> 10 = (a + b + 1) >> 1; dx = dy = 16:
// (256 (a + b + c + d) + 512) >> 10 = (a + b + c + d + 2) >> 2; dx = -1 (-1/32 px): floor gives the
// left neighbour with weight 1/32: (32 (l + 31 c) + 512) >> 10 = (l + 31 c + 16) >> 5.
TEST(RemapBilinear, GoldenFractionalShifts) {
  const Plane source = random_plane(70, 9, kU8, 96, 30);
  const Plane half_x = constant_map(70, 9, 16, 0);
  const Plane half_xy = constant_map(70, 9, 16, 16);
  const Plane minus_sixteenth = constant_map(70, 9, -1, 0);
  auto s = [&](int x, int y) { return int{source.at<uint8_t>(std::clamp(x, 0, 69), std::clamp(y, 0, 8))}; };
  for_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Plane a = run_remap(source, half_x, BorderMode::replicate, 0, backend, isa);
    const Plane b = run_remap(source, half_xy, BorderMode::replicate, 0, backend, isa);
    const Plane c = run_remap(source, minus_sixteenth, BorderMode::replicate, 0, backend, isa);
    for (int y = 0; y < 9; ++y) {
      for (int x = 0; x < 70; ++x) {
        ASSERT_EQ(a.at<uint8_t>(x, y), (s(x, y) + s(x + 1, y) + 1) >> 1) << label << " x=" << x << " y=" << y;
        ASSERT_EQ(b.at<uint8_t>(x, y), (s(x, y) + s(x + 1, y) + s(x, y + 1) + s(x + 1, y + 1) + 2) >> 2)
            << label << " x=" << x << " y=" << y;
        ASSERT_EQ(c.at<uint8_t>(x, y), (s(x - 1, y) + 31 * s(x, y) + 16) >> 5) << label << " x=" << x << " y=" << y;
      }
    }
  });
}

// The closed form of kernels/remap_bilinear.cpp's header comment (chunks of 64 pixels = the
// counting back end's u8 lanes).
simd::OpCounts remap_closed_form(const testing::TileWork& work, bool constant_border) {
  simd::OpCounts counts;
  counts[simd::OpClass::load] = 4 * work.chunks + work.tiles;
  counts[simd::OpClass::gather] = 16 * work.chunks;
  counts[simd::OpClass::store] = work.chunks;
  counts[simd::OpClass::arith] = 96 * work.chunks + work.tiles;
  counts[simd::OpClass::shift] = 36 * work.chunks;
  counts[simd::OpClass::logic] = (constant_border ? 40 : 8) * work.chunks;
  counts[simd::OpClass::compare] = (constant_border ? 16 : 0) * work.chunks;
  counts[simd::OpClass::multiply] = 20 * work.chunks;
  counts[simd::OpClass::permute] = 3 * work.chunks + work.rows + 10 * work.tiles;
  return counts;
}

TEST(RemapBilinear, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU8 == 64, "the closed form assumes 64 u8 lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 640, 480}, {1, 1, 1, 1},
                                               {65, 7, 65, 7}, {631, 479, 100, 37}, {200, 3, 7, 5}}) {
    KernelCase test_case{"remap_bilinear", {}, {}, 0};
    test_case.inputs.push_back(random_plane(shape.width, shape.height, kU8, 0, 31));
    test_case.inputs.push_back(random_map(shape.width, shape.height, 20, 32));
    const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 64);
    for (BorderMode mode : {BorderMode::replicate, BorderMode::constant}) {
      EXPECT_TRUE(testing::op_counts_equal(remap_closed_form(work, mode == BorderMode::constant),
                                           testing::count_ops(test_case, shape.tile_width, shape.tile_height, mode)))
          << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height
          << " border " << border_mode_name(mode);
    }
  }
}

TEST(RemapBilinear, SourceRectIsTileGrownByMaxDisplacementClippedToPlane) {
  const KernelDescriptor& kernel = testing::kernel_named("remap_bilinear");
  const PreparedKernel defaults = kernel.prepare({}, {{631, 479}, {631, 479}});
  const PixelRect box = kernel.source_rect(0, {100, 50, 164, 82}, {631, 479}, defaults.params.get());
  EXPECT_EQ(box.x0, 36);
  EXPECT_EQ(box.y0, 0);
  EXPECT_EQ(box.x1, 229);  // 164 + 64 + 1 (second tap)
  EXPECT_EQ(box.y1, 147);
  // A map larger than the source: a tile far right of the source still reads its last column.
  const PreparedKernel small = kernel.prepare({{"max_displacement_px", 8}}, {{100, 80}, {631, 479}});
  const PixelRect edge = kernel.source_rect(0, {500, 0, 564, 16}, {100, 80}, small.params.get());
  EXPECT_EQ(edge.x0, 99);
  EXPECT_EQ(edge.x1, 100);
  EXPECT_EQ(edge.y0, 0);
  EXPECT_EQ(edge.y1, 25);
}

TEST(RemapBilinear, RefusesBadParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("remap_bilinear");
  try {
    kernel.prepare({{"max_displacement_px", 5000}}, {{10, 10}, {10, 10}});
    FAIL() << "max_displacement_px = 5000 accepted";
  } catch (const KernelError& error) {
    EXPECT_NE(std::string(error.what()).find("max_displacement_px"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("5000"), std::string::npos) << error.what();
  }
  EXPECT_THROW(kernel.prepare({{"max_displacement_px", -1}}, {{10, 10}, {10, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"max_displacement", 8}}, {{10, 10}, {10, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({}, {{10, 10}}), KernelError);
}

// float -> Q5 -> float reproduces every source position within 1/64 px (rounding to nearest 1/32).
TEST(RemapTable, FloatMapRoundTripWithinHalfStep) {
  const int width = 211, height = 67, stride = 224;
  std::vector<float> map_x(static_cast<size_t>(stride) * height, -1e30f);  // padding must not be read
  std::vector<float> map_y(map_x.size(), -1e30f);
  std::mt19937 generator(33);
  std::uniform_real_distribution<float> delta(-1000.0f, 1000.0f);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      map_x[static_cast<size_t>(y) * stride + x] = static_cast<float>(x) + delta(generator);
      map_y[static_cast<size_t>(y) * stride + x] = static_cast<float>(y) + delta(generator);
    }
  }
  const Plane map = make_remap_q5_from_float(map_x.data(), map_y.data(), width, height, stride);
  double worst_px = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double source_x = x + map.row<int16_t>(y)[2 * x] / 32.0;
      const double source_y = y + map.row<int16_t>(y)[2 * x + 1] / 32.0;
      worst_px = std::max({worst_px, std::abs(source_x - map_x[static_cast<size_t>(y) * stride + x]),
                           std::abs(source_y - map_y[static_cast<size_t>(y) * stride + x])});
    }
  }
  EXPECT_LE(worst_px, 1.0 / 64 + 1e-4);
}

TEST(RemapTable, OutOfRangeDisplacementNamesThePixel) {
  std::vector<float> map_x(12 * 9), map_y(12 * 9);
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 12; ++x) {
      map_x[y * 12 + x] = static_cast<float>(x);
      map_y[y * 12 + x] = static_cast<float>(y);
    }
  }
  map_y[7 * 12 + 5] = 7 + 1024.0f;  // 1024 px is one step past +1023.96875
  try {
    make_remap_q5_from_float(map_x.data(), map_y.data(), 12, 9, 12);
    FAIL() << "a displacement of 1024 px accepted";
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("pixel (5, 7)"), std::string::npos) << message;
    EXPECT_NE(message.find("source_y"), std::string::npos) << message;
    EXPECT_NE(message.find("1024"), std::string::npos) << message;
  }
  map_y[7 * 12 + 5] = 7 + 1023.96875f;  // the largest value that fits
  EXPECT_NO_THROW(make_remap_q5_from_float(map_x.data(), map_y.data(), 12, 9, 12));
  map_y[7 * 12 + 5] = 7 - 1024.0f;  // the smallest
  EXPECT_NO_THROW(make_remap_q5_from_float(map_x.data(), map_y.data(), 12, 9, 12));
  map_x[0] = std::nanf("");
  EXPECT_THROW(make_remap_q5_from_float(map_x.data(), map_y.data(), 12, 9, 12), std::invalid_argument);
  EXPECT_THROW(make_remap_q5_from_float(map_x.data(), map_y.data(), 12, 9, 11), std::invalid_argument);
}

TEST(RemapTable, SyntheticMapIsSmoothAndWithinDefaultDisplacement) {
  const Plane map = make_synthetic_rectification_map(1920, 1080);
  int max_q5 = 0;
  for (int y = 0; y < map.height(); ++y) {
    for (int i = 0; i < 2 * map.width(); ++i) max_q5 = std::max(max_q5, std::abs(int{map.row<int16_t>(y)[i]}));
  }
  EXPECT_GT(max_q5, 32 * 5) << "the default model should move the corners by several pixels";
  EXPECT_LE(max_q5, 32 * 64) << "the default model should fit remap_bilinear's default max_displacement_px";
  // The centre pixel barely moves.
  EXPECT_LE(std::abs(int{map.row<int16_t>(540)[2 * 960]}), 32);
  EXPECT_THROW(make_synthetic_rectification_map(64, 64, {0.5, 1.0, 0.0, 0}), std::invalid_argument);
}

// A textured test image: smooth shading, edges and some noise (pure noise is the worst case for
// interpolation differences and unlike a camera image).
cv::Mat textured_image(int width, int height, uint32_t seed) {
  cv::Mat image(height, width, CV_8UC1);
  std::mt19937 generator(seed);
  std::normal_distribution<double> noise(0.0, 6.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double shade = 128 + 60 * std::sin(x * 0.05) * std::cos(y * 0.07) + ((x / 40 + y / 30) % 2 ? 40 : -40);
      image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(shade + noise(generator));
    }
  }
  return image;
}

// Fraction of pixels where |a - b| <= 1 and the largest difference.
std::pair<double, int> agreement(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  double max_difference = 0;
  cv::minMaxLoc(difference, nullptr, &max_difference);
  const int within = cv::countNonZero(difference <= 1);
  return {static_cast<double>(within) / static_cast<double>(a.total()), static_cast<int>(max_difference)};
}

// OpenCV's remap (INTER_LINEAR, 8-bit, float maps) rounds each position to 1/32 px (ties to even)
// and weighs with 15-bit weights that are 32 times ours; remap_q5 holds the same positions and the
// kernel rounds the same way, so the bits agree on every pixel, in both border modes, including
// positions exactly halfway between two 1/32 px steps (multiples of 1/64 px), positions far outside
// the source. (The Q4 kernel this replaced agreed within 1 grey level on 97.1 % of this image.)
TEST(RemapBilinear, GivesOpenCvRemapBitsOnFloatMaps) {
  const int width = 631, height = 479;
  const cv::Mat image = textured_image(width, height, 34);
  Plane source(width, height, kU8, 640);
  for (int y = 0; y < height; ++y) std::memcpy(source.row<uint8_t>(y), image.ptr<uint8_t>(y), width);
  std::vector<float> map_x, map_y;
  make_synthetic_rectification_float(width, height, {0.02, 0.97, -0.15, 0}, map_x, map_y);
  // Every 7th pixel of every 5th row exactly on a tie (a multiple of 1/64 px, odd in 1/64 steps),
  // every 11th far outside the source.
  std::mt19937 generator(35);
  std::uniform_int_distribution<int> odd64(-200, 200);
  for (int y = 0; y < height; y += 5) {
    for (int x = 0; x < width; x += 7) {
      const size_t index = static_cast<size_t>(y) * width + x;
      map_x[index] = static_cast<float>(x) + static_cast<float>(2 * odd64(generator) + 1) / 64.0f;
      map_y[index] = static_cast<float>(y) + static_cast<float>(2 * odd64(generator) + 1) / 64.0f;
      if (x % 11 == 0) map_x[index] = static_cast<float>(x) + (x % 2 ? 900.5f : -700.25f);
    }
  }
  const Plane map = make_remap_q5_from_float(map_x.data(), map_y.data(), width, height, width);
  const cv::Mat float_x(height, width, CV_32FC1, map_x.data());
  const cv::Mat float_y(height, width, CV_32FC1, map_y.data());
  for (BorderMode mode : {BorderMode::replicate, BorderMode::constant}) {
    const int cv_border = mode == BorderMode::replicate ? cv::BORDER_REPLICATE : cv::BORDER_CONSTANT;
    for_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
      const Plane ours = run_remap(source, map, mode, 77, backend, isa);
      const cv::Mat ours_mat(height, width, CV_8UC1, const_cast<uint8_t*>(ours.row<uint8_t>(0)),
                             static_cast<size_t>(ours.stride_bytes()));
      cv::Mat expected;
      cv::remap(image, expected, float_x, float_y, cv::INTER_LINEAR, cv_border, cv::Scalar(77));
      const auto [fraction, max_difference] = agreement(ours_mat, expected);
      cv::Mat difference;
      cv::absdiff(ours_mat, expected, difference);
      EXPECT_EQ(cv::countNonZero(difference), 0) << label << " " << border_mode_name(mode) << ": max difference "
                                                  << max_difference << ", within 1: " << fraction;
    });
  }
}

}  // namespace
}  // namespace lpstereo
