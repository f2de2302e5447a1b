// The disparity engine's command-line options, shared by the commands that run the engine
// (`lpstereo disparity`, `obstacles`, `terrain`, `obstacles3d`): one definition of --min-disp, --num-disp, --paths,
// --p1, --p2, --census, --subpixel, --lr-check, --uniqueness, --median, --speckle-size,
// --speckle-range, --multires and --multires-far, and one translation into arm::DisparityParameters with the checks.
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "arm/disparity_engine.h"
#include "arm/point_cloud.h"
#include "io/rectification.h"

namespace lpstereo::tools {

// --multires on|off and --multires-far F: also used alone, by `lpstereo eval middlebury|kitti`.
struct MultiresOptions {
  explicit MultiresOptions(const arm::DisparityParameters& defaults = {})
      : multires(defaults.multires ? "on" : "off"), default_multires_far_disparities(defaults.multires_far_disparities) {}
  std::string multires;
  // --multires-far: given only with --multires on (else a usage error); unset: the default.
  std::optional<int> multires_far_disparities;
  int default_multires_far_disparities;
};

// Adds --multires and --multires-far to `command`.
void add_multires_options(CLI::App& command, MultiresOptions& options);

// Sets parameters.multires and multires_far_disparities from the options. Throws CommandError
// (exit 2) for --multires-far without --multires on.
void apply_multires_options(const MultiresOptions& options, arm::DisparityParameters& parameters);

struct DisparityEngineOptions {
  // The options' defaults are `defaults`' (arm::DisparityParameters' own for `lpstereo disparity`;
  // the obstacle detector's tuned matcher for `lpstereo obstacles`).
  explicit DisparityEngineOptions(const arm::DisparityParameters& defaults = {})
      : paths(defaults.paths),
        census(defaults.census_width == 9 ? "9x7" : "5x5"),
        subpixel(defaults.subpixel ? "on" : "off"),
        lr_check(defaults.lr_max_diff >= 0 ? std::to_string(defaults.lr_max_diff) : "off"),
        uniqueness_percent(defaults.uniqueness_percent),
        median(defaults.median ? "on" : "off"),
        speckle_size_px(defaults.speckle_max_size_px),
        speckle_range_px(defaults.speckle_max_difference_px),
        multires(defaults) {}
  std::optional<int> min_disparity_px, num_disparities;
  int paths;
  std::optional<int> p1, p2;
  std::string census;
  std::string subpixel;
  std::string lr_check;
  int uniqueness_percent;
  std::string median;
  int speckle_size_px;
  int speckle_range_px;
  MultiresOptions multires;
  std::string max_memory;  // --max-memory (add_max_memory_option); "" = the machine's available memory
};

// --max-memory SIZE, for the commands that run the engine on whole frames (`lpstereo disparity`,
// `lpstereo run`).
void add_max_memory_option(CLI::App& command, DisparityEngineOptions& options);

// --max-memory in bytes: a number with an optional K, M or G suffix (powers of 1024); "" = the
// machine's available memory (MemAvailable of /proc/meminfo; 0 = no limit where it cannot be read).
// Throws CommandError (exit 2) for text that is not a size.
size_t max_memory_bytes(const std::string& text);

// Fails before anything is allocated when the engine's working set for width x height frames
// (arm::DisparityEngine::working_set_bytes) exceeds --max-memory: CommandError (exit 1), one line
// naming the need, the setting and the limit. `engines`: that many engines at once (frames in flight).
void check_engine_memory(const DisparityEngineOptions& options, int width, int height, const arm::DisparityParameters& parameters,
                         int worker_threads, int engines = 1);

// Adds the options to `command`; num_disparities_help is --num-disp's help (its default differs).
void add_disparity_engine_options(CLI::App& command, DisparityEngineOptions& options, const std::string& num_disparities_help);

// The engine's parameters for an image `width` px wide; --num-disp defaults to
// default_num_disparities. Throws CommandError (one line naming the flag, expected and actual).
arm::DisparityParameters disparity_parameters(const DisparityEngineOptions& options, int width, int default_num_disparities);

// The disparity_to_points parameters of a rectified pinhole pair matched with [min, min + num)
// disparities: the rectified focal length, baseline and left principal point, and the principal
// points' difference as the disparity offset (0 unless the file gives the views different cx).
inline arm::TriangulationParameters triangulation_parameters(const io::RectifiedGeometry& geometry, int min_disparity,
                                                             int num_disparities) {
  return {geometry.baseline_m, geometry.focal_px, geometry.cx_left_px, geometry.cy_px, min_disparity, num_disparities,
          geometry.cx_right_px - geometry.cx_left_px};
}

}  // namespace lpstereo::tools
