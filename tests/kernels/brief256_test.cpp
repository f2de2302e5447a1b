// brief256 and its pattern: the pattern's documented properties (inside the disc of radius 15, no
// constant pair, Gaussian spread sigma ~ 31/5, sectors 4 and 8 exactly the quarter and half turns),
// the Hamming distance helper, bit-exact agreement of every back end with the reference at odd sizes
// in padded buffers for several sectors, zero descriptors for invalid and border keypoints, equal
// descriptors for the same patch at two places, the closed-form op count, refused inputs; and with
// OpenCV (cv::warpAffine) the steered pattern of sector s on an image rotated by s x 22.5 degrees
// matching the original better than the unsteered one, and (issue 8's acceptance) a rotated pair
// matched by hamming_match with steered descriptors giving within 10 % of an unrotated pair's inliers.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <set>

#include "arm/tasks/keypoint_record.h"
#include "dag/tile_executor.h"
#include "kernels/brief_hamming.h"
#include "kernels/brief_pattern.h"
#include "kernels/match_record.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

#if defined(LPSTEREO_TEST_WITH_OPENCV)
#include <opencv2/imgproc.hpp>
#endif

namespace lpstereo {
namespace {

using kernels::BriefPair;
using kernels::kBriefPairs;
using kernels::kBriefPattern;
using kernels::kBriefSteeredPatterns;
using kernels::kBriefWords;
using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

TEST(BriefPattern, PointsLieInTheDiscAndNoPairIsConstant) {
  double sum_squares = 0.0;
  for (const BriefPair& pair : kBriefPattern) {
    EXPECT_LE(pair.ax * pair.ax + pair.ay * pair.ay, 225);
    EXPECT_LE(pair.bx * pair.bx + pair.by * pair.by, 225);
    EXPECT_FALSE(pair.ax == pair.bx && pair.ay == pair.by);
    sum_squares += pair.ax * pair.ax + pair.ay * pair.ay + pair.bx * pair.bx + pair.by * pair.by;
  }
  // sigma = 31 / 5 = 6.2 per coordinate, a little less after the disc's rejection: 1024 coordinates.
  const double sigma = std::sqrt(sum_squares / (4.0 * kBriefPairs));
  EXPECT_GT(sigma, 5.0);
  EXPECT_LT(sigma, 6.6);
  // Not a degenerate table: many distinct points.
  std::set<std::pair<int, int>> distinct;
  for (const BriefPair& pair : kBriefPattern) distinct.insert({pair.ax, pair.ay});
  EXPECT_GT(distinct.size(), 150u);
}

TEST(BriefPattern, SteeredPatternsStayInThePatchAndQuarterTurnsAreExact) {
  EXPECT_EQ(kBriefSteeredPatterns[0], kBriefPattern);
  for (const auto& pattern : kBriefSteeredPatterns) {
    for (const BriefPair& pair : pattern) {
      for (int value : {pair.ax, pair.ay, pair.bx, pair.by}) {
        EXPECT_GE(value, -15);
        EXPECT_LE(value, 15);
      }
    }
  }
  for (int i = 0; i < kBriefPairs; ++i) {
    const BriefPair& base = kBriefPattern[static_cast<size_t>(i)];
    // theta = 90 degrees, x right y down: (x, y) -> (-y, x); 180: (-x, -y).
    EXPECT_EQ(kBriefSteeredPatterns[4][static_cast<size_t>(i)],
              (BriefPair{static_cast<int8_t>(-base.ay), base.ax, static_cast<int8_t>(-base.by), base.bx}));
    EXPECT_EQ(kBriefSteeredPatterns[8][static_cast<size_t>(i)],
              (BriefPair{static_cast<int8_t>(-base.ax), static_cast<int8_t>(-base.ay), static_cast<int8_t>(-base.bx),
                         static_cast<int8_t>(-base.by)}));
    // 22.5 degrees: within rounding of the float rotation.
    const double angle = 22.5 * std::numbers::pi / 180.0;
    const BriefPair& steered = kBriefSteeredPatterns[1][static_cast<size_t>(i)];
    EXPECT_LE(std::abs(steered.ax - (std::cos(angle) * base.ax - std::sin(angle) * base.ay)), 0.5 + 1e-3);
    EXPECT_LE(std::abs(steered.ay - (std::sin(angle) * base.ax + std::cos(angle) * base.ay)), 0.5 + 1e-3);
  }
}

TEST(BriefHamming, CountsDifferingBits) {
  uint32_t zeros[kBriefWords] = {}, ones[kBriefWords], some[kBriefWords] = {};
  for (uint32_t& word : ones) word = 0xFFFFFFFFu;
  some[0] = 0x1u;
  some[3] = 0x80000000u;
  some[7] = 0x0F0F0000u;
  EXPECT_EQ(kernels::brief_hamming_distance(zeros, zeros), 0);
  EXPECT_EQ(kernels::brief_hamming_distance(zeros, ones), 256);
  EXPECT_EQ(kernels::brief_hamming_distance(zeros, some), 10);
  EXPECT_EQ(kernels::brief_hamming_distance(ones, some), 246);
  EXPECT_EQ(kernels::brief_hamming_distance(some, some), 0);
}

// A keypoint list of `count` rows: usable keypoints, unusable ones (near every border, negative,
// huge), a few invalid rows with coordinates, then zero rows; padded stride.
Plane keypoint_list(int count, int width, int height, uint32_t seed) {
  Plane list(arm::kKeypointWords, count, {ElementType::s32, 0}, arm::kKeypointWords * 4 + 12);
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> column(15, width - 16), row(15, height - 16);
  const int32_t special[][2] = {{14, 40}, {15, 15}, {width - 15, 40}, {width - 16, height - 16}, {40, 14}, {40, height - 15},
                                {-5, 40}, {40, -100000}, {70000, 40}, {40, 2000000000}, {-2147483647 - 1, 3}};
  for (int k = 0; k < count; ++k) {
    int32_t* word = list.row<int32_t>(k);
    word[arm::kKeypointValid] = 1;
    word[arm::kKeypointXPx] = column(generator);
    word[arm::kKeypointYPx] = row(generator);
    word[arm::kKeypointResponse] = static_cast<int32_t>(generator());
    const int special_count = static_cast<int>(std::size(special));
    if (k % 7 == 3) {
      word[arm::kKeypointXPx] = special[(k / 7) % special_count][0];
      word[arm::kKeypointYPx] = special[(k / 7) % special_count][1];
    }
    if (k % 11 == 5) word[arm::kKeypointValid] = 0;
    if (k % 13 == 6) word[arm::kKeypointValid] = 0x10000;  // nonzero in the high half only: valid
    if (k >= count - 5) std::fill(word, word + arm::kKeypointWords, 0);
  }
  return list;
}

TEST(Brief256, MatchesReferenceAtOddSizeInPaddedBuffer) {
  for (int sector : {0, 1, 5, 10, 15}) {
    KernelCase test_case{"brief256", {{"yaw_sector", sector}}, {}, 20};
    test_case.inputs.push_back(random_plane(631, 479, {ElementType::u8, 0}, 640, 61));
    test_case.inputs.push_back(keypoint_list(203, 631, 479, 62));
    expect_all_back_ends_match_reference(test_case, {{8, 203}, {8, 64}, {8, 7}, {8, 1}});
  }
}

TEST(Brief256, SmallImagesGiveZeroDescriptors) {
  for (auto [width, height] : std::vector<std::pair<int, int>>{{30, 100}, {100, 30}, {31, 31}, {5, 5}}) {
    KernelCase test_case{"brief256", {{"yaw_sector", 3}}, {}, 4};
    test_case.inputs.push_back(random_plane(width, height, {ElementType::u8, 0}, width + 3, 63));
    test_case.inputs.push_back(keypoint_list(9, 40, 40, 64));
    const std::vector<Plane> reference = expect_all_back_ends_match_reference(test_case, {{8, 9}, {8, 2}});
    int nonzero = 0;
    for (int k = 0; k < 9; ++k) {
      for (int w = 0; w < kBriefWords; ++w) nonzero += reference[0].at<uint32_t>(w, k) != 0;
    }
    if (width < 31 || height < 31) {
      EXPECT_EQ(nonzero, 0) << width << "x" << height;
    }
  }
}

Plane run_brief(const Plane& image, const Plane& keypoints, int sector, KernelBackend backend, simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("brief256");
  const PreparedKernel prepared =
      kernel.prepare({{"yaw_sector", sector}}, {{image.width(), image.height()}, {keypoints.width(), keypoints.height()}});
  Plane output(kBriefWords, keypoints.height(), {ElementType::u32, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, {image.view(), keypoints.view()}, {output.view()}};
  run_vector_node(binding, kBriefWords, 16, backend, isa);
  return output;
}

template <class Check>
void on_every_back_end(const Check& check) {
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

Plane list_of(const std::vector<std::array<int32_t, 3>>& points) {
  Plane list(arm::kKeypointWords, static_cast<int>(points.size()), {ElementType::s32, 0});
  for (size_t k = 0; k < points.size(); ++k) {
    int32_t* word = list.row<int32_t>(static_cast<int>(k));
    word[arm::kKeypointValid] = points[k][0];
    word[arm::kKeypointXPx] = points[k][1];
    word[arm::kKeypointYPx] = points[k][2];
    word[arm::kKeypointResponse] = 0;
  }
  return list;
}

// The same 40 x 40 patch copied to a second place gives the same descriptor for every sector;
// another patch gives a distant one; invalid rows and keypoints too near the border give zero.
TEST(Brief256, SamePatchSameDescriptorAndZeroForUnusableKeypoints) {
  Plane image = random_plane(150, 90, {ElementType::u8, 0}, 160, 65);
  for (int y = 0; y < 40; ++y) {
    for (int x = 0; x < 40; ++x) image.at<uint8_t>(100 + x, 45 + y) = image.at<uint8_t>(10 + x, 5 + y);
  }
  const Plane list = list_of({{1, 30, 25}, {1, 120, 65}, {1, 70, 40}, {0, 30, 25}, {1, 14, 25}, {1, 135, 40}, {1, 60, 75}});
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    for (int sector : {0, 3, 9}) {
      const Plane descriptors = run_brief(image, list, sector, backend, isa);
      const uint32_t* first = descriptors.row<const uint32_t>(0);
      EXPECT_EQ(kernels::brief_hamming_distance(first, descriptors.row<const uint32_t>(1)), 0) << label;
      EXPECT_GT(kernels::brief_hamming_distance(first, descriptors.row<const uint32_t>(2)), 64) << label;
      for (int k = 3; k < 7; ++k) {
        for (int w = 0; w < kBriefWords; ++w) EXPECT_EQ(descriptors.at<uint32_t>(w, k), 0u) << label << " row " << k;
      }
    }
  });
}

// The closed form of kernels/brief256.cpp for the counting back end (L = 16, Q = 1).
TEST(Brief256, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU32 == 16, "the closed form assumes 16 32-bit lanes");
  for (auto [keypoints, tile_height] : std::vector<std::pair<int, int>>{{203, 203}, {203, 64}, {1, 1}, {40, 7}}) {
    KernelCase test_case{"brief256", {{"yaw_sector", 2}}, {}, 0};
    test_case.inputs.push_back(random_plane(97, 61, {ElementType::u8, 0}, 0, 66));
    test_case.inputs.push_back(keypoint_list(keypoints, 97, 61, 67));
    simd::OpCounts expected;
    for (const TileRect& tile : make_tiles(kBriefWords, keypoints, kBriefWords, tile_height)) {
      const int64_t k = tile.height;
      expected[simd::OpClass::load] += 128 + 64 * k;
      expected[simd::OpClass::store] += 64 + k;
      expected[simd::OpClass::arith] += 64 + k + 64 * k;
      expected[simd::OpClass::multiply] += 64 + k;
      expected[simd::OpClass::gather] += 6 * k + 64 * k;
      expected[simd::OpClass::compare] += 5 * k + 32 * k;
      expected[simd::OpClass::logic] += 8 * k + 64 * k + k;
      expected[simd::OpClass::shift] += 2 * k;
      expected[simd::OpClass::permute] += 44;
    }
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, kBriefWords, tile_height)))
        << keypoints << " keypoints in tiles of " << tile_height;
  }
  // Under 31 x 31: zeros only.
  KernelCase tiny{"brief256", {}, {}, 0};
  tiny.inputs.push_back(random_plane(30, 40, {ElementType::u8, 0}, 0, 68));
  tiny.inputs.push_back(keypoint_list(20, 40, 40, 69));
  simd::OpCounts expected;
  expected[simd::OpClass::permute] = 3;  // tiles of 8 rows: 8, 8, 4
  expected[simd::OpClass::store] = 20;
  EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(tiny, kBriefWords, 8)));
}

TEST(Brief256MustFail, RefusesBadInputsAndParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("brief256");
  EXPECT_THROW(kernel.prepare({{"yaw_sector", 16}}, {{100, 100}, {4, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({{"sector", 1}}, {{100, 100}, {4, 10}}), KernelError);
  EXPECT_THROW(kernel.prepare({}, {{100, 100}}), KernelError);
  EXPECT_THROW(kernel.prepare({}, {{40000, 40000}, {4, 10}}), KernelError);
  try {
    kernel.prepare({}, {{100, 100}, {5, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'keypoints': expected a width of 4 words (arm/tasks/keypoint_record.h), got 5");
  }
}

#if defined(LPSTEREO_TEST_WITH_OPENCV)
// A smooth random texture (blobs of a few px) of size x size, seeded.
cv::Mat smooth_texture(int size, uint64_t seed) {
  cv::Mat noise(size, size, CV_8U);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat texture;
  cv::GaussianBlur(noise, texture, cv::Size(0, 0), 2.0);
  cv::normalize(texture, texture, 0, 255, cv::NORM_MINMAX);
  return texture;
}

Plane plane_of(const cv::Mat& mat) {
  Plane plane(mat.cols, mat.rows, {ElementType::u8, 0}, mat.cols + 7);
  for (int y = 0; y < mat.rows; ++y) {
    for (int x = 0; x < mat.cols; ++x) plane.at<uint8_t>(x, y) = mat.at<uint8_t>(y, x);
  }
  return plane;
}

// The texture rotated about its centre by sector x 22.5 degrees with cv::warpAffine (bilinear).
cv::Mat rotated_by_sector(const cv::Mat& texture, int sector) {
  const float centre = static_cast<float>((texture.cols - 1) / 2.0);
  // Our rotation is positive from +x towards +y (y down); OpenCV's angle is the opposite sense.
  const cv::Mat rotation = cv::getRotationMatrix2D(cv::Point2f(centre, centre), -sector * 22.5, 1.0);
  cv::Mat rotated;
  cv::warpAffine(texture, rotated, rotation, texture.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return rotated;
}

// Keypoints {valid, x, y} on a grid of 11 x 11 points 12 px apart around the centre.
std::vector<std::array<int32_t, 3>> grid_around(double centre) {
  std::vector<std::array<int32_t, 3>> points;
  for (int y = -60; y <= 60; y += 12) {
    for (int x = -60; x <= 60; x += 12) points.push_back({1, static_cast<int32_t>(centre + x), static_cast<int32_t>(centre + y)});
  }
  return points;
}

// The points rotated about (centre, centre) by sector x 22.5 degrees, as rotated_by_sector does, rounded.
std::vector<std::array<int32_t, 3>> rotated_points(const std::vector<std::array<int32_t, 3>>& points, double centre,
                                                   int sector) {
  const double theta = sector * 22.5 * std::numbers::pi / 180.0;
  std::vector<std::array<int32_t, 3>> moved;
  for (const auto& point : points) {
    const double x = point[1] - centre, y = point[2] - centre;
    moved.push_back({point[0], static_cast<int32_t>(std::lround(centre + std::cos(theta) * x - std::sin(theta) * y)),
                     static_cast<int32_t>(std::lround(centre + std::sin(theta) * x + std::cos(theta) * y))});
  }
  return moved;
}

// Per sector s: the mean Hamming distance between the original's descriptors (sector 0) at the grid
// and the rotated image's at the rotated grid with the steered pattern (sector s) must be clearly
// below the one with the unsteered pattern (sector 0), and small in absolute terms.
TEST(Brief256, SteeredPatternMatchesARotatedImageBetterThanTheUnsteeredOne) {
  constexpr int kSize = 241;
  const cv::Mat texture = smooth_texture(kSize, 71);
  const Plane original = plane_of(texture);
  const double centre = (kSize - 1) / 2.0;
  const std::vector<std::array<int32_t, 3>> points = grid_around(centre);
  const Plane original_descriptors = run_brief(original, list_of(points), 0, KernelBackend::counting, simd::Isa::scalar);
  for (int sector = 1; sector < kernels::kBriefSectors; ++sector) {
    const Plane rotated = plane_of(rotated_by_sector(texture, sector));
    const Plane list = list_of(rotated_points(points, centre, sector));
    const Plane steered = run_brief(rotated, list, sector, KernelBackend::counting, simd::Isa::scalar);
    const Plane unsteered = run_brief(rotated, list, 0, KernelBackend::counting, simd::Isa::scalar);
    double steered_sum = 0.0, unsteered_sum = 0.0;
    for (int k = 0; k < original_descriptors.height(); ++k) {
      steered_sum += kernels::brief_hamming_distance(original_descriptors.row<const uint32_t>(k), steered.row<const uint32_t>(k));
      unsteered_sum += kernels::brief_hamming_distance(original_descriptors.row<const uint32_t>(k), unsteered.row<const uint32_t>(k));
    }
    const double count = original_descriptors.height();
    EXPECT_LT(steered_sum / count, 0.5 * unsteered_sum / count) << "sector " << sector;
    EXPECT_LT(steered_sum / count, 50.0) << "sector " << sector;
    std::printf("sector %2d: mean Hamming distance steered %.1f, unsteered %.1f (of 256)\n", sector, steered_sum / count,
                unsteered_sum / count);
  }
}

// Inliers of matching the first image's descriptors (query, row k = first_points[k]) against the
// second's (train) with the hamming_match kernel at its default ratio test: the second image's
// keypoints are second_points (first_points[k] mapped by the images' transform) in a shuffled order,
// so the true counterpart must be found, not assumed. An inlier = an accepted match whose train row
// is the query's counterpart.
int matching_inliers(const Plane& first_image, const std::vector<std::array<int32_t, 3>>& first_points,
                     const Plane& second_image, const std::vector<std::array<int32_t, 3>>& second_points,
                     int second_sector, uint32_t shuffle_seed) {
  std::vector<int> counterpart_of_train_row(second_points.size());
  for (size_t j = 0; j < counterpart_of_train_row.size(); ++j) counterpart_of_train_row[j] = static_cast<int>(j);
  std::shuffle(counterpart_of_train_row.begin(), counterpart_of_train_row.end(), std::mt19937(shuffle_seed));
  std::vector<std::array<int32_t, 3>> shuffled;
  for (int k : counterpart_of_train_row) shuffled.push_back(second_points[static_cast<size_t>(k)]);
  const Plane query_keypoints = list_of(first_points), train_keypoints = list_of(shuffled);
  const std::vector<Plane> inputs{run_brief(first_image, query_keypoints, 0, KernelBackend::counting, simd::Isa::scalar),
                                  query_keypoints,
                                  run_brief(second_image, train_keypoints, second_sector, KernelBackend::counting, simd::Isa::scalar),
                                  train_keypoints};
  const KernelDescriptor& kernel = testing::kernel_named("hamming_match");
  std::vector<PlaneShape> shapes;
  for (const Plane& input : inputs) shapes.push_back({input.width(), input.height()});
  const PreparedKernel prepared = kernel.prepare(nlohmann::json::object(), shapes);  // ratio_q8 at its default
  Plane matches(kernels::kMatchWords, inputs[0].height(), {ElementType::s32, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, testing::plane_views(inputs), {matches.view()}};
  run_vector_node(binding, kernels::kMatchWords, 16, KernelBackend::counting, simd::Isa::scalar);
  int inliers = 0;
  for (int q = 0; q < matches.height(); ++q) {
    const int32_t train = matches.at<int32_t>(kernels::kMatchTrainIndex, q);
    inliers += matches.at<int32_t>(kernels::kMatchAccepted, q) == 1 && train >= 0 &&
               counterpart_of_train_row[static_cast<size_t>(train)] == q;
  }
  return inliers;
}

// Issue 8's acceptance: steering makes a rotated image match its original as well as an unrotated
// pair (within 10 % of inliers). Reference pair: the texture and a copy with Gaussian noise (sigma 2
// grey levels, seeded), sector-0 descriptors on both. Rotated pair: the texture and the texture
// rotated by s x 22.5 degrees, the rotated image's descriptors with the steered pattern of sector s.
// To show the test can fail, the unsteered pattern (sector 0) on the rotated image must give fewer
// than half the reference's inliers from 45 to 315 degrees (sectors 2 .. 14).
TEST(Brief256, SteeredRotatedPairMatchesAsWellAsAnUnrotatedPair) {
  constexpr int kSize = 241;
  const cv::Mat texture = smooth_texture(kSize, 71);
  const Plane original = plane_of(texture);
  const double centre = (kSize - 1) / 2.0;
  const std::vector<std::array<int32_t, 3>> points = grid_around(centre);
  cv::Mat noise(kSize, kSize, CV_16S);
  cv::RNG rng(72);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
  cv::Mat noisy;
  cv::add(texture, noise, noisy, cv::noArray(), CV_8U);  // saturating to 0 .. 255
  const int reference_inliers = matching_inliers(original, points, plane_of(noisy), points, 0, 73);
  std::printf("reference (noise sigma 2, sector 0): %d inliers of %zu\n", reference_inliers, points.size());
  EXPECT_GE(reference_inliers, static_cast<int>(points.size()) * 9 / 10);
  for (int sector = 1; sector < kernels::kBriefSectors; ++sector) {
    const Plane rotated = plane_of(rotated_by_sector(texture, sector));
    const std::vector<std::array<int32_t, 3>> moved = rotated_points(points, centre, sector);
    const int steered_inliers = matching_inliers(original, points, rotated, moved, sector, 74 + static_cast<uint32_t>(sector));
    const int unsteered_inliers = matching_inliers(original, points, rotated, moved, 0, 74 + static_cast<uint32_t>(sector));
    std::printf("sector %2d: inliers steered %3d, unsteered %3d, reference %3d\n", sector, steered_inliers,
                unsteered_inliers, reference_inliers);
    EXPECT_GE(10 * steered_inliers, 9 * reference_inliers) << "sector " << sector;
    if (sector >= 2 && sector <= 14) {
      EXPECT_LT(2 * unsteered_inliers, reference_inliers) << "sector " << sector;
    }
  }
}
#endif

}  // namespace
}  // namespace lpstereo
