#include "arm/disparity_engine.h"

#include <stdexcept>

#include "arm/scheduler.h"

namespace lpstereo::arm {

namespace {
void check_range(const char* name, int value, int min_value, int max_value) {
  if (value < min_value || value > max_value) {
    throw std::invalid_argument(std::string("disparity parameter '") + name + "': expected [" + std::to_string(min_value) +
                                ", " + std::to_string(max_value) + "], got " + std::to_string(value));
  }
}
}  // namespace

GraphSpec DisparityEngine::graph_spec(const DisparityParameters& parameters) {
  check_range("census_width", parameters.census_width, 5, 5);
  GraphSpec spec;
  spec.name = "disparity-engine";
  spec.description = "census 5x5 of both views, winner-takes-all on Hamming costs";
  spec.inputs = {{"left", {ElementType::u8, 0}}, {"right", {ElementType::u8, 0}}};
  NodeSpec census_left;
  census_left.name = "census_left";
  census_left.kernel = "census5x5";
  census_left.inputs["input"] = {"left", false};
  census_left.outputs["output"] = "left_census";
  NodeSpec census_right = census_left;
  census_right.name = "census_right";
  census_right.inputs["input"] = {"right", false};
  census_right.outputs["output"] = "right_census";
  NodeSpec match;
  match.name = "match";
  match.kernel = "census_wta_disparity";
  match.inputs["left"] = {"left_census", false};
  match.inputs["right"] = {"right_census", false};
  match.outputs["disparity"] = "disparity";
  match.params = {{"min_disparity", parameters.min_disparity},
                  {"num_disparities", parameters.num_disparities},
                  {"max_cost_bits", parameters.max_cost_bits}};
  spec.nodes = {census_left, census_right, match};
  spec.outputs = {"disparity"};
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
