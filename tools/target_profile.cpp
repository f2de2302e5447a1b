#include "tools/target_profile.h"

namespace lpstereo::tools {

Graph verified_for_target(const GraphSpec& spec, const host_sim::Target& target, int width, int height, bool check_sram) {
  Graph graph(spec);
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  options.memory = target.memory_budget();
  if (!check_sram) options.memory.sram_bytes = 0;  // 0 = unchecked: tiles as if the SRAM were large enough
  graph.verify(options);
  return graph;
}

host_sim::ProfileReport profile_engine_on_target(const arm::DisparityParameters& parameters, int width, int height,
                                                 const host_sim::Target& target,
                                                 const std::map<std::string, const Plane*>& inputs,
                                                 const host_sim::ProfileOptions& options) {
  arm::DisparityParameters chip = parameters;
  chip.schedule = arm::SgmSchedule::sequential;
  const Graph graph = verified_for_target(arm::DisparityEngine::graph_spec(chip), target, width, height);
  return host_sim::profile_graph(graph, target, inputs, options);
}

}  // namespace lpstereo::tools
