// What the RANSAC estimators of arm/localization share: a seeded generator (so a run, a test and
// a replay draw the same samples on every platform and standard library: std::uniform_int_distribution
// is not specified bit for bit, so it is not used) and the adaptive iteration count.
//
// Iteration count (Fischler and Bolles 1981; Hartley and Zisserman, "Multiple View Geometry", 2nd ed.,
// §4.7.1, eq. 4.18): to draw, with probability `confidence`, at least one sample of s inliers when
// a fraction w of the data are inliers,
//     N = log(1 - confidence) / log(1 - w^s),
// re-evaluated with the best inlier ratio found so far and capped by max_iterations.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace lpstereo::arm::localization {

// SplitMix64 (Steele, Lea, Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014):
// 64-bit state, full period, the same sequence everywhere.
class RansacRandom {
 public:
  explicit RansacRandom(uint64_t seed) : state_(seed) {}
  uint64_t next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, count) by multiply-shift of the high 32 bits (bias below 2^-32 * count, irrelevant here).
  int below(int count) { return static_cast<int>(((next() >> 32) * static_cast<uint64_t>(count)) >> 32); }
  // k distinct indices in [0, count) into out (k <= count; k is tiny: 3 or 8, so rejection is cheap).
  void draw_distinct(int count, int k, int* out) {
    for (int i = 0; i < k; ++i) {
      int candidate;
      do {
        candidate = below(count);
      } while (std::find(out, out + i, candidate) != out + i);
      out[i] = candidate;
    }
  }

 private:
  uint64_t state_;
};

// N of the header comment for an inlier ratio w in [0, 1], at least 1, at most max_iterations.
inline int ransac_iterations_needed(double inlier_ratio, int sample_size, double confidence, int max_iterations) {
  const double all_inliers = std::pow(std::clamp(inlier_ratio, 0.0, 1.0), sample_size);
  if (all_inliers >= 1.0) return 1;
  if (all_inliers <= 0.0) return max_iterations;
  const double needed = std::ceil(std::log(1.0 - confidence) / std::log(1.0 - all_inliers));
  if (!(needed < static_cast<double>(max_iterations))) return max_iterations;
  return std::max(1, static_cast<int>(needed));
}

// The hypothesise-and-verify loop both estimators run: minimal samples of sample_size distinct
// indices in [0, count) drawn by RansacRandom{seed}; fit(sample) gives std::optional<Model> (none
// for a degenerate sample, which still counts as an iteration); inliers_of(model) the indices it
// explains; the model with the most inliers wins (ties keep the earlier); the count adapts to its
// inlier ratio (ransac_iterations_needed).
template <typename Model>
struct RansacConsensus {
  std::optional<Model> model;
  std::vector<int> inliers;
  int iterations = 0;
};

template <typename Model, typename Fit, typename InliersOf>
RansacConsensus<Model> find_consensus(int count, int sample_size, int max_iterations, double confidence, uint64_t seed,
                                      const Fit& fit, const InliersOf& inliers_of) {
  RansacConsensus<Model> best;
  RansacRandom random{seed};
  std::vector<int> sample(static_cast<size_t>(sample_size));
  int needed = max_iterations;
  for (int iteration = 0; iteration < needed; ++iteration) {
    random.draw_distinct(count, sample_size, sample.data());
    best.iterations = iteration + 1;
    std::optional<Model> candidate = fit(sample);
    if (!candidate) continue;
    std::vector<int> inliers = inliers_of(*candidate);
    if (inliers.size() > best.inliers.size()) {
      best.inliers = std::move(inliers);
      best.model = std::move(candidate);
      needed = ransac_iterations_needed(static_cast<double>(best.inliers.size()) / count, sample_size, confidence, max_iterations);
    }
  }
  return best;
}

inline std::string format_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

// Throws std::invalid_argument "<owner> parameter <name>: expected <expected>, got <value>".
[[noreturn]] inline void throw_parameter_error(const std::string& owner, const std::string& name, const std::string& expected,
                                               double value) {
  throw std::invalid_argument(owner + " parameter " + name + ": expected " + expected + ", got " + format_number(value));
}

// The parameters every RANSAC here has: threshold > 0 and finite, max_iterations >= 1,
// confidence in (0, 1), min_inliers >= the minimal sample.
inline void check_ransac_parameters(const std::string& owner, const std::string& threshold_name, double threshold,
                                    int max_iterations, double confidence, int min_inliers, int sample_size) {
  if (!(threshold > 0) || !std::isfinite(threshold)) throw_parameter_error(owner, threshold_name, "> 0", threshold);
  if (max_iterations < 1) throw_parameter_error(owner, "max_iterations", ">= 1", max_iterations);
  if (!(confidence > 0 && confidence < 1)) throw_parameter_error(owner, "confidence", "in (0, 1)", confidence);
  if (min_inliers < sample_size) throw_parameter_error(owner, "min_inliers", ">= " + std::to_string(sample_size), min_inliers);
}

}  // namespace lpstereo::arm::localization
