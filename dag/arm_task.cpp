#include "dag/arm_task.h"

#include <algorithm>
#include <stdexcept>

namespace lpstereo {

int ArmTaskDescriptor::input_count() const {
  return static_cast<int>(std::count_if(ports.begin(), ports.end(),
                                        [](const PortSpec& port) { return port.direction == PortDirection::input; }));
}

int ArmTaskDescriptor::output_count() const { return static_cast<int>(ports.size()) - input_count(); }

ArmTaskRegistry& ArmTaskRegistry::instance() {
  static ArmTaskRegistry registry;
  return registry;
}

void ArmTaskRegistry::add(ArmTaskDescriptor descriptor) {
  if (find(descriptor.name) != nullptr) throw std::logic_error("ARM task '" + descriptor.name + "' registered twice");
  if (!descriptor.prepare || !descriptor.run) {
    throw std::logic_error("ARM task '" + descriptor.name + "' lacks a prepare or run function");
  }
  tasks_.push_back(std::make_unique<ArmTaskDescriptor>(std::move(descriptor)));
}

const ArmTaskDescriptor* ArmTaskRegistry::find(const std::string& name) const {
  for (const auto& task : tasks_) {
    if (task->name == name) return task.get();
  }
  return nullptr;
}

std::vector<std::string> ArmTaskRegistry::names() const {
  std::vector<std::string> result;
  for (const auto& task : tasks_) result.push_back(task->name);
  std::sort(result.begin(), result.end());
  return result;
}

}  // namespace lpstereo
