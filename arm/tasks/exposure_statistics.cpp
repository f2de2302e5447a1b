// ARM task "exposure_statistics": the per-frame luma statistics an auto-exposure loop reads (mean,
// share of under- and over-exposed pixels), from a u8 image subsampled on a grid, as an ARM core
// would do it on a DRAM-resident frame.
//
// Output: a 1 x 4 u32 plane: [0] mean luma in Q8 (value / 256 = grey level), [1] dark pixels per
// 65536 (luma <= dark_level), [2] bright pixels per 65536 (luma >= bright_level), [3] samples taken.
//
// Counted work (deterministic, ArmWork): per sample 4 scalar ops (load, add, two compares) and 1
// byte read; the grid step keeps the touched cache lines to one in step_px rows.
#include "dag/arm_task.h"

namespace lpstereo::arm {
namespace {

struct ExposureParams {
  int step_px;
  int dark_level;
  int bright_level;
};

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"step_px", "dark_level", "bright_level"});
  auto prepared = std::make_shared<ExposureParams>();
  prepared->step_px = param_int(params, "step_px", 4, 1, 64);
  prepared->dark_level = param_int(params, "dark_level", 16, 0, 255);
  prepared->bright_level = param_int(params, "bright_level", 240, 0, 255);
  if (prepared->dark_level >= prepared->bright_level) {
    throw KernelError("parameter 'dark_level': expected < bright_level (" + std::to_string(prepared->bright_level) +
                      "), got " + std::to_string(prepared->dark_level));
  }
  (void)input_shapes;
  return PreparedKernel{prepared, {PlaneShape{4, 1}}};
}

void run(const ArmTaskArgs& args) {
  const auto& params = *static_cast<const ExposureParams*>(args.params);
  const Plane& image = *args.inputs.at(0);
  uint64_t sum = 0, dark = 0, bright = 0, samples = 0;
  for (int y = params.step_px / 2; y < image.height(); y += params.step_px) {
    const uint8_t* row = image.row<uint8_t>(y);
    for (int x = params.step_px / 2; x < image.width(); x += params.step_px) {
      const int luma = row[x];
      sum += static_cast<uint64_t>(luma);
      dark += luma <= params.dark_level ? 1 : 0;
      bright += luma >= params.bright_level ? 1 : 0;
      ++samples;
    }
  }
  uint32_t* out = args.outputs.at(0)->row<uint32_t>(0);
  out[0] = samples ? static_cast<uint32_t>((sum * 256 + samples / 2) / samples) : 0;
  out[1] = samples ? static_cast<uint32_t>((dark * 65536) / samples) : 0;
  out[2] = samples ? static_cast<uint32_t>((bright * 65536) / samples) : 0;
  out[3] = static_cast<uint32_t>(samples);
  if (args.work != nullptr) {
    args.work->scalar_ops += 4 * samples;
    args.work->memory_bytes += samples;
  }
}

ArmTaskDescriptor make_exposure_statistics() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "exposure_statistics";
  descriptor.summary = "mean luma and under/over-exposed shares of a u8 image, for auto-exposure";
  descriptor.ports = {{"image", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"statistics", PortDirection::output, {ElementType::u32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(exposure_statistics, lpstereo::arm::make_exposure_statistics);
