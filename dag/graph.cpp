#include "dag/graph.h"

#include "dag/constant_generators.h"
#include "dag/tile_executor.h"

#include <algorithm>
#include <fstream>
#include <functional>
#include <mutex>
#include <set>
#include <sstream>
#include <utility>

namespace lpstereo {

namespace {

constexpr const char* kPhaseTopological = "verify phase 1 (topological order)";
constexpr const char* kPhasePorts = "verify phase 2 (ports and formats)";
constexpr const char* kPhaseWriter = "verify phase 3 (single writer)";
constexpr const char* kPhaseMemory = "verify phase 4 (memory placement)";
constexpr const char* kPhaseInit = "verify phase 5 (node init)";

// ---- JSON spec parsing ----

[[noreturn]] void spec_error(const std::string& source, const std::string& path, const std::string& what) {
  throw GraphSpecError(source + ": at " + path + ": " + what);
}

const nlohmann::json& require(const nlohmann::json& object, const char* key, const std::string& source,
                              const std::string& path) {
  if (!object.is_object() || !object.contains(key)) spec_error(source, path, std::string("missing key '") + key + "'");
  return object.at(key);
}

std::string require_string(const nlohmann::json& object, const char* key, const std::string& source,
                           const std::string& path) {
  const nlohmann::json& value = require(object, key, source, path);
  if (!value.is_string() || value.get<std::string>().empty()) {
    spec_error(source, path + "." + key, "expected a non-empty string, got " + value.dump());
  }
  return value.get<std::string>();
}

void check_keys(const nlohmann::json& object, const std::set<std::string>& known, const std::string& source,
                const std::string& path) {
  if (!object.is_object()) spec_error(source, path, "expected an object, got " + object.dump());
  for (const auto& item : object.items()) {
    if (known.count(item.key()) == 0) {
      std::string list;
      for (const std::string& key : known) list += (list.empty() ? "" : ", ") + key;
      spec_error(source, path, "unknown key '" + item.key() + "' (known: " + list + ")");
    }
  }
}

BufferFormat require_format(const nlohmann::json& object, const std::string& source, const std::string& path) {
  const std::string name = require_string(object, "format", source, path);
  std::optional<BufferFormat> format = parse_format(name);
  if (!format) spec_error(source, path + ".format", "unknown format '" + name + "' (u8, u16, s16q4, census32, ...)");
  return *format;
}

int tile_dimension(const nlohmann::json& schedule, const char* key, const std::string& source, const std::string& path) {
  if (!schedule.contains(key)) return 0;
  const nlohmann::json& value = schedule.at(key);
  if (!value.is_number_integer() || value.get<int64_t>() < 1 || value.get<int64_t>() > 65536) {
    spec_error(source, path + "." + key, "expected an integer in [1, 65536], got " + value.dump());
  }
  return value.get<int>();
}

NodeSpec parse_node(const nlohmann::json& node, const std::string& source, const std::string& path) {
  check_keys(node, {"name", "kernel", "task", "engine", "inputs", "outputs", "params", "border", "border_value", "schedule",
              "comment"},
             source, path);
  NodeSpec spec;
  spec.name = require_string(node, "name", source, path);
  const bool has_kernel = node.contains("kernel");
  const bool has_task = node.contains("task");
  if (has_kernel == has_task) spec_error(source, path, "expected exactly one of 'kernel' and 'task'");
  if (has_kernel) spec.kernel = require_string(node, "kernel", source, path);
  if (has_task) spec.task = require_string(node, "task", source, path);
  if (node.contains("engine")) {
    spec.engine = require_string(node, "engine", source, path);
    if (spec.engine == "vector" || spec.engine == "arm") {
      // The default engines are implied by "kernel" and "task"; naming them must agree.
      if ((spec.engine == "vector") != has_kernel) {
        spec_error(source, path + ".engine", "'" + spec.engine + "' runs " + (has_kernel ? "tasks" : "kernels") +
                                                 ", this node has a " + (has_kernel ? "kernel" : "task"));
      }
      spec.engine.clear();
    } else if (!has_kernel) {
      spec_error(source, path + ".engine", "a fixed-function unit ('" + spec.engine + "') runs a kernel, this node has a task");
    }
  }
  if (node.contains("inputs")) {
    const nlohmann::json& inputs = node.at("inputs");
    if (!inputs.is_object()) spec_error(source, path + ".inputs", "expected an object {port: buffer}");
    for (const auto& item : inputs.items()) {
      const std::string port_path = path + ".inputs." + item.key();
      InputBinding binding;
      if (item.value().is_string()) {
        binding.buffer = item.value().get<std::string>();
      } else if (item.value().is_object()) {
        check_keys(item.value(), {"buffer", "delayed"}, source, port_path);
        binding.buffer = require_string(item.value(), "buffer", source, port_path);
        if (item.value().contains("delayed")) {
          if (!item.value().at("delayed").is_boolean()) spec_error(source, port_path + ".delayed", "expected true or false");
          binding.delayed = item.value().at("delayed").get<bool>();
        }
      } else {
        spec_error(source, port_path, "expected a buffer name or {\"buffer\": ..., \"delayed\": true}");
      }
      spec.inputs[item.key()] = binding;
    }
  }
  if (node.contains("outputs")) {
    const nlohmann::json& outputs = node.at("outputs");
    if (!outputs.is_object()) spec_error(source, path + ".outputs", "expected an object {port: buffer}");
    for (const auto& item : outputs.items()) {
      if (!item.value().is_string() || item.value().get<std::string>().empty()) {
        spec_error(source, path + ".outputs." + item.key(), "expected a buffer name");
      }
      spec.outputs[item.key()] = item.value().get<std::string>();
    }
  }
  if (node.contains("params")) spec.params = node.at("params");
  if (node.contains("border")) {
    const nlohmann::json& border = node.at("border");
    if (border == "replicate") {
      spec.border_mode = BorderMode::replicate;
    } else if (border == "constant") {
      spec.border_mode = BorderMode::constant;
    } else {
      spec_error(source, path + ".border", "expected \"replicate\" or \"constant\", got " + border.dump());
    }
  }
  if (node.contains("border_value")) {
    const nlohmann::json& value = node.at("border_value");
    if (!value.is_number_unsigned() || value.get<uint64_t>() > 0xFFFFFFFFu) {
      spec_error(source, path + ".border_value", "expected an unsigned integer, got " + value.dump());
    }
    spec.border_value = value.get<uint32_t>();
  }
  if (node.contains("schedule")) {
    const nlohmann::json& schedule = node.at("schedule");
    check_keys(schedule, {"tile_width", "tile_height"}, source, path + ".schedule");
    spec.tile_width = tile_dimension(schedule, "tile_width", source, path + ".schedule");
    spec.tile_height = tile_dimension(schedule, "tile_height", source, path + ".schedule");
  }
  return spec;
}

// ---- constant generators ----

struct ConstantGeneratorEntry {
  BufferFormat format;
  ConstantGenerator generate;
};

std::map<std::string, ConstantGeneratorEntry>& constant_generators() {
  static std::map<std::string, ConstantGeneratorEntry> generators = [] {
    std::map<std::string, ConstantGeneratorEntry> builtin;
    for (const BuiltinConstantGenerator& generator : builtin_constant_generators()) {
      builtin[generator.name] = {generator.format, generator.generate};
    }
    return builtin;
  }();
  return generators;
}

std::string describe_port(const NodeInfo& node, const std::string& port) {
  return "node '" + node.spec.name + "' port '" + port + "'";
}

}  // namespace

GraphSpec parse_graph_spec(const std::string& json_text, const std::string& source_name) {
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::parse_error& error) {
    // nlohmann reports "... parse error at line L, column C: ..."; keep its position text.
    std::string message = error.what();
    const size_t at = message.find("at line ");
    std::string position = "1:1";
    if (at != std::string::npos) {
      int line = 0, column = 0;
      if (std::sscanf(message.c_str() + at, "at line %d, column %d", &line, &column) == 2) {
        position = std::to_string(line) + ":" + std::to_string(column);
      }
    }
    const size_t colon = message.find(": ", at == std::string::npos ? 0 : at);
    throw GraphSpecError(source_name + ":" + position + ": malformed JSON: " +
                         (colon == std::string::npos ? message : message.substr(colon + 2)));
  }
  const std::string root = "$";
  check_keys(document, {"name", "description", "inputs", "constants", "nodes", "outputs", "budget", "camera", "comment"},
             source_name, root);
  GraphSpec spec;
  spec.name = require_string(document, "name", source_name, root);
  if (document.contains("description") && document.at("description").is_string()) {
    spec.description = document.at("description").get<std::string>();
  }
  const nlohmann::json& inputs = require(document, "inputs", source_name, root);
  if (!inputs.is_array()) spec_error(source_name, "$.inputs", "expected an array");
  for (size_t i = 0; i < inputs.size(); ++i) {
    const std::string path = "$.inputs[" + std::to_string(i) + "]";
    check_keys(inputs[i], {"name", "format", "comment"}, source_name, path);
    spec.inputs.push_back({require_string(inputs[i], "name", source_name, path), require_format(inputs[i], source_name, path)});
  }
  if (document.contains("constants")) {
    const nlohmann::json& constants = document.at("constants");
    if (!constants.is_array()) spec_error(source_name, "$.constants", "expected an array");
    for (size_t i = 0; i < constants.size(); ++i) {
      const std::string path = "$.constants[" + std::to_string(i) + "]";
      check_keys(constants[i], {"name", "generator", "params", "width", "height", "comment"}, source_name, path);
      ConstantSpec constant{require_string(constants[i], "name", source_name, path),
                            require_string(constants[i], "generator", source_name, path), nlohmann::json::object()};
      if (constants[i].contains("params")) constant.params = constants[i].at("params");
      for (const char* key : {"width", "height"}) {
        if (!constants[i].contains(key)) continue;
        const nlohmann::json& value = constants[i].at(key);
        if (!value.is_number_integer() || value.get<int64_t>() < 0 || value.get<int64_t>() > 65536) {
          spec_error(source_name, path + "." + key, "expected an integer 0..65536 (0 = the frame size), got " + value.dump());
        }
        (std::string(key) == "width" ? constant.width : constant.height) = value.get<int>();
      }
      spec.constants.push_back(constant);
    }
  }
  const nlohmann::json& nodes = require(document, "nodes", source_name, root);
  if (!nodes.is_array() || nodes.empty()) spec_error(source_name, "$.nodes", "expected a non-empty array");
  for (size_t i = 0; i < nodes.size(); ++i) {
    spec.nodes.push_back(parse_node(nodes[i], source_name, "$.nodes[" + std::to_string(i) + "]"));
  }
  if (document.contains("outputs")) {
    const nlohmann::json& outputs = document.at("outputs");
    if (!outputs.is_array()) spec_error(source_name, "$.outputs", "expected an array of buffer names");
    for (const nlohmann::json& output : outputs) {
      if (!output.is_string()) spec_error(source_name, "$.outputs", "expected buffer names, got " + output.dump());
      spec.outputs.push_back(output.get<std::string>());
    }
  }
  if (document.contains("camera")) {
    const nlohmann::json& camera = document.at("camera");
    check_keys(camera, {"baseline_m", "hfov_deg", "comment"}, source_name, "$.camera");
    auto positive = [&](const char* key, double max_value) {
      if (!camera.contains(key) || !camera.at(key).is_number() || !(camera.at(key).get<double>() > 0) ||
          camera.at(key).get<double>() >= max_value) {
        spec_error(source_name, std::string("$.camera.") + key,
                   "expected a number in (0, " + std::to_string(static_cast<int>(max_value)) + ")" +
                       (camera.contains(key) ? ", got " + camera.at(key).dump() : ", missing"));
      }
      return camera.at(key).get<double>();
    };
    spec.camera_baseline_m = positive("baseline_m", 100);
    spec.camera_hfov_deg = positive("hfov_deg", 180);
  }
  if (document.contains("budget")) {
    const nlohmann::json& budget = document.at("budget");
    check_keys(budget, {"enforce", "note"}, source_name, "$.budget");
    if (budget.contains("enforce")) {
      if (!budget.at("enforce").is_boolean()) spec_error(source_name, "$.budget.enforce", "expected true or false");
      spec.enforce_budget = budget.at("enforce").get<bool>();
    }
    if (budget.contains("note") && budget.at("note").is_string()) spec.budget_note = budget.at("note").get<std::string>();
    if (!spec.enforce_budget && spec.budget_note.empty()) {
      spec_error(source_name, "$.budget.note", "a graph not enforced must say why");
    }
  }
  return spec;
}

std::unique_ptr<Graph> make_verified_graph(GraphSpec spec, int width, int height, const MemoryBudget& memory) {
  auto graph = std::make_unique<Graph>(std::move(spec));
  VerifyOptions options;
  options.frame_width = width;
  options.frame_height = height;
  options.memory = memory;
  graph->verify(options);
  return graph;
}

GraphSpec load_graph_spec(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw GraphSpecError(path + ": cannot open graph file");
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) throw GraphSpecError(path + ": read error");
  return parse_graph_spec(text.str(), path);
}

void register_constant_generator(const std::string& name, BufferFormat format, ConstantGenerator generator) {
  constant_generators()[name] = {format, std::move(generator)};
}

Graph::Graph(GraphSpec spec) : spec_(std::move(spec)) {}

int Graph::buffer_index(const std::string& name) const {
  auto found = buffer_by_name_.find(name);
  return found == buffer_by_name_.end() ? -1 : found->second;
}

void Graph::verify(const VerifyOptions& options) {
  options_ = options;
  verified_ = false;
  nodes_.clear();
  buffers_.clear();
  buffer_by_name_.clear();
  extra_writers_.clear();
  order_.clear();
  constants_.clear();
  if (options.frame_width <= 0 || options.frame_height <= 0) {
    throw VerifyError(kPhasePorts, "frame size: expected width and height > 0, got " +
                                       std::to_string(options.frame_width) + "x" + std::to_string(options.frame_height));
  }

  // Buffers named by graph inputs, constants and node outputs; node bindings resolved by name.
  auto add_buffer = [&](const std::string& name) {
    auto [it, inserted] = buffer_by_name_.emplace(name, static_cast<int>(buffers_.size()));
    if (inserted) {
      BufferInfo info;
      info.name = name;
      buffers_.push_back(info);
    }
    return it->second;
  };
  for (const GraphInputSpec& input : spec_.inputs) {
    const int index = add_buffer(input.name);
    if (buffers_[index].is_graph_input) throw VerifyError(kPhaseWriter, "graph input '" + input.name + "' declared twice");
    buffers_[index].is_graph_input = true;
    buffers_[index].format = input.format;
    buffers_[index].shape = {options.frame_width, options.frame_height};
  }
  for (const ConstantSpec& constant : spec_.constants) {
    const int index = add_buffer(constant.name);
    if (buffers_[index].is_graph_input || buffers_[index].is_constant) {
      throw VerifyError(kPhaseWriter, "buffer '" + constant.name + "' has 2 writers: a graph input or constant, and constant '" +
                                          constant.name + "'");
    }
    auto generator = constant_generators().find(constant.generator);
    if (generator == constant_generators().end()) {
      std::string known;
      for (const auto& [name, entry] : constant_generators()) known += (known.empty() ? "" : ", ") + name;
      throw VerifyError(kPhasePorts, "constant '" + constant.name + "': unknown generator '" + constant.generator +
                                         "' (known: " + (known.empty() ? "none" : known) + ")");
    }
    buffers_[index].is_constant = true;
    buffers_[index].format = generator->second.format;
    buffers_[index].shape = {constant.width > 0 ? constant.width : options.frame_width,
                             constant.height > 0 ? constant.height : options.frame_height};
  }
  std::set<std::string> node_names;
  for (const NodeSpec& node_spec : spec_.nodes) {
    NodeInfo node;
    node.spec = node_spec;
    if (!node_names.insert(node_spec.name).second) {
      throw VerifyError(kPhasePorts, "node '" + node_spec.name + "' is declared twice");
    }
    if (!node_spec.kernel.empty()) {
      node.kernel = KernelRegistry::instance().find(node_spec.kernel);
      if (node.kernel == nullptr) {
        std::string known;
        for (const std::string& name : KernelRegistry::instance().names()) known += (known.empty() ? "" : ", ") + name;
        throw VerifyError(kPhasePorts, "node '" + node_spec.name + "': unknown kernel '" + node_spec.kernel +
                                           "' (known: " + known + ")");
      }
    } else {
      node.task = ArmTaskRegistry::instance().find(node_spec.task);
      if (node.task == nullptr) {
        std::string known;
        for (const std::string& name : ArmTaskRegistry::instance().names()) known += (known.empty() ? "" : ", ") + name;
        throw VerifyError(kPhasePorts, "node '" + node_spec.name + "': unknown ARM task '" + node_spec.task +
                                           "' (known: " + (known.empty() ? "none" : known) + ")");
      }
    }
    const std::vector<PortSpec>& ports = node.kernel ? node.kernel->ports : node.task->ports;
    // Every bound port must exist, every declared port must be bound.
    for (const auto& [port, binding] : node_spec.inputs) {
      auto found = std::find_if(ports.begin(), ports.end(), [&](const PortSpec& p) {
        return p.name == port && p.direction == PortDirection::input;
      });
      if (found == ports.end()) {
        std::string known;
        for (const PortSpec& p : ports) {
          if (p.direction == PortDirection::input) known += (known.empty() ? "" : ", ") + p.name;
        }
        throw VerifyError(kPhasePorts, describe_port(node, port) + ": no such input port (expected one of: " + known + ")");
      }
    }
    for (const auto& [port, buffer] : node_spec.outputs) {
      auto found = std::find_if(ports.begin(), ports.end(), [&](const PortSpec& p) {
        return p.name == port && p.direction == PortDirection::output;
      });
      if (found == ports.end()) {
        std::string known;
        for (const PortSpec& p : ports) {
          if (p.direction == PortDirection::output) known += (known.empty() ? "" : ", ") + p.name;
        }
        throw VerifyError(kPhasePorts, describe_port(node, port) + ": no such output port (expected one of: " + known + ")");
      }
    }
    for (const PortSpec& port : ports) {
      if (port.direction == PortDirection::input) {
        auto bound = node_spec.inputs.find(port.name);
        if (bound == node_spec.inputs.end()) {
          throw VerifyError(kPhasePorts, describe_port(node, port.name) + ": input not connected (expected a " +
                                             format_name(port.format) + " buffer)");
        }
        node.input_buffers.push_back(add_buffer(bound->second.buffer));
        node.input_delayed.push_back(bound->second.delayed);
      } else {
        auto bound = node_spec.outputs.find(port.name);
        if (bound == node_spec.outputs.end()) {
          throw VerifyError(kPhasePorts, describe_port(node, port.name) + ": output not connected");
        }
        node.output_buffers.push_back(add_buffer(bound->second));
      }
    }
    nodes_.push_back(std::move(node));
  }
  // Producers (first writer wins here; the others are reported by phase 3).
  for (size_t n = 0; n < nodes_.size(); ++n) {
    const std::vector<PortSpec>& ports = nodes_[n].kernel ? nodes_[n].kernel->ports : nodes_[n].task->ports;
    int output_port = 0;
    for (const PortSpec& port : ports) {
      if (port.direction != PortDirection::output) continue;
      BufferInfo& buffer = buffers_[nodes_[n].output_buffers[output_port]];
      const std::string writer = "node '" + nodes_[n].spec.name + "' port '" + port.name + "'";
      if (buffer.producer_node >= 0 || buffer.is_graph_input || buffer.is_constant) {
        const std::string first = buffer.producer_node >= 0
                                      ? "node '" + nodes_[buffer.producer_node].spec.name + "' port '" +
                                            std::string(nodes_[buffer.producer_node].kernel
                                                            ? nodes_[buffer.producer_node].kernel->ports[buffer.producer_port].name
                                                            : nodes_[buffer.producer_node].task->ports[buffer.producer_port].name) +
                                            "'"
                                      : (buffer.is_graph_input ? "graph input" : "constant");
        extra_writers_.push_back("buffer '" + buffer.name + "' has 2 writers: " + first + " and " + writer +
                                 " (expected 1 writer)");
      } else {
        buffer.producer_node = static_cast<int>(n);
        buffer.producer_port = static_cast<int>(&port - ports.data());
      }
      ++output_port;
    }
  }
  for (size_t n = 0; n < nodes_.size(); ++n) {
    for (int buffer : nodes_[n].input_buffers) buffers_[buffer].consumer_nodes.push_back(static_cast<int>(n));
    for (size_t i = 0; i < nodes_[n].input_buffers.size(); ++i) {
      if (nodes_[n].input_delayed[i]) buffers_[nodes_[n].input_buffers[i]].read_delayed = true;
    }
  }
  for (const std::string& output : spec_.outputs) {
    const int index = buffer_index(output);
    if (index < 0) throw VerifyError(kPhasePorts, "graph output '" + output + "': no such buffer");
    buffers_[index].is_graph_output = true;
  }

  phase_topological_order();
  phase_ports_and_formats();
  phase_single_writer();
  phase_memory_placement();
  phase_node_init();
  verified_ = true;
}

void Graph::phase_topological_order() {
  const int count = static_cast<int>(nodes_.size());
  std::vector<std::vector<int>> successors(count);
  std::vector<int> indegree(count, 0);
  for (int n = 0; n < count; ++n) {
    for (size_t i = 0; i < nodes_[n].input_buffers.size(); ++i) {
      if (nodes_[n].input_delayed[i]) continue;  // a delayed edge carries last frame's value: no dependency
      const int producer = buffers_[nodes_[n].input_buffers[i]].producer_node;
      if (producer < 0) continue;
      successors[producer].push_back(n);
      ++indegree[n];
    }
  }
  // Kahn's algorithm, lowest declared index first so the order is stable and readable.
  std::set<int> ready;
  for (int n = 0; n < count; ++n) {
    if (indegree[n] == 0) ready.insert(n);
  }
  while (!ready.empty()) {
    const int n = *ready.begin();
    ready.erase(ready.begin());
    order_.push_back(n);
    for (int next : successors[n]) {
      if (--indegree[next] == 0) ready.insert(next);
    }
  }
  if (static_cast<int>(order_.size()) == count) return;
  // Name one cycle: walk predecessors among the unsorted nodes until a node repeats.
  std::vector<int> predecessor(count, -1);
  for (int n = 0; n < count; ++n) {
    for (int next : successors[n]) {
      if (indegree[next] > 0 && indegree[n] > 0) predecessor[next] = n;
    }
  }
  int start = -1;
  for (int n = 0; n < count && start < 0; ++n) {
    if (indegree[n] > 0) start = n;
  }
  std::vector<int> seen(count, -1);
  std::vector<int> walk;
  int current = start;
  while (current >= 0 && seen[current] < 0) {
    seen[current] = static_cast<int>(walk.size());
    walk.push_back(current);
    current = predecessor[current];
  }
  std::string cycle;
  if (current >= 0) {
    std::vector<int> loop(walk.begin() + seen[current], walk.end());
    std::reverse(loop.begin(), loop.end());
    // Start the cycle at its first-declared node, so the message is the same however it was found.
    std::rotate(loop.begin(), std::min_element(loop.begin(), loop.end()), loop.end());
    for (int n : loop) cycle += "'" + nodes_[n].spec.name + "' -> ";
    cycle += "'" + nodes_[loop.front()].spec.name + "'";
  }
  throw VerifyError(kPhaseTopological, "cycle not broken by a delayed edge: " + cycle +
                                           " (mark one input {\"buffer\": ..., \"delayed\": true} to read the previous frame)");
}

void Graph::phase_ports_and_formats() {
  // Formats are static: every produced buffer takes its producer's port format.
  for (BufferInfo& buffer : buffers_) {
    if (buffer.producer_node >= 0) {
      const NodeInfo& producer = nodes_[buffer.producer_node];
      buffer.format = (producer.kernel ? producer.kernel->ports : producer.task->ports)[buffer.producer_port].format;
    } else if (!buffer.is_graph_input && !buffer.is_constant) {
      std::string reader = "?";
      if (!buffer.consumer_nodes.empty()) reader = nodes_[buffer.consumer_nodes.front()].spec.name;
      throw VerifyError(kPhasePorts, "buffer '" + buffer.name + "' read by node '" + reader +
                                         "' has no writer (expected a graph input, a constant or a node output)");
    }
  }
  // Shapes propagate in topological order; a delayed input's shape comes from the previous pass, so
  // run twice and insist the shapes agree.
  std::vector<bool> shape_known(buffers_.size(), false);
  for (size_t b = 0; b < buffers_.size(); ++b) shape_known[b] = buffers_[b].is_graph_input || buffers_[b].is_constant;
  for (int pass = 0; pass < 2; ++pass) {
    for (int n : order_) {
      NodeInfo& node = nodes_[n];
      const std::vector<PortSpec>& ports = node.kernel ? node.kernel->ports : node.task->ports;
      std::vector<PlaneShape> input_shapes;
      bool all_known = true;
      bool provisional = false;  // a delayed input's shape guessed as the frame size in pass 1
      int input = 0;
      for (const PortSpec& port : ports) {
        if (port.direction != PortDirection::input) continue;
        const BufferInfo& buffer = buffers_[node.input_buffers[input]];
        if (buffer.format != port.format) {
          std::string source = buffer.is_graph_input ? "graph input" : (buffer.is_constant ? "constant" : "");
          if (buffer.producer_node >= 0) source = "node '" + nodes_[buffer.producer_node].spec.name + "'";
          throw VerifyError(kPhasePorts, describe_port(node, port.name) + ": format mismatch: expected " +
                                             format_name(port.format) + ", got " + format_name(buffer.format) +
                                             " (buffer '" + buffer.name + "' from " + source + ")");
        }
        if (shape_known[node.input_buffers[input]]) {
          input_shapes.push_back(buffer.shape);
        } else if (node.input_delayed[input] && pass == 0) {
          // A loop closed by a delayed edge: its shape comes from its producer, prepared later in
          // this pass; guess the frame size now, pass 2 recomputes with the real shape.
          input_shapes.push_back({options_.frame_width, options_.frame_height});
          provisional = true;
        } else {
          all_known = false;
        }
        ++input;
      }
      if (!all_known) {
        if (pass == 1) {
          throw VerifyError(kPhasePorts, "node '" + node.spec.name + "': input shape unknown (a delayed loop with no source)");
        }
        continue;
      }
      if (provisional) {
        try {
          PreparedKernel guess = node.kernel ? node.kernel->prepare(node.spec.params, input_shapes)
                                             : node.task->prepare(node.spec.params, input_shapes);
          for (size_t o = 0; o < node.output_buffers.size() && o < guess.output_shapes.size(); ++o) {
            buffers_[node.output_buffers[o]].shape = guess.output_shapes[o];
            shape_known[node.output_buffers[o]] = true;
          }
        } catch (const std::exception&) {
          // The guess did not suit the node; pass 2 reports what is wrong with the real shapes.
        }
        continue;
      }
      try {
        node.prepared = node.kernel ? node.kernel->prepare(node.spec.params, input_shapes)
                                    : node.task->prepare(node.spec.params, input_shapes);
      } catch (const KernelError& error) {
        throw VerifyError(kPhasePorts, "node '" + node.spec.name + "' (" +
                                           (node.kernel ? "kernel '" + node.kernel->name : "task '" + node.task->name) +
                                           "'): " + error.what());
      } catch (const nlohmann::json::exception& error) {
        throw VerifyError(kPhasePorts, "node '" + node.spec.name + "': parameters: " + error.what());
      }
      if (node.kernel != nullptr && !node.kernel->border_modes.empty() &&
          std::find(node.kernel->border_modes.begin(), node.kernel->border_modes.end(), node.spec.border_mode) ==
              node.kernel->border_modes.end()) {
        throw VerifyError(kPhasePorts, "node '" + node.spec.name + "': border mode '" +
                                           std::string(border_mode_name(node.spec.border_mode)) + "' not supported by kernel '" +
                                           node.kernel->name + "'");
      }
      if (node.prepared.output_shapes.size() != node.output_buffers.size()) {
        throw VerifyError(kPhasePorts, "node '" + node.spec.name + "': prepare gave " +
                                           std::to_string(node.prepared.output_shapes.size()) + " output shapes, expected " +
                                           std::to_string(node.output_buffers.size()));
      }
      for (size_t o = 0; o < node.output_buffers.size(); ++o) {
        BufferInfo& buffer = buffers_[node.output_buffers[o]];
        const PlaneShape& shape = node.prepared.output_shapes[o];
        if (pass == 1 && shape_known[node.output_buffers[o]] && !(buffer.shape == shape) && buffer.read_delayed) {
          throw VerifyError(kPhasePorts, "buffer '" + buffer.name + "': delayed shape " + std::to_string(buffer.shape.width) +
                                             "x" + std::to_string(buffer.shape.height) + " differs from the produced " +
                                             std::to_string(shape.width) + "x" + std::to_string(shape.height));
        }
        if (shape.width <= 0 || shape.height <= 0) {
          throw VerifyError(kPhasePorts, "node '" + node.spec.name + "': output shape " + std::to_string(shape.width) + "x" +
                                             std::to_string(shape.height) + " is empty");
        }
        buffer.shape = shape;
        shape_known[node.output_buffers[o]] = true;
      }
    }
  }
}

void Graph::phase_single_writer() {
  if (!extra_writers_.empty()) throw VerifyError(kPhaseWriter, extra_writers_.front());
}

size_t tile_working_set_bytes(const NodeInfo& node, const std::vector<BufferInfo>& buffers, int tile_width,
                              int tile_height) {
  const KernelDescriptor& kernel = *node.kernel;
  size_t bytes = 0;
  int input = 0;
  int output = 0;
  for (const PortSpec& port : kernel.ports) {
    const size_t element_size = static_cast<size_t>(element_bytes(port.format.type));
    if (port.direction == PortDirection::output) {
      bytes += 2 * static_cast<size_t>(tile_width) * tile_height * element_size;
      ++output;
      continue;
    }
    const BufferInfo& buffer = buffers[node.input_buffers[input]];
    if (port.access == PortAccess::whole) {
      PixelRect rect{0, 0, buffer.shape.width, buffer.shape.height};
      if (kernel.source_rect) {
        rect = kernel.source_rect(input, PixelRect{0, 0, tile_width, tile_height}, buffer.shape, node.prepared.params.get());
      }
      bytes += 2 * static_cast<size_t>(rect.x1 - rect.x0) * (rect.y1 - rect.y0) * element_size;
    } else {
      const PixelRect rect = tile_input_rect(kernel, node.prepared.input_halos, node.prepared.input_scales, input,
                                             TileRect{0, 0, tile_width, tile_height});
      bytes += 2 * static_cast<size_t>(rect.x1 - rect.x0) * static_cast<size_t>(rect.y1 - rect.y0) * element_size;
    }
    ++input;
  }
  if (kernel.scratch_bytes) bytes += kernel.scratch_bytes(tile_width, tile_height, node.prepared.params.get());
  return bytes + row_state_bytes(node, buffers);
}

size_t row_state_bytes(const NodeInfo& node, const std::vector<BufferInfo>& buffers) {
  if (!node.is_vector() || !node.kernel->state_bytes) return 0;
  const PlaneShape image = buffers[node.output_buffers.at(0)].shape;
  return node.kernel->state_bytes(image.width, image.height, node.prepared.params.get());
}

VectorNodeBinding vector_node_binding(const NodeInfo& node) {
  VectorNodeBinding binding;
  binding.kernel = node.kernel;
  binding.params = node.prepared.params.get();
  binding.border_mode = node.spec.border_mode;
  binding.border_value = node.spec.border_value;
  binding.input_halos = node.prepared.input_halos;
  binding.input_scales = node.prepared.input_scales;
  return binding;
}

namespace {

std::string joined(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text.empty() ? "none" : text;
}

}  // namespace

std::string unit_refusal(const UnitLimits& unit, const NodeInfo& node, const std::vector<BufferInfo>& buffers) {
  std::vector<int> planes = node.input_buffers;
  planes.insert(planes.end(), node.output_buffers.begin(), node.output_buffers.end());
  for (int b : planes) {
    const PlaneShape& shape = buffers[b].shape;
    if (shape.width > unit.max_width || shape.height > unit.max_height) {
      return "buffer '" + buffers[b].name + "' is " + std::to_string(shape.width) + "x" + std::to_string(shape.height) +
             ", the unit's limit is " + std::to_string(unit.max_width) + "x" + std::to_string(unit.max_height);
    }
  }
  if (node.kernel == nullptr || std::find(unit.functions.begin(), unit.functions.end(), node.kernel->name) == unit.functions.end()) {
    return (node.kernel ? "kernel '" + node.kernel->name + "'" : "task '" + node.spec.task + "'") +
           " is not one of its functions (" + joined(unit.functions) + ")";
  }
  if (unit.kind == "stereo") {
    if (node.kernel->name.rfind("census", 0) == 0) {
      const Halo& halo = node.kernel->halo;
      const int width = halo.left + halo.right + 1, height = halo.top + halo.bottom + 1;
      if (width != unit.census_width || height != unit.census_height) {
        return "census window " + std::to_string(width) + "x" + std::to_string(height) + ", the unit's is " +
               std::to_string(unit.census_width) + "x" + std::to_string(unit.census_height);
      }
    } else if (node.kernel->name.rfind("sgm", 0) == 0) {
      // A unit is programmed with explicit values: the node must state each one.
      int values[3] = {0, 0, 0};
      const char* keys[3] = {"num_disparities", "p1", "p2"};
      for (int i = 0; i < 3; ++i) {
        if (!node.spec.params.contains(keys[i]) || !node.spec.params.at(keys[i]).is_number_integer()) {
          return std::string("parameter '") + keys[i] + "' must be given as an integer (a unit is programmed with explicit values)";
        }
        values[i] = node.spec.params.at(keys[i]).get<int>();
      }
      if (std::find(unit.search_ranges.begin(), unit.search_ranges.end(), values[0]) == unit.search_ranges.end()) {
        std::vector<std::string> offered;
        for (int value : unit.search_ranges) offered.push_back(std::to_string(value));
        return "search range (num_disparities) " + std::to_string(values[0]) + " is not one the unit offers (" + joined(offered) + ")";
      }
      if (values[1] > unit.p1_max || values[2] > unit.p2_max) {
        return "penalties p1 " + std::to_string(values[1]) + ", p2 " + std::to_string(values[2]) + ", the unit's limits are p1 <= " +
               std::to_string(unit.p1_max) + ", p2 <= " + std::to_string(unit.p2_max);
      }
    }
  }
  const size_t state = row_state_bytes(node, buffers);
  if (state > unit.local_memory_bytes) {
    return "row state of " + std::to_string(state) + " bytes, the unit's local memory is " +
           std::to_string(unit.local_memory_bytes) + " bytes (over by " + std::to_string(state - unit.local_memory_bytes) + ")";
  }
  return "";
}

void Graph::check_unit_node(const NodeInfo& node) const {
  const MemoryBudget& memory = options_.memory;
  const auto unit = std::find_if(memory.units.begin(), memory.units.end(),
                                 [&](const UnitLimits& candidate) { return candidate.name == node.spec.engine; });
  if (unit == memory.units.end()) {
    std::vector<std::string> names;
    for (const UnitLimits& candidate : memory.units) names.push_back(candidate.name);
    throw VerifyError(kPhaseMemory, "node '" + node.spec.name + "': engine '" + node.spec.engine + "': target '" +
                                        memory.target_name + "' has no such unit (its units: " + joined(names) + ")");
  }
  const std::string refusal = unit_refusal(*unit, node, buffers_);
  if (!refusal.empty()) throw VerifyError(kPhaseMemory, "node '" + node.spec.name + "' on unit '" + unit->name + "': " + refusal);
}

void Graph::phase_memory_placement() {
  const MemoryBudget& memory = options_.memory;
  sram_peak_bytes_ = 0;
  for (BufferInfo& buffer : buffers_) buffer.unit_local = false;
  for (int n : order_) {
    NodeInfo& node = nodes_[n];
    if (!node.is_vector()) continue;
    const PlaneShape output = buffers_[node.output_buffers.at(0)].shape;
    if (node.on_unit()) {
      // A unit streams its planes itself: full-width strips for the native run of its functional
      // model, no vector SRAM taken; on a target, the unit's own limits.
      node.tile_width = output.width;
      node.tile_height = std::min(64, output.height);
      node.sram_working_set_bytes = 0;
      if (memory.check_units) check_unit_node(node);
      continue;
    }
    if (node.spec.tile_width > 0 || node.spec.tile_height > 0) {
      node.tile_width = std::min(node.spec.tile_width > 0 ? node.spec.tile_width : output.width, output.width);
      node.tile_height = std::min(node.spec.tile_height > 0 ? node.spec.tile_height : 64, output.height);
    } else {
      // Auto schedule: full-width strips as tall as fit the SRAM share (tallest first: fewer DMA
      // set-ups, less halo re-read); if one row does not fit, narrower tiles.
      node.tile_width = output.width;
      node.tile_height = std::min(64, output.height);
      if (memory.sram_bytes > 0) {
        const size_t limit = static_cast<size_t>(static_cast<double>(memory.sram_bytes) * memory.sram_tile_share);
        while (node.tile_height > 1 && tile_working_set_bytes(node, buffers_, node.tile_width, node.tile_height) > limit) {
          node.tile_height = std::max(1, node.tile_height / 2);
        }
        const bool whole_rows = node.kernel->state_bytes || node.kernel->full_width_tiles;
        while (!whole_rows && node.tile_width > 64 && tile_working_set_bytes(node, buffers_, node.tile_width, node.tile_height) > limit) {
          node.tile_width = (node.tile_width / 2 + 63) / 64 * 64;
        }
      }
    }
    if ((node.kernel->state_bytes || node.kernel->full_width_tiles) && node.tile_width != output.width) {
      throw VerifyError(kPhaseMemory, "node '" + node.spec.name + "': kernel '" + node.kernel->name +
                                          (node.kernel->state_bytes ? "' carries row state" : "' works along whole rows") +
                                          ": expected full-width tiles (" +
                                          std::to_string(output.width) + "), got tile width " +
                                          std::to_string(node.tile_width));
    }
    const int block_width = std::max(1, node.kernel->block_width);
    const int block_height = std::max(1, node.kernel->block_height);
    if (node.tile_width < output.width && node.tile_width % block_width != 0) {
      throw VerifyError(kPhaseMemory, "node '" + node.spec.name + "': tile width " + std::to_string(node.tile_width) +
                                          " is not a multiple of the kernel block width " + std::to_string(block_width));
    }
    if (node.tile_height < output.height && node.tile_height % block_height != 0) {
      throw VerifyError(kPhaseMemory, "node '" + node.spec.name + "': tile height " + std::to_string(node.tile_height) +
                                          " is not a multiple of the kernel block height " + std::to_string(block_height));
    }
    node.sram_working_set_bytes = tile_working_set_bytes(node, buffers_, node.tile_width, node.tile_height);
    if (memory.sram_bytes > 0 && node.sram_working_set_bytes > memory.sram_bytes) {
      throw SramBudgetError(kPhaseMemory, "node '" + node.spec.name + "': SRAM working set of a " +
                                          std::to_string(node.tile_width) + "x" + std::to_string(node.tile_height) +
                                          " tile is " + std::to_string(node.sram_working_set_bytes) +
                                          " bytes, target '" + memory.target_name + "' has " +
                                          std::to_string(memory.sram_bytes) + " bytes of SRAM (over by " +
                                          std::to_string(node.sram_working_set_bytes - memory.sram_bytes) + ")");
    }
    sram_peak_bytes_ = std::max(sram_peak_bytes_, node.sram_working_set_bytes);
  }
  // A unit's internal stage: produced on a unit and read only on the same unit, never by a later
  // frame nor as a graph output, it streams inside the unit (a stereo unit's census).
  if (memory.check_units) {
    for (BufferInfo& buffer : buffers_) {
      if (buffer.producer_node < 0 || buffer.is_graph_output || buffer.read_delayed || buffer.consumer_nodes.empty()) continue;
      const std::string& engine = nodes_[buffer.producer_node].spec.engine;
      if (!nodes_[buffer.producer_node].on_unit()) continue;
      buffer.unit_local = std::all_of(buffer.consumer_nodes.begin(), buffer.consumer_nodes.end(),
                                      [&](int consumer) { return nodes_[consumer].spec.engine == engine; });
    }
  }
  // DRAM: every buffer lives in DRAM but a unit's internal stage. Inputs are double-buffered (capture
  // writes the next frame while this one is processed); constants, outputs and delayed buffers (two
  // frames) stay live; intermediates live from their producer to their last consumer.
  std::vector<int> position(nodes_.size(), 0);
  for (size_t i = 0; i < order_.size(); ++i) position[order_[i]] = static_cast<int>(i);
  size_t resident = 0;
  std::vector<size_t> live_at(order_.size() + 1, 0);
  for (const BufferInfo& buffer : buffers_) {
    const size_t bytes = buffer.unit_local ? 0 : buffer.bytes();
    if (buffer.is_graph_input) {
      resident += 2 * bytes;
    } else if (buffer.is_constant || buffer.is_graph_output) {
      resident += bytes * (buffer.read_delayed ? 2 : 1);
    } else if (buffer.read_delayed) {
      resident += 2 * bytes;
    } else if (buffer.producer_node >= 0) {
      int first = position[buffer.producer_node];
      int last = first;
      for (int consumer : buffer.consumer_nodes) last = std::max(last, position[consumer]);
      for (int step = first; step <= last; ++step) live_at[step] += bytes;
    }
  }
  dram_peak_bytes_ = resident + *std::max_element(live_at.begin(), live_at.end());
  if (memory.dram_bytes > 0 && dram_peak_bytes_ > memory.dram_bytes) {
    throw VerifyError(kPhaseMemory, "graph '" + spec_.name + "': DRAM peak is " + std::to_string(dram_peak_bytes_) +
                                        " bytes, target '" + memory.target_name + "' gives graphs " +
                                        std::to_string(memory.dram_bytes) + " bytes (over by " +
                                        std::to_string(dram_peak_bytes_ - memory.dram_bytes) + ")");
  }
}

void Graph::phase_node_init() {
  for (const ConstantSpec& constant : spec_.constants) {
    const int index = buffer_index(constant.name);
    const ConstantGeneratorEntry& entry = constant_generators().at(constant.generator);
    try {
      Plane plane = entry.generate(constant.params, options_.frame_width, options_.frame_height);
      if (plane.width() != buffers_[index].shape.width || plane.height() != buffers_[index].shape.height ||
          !(plane.format() == buffers_[index].format)) {
        throw VerifyError(kPhaseInit, "constant '" + constant.name + "': generator '" + constant.generator + "' gave " +
                                          std::to_string(plane.width()) + "x" + std::to_string(plane.height()) + " " +
                                          format_name(plane.format()) + ", expected " +
                                          std::to_string(buffers_[index].shape.width) + "x" +
                                          std::to_string(buffers_[index].shape.height) + " " +
                                          format_name(buffers_[index].format));
      }
      constants_[index] = std::move(plane);
    } catch (const VerifyError&) {
      throw;
    } catch (const std::exception& error) {
      throw VerifyError(kPhaseInit, "constant '" + constant.name + "' (generator '" + constant.generator + "'): " + error.what());
    }
  }
}

std::string Graph::to_dot() const {
  std::ostringstream dot;
  auto quote = [](const std::string& text) {
    std::string quoted = "\"";
    for (char c : text) {
      if (c == '"' || c == '\\') quoted += '\\';
      quoted += c;
    }
    return quoted + "\"";
  };
  dot << "digraph " << quote(spec_.name) << " {\n  rankdir=LR;\n  node [fontname=\"Helvetica\"];\n";
  for (const GraphInputSpec& input : spec_.inputs) {
    dot << "  " << quote("buffer:" + input.name) << " [shape=ellipse, label=" << quote(input.name + "\\n" + format_name(input.format))
        << "];\n";
  }
  for (const ConstantSpec& constant : spec_.constants) {
    dot << "  " << quote("buffer:" + constant.name) << " [shape=note, label=" << quote(constant.name + "\\n" + constant.generator)
        << "];\n";
  }
  for (const NodeSpec& node : spec_.nodes) {
    // Vector nodes blue, ARM tasks orange, nodes on a fixed-function unit green.
    const bool vector = !node.kernel.empty();
    const bool unit = vector && !node.engine.empty();
    const std::string engine = unit ? node.engine + ": " + node.kernel : (vector ? "vector: " + node.kernel : "ARM: " + node.task);
    dot << "  " << quote("node:" + node.name) << " [shape=box, style=filled, fillcolor="
        << (unit ? "\"#a1d99b\"" : (vector ? "\"#9ecae1\"" : "\"#fdae6b\"")) << ", label=" << quote(node.name + "\\n" + engine)
        << "];\n";
  }
  // Edges producer -> consumer through named buffers; intermediate buffers are edge labels.
  std::map<std::string, std::string> producer_of;
  for (const GraphInputSpec& input : spec_.inputs) producer_of[input.name] = "buffer:" + input.name;
  for (const ConstantSpec& constant : spec_.constants) producer_of[constant.name] = "buffer:" + constant.name;
  for (const NodeSpec& node : spec_.nodes) {
    for (const auto& [port, buffer] : node.outputs) producer_of.emplace(buffer, "node:" + node.name);
  }
  for (const NodeSpec& node : spec_.nodes) {
    for (const auto& [port, binding] : node.inputs) {
      auto producer = producer_of.find(binding.buffer);
      const std::string from = producer == producer_of.end() ? "buffer:" + binding.buffer : producer->second;
      dot << "  " << quote(from) << " -> " << quote("node:" + node.name) << " [label=" << quote(binding.buffer)
          << (binding.delayed ? ", style=dashed, constraint=false" : "") << "];\n";
    }
  }
  for (const std::string& output : spec_.outputs) {
    auto producer = producer_of.find(output);
    if (producer == producer_of.end()) continue;
    dot << "  " << quote("output:" + output) << " [shape=ellipse, peripheries=2, label=" << quote(output) << "];\n";
    dot << "  " << quote(producer->second) << " -> " << quote("output:" + output) << ";\n";
  }
  dot << "}\n";
  return dot.str();
}

}  // namespace lpstereo
