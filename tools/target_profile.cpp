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

void bind_to_units(GraphSpec& spec, const host_sim::Target& target, int width, int height) {
  if (target.units.empty()) return;
  const Graph on_vector = verified_for_target(spec, target, width, height, false);
  for (size_t n = 0; n < spec.nodes.size(); ++n) {
    const NodeInfo& node = on_vector.nodes()[n];
    if (!node.is_vector() || !spec.nodes[n].engine.empty()) continue;
    for (const host_sim::FixedFunctionUnit& unit : target.units) {
      if (unit_refusal(unit.limits, node, on_vector.buffers()).empty()) {
        spec.nodes[n].engine = unit.limits.name;
        break;
      }
    }
  }
  // A stereo unit's census and median are stages of its matcher's job: one whose neighbour (the
  // matcher it feeds, the matcher it filters) stays on the vector engine stays there too.
  for (size_t n = 0; n < spec.nodes.size(); ++n) {
    const host_sim::FixedFunctionUnit* unit = spec.nodes[n].engine.empty() ? nullptr : target.unit(spec.nodes[n].engine);
    if (unit == nullptr || unit->limits.kind != "stereo" || spec.nodes[n].kernel.rfind("sgm", 0) == 0) continue;
    const NodeInfo& node = on_vector.nodes()[n];
    bool with_matcher = false;
    for (int output : node.output_buffers) {
      for (int consumer : on_vector.buffers()[output].consumer_nodes) {
        with_matcher = with_matcher || (spec.nodes[consumer].engine == spec.nodes[n].engine &&
                                        spec.nodes[consumer].kernel.rfind("sgm", 0) == 0);
      }
    }
    for (int input : node.input_buffers) {
      const int producer = on_vector.buffers()[input].producer_node;
      with_matcher = with_matcher || (producer >= 0 && spec.nodes[producer].engine == spec.nodes[n].engine &&
                                      spec.nodes[producer].kernel.rfind("sgm", 0) == 0);
    }
    if (!with_matcher) spec.nodes[n].engine.clear();
  }
}

host_sim::ProfileReport profile_engine_on_target(const arm::DisparityParameters& parameters, int width, int height,
                                                 const host_sim::Target& target,
                                                 const std::map<std::string, const Plane*>& inputs,
                                                 const host_sim::ProfileOptions& options) {
  GraphSpec spec = arm::DisparityEngine::graph_spec(parameters, arm::EightPathLayout::forward_backward);
  bind_to_units(spec, target, width, height);
  const Graph graph = verified_for_target(spec, target, width, height);
  return host_sim::profile_graph(graph, target, inputs, options);
}

}  // namespace lpstereo::tools
