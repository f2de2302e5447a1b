// median3x3_s16: bit-exact against the reference on every back end and border mode, the invalid
// rule of kernels/median3x3_s16.cpp in golden cases, the closed-form op count, and (with OpenCV)
// equality with cv::medianBlur(3) on CV_16S wherever the centre is valid.
#include <gtest/gtest.h>

#include <random>

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

constexpr int16_t kInvalid = -16;  // min_disparity 0

// A disparity-like map: values from a few levels (ties), about `invalid_share` of them invalid, and
// a few extreme values, in a padded buffer.
Plane disparity_map(int width, int height, ptrdiff_t stride, uint32_t seed, double invalid_share) {
  Plane plane = random_plane(width, height, {ElementType::s16, 4}, stride, seed);
  std::mt19937 generator(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> level(0, 12);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double draw = unit(generator);
      int16_t value = static_cast<int16_t>(level(generator) * 40);
      if (draw < invalid_share) value = kInvalid;
      else if (draw > 0.995) value = static_cast<int16_t>(draw > 0.9975 ? 32767 : -32768);
      plane.at<int16_t>(x, y) = value;
    }
  }
  return plane;
}

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}, {1, 1}};

TEST(Median3x3S16, MatchesReferenceAtOddSizeInPaddedBuffer) {
  for (double invalid_share : {0.0, 0.3, 0.7}) {
    KernelCase test_case{"median3x3_s16", {{"invalid_q4", kInvalid}}, {}, 6};
    test_case.inputs.push_back(disparity_map(631, 479, 640 * 2 + 4, 31, invalid_share));
    expect_all_back_ends_match_reference(test_case, kTileShapes);
  }
}

TEST(Median3x3S16, MatchesReferenceOnRandomBitsAndTinyImages) {
  KernelCase random_bits{"median3x3_s16", {{"invalid_q4", -1008}}, {}, 2};
  random_bits.inputs.push_back(random_plane(203, 97, {ElementType::s16, 4}, 203 * 2 + 10, 32));
  expect_all_back_ends_match_reference(random_bits, {{203, 97}, {16, 8}, {3, 2}});
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {33, 2}, {65, 1}}) {
    KernelCase test_case{"median3x3_s16", {{"invalid_q4", kInvalid}}, {}, 4};
    test_case.inputs.push_back(disparity_map(width, height, width * 2 + 6, 33, 0.3));
    expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
  }
}

Plane run_median(const Plane& input, BorderMode mode, uint32_t border_value, KernelBackend backend, simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("median3x3_s16");
  const PreparedKernel prepared = kernel.prepare({{"invalid_q4", kInvalid}}, {{input.width(), input.height()}});
  Plane output(input.width(), input.height(), {ElementType::s16, 4});
  VectorNodeBinding binding{&kernel, prepared.params.get(), mode, border_value, {input.view()}, {output.view()}};
  run_vector_node(binding, input.width(), input.height(), backend, isa);
  return output;
}

Plane window_of(const std::vector<int16_t>& values) {
  Plane plane(3, 3, {ElementType::s16, 4});
  for (int i = 0; i < 9; ++i) plane.at<int16_t>(i % 3, i / 3) = values[static_cast<size_t>(i)];
  return plane;
}

// Golden windows (centre = element 4):
//   plain values {90, 10, 80, 20, 70, 30, 60, 40, 50} -> 50;
//   an invalid centre stays invalid even among eight valid neighbours;
//   four invalid neighbours around a valid centre: the median of the nine, invalid sorting first,
//     {-16 x4, 10, 20, 30, 40, 50} -> 10 (valid);
//   five invalid of nine around a valid centre -> invalid;
//   a corner of a 3x3 ramp with a constant border of -16 (invalid outside): five outside values ->
//     invalid; with the replicate border {1,1,2, 1,1,2, 4,4,5} x 16 -> 32.
TEST(Median3x3S16, GoldenValuesOfTheInvalidRule) {
  const Plane plain = window_of({90, 10, 80, 20, 70, 30, 60, 40, 50});
  const Plane invalid_centre = window_of({10, 10, 10, 10, kInvalid, 10, 10, 10, 10});
  const Plane four_invalid = window_of({kInvalid, 10, kInvalid, 20, 30, kInvalid, 40, kInvalid, 50});
  const Plane five_invalid = window_of({kInvalid, 10, kInvalid, 20, 30, kInvalid, kInvalid, kInvalid, 50});
  Plane ramp(3, 3, {ElementType::s16, 4});
  for (int i = 0; i < 9; ++i) ramp.at<int16_t>(i % 3, i / 3) = static_cast<int16_t>(16 * (i + 1));
  auto check = [&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    EXPECT_EQ(run_median(plain, BorderMode::replicate, 0, backend, isa).at<int16_t>(1, 1), 50) << label;
    EXPECT_EQ(run_median(invalid_centre, BorderMode::replicate, 0, backend, isa).at<int16_t>(1, 1), kInvalid) << label;
    EXPECT_EQ(run_median(four_invalid, BorderMode::replicate, 0, backend, isa).at<int16_t>(1, 1), 10) << label;
    EXPECT_EQ(run_median(five_invalid, BorderMode::replicate, 0, backend, isa).at<int16_t>(1, 1), kInvalid) << label;
    EXPECT_EQ(run_median(ramp, BorderMode::constant, static_cast<uint16_t>(kInvalid), backend, isa).at<int16_t>(0, 0), kInvalid)
        << label;
    EXPECT_EQ(run_median(ramp, BorderMode::replicate, 0, backend, isa).at<int16_t>(0, 0), 32) << label;
  };
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// The closed form of kernels/median3x3_s16.cpp: per chunk of 32 pixels (the counting back end's
// 16-bit lanes) 9 loads, 30 min/max, 1 compare, 1 select (logic), 1 store; per tile 1 broadcast.
TEST(Median3x3S16, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU16 == 32, "the closed form assumes 32 16-bit lanes");
  struct Shape {
    int width, height, tile_width, tile_height;
  };
  for (const Shape& shape : std::vector<Shape>{{631, 479, 631, 479}, {640, 480, 640, 16}, {1, 1, 1, 1}, {33, 7, 33, 7},
                                               {631, 479, 100, 37}, {200, 3, 7, 5}}) {
    KernelCase test_case{"median3x3_s16", {{"invalid_q4", kInvalid}}, {}, 0};
    test_case.inputs.push_back(disparity_map(shape.width, shape.height, 0, 34, 0.2));
    const testing::TileWork work = testing::tile_work(shape.width, shape.height, shape.tile_width, shape.tile_height, 32);
    simd::OpCounts expected;
    expected[simd::OpClass::load] = 9 * work.chunks;
    expected[simd::OpClass::arith] = 30 * work.chunks;
    expected[simd::OpClass::compare] = work.chunks;
    expected[simd::OpClass::logic] = work.chunks;
    expected[simd::OpClass::store] = work.chunks;
    expected[simd::OpClass::permute] = work.tiles;
    for (BorderMode mode : {BorderMode::replicate, BorderMode::constant}) {
      EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, shape.tile_width, shape.tile_height, mode)))
          << shape.width << "x" << shape.height << " in tiles of " << shape.tile_width << "x" << shape.tile_height
          << " border " << border_mode_name(mode);
    }
  }
}

TEST(Median3x3S16MustFail, RefusesUnknownAndOutOfRangeParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("median3x3_s16");
  EXPECT_THROW(kernel.prepare({{"radius", 2}}, {{10, 10}}), KernelError);
  try {
    kernel.prepare({{"invalid_q4", 40000}}, {{10, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "parameter 'invalid_q4': expected an integer in [-32768, 32767], got 40000");
  }
}

#ifdef LPSTEREO_TEST_WITH_OPENCV
// Where the centre is valid the kernel is cv::medianBlur(3) on CV_16S (border replicate); where it
// is invalid it stays invalid.
TEST(Median3x3S16, EqualsOpenCvMedianBlurOnValidCentres) {
  const Plane input = disparity_map(631, 479, 0, 35, 0.3);
  const cv::Mat source(input.height(), input.width(), CV_16SC1, input.row<int16_t>(0), static_cast<size_t>(input.stride_bytes()));
  cv::Mat expected;
  cv::medianBlur(source, expected, 3);
  const Plane output = run_median(input, BorderMode::replicate, 0, KernelBackend::native, simd::active_isa());
  int invalid_centres = 0;
  for (int y = 0; y < input.height(); ++y) {
    for (int x = 0; x < input.width(); ++x) {
      const bool centre_invalid = input.at<int16_t>(x, y) == kInvalid;
      invalid_centres += centre_invalid ? 1 : 0;
      ASSERT_EQ(output.at<int16_t>(x, y), centre_invalid ? kInvalid : expected.at<int16_t>(y, x)) << "x=" << x << " y=" << y;
    }
  }
  EXPECT_GT(invalid_centres, 0);
}
#endif

}  // namespace
}  // namespace lpstereo
