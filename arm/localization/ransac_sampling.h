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

}  // namespace lpstereo::arm::localization
