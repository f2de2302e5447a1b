// hamming_match: bit-exact agreement of every back end with the reference at odd descriptor counts in
// padded buffers (train counts below, at and above one vector, invalid rows among them), records
// worked out by hand (nearest, second, ties, one valid train, invalid query and train rows, the
// ratio test's strict boundary, max_distance, the extreme distances 0 and 256), matching a brief256
// set against itself shuffled, the closed-form op count, refused shapes and parameters.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <numeric>
#include <random>
#include <tuple>

#include "arm/tasks/keypoint_record.h"
#include "dag/tile_executor.h"
#include "kernels/brief_hamming.h"
#include "kernels/brief_pattern.h"
#include "kernels/match_record.h"
#include "kernels/simd/emulated.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

using kernels::kBriefWords;
using testing::expect_all_back_ends_match_reference;
using testing::KernelCase;
using testing::random_plane;

// A keypoint list of `count` rows whose valid word follows `valid(k)` (positions are irrelevant to
// the matcher), padded stride.
template <class Valid>
Plane keypoint_list(int count, const Valid& valid) {
  Plane list(arm::kKeypointWords, count, {ElementType::s32, 0}, arm::kKeypointWords * 4 + 20);
  for (int k = 0; k < count; ++k) {
    int32_t* word = list.row<int32_t>(k);
    word[arm::kKeypointValid] = valid(k);
    word[arm::kKeypointXPx] = 16 + k;
    word[arm::kKeypointYPx] = 16;
    word[arm::kKeypointResponse] = 1000 - k;
  }
  return list;
}

// Train descriptors: random; query q is train (q * 7) % Nt with a few bits flipped (a near match),
// every fifth query random. Padded strides.
std::pair<Plane, Plane> descriptor_sets(int query_count, int train_count, uint32_t seed) {
  Plane train = random_plane(kBriefWords, train_count, {ElementType::u32, 0}, kBriefWords * 4 + 28, seed);
  Plane query = random_plane(kBriefWords, query_count, {ElementType::u32, 0}, kBriefWords * 4 + 4, seed + 1);
  std::mt19937 generator(seed + 2);
  for (int q = 0; q < query_count; ++q) {
    if (q % 5 == 4) continue;
    const int source = (q * 7) % train_count;
    for (int w = 0; w < kBriefWords; ++w) query.at<uint32_t>(w, q) = train.at<uint32_t>(w, source);
    const int flips = static_cast<int>(generator() % 40);
    for (int f = 0; f < flips; ++f) {
      const uint32_t bit = generator() % 256;
      query.at<uint32_t>(static_cast<int>(bit / 32), q) ^= uint32_t{1} << (bit % 32);
    }
  }
  return {std::move(query), std::move(train)};
}

KernelCase match_case(int query_count, int train_count, const nlohmann::json& params, uint32_t seed) {
  KernelCase test_case{"hamming_match", params, {}, 12};
  auto [query, train] = descriptor_sets(query_count, train_count, seed);
  test_case.inputs.push_back(std::move(query));
  test_case.inputs.push_back(keypoint_list(query_count, [](int k) { return k % 11 == 5 ? 0 : (k % 13 == 6 ? 0x10000 : 1); }));
  test_case.inputs.push_back(std::move(train));
  test_case.inputs.push_back(keypoint_list(train_count, [](int k) { return k % 9 == 4 ? 0 : (k % 17 == 3 ? -1 : 1); }));
  return test_case;
}

TEST(HammingMatch, MatchesReferenceAtOddCountsInPaddedBuffers) {
  for (int train_count : {1, 2, 3, 15, 16, 17, 157}) {
    for (const nlohmann::json& params : {nlohmann::json::object(), nlohmann::json{{"ratio_q8", 256}, {"max_distance", 30}},
                                         nlohmann::json{{"ratio_q8", 0}}}) {
      const std::vector<Plane> reference =
          expect_all_back_ends_match_reference(match_case(203, train_count, params, 31), {{4, 203}, {4, 64}, {4, 7}, {4, 1}});
      if (train_count == 157 && params.empty()) {
        // Not a degenerate run: most valid near-match queries are accepted, and some queries are not.
        int accepted = 0;
        for (int q = 0; q < 203; ++q) accepted += reference[0].at<int32_t>(kernels::kMatchAccepted, q);
        EXPECT_GT(accepted, 100);
        EXPECT_LT(accepted, 203);
      }
    }
  }
}

struct Record {
  int32_t train, best, second, accepted;
};

Record record_of(const Plane& matches, int q) {
  return {matches.at<int32_t>(kernels::kMatchTrainIndex, q), matches.at<int32_t>(kernels::kMatchBestDistance, q),
          matches.at<int32_t>(kernels::kMatchSecondDistance, q), matches.at<int32_t>(kernels::kMatchAccepted, q)};
}

Plane run_match(const std::vector<Plane>& inputs, const nlohmann::json& params, KernelBackend backend, simd::Isa isa) {
  const KernelDescriptor& kernel = testing::kernel_named("hamming_match");
  std::vector<PlaneShape> shapes;
  std::vector<PlaneView> views;
  for (const Plane& input : inputs) {
    shapes.push_back({input.width(), input.height()});
    views.push_back(input.view());
  }
  const PreparedKernel prepared = kernel.prepare(params, shapes);
  Plane output(kernels::kMatchWords, inputs[0].height(), {ElementType::s32, 0});
  VectorNodeBinding binding{&kernel, prepared.params.get(), BorderMode::replicate, 0, views, {output.view()}};
  run_vector_node(binding, kernels::kMatchWords, 3, backend, isa);
  return output;
}

template <class Check>
void on_every_back_end(const Check& check) {
  for (simd::Isa isa : simd::available_isas()) check(KernelBackend::native, isa, std::string(simd::isa_name(isa)));
  check(KernelBackend::counting, simd::Isa::scalar, "counting");
}

// `base` with the first `bits` bits (in bit order over the 8 words) flipped.
std::array<uint32_t, 8> flipped(const std::array<uint32_t, 8>& base, int bits) {
  std::array<uint32_t, 8> result = base;
  for (int bit = 0; bit < bits; ++bit) result[static_cast<size_t>(bit / 32)] ^= uint32_t{1} << (bit % 32);
  return result;
}

Plane descriptor_plane(const std::vector<std::array<uint32_t, 8>>& rows) {
  Plane plane(kBriefWords, static_cast<int>(rows.size()), {ElementType::u32, 0});
  for (size_t k = 0; k < rows.size(); ++k) {
    for (int w = 0; w < kBriefWords; ++w) plane.at<uint32_t>(w, static_cast<int>(k)) = rows[k][static_cast<size_t>(w)];
  }
  return plane;
}

// Distances chosen by construction (flipping known numbers of bits), so each record is known
// without running any matcher.
TEST(HammingMatch, RecordsWorkedOutByHand) {
  const std::array<uint32_t, 8> a = {0x12345678u, 0x9ABCDEF0u, 0x0F0F0F0Fu, 0xF0F0F0F0u, 0x13579BDFu, 0x2468ACE0u, 0xDEADBEEFu, 0x01234567u};
  const std::array<uint32_t, 8> b = flipped(a, 100);
  std::array<uint32_t, 8> complement{};
  for (int w = 0; w < 8; ++w) complement[static_cast<size_t>(w)] = ~a[static_cast<size_t>(w)];
  // Trains: 0 = a + 10 bits, 1 = a + 3 bits, 2 = a exact but INVALID, 3 = b + 5, 4 = b + 5 (a tie),
  // 5 = complement of a (256 from a), 6 .. 20 = b + 60 (fillers past one vector).
  std::vector<std::array<uint32_t, 8>> trains = {flipped(a, 10), flipped(a, 3), a, flipped(b, 5), flipped(b, 5), complement};
  for (int k = 6; k < 21; ++k) trains.push_back(flipped(b, 60));
  const Plane train_descriptors = descriptor_plane(trains);
  const Plane train_keypoints = keypoint_list(21, [](int k) { return k == 2 ? 0 : 1; });
  // Queries: 0 = a, 1 = b, 2 = a (invalid row), 3 = complement of a.
  const Plane query_descriptors = descriptor_plane({a, b, a, complement});
  const Plane query_keypoints = keypoint_list(4, [](int k) { return k == 2 ? 0 : 1; });
  const std::vector<Plane> inputs = {query_descriptors.clone(), query_keypoints.clone(), train_descriptors.clone(), train_keypoints.clone()};
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Plane matches = run_match(inputs, {{"ratio_q8", 205}}, backend, isa);
    // a: train 1 at 3, second train 0 at 10 (the invalid exact train 2 is ignored); 768 < 2050.
    const Record q0 = record_of(matches, 0);
    EXPECT_EQ(q0.train, 1) << label;
    EXPECT_EQ(q0.best, 3) << label;
    EXPECT_EQ(q0.second, 10) << label;
    EXPECT_EQ(q0.accepted, 1) << label;
    // b: trains 3 and 4 tie at 5: the lower row wins, second = 5, the ratio test rejects.
    const Record q1 = record_of(matches, 1);
    EXPECT_EQ(q1.train, 3) << label;
    EXPECT_EQ(q1.best, 5) << label;
    EXPECT_EQ(q1.second, 5) << label;
    EXPECT_EQ(q1.accepted, 0) << label;
    const Record q2 = record_of(matches, 2);
    EXPECT_EQ(q2.train, kernels::kMatchNoTrain) << label;
    EXPECT_EQ(q2.best, kernels::kMatchNoDistance) << label;
    EXPECT_EQ(q2.second, kernels::kMatchNoDistance) << label;
    EXPECT_EQ(q2.accepted, 0) << label;
    // The complement: train 5 at distance 0 (the second is derived below).
    const Record q3 = record_of(matches, 3);
    EXPECT_EQ(q3.train, 5) << label;
    EXPECT_EQ(q3.best, 0) << label;
    EXPECT_EQ(q3.accepted, 1) << label;
  });
  // The complement query's second distance, derived: d(~a, t) = 256 - d(a, t).
  int expected_second = 256;
  for (int k = 0; k < 21; ++k) {
    if (k == 2 || k == 5) continue;
    expected_second = std::min(expected_second, 256 - kernels::brief_hamming_distance(a.data(), trains[static_cast<size_t>(k)].data()));
  }
  EXPECT_EQ(record_of(run_match(inputs, {}, KernelBackend::counting, simd::Isa::scalar), 3).second, expected_second);
}

// The ratio test's boundary is strict, max_distance is inclusive, and one valid train accepts nothing.
TEST(HammingMatch, RatioBoundaryMaxDistanceAndASingleTrain) {
  const std::array<uint32_t, 8> a = {1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u};
  // best 8, second 10: 8 x 256 = 2048 = 204.8 x 10: ratio_q8 205 accepts (2048 < 2050), 204 rejects (2048 < 2040 fails).
  const std::vector<Plane> inputs = {descriptor_plane({a}), keypoint_list(1, [](int) { return 1; }),
                                     descriptor_plane({flipped(a, 10), flipped(a, 8)}), keypoint_list(2, [](int) { return 1; })};
  // 256 x 8 < r x 10 <=> r > 204.8; boundary case: 256 x 5 = 1280 = 128 x 10 with a best of 5 below.
  const std::vector<Plane> boundary = {descriptor_plane({a}), keypoint_list(1, [](int) { return 1; }),
                                       descriptor_plane({flipped(a, 10), flipped(a, 5)}), keypoint_list(2, [](int) { return 1; })};
  const std::vector<Plane> single = {descriptor_plane({a}), keypoint_list(1, [](int) { return 1; }),
                                     descriptor_plane({flipped(a, 1), flipped(a, 0)}), keypoint_list(2, [](int k) { return k == 0 ? 1 : 0; })};
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    EXPECT_EQ(record_of(run_match(inputs, {{"ratio_q8", 205}}, backend, isa), 0).accepted, 1) << label;
    EXPECT_EQ(record_of(run_match(inputs, {{"ratio_q8", 204}}, backend, isa), 0).accepted, 0) << label;
    EXPECT_EQ(record_of(run_match(boundary, {{"ratio_q8", 128}}, backend, isa), 0).accepted, 0) << label;  // equal: rejected
    EXPECT_EQ(record_of(run_match(boundary, {{"ratio_q8", 129}}, backend, isa), 0).accepted, 1) << label;
    EXPECT_EQ(record_of(run_match(inputs, {{"ratio_q8", 256}, {"max_distance", 8}}, backend, isa), 0).accepted, 1) << label;
    EXPECT_EQ(record_of(run_match(inputs, {{"ratio_q8", 256}, {"max_distance", 7}}, backend, isa), 0).accepted, 0) << label;
    const Record lone = record_of(run_match(single, {{"ratio_q8", 256}}, backend, isa), 0);
    EXPECT_EQ(lone.train, 0) << label;
    EXPECT_EQ(lone.best, 1) << label;
    EXPECT_EQ(lone.second, kernels::kMatchNoDistance) << label;
    EXPECT_EQ(lone.accepted, 0) << label;
  });
}

// A brief256 descriptor set matched against itself in shuffled order: every valid row finds its
// own copy at distance 0 (descriptors of random patches are distinct).
TEST(HammingMatch, FindsEachDescriptorOfABrief256SetInAShuffledCopy) {
  const int count = 61;
  Plane image = random_plane(200, 120, {ElementType::u8, 0}, 208, 41);
  Plane keypoints(arm::kKeypointWords, count, {ElementType::s32, 0});
  std::mt19937 generator(42);
  for (int k = 0; k < count; ++k) {
    keypoints.at<int32_t>(arm::kKeypointValid, k) = k < count - 4 ? 1 : 0;
    keypoints.at<int32_t>(arm::kKeypointXPx, k) = 16 + (k % 12) * 14;  // distinct places
    keypoints.at<int32_t>(arm::kKeypointYPx, k) = 16 + (k / 12) * 17;
    keypoints.at<int32_t>(arm::kKeypointResponse, k) = 0;
  }
  const KernelDescriptor& brief = testing::kernel_named("brief256");
  const PreparedKernel prepared = brief.prepare({}, {{200, 120}, {arm::kKeypointWords, count}});
  Plane descriptors(kBriefWords, count, {ElementType::u32, 0});
  VectorNodeBinding binding{&brief, prepared.params.get(), BorderMode::replicate, 0, {image.view(), keypoints.view()}, {descriptors.view()}};
  run_vector_node(binding, kBriefWords, 16, KernelBackend::counting, simd::Isa::scalar);
  std::vector<int> order(count);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), generator);
  Plane shuffled_descriptors(kBriefWords, count, {ElementType::u32, 0});
  Plane shuffled_keypoints(arm::kKeypointWords, count, {ElementType::s32, 0});
  for (int k = 0; k < count; ++k) {
    for (int w = 0; w < kBriefWords; ++w) shuffled_descriptors.at<uint32_t>(w, k) = descriptors.at<uint32_t>(w, order[static_cast<size_t>(k)]);
    for (int w = 0; w < arm::kKeypointWords; ++w) shuffled_keypoints.at<int32_t>(w, k) = keypoints.at<int32_t>(w, order[static_cast<size_t>(k)]);
  }
  const std::vector<Plane> inputs = {descriptors.clone(), keypoints.clone(), shuffled_descriptors.clone(), shuffled_keypoints.clone()};
  on_every_back_end([&](KernelBackend backend, simd::Isa isa, const std::string& label) {
    const Plane matches = run_match(inputs, {}, backend, isa);
    for (int q = 0; q < count; ++q) {
      const Record record = record_of(matches, q);
      if (q >= count - 4) {
        EXPECT_EQ(record.train, kernels::kMatchNoTrain) << label << " query " << q;
        continue;
      }
      EXPECT_EQ(order[static_cast<size_t>(record.train)], q) << label << " query " << q;
      EXPECT_EQ(record.best, 0) << label;
      EXPECT_GT(record.second, 0) << label;
      EXPECT_EQ(record.accepted, 1) << label;
    }
  });
}

// The closed form of kernels/hamming_match.cpp for the counting back end (L = 16).
TEST(HammingMatch, CountedOpsEqualClosedForm) {
  static_assert(simd::Counting::kLanesU32 == 16, "the closed form assumes 16 32-bit lanes");
  for (auto [queries, trains, tile_height] : std::vector<std::tuple<int, int, int>>{{203, 157, 203}, {203, 157, 64}, {1, 1, 1}, {40, 33, 7}, {9, 16, 4}}) {
    const KernelCase test_case = match_case(queries, trains, {{"ratio_q8", 200}}, 51);
    const int64_t c = (trains + 15) / 16;
    simd::OpCounts expected;
    for (const TileRect& tile : make_tiles(kernels::kMatchWords, queries, kernels::kMatchWords, tile_height)) {
      const int64_t k = tile.height;
      expected[simd::OpClass::load] += 1 + 9 * c * k;
      expected[simd::OpClass::store] += 9 * c + k;
      expected[simd::OpClass::arith] += 2 * c + k * (12 * c + 12);
      expected[simd::OpClass::logic] += 11 * c + k * (9 * c + 14);
      expected[simd::OpClass::compare] += 3 + 2 * c + k * (c + 7);
      expected[simd::OpClass::multiply] += 2 * c + k;
      expected[simd::OpClass::shift] += 8 * c + k;
      expected[simd::OpClass::popcount] += 8 * c * k;
      expected[simd::OpClass::gather] += 18 * c;
      expected[simd::OpClass::permute] += 15 + 21 * k;
    }
    EXPECT_TRUE(testing::op_counts_equal(expected, testing::count_ops(test_case, kernels::kMatchWords, tile_height)))
        << queries << " queries, " << trains << " trains, tiles of " << tile_height;
  }
}

TEST(HammingMatchMustFail, RefusesBadShapesAndParameters) {
  const KernelDescriptor& kernel = testing::kernel_named("hamming_match");
  const std::vector<PlaneShape> good = {{8, 10}, {4, 10}, {8, 20}, {4, 20}};
  EXPECT_NO_THROW(kernel.prepare({}, good));
  EXPECT_THROW(kernel.prepare({{"ratio_q8", 257}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({{"max_distance", -1}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({{"ratio", 0.8}}, good), KernelError);
  EXPECT_THROW(kernel.prepare({}, {{8, 10}, {4, 10}, {8, 20}}), KernelError);
  EXPECT_THROW(kernel.prepare({}, {{8, 10}, {4, 10}, {8, 0}, {4, 0}}), KernelError);
  try {
    kernel.prepare({}, {{8, 10}, {4, 10}, {8, 20}, {4, 19}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'train_keypoints': expected as many rows as 'train_descriptors' (20), got 19");
  }
  try {
    kernel.prepare({}, {{7, 10}, {4, 10}, {8, 20}, {4, 20}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'query_descriptors': expected a width of 8 words (kernels/brief256.cpp), got 7");
  }
}

}  // namespace
}  // namespace lpstereo
