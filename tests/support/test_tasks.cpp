// ARM tasks that exist for the tests only (linked into test binaries, never into the tool).
//   test_frame_counter: "previous" u32 (any shape) -> "count" u32 1x1 = previous[0] + 1.
//     Wired to itself through a delayed edge it counts frames; it counts 1 unit of scalar work.
#include "dag/arm_task.h"

namespace lpstereo::testing {
namespace {

ArmTaskDescriptor make_test_frame_counter() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "test_frame_counter";
  descriptor.summary = "test only: count = previous + 1";
  descriptor.ports = {{"previous", PortDirection::input, {ElementType::u32, 0}, PortAccess::whole},
                      {"count", PortDirection::output, {ElementType::u32, 0}, PortAccess::whole}};
  descriptor.prepare = [](const nlohmann::json& params, const std::vector<PlaneShape>&) {
    check_param_names(params, {});
    return PreparedKernel{nullptr, {PlaneShape{1, 1}}};
  };
  descriptor.run = [](const ArmTaskArgs& args) {
    args.outputs[0]->at<uint32_t>(0, 0) = args.inputs[0]->at<uint32_t>(0, 0) + 1;
    if (args.work) args.work->scalar_ops += 1;
  };
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::testing

LPSTEREO_REGISTER_ARM_TASK(test_frame_counter, lpstereo::testing::make_test_frame_counter);
