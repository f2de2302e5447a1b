// census5x5, census9x7 and census9x9_sparse: bit-exact against the scalar reference on every back
// end, closed-form op count, and golden-bit checks of the signature layout.
#include <gtest/gtest.h>

#include "dag/tile_executor.h"
#include "kernels/census_window.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

const std::vector<std::pair<int, int>> kTileShapes = {{631, 479}, {64, 16}, {100, 37}, {7, 5}};

TEST(Census, Census5x5MatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"census5x5", {}, {}, 36};
  test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 1));
  expect_all_back_ends_match_reference(test_case, kTileShapes);
}

TEST(Census, Census9x7MatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"census9x7", {}, {}, 24};
  test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 2));
  expect_all_back_ends_match_reference(test_case, kTileShapes);
}

TEST(Census, Census9x9SparseMatchesReferenceAtOddSizeInPaddedBuffer) {
  KernelCase test_case{"census9x9_sparse", {}, {}, 24};
  test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 5));
  expect_all_back_ends_match_reference(test_case, kTileShapes);
}

TEST(Census, TinyImagesSmallerThanTheWindow) {
  for (const char* name : {"census5x5", "census9x7", "census9x9_sparse"}) {
    for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {3, 2}, {65, 3}, {130, 1}}) {
      KernelCase test_case{name, {}, {}, 8};
      test_case.inputs.push_back(random_plane(width, height, {ElementType::u8, 0}, width + 3, 3));
      expect_all_back_ends_match_reference(test_case, {{width, height}, {2, 1}});
    }
  }
}

// Golden bits: a centre of 100 with the neighbours in raster order darker at positions 0, 7 and 23
// (5x5: positions 0..23, centre skipped) gives bits 0, 7 and 23.
TEST(Census, Census5x5GoldenBits) {
  Plane input(5, 5, {ElementType::u8, 0});
  int neighbour = 0;
  for (int y = 0; y < 5; ++y) {
    for (int x = 0; x < 5; ++x) {
      if (x == 2 && y == 2) {
        input.at<uint8_t>(x, y) = 100;
        continue;
      }
      input.at<uint8_t>(x, y) = (neighbour == 0 || neighbour == 7 || neighbour == 23) ? 99 : 100;
      ++neighbour;
    }
  }
  const KernelDescriptor& kernel = testing::kernel_named("census5x5");
  for (simd::Isa isa : simd::available_isas()) {
    Plane output(5, 5, {ElementType::census32, 0});
    VectorNodeBinding binding{&kernel, nullptr, BorderMode::replicate, 0, {input.view()}, {output.view()}};
    run_vector_node(binding, 5, 5, KernelBackend::native, isa);
    EXPECT_EQ(output.at<uint32_t>(2, 2), (1u << 0) | (1u << 7) | (1u << 23)) << simd::isa_name(isa);
  }
}

// Golden bits of the sparse census: the samples sit two pixels apart in a 9x9 window, numbered in
// raster order over the 5x5 samples with the centre (sample 12) skipped; darker samples at (0, 0),
// (8, 0), (2, 4) and (8, 8) of the window are bits 0, 4, 11 and 23. A darker pixel between samples,
// at (1, 1), changes nothing.
TEST(Census, Census9x9SparseGoldenBits) {
  Plane input(9, 9, {ElementType::u8, 0});
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 9; ++x) input.at<uint8_t>(x, y) = 100;
  }
  for (auto [x, y] : std::vector<std::pair<int, int>>{{0, 0}, {8, 0}, {2, 4}, {8, 8}, {1, 1}}) input.at<uint8_t>(x, y) = 99;
  const KernelDescriptor& kernel = testing::kernel_named("census9x9_sparse");
  EXPECT_EQ(kernel.halo, (Halo{4, 4, 4, 4}));
  for (simd::Isa isa : simd::available_isas()) {
    Plane output(9, 9, {ElementType::census32, 0});
    VectorNodeBinding binding{&kernel, nullptr, BorderMode::replicate, 0, {input.view()}, {output.view()}};
    run_vector_node(binding, 9, 9, KernelBackend::native, isa);
    EXPECT_EQ(output.at<uint32_t>(4, 4), (1u << 0) | (1u << 4) | (1u << 11) | (1u << 23)) << simd::isa_name(isa);
  }
}

// The closed form of census_window.h, for one tile covering a W x H image:
//   chunks = H * ceil(W / 64); load = 25 chunks; compare = 24 chunks; logic = 48 chunks;
//   permute = 8 chunks + 9 (broadcasts); store = H * ceil(W / 16).
simd::OpCounts census5x5_closed_form(int64_t width, int64_t height) {
  const int64_t chunks = height * ((width + 63) / 64);
  simd::OpCounts counts;
  counts[simd::OpClass::load] = 25 * chunks;
  counts[simd::OpClass::compare] = 24 * chunks;
  counts[simd::OpClass::logic] = 48 * chunks;
  counts[simd::OpClass::permute] = 8 * chunks + 9;
  counts[simd::OpClass::store] = height * ((width + 15) / 16);
  return counts;
}

// census9x9_sparse has the same 24 samples, so the same closed form.
TEST(Census, Census5x5AndSparse9x9CountedOpsEqualClosedForm) {
  for (const char* name : {"census5x5", "census9x9_sparse"}) {
    for (auto [width, height] : std::vector<std::pair<int, int>>{{631, 479}, {640, 480}, {1, 1}, {65, 7}, {200, 3}}) {
      KernelCase test_case{name, {}, {}, 0};
      test_case.inputs.push_back(random_plane(width, height, {ElementType::u8, 0}, 0, 4));
      EXPECT_TRUE(testing::op_counts_equal(census5x5_closed_form(width, height), testing::count_ops(test_case, width, height)))
          << name << " " << width << "x" << height;
    }
  }
}

}  // namespace
}  // namespace lpstereo
