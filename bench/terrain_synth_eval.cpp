// terrain_synth_eval: issue 9's synthetic acceptance line, measured. An evaluation program, not a
// test (it renders 15 scenes, 640x480 unless --width/--height; the figures are printed, the lines checked at the end).
//
// For several seeds and ground kinds (hills; ditch + berm; mining-like rough; hills + rough with the
// camera rolled), io::render_stereo_synth renders a 640x480 pair with obstacles standing on the
// height field (io/stereo_synth.h); arm::DisparityEngine (the `lpstereo points` settings) gives the
// disparity, arm::invalidate_near_side_of_discontinuities drops the near side of every disparity
// jump of more than 2 px, 3 px wide (the fattened object edges; "edge px" counts the pixels
// dropped; --discontinuity-radius 0 turns it off), arm::triangulate the camera-frame points, arm::CameraToVehicle with the synthetic
// camera's known mount (roll, pitch, 0 yaw, centre camera_height_m above the ground under it) the
// vehicle frame; then the 2.5D grid, fit_terrain and classify_points (arm/terrain/terrain_model.h).
//
// Per scene:
//   RMS height error   S(x, y) - true ground height (io::SynthGroundTruth) at the centres of the cells
//                      the surface covers and the left camera sees ground in (a cell is visible when
//                      a ground pixel of the exact ground truth, object id 0, falls into it), within
//                      20 m forward (the line: <= 5 cm) and over the whole 34 m area.
//   obstacle points    a measured point is truly an obstacle when its pixel shows an object (object
//                      id image) and the exact 3D point of that pixel is more than 20 cm above the true
//                      ground; found when classify_points says obstacle. Precision and recall over the
//                      measured points the surface covers (the line: both >= 95 %).
//                      w-prec, w-recall, w-lines: the same against the window truth: each point is
//                      labelled by the pixel of the census window (census_width / 2 = 2 px each side)
//                      around its own whose true disparity is nearest the point's measured disparity
//                      (the centre pixel on a tie). The pixel truth counts a ground pixel that the
//                      matcher gave its neighbouring object's disparity (the fattened edge: its point
//                      stands at the object's range, 1-2 px beside it) as a false obstacle point, and
//                      an object pixel given the ground's disparity behind as a missed one; no stereo
//                      matcher with a window that wide can place such a point on its own pixel's
//                      surface. The exit code stays on the pixel truth.
//                      Classified by classify_points with a StereoRayModel: a 1 px disparity margin
//                      with support in the point's own cell (--disparity-margin, --support-reach;
//                      --disparity-margin 0 for the plain height test).
// --fp-bands prints, per scene, where the false obstacle points on ground pixels are (5 m bands: their
// own height error, the surface's, how many lie within 2 m of the berm line y = 7 m) and why (nearest
// object pixel, disparity error) and the missed obstacle points (FN: the exact point's height above the
// ground, the disparity error, the nearest pixel that is not an obstacle pixel; per 5 m band, the
// surface's mean error under them and how many the height test against the true ground would find).
// The mount is checked first on the exact ground truth: its ground pixels, through the same
// triangulation formula and CameraToVehicle, must lie on SynthGroundTruth (max error: "mount").
// Diagnostics beside the two lines, to tell the stereo's share from the fit's: "bias" (mean signed
// surface error within 20 m), "grid" (the measured cells' own heights, max(min z, mean z - sigma),
// against the truth), "points" (measured ground points' height above the true ground, RMS), "exact"
// (the same grid and fit on the exact points of every pixel: the fit alone), "FP" and "FP ground"
// (false obstacle points, and those on ground pixels), "gnd>20cm" (measured ground points more than
// 20 cm above the true ground within 20 m: stereo errors no surface can hide). --bands prints the
// surface's RMS per 5 m band for the left verge, the road and the right verge, and the share of the
// squared error within 20 m near objects (within 2 cells of a cell with object points), on the berm's
// strip, the ditch's and elsewhere; --error-map the error per cell as a text map; --exact-points runs
// the whole evaluation on the exact points.
//
// Scenes: real asphalt through a real camera pair by default (io::SynthRoadSurface::asphalt,
// io::use_real_camera_pair; issue 46); --surface textured --camera clean gives the generator's
// former scenes (noise --noise-sigma, 1 by default).
// Usage: terrain_synth_eval [--seeds N] [--first-seed S] [--scene SPEC] [--width W --height H] [--census 5|9] [--bands]
//        [--surface asphalt|textured] [--camera real|clean]
//        [--lr-max-diff PX] [--uniqueness-percent P] [--regularisation R] [--hole-membrane H]
//        [--control N] [--initial-control N] [--tolerance-m T] [--equalisation-threshold-factor F] [--alpha-initial A]
//        [--threshold-factor F] [--alpha-step A] [--maximum-weight W] [--iterations N] [--cell-m C] [--noise-sigma S] [--thesis-cell-rule]
//        [--noise-quantile Q] [--vertical-gap-m G] [--discontinuity-radius R] [--discontinuity-jump J] [--disparity-margin M] [--exact-points]
//        [--support-reach N] [--equalisation-step-m S] [--step-reach N] [--patch-max-cells N] [--obstacle-refit-m H] [--fp-bands] [--error-map]
//        [--occlusion-upper-bounds on|off] [--occluder-rows N] [--occluder-jump J] [--upper-bound-tolerance-m T]
// The disparity range is 80 at 640 px wide and scales with the width (160 at 1280).
// Exit 0 when every scene meets both lines, 1 otherwise.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "arm/disparity_engine.h"
#include "arm/point_cloud.h"
#include "arm/terrain_points.h"
#include "arm/terrain/terrain_model.h"
#include "io/image_io.h"
#include "io/stereo_synth.h"
#include "bench/number_argument.h"
#include "kernels/disparity_to_points.h"
#include "bench/heap_setting.h"

namespace {

using namespace lpstereo;
using bench::number_argument;
namespace terrain = arm::terrain;

struct SceneKind {
  const char* name;
  const char* ground;  // io::parse_synth_ground spec
  double roll_deg;
};

struct Settings {
  int seeds = 3;       // --seeds N: seeds first_seed .. first_seed + N - 1
  int first_seed = 1;  // --first-seed
  int width = 640, height = 480;  // --width, --height: the rendering (the disparity range scales with the width)
  std::string only_scene;         // --scene SPEC: only the scene kind of that ground spec ("hills", "ditch+berm", ...)
  // --discontinuity-radius, --discontinuity-jump: arm::invalidate_near_side_of_discontinuities on the
  // disparity before triangulation (radius 0: off).
  arm::DiscontinuityFilter discontinuity;
  // --disparity-margin: terrain::StereoRayModel (0: the plain classify_points); --support-reach: its
  // support_reach_cells (-1: off). 1 px with support in the point's own cell: see docs/terrain.md.
  double disparity_margin_px = 1.0;
  int support_reach_cells = 0;
  bool false_positive_bands = false;  // --fp-bands: the false obstacle points on ground pixels per 5 m band
  bool error_map = false;     // --error-map: the surface's error per cell as a text map (see evaluate)
  bool bands = false;         // --bands: the surface's RMS error per 5 m band forward x road / beside it
  bool exact_points = false;  // --exact-points: the exact points of every pixel instead of the stereo ones
  double noise_sigma = 1.0;  // --noise-sigma, with --camera clean (the real camera pair sets its own)
  // The scenes (issue 46): --surface asphalt|textured (io::SynthRoadSurface) and --camera real|clean
  // (real: io::use_real_camera_pair, the two cameras' exposures and lenses differ; clean: alike,
  // noise_sigma). Real asphalt through a real pair is the default, as hard as the world.
  io::SynthRoadSurface surface = io::SynthRoadSurface::asphalt;
  bool real_camera = true;
  int census_width = 5;  // the disparity engine's census window (5 or 9)
  // --lr-max-diff, --uniqueness-percent: the disparity engine's left-right tolerance (px, -1 off) and
  // uniqueness ratio (%, 0 off); the engine's defaults unless given.
  int lr_max_diff_px = arm::DisparityParameters{}.lr_max_diff;
  int uniqueness_percent = arm::DisparityParameters{}.uniqueness_percent;
  // The fit's defaults but the step rule on (0.45 m within 4 cells; --equalisation-step-m 0 for the
  // thesis's equalisation everywhere) with its patch limit of 16 cells (--patch-max-cells 0: none):
  // docs/terrain.md has the figures with and without. The obstacle refit stays off (the fit's
  // default; --obstacle-refit-m 0.45 is the measured setting).
  terrain::TerrainFitParameters fit = [] {
    terrain::TerrainFitParameters parameters;
    parameters.equalisation_step_m = 0.45;
    parameters.equalisation_patch_max_cells = 16;
    return parameters;
  }();
  terrain::TerrainGridSpec grid;  // 0..34 m forward, +-11 m lateral, 0.5 m cells (the thesis's area)
  // --occlusion-upper-bounds on|off (grid.occlusion_upper_bounds), --occluder-rows N, --occluder-jump J
  // (arm::OccluderTest on the disparity after the discontinuity filter; for the exact-point
  // diagnostic on the true disparity), --upper-bound-tolerance-m T (fit.upper_bound_tolerance_m).
  arm::OccluderTest occluder;
};

// Extra obstacles within the evaluated 34 m (the random scene spreads its objects to 80 m): boxes,
// bins, pedestrians and a car, from a small LCG of the seed, kept clear of the random ones.
std::vector<io::SynthObject> near_obstacles(uint32_t seed, const std::vector<io::SynthObject>& existing) {
  uint64_t state = seed * 6364136223846793005ull + 1442695040888963407ull;
  auto uniform = [&state](double low, double high) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return low + (high - low) * static_cast<double>(state >> 11) * (1.0 / 9007199254740992.0);
  };
  const io::SynthClass classes[] = {io::SynthClass::box, io::SynthClass::bin, io::SynthClass::pedestrian, io::SynthClass::car,
                                    io::SynthClass::bin, io::SynthClass::pedestrian};
  std::vector<io::SynthObject> objects = existing;
  for (int attempt = 0, placed = 0; attempt < 200 && placed < 6; ++attempt) {
    io::SynthObject o = io::synth_object(classes[placed], uniform(-5.0, 5.0), uniform(7.0, 30.0));
    bool overlaps = false;
    for (const io::SynthObject& other : objects) {
      if (std::hypot(o.x_m - other.x_m, o.z_m - other.z_m) < 0.5 * (std::hypot(o.width_m, o.length_m) + std::hypot(other.width_m, other.length_m)) + 1.0) {
        overlaps = true;
      }
    }
    if (overlaps) continue;
    objects.push_back(o);
    ++placed;
  }
  return objects;
}

struct SceneResult {
  bool known = false;
  std::string reason;
  double rms_20_m = NAN, rms_34_m = NAN;
  double bias_20_m = NAN;       // mean signed error within 20 m (surface - truth)
  double grid_rms_20_m = NAN;
  double point_rms_20_m = NAN;
  double exact_rms_20_m = NAN;  // the same grid and fit on the exact points (ground-truth disparity): the fit's own share  // measured ground points (object id 0): height above the true ground, within 20 m   // the grid's own cell heights (measured cells) against the truth, within 20 m
  int cells_20 = 0, cells_34 = 0;
  int64_t true_positive = 0, false_positive = 0, false_negative = 0, truly_obstacle = 0;
  int64_t false_positive_ground_pixel = 0;   // of false_positive: the pixel shows the ground (object id 0)
  // The same counts against the window truth (the header comment): the pixel of the census window
  // whose true disparity is nearest the measured one labels the point.
  int64_t window_true_positive = 0, window_false_positive = 0, window_truly_obstacle = 0;
  int64_t ground_points_above_20_cm = 0;     // measured ground points more than 20 cm above the true ground
  double mount_error_m = 0;
  int iterations = 0;
  double fit_ms = 0;
  int64_t discontinuity_invalidated = 0;
};

SceneResult evaluate(const io::StereoSynthOptions& options, const Settings& settings) {
  SceneResult result;
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const io::SynthGroundTruth truth(options);
  const int width = options.width, height = options.height;

  arm::DisparityParameters disparity_parameters;
  // 80 at 640 px (points from 2.1 m on), scaled with the width to keep the same near range.
  disparity_parameters.num_disparities = 16 * ((80 * width / 640 + 15) / 16);
  disparity_parameters.census_width = settings.census_width;
  disparity_parameters.lr_max_diff = settings.lr_max_diff_px;
  disparity_parameters.uniqueness_percent = settings.uniqueness_percent;
  arm::DisparityEngine engine(width, height, disparity_parameters);
  const Plane left = io::mat_to_plane(scene.left, BufferFormat{ElementType::u8});
  const Plane right = io::mat_to_plane(scene.right, BufferFormat{ElementType::u8});
  Plane disparity = engine.compute(left, right).clone();
  result.discontinuity_invalidated = settings.discontinuity.apply(disparity, engine.invalid_disparity_q4());
  const double cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
  const arm::TriangulationParameters triangulation{options.baseline_m, scene.focal_px, cx, cy, 0, disparity_parameters.num_disparities, 0};
  const arm::CameraPoints points = arm::triangulate(disparity, triangulation);

  arm::CameraMount mount;
  mount.roll_rad = options.roll_rad;
  mount.pitch_rad = options.pitch_rad;
  mount.position_m = Eigen::Vector3d(0, 0, options.camera_height_m);
  const arm::CameraToVehicle to_vehicle(mount);
  auto ground_height = [&truth](const Eigen::Vector3d& vehicle) { return truth.height_m(-vehicle.y(), vehicle.x()); };
  // The exact 3D point of pixel (u, v) from the ground-truth disparity (pinhole, d = f B / Z).
  auto exact_point = [&](int u, int v) {
    const double d = scene.disparity_px.at<float>(v, u);
    const double z = scene.focal_px * options.baseline_m / d;
    return to_vehicle.apply(Eigen::Vector3d((u - cx) * z / scene.focal_px, (v - cy) * z / scene.focal_px, z));
  };

  // Visible cells (exact ground pixels) and the mount check.
  const terrain::TerrainGridSpec& spec = settings.grid;
  Eigen::MatrixXi visible = Eigen::MatrixXi::Zero(spec.forward_cells(), spec.lateral_cells());
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      if (scene.object_ids.at<uint16_t>(v, u) != 0 || !std::isfinite(scene.disparity_px.at<float>(v, u))) continue;
      const Eigen::Vector3d p = exact_point(u, v);
      if (p.x() > 300) continue;  // the background wall
      result.mount_error_m = std::max(result.mount_error_m, std::abs(p.z() - ground_height(p)));
      int i = 0, j = 0;
      if (spec.cell_of(p.x(), p.y(), &i, &j)) visible(i, j) = 1;
    }
  }

  // The occlusion-aware sampling's flags (arm::pixels_over_occluder) of the measured disparity, and
  // of the true disparity for the exact points.
  const bool occlusion = spec.occlusion_upper_bounds;
  std::vector<uint8_t> over_occluder, exact_over_occluder;
  if (occlusion) {
    Plane exact_q4(width, height, BufferFormat{ElementType::s16});
    const int16_t invalid_q4 = engine.invalid_disparity_q4();
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const float d = scene.disparity_px.at<float>(v, u);
        exact_q4.row<int16_t>(v)[u] = std::isfinite(d) && d > 0 ? static_cast<int16_t>(std::lround(std::min(d * 16.0, 32767.0))) : invalid_q4;
      }
    }
    exact_over_occluder = arm::pixels_over_occluder(exact_q4, invalid_q4, settings.occluder);
    over_occluder = settings.exact_points ? exact_over_occluder : arm::pixels_over_occluder(disparity, invalid_q4, settings.occluder);
  }
  const auto flag = [](const std::vector<uint8_t>& flags, int pixel) { return !flags.empty() && flags[static_cast<size_t>(pixel)] != 0; };

  // Measured points in the vehicle frame, with their pixels.
  std::vector<Eigen::Vector3d> measured;
  std::vector<int> pixel_of;
  terrain::HeightGridAccumulator accumulator(spec);
  for (int v = 0; v < height; ++v) {
    const auto* x_mm = points.x_mm.row<int32_t>(v);
    const auto* y_mm = points.y_mm.row<int32_t>(v);
    const auto* z_mm = points.z_mm.row<int32_t>(v);
    for (int u = 0; u < width; ++u) {
      if (settings.exact_points ? !std::isfinite(scene.disparity_px.at<float>(v, u)) : z_mm[u] == kernels::kNoPointMm) continue;
      const Eigen::Vector3d p =
          settings.exact_points ? exact_point(u, v) : to_vehicle.apply(Eigen::Vector3d(x_mm[u], y_mm[u], z_mm[u]) * 1e-3);
      if (p.x() > 300) continue;  // the background wall
      measured.push_back(p);
      pixel_of.push_back(v * width + u);
      accumulator.add_point(p, flag(over_occluder, v * width + u));
    }
  }
  const terrain::HeightGrid grid = accumulator.finish();
  {
    double sum = 0;
    int64_t count = 0;
    for (size_t k = 0; k < measured.size(); ++k) {
      const int u = pixel_of[k] % width, v = pixel_of[k] / width;
      if (scene.object_ids.at<uint16_t>(v, u) != 0 || measured[k].x() > 20 || !std::isfinite(scene.disparity_px.at<float>(v, u))) continue;
      const double error = measured[k].z() - ground_height(measured[k]);
      sum += error * error, ++count;
      result.ground_points_above_20_cm += error > 0.2 ? 1 : 0;
    }
    result.point_rms_20_m = std::sqrt(sum / static_cast<double>(std::max<int64_t>(count, 1)));
  }
  const auto start = std::chrono::steady_clock::now();
  const terrain::TerrainEstimate estimate = terrain::fit_terrain(grid, settings.fit);
  result.fit_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  result.known = estimate.known;
  result.reason = estimate.reason;
  result.iterations = estimate.iterations;
  if (!estimate.known) return result;

  // Diagnostic: the same pipeline on the exact points of every pixel (no stereo error).
  {
    terrain::HeightGridAccumulator exact_accumulator(spec);
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        if (!std::isfinite(scene.disparity_px.at<float>(v, u))) continue;
        const Eigen::Vector3d p = exact_point(u, v);
        if (p.x() < 300) exact_accumulator.add_point(p, flag(exact_over_occluder, v * width + u));
      }
    }
    const terrain::TerrainEstimate exact = terrain::fit_terrain(exact_accumulator.finish(), settings.fit);
    double sum = 0;
    int count = 0;
    for (int i = 0; exact.known && i < spec.forward_cells(); ++i) {
      for (int j = 0; j < spec.lateral_cells(); ++j) {
        const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
        const double error = exact.surface.height_m(x, y) - truth.height_m(-y, x);
        if (!visible(i, j) || x > 20 || !std::isfinite(error)) continue;
        sum += error * error, ++count;
      }
    }
    result.exact_rms_20_m = std::sqrt(sum / std::max(count, 1));
  }

  double sum_20 = 0, sum_34 = 0, signed_20 = 0, grid_sum_20 = 0;
  int grid_cells_20 = 0;
  for (int i = 0; i < spec.forward_cells(); ++i) {
    for (int j = 0; j < spec.lateral_cells(); ++j) {
      if (!visible(i, j)) continue;
      const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
      const double surface = estimate.surface.height_m(x, y);
      if (!std::isfinite(surface)) continue;
      const double error = surface - truth.height_m(-y, x);
      sum_34 += error * error;
      ++result.cells_34;
      if (x <= 20) {
        sum_20 += error * error, signed_20 += error, ++result.cells_20;
        if (grid.state(i, j) == terrain::kCellMeasured) {
          const double grid_error = grid.height_m(i, j) - truth.height_m(-y, x);
          grid_sum_20 += grid_error * grid_error, ++grid_cells_20;
        }
      }
    }
  }
  result.rms_20_m = std::sqrt(sum_20 / std::max(result.cells_20, 1));
  if (settings.bands) {
    for (int band = 0; band < 7; ++band) {
      std::printf("    %2d-%2d m:", 5 * band, 5 * band + 5);
      for (int side = 0; side < 3; ++side) {
        double sum = 0, bias = 0;
        int count = 0;
        for (int i = 0; i < spec.forward_cells(); ++i) {
          for (int j = 0; j < spec.lateral_cells(); ++j) {
            const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
            const int cell_side = y > 5.6 ? 0 : (y < -5.6 ? 2 : 1);  // left verge, road, right verge
            if (!visible(i, j) || x < 5 * band || x >= 5 * band + 5 || cell_side != side) continue;
            const double error = estimate.surface.height_m(x, y) - truth.height_m(-y, x);
            if (!std::isfinite(error)) continue;
            sum += error * error, bias += error, ++count;
          }
        }
        std::printf("  %s rms %5.1f cm bias %5.1f cm (%3d cells)", side == 0 ? "left " : (side == 1 ? "road " : "right"),
                    100 * std::sqrt(sum / std::max(count, 1)), 100 * bias / std::max(count, 1), count);
      }
      std::printf("\n");
    }
  }
  // The cells holding measured points of object pixels (the diagnostics below).
  std::vector<uint8_t> obstacle_cell(static_cast<size_t>(spec.forward_cells()) * spec.lateral_cells(), 0);
  for (size_t k = 0; k < measured.size(); ++k) {
    int i = 0, j = 0;
    const int u = pixel_of[k] % width, v = pixel_of[k] / width;
    if (scene.object_ids.at<uint16_t>(v, u) != 0 && spec.cell_of(measured[k].x(), measured[k].y(), &i, &j)) {
      obstacle_cell[static_cast<size_t>(i) * spec.lateral_cells() + j] = 1;
    }
  }
  if (settings.bands) {
    // Where the squared error within 20 m comes from: cells within 2 cells of a cell holding measured
    // object points, the berm's strip (|y - 7| < 2 m), the ditch's (|y + 6.5| < 1.75 m), the rest.
    std::vector<uint8_t> near_object(obstacle_cell.size(), 0);
    for (int i = 0; i < spec.forward_cells(); ++i) {
      for (int j = 0; j < spec.lateral_cells(); ++j) {
        if (obstacle_cell[static_cast<size_t>(i) * spec.lateral_cells() + j] == 0) continue;
        for (int a = std::max(0, i - 2); a <= std::min(spec.forward_cells() - 1, i + 2); ++a) {
          for (int b = std::max(0, j - 2); b <= std::min(spec.lateral_cells() - 1, j + 2); ++b) near_object[static_cast<size_t>(a) * spec.lateral_cells() + b] = 1;
        }
      }
    }
    double share_sum[4] = {}, share_bias[4] = {};
    int share_count[4] = {};
    for (int i = 0; i < spec.forward_cells(); ++i) {
      for (int j = 0; j < spec.lateral_cells(); ++j) {
        const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
        const double error = estimate.surface.height_m(x, y) - truth.height_m(-y, x);
        if (!visible(i, j) || x > 20 || !std::isfinite(error)) continue;
        const int kind = near_object[static_cast<size_t>(i) * spec.lateral_cells() + j] ? 0 : std::abs(y - 7) < 2 ? 1 : std::abs(y + 6.5) < 1.75 ? 2 : 3;
        share_sum[kind] += error * error, share_bias[kind] += error, ++share_count[kind];
      }
    }
    const double total = share_sum[0] + share_sum[1] + share_sum[2] + share_sum[3];
    std::printf("    squared error within 20 m:");
    const char* kind_names[4] = {"near objects", "berm strip", "ditch strip", "rest"};
    for (int kind = 0; kind < 4; ++kind) {
      std::printf("  %s %4.1f %% (rms %4.1f cm, bias %+5.1f cm, %3d cells)", kind_names[kind], 100 * share_sum[kind] / std::max(total, 1e-12),
                  100 * std::sqrt(share_sum[kind] / std::max(share_count[kind], 1)), 100 * share_bias[kind] / std::max(share_count[kind], 1), share_count[kind]);
    }
    std::printf("\n");
  }
  if (settings.error_map) {
    // One line per forward row (far at the top), one character per lateral cell (left at the left):
    // the surface's error against the truth, '.' not visible; '0' within 5 cm, '+' / '-' 5-15 cm
    // above / below, 'A' / 'a' 15-30 cm, '#' / '=' more; the grid cell's own state after '|':
    // 'o' a cell whose measured points include an object pixel's, 'm' measured, 'f' filled, ' ' invalid.
    for (int i = spec.forward_cells() - 1; i >= 0; --i) {
      std::string surface_row, grid_row;
      for (int j = spec.lateral_cells() - 1; j >= 0; --j) {
        const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
        const double error = estimate.surface.height_m(x, y) - truth.height_m(-y, x);
        char c = '.';
        if (visible(i, j) && std::isfinite(error)) {
          const double a = std::abs(error);
          c = a < 0.05 ? '0' : a < 0.15 ? (error > 0 ? '+' : '-') : a < 0.30 ? (error > 0 ? 'A' : 'a') : (error > 0 ? '#' : '=');
        }
        surface_row += c;
        grid_row += obstacle_cell[static_cast<size_t>(i) * spec.lateral_cells() + j] ? 'o'
                    : grid.state(i, j) == terrain::kCellMeasured                        ? 'm'
                    : grid.state(i, j) == terrain::kCellFilled                          ? 'f'
                                                                                        : ' ';
      }
      std::printf("    %5.2f m %s | %s\n", spec.cell_centre_x_m(i), surface_row.c_str(), grid_row.c_str());
    }
  }
  result.rms_34_m = std::sqrt(sum_34 / std::max(result.cells_34, 1));
  result.bias_20_m = signed_20 / std::max(result.cells_20, 1);
  result.grid_rms_20_m = std::sqrt(grid_sum_20 / std::max(grid_cells_20, 1));

  terrain::StereoRayModel stereo;
  stereo.camera_centre_m = to_vehicle.translation_m();
  stereo.optical_axis = to_vehicle.rotation() * Eigen::Vector3d::UnitZ();
  stereo.focal_baseline_px_m = scene.focal_px * options.baseline_m;
  stereo.disparity_margin_px = settings.disparity_margin_px;
  stereo.support_reach_cells = settings.support_reach_cells;
  const std::vector<terrain::PointClass> classes = settings.disparity_margin_px > 0 ? terrain::classify_points(measured, estimate, 0.2, stereo)
                                                                                  : terrain::classify_points(measured, estimate, 0.2);
  int64_t fp_count[7] = {}, fp_berm[7] = {}, fp_near[4] = {}, fp_disparity[4] = {};
  double fp_point_error[7] = {}, fp_surface_error[7] = {};
  int64_t fn_height[3] = {}, fn_disparity[4] = {}, fn_near[4] = {};
  // Missed obstacle points per 5 m band: how many, the surface's mean error under them, and how many
  // the same height test against the true ground would have found (the surface's share of the misses).
  int64_t fn_count[7] = {}, fn_found_by_truth[7] = {};
  double fn_surface_error[7] = {};
  // The pixel truth: a pixel is an obstacle pixel when it shows an object whose exact point is more
  // than 20 cm above the true ground.
  std::vector<uint8_t> pixel_obstacle(static_cast<size_t>(width) * height, 0);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      if (scene.object_ids.at<uint16_t>(v, u) == 0 || !std::isfinite(scene.disparity_px.at<float>(v, u))) continue;
      const Eigen::Vector3d p = exact_point(u, v);
      pixel_obstacle[static_cast<size_t>(v) * width + u] = p.z() - ground_height(p) > 0.2 ? 1 : 0;
    }
  }
  const int window_half_px = settings.census_width / 2;
  for (size_t k = 0; k < measured.size(); ++k) {
    if (classes[k] == terrain::PointClass::outside) continue;
    const int u = pixel_of[k] % width, v = pixel_of[k] / width;
    const bool obstacle = pixel_obstacle[pixel_of[k]] != 0;
    // The window truth: the pixel of the census window around (u, v) whose true disparity is nearest
    // the measured one (the centre on a tie) labels the point, so that a point the matcher took from
    // a neighbour inside its window (the fattened foreground beside an object, the background seen
    // through an object's edge) is judged by the surface it was measured on.
    const double measured_disparity = stereo.focal_baseline_px_m / (measured[k] - stereo.camera_centre_m).dot(stereo.optical_axis);
    bool window_obstacle = obstacle;
    {
      const float centre_disparity = scene.disparity_px.at<float>(v, u);
      double best = std::isfinite(centre_disparity) ? std::abs(centre_disparity - measured_disparity) : INFINITY;
      for (int dv = -window_half_px; dv <= window_half_px; ++dv) {
        for (int du = -window_half_px; du <= window_half_px; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu < 0 || uu >= width || vv < 0 || vv >= height) continue;
          const float d = scene.disparity_px.at<float>(vv, uu);
          if (!std::isfinite(d) || std::abs(d - measured_disparity) >= best) continue;
          best = std::abs(d - measured_disparity);
          window_obstacle = pixel_obstacle[static_cast<size_t>(vv) * width + uu] != 0;
        }
      }
    }
    const bool found = classes[k] == terrain::PointClass::obstacle;
    result.truly_obstacle += obstacle ? 1 : 0;
    result.true_positive += obstacle && found ? 1 : 0;
    result.false_positive += !obstacle && found ? 1 : 0;
    result.false_positive_ground_pixel += !obstacle && found && scene.object_ids.at<uint16_t>(v, u) == 0 ? 1 : 0;
    result.false_negative += obstacle && !found ? 1 : 0;
    result.window_truly_obstacle += window_obstacle ? 1 : 0;
    result.window_true_positive += window_obstacle && found ? 1 : 0;
    result.window_false_positive += !window_obstacle && found ? 1 : 0;
    if (settings.false_positive_bands && obstacle && !found) {
      const Eigen::Vector3d p = exact_point(u, v);
      const double above = p.z() - ground_height(p);
      fn_height[above < 0.4 ? 0 : above < 1.0 ? 1 : 2] += 1;
      const double error_px = measured_disparity - scene.disparity_px.at<float>(v, u);
      fn_disparity[error_px > -0.5 ? 0 : error_px > -1 ? 1 : error_px > -2 ? 2 : 3] += 1;
      int nearest = 99;
      for (int du = -12; du <= 12; ++du) {
        for (int dv = -12; dv <= 12; ++dv) {
          const int uu = u + du, vv = v + dv;
          if (uu < 0 || uu >= width || vv < 0 || vv >= height || pixel_obstacle[static_cast<size_t>(vv) * width + uu] != 0) continue;
          nearest = std::min(nearest, std::max(std::abs(du), std::abs(dv)));
        }
      }
      fn_near[nearest <= 3 ? 0 : nearest <= 6 ? 1 : nearest <= 12 ? 2 : 3] += 1;
      const Eigen::Vector3d& q = measured[k];
      const int band = std::clamp(static_cast<int>(q.x() / 5), 0, 6);
      fn_count[band] += 1;
      fn_surface_error[band] += estimate.surface.height_m(q.x(), q.y()) - ground_height(q);
      fn_found_by_truth[band] += q.z() - ground_height(q) > 0.2 ? 1 : 0;
    }
    if (settings.false_positive_bands && !obstacle && found && scene.object_ids.at<uint16_t>(v, u) == 0) {
      // Why a ground point is taken for an obstacle: its own height error (point above the true
      // ground) against the surface's error below the truth there.
      const Eigen::Vector3d& p = measured[k];
      const int band = std::min(6, static_cast<int>(p.x() / 5));
      fp_count[band] += 1;
      fp_point_error[band] += p.z() - ground_height(p);
      fp_surface_error[band] += estimate.surface.height_m(p.x(), p.y()) - ground_height(p);
      fp_berm[band] += std::abs(p.y() - 7.0) < 2.0 ? 1 : 0;
      int nearest = 99;
      for (int du = -12; du <= 12; ++du) {
        for (int dv = -12; dv <= 12; ++dv) {
          const int uu = u + du, vv = v + dv;
          if (uu < 0 || uu >= width || vv < 0 || vv >= height || scene.object_ids.at<uint16_t>(vv, uu) == 0) continue;
          nearest = std::min(nearest, std::max(std::abs(du), std::abs(dv)));
        }
      }
      fp_near[nearest <= 3 ? 0 : nearest <= 6 ? 1 : nearest <= 12 ? 2 : 3] += 1;
      const double truth_disparity = scene.disparity_px.at<float>(v, u);
      const double error_px = measured_disparity - truth_disparity;
      fp_disparity[error_px < 0.5 ? 0 : error_px < 1 ? 1 : error_px < 2 ? 2 : 3] += 1;
    }
  }
  if (settings.false_positive_bands) {
    std::printf("    FN: exact point 20-40 cm above the ground %lld, 40-100 cm %lld, higher %lld; disparity error > -0.5 px %lld, -0.5..-1 %lld, -1..-2 %lld, <= -2 %lld; "
                "non-obstacle pixel within 3 px %lld, 4-6 px %lld, 7-12 px %lld, further %lld\n",
                (long long)fn_height[0], (long long)fn_height[1], (long long)fn_height[2], (long long)fn_disparity[0], (long long)fn_disparity[1],
                (long long)fn_disparity[2], (long long)fn_disparity[3], (long long)fn_near[0], (long long)fn_near[1], (long long)fn_near[2], (long long)fn_near[3]);
    std::printf("    FP ground: object within 3 px %lld, 4-6 px %lld, 7-12 px %lld, further %lld; disparity error < 0.5 px %lld, 0.5-1 %lld, 1-2 %lld, >= 2 %lld\n",
                (long long)fp_near[0], (long long)fp_near[1], (long long)fp_near[2], (long long)fp_near[3], (long long)fp_disparity[0],
                (long long)fp_disparity[1], (long long)fp_disparity[2], (long long)fp_disparity[3]);
    for (int band = 0; band < 7; ++band) {
      if (fn_count[band] == 0) continue;
      std::printf("    FN %2d-%2d m: %6lld points, mean surface error %+6.1f cm, above 20 cm over the true ground %lld\n", band * 5, band * 5 + 5,
                  (long long)fn_count[band], 100.0 * fn_surface_error[band] / double(fn_count[band]), (long long)fn_found_by_truth[band]);
    }
    for (int band = 0; band < 7; ++band) {
      if (fp_count[band] == 0) continue;
      std::printf("    FP ground %2d-%2d m: %6lld points, mean point error %+6.1f cm, mean surface error %+6.1f cm, within 2 m of y = 7 m %lld\n",
                  5 * band, 5 * band + 5, static_cast<long long>(fp_count[band]), 100 * fp_point_error[band] / fp_count[band],
                  100 * fp_surface_error[band] / fp_count[band], static_cast<long long>(fp_berm[band]));
    }
  }
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  std::printf("heap: %s\n", lpstereo::bench::keep_freed_heap_memory_setting().c_str());
  Settings settings;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds") settings.seeds = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--scene" && i + 1 < argc) settings.only_scene = argv[++i];
    else if (a == "--width") settings.width = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--height") settings.height = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--first-seed") settings.first_seed = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--control") settings.fit.control_forward = settings.fit.control_lateral = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--initial-control") settings.fit.initial_control_forward = settings.fit.initial_control_lateral = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--equalisation-threshold-factor") settings.fit.equalisation_threshold_factor = number_argument(i, argc, argv);
    else if (a == "--tolerance-m") settings.fit.equalisation_tolerance_m = number_argument(i, argc, argv);
    else if (a == "--alpha-initial") settings.fit.alpha_initial = number_argument(i, argc, argv);
    else if (a == "--threshold-factor") settings.fit.threshold_factor = number_argument(i, argc, argv);
    else if (a == "--alpha-step") settings.fit.alpha_step = number_argument(i, argc, argv);
    else if (a == "--regularisation") settings.fit.regularisation = number_argument(i, argc, argv);
    else if (a == "--hole-membrane") settings.fit.hole_membrane = number_argument(i, argc, argv);
    else if (a == "--maximum-weight") settings.fit.maximum_weight = number_argument(i, argc, argv);
    else if (a == "--iterations") settings.fit.max_iterations = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--cell-m") settings.grid.cell_m = number_argument(i, argc, argv);
    else if (a == "--lr-max-diff") settings.lr_max_diff_px = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--uniqueness-percent") settings.uniqueness_percent = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--census") settings.census_width = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--exact-points") settings.exact_points = true;
    else if (a == "--discontinuity-radius") settings.discontinuity.radius_px = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--discontinuity-jump") settings.discontinuity.jump_px = number_argument(i, argc, argv);
    else if (a == "--disparity-margin") settings.disparity_margin_px = number_argument(i, argc, argv);
    else if (a == "--support-reach") settings.support_reach_cells = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--equalisation-step-m") settings.fit.equalisation_step_m = number_argument(i, argc, argv);
    else if (a == "--patch-max-cells") settings.fit.equalisation_patch_max_cells = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--obstacle-refit-m") settings.fit.obstacle_refit_height_m = number_argument(i, argc, argv);
    else if (a == "--step-reach") settings.fit.equalisation_step_reach_cells = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--thesis-cell-rule") settings.grid.cell_rule = terrain::TerrainGridSpec::CellRule::thesis;
    else if (a == "--noise-quantile") settings.grid.noise_floor_quantile = number_argument(i, argc, argv);
    else if (a == "--vertical-gap-m") settings.grid.vertical_gap_m = number_argument(i, argc, argv);
    else if (a == "--occlusion-upper-bounds" && i + 1 < argc && (std::string(argv[i + 1]) == "on" || std::string(argv[i + 1]) == "off"))
      settings.grid.occlusion_upper_bounds = std::string(argv[++i]) == "on";
    else if (a == "--occluder-rows") settings.occluder.rows_below_px = static_cast<int>(number_argument(i, argc, argv));
    else if (a == "--occluder-jump") settings.occluder.jump_px = number_argument(i, argc, argv);
    else if (a == "--upper-bound-tolerance-m") settings.fit.upper_bound_tolerance_m = number_argument(i, argc, argv);
    else if (a == "--bands") settings.bands = true;
    else if (a == "--fp-bands") settings.false_positive_bands = true;
    else if (a == "--error-map") settings.error_map = true;
    else if (a == "--noise-sigma") settings.noise_sigma = number_argument(i, argc, argv);
    else if (a == "--surface" && i + 1 < argc) {
      try {
        settings.surface = io::parse_synth_road_surface(argv[++i]);
      } catch (const std::invalid_argument& error) {
        std::fprintf(stderr, "terrain_synth_eval: --%s\n", error.what());
        return 2;
      }
    } else if (a == "--camera" && i + 1 < argc && (std::string(argv[i + 1]) == "real" || std::string(argv[i + 1]) == "clean")) {
      settings.real_camera = std::string(argv[++i]) == "real";
    } else {
      std::fprintf(stderr, "%s: unknown option (see the header of bench/terrain_synth_eval.cpp)\n", argv[i]);
      return 2;
    }
  }
  try {  // bad values stop here, before the first scene renders
    settings.occluder.validate();
    settings.grid.validate();
    // The fit's parameters: fit_terrain checks them (against the grid's cells) before any data, so a
    // fit of the empty grid throws for a bad --control, --regularisation, --hole-membrane ...
    (void)terrain::fit_terrain(terrain::HeightGridAccumulator(settings.grid).finish(), settings.fit);
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "terrain_synth_eval: %s\n", error.what());
    return 2;
  }
  const terrain::TerrainFitParameters& f = settings.fit;
  std::printf("terrain_synth_eval: road surface %s, %s\n", io::synth_road_surface_name(settings.surface),
              settings.real_camera ? "real camera pair (io::use_real_camera_pair: noise 2, right gain 1.08 and offset -5, vignetting 0.3, "
                                     "blur 0.7 px; the noise below is not used)"
                                   : "clean camera pair (cameras alike)");
  std::printf("terrain_synth_eval: %dx%d, hfov 60 deg, baseline 0.30 m, camera 1.5 m, pitch 0.06 rad, noise %.1f, 4 rays/px; "
              "area %.0fx%.0f m, cell %.2f m; fit: degree %dx%d, control %dx%d (from %dx%d), %d iterations, threshold factor %.2f, "
              "alpha %.2f + %.2f/iteration, maximum weight %g, regularisation %.1e, hole membrane %.2f, equalisation tolerance %.3f m and %.1f th, step rule %.2f m within %d cells, patch limit %d cells, obstacle refit %.2f m; obstacle threshold 0.20 m, "
              "disparity margin %.2f px, support %d cells; occlusion upper bounds %s (%d rows, jump %.2f px, tolerance %.2f m)\n",
              settings.width, settings.height, settings.noise_sigma, settings.grid.forward_max_m - settings.grid.forward_min_m,
              settings.grid.lateral_max_m - settings.grid.lateral_min_m, settings.grid.cell_m, f.degree_forward, f.degree_lateral,
              f.control_forward, f.control_lateral, f.initial_control_forward, f.initial_control_lateral, f.max_iterations,
              f.threshold_factor, f.alpha_initial, f.alpha_step, f.maximum_weight, f.regularisation, f.hole_membrane, f.equalisation_tolerance_m, f.equalisation_threshold_factor,
              f.equalisation_step_m, f.equalisation_step_reach_cells, f.equalisation_patch_max_cells, f.obstacle_refit_height_m, settings.disparity_margin_px, settings.support_reach_cells,
              settings.grid.occlusion_upper_bounds ? "on" : "off", settings.occluder.rows_below_px, settings.occluder.jump_px,
              f.upper_bound_tolerance_m);
  std::printf("%-26s %4s %10s %10s %9s %9s %11s %10s %7s %7s %9s %9s %8s %7s %9s %8s %8s %8s %9s %6s %8s %8s %6s\n", "scene", "seed", "rms<=20m", "rms<=34m", "bias<=20m",
              "grid<=20m", "points<=20", "exact<=20", "cells20", "cells34", "precision", "recall", "obstacle", "FP", "FP ground", "gnd>20cm", "edge px", "mount", "fit", "lines",
              "w-prec", "w-recall", "w-lines");
  const SceneKind kinds[] = {{"hills", "hills", 0.0},
                             {"ditch+berm", "ditch+berm", 0.0},
                             {"rough", "rough", 0.0},
                             {"hills+rough, roll 3 deg", "hills+rough", 3.0},
                             {"ditch-u+berm, roll -2 deg", "ditch-u+berm", -2.0}};
  int failed = 0, window_failed = 0, scenes = 0;
  for (const SceneKind& kind : kinds) {
    if (!settings.only_scene.empty() && settings.only_scene != kind.ground) continue;
    for (int seed = settings.first_seed; seed < settings.first_seed + settings.seeds; ++seed) {
      io::StereoSynthOptions options;
      options.width = settings.width;
      options.height = settings.height;
      options.pitch_rad = 0.06;
      options.roll_rad = kind.roll_deg * 3.14159265358979323846 / 180;
      options.ground = io::parse_synth_ground(kind.ground);
      options.noise_sigma = settings.noise_sigma;
      if (settings.real_camera) io::use_real_camera_pair(options);
      options.road_surface = settings.surface;
      options.seed = static_cast<uint32_t>(seed);
      options.objects = near_obstacles(static_cast<uint32_t>(seed), io::random_synth_objects(static_cast<uint32_t>(seed)));
      const SceneResult r = evaluate(options, settings);
      ++scenes;
      if (!r.known) {
        std::printf("%-26s %4d  unknown terrain: %s\n", kind.name, seed, r.reason.c_str());
        ++failed;
        continue;
      }
      const double precision = 100.0 * static_cast<double>(r.true_positive) / static_cast<double>(std::max<int64_t>(r.true_positive + r.false_positive, 1));
      const double recall = 100.0 * static_cast<double>(r.true_positive) / static_cast<double>(std::max<int64_t>(r.truly_obstacle, 1));
      const bool ok = r.rms_20_m <= 0.05 && precision >= 95 && recall >= 95;
      failed += ok ? 0 : 1;
      const double window_precision = 100.0 * static_cast<double>(r.window_true_positive) /
                                      static_cast<double>(std::max<int64_t>(r.window_true_positive + r.window_false_positive, 1));
      const double window_recall = 100.0 * static_cast<double>(r.window_true_positive) / static_cast<double>(std::max<int64_t>(r.window_truly_obstacle, 1));
      const bool window_ok = r.rms_20_m <= 0.05 && window_precision >= 95 && window_recall >= 95;
      window_failed += window_ok ? 0 : 1;
      std::printf("%-26s %4d %8.1f cm %8.1f cm %7.1f cm %7.1f cm %8.1f cm %7.1f cm %7d %7d %8.1f %% %8.1f %% %8lld %7lld %9lld %8lld %8lld %6.0f um %6.1f ms %6s %6.1f %% %6.1f %% %6s\n", kind.name, seed,
                  100 * r.rms_20_m, 100 * r.rms_34_m, 100 * r.bias_20_m, 100 * r.grid_rms_20_m, 100 * r.point_rms_20_m, 100 * r.exact_rms_20_m, r.cells_20, r.cells_34, precision, recall, static_cast<long long>(r.truly_obstacle), static_cast<long long>(r.false_positive),
                  static_cast<long long>(r.false_positive_ground_pixel), static_cast<long long>(r.ground_points_above_20_cm), static_cast<long long>(r.discontinuity_invalidated),
                  1e6 * r.mount_error_m, r.fit_ms, ok ? "met" : "MISSED", window_precision, window_recall, window_ok ? "met" : "MISSED");
      std::fflush(stdout);
    }
  }
  std::printf("%d of %d scenes meet both lines (RMS <= 5 cm within 20 m; obstacle-point precision and recall >= 95 %%)\n",
              scenes - failed, scenes);
  std::printf("%d of %d scenes meet both lines with the window truth (w-prec, w-recall: each point labelled by the pixel of its census window whose true disparity is nearest the measured one)\n",
              scenes - window_failed, scenes);
  return failed == 0 ? 0 : 1;
}
