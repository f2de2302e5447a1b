// The bag-of-binary-words vocabulary tree (arm/localization/vocabulary_tree.h): k-majority centres,
// descent to the leaves, TF-IDF and the L1 score, the query's ranking, the file and its failures.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "arm/localization/vocabulary_tree.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::arm::localization {
namespace {

BriefDescriptor random_descriptor(std::mt19937& generator) {
  BriefDescriptor d;
  for (uint32_t& word : d) word = static_cast<uint32_t>(generator());
  return d;
}

// Flips `bits` distinct random bits.
BriefDescriptor with_noise(BriefDescriptor d, int bits, std::mt19937& generator) {
  std::vector<int> positions(256);
  for (int i = 0; i < 256; ++i) positions[static_cast<size_t>(i)] = i;
  std::shuffle(positions.begin(), positions.end(), generator);
  for (int i = 0; i < bits; ++i) d[static_cast<size_t>(positions[static_cast<size_t>(i)] / 32)] ^= 1u << (positions[static_cast<size_t>(i)] % 32);
  return d;
}

// Keyframes of random descriptors: each keyframe its own `per_keyframe` descriptors.
std::vector<std::vector<BriefDescriptor>> random_keyframes(int keyframes, int per_keyframe, uint32_t seed) {
  std::mt19937 generator(seed);
  std::vector<std::vector<BriefDescriptor>> all(static_cast<size_t>(keyframes));
  for (auto& keyframe : all) {
    for (int i = 0; i < per_keyframe; ++i) keyframe.push_back(random_descriptor(generator));
  }
  return all;
}

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

// Expects load to throw VocabularyError with one line naming the file and containing `needle`.
void expect_load_fails(const std::string& path, const std::string& needle) {
  try {
    VocabularyTree::load(path);
    ADD_FAILURE() << "no error for " << needle;
  } catch (const VocabularyError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(needle), std::string::npos) << message;
  }
}

TEST(VocabularyTree, MajorityCentreIsTheBitwiseMajority) {
  // Three descriptors, worked by hand on word 0 and word 7 (the others zero):
  //   a = 0b1100, b = 0b1010, c = 0b0110 -> bits 1 and 2 twice, bit 3 twice, bit 0 never:
  //   majority (>= 2 of 3) = 0b1110; word 7: only a has bit 31 -> 0.
  BriefDescriptor a{}, b{}, c{};
  a[0] = 0b1100;
  b[0] = 0b1010;
  c[0] = 0b0110;
  a[7] = 0x80000000u;
  const BriefDescriptor centre = majority_descriptor({&a, &b, &c});
  BriefDescriptor expected{};
  expected[0] = 0b1110;
  EXPECT_EQ(centre, expected);
  // Two descriptors: a tie (1 of 2) gives 1 (DBoW2: N/2 + N%2 = 1 is enough), so the centre is the OR.
  const BriefDescriptor pair = majority_descriptor({&a, &b});
  BriefDescriptor expected_pair{};
  expected_pair[0] = 0b1110;
  expected_pair[7] = 0x80000000u;
  EXPECT_EQ(pair, expected_pair);
  // Four: bit 3 in a, b (2 of 4: a tie, 1), bit 0 in none, bit 2 in a, c (1).
  BriefDescriptor d{};
  d[0] = 0b0001;
  const BriefDescriptor four = majority_descriptor({&a, &b, &c, &d});
  BriefDescriptor expected_four{};
  expected_four[0] = 0b1110;  // bit 0: 1 of 4 -> 0; bits 1, 2, 3: 2 of 4 -> 1
  EXPECT_EQ(four, expected_four);
  EXPECT_EQ(majority_descriptor({}), BriefDescriptor{});
}

TEST(VocabularyTree, ShapeFollowsBranchingAndDepthAndTrainingIsDeterministic) {
  const auto keyframes = random_keyframes(20, 100, 3);
  const VocabularyParameters parameters{.branching = 4, .depth = 3, .max_iterations = 8, .seed = 11};
  const VocabularyTree tree = VocabularyTree::train(keyframes, parameters);
  EXPECT_LE(tree.word_count(), 64u);   // 4^3
  EXPECT_GE(tree.word_count(), 40u);   // 2000 random descriptors fill nearly every leaf
  for (const VocabularyTree::Node& node : tree.nodes()) EXPECT_LE(node.child_count, 4u);
  EXPECT_EQ(VocabularyTree::train(keyframes, parameters), tree);
  VocabularyParameters other = parameters;
  other.seed = 12;
  EXPECT_FALSE(VocabularyTree::train(keyframes, other) == tree);
  // IDF = log(N / n_i) with n_i counted independently here.
  std::vector<std::vector<int>> keyframes_of_word(tree.word_count());
  for (size_t k = 0; k < keyframes.size(); ++k) {
    for (const BriefDescriptor& d : keyframes[k]) {
      auto& list = keyframes_of_word[tree.word_of(d)];
      if (list.empty() || list.back() != static_cast<int>(k)) list.push_back(static_cast<int>(k));
    }
  }
  for (uint32_t w = 0; w < tree.word_count(); ++w) {
    ASSERT_FALSE(keyframes_of_word[w].empty()) << "word " << w;
    EXPECT_DOUBLE_EQ(tree.idf(w), std::log(20.0 / static_cast<double>(keyframes_of_word[w].size()))) << "word " << w;
  }
}

TEST(VocabularyTree, TrainingDescriptorLandsInItsOwnLeaf) {
  // Every training descriptor was clustered down to a leaf; descending from the root must reach the
  // leaf whose centre is nearest among its siblings at every level, i.e. its cluster: checked by
  // comparing with an independent walk that takes the minimum distance at each level.
  const auto keyframes = random_keyframes(10, 60, 5);
  const VocabularyTree tree = VocabularyTree::train(keyframes, {.branching = 5, .depth = 3, .max_iterations = 5, .seed = 2});
  const auto& nodes = tree.nodes();
  int checked = 0;
  for (const auto& keyframe : keyframes) {
    for (const BriefDescriptor& d : keyframe) {
      const uint32_t word = tree.word_of(d);
      const uint32_t leaf = tree.leaf_of_word(word);
      EXPECT_EQ(nodes[leaf].child_count, 0u);
      EXPECT_EQ(nodes[leaf].word, word);
      // Independent walk.
      uint32_t node = 0;
      while (nodes[node].child_count) {
        uint32_t best = nodes[node].first_child;
        for (uint32_t c = 0; c < nodes[node].child_count; ++c) {
          const uint32_t child = nodes[node].first_child + c;
          int dc = 0, db = 0;
          for (int i = 0; i < 8; ++i) {
            dc += std::popcount(nodes[child].centre[static_cast<size_t>(i)] ^ d[static_cast<size_t>(i)]);
            db += std::popcount(nodes[best].centre[static_cast<size_t>(i)] ^ d[static_cast<size_t>(i)]);
          }
          if (dc < db) best = child;
        }
        node = best;
      }
      EXPECT_EQ(node, leaf);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 600);
  // A vocabulary trained on 3 keyframes of 5 descriptors each, depth 4, branching 16: every
  // descriptor gets its own cluster at the first split (16 >= 15 distinct), so each training
  // descriptor's word is different from every other's.
  const auto few = random_keyframes(3, 5, 9);
  const VocabularyTree fine = VocabularyTree::train(few, {.branching = 16, .depth = 4, .max_iterations = 5, .seed = 4});
  std::vector<uint32_t> words;
  for (const auto& keyframe : few) {
    for (const BriefDescriptor& d : keyframe) words.push_back(fine.word_of(d));
  }
  std::sort(words.begin(), words.end());
  EXPECT_EQ(std::unique(words.begin(), words.end()), words.end());
  EXPECT_EQ(fine.word_count(), 15u);
}

TEST(VocabularyTree, L1ScoreOfHandMadeVectors) {
  // v = (0.5, 0.5, 0), w = (0, 0.5, 0.5) over words 1, 2, 3: |v - w|_1 = 0.5 + 0 + 0.5 = 1 -> 0.5.
  const BowVector v = {{1, 0.5}, {2, 0.5}}, w = {{2, 0.5}, {3, 0.5}};
  EXPECT_DOUBLE_EQ(bow_l1_score(v, w), 0.5);
  EXPECT_DOUBLE_EQ(bow_l1_score(v, v), 1.0);
  EXPECT_DOUBLE_EQ(bow_l1_score(v, {{7, 1.0}}), 0.0);
  EXPECT_DOUBLE_EQ(bow_l1_score(v, {}), 0.0);
  // (0.25, 0.75) against (0.75, 0.25): |.|_1 = 1 -> 0.5.
  EXPECT_DOUBLE_EQ(bow_l1_score({{4, 0.25}, {9, 0.75}}, {{4, 0.75}, {9, 0.25}}), 0.5);
}

TEST(VocabularyTree, QueryWithNoisyOwnDescriptorsRanksTheKeyframeFirst) {
  const auto keyframes = random_keyframes(200, 80, 21);
  const VocabularyTree tree = VocabularyTree::train(keyframes, {.branching = 8, .depth = 4, .max_iterations = 6, .seed = 1});
  BowDatabase index(tree);
  for (const auto& keyframe : keyframes) index.add(keyframe);
  ASSERT_EQ(index.size(), 200u);
  // Transform is L1-normalised.
  double sum = 0;
  for (const auto& entry : index.vector_of(17)) sum += entry.second;
  EXPECT_NEAR(sum, 1.0, 1e-12);
  std::mt19937 generator(77);
  for (const size_t target : {0u, 17u, 123u, 199u}) {
    std::vector<BriefDescriptor> query;
    for (const BriefDescriptor& d : keyframes[target]) query.push_back(with_noise(d, 8, generator));
    ArmWork work;
    const std::vector<BowCandidate> top = index.query(query, 5, &work);
    ASSERT_FALSE(top.empty());
    EXPECT_EQ(top[0].keyframe_index, target);
    for (size_t i = 1; i < top.size(); ++i) EXPECT_GE(top[i - 1].score, top[i].score);
    // The score through the inverted index equals the direct L1 score of the two vectors.
    EXPECT_NEAR(top[0].score, bow_l1_score(tree.transform(query), index.vector_of(target)), 1e-12);
    EXPECT_GT(top[0].score, 0.3);
    if (top.size() > 1) {
      EXPECT_GT(top[0].score, 2 * top[1].score);
    }
    // Counted work: at least one descent (k distances per level) per descriptor, 24 ops each.
    EXPECT_GE(work.scalar_ops, 80u * 8u * 24u);
    EXPECT_GT(work.memory_bytes, 0u);
  }
  EXPECT_TRUE(index.query({}, 3).empty());
  EXPECT_THROW(index.query(keyframes[0], 0), std::invalid_argument);
}

TEST(VocabularyTree, RefusesBadParameters) {
  const auto keyframes = random_keyframes(2, 5, 1);
  EXPECT_THROW(VocabularyTree::train(keyframes, {.branching = 1}), std::invalid_argument);
  EXPECT_THROW(VocabularyTree::train(keyframes, {.depth = 0}), std::invalid_argument);
  EXPECT_THROW(VocabularyTree::train(keyframes, {.max_iterations = 0}), std::invalid_argument);
  EXPECT_THROW(VocabularyTree::train({{}, {}}, {}), std::invalid_argument);
}

class VocabularyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    tree_ = VocabularyTree::train(random_keyframes(30, 40, 8), {.branching = 6, .depth = 3, .max_iterations = 5, .seed = 3});
    path_ = (directory_ / "vocabulary.bin").string();
    tree_.save(path_);
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_vocabulary"};  // per process and test: release and debug-asan may run it at once
  const std::filesystem::path& directory_ = scratch_.root();
  VocabularyTree tree_;
  std::string path_;
};

TEST_F(VocabularyFile, SaveLoadRoundTripIsEqual) {
  const VocabularyTree loaded = VocabularyTree::load(path_);
  EXPECT_EQ(loaded, tree_);
  EXPECT_EQ(loaded.word_count(), tree_.word_count());
  // Header fields at their documented offsets: magic, version 1, branching 6, depth 3, 30 keyframes.
  const std::vector<uint8_t> bytes = read_bytes(path_);
  EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 4), "LPVT");
  EXPECT_EQ(bytes[4], 1);
  EXPECT_EQ(bytes[8], 6);
  EXPECT_EQ(bytes[12], 3);
  EXPECT_EQ(bytes[16], 30);
  const size_t nodes = tree_.nodes().size(), words = tree_.word_count();
  EXPECT_EQ(bytes.size(), 28 + nodes * 44 + words * 12 + 4);
  EXPECT_FALSE(std::filesystem::exists(path_ + ".tmp"));
}

TEST_F(VocabularyFile, CorruptFilesFailWithOneLine) {
  const std::vector<uint8_t> good = read_bytes(path_);
  const std::string bad = (directory_ / "bad.bin").string();

  std::vector<uint8_t> bytes = good;
  bytes[0] = 'X';
  write_bytes(bad, bytes);
  expect_load_fails(bad, "magic bytes 58 50 56 54, expected \"LPVT\"");

  bytes = good;
  bytes[4] = 2;
  write_bytes(bad, bytes);
  expect_load_fails(bad, "version 2, expected 1");

  bytes = good;
  bytes[good.size() / 2] ^= 0x10;
  write_bytes(bad, bytes);
  expect_load_fails(bad, "checksum");

  bytes.assign(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(good.size() - 100));
  write_bytes(bad, bytes);
  expect_load_fails(bad, "checksum");

  bytes.assign(good.begin(), good.begin() + 20);
  write_bytes(bad, bytes);
  expect_load_fails(bad, "20 bytes, expected at least 32");

  expect_load_fails((directory_ / "missing.bin").string(), "cannot open");
}

// A well-formed checksum over a broken tree: the links are checked after the checksum.
TEST_F(VocabularyFile, BrokenLinksUnderAValidChecksumFail) {
  std::vector<uint8_t> bytes = read_bytes(path_);
  const auto reseal = [](std::vector<uint8_t>& b) {
    const size_t body = b.size() - 4;
    const uint32_t crc = crc32_ieee(b.data(), body);
    for (int i = 0; i < 4; ++i) b[body + static_cast<size_t>(i)] = static_cast<uint8_t>(crc >> (8 * i));
  };
  const std::string bad = (directory_ / "links.bin").string();
  // Node 0 (the root, at byte 28): its first child pointing at itself.
  std::fill(bytes.begin() + 28, bytes.begin() + 32, uint8_t{0});
  reseal(bytes);
  write_bytes(bad, bytes);
  expect_load_fails(bad, "node 0 children 0 .. +");
  // The node count one too high: the sizes no longer add up.
  bytes = read_bytes(path_);
  bytes[20] = static_cast<uint8_t>(bytes[20] + 1);
  reseal(bytes);
  write_bytes(bad, bytes);
  expect_load_fails(bad, "bytes (at least 1 node)");
}

}  // namespace
}  // namespace lpstereo::arm::localization
