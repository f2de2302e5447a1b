#include "arm/disparity_engine.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "arm/scheduler.h"

namespace lpstereo::arm {

namespace {
// A matcher node reading both views' census signatures.
NodeSpec census_pair_node(const std::string& name, const std::string& kernel, const nlohmann::json& params,
                          const std::string& left_census, const std::string& right_census) {
  NodeSpec node;
  node.name = name;
  node.kernel = kernel;
  node.inputs["left"] = {left_census, false};
  node.inputs["right"] = {right_census, false};
  node.params = params;
  return node;
}

NodeSpec unary_node(const std::string& name, const std::string& kernel, const std::string& input, const std::string& output) {
  NodeSpec node;
  node.name = name;
  node.kernel = kernel;
  node.inputs["input"] = {input, false};
  node.outputs["output"] = output;
  return node;
}

void check_range(const char* name, int value, int min_value, int max_value) {
  if (value < min_value || value > max_value) {
    throw std::invalid_argument(std::string("disparity parameter '") + name + "': expected [" + std::to_string(min_value) +
                                ", " + std::to_string(max_value) + "], got " + std::to_string(value));
  }
}

// The search range against the image width (the kernels check the rest when the graph is verified).
void check_range_fits(int width, const DisparityParameters& parameters) {
  check_range("num_disparities", parameters.num_disparities, 1, width);
  check_range("min_disparity", parameters.min_disparity, -width + 1, width - 1);
  if (parameters.min_disparity + parameters.num_disparities > width) {
    throw std::invalid_argument("disparity parameters: min_disparity + num_disparities = " +
                                std::to_string(parameters.min_disparity + parameters.num_disparities) +
                                " exceeds the image width " + std::to_string(width));
  }
}

int floor_half(int value) { return value >= 0 ? value / 2 : -((1 - value) / 2); }
int ceil_half(int value) { return -floor_half(-value); }

// The matching nodes for one pass: census of both views (named with `suffix`) already in
// left_census / right_census; the pass's disparity map (s16 Q4) into `output`.
void add_matcher(GraphSpec& spec, const DisparityParameters& parameters, EightPathLayout layout, int min_disparity,
                 int num_disparities, const std::string& suffix, const std::string& output) {
  const std::string left_census = "left_census" + suffix;
  const std::string right_census = "right_census" + suffix;
  const bool census64 = parameters.census_width == 9;
  if (parameters.paths == 0) {
    NodeSpec match = census_pair_node("match" + suffix, "census_wta_disparity",
                                      {{"min_disparity", min_disparity},
                                       {"num_disparities", num_disparities},
                                       {"max_cost_bits", parameters.max_cost_bits}},
                                      left_census, right_census);
    match.outputs["disparity"] = output;
    spec.nodes.push_back(match);
    return;
  }
  const std::string kernel_suffix = census64 ? "_census64" : "";
  const nlohmann::json penalties = {
      {"min_disparity", min_disparity},
      {"num_disparities", num_disparities},
      {"p1", parameters.p1 >= 0 ? parameters.p1 : (census64 ? 7 : 5)},
      {"p2", parameters.p2 >= 0 ? parameters.p2 : (census64 ? 50 : 45)}};
  nlohmann::json selection = penalties;
  selection["uniqueness_percent"] = parameters.uniqueness_percent;
  selection["subpixel"] = parameters.subpixel ? 1 : 0;
  selection["lr_max_diff"] = parameters.lr_max_diff;
  if (parameters.paths == 4) {
    NodeSpec sgm = census_pair_node("sgm" + suffix, "sgm_4path" + kernel_suffix, selection, left_census, right_census);
    sgm.outputs["disparity"] = output;
    spec.nodes.push_back(sgm);
    return;
  }
  if (layout == EightPathLayout::forward_backward) {
    NodeSpec forward =
        census_pair_node("sgm_forward" + suffix, "sgm_8path_forward" + kernel_suffix, penalties, left_census, right_census);
    forward.outputs["sums"] = "forward_sums" + suffix;
    NodeSpec backward =
        census_pair_node("sgm_backward" + suffix, "sgm_8path_backward" + kernel_suffix, selection, left_census, right_census);
    backward.inputs["forward"] = {"forward_sums" + suffix, false};
    backward.outputs["disparity"] = output;
    spec.nodes.push_back(forward);
    spec.nodes.push_back(backward);
    return;
  }
  // 8 paths by bands (kernels/sgm_8path_bands.cpp): the two checkpoint passes side by side, then the
  // bands, in parallel; no W x H x D volume.
  NodeSpec forward = census_pair_node("sgm_forward_checkpoints" + suffix, "sgm_8path_forward_checkpoints" + kernel_suffix,
                                      penalties, left_census, right_census);
  forward.outputs["checkpoints"] = "forward_checkpoints" + suffix;
  NodeSpec backward = census_pair_node("sgm_backward_checkpoints" + suffix, "sgm_8path_backward_checkpoints" + kernel_suffix,
                                       penalties, left_census, right_census);
  backward.outputs["checkpoints"] = "backward_checkpoints" + suffix;
  NodeSpec bands = census_pair_node("sgm_bands" + suffix, "sgm_8path_bands" + kernel_suffix, selection, left_census, right_census);
  bands.inputs["forward_checkpoints"] = {forward.outputs["checkpoints"], false};
  bands.inputs["backward_checkpoints"] = {backward.outputs["checkpoints"], false};
  bands.outputs["disparity"] = output;
  spec.nodes.push_back(forward);
  spec.nodes.push_back(backward);
  spec.nodes.push_back(bands);
}

// The SGM map's post-processing, OpenCV StereoSGBM's: the 3x3 median that keeps invalid pixels
// invalid, then the speckle filter; from `input` into "disparity". Called only when one of the two is
// on (otherwise the matcher writes "disparity" itself).
void add_post_processing(GraphSpec& spec, const DisparityParameters& parameters, const std::string& input) {
  const bool speckle = parameters.speckle_max_size_px > 0;
  const int invalid_q4 = (parameters.min_disparity - 1) * 16;
  std::string last = input;
  if (parameters.median) {
    NodeSpec median = unary_node("median", "median3x3_s16", last, speckle ? "median_disparity" : "disparity");
    median.params = {{"invalid_q4", invalid_q4}};
    last = median.outputs["output"];
    spec.nodes.push_back(median);
    spec.description += ", 3x3 median";
  }
  if (speckle) {
    NodeSpec filter;
    filter.name = "speckle";
    filter.task = "speckle_filter";
    filter.inputs["disparity"] = {last, false};
    filter.outputs["filtered"] = "disparity";
    filter.params = {{"max_speckle_size", parameters.speckle_max_size_px},
                     {"max_difference_q4", parameters.speckle_max_difference_px * 16},
                     {"invalid_q4", invalid_q4}};
    spec.nodes.push_back(filter);
    spec.description += ", speckle filter";
  }
}

// Census of both views: `left` and `right` into left_census<suffix> and right_census<suffix>.
void add_census(GraphSpec& spec, const DisparityParameters& parameters, const std::string& left, const std::string& right,
                const std::string& suffix) {
  const std::string kernel = parameters.census_width == 9 ? "census9x7" : "census5x5";
  spec.nodes.push_back(unary_node("census_left" + suffix, kernel, left, "left_census" + suffix));
  spec.nodes.push_back(unary_node("census_right" + suffix, kernel, right, "right_census" + suffix));
}

// Makes `plane` a buffer of `like`'s size and format (kept when it already is one).
void fit_plane(Plane& plane, const Plane& like) {
  if (plane.empty() || plane.width() != like.width() || plane.height() != like.height() || !(plane.format() == like.format())) {
    plane = Plane(like.width(), like.height(), like.format());
  }
}

// Writes `source` mirrored left to right into `destination` (same size and format).
void mirror_rows(const Plane& source, Plane& destination) {
  const int width = source.width();
  const int bytes = source.element_size();
  for (int y = 0; y < source.height(); ++y) {
    const uint8_t* in = source.row<const uint8_t>(y);
    uint8_t* out = destination.row<uint8_t>(y);
    for (int x = 0; x < width; ++x) std::memcpy(out + (width - 1 - x) * bytes, in + x * bytes, static_cast<size_t>(bytes));
  }
}
}  // namespace

DisparityParameters chip_configuration(const DisparityParameters& requested, const std::vector<int>& offered_search_ranges) {
  if (offered_search_ranges.empty()) throw std::invalid_argument("chip_configuration: the unit offers no search range");
  DisparityParameters chip;  // the defaults: census 5x5, penalties, uniqueness, sub-pixel, median
  chip.min_disparity = requested.min_disparity;
  chip.paths = 4;
  chip.lr_max_diff = 1;
  chip.speckle_max_size_px = 0;
  std::vector<int> ranges = offered_search_ranges;
  std::sort(ranges.begin(), ranges.end());
  const auto covering = std::lower_bound(ranges.begin(), ranges.end(), requested.num_disparities);
  chip.num_disparities = covering == ranges.end() ? ranges.back() : *covering;
  return chip;
}

std::string settings_text(const DisparityParameters& parameters) {
  const std::string census = parameters.census_width == 9 ? "census 9x7" : "census 5x5";
  if (parameters.paths == 0) {
    return census + ", winner-takes-all (no aggregation), max cost " + std::to_string(parameters.max_cost_bits) + " bits";
  }
  const bool census64 = parameters.census_width == 9;
  std::string text = std::to_string(parameters.paths) + "-path SGM, " + census;
  text += ", P1 " + std::to_string(parameters.p1 >= 0 ? parameters.p1 : (census64 ? 7 : 5));
  text += ", P2 " + std::to_string(parameters.p2 >= 0 ? parameters.p2 : (census64 ? 50 : 45));
  text += ", uniqueness " + std::to_string(parameters.uniqueness_percent) + " %";
  text += parameters.subpixel ? ", sub-pixel on" : ", sub-pixel off";
  text += parameters.lr_max_diff >= 0 ? ", LR check " + std::to_string(parameters.lr_max_diff) + " px" : ", LR check off";
  if (parameters.median) text += ", 3x3 median";
  if (parameters.speckle_max_size_px > 0) {
    text += ", speckles <= " + std::to_string(parameters.speckle_max_size_px) + " px within " +
            std::to_string(parameters.speckle_max_difference_px) + " px removed";
  }
  if (parameters.multires) {
    const MultiresSplit split =
        multires_split(parameters.min_disparity, parameters.num_disparities, parameters.multires_far_disparities);
    text += ", multi-resolution (full resolution " + std::to_string(split.num_far) + " px, half resolution " +
            std::to_string(split.num_near) + " half px)";
  }
  return text;
}

MultiresSplit multires_split(int min_disparity, int num_disparities, int far_cap) {
  MultiresSplit split;
  split.min_far = min_disparity;
  split.num_far = std::min(num_disparities, far_cap);
  split.margin_px = std::min(2, split.num_far - 1);
  const int top = split.min_far + split.num_far - 1 - split.margin_px;
  split.min_near = floor_half(min_disparity);
  // The near pass must reach beyond the trusted far range (disparity_fuse_multires refuses
  // otherwise); only a 1-disparity range needs the extra half pixel.
  const int max_near = std::max(ceil_half(min_disparity + num_disparities - 1), floor_half(top) + 1);
  split.num_near = max_near - split.min_near + 1;
  return split;
}

GraphSpec DisparityEngine::graph_spec(const DisparityParameters& parameters, EightPathLayout layout) {
  if (parameters.census_width != 5 && parameters.census_width != 9) {
    throw std::invalid_argument("disparity parameter 'census_width': expected 5 or 9, got " +
                                std::to_string(parameters.census_width));
  }
  if (parameters.paths != 0 && parameters.paths != 4 && parameters.paths != 8) {
    throw std::invalid_argument("disparity parameter 'paths': expected 0, 4 or 8, got " + std::to_string(parameters.paths));
  }
  // the winner-takes-all baseline exists for census 5x5 only
  if (parameters.paths == 0) check_range("census_width", parameters.census_width, 5, 5);
  const std::string census_name = parameters.census_width == 9 ? "9x7" : "5x5";
  const std::string matcher = parameters.paths == 0
                                  ? std::string("winner-takes-all on Hamming costs")
                                  : "semi-global matching over " + std::to_string(parameters.paths) +
                                        " paths, winner takes all with uniqueness, sub-pixel and LR check";
  GraphSpec spec;
  spec.name = "disparity-engine";
  spec.inputs = {{"left", {ElementType::u8, 0}}, {"right", {ElementType::u8, 0}}};
  spec.outputs = {"disparity"};
  check_range("speckle_max_size_px", parameters.speckle_max_size_px, 0, 1 << 30);
  check_range("speckle_max_difference_px", parameters.speckle_max_difference_px, 0, 4095);
  // The SGM map's post-processing (never after the winner-takes-all baseline).
  const bool post_processing = parameters.paths != 0 && (parameters.median || parameters.speckle_max_size_px > 0);
  add_census(spec, parameters, "left", "right", "");
  if (!parameters.multires) {
    spec.description = "census " + census_name + " of both views, " + matcher;
    add_matcher(spec, parameters, layout, parameters.min_disparity, parameters.num_disparities, "",
                post_processing ? "sgm_disparity" : "disparity");
    if (post_processing) add_post_processing(spec, parameters, "sgm_disparity");
    return spec;
  }
  check_range("multires_far_disparities", parameters.multires_far_disparities, 1, 512);
  const MultiresSplit split =
      multires_split(parameters.min_disparity, parameters.num_disparities, parameters.multires_far_disparities);
  spec.name = "disparity-engine-multires";
  spec.description = "multi-resolution: census " + census_name + " and " + matcher + " at full resolution over [" +
                     std::to_string(split.min_far) + ", " + std::to_string(split.min_far + split.num_far) +
                     ") px and at half resolution over [" + std::to_string(split.min_near) + ", " +
                     std::to_string(split.min_near + split.num_near) + ") half px, fused (disparity_fuse_multires)";
  add_matcher(spec, parameters, layout, split.min_far, split.num_far, "", "disparity_far");
  spec.nodes.push_back(unary_node("downsample_left", "downsample2x", "left", "left_half"));
  spec.nodes.push_back(unary_node("downsample_right", "downsample2x", "right", "right_half"));
  add_census(spec, parameters, "left_half", "right_half", "_half");
  add_matcher(spec, parameters, layout, split.min_near, split.num_near, "_half", "disparity_near_half");
  NodeSpec fuse;
  fuse.name = "fuse";
  fuse.kernel = "disparity_fuse_multires";
  fuse.inputs["full"] = {"disparity_far", false};
  fuse.inputs["half"] = {"disparity_near_half", false};
  fuse.outputs["fused"] = post_processing ? "disparity_fused" : "disparity";
  fuse.params = {{"min_far", split.min_far},
                 {"num_far", split.num_far},
                 {"min_near", split.min_near},
                 {"num_near", split.num_near},
                 {"margin_px", split.margin_px}};
  spec.nodes.push_back(fuse);
  if (post_processing) add_post_processing(spec, parameters, "disparity_fused");
  return spec;
}

DisparityEngine::DisparityEngine(int width, int height, const DisparityParameters& parameters, const MemoryBudget& memory,
                                 int worker_threads, KernelBackend backend)
    : parameters_(parameters) {
  check_range_fits(width, parameters);
  const int workers = resolved_worker_threads(worker_threads);
  GraphSpec spec = graph_spec(parameters);
  // The speckle filter in bands on the workers: it is the graph's last node, so the other workers
  // would wait for it (the same bits and counted work, arm/tasks/speckle_filter.cpp).
  for (NodeSpec& node : spec.nodes) {
    if (node.task == "speckle_filter") node.params["threads"] = workers;
  }
  graph_ = make_verified_graph(spec, width, height, memory);
  runner_ = std::make_unique<FrameRunner>(*graph_, workers, backend);
}

size_t DisparityEngine::working_set_bytes(int width, int height, const DisparityParameters& parameters, int worker_threads) {
  check_range_fits(width, parameters);
  const auto graph = make_verified_graph(graph_spec(parameters), width, height, MemoryBudget{});
  const size_t speckle_marks =
      parameters.paths != 0 && parameters.speckle_max_size_px > 0 ? static_cast<size_t>(width) * static_cast<size_t>(height) : 0;
  return FrameRunner::planned_bytes(*graph, worker_threads) + speckle_marks;
}

DisparityEngine::~DisparityEngine() = default;

const Plane& DisparityEngine::compute(const Plane& left, const Plane& right) {
  runner_->process({{"left", &left}, {"right", &right}});
  return runner_->buffer("disparity");
}

const Plane& DisparityEngine::compute_right_view(const Plane& left, const Plane& right) {
  // mirror(right) is the left view of the mirrored pair; process() checks the sizes and formats.
  fit_plane(mirrored_left_, right);
  fit_plane(mirrored_right_, left);
  mirror_rows(right, mirrored_left_);
  mirror_rows(left, mirrored_right_);
  const Plane& mirrored = compute(mirrored_left_, mirrored_right_);
  fit_plane(right_view_, mirrored);
  mirror_rows(mirrored, right_view_);
  return right_view_;
}

}  // namespace lpstereo::arm
