#include "tools/disparity_options.h"

#include <cctype>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "arm/scheduler.h"
#include "tools/command_error.h"

namespace lpstereo::tools {

void add_disparity_engine_options(CLI::App& command, DisparityEngineOptions& options, const std::string& num_disparities_help) {
  command.add_option("--min-disp", options.min_disparity_px, "smallest disparity searched, px (may be negative; default 0)");
  command.add_option("--num-disp", options.num_disparities, num_disparities_help);
  command.add_option("--paths", options.paths, "SGM paths: 4 (one pass), 8 (two passes), 0 (census winner takes all)")
      ->capture_default_str()
      ->check(CLI::IsMember({0, 4, 8}));
  command.add_option("--p1", options.p1, "SGM penalty for a 1 px change, Hamming bits (default 5 for 5x5, 7 for 9x7)");
  command.add_option("--p2", options.p2, "SGM penalty for larger changes, Hamming bits, >= p1, <= 4000 (default 45 / 50)");
  command.add_option("--census", options.census, "census window")->capture_default_str()->check(CLI::IsMember({"5x5", "9x7"}));
  command.add_option("--subpixel", options.subpixel, "parabola sub-pixel step (Q4)")
      ->capture_default_str()
      ->check(CLI::IsMember({"on", "off"}));
  command.add_option("--lr-check", options.lr_check, "left-right check tolerance in px, or off")->capture_default_str();
  command.add_option("--uniqueness", options.uniqueness_percent, "SGM uniqueness ratio in % (0 = off, <= 50)")
      ->capture_default_str();
  command.add_option("--median", options.median, "SGM: 3x3 median that keeps invalid pixels invalid")
      ->capture_default_str()
      ->check(CLI::IsMember({"on", "off"}));
  command.add_option("--speckle-size", options.speckle_size_px,
                     "SGM: regions of at most this many pixels become invalid (cv::filterSpeckles; 0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1 << 30));
  command.add_option("--speckle-range", options.speckle_range_px,
                     "SGM: neighbours within this many px belong to one speckle region")
      ->capture_default_str()
      ->check(CLI::Range(0, 4095));
  add_multires_options(command, options.multires);
}

void add_max_memory_option(CLI::App& command, DisparityEngineOptions& options) {
  command.add_option("--max-memory", options.max_memory,
                     "working memory the disparity engine may take: bytes, or a number with K, M or G (powers of 1024); "
                     "default: the machine's available memory. A size and range that need more fail before allocating");
}

size_t max_memory_bytes(const std::string& text) {
  if (text.empty()) {
    std::ifstream meminfo("/proc/meminfo");
    std::string key;
    size_t kilobytes = 0;
    while (meminfo >> key >> kilobytes) {
      if (key == "MemAvailable:") return kilobytes * 1024;
      meminfo.ignore(256, '\n');
    }
    return 0;
  }
  size_t digits = 0;
  while (digits < text.size() && std::isdigit(static_cast<unsigned char>(text[digits]))) ++digits;
  const std::string suffix = text.substr(digits);
  const int shift = suffix.empty() ? 0 : suffix == "K" || suffix == "k" ? 10 : suffix == "M" || suffix == "m" ? 20
                    : suffix == "G" || suffix == "g" ? 30 : -1;
  if (digits == 0 || digits > 12 || shift < 0) {
    throw CommandError(kExitUsage, "--max-memory: expected bytes or a number with K, M or G (e.g. 600M), got '" + text + "'");
  }
  return static_cast<size_t>(std::stoull(text.substr(0, digits))) << shift;
}

void check_engine_memory(const DisparityEngineOptions& options, int width, int height, const arm::DisparityParameters& parameters,
                         int worker_threads, int engines) {
  const size_t limit = max_memory_bytes(options.max_memory);
  if (limit == 0) return;
  const size_t need = static_cast<size_t>(engines) * arm::DisparityEngine::working_set_bytes(width, height, parameters, worker_threads);
  if (need <= limit) return;
  auto mib = [](size_t bytes) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.1f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
    return std::string(text);
  };
  throw CommandError(kExitInput, "disparity engine at " + std::to_string(width) + "x" + std::to_string(height) + " (" +
                                     arm::settings_text(parameters) + ", " +
                                     std::to_string(arm::resolved_worker_threads(worker_threads)) + " workers" +
                                     (engines > 1 ? ", " + std::to_string(engines) + " pairs in flight" : "") + ") needs " +
                                     mib(need) + " of working memory; " +
                                     (options.max_memory.empty() ? "the machine has " + mib(limit) + " available"
                                                                 : "--max-memory " + options.max_memory + " allows " + mib(limit)) +
                                     " (fewer --num-disp, --paths 4, --multires on, fewer --threads or --in-flight need less)");
}

void add_multires_options(CLI::App& command, MultiresOptions& options) {
  command.add_option("--multires", options.multires,
                     "on: full-resolution SGM over [min-disp, min-disp + min(num-disp, --multires-far)) plus a half-resolution "
                     "pass over the whole range, fused into one full-resolution map (arm/disparity_engine.h, "
                     "docs/kernels.md); off: one full-resolution pass")
      ->capture_default_str()
      ->check(CLI::IsMember({"on", "off"}));
  command.add_option("--multires-far", options.multires_far_disparities,
                     "with --multires on: the full-resolution pass's cap in px (the half-resolution pass matches "
                     "the rest of the range)")
      ->default_str(std::to_string(options.default_multires_far_disparities))
      ->check(CLI::Range(1, 512));
}

void apply_multires_options(const MultiresOptions& options, arm::DisparityParameters& parameters) {
  parameters.multires = options.multires == "on";
  if (options.multires_far_disparities && !parameters.multires) {
    throw CommandError(kExitUsage, "--multires-far: sets the multi-resolution engine's full-resolution pass; expected --multires on, got off");
  }
  parameters.multires_far_disparities = options.multires_far_disparities.value_or(options.default_multires_far_disparities);
}

arm::DisparityParameters disparity_parameters(const DisparityEngineOptions& options, int width, int default_num_disparities) {
  arm::DisparityParameters parameters;
  parameters.paths = options.paths;
  parameters.census_width = options.census == "9x7" ? 9 : 5;
  if (options.p1) parameters.p1 = *options.p1;
  if (options.p2) parameters.p2 = *options.p2;
  parameters.subpixel = options.subpixel == "on";
  parameters.uniqueness_percent = options.uniqueness_percent;
  parameters.median = options.median == "on";
  parameters.speckle_max_size_px = options.speckle_size_px;
  parameters.speckle_max_difference_px = options.speckle_range_px;
  apply_multires_options(options.multires, parameters);
  if (options.lr_check == "off") {
    parameters.lr_max_diff = -1;
  } else {
    try {
      size_t used = 0;
      parameters.lr_max_diff = std::stoi(options.lr_check, &used);
      if (used != options.lr_check.size() || parameters.lr_max_diff < 0) throw std::invalid_argument("not a count");
    } catch (const std::exception&) {
      throw CommandError(kExitUsage, "--lr-check: expected a tolerance in px (0, 1, 2, ...) or off, got '" + options.lr_check + "'");
    }
  }
  parameters.min_disparity = options.min_disparity_px.value_or(0);
  parameters.num_disparities = options.num_disparities.value_or(default_num_disparities);
  check_disparity_range(parameters.min_disparity, parameters.num_disparities, width);
  return parameters;
}

}  // namespace lpstereo::tools
