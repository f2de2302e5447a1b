// census_wta_disparity: local stereo matching on 5x5 census signatures, winner takes all.
//
// For each left pixel x and each disparity d in [min_disparity, min_disparity + num_disparities),
// the matching cost is the Hamming distance between left census(x) and right census(x - d); the
// disparity with the lowest cost wins (ties: the smallest d). min_disparity may be negative. No aggregation and no sub-pixel step: this is the matching-cost
// stage of the disparity engine on its own, the baseline the SGM engine improves on.
//
// Ports: "left" census32, "right" census32 (window access; the right view needs
// min_disparity + num_disparities - 1 columns to the left of the tile and -min_disparity to its
// right, replicate border), output "disparity" s16 Q4.
// Output: d * 16 (Q4, no fraction bits used); invalid = (min_disparity - 1) * 16 (DESIGN.md §4)
// where the best cost exceeds max_cost_bits (a weak match). |d| < 2048 keeps d * 16 in s16.
//
// Vector schedule: one chunk = 2 x kLanesU32 pixels (two u32 halves, narrowed to one s16 vector).
// Op count per chunk, D = num_disparities (closed form, tests/kernels/census_wta_disparity_test.cpp):
//   load = 2 + 2 D; logic = 2 D (xor) + 2 D (select) + 2 (invalid select); popcount = 2 D;
//   compare = 2 D + 2; arith = 2 D (min) + 2 D (disparity += 1); shift = 2; permute = 1 (narrow);
//   store = 1; plus 6 broadcasts (permute) per tile.
#include <cstdint>
#include <vector>

#include "kernels/census_cost.h"
#include "kernels/kernel.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

struct CensusWtaParams {
  int min_disparity;   // pixels; the search covers [min_disparity, min_disparity + num_disparities)
  int num_disparities;
  int max_cost_bits;   // a best cost above this many differing bits gives an invalid pixel
};

// The one invalid value of the output (DESIGN.md §4).
constexpr int32_t invalid_disparity_q4(const CensusWtaParams& params) { return (params.min_disparity - 1) * 16; }

template <class B>
void census_wta_disparity_body(const TileArgs& args) {
  using VU32 = typename B::VU32;
  constexpr int kHalf = B::kLanesU32;
  constexpr int kChunk = 2 * kHalf;
  const auto& params = *static_cast<const CensusWtaParams*>(args.params);
  const PlaneView& left = args.inputs[0];
  const PlaneView& right = args.inputs[1];
  const PlaneView& output = args.outputs[0];
  const int width = output.width;

  const VU32 all_ones = B::set1_u32(0xFFFFFFFFu);
  const VU32 one = B::set1_u32(1);
  const VU32 zero = B::set1_u32(0);
  const VU32 max_cost = B::set1_u32(static_cast<uint32_t>(params.max_cost_bits));
  const VU32 invalid = B::set1_u32(static_cast<uint32_t>(invalid_disparity_q4(params)));
  const VU32 first_disparity = B::set1_u32(static_cast<uint32_t>(params.min_disparity));
  // Readable right-view columns end at width + the right halo (-min_disparity when negative).
  const int readable_end = width + (params.min_disparity < 0 ? -params.min_disparity : 0);

  for (int y = 0; y < output.height; ++y) {
    const uint32_t* left_row = plane_row<const uint32_t>(left, y);
    const uint32_t* right_row = plane_row<const uint32_t>(right, y);
    int16_t* out_row = plane_row<int16_t>(output, y);
    for (int x = 0; x < width; x += kChunk) {
      VU32 result[2];
      for (int half = 0; half < 2; ++half) {
        const int first = x + half * kHalf;
        // Left columns readable: [first, width); right: [first - max_d, readable_end).
        const int lanes = width - first >= kHalf ? kHalf : (width - first > 0 ? width - first : 0);
        const VU32 signature = lanes == kHalf ? B::load(left_row + first) : B::load_partial(left_row + first, lanes);
        VU32 best_cost = all_ones;
        VU32 best_disparity = zero;
        VU32 disparity = first_disparity;
        for (int step = 0; step < params.num_disparities; ++step) {
          const int d = params.min_disparity + step;
          const int readable = readable_end - (first - d);
          const VU32 candidate = readable >= kHalf ? B::load(right_row + first - d)
                                                   : B::load_partial(right_row + first - d, readable > 0 ? readable : 0);
          const VU32 cost = census_hamming<B>(signature, candidate);
          const VU32 better = B::cmplt(cost, best_cost);
          best_cost = B::min(best_cost, cost);
          best_disparity = B::select(better, disparity, best_disparity);
          disparity = B::add(disparity, one);
        }
        const VU32 disparity_q4 = B::template shl<4>(best_disparity);
        result[half] = B::select(B::cmpgt(best_cost, max_cost), invalid, disparity_q4);
      }
      const typename B::VS16 packed = B::narrow_sat_s16(B::as_s32(result[0]), B::as_s32(result[1]));
      const int remaining = width - x;
      if (remaining >= kChunk) {
        B::store(out_row + x, packed);
      } else {
        B::store_partial(out_row + x, packed, remaining);
      }
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(census_wta_disparity, census_wta_disparity_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(census_wta_disparity)

namespace lpstereo::kernels {
namespace {

void census_wta_disparity_counting(const TileArgs& args) { census_wta_disparity_body<simd::Counting>(args); }

void census_wta_disparity_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                    const void* params_pointer, BorderMode /*border_mode*/, uint32_t /*border_value*/) {
  const auto& params = *static_cast<const CensusWtaParams*>(params_pointer);
  const PlaneView& left = inputs[0];
  const PlaneView& right = inputs[1];
  const PlaneView& output = outputs[0];
  for (int y = 0; y < output.height; ++y) {
    for (int x = 0; x < output.width; ++x) {
      int best_cost = 1 << 30;
      int best_disparity = params.min_disparity;
      for (int d = params.min_disparity; d < params.min_disparity + params.num_disparities; ++d) {
        const int cost = census_cost_reference(left, right, 4, x, y, d);
        if (cost < best_cost) {
          best_cost = cost;
          best_disparity = d;
        }
      }
      plane_row<int16_t>(output, y)[x] =
          best_cost > params.max_cost_bits ? static_cast<int16_t>(invalid_disparity_q4(params)) : static_cast<int16_t>(best_disparity * 16);
    }
  }
}

PreparedKernel census_wta_disparity_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"min_disparity", "num_disparities", "max_cost_bits"});
  auto prepared = std::make_shared<CensusWtaParams>();
  prepared->min_disparity = param_int(params, "min_disparity", 0, -2047, 2046);
  prepared->num_disparities = param_int(params, "num_disparities", 64, 1, 2047 - prepared->min_disparity);
  prepared->max_cost_bits = param_int(params, "max_cost_bits", 8, 0, 24);
  if (!(input_shapes.at(0) == input_shapes.at(1))) {
    throw KernelError("port 'right': expected the left view's size " + std::to_string(input_shapes[0].width) + "x" +
                      std::to_string(input_shapes[0].height) + ", got " + std::to_string(input_shapes[1].width) + "x" +
                      std::to_string(input_shapes[1].height));
  }
  PreparedKernel result{prepared, {input_shapes.at(0)}, {}};
  const int max_disparity = prepared->min_disparity + prepared->num_disparities - 1;
  result.input_halos = {Halo{}, Halo{max_disparity > 0 ? max_disparity : 0, prepared->min_disparity < 0 ? -prepared->min_disparity : 0, 0, 0}};
  return result;
}

KernelDescriptor make_census_wta_disparity() {
  KernelDescriptor descriptor;
  descriptor.name = "census_wta_disparity";
  descriptor.summary = "winner-takes-all disparity from 5x5 census Hamming costs (s16 Q4, invalid (min_disparity - 1) * 16)";
  descriptor.ports = {{"left", PortDirection::input, {ElementType::census32, 0}, PortAccess::window},
                      {"right", PortDirection::input, {ElementType::census32, 0}, PortAccess::window},
                      {"disparity", PortDirection::output, {ElementType::s16, 4}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = census_wta_disparity_prepare;
  descriptor.counting = census_wta_disparity_counting;
  descriptor.reference = census_wta_disparity_reference;
  LPSTEREO_FILL_NATIVE_TABLE(census_wta_disparity)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(census_wta_disparity, lpstereo::kernels::make_census_wta_disparity);
#endif
