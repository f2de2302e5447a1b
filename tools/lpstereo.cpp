// lpstereo: the command line. Sub-commands:
//   disparity   the main job: LEFT RIGHT -o OUT through arm::DisparityEngine (KITTI PNG, PFM or raw
//               s16; optional multi-resolution, rectification with a calibration, right-view map,
//               fill, colour view, profile on a target), or --synthetic: the built-in scene into a
//               folder with its colour view, truth and cv1-class profile
//   eval        middlebury | kitti: accuracy on the shared data, optionally beside OpenCV StereoSGBM;
//               odometry: a trajectory against its ground truth (KITTI odometry metric)
//   profile     the cost of a graph on a target at a frame size: report JSON, Perfetto trace,
//               Markdown summary; --enforce exits 3 when over the time or bandwidth budget
//   graph       verify | dot
//   kernels     the kernels and ARM tasks this binary has
//   rectify, check-rectification, calibrate   cameras (tools/geometry_commands.h)
//   points, synth   point clouds (tools/points_command.h), synthetic scenes (tools/synth_command.h)
//   obstacles   the obstacle detector on a rectified pair (tools/obstacles_command.h)
//   terrain     the B-spline terrain model and traversability cost of a rectified pair (tools/terrain_command.h)
//   odometry    stereo visual odometry over a rectified sequence, KITTI poses out (tools/odometry_command.h)
//   localize    keyframe localization of a downward stereo camera, KITTI poses + keyframe database out
//               (tools/localize_command.h)
//   obstacles3d 3D obstacles over a sequence: occupancy grids, stixels or tracked voxels (tools/obstacles3d_command.h)
//   run         a graph on a stereo source (camera or recording), live status, outputs, recording
//               (tools/run_command.h)
//
// Exit codes: 0 done; 1 bad input or a graph that fails verify (one line on stderr); 2 bad usage;
// 3 over budget with --enforce; 4 `terrain` found the terrain unknown (its JSON written, known false).
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "arm/disparity_engine.h"
#include "arm/heap_policy.h"
#include "arm/scheduler.h"
#include "dag/atomic_file.h"
#include "dag/graph.h"
#include "host_sim/report.h"
#include "host_sim/simulator.h"
#include "host_sim/target.h"
#include "io/disparity_io.h"
#include "io/image_io.h"
#include "io/synthetic_scene.h"
#include "kernels/simd/isa.h"
#include "tools/command_error.h"
#include "tools/disparity_options.h"
#include "tools/eval_command.h"
#include "tools/geometry_commands.h"
#include "tools/localize_command.h"
#include "tools/obstacles3d_command.h"
#include "tools/obstacles_command.h"
#include "tools/odometry_command.h"
#include "tools/points_command.h"
#include "tools/terrain_command.h"
#include "tools/run_command.h"
#include "tools/synth_command.h"
#include "tools/target_profile.h"

namespace {

using namespace lpstereo;
using tools::CommandError;
using tools::kExitInput;
using tools::kExitOverBudget;
using tools::kExitUsage;

struct FrameSize {
  int width = 0;
  int height = 0;
};

void check_frame_size(const FrameSize& size) {
  if (size.width < 16 || size.height < 16 || size.width > 16384 || size.height > 16384) {
    throw CommandError(kExitUsage, "frame size: expected 16..16384 x 16..16384, got " + std::to_string(size.width) + "x" +
                              std::to_string(size.height));
  }
}

// A graph verified for a target at a frame size (tools/target_profile.h).
Graph verified_for_target(const GraphSpec& spec, const host_sim::Target& target, const FrameSize& size, bool check_sram = true) {
  return tools::verified_for_target(spec, target, size.width, size.height, check_sram);
}

Graph load_and_verify(const std::string& graph_name, const host_sim::Target& target, const FrameSize& size,
                      bool check_sram = true) {
  return verified_for_target(load_graph_spec(host_sim::find_data_file("graphs", graph_name)), target, size, check_sram);
}

// Synthetic frames for every u8 input of a graph: the left/right views of the built-in scene.
std::map<std::string, Plane> synthetic_inputs(const Graph& graph, const FrameSize& size) {
  io::SyntheticSceneOptions options;
  options.width = size.width;
  options.height = size.height;
  io::SyntheticStereoScene scene = io::make_synthetic_stereo_scene(options);
  std::map<std::string, Plane> inputs;
  int index = 0;
  for (const GraphInputSpec& input : graph.spec().inputs) {
    if (input.format.type == ElementType::u8) {
      inputs[input.name] = (index++ % 2 == 0) ? scene.left : scene.right;
    } else if (input.format.type == ElementType::s16 && input.format.fraction_bits == 4) {
      inputs[input.name] = scene.disparity_q4;  // a disparity input: the scene's true disparity
    } else {
      throw CommandError(kExitInput, "graph input '" + input.name + "' is " + format_name(input.format) +
                                         "; synthetic frames exist for u8 views and s16q4 disparity inputs only");
    }
  }
  return inputs;
}

std::map<std::string, const Plane*> pointers(const std::map<std::string, Plane>& planes) {
  std::map<std::string, const Plane*> result;
  for (const auto& [name, plane] : planes) result[name] = &plane;
  return result;
}

struct ProfileOutputs {
  std::string report_path, trace_path, summary_path;
};

void write_profile_outputs(const host_sim::ProfileReport& report, const ProfileOutputs& outputs) {
  if (!outputs.report_path.empty()) write_file_atomically(outputs.report_path, host_sim::report_json(report).dump(2) + "\n");
  if (!outputs.trace_path.empty()) write_file_atomically(outputs.trace_path, host_sim::chrome_trace_json(report));
  if (!outputs.summary_path.empty()) write_file_atomically(outputs.summary_path, host_sim::report_markdown(report));
}

int run_profile(const std::string& graph_name, const std::string& target_name, FrameSize size, double fps,
                const host_sim::ProfileOptions& pipeline, bool enforce, const ProfileOutputs& outputs) {
  check_frame_size(size);
  if (!(fps > 0 && fps <= 10000)) throw CommandError(kExitUsage, "--fps: expected a number in (0, 10000], got " + std::to_string(fps));
  const host_sim::Target target = host_sim::load_target(target_name);
  // A graph whose tiles do not fit the target's SRAM is refused by verify(); the profile still
  // reports what the rest would cost (tiles placed as if the SRAM were large enough), says first
  // and in the report that it does not fit, and fails --enforce whatever the graph file says.
  std::string sram_refusal;
  const Graph graph = [&] {
    try {
      return load_and_verify(graph_name, target, size);
    } catch (const SramBudgetError& error) {
      sram_refusal = error.what();
      return load_and_verify(graph_name, target, size, false);
    }
  }();
  const std::map<std::string, Plane> inputs = synthetic_inputs(graph, size);
  host_sim::ProfileOptions options = pipeline;
  options.fps_target = fps;
  host_sim::ProfileReport report = host_sim::profile_graph(graph, target, pointers(inputs), options);
  if (!sram_refusal.empty()) {
    report.fits_budget = false;
    report.over_budget.insert(report.over_budget.begin(), "does not fit the SRAM: " + sram_refusal +
                                                              " (the figures place its tiles as if it did)");
    std::cout << "DOES NOT FIT: " << sram_refusal << "\n";
  }
  std::cout << host_sim::report_table(report);
  write_profile_outputs(report, outputs);
  if (enforce && !report.fits_budget) {
    if (!report.enforce_budget && sram_refusal.empty()) {
      std::cout << "not enforced: graph '" << report.graph << "' is marked as not meant to fit: " << report.budget_note << "\n";
      return 0;
    }
    std::string reasons;
    for (const std::string& reason : report.over_budget) reasons += (reasons.empty() ? "" : "; ") + reason;
    std::cerr << "lpstereo: over budget: graph '" << report.graph << "' on " << report.target << " at " << report.width << "x"
              << report.height << ": " << reasons << "\n";
    return kExitOverBudget;
  }
  return 0;
}

// The matcher options (--min-disp, --num-disp, --paths, ...) are the shared ones (tools/disparity_options.h).
struct DisparityOptions : tools::DisparityEngineOptions {
  // LEFT RIGHT -o OUT
  std::string left_path, right_path, output_path, format, color_path, report_path;
  bool fill = false;
  // --synthetic: the built-in scene, everything into out_directory
  bool synthetic = false;
  FrameSize size{640, 480};
  std::string out_directory = "out";
  double fps = 30;
  // both
  std::string target_name;  // empty: cv1-class for --synthetic, no profile otherwise
  std::string config = "host";  // host: the engine's accurate defaults; chip: what the target's stereo unit runs
  std::vector<std::string> matcher_flags_given;  // the matcher flags on the command line (--config chip refuses them)
  int threads = 0;
  std::string backend = "native";
  // LEFT RIGHT only: calibration (one file or A,B), rectify with it, the right-view map
  std::vector<std::string> calibration_files;
  bool rectify = false;
  std::string right_output_path;
};

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// The format a file name's extension implies (.png kitti, .pfm pfm, .s16/.raw s16), or "".
std::string format_of_extension(const std::string& extension) {
  if (extension == ".png") return "kitti";
  if (extension == ".pfm") return "pfm";
  if (extension == ".s16" || extension == ".raw") return "s16";
  return "";
}

// --format, or the one OUT's extension implies. --right-out is written in the same format, so its
// name must not imply another one.
std::string output_format(const DisparityOptions& options) {
  const std::string extension = lowercase(std::filesystem::path(options.output_path).extension().string());
  std::string format = options.format.empty() ? format_of_extension(extension) : options.format;
  if (format.empty()) {
    throw CommandError(kExitUsage, "-o " + options.output_path + ": cannot tell the format from the extension '" + extension +
                                       "'; expected .png, .pfm, .s16 or .raw, or give --format kitti|pfm|s16");
  }
  if (format == "kitti" && extension != ".png") {
    throw CommandError(kExitUsage, "-o " + options.output_path + ": --format kitti writes a PNG; expected a .png name, got '" +
                                       extension + "'");
  }
  if (!options.right_output_path.empty()) {
    const std::string right_extension = lowercase(std::filesystem::path(options.right_output_path).extension().string());
    const std::string implied = format_of_extension(right_extension);
    if (format == "kitti" && right_extension != ".png") {
      throw CommandError(kExitUsage, "--right-out " + options.right_output_path +
                                         ": written as kitti like -o, a PNG; expected a .png name, got '" + right_extension + "'");
    }
    if (!implied.empty() && implied != format) {
      throw CommandError(kExitUsage, "--right-out " + options.right_output_path + ": written as " + format +
                                         " like -o, but its extension '" + right_extension + "' means " + implied);
    }
  }
  return format;
}

// Several output files as one: each is written (atomically, by its writer) under a hidden staging
// name beside its destination, and all are renamed into place by commit() once every one is
// written. Until then an error (an exception) removes the staged files, so a failed run leaves no
// output behind, not even the ones it had finished.
class StagedOutputs {
 public:
  StagedOutputs() = default;
  StagedOutputs(const StagedOutputs&) = delete;
  StagedOutputs& operator=(const StagedOutputs&) = delete;
  ~StagedOutputs() {
    for (const auto& [staged, destination] : files_) std::remove(staged.c_str());
  }
  // Runs `writer` with the name to write `path` under: same folder (the rename stays on one file
  // system), same extension (codecs pick their format by it). Its errors name `path`.
  void write(const std::string& path, const std::function<void(const std::string& staged_path)>& writer) {
    const std::filesystem::path destination(path);
    const std::string staged = (destination.parent_path() / ("." + destination.filename().string() + ".staged" +
                                                           std::to_string(::getpid()) + destination.extension().string()))
                                   .string();
    files_.emplace_back(staged, path);
    try {
      writer(staged);
    } catch (const FileWriteError& error) {
      std::string message = error.what();
      for (size_t at = message.find(staged); at != std::string::npos; at = message.find(staged, at + path.size())) {
        message.replace(at, staged.size(), path);
      }
      throw FileWriteError(message);
    }
  }
  void commit() {
    for (size_t i = 0; i < files_.size(); ++i) {
      if (std::rename(files_[i].first.c_str(), files_[i].second.c_str()) != 0) {
        const std::string reason = std::strerror(errno);
        files_.erase(files_.begin(), files_.begin() + static_cast<std::ptrdiff_t>(i));  // those are in place
        throw FileWriteError(files_.front().second + ": cannot rename the staged file into place: " + reason);
      }
    }
    files_.clear();
  }

 private:
  std::vector<std::pair<std::string, std::string>> files_;  // staged name, destination
};

void write_disparity_file(const std::string& path, const std::string& format, const Plane& disparity_q4, int min_disparity_px) {
  if (format == "kitti") io::write_kitti_disparity_png(path, disparity_q4, min_disparity_px);
  if (format == "pfm") io::write_pfm(path, io::disparity_q4_to_px(disparity_q4, min_disparity_px));
  if (format == "s16") io::write_s16_raw(path, disparity_q4);
}

KernelBackend kernel_backend(const DisparityOptions& options) {
  return options.backend == "counting" ? KernelBackend::counting : KernelBackend::native;
}

double density_pct(const Plane& disparity_q4, int16_t invalid_q4) {
  int64_t valid = 0;
  for (int y = 0; y < disparity_q4.height(); ++y) {
    for (int x = 0; x < disparity_q4.width(); ++x) valid += disparity_q4.at<int16_t>(x, y) != invalid_q4 ? 1 : 0;
  }
  return 100.0 * static_cast<double>(valid) / (static_cast<double>(disparity_q4.width()) * disparity_q4.height());
}

using tools::profile_engine_on_target;  // tools/target_profile.h

// The matcher flags a --config chip run refuses: the chip configuration fixes them.
const std::vector<std::string> kMatcherFlags = {"--paths",  "--census",       "--p1",            "--p2",
                                                "--lr-check", "--uniqueness", "--subpixel",      "--median",
                                                "--speckle-size", "--speckle-range", "--multires", "--multires-far"};

// --config chip: the engine's parameters replaced by the chip configuration of the target's stereo
// unit (arm::chip_configuration; the target: --target, else cv1-class), checked against the width.
arm::DisparityParameters configured(const DisparityOptions& options, const arm::DisparityParameters& parameters, int width) {
  if (options.config != "chip") return parameters;
  if (!options.matcher_flags_given.empty()) {
    throw CommandError(kExitUsage, "--config chip fixes the matcher (arm::chip_configuration): expected none of the matcher flags, got " +
                                       options.matcher_flags_given.front());
  }
  const std::string target_name = options.target_name.empty() ? "cv1-class" : options.target_name;
  const host_sim::Target target = host_sim::load_target(target_name);
  for (const host_sim::FixedFunctionUnit& unit : target.units) {
    if (unit.limits.kind != "stereo") continue;
    const arm::DisparityParameters chip = arm::chip_configuration(parameters, unit.limits.search_ranges);
    tools::check_disparity_range(chip.min_disparity, chip.num_disparities, width);
    return chip;
  }
  throw CommandError(kExitUsage, "--config chip: expected a target with a stereo unit, target '" + target.name + "' has none");
}

// The built-in scene: disparity.png, disparity_color.png, the views, the truth and the profile on a
// target, all into one folder.
int run_disparity_synthetic(const DisparityOptions& options) {
  if (!options.left_path.empty() || !options.right_path.empty() || !options.output_path.empty() || !options.report_path.empty() ||
      !options.color_path.empty() || !options.format.empty() || !options.right_output_path.empty() ||
      !options.calibration_files.empty() || options.rectify) {
    throw CommandError(kExitUsage, "--synthetic writes everything into --out-dir; it takes no LEFT RIGHT, -o, --format, "
                                   "--color, --report, --right-out, --calib or --rectify");
  }
  check_frame_size(options.size);
  if (!(options.fps > 0 && options.fps <= 10000)) {
    throw CommandError(kExitUsage, "--fps: expected a number in (0, 10000], got " + std::to_string(options.fps));
  }
  io::SyntheticSceneOptions scene_options;
  scene_options.width = options.size.width;
  scene_options.height = options.size.height;
  const io::SyntheticStereoScene scene = io::make_synthetic_stereo_scene(scene_options);
  // Default range: the scene's largest disparity, rounded up to a multiple of 16.
  const int scene_num_disparities = std::min(options.size.width, (scene.max_disparity_px + 1 + 15) / 16 * 16);
  const arm::DisparityParameters parameters =
      configured(options, tools::disparity_parameters(options, options.size.width, scene_num_disparities), options.size.width);
  const host_sim::Target target = host_sim::load_target(options.target_name.empty() ? "cv1-class" : options.target_name);
  tools::check_engine_memory(options, options.size.width, options.size.height, parameters, options.threads);
  arm::DisparityEngine engine(options.size.width, options.size.height, parameters, MemoryBudget{}, options.threads,
                              kernel_backend(options));
  const Plane& disparity = engine.compute(scene.left, scene.right);
  const std::map<std::string, const Plane*> inputs = {{"left", &scene.left}, {"right", &scene.right}};
  host_sim::ProfileOptions profile_options;
  profile_options.fps_target = options.fps;
  const host_sim::ProfileReport report =
      profile_engine_on_target(parameters, options.size.width, options.size.height, target, inputs, profile_options);

  std::error_code error;
  std::filesystem::create_directories(options.out_directory, error);
  if (error) throw CommandError(kExitInput, options.out_directory + ": cannot create the output directory: " + error.message());
  const std::filesystem::path out(options.out_directory);
  const int min_disparity_px = parameters.min_disparity;
  io::write_kitti_disparity_png((out / "disparity.png").string(), disparity, min_disparity_px);
  io::write_image((out / "disparity_color.png").string(),
                  io::colorize_disparity(disparity, min_disparity_px, min_disparity_px + parameters.num_disparities));
  io::write_image((out / "left.png").string(), io::plane_to_mat(scene.left));
  io::write_image((out / "right.png").string(), io::plane_to_mat(scene.right));
  io::write_kitti_disparity_png((out / "ground_truth.png").string(), scene.disparity_q4, 0);
  write_profile_outputs(report, {(out / "profile.json").string(), (out / "trace.json").string(), (out / "profile.md").string()});

  std::cout << "disparity " << options.size.width << "x" << options.size.height << ", disparities [" << min_disparity_px << ", "
            << min_disparity_px + parameters.num_disparities << ") (" << engine.graph().spec().name << ", native ISA "
            << simd::isa_name(simd::active_isa()) << ") -> " << (out / "disparity.png").string() << ", "
            << (out / "disparity_color.png").string() << "\n";
  // Against the scene's exact disparity: share of valid pixels within 1 px, and density.
  int64_t valid = 0, good = 0;
  const int64_t total = static_cast<int64_t>(options.size.width) * options.size.height;
  for (int y = 0; y < options.size.height; ++y) {
    for (int x = 0; x < options.size.width; ++x) {
      const int estimate = disparity.at<int16_t>(x, y);
      if (estimate == engine.invalid_disparity_q4()) continue;
      ++valid;
      good += std::abs(estimate - scene.disparity_q4.at<int16_t>(x, y)) <= 16 ? 1 : 0;
    }
  }
  std::printf("synthetic scene: %.1f %% of pixels valid, %.1f %% of valid pixels within 1 px of the truth\n",
              100.0 * static_cast<double>(valid) / static_cast<double>(total),
              valid ? 100.0 * static_cast<double>(good) / static_cast<double>(valid) : 0.0);
  std::cout << host_sim::report_table(report);
  std::cout << "profile: " << (out / "profile.json").string() << ", trace (open in ui.perfetto.dev): "
            << (out / "trace.json").string() << ", summary: " << (out / "profile.md").string() << "\n";
  return 0;
}

// LEFT RIGHT -o OUT: every check before any file is written; the files are staged and renamed into
// place together, so a failure leaves none of them.
int run_disparity_files(const DisparityOptions& options) {
  if (options.left_path.empty() || options.right_path.empty() || options.output_path.empty()) {
    throw CommandError(kExitUsage, "give LEFT RIGHT -o OUT, or --synthetic for the built-in scene");
  }
  if (options.target_name.empty() != options.report_path.empty()) {
    throw CommandError(kExitUsage, "--target and --report go together (the report is the profile on that target)");
  }
  if (options.rectify && options.calibration_files.empty()) {
    throw CommandError(kExitUsage, "--rectify needs --calib FILE (the calibration to rectify with)");
  }
  if (!options.color_path.empty() && lowercase(std::filesystem::path(options.color_path).extension().string()) != ".png") {
    throw CommandError(kExitUsage, "--color " + options.color_path + ": expected a .png file name");
  }
  const std::string format = output_format(options);
  {
    // One file per output: a second one under the same name would replace the first.
    std::map<std::string, std::string> outputs;
    for (const auto& [flag, file] : {std::pair<std::string, std::string>{"-o", options.output_path},
                                     {"--right-out", options.right_output_path},
                                     {"--color", options.color_path},
                                     {"--report", options.report_path}}) {
      if (file.empty()) continue;
      const std::string key = std::filesystem::absolute(file).lexically_normal().string();
      if (outputs.count(key)) throw CommandError(kExitUsage, flag + " " + file + ": the same file as " + outputs[key]);
      outputs[key] = flag;
    }
  }
  Plane left = io::read_luma_u8(options.left_path);
  Plane right = io::read_luma_u8(options.right_path);
  if (left.width() != right.width() || left.height() != right.height()) {
    throw CommandError(kExitInput, "image sizes differ: left " + options.left_path + " is " + std::to_string(left.width()) + "x" +
                                       std::to_string(left.height()) + ", right " + options.right_path + " is " +
                                       std::to_string(right.width()) + "x" + std::to_string(right.height()));
  }
  check_frame_size({left.width(), left.height()});
  if (!options.calibration_files.empty()) {
    // Checked against the images' size with or without --rectify (one line naming both sizes).
    tools::load_calibration_for(options.calibration_files, left.width(), left.height());
    if (options.rectify) {
      tools::RectifiedViews rectified = tools::rectify_views(left, right, options.calibration_files);
      left = rectified.left;
      right = rectified.right;
    }
  }
  const arm::DisparityParameters parameters = configured(
      options, tools::disparity_parameters(options, left.width(), arm::DisparityParameters{}.num_disparities), left.width());
  std::optional<host_sim::Target> target;
  if (!options.target_name.empty()) target = host_sim::load_target(options.target_name);
  tools::check_engine_memory(options, left.width(), left.height(), parameters, options.threads);
  arm::DisparityEngine engine(left.width(), left.height(), parameters, MemoryBudget{}, options.threads, kernel_backend(options));
  const int16_t invalid_q4 = engine.invalid_disparity_q4();
  Plane disparity = engine.compute(left, right).clone();
  const double produced_pct = density_pct(disparity, invalid_q4);
  Plane right_disparity;
  if (!options.right_output_path.empty()) right_disparity = engine.compute_right_view(left, right).clone();
  if (options.fill) {
    io::fill_invalid_kitti(disparity, invalid_q4);
    if (!right_disparity.empty()) io::fill_invalid_kitti(right_disparity, invalid_q4);
  }
  std::optional<host_sim::ProfileReport> report;
  if (target) {
    const std::map<std::string, const Plane*> inputs = {{"left", &left}, {"right", &right}};
    report = profile_engine_on_target(parameters, left.width(), left.height(), *target, inputs, host_sim::ProfileOptions{});
  }

  const int min_disparity_px = parameters.min_disparity;
  StagedOutputs staged;
  staged.write(options.output_path,
               [&](const std::string& file) { write_disparity_file(file, format, disparity, min_disparity_px); });
  if (!right_disparity.empty()) {
    staged.write(options.right_output_path,
                 [&](const std::string& file) { write_disparity_file(file, format, right_disparity, min_disparity_px); });
  }
  if (!options.color_path.empty()) {
    staged.write(options.color_path, [&](const std::string& file) {
      io::write_image(file, io::colorize_disparity(disparity, min_disparity_px, min_disparity_px + parameters.num_disparities));
    });
  }
  if (report) staged.write(options.report_path, [&](const std::string& file) { write_profile_outputs(*report, {file, "", ""}); });
  staged.commit();
  std::string how;
  if (options.rectify) how += ", rectified with " + options.calibration_files.front();
  if (parameters.multires) {
    const arm::MultiresSplit split =
        arm::multires_split(parameters.min_disparity, parameters.num_disparities, parameters.multires_far_disparities);
    how += ", multi-resolution: full resolution [" + std::to_string(split.min_far) + ", " +
           std::to_string(split.min_far + split.num_far) + ") px, half resolution [" + std::to_string(split.min_near) + ", " +
           std::to_string(split.min_near + split.num_near) + ") half px";
  }
  std::printf("disparity %dx%d, disparities [%d, %d)%s, %.1f %% of pixels produced%s -> %s (%s)%s%s\n", left.width(),
              left.height(), min_disparity_px, min_disparity_px + parameters.num_disparities, how.c_str(), produced_pct,
              options.fill ? ", the rest filled" : "", options.output_path.c_str(), format.c_str(),
              right_disparity.empty() ? "" : ", right view -> ", options.right_output_path.c_str());
  return 0;
}

int run_graph_verify(const std::string& graph_name, const std::string& target_name, FrameSize size) {
  check_frame_size(size);
  const host_sim::Target target = host_sim::load_target(target_name);
  const Graph graph = load_and_verify(graph_name, target, size);
  std::cout << "graph '" << graph.spec().name << "' verified for " << target.name << " at " << size.width << "x" << size.height
            << ": " << graph.nodes().size() << " nodes, SRAM peak " << graph.sram_peak_bytes() << " of "
            << target.memory.sram_bytes << " bytes, DRAM peak " << graph.dram_peak_bytes() << " of "
            << target.memory.dram_bytes << " bytes\n";
  for (int index : graph.order()) {
    const NodeInfo& node = graph.nodes()[index];
    if (node.is_vector()) {
      std::cout << "  " << node.spec.name << ": vector " << node.kernel->name << ", tiles " << node.tile_width << "x"
                << node.tile_height << ", SRAM " << node.sram_working_set_bytes << " bytes\n";
    } else {
      std::cout << "  " << node.spec.name << ": ARM " << node.task->name << "\n";
    }
  }
  return 0;
}

int run_graph_dot(const std::string& graph_name, const std::string& output_path) {
  const Graph graph(load_graph_spec(host_sim::find_data_file("graphs", graph_name)));
  const std::string dot = graph.to_dot();
  if (output_path.empty()) {
    std::cout << dot;
  } else {
    write_file_atomically(output_path, dot);
  }
  return 0;
}

int run_kernels() {
  std::cout << "vector kernels:\n";
  for (const std::string& name : KernelRegistry::instance().names()) {
    std::cout << "  " << name << ": " << KernelRegistry::instance().find(name)->summary << "\n";
  }
  std::cout << "ARM tasks:\n";
  for (const std::string& name : ArmTaskRegistry::instance().names()) {
    std::cout << "  " << name << ": " << ArmTaskRegistry::instance().find(name)->summary << "\n";
  }
  std::cout << "native ISA levels here:";
  for (simd::Isa isa : simd::available_isas()) std::cout << " " << simd::isa_name(isa);
  std::cout << " (active: " << simd::isa_name(simd::active_isa()) << ")\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // Every sub-command that runs frames (disparity over a sequence, obstacles3d, odometry, run, ...)
  // reuses what the last frame freed instead of faulting it in again: arm/heap_policy.h. Returns
  // false, changing nothing, under a sanitizer's allocator.
  lpstereo::arm::keep_freed_heap_memory();
  CLI::App app{"lpstereo: stereo perception for low-power vision SoCs, simulated on the host"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "lpstereo 0.1.0");

  // disparity
  DisparityOptions disparity_options;
  CLI::App* disparity = app.add_subcommand(
      "disparity",
      "left-view disparity of a rectified pair (LEFT RIGHT -o OUT; --calib C --rectify rectifies it first; --right-out "
      "adds the right view's), or of the built-in scene (--synthetic)");
  disparity->add_option("left", disparity_options.left_path, "left image (any format OpenCV reads; colour becomes BT.601 luma)");
  disparity->add_option("right", disparity_options.right_path, "right image, same size as the left");
  disparity->add_option("-o,--output", disparity_options.output_path, "disparity file to write");
  disparity->add_option("--format", disparity_options.format,
                        "kitti (16-bit PNG, x256, 0 = invalid; negative disparities are written invalid), pfm (float "
                        "px, +inf = invalid, rows bottom to top) or s16 (raw little-endian int16 x16, no header, "
                        "invalid = (min-disp - 1) * 16); default: from OUT's extension (.png .pfm .s16/.raw)")
      ->check(CLI::IsMember({"kitti", "pfm", "s16"}));
  tools::add_disparity_engine_options(
      *disparity, disparity_options,
      "disparities searched: [min-disp, min-disp + num-disp) (default 64; --synthetic: the scene's range)");
  tools::add_max_memory_option(*disparity, disparity_options);
  disparity->add_option("--calib", disparity_options.calibration_files,
                        "calibration: OpenCV YAML/XML, KITTI calib, Middlebury calib.txt (two files as A,B: OpenCV "
                        "intrinsics + extrinsics, ROS camera_info or Kalibr left + right). With --rectify both views are "
                        "rectified with it first; without, it is only checked against the image size (and that it "
                        "maps inside the images) and otherwise unused")
      ->delimiter(',');
  disparity->add_flag("--rectify", disparity_options.rectify,
                      "rectify both views with --calib before matching (the fixed-point remap of `lpstereo rectify`); "
                      "the maps are then in rectified coordinates");
  disparity->add_option("--right-out", disparity_options.right_output_path,
                        "also write the right-view disparity (same format as -o; right pixel x matches left pixel x + d): "
                        "the engine run a second time on the mirrored pair");
  disparity->add_option("--backend", disparity_options.backend, "native (this CPU's best ISA level) or counting (same bits, slower)")
      ->capture_default_str()
      ->check(CLI::IsMember({"native", "counting"}));
  disparity->add_flag("--fill", disparity_options.fill,
                      "fill invalid pixels as the KITTI development kit does (along the row, from the lower neighbour); "
                      "both maps with --right-out");
  disparity->add_option("--color", disparity_options.color_path, "also write a colour view (PNG)");
  disparity->add_option("--threads", disparity_options.threads, "worker threads (0 = one per hardware thread)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  disparity->add_option("--target", disparity_options.target_name,
                        "target to profile the engine's graph on (targets/NAME.json or file; with --report; "
                        "--synthetic: default cv1-class)");
  disparity->add_option("--report", disparity_options.report_path, "profile report JSON (with --target)");
  disparity->add_option("--config", disparity_options.config,
                        "host: the engine's accurate defaults; chip: what the target's stereo unit runs (4-path SGM, "
                        "LR check 1 px, no speckle filter, the smallest search range the unit offers that covers "
                        "--num-disp; the target: --target, else cv1-class), the configuration the profile then costs "
                        "on the unit")
      ->capture_default_str()
      ->check(CLI::IsMember({"host", "chip"}));
  disparity->add_flag("--synthetic", disparity_options.synthetic,
                      "the built-in scene: disparity.png, disparity_color.png, left/right/ground_truth.png and "
                      "profile.json/trace.json/profile.md into --out-dir");
  disparity->add_option("--out-dir", disparity_options.out_directory, "--synthetic: output folder")->capture_default_str();
  disparity->add_option("--width", disparity_options.size.width, "--synthetic: scene width in pixels")->capture_default_str();
  disparity->add_option("--height", disparity_options.size.height, "--synthetic: scene height in pixels")->capture_default_str();
  disparity->add_option("--fps", disparity_options.fps, "--synthetic: frame rate the profile is judged against")
      ->capture_default_str();

  // eval
  tools::EvalOptions eval_options;
  CLI::App* eval = app.add_subcommand("eval", "accuracy: disparity on the real pairs of the shared data folder (bad-N, D1, "
                                              "EPE, density), or a trajectory against its ground truth (KITTI odometry metric)");
  eval->add_option("benchmark", eval_options.benchmark,
                   "middlebury (8 pairs), kitti (2015, 000046) or odometry (TRAJ.txt POSES.txt: KITTI odometry metric)")
      ->required()
      ->check(CLI::IsMember({"middlebury", "kitti", "odometry"}));
  eval->add_option("files", eval_options.files, "odometry: the estimated trajectory and the ground truth (KITTI pose files)");
  eval->add_option("--data", eval_options.data_directory,
                   "shared data folder (default: $LPSTEREO_SHARED_DATA, else ../shared/data)");
  eval->add_option("--baseline", eval_options.baseline, "opencv: StereoSGBM in MODE_SGBM, MODE_SGBM_3WAY and MODE_HH too")
      ->check(CLI::IsMember({"opencv"}));
  eval->add_option("--json", eval_options.json_path, "write every number to this JSON file");
  eval->add_option("--num-disp", eval_options.num_disparities, "override every pair's number of disparities");
  eval->add_option("--min-disp", eval_options.min_disparity_px, "override every pair's smallest disparity, px");
  eval->add_option("--threads", eval_options.threads, "engine worker threads (0 = one per hardware thread)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  tools::add_multires_options(*eval, eval_options.multires);
  eval->add_option("--chip", eval_options.chip_target,
                   "also the chip configuration of this target's stereo unit (arm::chip_configuration: 4-path SGM, "
                   "LR 1 px, no speckle filter, the unit's search range), as 'lpstereo chip'");
  eval->add_option("--lengths", eval_options.segment_lengths_m,
                   "odometry: segment lengths in metres, comma-separated (default: the lengths the path allows, "
                   "KITTI's 100,...,800 beyond 800 m)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  eval->add_option("--step", eval_options.step_frames, "odometry: segments start every N frames (default 1; KITTI's devkit: 10)")
      ->check(CLI::PositiveNumber);
  eval->add_option("--plot", eval_options.plot_path, "odometry: top view of the estimate against the ground truth (PNG)");

  // profile
  std::string profile_graph, profile_target = "cv1-class";
  FrameSize profile_size{3840, 1728};
  double profile_fps = 30;
  host_sim::ProfileOptions profile_options;
  bool enforce = false;
  ProfileOutputs outputs;
  CLI::App* profile = app.add_subcommand("profile", "simulate a graph on a target at a frame size");
  profile->add_option("--graph", profile_graph, "graph name (graphs/NAME.json) or file")->required();
  profile->add_option("--target", profile_target, "target name (targets/NAME.json) or file")->capture_default_str();
  profile->add_option("--width", profile_size.width, "frame width in pixels")->capture_default_str();
  profile->add_option("--height", profile_size.height, "frame height in pixels")->capture_default_str();
  profile->add_option("--fps", profile_fps, "frame rate budget")->capture_default_str();
  profile->add_option("--frames", profile_options.frames,
                      "frames simulated (>= 3; at least 4 x frames in flight + 4 are simulated whatever this says)")
      ->capture_default_str()
      ->check(CLI::Range(3, 100));
  profile->add_option("--frames-in-flight", profile_options.frames_in_flight,
                      "frames the pipeline holds at once (default: the target's pipeline setting)")
      ->check(CLI::Range(1, 16));
  profile->add_option("--max-latency-ms", profile_options.max_latency_ms,
                      "latency budget, first start to last end of a frame (over it: over budget)")
      ->check(CLI::PositiveNumber);
  profile->add_option("--report", outputs.report_path, "report JSON file");
  profile->add_option("--trace", outputs.trace_path, "Chrome-trace JSON file (opens in Perfetto)");
  profile->add_option("--summary-md", outputs.summary_path, "Markdown summary file");
  profile->add_flag("--enforce", enforce, "exit 3 when the frame time, latency, DRAM bandwidth or DRAM capacity is over budget");
  profile->add_flag("--count-every-tile", profile_options.count_every_tile, "count ops on every tile, not once per tile shape");

  // graph verify | dot
  CLI::App* graph = app.add_subcommand("graph", "check or draw a graph");
  graph->require_subcommand(1);
  std::string verify_graph, verify_target = "cv1-class", dot_graph, dot_output;
  FrameSize verify_size{3840, 1728};
  CLI::App* verify = graph->add_subcommand("verify", "run verify() against a target's memory");
  verify->add_option("graph", verify_graph, "graph name or file")->required();
  verify->add_option("--target", verify_target, "target name or file")->capture_default_str();
  verify->add_option("--width", verify_size.width, "frame width")->capture_default_str();
  verify->add_option("--height", verify_size.height, "frame height")->capture_default_str();
  CLI::App* dot = graph->add_subcommand("dot", "print the graph in Graphviz DOT");
  dot->add_option("graph", dot_graph, "graph name or file")->required();
  dot->add_option("--output", dot_output, "write to this file instead of stdout");

  CLI::App* kernels = app.add_subcommand("kernels", "list the kernels, ARM tasks and ISA levels");

  // rectify, check-rectification, calibrate
  tools::GeometryCommands geometry(app);
  tools::PointsCommand points(app);  // points (tools/points_command.h)
  tools::ObstaclesCommand obstacles(app);  // obstacles (tools/obstacles_command.h)
  tools::TerrainCommand terrain(app);      // terrain (tools/terrain_command.h)
  tools::OdometryCommand odometry(app);    // odometry (tools/odometry_command.h)
  tools::LocalizeCommand localize(app);    // localize (tools/localize_command.h)
  tools::Obstacles3dCommand obstacles3d(app);  // obstacles3d (tools/obstacles3d_command.h)
  tools::SynthCommand synth(app);    // synth (tools/synth_command.h)
  tools::RunCommand run(app);        // run (tools/run_command.h)

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    // --help and --version exit 0; every usage error prints one line and exits 2 (the README's code).
    if (error.get_exit_code() == 0) return app.exit(error);
    std::cerr << "lpstereo: " << error.what() << " (run with --help for the options)\n";
    return 2;
  }
  try {
    if (*disparity) {
      for (const std::string& flag : kMatcherFlags) {
        if (disparity->count(flag) > 0) disparity_options.matcher_flags_given.push_back(flag);
      }
      return disparity_options.synthetic ? run_disparity_synthetic(disparity_options) : run_disparity_files(disparity_options);
    }
    if (*eval) return tools::run_eval(eval_options);
    if (*profile) {
      return run_profile(profile_graph, profile_target, profile_size, profile_fps, profile_options, enforce, outputs);
    }
    if (*verify) return run_graph_verify(verify_graph, verify_target, verify_size);
    if (*dot) return run_graph_dot(dot_graph, dot_output);
    if (*kernels) return run_kernels();
    if (geometry.selected()) return geometry.run();
    if (points.selected()) return points.run();
    if (obstacles.selected()) return obstacles.run();
    if (terrain.selected()) return terrain.run();
    if (odometry.selected()) return odometry.run();
    if (localize.selected()) return localize.run();
    if (obstacles3d.selected()) return obstacles3d.run();
    if (synth.selected()) return synth.run();
    if (run.selected()) return run.run();
  } catch (const CommandError& error) {
    std::cerr << "lpstereo: " << error.what() << "\n";
    return error.exit_code;
  } catch (const VerifyError& error) {
    std::cerr << "lpstereo: " << error.what() << "\n";
    return kExitInput;
  } catch (const std::exception& error) {
    std::cerr << "lpstereo: " << error.what() << "\n";
    return kExitInput;
  }
  return 2;
}
