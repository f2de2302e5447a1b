// median3x3_s16: 3x3 median of s16 Q4 disparity that keeps invalid pixels invalid, s16q4 -> s16q4.
//
// The rule (parameter invalid_q4, the map's one invalid value, DESIGN.md §4):
//   - an invalid centre stays invalid: the median never invents a disparity where the matcher, its
//     uniqueness test or the left-right check refused one (libSGM runs its median before the LR
//     check for the same reason; a plain median would fill one-pixel LR-check holes);
//   - a valid centre takes the plain median of its nine window values, invalid ones included as
//     values. The invalid value (min_disparity - 1) * 16 sorts below every valid disparity, so the
//     result is invalid exactly when five or more of the nine are invalid (a valid pixel mostly
//     surrounded by invalid ones is a speckle), and otherwise a valid value from the window, taken
//     towards the lower (farther) side by each invalid neighbour: at an occlusion edge that is the
//     background side, where occluded pixels belong.
// So on valid centres this is cv::medianBlur(src, dst, 3) on CV_16S (border replicate) bit for bit,
// what OpenCV users already run on disparity; tests/kernels/median3x3_s16_test.cpp checks that.
// Values below invalid_q4 (no kernel of ours produces them) are plain values like any other.
//
// Ports: input "input" s16q4 (window, halo 1 on every side), output "output" s16q4 of the same
// size. Border modes: replicate and constant (outside pixels take the low 16 bits of border_value;
// set it to invalid_q4 to treat the outside as unknown). Exact: every output is one of the nine
// input values; no rounding, no saturation.
//
// Vector schedule: kernels/median3x3_window.h (the u8 median's network on signed 16-bit lanes), one
// chunk = B::kLanesU16 pixels of an output row. Op count per chunk (closed form, checked by
// tests/kernels/median3x3_s16_test.cpp):
//   load    = 9
//   arith   = 30   (signed min and max)
//   compare = 1    (centre == invalid_q4)
//   logic   = 1    (select the centre where it is invalid)
//   store   = 1
// and per tile 1 broadcast (permute: invalid_q4).
#include <algorithm>
#include <array>

#include "kernels/median3x3_window.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

struct MedianS16Params {
  int16_t invalid_q4;
};

template <class B>
void median3x3_s16_body(const TileArgs& args) {
  using VS16 = typename B::VS16;
  const auto& params = *static_cast<const MedianS16Params*>(args.params);
  const VS16 invalid = B::set1_s16(params.invalid_q4);
  median3x3_tile<B, int16_t>(args, [&](const VS16& centre, const VS16& median) {
    return B::select(B::cmpeq(centre, invalid), centre, median);
  });
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(median3x3_s16, median3x3_s16_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(median3x3_s16)

namespace lpstereo::kernels {
namespace {

void median3x3_s16_counting(const TileArgs& args) { median3x3_s16_body<simd::Counting>(args); }

// Scalar reference: the nine window values (border applied here), sorted; an invalid centre is kept.
void median3x3_s16_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                             const void* params_pointer, BorderMode border_mode, uint32_t border_value) {
  const auto& params = *static_cast<const MedianS16Params*>(params_pointer);
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  auto pixel = [&](int x, int y) -> int16_t {
    if (x < 0 || y < 0 || x >= source.width || y >= source.height) {
      if (border_mode == BorderMode::constant) return static_cast<int16_t>(border_value & 0xFFFFu);
      x = std::clamp(x, 0, source.width - 1);
      y = std::clamp(y, 0, source.height - 1);
    }
    return plane_row<const int16_t>(source, y)[x];
  };
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) {
      const int16_t centre = pixel(x, y);
      if (centre == params.invalid_q4) {
        plane_row<int16_t>(destination, y)[x] = centre;
        continue;
      }
      std::array<int16_t, 9> window{};
      int index = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) window[index++] = pixel(x + dx, y + dy);
      }
      std::sort(window.begin(), window.end());
      plane_row<int16_t>(destination, y)[x] = window[4];
    }
  }
}

PreparedKernel median3x3_s16_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"invalid_q4"});
  auto prepared = std::make_shared<MedianS16Params>();
  prepared->invalid_q4 = static_cast<int16_t>(param_int(params, "invalid_q4", -16, -32768, 32767));
  return PreparedKernel{prepared, {input_shapes.at(0)}};
}

KernelDescriptor make_median3x3_s16() {
  KernelDescriptor descriptor;
  descriptor.name = "median3x3_s16";
  descriptor.summary = "3x3 median of s16 Q4 disparity; an invalid centre stays invalid (param invalid_q4)";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::s16, 4}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::s16, 4}, PortAccess::window}};
  descriptor.halo = {1, 1, 1, 1};
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = median3x3_s16_prepare;
  descriptor.counting = median3x3_s16_counting;
  descriptor.reference = median3x3_s16_reference;
  LPSTEREO_FILL_NATIVE_TABLE(median3x3_s16)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(median3x3_s16, lpstereo::kernels::make_median3x3_s16);
#endif
