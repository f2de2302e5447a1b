#include "io/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace lpstereo::io {

namespace {

uint32_t hash3(int32_t x, int32_t y, uint32_t seed) {
  // Integer hash (Wang / Jenkins mix): deterministic on every platform.
  uint32_t h = static_cast<uint32_t>(x) * 0x8da6b343u ^ static_cast<uint32_t>(y) * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

// Value noise in [0, 1): bilinear interpolation of hashed lattice values with a smooth step.
double value_noise(double x, double y, double cell, uint32_t seed) {
  const double u = x / cell, v = y / cell;
  const double fu = std::floor(u), fv = std::floor(v);
  const int32_t ix = static_cast<int32_t>(fu), iy = static_cast<int32_t>(fv);
  auto lattice = [&](int32_t a, int32_t b) { return (hash3(a, b, seed) & 0xFFFF) / 65536.0; };
  double tx = u - fu, ty = v - fv;
  tx = tx * tx * (3 - 2 * tx);
  ty = ty * ty * (3 - 2 * ty);
  const double top = lattice(ix, iy) * (1 - tx) + lattice(ix + 1, iy) * tx;
  const double bottom = lattice(ix, iy + 1) * (1 - tx) + lattice(ix + 1, iy + 1) * tx;
  return top * (1 - ty) + bottom * ty;
}

// Texture of a surface at surface coordinates (s, t): three octaves, mean grey `base`.
double texture(double s, double t, uint32_t surface_seed, double base) {
  const double n = 0.45 * value_noise(s, t, 2.5, surface_seed) + 0.35 * value_noise(s, t, 8.0, surface_seed + 1) +
                   0.2 * value_noise(s, t, 24.0, surface_seed + 2);
  return base + 220.0 * (n - 0.5);
}

struct Box {
  double x0, y0, x1, y1;  // left-view rectangle, pixels
  double disparity_px;
  uint32_t seed;
  double base_grey;
};

}  // namespace

double synthetic_texture_grey(double s, double t, uint32_t surface_seed, double base_grey) {
  return texture(s, t, surface_seed, base_grey);
}

SyntheticStereoScene make_synthetic_stereo_scene(const SyntheticSceneOptions& options) {
  const int width = options.width, height = options.height;
  if (width < 16 || height < 16 || width > 16384 || height > 16384) {
    throw std::invalid_argument("synthetic scene size: expected 16..16384 x 16..16384, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  const double max_disparity = std::max(2.0, options.max_disparity_fraction * width);
  const double horizon = 0.45 * height;
  const double wall_disparity = 0.08 * max_disparity;
  // Ground: disparity grows linearly below the horizon (a flat road seen by a level camera).
  auto ground_disparity = [&](double y) { return wall_disparity + (y - horizon) / (height - horizon) * 0.9 * max_disparity; };

  std::vector<Box> boxes;
  const double w = width, h = height;
  boxes.push_back({0.10 * w, 0.30 * h, 0.28 * w, 0.80 * h, 0.55 * max_disparity, options.seed + 10, 110});  // near box
  boxes.push_back({0.55 * w, 0.35 * h, 0.66 * w, 0.62 * h, 0.30 * max_disparity, options.seed + 20, 150});  // mid box
  boxes.push_back({0.80 * w, 0.40 * h, 0.83 * w, 0.56 * h, 0.18 * max_disparity, options.seed + 30, 90});   // post
  boxes.push_back({0.40 * w, 0.41 * h, 0.42 * w, 0.47 * h, 0.12 * max_disparity, options.seed + 40, 200});  // small far object
  boxes.push_back({0.70 * w, 0.60 * h, 0.95 * w, 0.95 * h, 1.00 * max_disparity, options.seed + 50, 128});  // nearest

  // The visible surface at left-view pixel column x_left of row y: (disparity, grey). Boxes are
  // sorted near to far so the nearest covering surface wins.
  std::sort(boxes.begin(), boxes.end(), [](const Box& a, const Box& b) { return a.disparity_px > b.disparity_px; });
  auto surface_at_left = [&](double x, double y, double& disparity) -> double {
    for (const Box& box : boxes) {
      if (x >= box.x0 && x < box.x1 && y >= box.y0 && y < box.y1) {
        disparity = box.disparity_px;
        return texture(x - box.x0, y - box.y0, box.seed, box.base_grey);
      }
    }
    if (y >= horizon) {
      disparity = ground_disparity(y);
      return texture(x, y, options.seed + 60, 120);
    }
    disparity = wall_disparity;
    return texture(x, y, options.seed + 70, 140);
  };

  SyntheticStereoScene scene;
  scene.left = Plane(width, height, {ElementType::u8, 0});
  scene.right = Plane(width, height, {ElementType::u8, 0});
  scene.disparity_q4 = Plane(width, height, {ElementType::s16, 4});
  scene.max_disparity_px = static_cast<int>(std::ceil(max_disparity));
  auto to_u8 = [](double grey) { return static_cast<uint8_t>(std::clamp(std::lround(grey), 0L, 255L)); };
  std::vector<double> row_disparity(static_cast<size_t>(width));
  std::vector<double> splat(static_cast<size_t>(width));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double disparity = 0;
      const double noise = options.noise_grey_levels * ((hash3(x, y, options.seed + 99) & 0xFF) / 127.5 - 1.0);
      scene.left.at<uint8_t>(x, y) = to_u8(surface_at_left(x + 0.5, y + 0.5, disparity) + noise);
      scene.disparity_q4.at<int16_t>(x, y) = static_cast<int16_t>(std::lround(disparity * 16));
      row_disparity[static_cast<size_t>(x)] = disparity;
    }
    // Right view by z-buffered splatting: left column x lands on right column x - d; the nearest
    // surface (largest d) wins; columns nothing lands on (disoccluded) take the farther neighbour.
    std::fill(splat.begin(), splat.end(), -1.0);
    for (int x = 0; x < width; ++x) {
      const double d = row_disparity[static_cast<size_t>(x)];
      const long right_x = std::lround(x - d);
      if (right_x >= 0 && right_x < width) splat[static_cast<size_t>(right_x)] = std::max(splat[static_cast<size_t>(right_x)], d);
    }
    for (int x = 0; x < width; ++x) {
      if (splat[static_cast<size_t>(x)] >= 0) continue;
      double left_neighbour = -1, right_neighbour = -1;
      for (int k = x - 1; k >= 0 && left_neighbour < 0; --k) left_neighbour = splat[static_cast<size_t>(k)];
      for (int k = x + 1; k < width && right_neighbour < 0; ++k) right_neighbour = splat[static_cast<size_t>(k)];
      if (left_neighbour < 0) left_neighbour = right_neighbour;
      if (right_neighbour < 0) right_neighbour = left_neighbour;
      splat[static_cast<size_t>(x)] = std::max(0.0, std::min(left_neighbour, right_neighbour));
    }
    for (int x = 0; x < width; ++x) {
      // The grey of the surface point behind right pixel x: its left-view position is x + d.
      double disparity = 0;
      const double grey = surface_at_left(x + 0.5 + splat[static_cast<size_t>(x)], y + 0.5, disparity);
      const double noise = options.noise_grey_levels * ((hash3(x, y, options.seed + 199) & 0xFF) / 127.5 - 1.0);
      scene.right.at<uint8_t>(x, y) = to_u8(grey + noise);
    }
  }
  return scene;
}

}  // namespace lpstereo::io
