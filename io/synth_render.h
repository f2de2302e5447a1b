// What the two ray-cast synthetic generators share (io/stereo_synth.cpp: the road scene;
// io/stereo_flight.cpp: the downward-looking drone flight), so there is one texture, one sensor model
// and one way to write a folder (docs/synth.md). Internal to io/: not a public API.
//
// Determinism: own hash and random generator, no std:: distributions (their output differs between
// standard libraries, and a scene must be the same bits everywhere for a seed and any thread count).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "io/calibration.h"

namespace lpstereo::io::synth_detail {

constexpr double kPi = 3.14159265358979323846;

inline uint64_t mix64(uint64_t h) {
  h ^= h >> 30;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 27;
  h *= 0x94D049BB133111EBull;
  h ^= h >> 31;
  return h;
}

struct SplitMix {
  uint64_t state;
  uint64_t next() { return mix64(state += 0x9E3779B97F4A7C15ull); }
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
  double uniform(double low, double high) { return low + (high - low) * uniform(); }
  double gaussian() {  // Box-Muller; one value per call is enough here
    const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * kPi * u2);
  }
};

// A hash of an integer lattice point, in [-1, 1).
inline double lattice(int64_t x, int64_t y, uint64_t seed) {
  const uint64_t h = mix64(static_cast<uint64_t>(x) * 0x9E3779B97F4A7C15ull ^ mix64(static_cast<uint64_t>(y) ^ seed));
  return static_cast<double>(h >> 40) * (2.0 / 16777216.0) - 1.0;
}

// The smoothstep interpolation inside one lattice cell: corner = the values at (ix, iy), (ix + 1, iy),
// (ix, iy + 1), (ix + 1, iy + 1), (fx, fy) = (floor x, floor y).
inline double value_noise_in_cell(const double corner[4], double x, double y, double fx, double fy) {
  double sx = x - fx, sy = y - fy;
  sx = sx * sx * (3 - 2 * sx);
  sy = sy * sy * (3 - 2 * sy);
  const double top = corner[0] + sx * (corner[1] - corner[0]);
  const double bottom = corner[2] + sx * (corner[3] - corner[2]);
  return top + sy * (bottom - top);
}

inline double value_noise(double x, double y, uint64_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double corner[4] = {lattice(ix, iy, seed), lattice(ix + 1, iy, seed), lattice(ix, iy + 1, seed), lattice(ix + 1, iy + 1, seed)};
  return value_noise_in_cell(corner, x, y, fx, fy);
}

// value_noise through a cache of the last cell's corners: the same value, bit for bit; for a ray
// march whose consecutive steps mostly stay in a cell of the coarse octaves, and for the textures of
// neighbouring samples. The cell remembers its seed, so one cache may serve several seeds (it refills
// on a change).
struct NoiseCell {
  int64_t ix = 0, iy = 0;
  bool filled = false;
  double corner[4] = {0, 0, 0, 0};
  uint64_t seed = 0;
};
// Always inlined: the ray march calls it four times per step, and a call would be most of its cost.
[[gnu::always_inline]] inline double value_noise(double x, double y, uint64_t seed, NoiseCell& cell) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  if (!cell.filled || ix != cell.ix || iy != cell.iy || seed != cell.seed) {
    cell = {ix, iy, true, {lattice(ix, iy, seed), lattice(ix + 1, iy, seed), lattice(ix, iy + 1, seed), lattice(ix + 1, iy + 1, seed)}, seed};
  }
  return value_noise_in_cell(cell.corner, x, y, fx, fy);
}

// The weight of a texture octave of cell `cell` at a hit whose pixel footprint is `footprint` (same
// unit): full from 3 footprints, none below 1, so an octave fades out as it would blur through a lens
// instead of aliasing differently in the two views.
inline double octave_weight(double cell, double footprint) { return std::clamp((cell / footprint - 1.0) * 0.5, 0.0, 1.0); }

// Octaves of value noise with cells `cells` (metres, or radians x 1000 for the sky).
struct Texture {
  double cells[4];
  double amplitudes[4];
  int octaves;
};

// The texture at (s, r): its octaves' value noise, each weighted by octave_weight. `cells` holds one
// noise cell per octave (one set per surface and thread); a filled cell only speeds the lookups up,
// the value is the same bits.
inline double texture(const Texture& t, double s, double r, uint64_t seed, double footprint, NoiseCell (&cells)[4]) {
  double sum = 0;
  for (int k = 0; k < t.octaves; ++k) {
    const double weight = octave_weight(t.cells[k], footprint);
    if (weight > 0) sum += weight * t.amplitudes[k] * value_noise(s / t.cells[k], r / t.cells[k], seed + 7919u * static_cast<uint64_t>(k), cells[k]);
  }
  return sum;
}

// The same through fresh cells (no cache kept between calls).
inline double texture(const Texture& t, double s, double r, uint64_t seed, double footprint) {
  NoiseCell cells[4];
  return texture(t, s, r, seed, footprint, cells);
}

struct Rgb {
  double r = 0, g = 0, b = 0;
};
inline Rgb operator*(Rgb c, double k) { return {c.r * k, c.g * k, c.b * k}; }
inline Rgb operator+(Rgb a, Rgb b) { return {a.r + b.r, a.g + b.g, a.b + b.b}; }

inline uint8_t to_u8(double x) { return static_cast<uint8_t>(std::clamp(std::lround(x), 0L, 255L)); }

// Throws std::invalid_argument "<option>: expected <expected>, got <actual>" unless ok.
void require(bool ok, const std::string& option, const std::string& expected, double actual);

// The checks both generators make on the camera and sensor they share (the option names of the
// command line): width, height, hfov-deg, samples, noise-sigma, gain, offset, threads.
void validate_camera_and_sensor(int width, int height, double hfov_deg, int samples_per_axis, double noise_sigma, double right_gain,
                                double right_offset, int threads);

// The sensor of one rendered row of one view: BT.601 luma of the colours, the lens's vignetting, the
// camera's gain and offset, Gaussian noise of noise_sigma grey levels from a generator seeded by
// (seed, view, row) (so the result does not depend on which thread rendered the row), rounded and
// clamped to 0..255. `bgr` (may be null) receives the colour row with the same response and noise.
// Vignetting: the light reaching pixel (u, v) is scaled by 1 - vignetting r^2 / R^2, r its distance
// from the image centre (centre_u, centre_v) and R the corner's: `vignetting` is the share of light
// lost at the corners (a quadratic falloff, the leading term of a lens's cos^4 law); 0 = none, the
// factor exactly 1.
struct SensorModel {
  double noise_sigma = 0;
  double gain = 1;
  double offset = 0;
  double vignetting = 0;
  double centre_u = 0, centre_v = 0;
  double corner_radius_px = 1;
};
void expose_row(const Rgb* colours, int width, const SensorModel& sensor, uint64_t seed, int view, int row, uint8_t* grey,
                cv::Vec3b* bgr);

// The optics' blur: a Gaussian point spread of sigma_px (> 0) over the rendered radiance of one view
// (`image`, width x height colours row after row), separable, borders replicated, rows shared between
// `threads` threads (the same bits for any count: each output value is one fixed sum).
void blur_radiance(std::vector<Rgb>& image, int width, int height, double sigma_px, int threads);

// Calls render_row(v) for v = 0 .. height - 1 on `threads` threads, rows handed out one at a time
// (cheap and dear rows balance); `progress` (if set) gets the fraction done at each whole percent,
// one call at a time.
void render_rows(int height, int threads, const std::function<void(int)>& render_row,
                 const std::function<void(double)>& progress);

// The rectified pinhole pair both generators render: M1 = M2 = [f 0 cx; 0 f cy; 0 0 1], no
// distortion, R = I, T = (-B, 0, 0), with R1 R2 P1 P2 Q (already_rectified).
StereoCalibration pinhole_pair_calibration(int width, int height, double focal_px, double cx_px, double cy_px, double baseline_m);
// "NAME: f 0 cx -f*B 0 f cy 0 0 0 1 0\n": a KITTI projection line (P_rect_02/03, P0/P1) of a camera
// baseline_m to the right of the reference camera.
std::string kitti_projection_line(const std::string& name, double focal_px, double cx_px, double cy_px, double baseline_m);
// Ground truth in KITTI's 16-bit form: disparity x 256, 0 = none; a disparity too large for the
// format (>= 256 px) has none either rather than a wrong one. Not io::write_kitti_disparity_png: that
// one takes s16 Q4 (1/16 px) and the truth keeps the format's full 1/256 px.
cv::Mat kitti_disparity_truth(const cv::Mat& disparity_px);

// The sensor settings both generators record in their JSON: samples_per_pixel, noise_sigma,
// right_gain, right_offset, seed.
void add_sensor_settings(nlohmann::json& json, int samples_per_axis, double noise_sigma, double right_gain, double right_offset,
                         uint32_t seed);

// The road scene's surface and lenses in its JSON (road scene and sequence): road_surface, vignetting
// (left lens), right_vignetting, blur_sigma_px.
void add_surface_and_lens_settings(nlohmann::json& json, const char* road_surface, double vignetting, double right_vignetting,
                                   double blur_sigma_px);

// "%.12e": numbers in calibration files, full precision.
std::string number(double x);
// Throw std::runtime_error naming the path when the file cannot be written.
void write_png(const std::filesystem::path& path, const cv::Mat& image);
void write_text(const std::filesystem::path& path, const std::string& text);

// Creates a temporary sibling folder of `directory`, lets fill() write into it, then renames it to
// `directory` (an existing folder of that name is replaced only then). On any failure the temporary
// folder is removed, the previous folder stays, and std::runtime_error names `directory`.
void write_folder_atomically(const std::string& directory, const std::function<void(const std::filesystem::path&)>& fill);

}  // namespace lpstereo::io::synth_detail
