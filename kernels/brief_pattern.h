// The BRIEF-256 sampling pattern of kernel "brief256" (kernels/brief256.cpp) and its 16 steered
// copies, one per yaw sector (thesis 003 §3.5, fig. 3.7: the filter's yaw quantised into 16 sectors of 22.5
// degrees, the descriptor's sampling pattern rotated by the sector instead of computing a
// rotation-invariant descriptor per feature).
//
// Pair i (0 .. 255) compares point a_i with point b_i, offsets (dx, dy) in px from the keypoint
// (x right, y down); descriptor bit i = 1 when I(a_i) < I(b_i). Bit i is bit (i % 32) of word i / 32.
//
// Generator (Calonder, Lepetit, Strecha, Fua, "BRIEF: Binary Robust Independent Elementary
// Features", ECCV 2010, sampling strategy G II: a and b drawn independently from an isotropic
// Gaussian, sigma^2 = S^2 / 25, S = 31 the patch size), made exactly reproducible in integers:
//   - random words: Marsaglia's xorshift32 (x ^= x << 13; x ^= x >> 17; x ^= x << 5), seed 2010;
//   - a standard normal deviate: the Irwin-Hall sum of 12 uniforms, z = (sum of 12 (x >> 16) -
//     12 x 32768) / 65536 (variance 1 to within 2^-16; range -6 .. 6);
//   - a coordinate: round(sigma z) = floor((62 s + 327680) / 655360) for the integer sum s
//     (sigma = 31 / 5, 327680 = 5 x 65536);
//   - a point is drawn again (both coordinates) while dx^2 + dy^2 > 15^2: every point lies in the
//     disc of radius 15, so every rotation of it stays inside the 31 x 31 patch [-15, 15]^2;
//   - a pair is drawn again while a == b (a constant bit carries no information).
// Steering (sector s, angle theta_s = s x 22.5 degrees, positive from +x towards +y, i.e.
// clockwise on screen with y down): (dx, dy) -> (round(cos dx - sin dy), round(sin dx + cos dy))
// in integers with cos and sin in Q14 (kBriefCosQ14, round(16384 cos(k 22.5 deg))):
// x' = (c dx - s dy + 8192) >> 14 (round half up). The rotated points stay in [-15, 15]^2. A
// descriptor with sector s's pattern at q' in an image rotated by theta_s about any centre samples
// the same scene points as sector 0's pattern at q in the unrotated image (up to the rounding).
//
// Everything below is constexpr: the tables are constants computed by the compiler from this
// generator, identical on every platform (integer arithmetic only).
#pragma once

#include <array>
#include <cstdint>

namespace lpstereo::kernels {

inline constexpr int kBriefPairs = 256;
inline constexpr int kBriefWords = 8;          // u32 words per descriptor
inline constexpr int kBriefPatchRadius = 15;   // the pattern lies in [-15, 15]^2 (a 31 x 31 patch)
inline constexpr int kBriefSectors = 16;
inline constexpr uint32_t kBriefSeed = 2010;

struct BriefPair {
  int8_t ax, ay, bx, by;
  constexpr bool operator==(const BriefPair&) const = default;
};

// round(16384 cos(k 22.5 degrees)), k = 0 .. 15.
inline constexpr std::array<int32_t, kBriefSectors> kBriefCosQ14 = {
    16384, 15137, 11585, 6270, 0, -6270, -11585, -15137, -16384, -15137, -11585, -6270, 0, 6270, 11585, 15137};

constexpr int32_t brief_sin_q14(int sector) { return kBriefCosQ14[static_cast<size_t>((sector + 12) % kBriefSectors)]; }

namespace detail {

constexpr int64_t floor_div(int64_t numerator, int64_t denominator) {
  const int64_t quotient = numerator / denominator;
  return (numerator % denominator != 0 && (numerator < 0) != (denominator < 0)) ? quotient - 1 : quotient;
}

struct Xorshift32 {
  uint32_t state;
  constexpr uint32_t next() {
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return state;
  }
};

constexpr int gaussian_coordinate(Xorshift32& generator) {
  int64_t sum = 0;
  for (int i = 0; i < 12; ++i) sum += generator.next() >> 16;
  sum -= 12 * 32768;
  return static_cast<int>(floor_div(62 * sum + 327680, 655360));
}

constexpr void gaussian_point(Xorshift32& generator, int8_t& x, int8_t& y) {
  for (;;) {
    const int dx = gaussian_coordinate(generator);
    const int dy = gaussian_coordinate(generator);
    if (dx * dx + dy * dy <= kBriefPatchRadius * kBriefPatchRadius) {
      x = static_cast<int8_t>(dx);
      y = static_cast<int8_t>(dy);
      return;
    }
  }
}

constexpr std::array<BriefPair, kBriefPairs> generate_brief_pattern() {
  std::array<BriefPair, kBriefPairs> pattern{};
  Xorshift32 generator{kBriefSeed};
  for (BriefPair& pair : pattern) {
    do {
      gaussian_point(generator, pair.ax, pair.ay);
      gaussian_point(generator, pair.bx, pair.by);
    } while (pair.ax == pair.bx && pair.ay == pair.by);
  }
  return pattern;
}

constexpr int8_t rotate_x(int x, int y, int sector) {
  return static_cast<int8_t>((kBriefCosQ14[static_cast<size_t>(sector)] * x - brief_sin_q14(sector) * y + 8192) >> 14);
}
constexpr int8_t rotate_y(int x, int y, int sector) {
  return static_cast<int8_t>((brief_sin_q14(sector) * x + kBriefCosQ14[static_cast<size_t>(sector)] * y + 8192) >> 14);
}

}  // namespace detail

// The base pattern (sector 0), Calonder et al. G II as above.
inline constexpr std::array<BriefPair, kBriefPairs> kBriefPattern = detail::generate_brief_pattern();

constexpr std::array<std::array<BriefPair, kBriefPairs>, kBriefSectors> steer_brief_patterns() {
  std::array<std::array<BriefPair, kBriefPairs>, kBriefSectors> patterns{};
  for (int sector = 0; sector < kBriefSectors; ++sector) {
    for (int i = 0; i < kBriefPairs; ++i) {
      const BriefPair& p = kBriefPattern[static_cast<size_t>(i)];
      patterns[static_cast<size_t>(sector)][static_cast<size_t>(i)] =
          BriefPair{detail::rotate_x(p.ax, p.ay, sector), detail::rotate_y(p.ax, p.ay, sector),
                    detail::rotate_x(p.bx, p.by, sector), detail::rotate_y(p.bx, p.by, sector)};
    }
  }
  return patterns;
}

// The 16 steered patterns; kBriefSteeredPatterns[0] == kBriefPattern.
inline constexpr std::array<std::array<BriefPair, kBriefPairs>, kBriefSectors> kBriefSteeredPatterns = steer_brief_patterns();

}  // namespace lpstereo::kernels
