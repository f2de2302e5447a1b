#include "arm/disparity_engine.h"

#include <stdexcept>

#include <nlohmann/json.hpp>

#include "arm/scheduler.h"

namespace lpstereo::arm {

namespace {
// A matcher node reading both views' census signatures.
NodeSpec census_pair_node(const std::string& name, const std::string& kernel, const nlohmann::json& params) {
  NodeSpec node;
  node.name = name;
  node.kernel = kernel;
  node.inputs["left"] = {"left_census", false};
  node.inputs["right"] = {"right_census", false};
  node.params = params;
  return node;
}

void check_range(const char* name, int value, int min_value, int max_value) {
  if (value < min_value || value > max_value) {
    throw std::invalid_argument(std::string("disparity parameter '") + name + "': expected [" + std::to_string(min_value) +
                                ", " + std::to_string(max_value) + "], got " + std::to_string(value));
  }
}
}  // namespace

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
  return text;
}

GraphSpec DisparityEngine::graph_spec(const DisparityParameters& parameters) {
  if (parameters.census_width != 5 && parameters.census_width != 9) {
    throw std::invalid_argument("disparity parameter 'census_width': expected 5 or 9, got " +
                                std::to_string(parameters.census_width));
  }
  if (parameters.paths != 0 && parameters.paths != 4 && parameters.paths != 8) {
    throw std::invalid_argument("disparity parameter 'paths': expected 0, 4 or 8, got " + std::to_string(parameters.paths));
  }
  const bool census64 = parameters.census_width == 9;
  GraphSpec spec;
  spec.name = "disparity-engine";
  spec.inputs = {{"left", {ElementType::u8, 0}}, {"right", {ElementType::u8, 0}}};
  NodeSpec census_left;
  census_left.name = "census_left";
  census_left.kernel = census64 ? "census9x7" : "census5x5";
  census_left.inputs["input"] = {"left", false};
  census_left.outputs["output"] = "left_census";
  NodeSpec census_right = census_left;
  census_right.name = "census_right";
  census_right.inputs["input"] = {"right", false};
  census_right.outputs["output"] = "right_census";
  spec.nodes = {census_left, census_right};
  spec.outputs = {"disparity"};
  if (parameters.paths == 0) {
    check_range("census_width", parameters.census_width, 5, 5);
    spec.description = "census 5x5 of both views, winner-takes-all on Hamming costs";
    NodeSpec match = census_pair_node("match", "census_wta_disparity",
                                      {{"min_disparity", parameters.min_disparity},
                                       {"num_disparities", parameters.num_disparities},
                                       {"max_cost_bits", parameters.max_cost_bits}});
    match.outputs["disparity"] = "disparity";
    spec.nodes.push_back(match);
    return spec;
  }
  const std::string suffix = census64 ? "_census64" : "";
  const nlohmann::json penalties = {
      {"min_disparity", parameters.min_disparity},
      {"num_disparities", parameters.num_disparities},
      {"p1", parameters.p1 >= 0 ? parameters.p1 : (census64 ? 7 : 5)},
      {"p2", parameters.p2 >= 0 ? parameters.p2 : (census64 ? 50 : 45)}};
  nlohmann::json selection = penalties;
  selection["uniqueness_percent"] = parameters.uniqueness_percent;
  selection["subpixel"] = parameters.subpixel ? 1 : 0;
  selection["lr_max_diff"] = parameters.lr_max_diff;
  spec.description = std::string("census ") + (census64 ? "9x7" : "5x5") + " of both views, semi-global matching over " +
                     std::to_string(parameters.paths) + " paths, winner takes all with uniqueness, sub-pixel and LR check";
  // The matcher writes "disparity" directly when no post-processing follows, else "sgm_disparity"
  // (then "median_disparity"), and the last stage writes "disparity".
  check_range("speckle_max_size_px", parameters.speckle_max_size_px, 0, 1 << 30);
  check_range("speckle_max_difference_px", parameters.speckle_max_difference_px, 0, 4095);
  const bool speckle = parameters.speckle_max_size_px > 0;
  const std::string matched = parameters.median || speckle ? "sgm_disparity" : "disparity";
  if (parameters.paths == 4) {
    NodeSpec sgm = census_pair_node("sgm", "sgm_4path" + suffix, selection);
    sgm.outputs["disparity"] = matched;
    spec.nodes.push_back(sgm);
  } else if (parameters.parallel_8path_passes) {
    NodeSpec forward = census_pair_node("sgm_forward", "sgm_8path_forward" + suffix, penalties);
    forward.outputs["sums"] = "forward_sums";
    NodeSpec backward = census_pair_node("sgm_backward", "sgm_8path_backward_sums" + suffix, penalties);
    backward.outputs["sums"] = "backward_sums";
    NodeSpec select;
    select.name = "sgm_select";
    select.kernel = "sgm_8path_select";
    select.inputs["forward"] = {"forward_sums", false};
    select.inputs["backward"] = {"backward_sums", false};
    select.outputs["disparity"] = matched;
    select.params = selection;
    spec.nodes.push_back(forward);
    spec.nodes.push_back(backward);
    spec.nodes.push_back(select);
  } else {
    NodeSpec forward = census_pair_node("sgm_forward", "sgm_8path_forward" + suffix, penalties);
    forward.outputs["sums"] = "forward_sums";
    NodeSpec backward = census_pair_node("sgm_backward", "sgm_8path_backward" + suffix, selection);
    backward.inputs["forward"] = {"forward_sums", false};
    backward.outputs["disparity"] = matched;
    spec.nodes.push_back(forward);
    spec.nodes.push_back(backward);
  }
  const int invalid_q4 = (parameters.min_disparity - 1) * 16;
  std::string last = matched;
  if (parameters.median) {
    NodeSpec median;
    median.name = "median";
    median.kernel = "median3x3_s16";
    median.inputs["input"] = {last, false};
    last = speckle ? "median_disparity" : "disparity";
    median.outputs["output"] = last;
    median.params = {{"invalid_q4", invalid_q4}};
    spec.nodes.push_back(median);
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
  }
  if (parameters.median) spec.description += ", 3x3 median";
  if (speckle) spec.description += ", speckle filter";
  return spec;
}

DisparityEngine::DisparityEngine(int width, int height, const DisparityParameters& parameters, const MemoryBudget& memory,
                                 int worker_threads, KernelBackend backend)
    : parameters_(parameters) {
  check_range("num_disparities", parameters.num_disparities, 1, width);
  check_range("min_disparity", parameters.min_disparity, -width + 1, width - 1);
  if (parameters.min_disparity + parameters.num_disparities > width) {
    throw std::invalid_argument("disparity parameters: min_disparity + num_disparities = " +
                                std::to_string(parameters.min_disparity + parameters.num_disparities) +
                                " exceeds the image width " + std::to_string(width));
  }
  graph_ = std::make_unique<Graph>(graph_spec(parameters));
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  options.memory = memory;
  graph_->verify(options);
  runner_ = std::make_unique<FrameRunner>(*graph_, worker_threads, backend);
}

DisparityEngine::~DisparityEngine() = default;

const Plane& DisparityEngine::compute(const Plane& left, const Plane& right) {
  runner_->process({{"left", &left}, {"right", &right}});
  return runner_->buffer("disparity");
}

}  // namespace lpstereo::arm
