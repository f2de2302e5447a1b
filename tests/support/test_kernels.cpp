// Vector kernels that exist for the tests only (scalar native level and counting back end).
//   test_column_running_sum: u8 -> u32, out(x, y) = sum of in(x, 0..y). A row-state kernel: its
//     state is one u32 running sum per column, carried from tile to tile down the frame.
//   test_column_running_sum_bottom_up: the same from the bottom, out(x, y) = sum of in(x, y..H-1):
//     a row-state kernel whose tiles come bottom to top.
#include <algorithm>
#include <vector>

#include "kernels/kernel.h"
#include "kernels/simd/emulated.h"

namespace lpstereo::testing {
namespace {

template <class B, bool kBottomUp>
void column_running_sum_body(const TileArgs& args) {
  const PlaneView& input = args.inputs[0];
  const PlaneView& output = args.outputs[0];
  auto* sums = reinterpret_cast<uint32_t*>(args.state);
  for (int row = 0; row < output.height; ++row) {
    const int y = kBottomUp ? output.height - 1 - row : row;
    const uint8_t* in = plane_row<const uint8_t>(input, y);
    uint32_t* out = plane_row<uint32_t>(output, y);
    for (int x = 0; x < output.width; x += B::kLanesU8) {
      const int lanes = std::min(B::kLanesU8, output.width - x);
      const auto bytes = B::load_partial(in + x, lanes);
      const auto low = B::widen_lo(bytes);
      const auto high = B::widen_hi(bytes);
      const typename B::VU32 words[4] = {B::widen_lo(low), B::widen_hi(low), B::widen_lo(high), B::widen_hi(high)};
      for (int part = 0; part < 4; ++part) {
        const int first = x + part * B::kLanesU32;
        const int count = std::min(B::kLanesU32, output.width - first);
        if (count <= 0) break;
        const auto sum = B::add(B::load_partial(sums + first, count), words[part]);
        B::store_partial(sums + first, sum, count);
        B::store_partial(out + first, sum, count);
      }
    }
  }
}

template <bool kBottomUp>
void column_running_sum_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                  const void*, BorderMode, uint32_t) {
  for (int x = 0; x < outputs[0].width; ++x) {
    uint32_t sum = 0;
    for (int row = 0; row < outputs[0].height; ++row) {
      const int y = kBottomUp ? outputs[0].height - 1 - row : row;
      sum += plane_row<const uint8_t>(inputs[0], y)[x];
      plane_row<uint32_t>(outputs[0], y)[x] = sum;
    }
  }
}

template <bool kBottomUp>
KernelDescriptor make_column_running_sum() {
  KernelDescriptor descriptor;
  descriptor.name = kBottomUp ? "test_column_running_sum_bottom_up" : "test_column_running_sum";
  descriptor.rows_bottom_up = kBottomUp;
  descriptor.summary = "test only: running sum of each column (row state)";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::u32, 0}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = [](const nlohmann::json&, const std::vector<PlaneShape>& shapes) {
    return PreparedKernel{nullptr, {shapes.at(0)}};
  };
  descriptor.state_bytes = [](int width, int, const void*) { return sizeof(uint32_t) * static_cast<size_t>(width); };
  descriptor.native[0] = column_running_sum_body<simd::Scalar, kBottomUp>;
  descriptor.counting = column_running_sum_body<simd::Counting, kBottomUp>;
  descriptor.reference = column_running_sum_reference<kBottomUp>;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::testing

LPSTEREO_REGISTER_KERNEL(test_column_running_sum, lpstereo::testing::make_column_running_sum<false>);
LPSTEREO_REGISTER_KERNEL(test_column_running_sum_bottom_up, lpstereo::testing::make_column_running_sum<true>);
