#include "kernels/kernel.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace lpstereo {

std::string_view border_mode_name(BorderMode mode) {
  switch (mode) {
    case BorderMode::replicate: return "replicate";
    case BorderMode::constant: return "constant";
  }
  return "unknown";
}

uint8_t reference_pixel_u8(const PlaneView& plane, int x, int y, BorderMode border_mode, uint32_t border_value) {
  if (x < 0 || y < 0 || x >= plane.width || y >= plane.height) {
    if (border_mode == BorderMode::constant) return static_cast<uint8_t>(border_value);
    x = std::clamp(x, 0, plane.width - 1);
    y = std::clamp(y, 0, plane.height - 1);
  }
  return plane_row<const uint8_t>(plane, y)[x];
}

PixelRect window_input_rect(const Halo& halo, const InputScale& scale, int tile_x, int tile_y, int tile_width,
                            int tile_height) {
  auto floor_scaled = [&](int value) { return static_cast<int>((static_cast<int64_t>(value) * scale.numerator) / scale.denominator); };
  auto ceil_scaled = [&](int value) {
    return static_cast<int>((static_cast<int64_t>(value) * scale.numerator + scale.denominator - 1) / scale.denominator);
  };
  return PixelRect{floor_scaled(tile_x) - halo.left, floor_scaled(tile_y) - halo.top,
                   ceil_scaled(tile_x + tile_width) + halo.right, ceil_scaled(tile_y + tile_height) + halo.bottom};
}

int KernelDescriptor::input_count() const {
  return static_cast<int>(std::count_if(ports.begin(), ports.end(),
                                        [](const PortSpec& port) { return port.direction == PortDirection::input; }));
}

int KernelDescriptor::output_count() const { return static_cast<int>(ports.size()) - input_count(); }

TileFunction KernelDescriptor::native_for(simd::Isa isa) const {
  for (int level = static_cast<int>(isa); level >= 0; --level) {
    if (native[level] != nullptr) return native[level];
  }
  return nullptr;
}

KernelRegistry& KernelRegistry::instance() {
  static KernelRegistry registry;
  return registry;
}

void KernelRegistry::add(KernelDescriptor descriptor) {
  if (find(descriptor.name) != nullptr) {
    throw std::logic_error("kernel '" + descriptor.name + "' registered twice");
  }
  if (descriptor.native[0] == nullptr || descriptor.counting == nullptr || !descriptor.reference ||
      !descriptor.prepare) {
    throw std::logic_error("kernel '" + descriptor.name +
                           "' lacks a scalar native, counting, reference or prepare function");
  }
  kernels_.push_back(std::make_unique<KernelDescriptor>(std::move(descriptor)));
}

const KernelDescriptor* KernelRegistry::find(const std::string& name) const {
  for (const auto& kernel : kernels_) {
    if (kernel->name == name) return kernel.get();
  }
  return nullptr;
}

std::vector<std::string> KernelRegistry::names() const {
  std::vector<std::string> result;
  for (const auto& kernel : kernels_) result.push_back(kernel->name);
  std::sort(result.begin(), result.end());
  return result;
}

int param_int(const nlohmann::json& params, const char* name, int default_value, int min_value, int max_value) {
  if (!params.is_object() || !params.contains(name)) return default_value;
  const nlohmann::json& value = params.at(name);
  if (!value.is_number_integer()) {
    throw KernelError(std::string("parameter '") + name + "': expected an integer in [" + std::to_string(min_value) +
                      ", " + std::to_string(max_value) + "], got " + value.dump());
  }
  const int64_t number = value.get<int64_t>();
  if (number < min_value || number > max_value) {
    throw KernelError(std::string("parameter '") + name + "': expected an integer in [" + std::to_string(min_value) +
                      ", " + std::to_string(max_value) + "], got " + std::to_string(number));
  }
  return static_cast<int>(number);
}

double param_double(const nlohmann::json& params, const char* name, double default_value, double min_value,
                    double max_value) {
  if (!params.is_object() || !params.contains(name)) return default_value;
  const nlohmann::json& value = params.at(name);
  if (!value.is_number() || !std::isfinite(value.get<double>()) || value.get<double>() < min_value ||
      value.get<double>() > max_value) {
    std::ostringstream message;
    message << "parameter '" << name << "': expected a number in [" << min_value << ", " << max_value << "], got "
            << value.dump();
    throw KernelError(message.str());
  }
  return value.get<double>();
}

void check_param_names(const nlohmann::json& params, const std::vector<std::string>& known) {
  if (params.is_null()) return;
  if (!params.is_object()) throw KernelError("parameters: expected a JSON object, got " + params.dump());
  for (const auto& item : params.items()) {
    if (std::find(known.begin(), known.end(), item.key()) == known.end()) {
      std::string list;
      for (const std::string& name : known) list += (list.empty() ? "" : ", ") + name;
      throw KernelError("unknown parameter '" + item.key() + "' (known: " + (list.empty() ? "none" : list) + ")");
    }
  }
}

}  // namespace lpstereo
