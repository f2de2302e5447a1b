// A stereo scene the tool makes itself, so the main job and the tests run without data files:
// a road-like ground plane whose disparity grows towards the bottom, a far background wall, and
// boxes and posts of different sizes at different distances, all with a deterministic multi-octave
// value-noise texture. The right view is rendered from the same scene points, so the exact
// ground-truth disparity of the left view comes with it.
#pragma once

#include <cstdint>
#include <vector>

#include "dag/plane.h"

namespace lpstereo::io {

struct SyntheticStereoScene {
  Plane left;                         // u8
  Plane right;                        // u8
  Plane disparity_q4;                 // s16q4: true left-view disparity x 16 (never invalid)
  int max_disparity_px = 0;           // the largest disparity in the scene, rounded up
};

struct SyntheticSceneOptions {
  int width = 640;
  int height = 480;
  uint32_t seed = 1;
  double max_disparity_fraction = 0.08;  // nearest object's disparity as a share of the width
  double noise_grey_levels = 1.0;       // sensor noise amplitude (uniform), 0 for none
};

SyntheticStereoScene make_synthetic_stereo_scene(const SyntheticSceneOptions& options);

// The scene's surface texture at surface coordinates (s, t) in pixel-sized units: three octaves of
// value noise (cells of 2.5, 8 and 24 units), mean grey `base_grey`, about +-110 around it (not
// clamped). For tests that render their own surfaces (a plane at a known distance) with the same
// texture the built-in scene uses.
double synthetic_texture_grey(double s, double t, uint32_t surface_seed, double base_grey);

}  // namespace lpstereo::io
