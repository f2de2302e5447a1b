// census_wta_disparity: bit-exact on every back end, closed-form op count, golden disparity.
#include <gtest/gtest.h>

#include "dag/tile_executor.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;
using testing::sparse_census;


TEST(CensusWtaDisparity, MatchesReferenceAtOddSizeInPaddedBuffer) {
  for (auto [min_disparity, num_disparities] : std::vector<std::pair<int, int>>{{0, 1}, {0, 17}, {0, 64}, {-9, 20}, {-30, 10}, {5, 12}}) {
    KernelCase test_case{"census_wta_disparity",
                         {{"min_disparity", min_disparity}, {"num_disparities", num_disparities}, {"max_cost_bits", 4}}, {}, 10};
    test_case.inputs.push_back(sparse_census(631, 97, 640 * 4, 11));
    test_case.inputs.push_back(sparse_census(631, 97, 640 * 4 + 12, 12));
    expect_all_back_ends_match_reference(test_case, {{631, 97}, {64, 16}, {33, 7}});
  }
}

TEST(CensusWtaDisparity, FindsAKnownShift) {
  // The right view is the left view shifted left by 9 columns: every pixel with x >= 9 has
  // disparity 9 exactly (cost 0), for every back end.
  const int width = 101, height = 5, shift = 9;
  Plane left = random_plane(width, height, {ElementType::census32, 0}, 0, 5);
  Plane right(width, height, {ElementType::census32, 0});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) right.at<uint32_t>(x, y) = left.at<uint32_t>(std::min(width - 1, x + shift), y);
  }
  const KernelDescriptor& kernel = testing::kernel_named("census_wta_disparity");
  const PreparedKernel prepared = kernel.prepare({{"num_disparities", 32}, {"max_cost_bits", 0}}, {{width, height}, {width, height}});
  for (simd::Isa isa : simd::available_isas()) {
    Plane output(width, height, {ElementType::s16, 4});
    VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {left.view(), right.view()},
                              {output.view()}, prepared.input_halos};
    run_vector_node(binding, 40, 3, KernelBackend::native, isa);
    for (int y = 0; y < height; ++y) {
      for (int x = shift; x < width - shift; ++x) {
        ASSERT_EQ(output.at<int16_t>(x, y), shift * 16) << "x=" << x << " y=" << y << " " << simd::isa_name(isa);
      }
    }
  }
}

TEST(CensusWtaDisparity, FindsANegativeShift) {
  // The right view is the left view shifted right by 6 columns: disparity -6 with a range [-10, 5).
  const int width = 90, height = 4, shift = -6;
  Plane left = random_plane(width, height, {ElementType::census32, 0}, 0, 6);
  Plane right(width, height, {ElementType::census32, 0});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) right.at<uint32_t>(x, y) = left.at<uint32_t>(std::max(0, x + shift), y);
  }
  const KernelDescriptor& kernel = testing::kernel_named("census_wta_disparity");
  const PreparedKernel prepared = kernel.prepare({{"min_disparity", -10}, {"num_disparities", 15}, {"max_cost_bits", 0}},
                                                 {{width, height}, {width, height}});
  for (simd::Isa isa : simd::available_isas()) {
    Plane output(width, height, {ElementType::s16, 4});
    VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {left.view(), right.view()},
                              {output.view()}, prepared.input_halos};
    run_vector_node(binding, 32, 2, KernelBackend::native, isa);
    for (int y = 0; y < height; ++y) {
      for (int x = 10; x < width - 10; ++x) {
        ASSERT_EQ(output.at<int16_t>(x, y), shift * 16) << "x=" << x << " y=" << y << " " << simd::isa_name(isa);
      }
    }
  }
}

TEST(CensusWtaDisparity, CountedOpsEqualClosedForm) {
  const KernelDescriptor& kernel = testing::kernel_named("census_wta_disparity");
  for (auto [width, height, num_disparities] : std::vector<std::tuple<int, int, int>>{{631, 7, 16}, {32, 1, 1}, {100, 3, 64}}) {
    Plane left = random_plane(width, height, {ElementType::census32, 0}, 0, 1);
    Plane right = random_plane(width, height, {ElementType::census32, 0}, 0, 2);
    Plane output(width, height, {ElementType::s16, 4});
    const PreparedKernel prepared =
        kernel.prepare({{"num_disparities", num_disparities}}, {{width, height}, {width, height}});
    VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {left.view(), right.view()},
                              {output.view()}, prepared.input_halos};
    simd::OpCounts counts;
    run_vector_node(binding, width, height, KernelBackend::counting, simd::Isa::scalar, &counts);
    const int64_t chunks = static_cast<int64_t>(height) * ((width + 31) / 32);
    const int64_t d = num_disparities;
    EXPECT_EQ(counts[simd::OpClass::load], chunks * (2 + 2 * d));
    EXPECT_EQ(counts[simd::OpClass::logic], chunks * (4 * d + 2));
    EXPECT_EQ(counts[simd::OpClass::popcount], chunks * 2 * d);
    EXPECT_EQ(counts[simd::OpClass::compare], chunks * (2 * d + 2));
    EXPECT_EQ(counts[simd::OpClass::arith], chunks * 4 * d);
    EXPECT_EQ(counts[simd::OpClass::shift], chunks * 2);
    EXPECT_EQ(counts[simd::OpClass::permute], chunks + 6);
    EXPECT_EQ(counts[simd::OpClass::store], chunks);
  }
}

TEST(CensusWtaDisparity, RefusesBadParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("census_wta_disparity");
  EXPECT_THROW(kernel.prepare({{"num_disparities", 0}}, {{8, 8}, {8, 8}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"num_disparities", 16}}, {{8, 8}, {9, 8}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"max_disparty", 16}}, {{8, 8}, {8, 8}}), KernelError);
}

}  // namespace
}  // namespace lpstereo
