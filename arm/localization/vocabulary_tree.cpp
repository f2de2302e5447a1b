// Clustering, weights, scoring, file format and counted work: vocabulary_tree.h.
#include "arm/localization/vocabulary_tree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>

#include "arm/localization/ransac_sampling.h"
#include "dag/atomic_file.h"
#include "kernels/brief_hamming.h"

namespace lpstereo::arm::localization {
namespace {

constexpr char kMagic[4] = {'L', 'P', 'V', 'T'};
constexpr size_t kHeaderBytes = 4 + 6 * 4;
constexpr size_t kTrailerBytes = 4;
constexpr size_t kNodeBytes = 3 * 4 + kernels::kBriefWords * 4;
constexpr size_t kWordBytes = 4 + 8;

// ArmWork constants of the header comment.
constexpr uint64_t kDistanceOps = 24, kDistanceBytes = 32;
constexpr uint64_t kCountWordOps = 4;
constexpr uint64_t kWeightOps = 6, kWeightBytes = 12;
constexpr uint64_t kPostingOps = 6, kPostingBytes = 12;
constexpr uint64_t kRankOps = 8;

int distance(const BriefDescriptor& a, const BriefDescriptor& b) { return kernels::brief_hamming_distance(a.data(), b.data()); }

// Uniform in [0, total) for any 64-bit total: the high 64 bits of draw x total (multiply-shift),
// from 32-bit halves (no 128-bit type in ISO C++).
uint64_t draw_below(RansacRandom& random, uint64_t total) {
  const uint64_t draw = random.next();
  const uint64_t a_high = draw >> 32, a_low = draw & 0xFFFFFFFFu, b_high = total >> 32, b_low = total & 0xFFFFFFFFu;
  const uint64_t low_low = a_low * b_low, high_low = a_high * b_low, low_high = a_low * b_high;
  const uint64_t middle = (low_low >> 32) + (high_low & 0xFFFFFFFFu) + (low_high & 0xFFFFFFFFu);
  return a_high * b_high + (high_low >> 32) + (low_high >> 32) + (middle >> 32);
}

struct Trainer {
  const VocabularyParameters& parameters;
  std::vector<const BriefDescriptor*> descriptors;  // all training descriptors
  RansacRandom random;
  std::vector<VocabularyTree::Node>& nodes;

  // Splits descriptors[members] (indices) under `node` at `level` (the root is level 0).
  void split(uint32_t node, const std::vector<uint32_t>& members, int level) {
    if (level >= parameters.depth) return;
    const size_t count = members.size();
    // k-means++ seeds.
    std::vector<BriefDescriptor> centres;
    centres.push_back(*descriptors[members[static_cast<size_t>(random.below(static_cast<int>(count)))]]);
    std::vector<uint64_t> nearest_squared(count);
    for (size_t m = 0; m < count; ++m) {
      const uint64_t d = static_cast<uint64_t>(distance(*descriptors[members[m]], centres[0]));
      nearest_squared[m] = d * d;
    }
    while (static_cast<int>(centres.size()) < parameters.branching) {
      uint64_t total = 0;
      for (const uint64_t d : nearest_squared) total += d;
      if (total == 0) break;  // every member equals a seed: fewer distinct descriptors than k
      uint64_t pick = draw_below(random, total);
      size_t chosen = 0;
      for (; chosen + 1 < count; ++chosen) {
        if (pick < nearest_squared[chosen]) break;
        pick -= nearest_squared[chosen];
      }
      centres.push_back(*descriptors[members[chosen]]);
      for (size_t m = 0; m < count; ++m) {
        const uint64_t d = static_cast<uint64_t>(distance(*descriptors[members[m]], centres.back()));
        nearest_squared[m] = std::min(nearest_squared[m], d * d);
      }
    }
    if (centres.size() < 2) return;  // a single distinct descriptor: a leaf

    // Lloyd iterations with k-majority centres.
    std::vector<uint32_t> assignment(count, std::numeric_limits<uint32_t>::max());
    for (int iteration = 0; iteration < parameters.max_iterations; ++iteration) {
      bool changed = false;
      for (size_t m = 0; m < count; ++m) {
        const BriefDescriptor& d = *descriptors[members[m]];
        uint32_t best = 0;
        int best_distance = distance(d, centres[0]);
        for (uint32_t c = 1; c < centres.size(); ++c) {
          const int candidate = distance(d, centres[c]);
          if (candidate < best_distance) {
            best_distance = candidate;
            best = c;
          }
        }
        if (assignment[m] != best) {
          assignment[m] = best;
          changed = true;
        }
      }
      // The last pass only assigns: the clusters are then exactly the descriptors nearest to each
      // centre, as word_of's descent finds them (a training descriptor reaches its own leaf).
      if (!changed || iteration + 1 == parameters.max_iterations) break;
      std::vector<std::vector<const BriefDescriptor*>> clusters(centres.size());
      for (size_t m = 0; m < count; ++m) clusters[assignment[m]].push_back(descriptors[members[m]]);
      for (size_t c = 0; c < centres.size(); ++c) {
        if (!clusters[c].empty()) centres[c] = majority_descriptor(clusters[c]);
      }
    }

    // Children: the non-empty clusters, in centre order.
    std::vector<std::vector<uint32_t>> child_members(centres.size());
    for (size_t m = 0; m < count; ++m) child_members[assignment[m]].push_back(members[m]);
    const uint32_t first_child = static_cast<uint32_t>(nodes.size());
    uint32_t children = 0;
    std::vector<uint32_t> used;
    for (size_t c = 0; c < centres.size(); ++c) {
      if (child_members[c].empty()) continue;
      VocabularyTree::Node child;
      child.centre = centres[c];
      nodes.push_back(child);
      used.push_back(static_cast<uint32_t>(c));
      ++children;
    }
    nodes[node].first_child = first_child;
    nodes[node].child_count = children;
    for (uint32_t i = 0; i < children; ++i) split(first_child + i, child_members[used[i]], level + 1);
  }
};

void check_parameters(const VocabularyParameters& p) {
  if (p.branching < 2 || p.branching > 64) throw_parameter_error("vocabulary", "branching", "2 .. 64", p.branching);
  if (p.depth < 1 || p.depth > 8) throw_parameter_error("vocabulary", "depth", "1 .. 8", p.depth);
  if (p.max_iterations < 1) throw_parameter_error("vocabulary", "max_iterations", ">= 1", p.max_iterations);
}

void put_u32(std::string& out, uint32_t value) {
  for (int byte = 0; byte < 4; ++byte) out.push_back(static_cast<char>(value >> (8 * byte)));
}

uint32_t get_u32(const std::vector<uint8_t>& bytes, size_t& offset) {
  uint32_t value = 0;
  for (int byte = 0; byte < 4; ++byte) value |= uint32_t{bytes[offset + static_cast<size_t>(byte)]} << (8 * byte);
  offset += 4;
  return value;
}

}  // namespace

BriefDescriptor majority_descriptor(const std::vector<const BriefDescriptor*>& descriptors) {
  std::array<uint32_t, kernels::kBriefPairs> ones{};
  for (const BriefDescriptor* d : descriptors) {
    for (int word = 0; word < kernels::kBriefWords; ++word) {
      for (uint32_t bits = (*d)[static_cast<size_t>(word)]; bits != 0; bits &= bits - 1) {
        ++ones[static_cast<size_t>(32 * word + std::countr_zero(bits))];
      }
    }
  }
  BriefDescriptor centre{};
  const size_t count = descriptors.size();
  for (int bit = 0; bit < kernels::kBriefPairs; ++bit) {
    if (count > 0 && 2 * size_t{ones[static_cast<size_t>(bit)]} >= count) centre[static_cast<size_t>(bit / 32)] |= 1u << (bit % 32);
  }
  return centre;
}

VocabularyTree VocabularyTree::train(const std::vector<std::vector<BriefDescriptor>>& keyframe_descriptors,
                                     const VocabularyParameters& parameters) {
  check_parameters(parameters);
  VocabularyTree tree;
  tree.branching_ = parameters.branching;
  tree.depth_ = parameters.depth;
  tree.training_keyframes_ = static_cast<uint32_t>(keyframe_descriptors.size());
  Trainer trainer{parameters, {}, RansacRandom{parameters.seed}, tree.nodes_};
  for (const auto& keyframe : keyframe_descriptors) {
    for (const BriefDescriptor& d : keyframe) trainer.descriptors.push_back(&d);
  }
  if (trainer.descriptors.empty()) {
    throw std::invalid_argument("vocabulary training: expected at least 1 descriptor, got 0 (from " +
                                std::to_string(keyframe_descriptors.size()) + " keyframes)");
  }
  if (trainer.descriptors.size() > std::numeric_limits<uint32_t>::max()) {
    throw std::invalid_argument("vocabulary training: expected at most 2^32 - 1 descriptors, got " +
                                std::to_string(trainer.descriptors.size()));
  }
  std::vector<uint32_t> all(trainer.descriptors.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<uint32_t>(i);
  tree.nodes_.push_back(Node{0, 0, kNoWord, majority_descriptor(trainer.descriptors)});
  trainer.split(0, all, 0);

  // Words: the leaves in depth-first order (children before the next sibling).
  std::vector<uint32_t> stack = {0};
  while (!stack.empty()) {
    const uint32_t node = stack.back();
    stack.pop_back();
    Node& n = tree.nodes_[node];
    if (n.child_count == 0) {
      n.word = static_cast<uint32_t>(tree.word_leaf_.size());
      tree.word_leaf_.push_back(node);
      continue;
    }
    for (uint32_t c = n.child_count; c-- > 0;) stack.push_back(n.first_child + c);
  }
  // IDF: keyframes per word.
  std::vector<uint32_t> keyframes_with(tree.word_leaf_.size(), 0);
  std::vector<uint32_t> last_keyframe(tree.word_leaf_.size(), std::numeric_limits<uint32_t>::max());
  for (uint32_t k = 0; k < keyframe_descriptors.size(); ++k) {
    for (const BriefDescriptor& d : keyframe_descriptors[k]) {
      const uint32_t word = tree.word_of(d);
      if (last_keyframe[word] != k) {
        last_keyframe[word] = k;
        ++keyframes_with[word];
      }
    }
  }
  tree.idf_.resize(tree.word_leaf_.size());
  for (size_t w = 0; w < tree.idf_.size(); ++w) {
    // A leaf's own training descriptors descend to it (the centres are the clusters' nearest), so
    // n_w >= 1; guard anyway for a descriptor that a tie sends elsewhere.
    tree.idf_[w] = std::log(static_cast<double>(tree.training_keyframes_) / std::max<uint32_t>(1, keyframes_with[w]));
  }
  return tree;
}

uint32_t VocabularyTree::word_of(const BriefDescriptor& descriptor, ArmWork* work) const {
  uint32_t node = 0;
  uint64_t distances = 0;
  while (nodes_[node].child_count != 0) {
    const Node& parent = nodes_[node];
    uint32_t best = parent.first_child;
    int best_distance = distance(descriptor, nodes_[best].centre);
    for (uint32_t c = 1; c < parent.child_count; ++c) {
      const int candidate = distance(descriptor, nodes_[parent.first_child + c].centre);
      if (candidate < best_distance) {
        best_distance = candidate;
        best = parent.first_child + c;
      }
    }
    distances += parent.child_count;
    node = best;
  }
  if (work) {
    work->scalar_ops += distances * kDistanceOps;
    work->memory_bytes += distances * kDistanceBytes;
  }
  return nodes_[node].word;
}

BowVector VocabularyTree::transform(const std::vector<BriefDescriptor>& descriptors, ArmWork* work) const {
  BowVector vector;
  if (descriptors.empty()) return vector;
  std::vector<uint32_t> words;
  words.reserve(descriptors.size());
  for (const BriefDescriptor& d : descriptors) words.push_back(word_of(d, work));
  std::sort(words.begin(), words.end());
  const double per_descriptor = 1.0 / static_cast<double>(descriptors.size());
  double sum = 0;
  for (size_t i = 0; i < words.size();) {
    size_t j = i;
    while (j < words.size() && words[j] == words[i]) ++j;
    const double weight = static_cast<double>(j - i) * per_descriptor * idf_[words[i]];
    if (weight > 0) {
      vector.emplace_back(words[i], weight);
      sum += weight;
    }
    i = j;
  }
  if (sum > 0) {
    for (auto& entry : vector) entry.second /= sum;
  }
  if (work) {
    work->scalar_ops += descriptors.size() * kCountWordOps + vector.size() * kWeightOps;
    work->memory_bytes += vector.size() * kWeightBytes;
  }
  return vector;
}

double bow_l1_score(const BowVector& v, const BowVector& w) {
  // Over the common words: |v_i - w_i| - |v_i| - |w_i| (header comment); the rest of |v - w|_1 is 2.
  double common = 0;
  size_t i = 0, j = 0;
  while (i < v.size() && j < w.size()) {
    if (v[i].first < w[j].first) {
      ++i;
    } else if (w[j].first < v[i].first) {
      ++j;
    } else {
      common += std::abs(v[i].second - w[j].second) - std::abs(v[i].second) - std::abs(w[j].second);
      ++i;
      ++j;
    }
  }
  if (v.empty() || w.empty()) return 0.0;
  return -0.5 * common;
}

void VocabularyTree::save(const std::string& path) const {
  std::string out(kMagic, 4);
  put_u32(out, kFileVersion);
  put_u32(out, static_cast<uint32_t>(branching_));
  put_u32(out, static_cast<uint32_t>(depth_));
  put_u32(out, training_keyframes_);
  put_u32(out, static_cast<uint32_t>(nodes_.size()));
  put_u32(out, static_cast<uint32_t>(idf_.size()));
  for (const Node& node : nodes_) {
    put_u32(out, node.first_child);
    put_u32(out, node.child_count);
    put_u32(out, node.word);
    for (const uint32_t word : node.centre) put_u32(out, word);
  }
  for (size_t w = 0; w < idf_.size(); ++w) {
    put_u32(out, word_leaf_[w]);
    uint64_t bits;
    std::memcpy(&bits, &idf_[w], 8);
    put_u32(out, static_cast<uint32_t>(bits));
    put_u32(out, static_cast<uint32_t>(bits >> 32));
  }
  put_u32(out, crc32_ieee(reinterpret_cast<const uint8_t*>(out.data()), out.size()));
  try {
    write_file_atomically(path, out);
  } catch (const std::exception& error) {
    throw VocabularyError("vocabulary " + path + ": " + error.what());
  }
}

VocabularyTree VocabularyTree::load(const std::string& path) {
  const auto fail = [&path](const std::string& what) { throw VocabularyError("vocabulary " + path + ": " + what); };
  std::ifstream file(path, std::ios::binary);
  if (!file) fail("cannot open the file");
  const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
  if (bytes.size() < kHeaderBytes + kTrailerBytes) {
    fail(std::to_string(bytes.size()) + " bytes, expected at least " + std::to_string(kHeaderBytes + kTrailerBytes) +
         " (header and checksum; truncated)");
  }
  if (std::memcmp(bytes.data(), kMagic, 4) != 0) {
    char found[48];
    std::snprintf(found, sizeof found, "%02X %02X %02X %02X", bytes[0], bytes[1], bytes[2], bytes[3]);
    fail(std::string("magic bytes ") + found + ", expected \"LPVT\" (4C 50 56 54): not a vocabulary file");
  }
  size_t offset = 4;
  const uint32_t version = get_u32(bytes, offset);
  if (version != kFileVersion) fail("version " + std::to_string(version) + ", expected " + std::to_string(kFileVersion));
  const size_t body_end = bytes.size() - kTrailerBytes;
  size_t trailer = body_end;
  const uint32_t stored_crc = get_u32(bytes, trailer);
  const uint32_t actual_crc = crc32_ieee(bytes.data(), body_end);
  if (stored_crc != actual_crc) {
    char text[96];
    std::snprintf(text, sizeof text, "checksum 0x%08X, expected 0x%08X (corrupt or truncated)", actual_crc, stored_crc);
    fail(text);
  }
  VocabularyTree tree;
  tree.branching_ = static_cast<int>(get_u32(bytes, offset));
  tree.depth_ = static_cast<int>(get_u32(bytes, offset));
  tree.training_keyframes_ = get_u32(bytes, offset);
  const uint32_t node_count = get_u32(bytes, offset);
  const uint32_t word_count = get_u32(bytes, offset);
  if (tree.branching_ < 2 || tree.branching_ > 64) fail("branching " + std::to_string(tree.branching_) + ", expected 2 .. 64");
  if (tree.depth_ < 1 || tree.depth_ > 8) fail("depth " + std::to_string(tree.depth_) + ", expected 1 .. 8");
  const size_t left = body_end - offset;
  const size_t needed = size_t{node_count} * kNodeBytes + size_t{word_count} * kWordBytes;
  if (node_count == 0 || needed != left) {
    fail(std::to_string(node_count) + " nodes and " + std::to_string(word_count) + " words need " + std::to_string(needed) +
         " bytes (at least 1 node), " + std::to_string(left) + " left");
  }
  tree.nodes_.resize(node_count);
  for (uint32_t n = 0; n < node_count; ++n) {
    Node& node = tree.nodes_[n];
    node.first_child = get_u32(bytes, offset);
    node.child_count = get_u32(bytes, offset);
    node.word = get_u32(bytes, offset);
    for (uint32_t& word : node.centre) word = get_u32(bytes, offset);
    const std::string which = "node " + std::to_string(n);
    if (node.child_count > static_cast<uint32_t>(tree.branching_)) {
      fail(which + " has " + std::to_string(node.child_count) + " children, expected at most " + std::to_string(tree.branching_));
    }
    if (node.child_count != 0 && (node.first_child <= n || uint64_t{node.first_child} + node.child_count > node_count)) {
      fail(which + " children " + std::to_string(node.first_child) + " .. +" + std::to_string(node.child_count) +
           ", expected after the node and inside " + std::to_string(node_count) + " nodes");
    }
    if ((node.child_count == 0) != (node.word < word_count)) {
      fail(which + " word " + std::to_string(node.word) + ", expected a word below " + std::to_string(word_count) +
           " exactly for leaves");
    }
  }
  const auto leaves = std::count_if(tree.nodes_.begin(), tree.nodes_.end(), [](const Node& node) { return node.child_count == 0; });
  if (static_cast<uint64_t>(leaves) != word_count) {
    fail(std::to_string(leaves) + " leaves, expected one per word (" + std::to_string(word_count) + ")");
  }
  tree.word_leaf_.resize(word_count);
  tree.idf_.resize(word_count);
  for (uint32_t w = 0; w < word_count; ++w) {
    tree.word_leaf_[w] = get_u32(bytes, offset);
    uint64_t bits = get_u32(bytes, offset);
    bits |= uint64_t{get_u32(bytes, offset)} << 32;
    std::memcpy(&tree.idf_[w], &bits, 8);
    if (tree.word_leaf_[w] >= node_count || tree.nodes_[tree.word_leaf_[w]].word != w) {
      fail("word " + std::to_string(w) + " leaf " + std::to_string(tree.word_leaf_[w]) + ", expected a leaf holding that word");
    }
  }
  // Every node reachable at most once from the root, no deeper than depth (children come after their
  // parent, so a descent always ends).
  std::vector<uint8_t> seen(node_count, 0);
  std::vector<std::pair<uint32_t, int>> stack = {{0, 0}};
  while (!stack.empty()) {
    const auto [node, level] = stack.back();
    stack.pop_back();
    if (seen[node]++) fail("node " + std::to_string(node) + " has two parents, expected a tree");
    if (level > tree.depth_) fail("node " + std::to_string(node) + " at level " + std::to_string(level) + ", expected at most depth " + std::to_string(tree.depth_));
    const Node& n = tree.nodes_[node];
    for (uint32_t c = 0; c < n.child_count; ++c) stack.emplace_back(n.first_child + c, level + 1);
  }
  return tree;
}

BowDatabase::BowDatabase(const VocabularyTree& vocabulary) : vocabulary_(vocabulary), inverted_(vocabulary.word_count()) {}

size_t BowDatabase::add(const std::vector<BriefDescriptor>& descriptors) {
  const uint32_t index = static_cast<uint32_t>(vectors_.size());
  vectors_.push_back(vocabulary_.transform(descriptors));
  for (const auto& [word, weight] : vectors_.back()) inverted_[word].push_back({index, weight});
  return index;
}

std::vector<BowCandidate> BowDatabase::query(const std::vector<BriefDescriptor>& descriptors, int top_n, ArmWork* work) const {
  if (top_n < 1) throw_parameter_error("vocabulary query", "top_n", ">= 1", top_n);
  const BowVector query_vector = vocabulary_.transform(descriptors, work);
  // Accumulates sum over common words of (|q - w| - q - w) per keyframe (<= 0; the score is -0.5 x it).
  std::vector<double> common(vectors_.size(), 0.0);
  std::vector<uint32_t> touched;
  uint64_t postings = 0;
  for (const auto& [word, q] : query_vector) {
    const std::vector<Posting>& list = inverted_[word];
    postings += list.size();
    for (const Posting& posting : list) {
      if (common[posting.keyframe] == 0.0) touched.push_back(posting.keyframe);
      common[posting.keyframe] += std::abs(q - posting.weight) - q - posting.weight;
    }
  }
  std::vector<BowCandidate> candidates;
  candidates.reserve(touched.size());
  for (const uint32_t k : touched) {
    if (common[k] < 0.0) candidates.push_back({k, -0.5 * common[k]});
  }
  const size_t keep = std::min(candidates.size(), static_cast<size_t>(top_n));
  std::partial_sort(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(keep), candidates.end(),
                    [](const BowCandidate& a, const BowCandidate& b) {
                      return a.score != b.score ? a.score > b.score : a.keyframe_index < b.keyframe_index;
                    });
  candidates.resize(keep);
  if (work) {
    work->scalar_ops += postings * kPostingOps + touched.size() * kRankOps;
    work->memory_bytes += postings * kPostingBytes;
  }
  return candidates;
}

}  // namespace lpstereo::arm::localization
