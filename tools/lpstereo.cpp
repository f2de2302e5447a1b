// lpstereo: the command line. Sub-commands:
//   disparity   the main job: a stereo pair (files or the built-in synthetic scene) -> disparity
//               (KITTI PNG), colour view, and the simulated cost of the graph on a target
//   profile     the cost of a graph on a target at a frame size: report JSON, Perfetto trace,
//               Markdown summary; --enforce exits 3 when over the time or bandwidth budget
//   graph       verify | dot
//   kernels     the kernels and ARM tasks this binary has
//
// Exit codes: 0 done; 1 bad input or a graph that fails verify (one line on stderr); 2 bad usage;
// 3 over budget with --enforce.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>

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

namespace {

using namespace lpstereo;

constexpr int kExitInput = 1;
constexpr int kExitOverBudget = 3;

// An error that ends the command with one line and an exit code.
struct CommandError : std::runtime_error {
  CommandError(int code, const std::string& message) : std::runtime_error(message), exit_code(code) {}
  int exit_code;
};

struct FrameSize {
  int width = 0;
  int height = 0;
};

void check_frame_size(const FrameSize& size) {
  if (size.width < 16 || size.height < 16 || size.width > 16384 || size.height > 16384) {
    throw CommandError(2, "frame size: expected 16..16384 x 16..16384, got " + std::to_string(size.width) + "x" +
                              std::to_string(size.height));
  }
}

Graph load_and_verify(const std::string& graph_name, const host_sim::Target& target, const FrameSize& size) {
  Graph graph(load_graph_spec(host_sim::find_data_file("graphs", graph_name)));
  VerifyOptions options;
  options.frame_width = size.width;
  options.frame_height = size.height;
  options.memory = target.memory_budget();
  graph.verify(options);
  return graph;
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
    if (input.format.type != ElementType::u8) {
      throw CommandError(kExitInput, "graph input '" + input.name + "' is " + format_name(input.format) +
                                         "; synthetic frames exist for u8 inputs only");
    }
    inputs[input.name] = (index++ % 2 == 0) ? scene.left : scene.right;
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

int run_profile(const std::string& graph_name, const std::string& target_name, FrameSize size, double fps, int frames,
                bool count_every_tile, bool enforce, const ProfileOutputs& outputs) {
  check_frame_size(size);
  if (!(fps > 0 && fps <= 10000)) throw CommandError(2, "--fps: expected a number in (0, 10000], got " + std::to_string(fps));
  const host_sim::Target target = host_sim::load_target(target_name);
  const Graph graph = load_and_verify(graph_name, target, size);
  const std::map<std::string, Plane> inputs = synthetic_inputs(graph, size);
  host_sim::ProfileOptions options;
  options.fps_target = fps;
  options.frames = frames;
  options.count_every_tile = count_every_tile;
  const host_sim::ProfileReport report = host_sim::profile_graph(graph, target, pointers(inputs), options);
  std::cout << host_sim::report_table(report);
  write_profile_outputs(report, outputs);
  if (enforce && !report.fits_budget) {
    if (!report.enforce_budget) {
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

int run_disparity(const std::string& left_path, const std::string& right_path, FrameSize size, const std::string& graph_name,
                  const std::string& target_name, const std::string& out_directory, double fps) {
  const bool synthetic = left_path.empty() && right_path.empty();
  if (left_path.empty() != right_path.empty()) throw CommandError(2, "give both --left and --right, or neither (synthetic scene)");
  std::map<std::string, Plane> inputs;
  std::optional<io::SyntheticStereoScene> scene;
  if (synthetic) {
    check_frame_size(size);
    io::SyntheticSceneOptions options;
    options.width = size.width;
    options.height = size.height;
    scene = io::make_synthetic_stereo_scene(options);
    inputs["left"] = scene->left;
    inputs["right"] = scene->right;
  } else {
    inputs["left"] = io::read_luma_u8(left_path);
    inputs["right"] = io::read_luma_u8(right_path);
    const Plane& left = inputs["left"];
    const Plane& right = inputs["right"];
    if (left.width() != right.width() || left.height() != right.height()) {
      throw CommandError(kExitInput, "image sizes differ: left " + left_path + " is " + std::to_string(left.width()) + "x" +
                                         std::to_string(left.height()) + ", right " + right_path + " is " +
                                         std::to_string(right.width()) + "x" + std::to_string(right.height()));
    }
    size = {left.width(), left.height()};
    check_frame_size(size);
  }
  const host_sim::Target target = host_sim::load_target(target_name);
  const Graph graph = load_and_verify(graph_name, target, size);
  if (graph.buffer_index("disparity") < 0 || graph.buffers()[graph.buffer_index("disparity")].format != BufferFormat{ElementType::s16, 4}) {
    throw CommandError(kExitInput, "graph '" + graph.spec().name + "' has no s16q4 buffer named 'disparity'");
  }
  std::error_code error;
  std::filesystem::create_directories(out_directory, error);
  if (error) throw CommandError(kExitInput, out_directory + ": cannot create the output directory: " + error.message());

  arm::FrameRunner runner(graph);
  runner.process(pointers(inputs));
  const Plane& disparity = runner.buffer("disparity");
  int num_disparities = 64;
  for (const NodeInfo& node : graph.nodes()) {
    if (node.spec.params.is_object() && node.spec.params.contains("num_disparities")) {
      num_disparities = node.spec.params.at("num_disparities").get<int>();
    }
  }
  const std::filesystem::path out(out_directory);
  io::write_kitti_disparity_png((out / "disparity.png").string(), disparity, 0);
  io::write_image((out / "disparity_color.png").string(), io::colorize_disparity(disparity, 0, num_disparities));
  if (synthetic) {
    io::write_image((out / "left.png").string(), io::plane_to_mat(scene->left));
    io::write_image((out / "right.png").string(), io::plane_to_mat(scene->right));
    io::write_kitti_disparity_png((out / "ground_truth.png").string(), scene->disparity_q4, 0);
  }
  host_sim::ProfileOptions options;
  options.fps_target = fps;
  const host_sim::ProfileReport report = host_sim::profile_graph(graph, target, pointers(inputs), options);
  write_profile_outputs(report, {(out / "profile.json").string(), (out / "trace.json").string(), (out / "profile.md").string()});

  std::cout << "disparity " << size.width << "x" << size.height << " (" << graph.spec().name << ", native ISA "
            << simd::isa_name(simd::active_isa()) << ") -> " << (out / "disparity.png").string() << ", "
            << (out / "disparity_color.png").string() << "\n";
  if (synthetic) {
    // Against the scene's exact disparity: share of valid pixels within 1 px, and density.
    int64_t valid = 0, good = 0;
    const int64_t total = static_cast<int64_t>(size.width) * size.height;
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        const int estimate = disparity.at<int16_t>(x, y);
        if (estimate == io::invalid_disparity_q4(0)) continue;
        ++valid;
        good += std::abs(estimate - scene->disparity_q4.at<int16_t>(x, y)) <= 16 ? 1 : 0;
      }
    }
    std::printf("synthetic scene: %.1f %% of pixels valid, %.1f %% of valid pixels within 1 px of the truth\n",
                100.0 * static_cast<double>(valid) / static_cast<double>(total),
                valid ? 100.0 * static_cast<double>(good) / static_cast<double>(valid) : 0.0);
  }
  std::cout << host_sim::report_table(report);
  std::cout << "profile: " << (out / "profile.json").string() << ", trace (open in ui.perfetto.dev): "
            << (out / "trace.json").string() << ", summary: " << (out / "profile.md").string() << "\n";
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
  CLI::App app{"lpstereo: stereo perception for low-power vision SoCs, simulated on the host"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "lpstereo 0.1.0");

  // disparity
  std::string left_path, right_path, out_directory = "out", graph_name = "stereo-census-wta", target_name = "cv1-class";
  FrameSize size{640, 480};
  double fps = 30;
  CLI::App* disparity = app.add_subcommand("disparity", "disparity of a stereo pair (or the built-in synthetic scene) and its cost on a target");
  disparity->add_option("--left", left_path, "left image (any format OpenCV reads; colour becomes BT.601 luma)");
  disparity->add_option("--right", right_path, "right image, same size as the left");
  disparity->add_option("--width", size.width, "synthetic scene width in pixels")->capture_default_str();
  disparity->add_option("--height", size.height, "synthetic scene height in pixels")->capture_default_str();
  disparity->add_option("--graph", graph_name, "graph name (graphs/NAME.json) or file")->capture_default_str();
  disparity->add_option("--target", target_name, "target name (targets/NAME.json) or file")->capture_default_str();
  disparity->add_option("--out", out_directory, "output directory")->capture_default_str();
  disparity->add_option("--fps", fps, "frame rate the profile is judged against")->capture_default_str();

  // profile
  std::string profile_graph, profile_target = "cv1-class";
  FrameSize profile_size{3840, 1728};
  double profile_fps = 30;
  int frames = 4;
  bool enforce = false, count_every_tile = false;
  ProfileOutputs outputs;
  CLI::App* profile = app.add_subcommand("profile", "simulate a graph on a target at a frame size");
  profile->add_option("--graph", profile_graph, "graph name (graphs/NAME.json) or file")->required();
  profile->add_option("--target", profile_target, "target name (targets/NAME.json) or file")->capture_default_str();
  profile->add_option("--width", profile_size.width, "frame width in pixels")->capture_default_str();
  profile->add_option("--height", profile_size.height, "frame height in pixels")->capture_default_str();
  profile->add_option("--fps", profile_fps, "frame rate budget")->capture_default_str();
  profile->add_option("--frames", frames, "frames simulated back to back (>= 3)")->capture_default_str()->check(CLI::Range(3, 100));
  profile->add_option("--report", outputs.report_path, "report JSON file");
  profile->add_option("--trace", outputs.trace_path, "Chrome-trace JSON file (opens in Perfetto)");
  profile->add_option("--summary-md", outputs.summary_path, "Markdown summary file");
  profile->add_flag("--enforce", enforce, "exit 3 when the frame time or DRAM bandwidth is over budget");
  profile->add_flag("--count-every-tile", count_every_tile, "count ops on every tile, not once per tile shape");

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

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error);
  }
  try {
    if (*disparity) return run_disparity(left_path, right_path, size, graph_name, target_name, out_directory, fps);
    if (*profile) {
      return run_profile(profile_graph, profile_target, profile_size, profile_fps, frames, count_every_tile, enforce, outputs);
    }
    if (*verify) return run_graph_verify(verify_graph, verify_target, verify_size);
    if (*dot) return run_graph_dot(dot_graph, dot_output);
    if (*kernels) return run_kernels();
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
