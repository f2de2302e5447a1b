// An ARM-side task: ordinary C++ over small data, run by the ARM-side scheduler on one of the ARM
// cores. Its simulated cost must be deterministic, so a task counts its own work in ArmWork units
// (documented per task) instead of being timed; the target's ARM model turns the counts into cycles
// (host_sim/cost_model.h).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dag/plane.h"
#include "kernels/kernel.h"

namespace lpstereo {

// Work an ARM task did, by kind. The target gives cycles per unit of each kind.
struct ArmWork {
  uint64_t scalar_ops = 0;   // ALU / branch operations on registers
  uint64_t memory_bytes = 0; // bytes read or written from DRAM-resident buffers (cache-miss bound)
  ArmWork& operator+=(const ArmWork& other) {
    scalar_ops += other.scalar_ops;
    memory_bytes += other.memory_bytes;
    return *this;
  }
};

struct ArmTaskArgs {
  std::vector<const Plane*> inputs;  // in port order
  std::vector<Plane*> outputs;       // in port order, allocated by the graph with prepared shapes
  const void* params = nullptr;
  ArmWork* work = nullptr;           // add what the task did
};

struct ArmTaskDescriptor {
  std::string name;
  std::string summary;
  std::vector<PortSpec> ports;  // inputs first, then outputs; access is ignored
  // Validates parameters and input shapes, returns prepared parameters and output shapes. Throws KernelError.
  std::function<PreparedKernel(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes)> prepare;
  std::function<void(const ArmTaskArgs& args)> run;

  int input_count() const;
  int output_count() const;
};

class ArmTaskRegistry {
 public:
  static ArmTaskRegistry& instance();
  void add(ArmTaskDescriptor descriptor);
  const ArmTaskDescriptor* find(const std::string& name) const;
  std::vector<std::string> names() const;

 private:
  std::vector<std::unique_ptr<ArmTaskDescriptor>> tasks_;
};

namespace detail {
struct ArmTaskRegistrar {
  explicit ArmTaskRegistrar(ArmTaskDescriptor (*make)()) { ArmTaskRegistry::instance().add(make()); }
};
}  // namespace detail

}  // namespace lpstereo

#define LPSTEREO_REGISTER_ARM_TASK(identifier, make_function) \
  static const ::lpstereo::detail::ArmTaskRegistrar lpstereo_arm_task_registrar_##identifier(make_function)
