#include "tools/eval_command.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "arm/disparity_engine.h"
#include "dag/atomic_file.h"
#include "host_sim/target.h"
#include "io/disparity_metrics.h"
#include "io/image_io.h"
#include "io/kitti_poses.h"
#include "io/odometry_metrics.h"
#include "io/opencv_sgbm.h"
#include "io/stereo_datasets.h"
#include "tools/command_error.h"
#include "tools/trajectory_plot.h"

namespace lpstereo::tools {

namespace {

constexpr const char* kLpstereoMethod = "lpstereo";

struct Method {
  std::string name;                 // row label and JSON key
  std::optional<io::SgbmMode> sgbm; // empty: lpstereo's engine
  bool chip = false;                // lpstereo's engine in the chip configuration (--chip)
};

// Every number of one evaluation, flattened ("all.dense.bad2_pct" -> value); NaN = not available.
using FlatMetrics = std::vector<std::pair<std::string, double>>;

void add_error_metrics(FlatMetrics& flat, const std::string& prefix, const io::ErrorMetrics& metrics) {
  flat.emplace_back(prefix + "pixels", static_cast<double>(metrics.pixels));
  flat.emplace_back(prefix + "bad1_pct", metrics.bad1_pct);
  flat.emplace_back(prefix + "bad2_pct", metrics.bad2_pct);
  flat.emplace_back(prefix + "bad4_pct", metrics.bad4_pct);
  flat.emplace_back(prefix + "d1_pct", metrics.d1_pct);
  flat.emplace_back(prefix + "epe_px", metrics.epe_px);
}

FlatMetrics flatten(const io::DisparityMetrics& metrics) {
  FlatMetrics flat;
  for (const auto& [name, region] : {std::pair<std::string, const io::RegionMetrics*>{"nonocc", &metrics.nonocc},
                                     std::pair<std::string, const io::RegionMetrics*>{"all", &metrics.all}}) {
    flat.emplace_back(name + ".ground_truth_pixels", static_cast<double>(region->ground_truth_pixels));
    flat.emplace_back(name + ".density_pct", region->density_pct);
    add_error_metrics(flat, name + ".dense.", region->dense);
    add_error_metrics(flat, name + ".valid.", region->valid);
  }
  return flat;
}

double lookup(const FlatMetrics& flat, const std::string& key) {
  for (const auto& [name, value] : flat) {
    if (name == key) return value;
  }
  return std::nan("");
}

// Mean over pairs of each number, ignoring pairs where it is not available.
FlatMetrics mean_of(const std::vector<FlatMetrics>& per_pair) {
  FlatMetrics mean;
  if (per_pair.empty()) return mean;
  for (const auto& [key, unused] : per_pair.front()) {
    double sum = 0;
    int count = 0;
    for (const FlatMetrics& flat : per_pair) {
      const double value = lookup(flat, key);
      if (std::isnan(value)) continue;
      sum += value;
      ++count;
    }
    mean.emplace_back(key, count > 0 ? sum / count : std::nan(""));
  }
  return mean;
}

nlohmann::json to_json(const FlatMetrics& flat) {
  nlohmann::json json = nlohmann::json::object();
  for (const auto& [key, value] : flat) {
    std::string pointer = "/" + key;
    for (char& c : pointer) c = c == '.' ? '/' : c;
    const bool count = key.size() >= 6 && key.compare(key.size() - 6, 6, "pixels") == 0;
    json[nlohmann::json::json_pointer(pointer)] = std::isnan(value) ? nlohmann::json(nullptr)
                                                  : count           ? nlohmann::json(std::llround(value))
                                                                    : nlohmann::json(value);
  }
  return json;
}

std::string cell(const FlatMetrics& flat, const std::string& region, const std::string& metric) {
  const double dense = lookup(flat, region + ".dense." + metric);
  const double valid = lookup(flat, region + ".valid." + metric);
  char text[32];
  if (std::isnan(dense) && std::isnan(valid)) return "-";
  std::snprintf(text, sizeof text, "%.2f/%.2f", dense, valid);
  return text;
}

std::string number(double value, const char* format) {
  if (std::isnan(value)) return "-";
  char text[32];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

void print_table(const std::vector<Method>& methods, const std::vector<FlatMetrics>& rows) {
  std::printf("  %-22s %8s %8s | %13s %13s %13s %13s | %13s %13s %13s\n", "method (dense/valid)", "dens-noc", "dens-all",
              "noc bad-1 %", "noc bad-2 %", "noc bad-4 %", "noc EPE px", "all bad-2 %", "all D1 %", "all EPE px");
  for (size_t m = 0; m < methods.size(); ++m) {
    const FlatMetrics& flat = rows[m];
    std::printf("  %-22s %8s %8s | %13s %13s %13s %13s | %13s %13s %13s\n", methods[m].name.c_str(),
                number(lookup(flat, "nonocc.density_pct"), "%.1f%%").c_str(),
                number(lookup(flat, "all.density_pct"), "%.1f%%").c_str(), cell(flat, "nonocc", "bad1_pct").c_str(),
                cell(flat, "nonocc", "bad2_pct").c_str(), cell(flat, "nonocc", "bad4_pct").c_str(),
                cell(flat, "nonocc", "epe_px").c_str(), cell(flat, "all", "bad2_pct").c_str(),
                cell(flat, "all", "d1_pct").c_str(), cell(flat, "all", "epe_px").c_str());
  }
}

std::string range_text(int min_disparity_px, int num_disparities) {
  return "[" + std::to_string(min_disparity_px) + ", " + std::to_string(min_disparity_px + num_disparities) + ")";
}


// --- eval odometry -------------------------------------------------------------------------------

std::vector<Eigen::Isometry3d> read_trajectory(const std::string& path) {
  std::vector<Eigen::Isometry3d> poses = io::read_kitti_poses(path);  // PoseFileError names the file and line
  if (poses.empty()) throw CommandError(kExitInput, path + ": no pose (expected one line of 12 numbers per frame)");
  return poses;
}

std::string lengths_text(const std::vector<double>& lengths_m) {
  std::string text;
  for (double length_m : lengths_m) text += (text.empty() ? "" : ", ") + number(length_m, "%g");
  return text + " m";
}

nlohmann::json number_or_null(double value) { return std::isnan(value) ? nlohmann::json(nullptr) : nlohmann::json(value); }

// The KITTI metric of `estimate_path` against `truth_path`, printed, and optionally drawn and saved.
int run_eval_odometry(const EvalOptions& options) {
  if (options.files.size() != 2) {
    throw CommandError(kExitUsage, "eval odometry: expected 2 files (TRAJ.txt POSES.txt: the estimate, then the ground truth), got " +
                                       std::to_string(options.files.size()));
  }
  for (const auto& [given, flag] : {std::pair<bool, const char*>{!options.data_directory.empty(), "--data"},
                                    {!options.baseline.empty(), "--baseline"},
                                    {options.num_disparities.has_value(), "--num-disp"},
                                    {options.min_disparity_px.has_value(), "--min-disp"},
                                    {options.multires.multires == "on", "--multires"},
                                    {options.multires.multires_far_disparities.has_value(), "--multires-far"}}) {
    if (given) throw CommandError(kExitUsage, std::string(flag) + ": only for eval middlebury|kitti, not eval odometry");
  }
  const std::string& estimate_path = options.files[0];
  const std::string& truth_path = options.files[1];
  const std::vector<Eigen::Isometry3d> estimate = read_trajectory(estimate_path);
  const std::vector<Eigen::Isometry3d> ground_truth = read_trajectory(truth_path);
  if (estimate.size() != ground_truth.size()) {
    throw CommandError(kExitInput, estimate_path + " has " + std::to_string(estimate.size()) + " poses, " + truth_path + " has " +
                                       std::to_string(ground_truth.size()) + ": expected one pose per frame in both");
  }
  // The relative errors do not depend on where a trajectory starts; the end-point error and the ATE
  // compare positions as given, which is what a trajectory starting at the identity means.
  for (const auto& [path, poses] : {std::pair<const std::string&, const std::vector<Eigen::Isometry3d>&>{estimate_path, estimate},
                                    {truth_path, ground_truth}}) {
    if (!poses.front().isApprox(Eigen::Isometry3d::Identity(), 1e-6)) {
      std::fprintf(stderr, "eval odometry: note: %s does not start at the identity; the end-point error and the ATE compare "
                           "positions as given\n", path.c_str());
    }
  }
  io::OdometrySettings settings;
  settings.segment_lengths_m = options.segment_lengths_m;
  settings.step_frames = options.step_frames.value_or(1);
  io::OdometryErrors errors;
  try {
    errors = io::evaluate_odometry(estimate, ground_truth, settings);
  } catch (const io::OdometryEvaluationError& error) {
    const std::string advice = options.segment_lengths_m.empty() ? "" : " (--lengths)";
    throw CommandError(kExitInput, truth_path + ": " + error.what() + advice);
  }
  std::vector<double> lengths_m;
  for (const io::LengthErrors& summary : errors.per_length) lengths_m.push_back(summary.length_m);
  const std::string lengths_source = options.segment_lengths_m.empty() ? "automatic: the lengths the path allows" : "--lengths";

  std::printf("eval odometry: %s (estimate) against %s (ground truth): %d frames\n", estimate_path.c_str(), truth_path.c_str(),
              errors.frames);
  std::printf("path length: ground truth %.2f m, estimate %.2f m\n", errors.ground_truth_path_m, errors.estimate_path_m);
  std::printf("KITTI odometry metric (devkit evaluate_odometry): segments from every %d frame(s), lengths %s (%s); error = "
              "relative pose error over the segment / its length\n",
              errors.step_frames, lengths_text(lengths_m).c_str(), lengths_source.c_str());
  std::printf("  %10s %9s %15s %17s\n", "length m", "segments", "translation %", "rotation deg/m");
  for (const io::LengthErrors& summary : errors.per_length) {
    std::printf("  %10s %9d %15s %17s\n", number(summary.length_m, "%g").c_str(), summary.segments,
                number(summary.translation_error_pct, "%.3f").c_str(), number(summary.rotation_error_deg_per_m, "%.5f").c_str());
  }
  std::printf("  %10s %9zu %15.3f %17.5f   (mean over all segments, as KITTI)\n", "all", errors.segments.size(),
              errors.translation_error_pct, errors.rotation_error_deg_per_m);
  std::printf("end point: %.3f m (%s %% of the path), rotation %.3f deg\n", errors.end_point_error_m,
              number(errors.end_point_error_pct, "%.2f").c_str(), errors.end_rotation_error_deg);
  std::printf("ATE (RMS position error over the frames, no alignment): %.3f m\n", errors.ate_rmse_m);
  std::printf("translation error %.3f %%, rotation error %.5f deg/m\n", errors.translation_error_pct,
              errors.rotation_error_deg_per_m);

  if (!options.plot_path.empty()) {
    TrajectoryPlotLabels labels;
    char title[160];
    std::snprintf(title, sizeof title, "translation error %.2f %%, rotation error %.4f deg/m, end point %.2f m",
                  errors.translation_error_pct, errors.rotation_error_deg_per_m, errors.end_point_error_m);
    labels.title = title;
    labels.estimate_name = std::filesystem::path(estimate_path).filename().string();
    labels.ground_truth_name = std::filesystem::path(truth_path).filename().string();
    io::write_image(options.plot_path, draw_trajectory_plot(estimate, ground_truth, labels));
    std::printf("plot: %s\n", options.plot_path.c_str());
  }
  if (!options.json_path.empty()) {
    nlohmann::json report;
    report["benchmark"] = "odometry";
    report["estimate"] = estimate_path;
    report["ground_truth"] = truth_path;
    report["frames"] = errors.frames;
    report["step_frames"] = errors.step_frames;
    report["lengths_m"] = lengths_m;
    report["lengths_source"] = options.segment_lengths_m.empty() ? "automatic" : "--lengths";
    report["ground_truth_path_m"] = errors.ground_truth_path_m;
    report["estimate_path_m"] = errors.estimate_path_m;
    report["segments"] = errors.segments.size();
    report["translation_error_pct"] = errors.translation_error_pct;
    report["rotation_error_deg_per_m"] = errors.rotation_error_deg_per_m;
    report["per_length"] = nlohmann::json::array();
    for (const io::LengthErrors& summary : errors.per_length) {
      report["per_length"].push_back({{"length_m", summary.length_m},
                                      {"segments", summary.segments},
                                      {"translation_error_pct", number_or_null(summary.translation_error_pct)},
                                      {"rotation_error_deg_per_m", number_or_null(summary.rotation_error_deg_per_m)}});
    }
    report["end_point_error_m"] = errors.end_point_error_m;
    report["end_point_error_pct"] = number_or_null(errors.end_point_error_pct);
    report["end_rotation_error_deg"] = errors.end_rotation_error_deg;
    report["ate_rmse_m"] = errors.ate_rmse_m;
    write_file_atomically(options.json_path, report.dump(2) + "\n");
    std::printf("report: %s\n", options.json_path.c_str());
  }
  return 0;
}

}  // namespace

int run_eval(const EvalOptions& options) {
  if (options.benchmark == "odometry") return run_eval_odometry(options);
  if (options.benchmark != "middlebury" && options.benchmark != "kitti") {
    throw CommandError(kExitUsage, "eval: expected 'middlebury', 'kitti' or 'odometry', got '" + options.benchmark + "'");
  }
  if (!options.files.empty()) {
    throw CommandError(kExitUsage, "eval " + options.benchmark + ": expected no file (the pairs come from --data), got '" +
                                       options.files.front() + "'");
  }
  if (!options.segment_lengths_m.empty() || options.step_frames || !options.plot_path.empty()) {
    throw CommandError(kExitUsage, "--lengths, --step, --plot: only for eval odometry, not eval " + options.benchmark);
  }
  const bool with_opencv = options.baseline == "opencv";
  if (!options.baseline.empty() && !with_opencv) {
    throw CommandError(kExitUsage, "--baseline: expected 'opencv', got '" + options.baseline + "'");
  }
  if (options.num_disparities && *options.num_disparities <= 0) {
    throw CommandError(kExitUsage, "--num-disp: expected a positive number of disparities, got " +
                                       std::to_string(*options.num_disparities));
  }
  if (with_opencv && options.num_disparities && *options.num_disparities % 16 != 0) {
    throw CommandError(kExitUsage, "--num-disp: OpenCV StereoSGBM needs a multiple of 16 (the same range for both), got " +
                                       std::to_string(*options.num_disparities));
  }
  arm::DisparityParameters defaults;
  apply_multires_options(options.multires, defaults);  // a usage error before any data is read
  const std::string data_directory = io::shared_data_directory(options.data_directory);
  std::vector<io::StereoPair> pairs = options.benchmark == "middlebury" ? io::load_middlebury_pairs(data_directory)
                                                                         : io::load_kitti_pairs(data_directory);
  std::vector<Method> methods = {{kLpstereoMethod, std::nullopt}};
  // --chip TARGET: the configuration the chip graphs run on TARGET's stereo unit, beside the defaults.
  std::vector<int> chip_search_ranges;
  if (!options.chip_target.empty()) {
    const host_sim::Target target = host_sim::load_target(options.chip_target);
    for (const host_sim::FixedFunctionUnit& unit : target.units) {
      if (unit.limits.kind == "stereo" && chip_search_ranges.empty()) chip_search_ranges = unit.limits.search_ranges;
    }
    if (chip_search_ranges.empty()) {
      throw CommandError(kExitUsage, "--chip: expected a target with a stereo unit, target '" + target.name + "' has none");
    }
    methods.push_back({std::string(kLpstereoMethod) + " chip", std::nullopt, true});
  }
  if (with_opencv) {
    for (io::SgbmMode mode : {io::SgbmMode::sgbm, io::SgbmMode::sgbm_3way, io::SgbmMode::hh}) {
      methods.push_back({std::string("opencv ") + io::sgbm_mode_name(mode), mode});
    }
  }
  const io::SgbmSettings sgbm_settings;
  std::printf("eval %s: %zu pair(s) from %s; dense = after the KITTI fill, every ground-truth pixel; valid = only the "
              "pixels the method produced\n",
              options.benchmark.c_str(), pairs.size(), data_directory.c_str());
  // settings_text would name the multi-resolution split of the default range; each pair has its own.
  arm::DisparityParameters single_pass = defaults;
  single_pass.multires = false;
  std::printf("lpstereo: arm::DisparityEngine (%s%s)\n", arm::settings_text(single_pass).c_str(),
              defaults.multires ? (", multi-resolution: at most " + std::to_string(defaults.multires_far_disparities) +
                                   " px at full resolution, the whole range at half resolution, fused")
                                      .c_str()
                                : "");
  if (!chip_search_ranges.empty()) {
    std::printf("lpstereo chip: arm::chip_configuration on %s's stereo unit (%s; the smallest offered range covering "
                "each pair's)\n",
                options.chip_target.c_str(), arm::settings_text(arm::chip_configuration(single_pass, chip_search_ranges)).c_str());
  }
  if (with_opencv) std::printf("%s\n", io::sgbm_settings_text(sgbm_settings).c_str());

  nlohmann::json report;
  report["benchmark"] = options.benchmark;
  report["data_directory"] = data_directory;
  report["settings"]["lpstereo"] = {{"engine", "arm::DisparityEngine"},
                                    {"census_width", defaults.census_width},
                                    {"max_cost_bits", defaults.max_cost_bits},
                                    {"multires", defaults.multires}};
  if (defaults.multires) report["settings"]["lpstereo"]["multires_far_disparities"] = defaults.multires_far_disparities;
  if (with_opencv) report["settings"]["opencv"] = io::sgbm_settings_text(sgbm_settings);
  report["settings"]["fill"] = "KITTI devkit interpolateBackground (dense metrics)";
  report["pairs"] = nlohmann::json::array();

  std::map<std::string, std::vector<FlatMetrics>> per_method;
  for (io::StereoPair& pair : pairs) {
    if (options.num_disparities) {
      pair.num_disparities = *options.num_disparities;
      pair.range_source = "--num-disp";
    }
    if (options.min_disparity_px) {
      pair.min_disparity_px = *options.min_disparity_px;
      pair.range_source += pair.range_source == "--num-disp" ? " and --min-disp" : "; --min-disp";
    }
    const int width = pair.left.width();
    if (pair.min_disparity_px + pair.num_disparities > width || pair.min_disparity_px <= -width) {
      throw CommandError(kExitInput, pair.name + ": disparity range " + range_text(pair.min_disparity_px, pair.num_disparities) +
                                         ": expected min-disp > -" + std::to_string(width) + " and min-disp + num-disp <= " +
                                         std::to_string(width) + " (the image width)");
    }
    std::fprintf(stderr, "eval: %s/%s %dx%d, disparities %s ...\n", pair.collection.c_str(), pair.name.c_str(), width,
                 pair.left.height(), range_text(pair.min_disparity_px, pair.num_disparities).c_str());
    const int16_t invalid_q4 = static_cast<int16_t>((pair.min_disparity_px - 1) * 16);
    std::vector<FlatMetrics> rows;
    nlohmann::json pair_json = {{"collection", pair.collection},
                                {"name", pair.name},
                                {"width", width},
                                {"height", pair.left.height()},
                                {"min_disparity_px", pair.min_disparity_px},
                                {"num_disparities", pair.num_disparities},
                                {"range_source", pair.range_source},
                                {"has_nonocc", !pair.nonocc_mask.empty()}};
    for (const Method& method : methods) {
      Plane disparity_q4;
      if (method.sgbm) {
        disparity_q4 = io::run_opencv_sgbm(pair.left, pair.right, pair.min_disparity_px, pair.num_disparities, *method.sgbm,
                                           sgbm_settings);
      } else {
        arm::DisparityParameters parameters = defaults;
        parameters.min_disparity = pair.min_disparity_px;
        parameters.num_disparities = pair.num_disparities;
        if (method.chip) {
          // The unit searches its own range; one that runs past the image is cut to the width.
          parameters = arm::chip_configuration(parameters, chip_search_ranges);
          parameters.num_disparities = std::min(parameters.num_disparities, width - pair.min_disparity_px);
        }
        arm::DisparityEngine engine(width, pair.left.height(), parameters, {}, options.threads);
        disparity_q4 = engine.compute(pair.left, pair.right);  // shares the buffer, which outlives the engine
      }
      rows.push_back(flatten(io::evaluate_disparity(disparity_q4, invalid_q4, pair.ground_truth_px, pair.nonocc_mask)));
      pair_json["methods"][method.name] = to_json(rows.back());
      per_method[method.name].push_back(rows.back());
    }
    std::printf("\n%s/%s (%dx%d, disparities %s: %s)\n", pair.collection.c_str(), pair.name.c_str(), width,
                pair.left.height(), range_text(pair.min_disparity_px, pair.num_disparities).c_str(),
                pair.range_source.c_str());
    print_table(methods, rows);
    report["pairs"].push_back(pair_json);
  }
  std::vector<FlatMetrics> means;
  for (const Method& method : methods) {
    means.push_back(mean_of(per_method[method.name]));
    report["mean"][method.name] = to_json(means.back());
  }
  std::printf("\nmean over %zu pair(s) (%s)\n", pairs.size(), options.benchmark.c_str());
  print_table(methods, means);
  if (!options.json_path.empty()) {
    write_file_atomically(options.json_path, report.dump(2) + "\n");
    std::printf("\nreport: %s\n", options.json_path.c_str());
  }
  return 0;
}

}  // namespace lpstereo::tools
