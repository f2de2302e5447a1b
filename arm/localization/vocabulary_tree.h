// A bag-of-binary-words vocabulary tree over BRIEF-256 descriptors for relocalization anywhere in the
// map (issue 8 item 4), after D. Galvez-Lopez and J. D. Tardos, "Bags of Binary Words for Fast Place
// Recognition in Image Sequences", IEEE T-RO 28(5), 2012 (DBoW2).
//
// Vocabulary (§III of the paper): a tree of branching factor k and depth L built by hierarchical
// k-majority clustering (k-medians in Hamming space) of training descriptors:
//   - at a node, its descriptors are split into at most k clusters: seeds by k-means++ (Arthur and
//     Vassilvitskii, SODA 2007: the first uniformly, each next one with probability proportional to
//     D(x)^2, the squared Hamming distance to the nearest seed so far), drawn with the seeded
//     SplitMix64 generator of ransac_sampling.h (RansacRandom), so a seed gives the same tree on every
//     platform; fewer than k seeds when fewer distinct descriptors remain;
//   - then Lloyd iterations (at most max_iterations, stopping when no assignment changes): each
//     descriptor to its nearest centre (ties: the lowest-numbered centre), each centre to the bitwise
//     majority of its members: bit = 1 when 2 x (members with the bit set) >= members (DBoW2's
//     FORB::meanValue: N/2 + N%2 ones or more; a tie of an even count gives 1); a centre left without
//     members keeps its position and is dropped when the children are made;
//   - each cluster becomes a child node and is split again, down to depth L; a node at depth L or
//     with a single distinct descriptor is a leaf. The leaves are the words (numbered in the order
//     the tree is built, depth first).
// Word of a descriptor: from the root, descend to the child whose centre is nearest (ties: the
// lowest-numbered child) until a leaf (at most k x L Hamming distances).
// Weights (DBoW2 TF-IDF): idf_i = log(N / n_i), N = training keyframes, n_i = training keyframes
// with a descriptor in word i (>= 1: every leaf holds a training descriptor). A keyframe's
// bag-of-words vector: v_i = (n_id / n_d) idf_i (n_id of its n_d descriptors in word i), L1-normalised;
// words with weight 0 (in every training keyframe: they tell nothing) are left out.
// Score (DBoW2's L1 score, paper eq. 2): s(v, w) = 1 - 0.5 |v - w|_1 in [0, 1] (1: the same vector),
// computed through the inverted index over the words both vectors hold, since for L1-normalised v
// and w: |v - w|_1 = 2 + sum_{i: v_i != 0, w_i != 0} (|v_i - w_i| - |v_i| - |w_i|).
//
// File format (little-endian; version 1):
//   header  "LPVT" (4 bytes), version u32, branching u32, depth u32, training keyframes u32,
//           node count u32, word count u32
//   nodes   per node (node 0 = the root): first child u32, child count u32 (0: a leaf), word u32
//           (0xFFFFFFFF for an inner node), centre 8 u32 (kernels/brief256.cpp's word order)
//   words   per word: its leaf node u32, idf f64
//   trailer CRC-32 (crc32_ieee of keyframe_database.h) of every byte before it, u32
// Reading checks, in the order the keyframe database uses, each failing with one line naming the
// file, the expected and the actual value: the file opens, is at least header + trailer long, the
// magic, the version, the checksum, then the sizes against the bytes left (so nothing trails), the
// tree's links (every child index inside the node array and after its parent, each node with one
// parent, no node below depth L) and the words (one per leaf, each leaf's word pointing back to it).
//
// Counted ARM work of a query (BowDatabase::query, ArmWork of dag/arm_task.h), per descriptor and
// per visited inverted-index entry, from the loops below:
//   - a Hamming distance to a centre: 24 scalar ops (8 xor, 8 popcount, 8 add) and 32 bytes (the
//     centre's words; the query descriptor stays in registers); a descent visits k children per
//     level, at most k x L distances per descriptor;
//   - building the query vector: 4 scalar ops per descriptor (count the word), then per distinct word
//     6 ops (tf x idf, normalise) and 12 bytes (its idf and the vector entry);
//   - an inverted-index entry (keyframe u32, weight f64): 6 scalar ops (|q - w| - q - w, accumulate)
//     and its 12 bytes (the entries stream from DRAM; the per-keyframe score array, 8 bytes per
//     keyframe, 8 kB for 1,000, stays in the cache and is not counted);
//   - ranking: 8 scalar ops per keyframe that shares a word with the query (its score, the test
//     against the current top N of the partial sort; an estimate of the average, not a bound).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "arm/localization/keyframe_database.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::localization {

class VocabularyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct VocabularyParameters {
  int branching = 10;      // k, children per node, 2 .. 64
  int depth = 4;           // L, levels below the root, 1 .. 8 (k^L words at most)
  int max_iterations = 10; // Lloyd iterations per split, >= 1
  uint64_t seed = 1;       // k-means++ seeding (RansacRandom)
};

// Sparse bag-of-words vector: (word, weight) sorted by word, weights L1-normalised (sum 1) or empty.
using BowVector = std::vector<std::pair<uint32_t, double>>;

// The bitwise majority of the descriptors (the k-majority centre of the header comment): bit = 1 when
// 2 x (descriptors with the bit) >= descriptors. Zero for an empty list.
BriefDescriptor majority_descriptor(const std::vector<const BriefDescriptor*>& descriptors);

class VocabularyTree {
 public:
  static constexpr uint32_t kFileVersion = 1;
  static constexpr uint32_t kNoWord = 0xFFFFFFFFu;

  struct Node {
    uint32_t first_child = 0;
    uint32_t child_count = 0;  // 0: a leaf
    uint32_t word = kNoWord;   // leaves only
    BriefDescriptor centre{};
    bool operator==(const Node&) const = default;
  };

  // Trains on the descriptors of a set of keyframes (one list per keyframe; the keyframe grouping
  // gives the IDF). Deterministic for the parameters (seed included). Throws std::invalid_argument for
  // parameters out of range or no descriptors at all.
  static VocabularyTree train(const std::vector<std::vector<BriefDescriptor>>& keyframe_descriptors,
                              const VocabularyParameters& parameters);

  // The word (leaf) of a descriptor; adds the Hamming distances it computed to *work when given.
  uint32_t word_of(const BriefDescriptor& descriptor, ArmWork* work = nullptr) const;
  // The TF-IDF vector of a keyframe's descriptors (header comment); empty for no descriptors.
  BowVector transform(const std::vector<BriefDescriptor>& descriptors, ArmWork* work = nullptr) const;

  uint32_t word_count() const { return static_cast<uint32_t>(idf_.size()); }
  double idf(uint32_t word) const { return idf_.at(word); }
  uint32_t leaf_of_word(uint32_t word) const { return word_leaf_.at(word); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  uint32_t training_keyframes() const { return training_keyframes_; }
  const std::vector<Node>& nodes() const { return nodes_; }

  // The file format of the header comment; save writes a temporary file and renames it. Both throw
  // VocabularyError with one line naming the file.
  void save(const std::string& path) const;
  static VocabularyTree load(const std::string& path);

  bool operator==(const VocabularyTree&) const = default;

 private:
  int branching_ = 0;
  int depth_ = 0;
  uint32_t training_keyframes_ = 0;
  std::vector<Node> nodes_;
  std::vector<uint32_t> word_leaf_;  // word -> leaf node
  std::vector<double> idf_;          // word -> idf
};

// L1 score of two L1-normalised bag-of-words vectors: 1 - 0.5 |v - w|_1 (header comment).
double bow_l1_score(const BowVector& v, const BowVector& w);

struct BowCandidate {
  size_t keyframe_index = 0;  // the order keyframes were added to the BowDatabase
  double score = 0;           // bow_l1_score, in [0, 1]
};

// The map's keyframes as bag-of-words vectors with an inverted index word -> (keyframe, weight).
class BowDatabase {
 public:
  explicit BowDatabase(const VocabularyTree& vocabulary);
  // Adds a keyframe's descriptors; returns its index (0, 1, ...).
  size_t add(const std::vector<BriefDescriptor>& descriptors);
  size_t size() const { return vectors_.size(); }
  const BowVector& vector_of(size_t keyframe_index) const { return vectors_.at(keyframe_index); }

  // The top_n keyframes (fewer when fewer share a word with the query) by descending score (ties: the
  // lower index first). Only keyframes sharing a word can score above 0. Counts the work of the header
  // comment into *work when given. Throws std::invalid_argument for top_n < 1.
  std::vector<BowCandidate> query(const std::vector<BriefDescriptor>& descriptors, int top_n, ArmWork* work = nullptr) const;

 private:
  struct Posting {
    uint32_t keyframe;
    double weight;
  };
  const VocabularyTree& vocabulary_;
  std::vector<BowVector> vectors_;
  std::vector<std::vector<Posting>> inverted_;  // per word
};

}  // namespace lpstereo::arm::localization
