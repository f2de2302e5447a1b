// ARM task "disparity_coverage": the view check of the obstacle chain on the chip (issue 10;
// arm/obstacles3d/disparity_coverage.h has the why and the measured threshold). The vector engine
// counts each row's invalid disparities (a v_disparity node whose one bin is the bin just below the
// map's range, where only the invalid value (min_disparity - 1) x 16 lands: the smallest valid Q4
// value is min_disparity x 16, kernels/sgm_core.h); this task sums the rows and applies
// arm::obstacles3d::coverage_of_invalid_count, the rule the host command applies to the whole map.
//
// Inputs: "invalid_rows" u16, 1 x H (the v_disparity node's histogram with num_bins 1: row v's
//   invalid count, Q0); "disparity" s16q4, W x H: its shape only, the share's denominator W x H
//   (never read: no work counted for it). W <= 65535, so a row's count never reaches v_disparity's
//   saturation at 65535 pixels, and W x H < 2^32.
// Parameter: degraded_invalid_share (double, (0, 1], default 0.10, DisparityCoverageParameters).
// Output "coverage": 1 x kCoverageWords u32 (arm/tasks/coverage_record.h).
//
// Counted work (ArmWork): per row 1 load and 1 add (2 scalar ops) and 2 bytes read; 8 ops for the
// share and the flag.
#include <string>

#include "arm/obstacles3d/disparity_coverage.h"
#include "arm/tasks/coverage_record.h"
#include "dag/arm_task.h"

namespace lpstereo::arm {
namespace {

constexpr int kMaxRowWidthPx = 65535;  // a row's count fits v_disparity's u16 bin unsaturated

std::string shape_text(const PlaneShape& shape) { return std::to_string(shape.width) + "x" + std::to_string(shape.height); }

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"degraded_invalid_share"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (invalid_rows, disparity), got " + std::to_string(input_shapes.size()));
  }
  const PlaneShape& rows = input_shapes[0];
  const PlaneShape& disparity = input_shapes[1];
  if (rows.width != 1 || rows.height != disparity.height) {
    throw KernelError("input 'invalid_rows': expected 1x" + std::to_string(disparity.height) +
                      " (one count per row of 'disparity': v_disparity with num_bins 1), got " + shape_text(rows));
  }
  if (disparity.width < 1 || disparity.width > kMaxRowWidthPx) {
    throw KernelError("input 'disparity': expected a width in [1, " + std::to_string(kMaxRowWidthPx) +
                      "] (a row's count is a u16 bin), got " + std::to_string(disparity.width));
  }
  auto prepared = std::make_shared<obstacles3d::DisparityCoverageParameters>();
  prepared->degraded_invalid_share =
      param_double(params, "degraded_invalid_share", obstacles3d::DisparityCoverageParameters{}.degraded_invalid_share, 0.0, 1.0);
  if (!(prepared->degraded_invalid_share > 0)) {
    throw KernelError("parameter 'degraded_invalid_share': expected (0, 1], got " + std::to_string(prepared->degraded_invalid_share));
  }
  return PreparedKernel{prepared, {PlaneShape{kCoverageWords, 1}}};
}

void run(const ArmTaskArgs& args) {
  const auto& parameters = *static_cast<const obstacles3d::DisparityCoverageParameters*>(args.params);
  const Plane& rows = *args.inputs.at(0);
  const Plane& disparity = *args.inputs.at(1);
  int64_t invalid_pixels = 0;
  for (int y = 0; y < rows.height(); ++y) invalid_pixels += rows.row<uint16_t>(y)[0];
  const int64_t pixels = static_cast<int64_t>(disparity.width()) * disparity.height();
  const obstacles3d::DisparityCoverage coverage = obstacles3d::coverage_of_invalid_count(invalid_pixels, pixels, parameters);
  uint32_t* out = args.outputs.at(0)->row<uint32_t>(0);
  out[kCoverageInvalidPixels] = static_cast<uint32_t>(coverage.invalid_pixels);
  out[kCoveragePixels] = static_cast<uint32_t>(coverage.pixels);
  out[kCoverageInvalidPer65536] = coverage_share_per_65536(coverage.invalid_pixels, coverage.pixels);
  out[kCoverageDegraded] = coverage.degraded ? 1u : 0u;
  if (args.work != nullptr) {
    args.work->scalar_ops += 2 * static_cast<uint64_t>(rows.height()) + 8;
    args.work->memory_bytes += 2 * static_cast<uint64_t>(rows.height());
  }
}

ArmTaskDescriptor make_disparity_coverage() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "disparity_coverage";
  descriptor.summary = "the view check: the share of invalid disparities from per-row counts, and the degraded flag";
  descriptor.ports = {{"invalid_rows", PortDirection::input, {ElementType::u16, 0}, PortAccess::whole},
                      {"disparity", PortDirection::input, {ElementType::s16, 4}, PortAccess::whole},
                      {"coverage", PortDirection::output, {ElementType::u32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(disparity_coverage, lpstereo::arm::make_disparity_coverage);
