// SGM kernels (sgm_4path, sgm_8path_forward / _backward, the path-pair and select passes, the banded
// 8-path schedule's checkpoints and bands, census64 variants): bit-exact against the
// scalar reference on every back end at odd sizes in padded buffers with several tile heights (the
// row state carried across tiles), golden disparities of shifted patterns, the overflow bound at the
// largest range and penalties, closed-form op counts, and parameter errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "dag/tile_executor.h"
#include "kernels/sgm_core.h"
#include "kernels/sgm_reference.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

// A u8 texture and a right view that sees it shifted by `disparity` px (x_right = x - disparity),
// plus noise: census of both gives plausible, structured costs (not white noise).
struct CensusPair {
  Plane left, right;
};

Plane random_census(int width, int height, ElementType type, ptrdiff_t stride, uint32_t seed) {
  Plane plane = random_plane(width, height, {type, 0}, stride, seed);
  // Keep the signatures to the census widths (24 / 62 bits) so costs stay in range.
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (type == ElementType::census32) plane.at<uint32_t>(x, y) &= 0x00FFFFFFu;
      else plane.at<uint64_t>(x, y) &= 0x3FFFFFFFFFFFFFFFull;
    }
  }
  return plane;
}

// Right census = left census shifted by a smooth disparity field (0.. max_shift), with a few
// flipped bits: aggregation has real structure to find.
CensusPair shifted_census(int width, int height, ElementType type, ptrdiff_t stride, int min_shift, int max_shift,
                          uint32_t seed) {
  CensusPair pair{random_census(width, height, type, stride, seed), Plane(width, height, {type, 0}, stride)};
  std::mt19937 generator(seed + 1);
  std::uniform_int_distribution<int> bit(0, type == ElementType::census32 ? 23 : 61);
  std::uniform_int_distribution<int> chance(0, 9);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int shift = min_shift + (max_shift - min_shift) * ((x / 17 + y / 11) % 4) / 3;
      const int source = std::clamp(x + shift, 0, width - 1);
      if (type == ElementType::census32) {
        uint32_t word = pair.left.at<uint32_t>(source, y);
        if (chance(generator) == 0) word ^= 1u << bit(generator);
        pair.right.at<uint32_t>(x, y) = word;
      } else {
        uint64_t word = pair.left.at<uint64_t>(source, y);
        if (chance(generator) == 0) word ^= 1ull << bit(generator);
        pair.right.at<uint64_t>(x, y) = word;
      }
    }
  }
  return pair;
}

nlohmann::json sgm_params(int min_disparity, int num_disparities, int p1, int p2, int uniqueness, int subpixel,
                          int lr_max_diff) {
  return {{"min_disparity", min_disparity}, {"num_disparities", num_disparities}, {"p1", p1}, {"p2", p2},
          {"uniqueness_percent", uniqueness}, {"subpixel", subpixel}, {"lr_max_diff", lr_max_diff}};
}

Plane reference_forward_sums(const Plane& left, const Plane& right, const nlohmann::json& params, int word_bytes);
nlohmann::json forward_params(const nlohmann::json& params);

struct RangeCase {
  int min_disparity, num_disparities, uniqueness, subpixel, lr_max_diff;
};

// Ranges: a full and a partial last vector on every back end, negative ranges, one disparity, and
// 64 / 128 disparities, which run the bodies specialised for 2, 4 and 8 vectors on the native levels.
const std::vector<RangeCase> kRanges = {{0, 32, 10, 1, 1}, {0, 17, 0, 1, -1}, {-9, 20, 15, 1, 0}, {-30, 10, 5, 0, 2},
                                        {3, 1, 0, 1, 1},   {0, 40, 50, 1, 3}, {0, 64, 10, 1, 1}, {-7, 128, 5, 1, 2}};

TEST(Sgm4Path, MatchesReferenceAtOddSizesInPaddedBuffersAcrossTileHeights) {
  for (const RangeCase& range : kRanges) {
    KernelCase test_case{"sgm_4path", sgm_params(range.min_disparity, range.num_disparities, 5, 60, range.uniqueness,
                                                 range.subpixel, range.lr_max_diff),
                         {}, 10};
    CensusPair pair = shifted_census(53, 23, ElementType::census32, 64 * 4, std::max(range.min_disparity, -5),
                                     range.min_disparity + range.num_disparities - 1, 7);
    test_case.inputs.push_back(std::move(pair.left));
    test_case.inputs.push_back(std::move(pair.right));
    SCOPED_TRACE("min_disparity " + std::to_string(range.min_disparity) + " D " + std::to_string(range.num_disparities));
    expect_all_back_ends_match_reference(test_case, {{53, 23}, {53, 5}, {53, 1}});
  }
}

TEST(Sgm4Path, TinyImages) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{1, 1}, {2, 3}, {3, 1}, {5, 2}}) {
    const nlohmann::json params = sgm_params(-2, 7, 3, 20, 10, 1, 1);
    KernelCase single{"sgm_4path", params, {random_census(width, height, ElementType::census32, width * 4 + 8, 4),
                                            random_census(width, height, ElementType::census32, width * 4, 5)}, 6};
    expect_all_back_ends_match_reference(single, {{width, height}, {width, 1}});
    KernelCase backward{"sgm_8path_backward", params, {single.inputs[0], single.inputs[1],
                                                       reference_forward_sums(single.inputs[0], single.inputs[1], forward_params(params), 4)}, 2};
    expect_all_back_ends_match_reference(backward, {{width, height}, {width, 1}});
  }
}

TEST(Sgm4Path, Census64MatchesReference) {
  KernelCase test_case{"sgm_4path_census64", sgm_params(-3, 35, 9, 110, 10, 1, 1), {}, 6};
  CensusPair pair = shifted_census(41, 13, ElementType::census64, 48 * 8, 0, 20, 9);
  test_case.inputs.push_back(std::move(pair.left));
  test_case.inputs.push_back(std::move(pair.right));
  expect_all_back_ends_match_reference(test_case, {{41, 13}, {41, 4}});
}

// The sums a sums-writing SGM kernel's reference gives for a census pair (u16, W*D per row): the
// forward paths' (sgm_8path_forward, the backward kernel's third input) or the backward paths'
// (sgm_8path_backward_sums, sgm_sums_select's second input).
Plane reference_sums(const std::string& kernel_name, const Plane& left, const Plane& right, const nlohmann::json& params) {
  const KernelDescriptor& kernel = testing::kernel_named(kernel_name);
  const PreparedKernel prepared = kernel.prepare(params, {{left.width(), left.height()}, {right.width(), right.height()}});
  const PlaneShape shape = prepared.output_shapes.at(0);
  const BufferFormat format = kernel.ports.at(2).format;  // the output port (sums u16, checkpoints bytes)
  Plane sums(shape.width, shape.height, format, shape.width * element_bytes(format.type) + 6);
  kernel.reference({left.view(), right.view()}, {sums.view()}, prepared.params.get(), BorderMode::replicate, 0);
  return sums;
}

Plane reference_forward_sums(const Plane& left, const Plane& right, const nlohmann::json& params, int word_bytes) {
  return reference_sums(word_bytes == 4 ? "sgm_8path_forward" : "sgm_8path_forward_census64", left, right, params);
}

Plane reference_backward_sums(const Plane& left, const Plane& right, const nlohmann::json& params, int word_bytes) {
  return reference_sums(word_bytes == 4 ? "sgm_8path_backward_sums" : "sgm_8path_backward_sums_census64", left, right, params);
}

nlohmann::json forward_params(const nlohmann::json& params) {
  nlohmann::json result = params;
  result.erase("uniqueness_percent");
  result.erase("subpixel");
  result.erase("lr_max_diff");
  return result;
}

TEST(Sgm8Path, ForwardAndBackwardMatchReferenceAcrossTileHeights) {
  for (const RangeCase& range : kRanges) {
    const nlohmann::json params = sgm_params(range.min_disparity, range.num_disparities, 6, 70, range.uniqueness,
                                             range.subpixel, range.lr_max_diff);
    CensusPair pair = shifted_census(47, 19, ElementType::census32, 56 * 4, std::max(range.min_disparity, -5),
                                     range.min_disparity + range.num_disparities - 1, 21);
    SCOPED_TRACE("min_disparity " + std::to_string(range.min_disparity) + " D " + std::to_string(range.num_disparities));
    KernelCase forward{"sgm_8path_forward", forward_params(params), {}, 4};
    forward.inputs = {pair.left, pair.right};
    expect_all_back_ends_match_reference(forward, {{47 * range.num_disparities, 19}, {47 * range.num_disparities, 4}});
    KernelCase backward{"sgm_8path_backward", params, {}, 8};
    backward.inputs = {pair.left, pair.right, reference_forward_sums(pair.left, pair.right, forward_params(params), 4)};
    expect_all_back_ends_match_reference(backward, {{47, 19}, {47, 6}, {47, 1}});
  }
}

// A disparity map (s16 Q4) of the image's size from a selecting kernel's scalar reference.
Plane reference_disparity(const std::string& kernel_name, const std::vector<const Plane*>& inputs, const nlohmann::json& params,
                          int width, int height) {
  const KernelDescriptor& kernel = testing::kernel_named(kernel_name);
  std::vector<PlaneShape> shapes;
  std::vector<PlaneView> views;
  for (const Plane* input : inputs) {
    shapes.push_back({input->width(), input->height()});
    views.push_back(input->view());
  }
  const PreparedKernel prepared = kernel.prepare(params, shapes);
  Plane disparity(width, height, {ElementType::s16, 4});
  kernel.reference(views, {disparity.view()}, prepared.params.get(), BorderMode::replicate, 0);
  return disparity;
}

// sgm_sums_select over two sums planes, through the tile executor on the native (widest level) and
// counting back ends, gives `expected` bit for bit.
void expect_select_gives(const Plane& first_sums, const Plane& second_sums, const nlohmann::json& params, const Plane& expected,
                         int tile_height) {
  const KernelDescriptor& selector = testing::kernel_named("sgm_sums_select");
  const PreparedKernel prepared = selector.prepare(
      params, {{first_sums.width(), first_sums.height()}, {second_sums.width(), second_sums.height()}});
  for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
    Plane actual(expected.width(), expected.height(), {ElementType::s16, 4});
    VectorNodeBinding binding{&selector, prepared.params.get(), BorderMode::replicate, 0,
                              {first_sums.view(), second_sums.view()}, {actual.view()}, prepared.input_halos};
    run_vector_node(binding, expected.width(), tile_height, backend, simd::available_isas().back());
    for (int y = 0; y < expected.height(); ++y) {
      for (int x = 0; x < expected.width(); ++x) {
        ASSERT_EQ(actual.at<int16_t>(x, y), expected.at<int16_t>(x, y)) << "x=" << x << " y=" << y;
      }
    }
  }
}

// The host-parallel 8-path pair: the backward paths' sums on their own, and the selection from both
// sums, against the reference at odd sizes across tile heights; and its output equals the two-pass
// pair's (sgm_8path_forward + sgm_8path_backward) bit for bit, so the engine may pick either.
TEST(Sgm8Path, BackwardSumsAndSelectMatchReferenceAndTheTwoPassPair) {
  for (const RangeCase& range : kRanges) {
    const nlohmann::json params = sgm_params(range.min_disparity, range.num_disparities, 6, 70, range.uniqueness,
                                             range.subpixel, range.lr_max_diff);
    CensusPair pair = shifted_census(45, 17, ElementType::census32, 52 * 4, std::max(range.min_disparity, -5),
                                     range.min_disparity + range.num_disparities - 1, 33);
    SCOPED_TRACE("min_disparity " + std::to_string(range.min_disparity) + " D " + std::to_string(range.num_disparities));
    const int sums_width = 45 * range.num_disparities;
    KernelCase backward_sums{"sgm_8path_backward_sums", forward_params(params), {pair.left, pair.right}, 6};
    expect_all_back_ends_match_reference(backward_sums, {{sums_width, 17}, {sums_width, 5}, {sums_width, 1}});
    const Plane forward = reference_forward_sums(pair.left, pair.right, forward_params(params), 4);
    const Plane backward = reference_backward_sums(pair.left, pair.right, forward_params(params), 4);
    KernelCase select{"sgm_sums_select", params, {forward, backward}, 4};
    expect_all_back_ends_match_reference(select, {{45, 17}, {45, 4}, {45, 1}});

    const Plane two_pass = reference_disparity("sgm_8path_backward", {&pair.left, &pair.right, &forward}, params, 45, 17);
    expect_select_gives(forward, backward, params, two_pass, 5);
  }
}

// The banded 8-path schedule (kernels/sgm_8path_bands.cpp): both checkpoint passes against the
// reference at odd sizes in padded buffers across tile heights (in bands; the row state carried
// across tiles), sgm_8path_bands from those checkpoints against the reference, and its map equals
// the two-pass pair's (sgm_8path_forward + sgm_8path_backward) bit for bit. Heights: three bands with
// a short last one, exactly one band, one band and one row; every range of kRanges (the bodies for
// 2, 4 and 8 vectors, partial vectors, negative ranges, one disparity).
TEST(Sgm8PathBands, CheckpointsAndBandsMatchReferenceAndTheTwoPassPair) {
  const std::vector<std::pair<int, int>> sizes = {{37, 150}, {29, 64}, {31, 65}};
  for (const RangeCase& range : kRanges) {
    for (auto [width, height] : sizes) {
      const nlohmann::json params = sgm_params(range.min_disparity, range.num_disparities, 6, 70, range.uniqueness,
                                               range.subpixel, range.lr_max_diff);
      CensusPair pair = shifted_census(width, height, ElementType::census32, (width + 9) * 4, std::max(range.min_disparity, -5),
                                       range.min_disparity + range.num_disparities - 1, 41);
      SCOPED_TRACE("min_disparity " + std::to_string(range.min_disparity) + " D " + std::to_string(range.num_disparities) +
                   ", " + std::to_string(width) + "x" + std::to_string(height));
      const int checkpoint_width = 3 * width * range.num_disparities;
      const int bands = kernels::sgm_band_count(height);
      for (const char* name : {"sgm_8path_forward_checkpoints", "sgm_8path_backward_checkpoints"}) {
        KernelCase checkpoints{name, forward_params(params), {pair.left, pair.right}, 6};
        expect_all_back_ends_match_reference(checkpoints, {{checkpoint_width, bands}, {checkpoint_width, 1}});
      }
      const Plane forward = reference_sums("sgm_8path_forward_checkpoints", pair.left, pair.right, forward_params(params));
      const Plane backward = reference_sums("sgm_8path_backward_checkpoints", pair.left, pair.right, forward_params(params));
      KernelCase banded{"sgm_8path_bands", params, {pair.left, pair.right, forward, backward}, 4};
      expect_all_back_ends_match_reference(banded, {{width, height}, {width, kernels::kSgmBandRows}, {width, 2 * kernels::kSgmBandRows}});
      const Plane forward_sums = reference_forward_sums(pair.left, pair.right, forward_params(params), 4);
      const Plane two_pass =
          reference_disparity("sgm_8path_backward", {&pair.left, &pair.right, &forward_sums}, params, width, height);
      const Plane by_bands =
          reference_disparity("sgm_8path_bands", {&pair.left, &pair.right, &forward, &backward}, params, width, height);
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) ASSERT_EQ(by_bands.at<int16_t>(x, y), two_pass.at<int16_t>(x, y)) << x << "," << y;
      }
    }
  }
}

// Checkpoint values are u8 while the path costs' bound Cmax + P2 (Cmax <= the census word's bits)
// fits a byte, u16 above: at the largest P2 kept in bytes (223 on census32, 191 on census64) and at
// the next P2 up, the checkpoints match the reference on every back end (the reference refuses a
// value above 255 in a byte) and the bands' map equals the two-pass pair's (no value was cut).
TEST(Sgm8PathBands, CheckpointValuesAreBytesExactlyWhileTheBoundFits) {
  struct Case {
    ElementType census;
    int word_bytes, p2, value_bytes;
    const char* suffix;
  };
  for (const Case& c : {Case{ElementType::census32, 4, 223, 1, ""}, Case{ElementType::census32, 4, 224, 2, ""},
                        Case{ElementType::census64, 8, 191, 1, "_census64"}, Case{ElementType::census64, 8, 192, 2, "_census64"},
                        Case{ElementType::census32, 4, 4000, 2, ""}}) {
    SCOPED_TRACE(std::string(c.suffix) + " P2 " + std::to_string(c.p2));
    const nlohmann::json params = sgm_params(-2, 21, 7, c.p2, 10, 1, 1);
    kernels::SgmParams typed;
    typed.p2 = c.p2;
    ASSERT_EQ(kernels::sgm_checkpoint_value_bytes(typed, c.word_bytes), c.value_bytes);
    CensusPair pair = shifted_census(23, 131, c.census, 30 * c.word_bytes, 0, 18, 57);
    const std::string forward_name = std::string("sgm_8path_forward_checkpoints") + c.suffix;
    const std::string backward_name = std::string("sgm_8path_backward_checkpoints") + c.suffix;
    const int checkpoint_width = 3 * 23 * 21 * c.value_bytes;
    for (const std::string& name : {forward_name, backward_name}) {
      KernelCase checkpoints{name, forward_params(params), {pair.left, pair.right}, 5};
      expect_all_back_ends_match_reference(checkpoints, {{checkpoint_width, 3}, {checkpoint_width, 1}});
    }
    const Plane forward = reference_sums(forward_name, pair.left, pair.right, forward_params(params));
    const Plane backward = reference_sums(backward_name, pair.left, pair.right, forward_params(params));
    ASSERT_EQ(forward.width(), checkpoint_width);
    const Plane forward_sums = reference_forward_sums(pair.left, pair.right, forward_params(params), c.word_bytes);
    const Plane two_pass = reference_disparity(std::string("sgm_8path_backward") + c.suffix, {&pair.left, &pair.right, &forward_sums},
                                               params, 23, 131);
    const Plane by_bands = reference_disparity(std::string("sgm_8path_bands") + c.suffix, {&pair.left, &pair.right, &forward, &backward},
                                               params, 23, 131);
    for (int y = 0; y < 131; ++y) {
      for (int x = 0; x < 23; ++x) ASSERT_EQ(by_bands.at<int16_t>(x, y), two_pass.at<int16_t>(x, y)) << x << "," << y;
    }
    // The bands kernel itself (native and counting, every ISA) from those checkpoints.
    KernelCase banded{std::string("sgm_8path_bands") + c.suffix, params, {pair.left, pair.right, forward, backward}, 4};
    expect_all_back_ends_match_reference(banded, {{23, 131}, {23, kernels::kSgmBandRows}});
  }
}

// The checkpoints are what the bands restore: with them zeroed (the frame start's state for every
// band) the bands' map differs from the two-pass pair's, so the restore is what makes it equal.
TEST(Sgm8PathBands, ZeroCheckpointsGiveADifferentMap) {
  const nlohmann::json params = sgm_params(0, 32, 6, 70, 10, 1, 1);
  CensusPair pair = shifted_census(41, 150, ElementType::census32, 41 * 4, 0, 31, 43);
  const Plane forward = reference_sums("sgm_8path_forward_checkpoints", pair.left, pair.right, forward_params(params));
  const Plane backward = reference_sums("sgm_8path_backward_checkpoints", pair.left, pair.right, forward_params(params));
  Plane zero_forward(forward.width(), forward.height(), forward.format());
  Plane zero_backward(backward.width(), backward.height(), backward.format());
  const KernelDescriptor& kernel = testing::kernel_named("sgm_8path_bands");
  const PreparedKernel prepared = kernel.prepare(params, {{41, 150}, {41, 150}, {forward.width(), forward.height()},
                                                          {backward.width(), backward.height()}});
  auto run = [&](const Plane& forward_checkpoints, const Plane& backward_checkpoints) {
    Plane disparity(41, 150, {ElementType::s16, 4});
    VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0,
                              {pair.left.view(), pair.right.view(), forward_checkpoints.view(), backward_checkpoints.view()},
                              {disparity.view()}, prepared.input_halos};
    run_vector_node(binding, 41, kernels::kSgmBandRows, KernelBackend::native, simd::available_isas().back());
    return disparity;
  };
  const Plane restored = run(forward, backward);
  const Plane zeroed = run(zero_forward, zero_backward);
  int64_t different = 0;
  for (int y = 0; y < 150; ++y) {
    for (int x = 0; x < 41; ++x) different += restored.at<int16_t>(x, y) != zeroed.at<int16_t>(x, y) ? 1 : 0;
  }
  EXPECT_GT(different, 0);
}

// The host-parallel 4-path pair: each pair's sums against the reference at odd sizes across tile
// heights (the row state carried across tiles), and pair + pair + sgm_sums_select gives sgm_4path's
// map bit for bit.
TEST(Sgm4Path, PathPairsAndSelectMatchReferenceAndTheSinglePass) {
  for (const RangeCase& range : kRanges) {
    const nlohmann::json params = sgm_params(range.min_disparity, range.num_disparities, 5, 60, range.uniqueness,
                                             range.subpixel, range.lr_max_diff);
    CensusPair pair = shifted_census(43, 19, ElementType::census32, 50 * 4, std::max(range.min_disparity, -5),
                                     range.min_disparity + range.num_disparities - 1, 41);
    SCOPED_TRACE("min_disparity " + std::to_string(range.min_disparity) + " D " + std::to_string(range.num_disparities));
    const int sums_width = 43 * range.num_disparities;
    for (const char* name : {"sgm_4path_row_pair_sums", "sgm_4path_column_pair_sums"}) {
      KernelCase pair_case{name, forward_params(params), {pair.left, pair.right}, 6};
      expect_all_back_ends_match_reference(pair_case, {{sums_width, 19}, {sums_width, 5}, {sums_width, 1}});
    }
    const Plane row_sums = reference_sums("sgm_4path_row_pair_sums", pair.left, pair.right, forward_params(params));
    const Plane column_sums = reference_sums("sgm_4path_column_pair_sums", pair.left, pair.right, forward_params(params));
    const Plane single_pass = reference_disparity("sgm_4path", {&pair.left, &pair.right}, params, 43, 19);
    expect_select_gives(row_sums, column_sums, params, single_pass, 7);
  }
}

TEST(Sgm4Path, PathPairsCensus64MatchReference) {
  const nlohmann::json params = sgm_params(-3, 35, 9, 110, 10, 1, 1);
  CensusPair pair = shifted_census(31, 13, ElementType::census64, 40 * 8, 0, 20, 9);
  for (const char* name : {"sgm_4path_row_pair_sums_census64", "sgm_4path_column_pair_sums_census64"}) {
    KernelCase pair_case{name, forward_params(params), {pair.left, pair.right}, 4};
    expect_all_back_ends_match_reference(pair_case, {{31 * 35, 13}, {31 * 35, 4}});
  }
}

TEST(Sgm8Path, BackwardSumsCensus64MatchesReference) {
  const nlohmann::json params = sgm_params(-4, 33, 10, 120, 10, 1, 1);
  CensusPair pair = shifted_census(29, 11, ElementType::census64, 32 * 8, 0, 25, 5);
  KernelCase backward_sums{"sgm_8path_backward_sums_census64", forward_params(params), {pair.left, pair.right}, 4};
  expect_all_back_ends_match_reference(backward_sums, {{29 * 33, 11}, {29 * 33, 3}});
}

TEST(Sgm8Path, Census64MatchesReference) {
  const nlohmann::json params = sgm_params(-4, 33, 10, 120, 10, 1, 1);
  CensusPair pair = shifted_census(29, 11, ElementType::census64, 32 * 8, 0, 25, 5);
  KernelCase forward{"sgm_8path_forward_census64", forward_params(params), {}, 4};
  forward.inputs = {pair.left, pair.right};
  expect_all_back_ends_match_reference(forward, {{29 * 33, 11}, {29 * 33, 3}});
  KernelCase backward{"sgm_8path_backward_census64", params, {}, 8};
  backward.inputs = {pair.left, pair.right, reference_forward_sums(pair.left, pair.right, forward_params(params), 8)};
  expect_all_back_ends_match_reference(backward, {{29, 11}, {29, 4}});
}

TEST(Sgm8PathBands, Census64MatchesReference) {
  const nlohmann::json params = sgm_params(-4, 33, 10, 120, 10, 1, 1);
  CensusPair pair = shifted_census(29, 131, ElementType::census64, 32 * 8, 0, 25, 5);
  const int checkpoint_width = 3 * 29 * 33;
  for (const char* name : {"sgm_8path_forward_checkpoints_census64", "sgm_8path_backward_checkpoints_census64"}) {
    KernelCase checkpoints{name, forward_params(params), {pair.left, pair.right}, 4};
    expect_all_back_ends_match_reference(checkpoints, {{checkpoint_width, 3}, {checkpoint_width, 1}});
  }
  KernelCase banded{"sgm_8path_bands_census64", params,
                    {pair.left, pair.right,
                     reference_sums("sgm_8path_forward_checkpoints_census64", pair.left, pair.right, forward_params(params)),
                     reference_sums("sgm_8path_backward_checkpoints_census64", pair.left, pair.right, forward_params(params))},
                    8};
  expect_all_back_ends_match_reference(banded, {{29, 131}, {29, kernels::kSgmBandRows}});
}

// A smooth texture f(x, y) (sum of oriented sines) seen by the right camera shifted by `shift` px:
// right(x, y) = f(x + shift, y), so the true left disparity is `shift` everywhere.
Plane texture(int width, int height, double shift) {
  Plane plane(width, height, {ElementType::u8, 0});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double u = x + shift;
      const double value = 128 + 45 * std::sin(0.9 * u + 0.4 * y) + 35 * std::sin(2.3 * u - 1.1 * y + 1.0) +
                           25 * std::sin(0.31 * u + 1.7 * y + 2.0) + 15 * std::sin(3.7 * u + 0.2 * y);
      plane.at<uint8_t>(x, y) = static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
    }
  }
  return plane;
}

Plane census_of(const Plane& image, const char* kernel_name) {
  const KernelDescriptor& census = testing::kernel_named(kernel_name);
  Plane out(image.width(), image.height(), census.ports[1].format);
  census.reference({image.view()}, {out.view()}, nullptr, BorderMode::replicate, 0);
  return out;
}

// Disparity maps of an 8-path run (forward then backward kernel) through the tile executor.
Plane run_8path(const Plane& left, const Plane& right, const nlohmann::json& params, KernelBackend backend, simd::Isa isa,
                int tile_height, bool census64 = false) {
  const KernelDescriptor& forward = testing::kernel_named(census64 ? "sgm_8path_forward_census64" : "sgm_8path_forward");
  const KernelDescriptor& backward = testing::kernel_named(census64 ? "sgm_8path_backward_census64" : "sgm_8path_backward");
  const std::vector<PlaneShape> shapes = {{left.width(), left.height()}, {right.width(), right.height()}};
  const PreparedKernel forward_prepared = forward.prepare(forward_params(params), shapes);
  Plane sums(forward_prepared.output_shapes[0].width, left.height(), {ElementType::u16, 0});
  VectorNodeBinding forward_binding{&forward, forward_prepared.params.get(), BorderMode::replicate, 0,
                                    {left.view(), right.view()}, {sums.view()}, forward_prepared.input_halos};
  run_vector_node(forward_binding, sums.width(), tile_height, backend, isa);
  const PreparedKernel prepared = backward.prepare(params, {shapes[0], shapes[1], {sums.width(), sums.height()}});
  Plane disparity(left.width(), left.height(), {ElementType::s16, 4});
  VectorNodeBinding binding{&backward, prepared.params.get(), BorderMode::replicate, 0,
                            {left.view(), right.view(), sums.view()}, {disparity.view()}, prepared.input_halos};
  run_vector_node(binding, left.width(), tile_height, backend, isa);
  return disparity;
}

Plane run_4path(const Plane& left, const Plane& right, const nlohmann::json& params, KernelBackend backend, simd::Isa isa,
                int tile_height) {
  const KernelDescriptor& kernel = testing::kernel_named("sgm_4path");
  const PreparedKernel prepared = kernel.prepare(params, {{left.width(), left.height()}, {right.width(), right.height()}});
  Plane disparity(left.width(), left.height(), {ElementType::s16, 4});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {left.view(), right.view()},
                            {disparity.view()}, prepared.input_halos};
  run_vector_node(binding, left.width(), tile_height, backend, isa);
  return disparity;
}

TEST(SgmGolden, IntegerShiftGivesTheShiftOnEveryBackEnd) {
  const int width = 96, height = 24, shift = 11;
  const Plane left = census_of(texture(width, height, 0), "census5x5");
  const Plane right = census_of(texture(width, height, shift), "census5x5");
  const nlohmann::json params = sgm_params(0, 32, 5, 60, 10, 0, 1);
  for (simd::Isa isa : simd::available_isas()) {
    for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
      for (int paths : {4, 8}) {
        const Plane disparity = paths == 4 ? run_4path(left, right, params, backend, isa, 5)
                                           : run_8path(left, right, params, backend, isa, 7);
        for (int y = 0; y < height; ++y) {
          for (int x = 2 * shift; x < width - 2; ++x) {  // the band past the left border may fail the LR check
            ASSERT_EQ(disparity.at<int16_t>(x, y), shift * 16)
                << paths << " paths, x=" << x << " y=" << y << " " << simd::isa_name(isa);
          }
        }
      }
    }
  }
}

TEST(SgmGolden, NegativeRangeFindsANegativeShift) {
  const int width = 80, height = 12, shift = -7;
  const Plane left = census_of(texture(width, height, 0), "census9x7");
  const Plane right = census_of(texture(width, height, shift), "census9x7");
  const nlohmann::json params = sgm_params(-12, 16, 9, 110, 0, 0, -1);
  const Plane disparity = run_8path(left, right, params, KernelBackend::native, simd::available_isas().back(), 4, true);
  for (int y = 0; y < height; ++y) {
    for (int x = 4; x < width + shift - 4; ++x) ASSERT_EQ(disparity.at<int16_t>(x, y), shift * 16) << "x=" << x << " y=" << y;
  }
}

TEST(SgmGolden, HalfPixelShiftGivesAHalfPixelSubPixelDisparity) {
  const int width = 120, height = 20;
  const double shift = 9.5;
  const Plane left = census_of(texture(width, height, 0), "census5x5");
  const Plane right = census_of(texture(width, height, shift), "census5x5");
  const nlohmann::json params = sgm_params(0, 24, 5, 60, 0, 1, -1);
  const Plane disparity = run_4path(left, right, params, KernelBackend::native, simd::available_isas().back(), 8);
  double error_sum = 0;
  int pixels = 0, far = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 25; x < width - 4; ++x) {  // past the occluded band the border replicate creates
      const double value = disparity.at<int16_t>(x, y) / 16.0;
      if (std::abs(value - shift) > 0.75) ++far;
      error_sum += value - shift;
      ++pixels;
    }
  }
  // Integer-only selection would be off by 0.5 px on average; the parabola brings it near 0.
  EXPECT_LT(std::abs(error_sum / pixels), 0.15) << "mean sub-pixel error over " << pixels << " pixels";
  EXPECT_LT(far, pixels / 50) << "pixels off by more than 0.75 px";
}

// A texture-less pair (a uniform grey view: every census word 0, every cost and every path sum 0 at
// every disparity): a tie across the whole range is no match. With the uniqueness check on, every
// pixel is invalid on every back end and in the reference (the former rule kept them all at
// min_disparity, because 0 x 100 > 0 x (100 - U) is false); with it off, every pixel takes the
// first disparity of the range (ties to the smallest d, no sub-pixel step at the range's edge).
TEST(SgmGolden, ATextureLessPairIsInvalidWithUniquenessAndTheFirstDisparityWithout) {
  const int width = 37, height = 9, min_disparity = -3;
  Plane grey(width, height, {ElementType::u8, 0});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) grey.at<uint8_t>(x, y) = 130;
  }
  for (const char* census_kernel : {"census5x5", "census9x7"}) {
    const bool census64 = std::string(census_kernel) == "census9x7";
    const Plane census = census_of(grey, census_kernel);
    for (int uniqueness : {5, 0}) {
      const nlohmann::json params = sgm_params(min_disparity, 20, 5, 60, uniqueness, 1, 1);
      const int16_t expected = static_cast<int16_t>((uniqueness > 0 ? min_disparity - 1 : min_disparity) * 16);
      for (simd::Isa isa : simd::available_isas()) {
        for (KernelBackend backend : {KernelBackend::native, KernelBackend::counting}) {
          for (int paths : {4, 8}) {
            if (paths == 4 && census64) continue;  // sgm_4path_census64 is checked by the reference case below
            const Plane disparity = paths == 4 ? run_4path(census, census, params, backend, isa, 4)
                                               : run_8path(census, census, params, backend, isa, 5, census64);
            for (int y = 0; y < height; ++y) {
              for (int x = 0; x < width; ++x) {
                ASSERT_EQ(disparity.at<int16_t>(x, y), expected) << census_kernel << " " << paths << " paths, U " << uniqueness
                                                                 << ", x=" << x << " y=" << y << " " << simd::isa_name(isa);
              }
            }
          }
        }
      }
      KernelCase test_case{census64 ? "sgm_4path_census64" : "sgm_4path", params, {}, 4};
      test_case.inputs = {census, census};
      const std::vector<Plane> reference = expect_all_back_ends_match_reference(test_case, {{width, height}, {width, 3}});
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) ASSERT_EQ(reference[0].at<int16_t>(x, y), expected) << "reference x=" << x << " y=" << y;
      }
    }
  }
}

TEST(SgmOverflow, NoOverflowAtLargestRangeAndPenalties) {
  // The largest supported range (512) and penalties (p1 = p2 = 4000) with census64 costs that swing
  // between 0 and 62 (the word or its complement), so path costs reach C + P2. The 16-bit sums of
  // every back end must equal the reference's 32-bit sums exactly, and the reference's largest path
  // cost and 8-path sum must respect the documented bound (kernels/sgm_core.h).
  // Random 62-bit words seen shifted by 10 px: d = 10 costs 0 everywhere, every other disparity
  // about 31 (at least ~18), so along the row the other disparities climb until P2 caps them and
  // L reaches Cmax + P2 = 4062 (P1 = P2: no cheap way to follow a neighbouring disparity).
  const int width = 301, height = 2, count = kernels::kSgmMaxDisparities, penalty = kernels::kSgmMaxPenalty;
  const Plane left = random_census(width, height, ElementType::census64, 0, 3);
  Plane right(width, height, {ElementType::census64, 0});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) right.at<uint64_t>(x, y) = left.at<uint64_t>(std::min(x + 10, width - 1), y);
  }
  for (int p1 : {0, penalty}) {
    const nlohmann::json params = sgm_params(-5, count, p1, penalty, 10, 1, 2);
    KernelCase forward{"sgm_8path_forward_census64", forward_params(params), {left, right}, 2};
    expect_all_back_ends_match_reference(forward, {{width * count, height}, {width * count, 2}});
    KernelCase backward{"sgm_8path_backward_census64", params, {left, right, reference_forward_sums(left, right, forward_params(params), 8)}, 2};
    expect_all_back_ends_match_reference(backward, {{width, height}, {width, 3}});
    const kernels::SgmVolume cost = kernels::sgm_reference_costs(left.view(), right.view(), 8, -5, count);
    kernels::SgmVolume sum{width, height, count, std::vector<int32_t>(cost.values.size(), 0)};
    int32_t largest_path = 0;
    for (const auto& direction : kernels::kSgmForwardPaths) {
      largest_path = std::max(largest_path, kernels::sgm_reference_add_path(cost, p1, penalty, direction, sum));
    }
    for (const auto& direction : kernels::kSgmBackwardPaths) {
      largest_path = std::max(largest_path, kernels::sgm_reference_add_path(cost, p1, penalty, direction, sum));
    }
    const int32_t largest_cost = *std::max_element(cost.values.begin(), cost.values.end());
    const int32_t largest_sum = *std::max_element(sum.values.begin(), sum.values.end());
    EXPECT_LE(largest_cost, 62);
    EXPECT_LE(largest_path, 62 + penalty);
    if (p1 == penalty) {
      EXPECT_GT(largest_path, penalty) << "the case climbs to the P2 cap";
    }
    EXPECT_LE(largest_sum, 8 * (62 + penalty));
    EXPECT_LT(largest_sum, 32768);
  }
}

TEST(SgmMustFail, RefusesBadParametersAndShapes) {
  const KernelDescriptor& kernel = testing::kernel_named("sgm_4path");
  auto expect_error = [&](const nlohmann::json& params, const std::vector<PlaneShape>& shapes, const std::string& text) {
    try {
      kernel.prepare(params, shapes);
      ADD_FAILURE() << "expected KernelError for " << params.dump();
    } catch (const KernelError& error) {
      EXPECT_NE(std::string(error.what()).find(text), std::string::npos) << error.what();
    }
  };
  const std::vector<PlaneShape> shapes = {{64, 8}, {64, 8}};
  expect_error({{"num_disparities", 0}}, shapes, "num_disparities");
  expect_error({{"num_disparities", 513}}, shapes, "num_disparities");
  expect_error({{"p1", 50}, {"p2", 10}}, shapes, "p2");
  expect_error({{"p2", 4001}}, shapes, "p2");
  expect_error({{"uniqueness_percent", 51}}, shapes, "uniqueness_percent");
  expect_error({{"lr_max_diff", -2}}, shapes, "lr_max_diff");
  expect_error({{"penalty", 3}}, shapes, "penalty");
  expect_error({}, {{64, 8}, {65, 8}}, "port 'right'");
  const KernelDescriptor& backward = testing::kernel_named("sgm_8path_backward");
  EXPECT_THROW(backward.prepare({{"num_disparities", 16}}, {{64, 8}, {64, 8}, {64 * 15, 8}}), KernelError);
  const KernelDescriptor& forward = testing::kernel_named("sgm_8path_forward");
  EXPECT_THROW(forward.prepare({{"subpixel", 1}}, shapes), KernelError);
  const KernelDescriptor& select = testing::kernel_named("sgm_sums_select");
  EXPECT_THROW(select.prepare({{"num_disparities", 16}}, {{64 * 16 + 3, 8}, {64 * 16 + 3, 8}}), KernelError);  // not W * D
  EXPECT_THROW(select.prepare({{"num_disparities", 16}}, {{64 * 16, 8}, {64 * 16, 9}}), KernelError);  // sizes differ
  EXPECT_EQ(select.prepare({{"num_disparities", 16}}, {{64 * 16, 8}, {64 * 16, 8}}).output_shapes.at(0), (PlaneShape{64, 8}));
}

// The closed-form op count of an SGM kernel on the counting back end (L = 32 u16 lanes, 16 u32,
// 8 u64; V = ceil(D / 32); s = log2 32 = 5 stages (1 permute + 1 min each) of the u16 lane minimum
// min_across, t = log2 16 = 4 of the u32 one). The same figures are listed in kernels/sgm_core.h.
simd::OpCounts expected_sgm_ops(kernels::SgmPass pass, int word_bytes, const kernels::SgmParams& p, int width, int height,
                                int tile_height) {
  using simd::OpClass;
  const int64_t L = 32, s = 5, t = 4;
  const int64_t V = (p.num_disparities + L - 1) / L, Dp = V * L;
  const bool select = kernels::sgm_selects(pass);
  const bool paths = kernels::sgm_runs_paths(pass);
  const bool lr = select && p.lr_max_diff >= 0, unique = select && p.uniqueness_percent > 0, sub = select && p.subpixel;
  const int64_t tiles = (height + tile_height - 1) / tile_height;
  const int64_t rows = height, pixels = int64_t{width} * height;
  simd::OpCounts per_tile, per_row, per_pixel;
  auto add = [](simd::OpCounts& counts, OpClass op, int64_t n) { counts[op] += static_cast<uint64_t>(n); };
  // Per tile: broadcasts, the zero "previous pixel", the left path's sentinels, lane indices.
  add(per_tile, OpClass::permute, 4 + 2 + 5);
  if (paths) add(per_tile, OpClass::store, (Dp + 2 + L - 1) / L);
  add(per_tile, OpClass::load, 1);
  add(per_tile, OpClass::compare, V);
  add(per_tile, OpClass::arith, 2 * V);
  add(per_tile, OpClass::logic, V);
  if (unique) {
    add(per_tile, OpClass::permute, 4);
    add(per_tile, OpClass::arith, V);
  }
  if (sub) add(per_tile, OpClass::permute, 5);
  if (lr) {
    add(per_tile, OpClass::load, 1);
    add(per_tile, OpClass::permute, 4);
  }
  // Per row.
  if (kernels::sgm_writes_sums(pass)) {  // staging the right row with its border
    const int64_t word_lanes = 64 / word_bytes;
    const int64_t left_halo = kernels::sgm_left_halo(p), right_halo = kernels::sgm_right_halo(p);
    add(per_row, OpClass::permute, 2);
    add(per_row, OpClass::store, (left_halo + word_lanes - 1) / word_lanes + (width + word_lanes - 1) / word_lanes +
                                     (right_halo + word_lanes - 1) / word_lanes);
    add(per_row, OpClass::load, (width + word_lanes - 1) / word_lanes);
  }
  if (lr) {  // the right view's window: it slides after every pixel but the last, then is stored whole
    add(per_row, OpClass::permute, 2 * V * (width - 1));
    add(per_row, OpClass::store, 2 * V);
  }
  if (select) {  // the row's final pass, two halves of L32 pixels per chunk of L
    const int64_t chunks = (width + L - 1) / L, halves = 2 * chunks;
    add(per_row, OpClass::permute, 1 + chunks);  // the u32 step; one narrow per chunk
    add(per_row, OpClass::store, chunks);
    add(per_row, OpClass::load, halves);
    add(per_row, OpClass::logic, halves);
    add(per_row, OpClass::shift, 2 * halves);
    add(per_row, OpClass::arith, halves);
    if (sub) {
      add(per_row, OpClass::load, 2 * halves);
      add(per_row, OpClass::arith, 16 * halves);
      add(per_row, OpClass::shift, 4 * halves);
      add(per_row, OpClass::compare, 7 * halves);
      add(per_row, OpClass::logic, 10 * halves);
    }
    if (unique) {
      add(per_row, OpClass::load, halves);
      add(per_row, OpClass::logic, 2 * halves);
      add(per_row, OpClass::multiply, 2 * halves);
      add(per_row, OpClass::compare, halves);
    }
    if (lr) {
      add(per_row, OpClass::permute, 1);
      add(per_row, OpClass::arith, 1 + 6 * halves);
      add(per_row, OpClass::shift, halves);
      add(per_row, OpClass::gather, halves);
      add(per_row, OpClass::compare, 4 * halves);
      add(per_row, OpClass::logic, 4 * halves);
    }
  }
  if (paths) {
    // Per pixel: census costs.
    add(per_pixel, OpClass::permute, 1 + V * (word_bytes == 4 ? 1 : 3));
    add(per_pixel, OpClass::load, V * (word_bytes == 4 ? 2 : 4));
    add(per_pixel, OpClass::logic, V * (word_bytes == 4 ? 2 : 4) + (Dp != p.num_disparities ? 1 : 0));
    add(per_pixel, OpClass::popcount, V * (word_bytes == 4 ? 2 : 4));
    // Path steps (four, or the pass's pair): (V - 1) + s + 1 + 6V arith and s permutes each; the sums
    // V per path after the first. Those from the previous row load 3V and store V each; the one along
    // the row keeps its costs in registers and shifts lanes instead (2V permutes).
    const int64_t row_path = kernels::sgm_runs_row_path(pass) ? 1 : 0;
    const int64_t memory_paths = kernels::sgm_state_regions(pass);
    const int64_t path_count = row_path + memory_paths;
    add(per_pixel, OpClass::load, memory_paths * 3 * V);
    add(per_pixel, OpClass::store, memory_paths * V);
    add(per_pixel, OpClass::arith, path_count * ((V - 1) + s + 1 + 6 * V) + (path_count - 1) * V);
    add(per_pixel, OpClass::permute, path_count * s + row_path * 2 * V);
  } else {  // the two sums loaded and added, the padding lanes set
    add(per_pixel, OpClass::load, 2 * V);
    add(per_pixel, OpClass::arith, V);
    add(per_pixel, OpClass::logic, Dp != p.num_disparities ? 1 : 0);
  }
  if (kernels::sgm_writes_sums(pass)) add(per_pixel, OpClass::store, V);
  if (pass == kernels::SgmPass::backward) {
    add(per_pixel, OpClass::load, V);
    add(per_pixel, OpClass::arith, V);
  }
  if (select) {  // keys, best key
    add(per_pixel, OpClass::permute, 2 * V + t);
    add(per_pixel, OpClass::arith, (2 * V - 1) + t);
    add(per_pixel, OpClass::logic, 1);
    add(per_pixel, OpClass::store, 1);
  }
  if (unique) {  // the second-best sum: mask |d - best| <= 1, u16 lane minimum
    add(per_pixel, OpClass::shift, 1);
    add(per_pixel, OpClass::logic, 1 + V);
    add(per_pixel, OpClass::arith, V + (V - 1) + s);
    add(per_pixel, OpClass::compare, V);
    add(per_pixel, OpClass::permute, s);
    add(per_pixel, OpClass::store, 1);
  }
  if (sub) {  // S(best - 1), S(best + 1): the sums stored, lane 0 of best moved out, two one-lane loads and stores
    add(per_pixel, OpClass::store, V + 2);
    add(per_pixel, OpClass::permute, 1);
    add(per_pixel, OpClass::load, 2);
  }
  if (lr) {  // the right view's running minimum of keys, the window's final element stored with its vector
    add(per_pixel, OpClass::store, 1);
    add(per_pixel, OpClass::arith, 2 * V);
  }
  simd::OpCounts total;
  for (int op = 0; op < simd::kOpClassCount; ++op) {
    total.by_class[op] = per_tile.by_class[op] * static_cast<uint64_t>(tiles) + per_row.by_class[op] * static_cast<uint64_t>(rows) +
                         per_pixel.by_class[op] * static_cast<uint64_t>(pixels);
  }
  return total;
}

TEST(SgmOps, CountedOpsEqualClosedForm) {
  struct OpCase {
    kernels::SgmPass pass;
    int word_bytes, width, height, tile_height, min_disparity, count, uniqueness, subpixel, lr;
  };
  const std::vector<OpCase> cases = {
      {kernels::SgmPass::single, 4, 45, 7, 3, 0, 64, 10, 1, 1},   {kernels::SgmPass::single, 4, 33, 5, 5, -3, 20, 0, 0, -1},
      {kernels::SgmPass::single, 8, 21, 4, 2, 2, 40, 5, 1, -1},   {kernels::SgmPass::forward, 4, 30, 5, 2, -4, 33, 0, 1, -1},
      {kernels::SgmPass::forward, 8, 19, 3, 3, 0, 16, 0, 1, -1},  {kernels::SgmPass::backward, 4, 37, 6, 4, 1, 96, 15, 1, 2},
      {kernels::SgmPass::backward, 8, 17, 3, 1, 0, 32, 0, 0, 0},  {kernels::SgmPass::backward_sums, 4, 31, 5, 2, -2, 35, 0, 1, -1},
      {kernels::SgmPass::backward_sums, 8, 18, 4, 3, 0, 32, 0, 1, -1}, {kernels::SgmPass::select, 4, 39, 6, 4, 1, 96, 15, 1, 2},
      {kernels::SgmPass::select, 4, 23, 5, 2, -3, 20, 0, 0, -1},
      {kernels::SgmPass::row_pair_sums, 4, 29, 5, 2, -2, 35, 0, 1, -1}, {kernels::SgmPass::row_pair_sums, 8, 17, 4, 3, 0, 64, 0, 1, -1},
      {kernels::SgmPass::column_pair_sums, 4, 33, 6, 4, 1, 40, 0, 1, -1}, {kernels::SgmPass::column_pair_sums, 8, 19, 3, 1, 0, 32, 0, 1, -1}};
  const char* names[2][7] = {{"sgm_4path", "sgm_8path_forward", "sgm_8path_backward", "sgm_8path_backward_sums",
                              "sgm_4path_row_pair_sums", "sgm_4path_column_pair_sums", "sgm_sums_select"},
                             {"sgm_4path_census64", "sgm_8path_forward_census64", "sgm_8path_backward_census64",
                              "sgm_8path_backward_sums_census64", "sgm_4path_row_pair_sums_census64",
                              "sgm_4path_column_pair_sums_census64", ""}};
  for (const OpCase& c : cases) {
    const std::string name = names[c.word_bytes == 4 ? 0 : 1][static_cast<int>(c.pass)];
    nlohmann::json params = sgm_params(c.min_disparity, c.count, 4, 50, c.uniqueness, c.subpixel, c.lr);
    if (kernels::sgm_writes_sums(c.pass)) params = forward_params(params);
    const ElementType type = c.word_bytes == 4 ? ElementType::census32 : ElementType::census64;
    KernelCase test_case{name, params, {random_census(c.width, c.height, type, 0, 1), random_census(c.width, c.height, type, 0, 2)}, 0};
    if (c.pass == kernels::SgmPass::backward) {
      test_case.inputs.push_back(reference_forward_sums(test_case.inputs[0], test_case.inputs[1], forward_params(params), c.word_bytes));
    }
    if (c.pass == kernels::SgmPass::select) {
      const Plane left = test_case.inputs[0], right = test_case.inputs[1];
      test_case.inputs = {reference_forward_sums(left, right, forward_params(params), c.word_bytes),
                          reference_backward_sums(left, right, forward_params(params), c.word_bytes)};
    }
    const KernelDescriptor& kernel = testing::kernel_named(name);
    const PreparedKernel prepared = testing::prepare_case(kernel, test_case);
    const auto& p = *static_cast<const kernels::SgmParams*>(prepared.params.get());
    const int output_width = kernels::sgm_writes_sums(c.pass) ? c.width * c.count : c.width;
    EXPECT_TRUE(testing::op_counts_equal(expected_sgm_ops(c.pass, c.word_bytes, p, c.width, c.height, c.tile_height),
                                         testing::count_ops(test_case, output_width, c.tile_height)))
        << name << " " << c.width << "x" << c.height << " tile height " << c.tile_height << " D " << c.count;
  }
}

}  // namespace
}  // namespace lpstereo
