// The outputs of a profile run: the report JSON (keys relied on by scripts and CI jobs, see
// docs/simulator.md), a Chrome-trace JSON that opens in Perfetto (one track per engine), a
// readable table and a Markdown summary.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "host_sim/simulator.h"

namespace lpstereo::host_sim {

inline constexpr const char* kModelDescription = "op-level, cycle-approximate";

nlohmann::json report_json(const ProfileReport& report);
std::string chrome_trace_json(const ProfileReport& report);
std::string report_table(const ProfileReport& report);
std::string report_markdown(const ProfileReport& report);

}  // namespace lpstereo::host_sim
