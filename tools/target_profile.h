// Profiles on a simulated target that several sub-commands share (`lpstereo profile`, `disparity
// --target`, `run`): a graph verified against a target's memory at a frame size, and the disparity
// engine's graph profiled in the chip's schedule.
#pragma once

#include <map>
#include <string>

#include "arm/disparity_engine.h"
#include "dag/graph.h"
#include "host_sim/simulator.h"
#include "host_sim/target.h"

namespace lpstereo::tools {

// A graph verified for a target at width x height. check_sram = false places the tiles as if the
// SRAM were large enough (a profile of a graph that does not fit).
Graph verified_for_target(const GraphSpec& spec, const host_sim::Target& target, int width, int height, bool check_sram = true);

// Binds every node of `spec` that no engine names to the first of the target's units that can run
// it at width x height (dag/graph.h unit_refusal): the chip runs a stage on its fixed-function unit
// when it has one that takes it (census and 4-path SGM on a stereo unit; 8-path SGM has none and
// stays on the vector engine).
void bind_to_units(GraphSpec& spec, const host_sim::Target& target, int width, int height);

// The engine's graph profiled on a target in the chip's layout (arm::EightPathLayout::
// forward_backward: 8 paths as two row-streaming passes with the forward sums in DRAM, the same bits
// as the host's bands), each stage on a unit of the target that takes it (bind_to_units). Verified
// against the target's memory.
host_sim::ProfileReport profile_engine_on_target(const arm::DisparityParameters& parameters, int width, int height,
                                                 const host_sim::Target& target,
                                                 const std::map<std::string, const Plane*>& inputs,
                                                 const host_sim::ProfileOptions& options);

}  // namespace lpstereo::tools
