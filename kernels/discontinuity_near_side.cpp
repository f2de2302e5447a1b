// discontinuity_near_side: drops the near side of every disparity jump, s16q4 -> s16q4. The vector
// engine's form of arm::invalidate_near_side_of_discontinuities (arm/terrain_points.h), with the same
// bits: a window matcher gives the background pixels beside a nearer object the object's disparity
// (foreground fattening; Hirschmueller and Scharstein 2009, §2); their 3D points would stand in the
// air beside the object, the false obstacle points of the terrain segmentation (docs/terrain.md).
//
// Parameters: invalid_q4 (the map's invalid value (min_disparity - 1) x 16, DESIGN.md §4; default
//   -16, in [-32768, 32766]), radius_px (1 .. 8, default 3), jump_q4 (the jump in Q4, 1 .. 32767,
//   default 32 = 2 px; the host function's jump_px becomes ceil(16 jump_px)).
// Rule: a value v is valid when v > invalid_q4 (invalid_q4 and everything below it are not). With
//   m the smallest valid value of the (2 radius + 1)^2 window around a valid pixel, the pixel becomes
//   invalid_q4 when v - m > jump_q4; every other pixel (invalid ones, and windows with nothing valid
//   but the centre's own value) is copied. Exact: no arithmetic reaches the output.
// Ports: input "input" s16q4 (window, halo radius_px on every side), output "output" s16q4 of the
//   same size. Border: replicate only. A replicated pixel repeats an edge pixel the window already
//   holds, so the window is in effect clipped to the image, as in the host function.
//
// Fixed point: the minimum is taken over t(v) = v - (invalid_q4 + 1) in u16 lanes (wrapping sub).
//   For invalid_q4 = I, valid v in [I + 1, 32767] map to [0, 32766 - I] and every v <= I to
//   [32767 - I, 65535]: above every valid one, so an unsigned minimum is the smallest VALID value
//   whenever the window holds one, with no compare and no select. The test t(v) > adds(M, jump_q4)
//   (saturating u16 add) equals v - m > jump_q4 for valid v and m, and is false when M is not
//   valid (M >= 32767 - I > t(v)) or the sum saturates (t(v) <= 65534 and then v - m <= jump_q4).
//   An invalid centre is excluded by its own compare (s16 v > I).
//
// Vector schedule (L = B::kLanesU16), per output row, two passes over scratch:
//   1. columns -radius .. width + radius - 1, L at a time: the 2 radius + 1 input rows loaded, t()
//      applied (sub) and reduced by unsigned min: the column minimum, stored to scratch;
//   2. columns 0 .. width - 1, L at a time: the 2 radius + 1 scratch vectors at offsets -radius ..
//      +radius reduced by min (the window minimum M); the centre loaded, t(centre) (sub),
//      adds(M, jump_q4), cmpgt (u16), cmpgt(centre, I) (s16), and, select, store.
// Op count (closed form, checked by tests/kernels/discontinuity_near_side_test.cpp), with
// R = 2 radius + 1, C1 = ceil((tile_width + 2 radius) / L), C2 = ceil(tile_width / L), per tile row:
//   load    = R C1 + (R + 1) C2
//   arith   = (2R - 1) C1 + (R + 1) C2     (pass 1: R subs, R - 1 mins; pass 2: R - 1 mins, 1 sub, 1 adds)
//   compare = 2 C2
//   logic   = 2 C2                          (and, select)
//   store   = C1 + C2
// and per tile 3 broadcasts (permute: invalid_q4 + 1, jump_q4, invalid_q4). Scratch: the column
// minima of one row, tile_width + 2 radius u16 rounded up to the widest vector.
#include <algorithm>
#include <string>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int kMaxRadiusPx = 8;

struct NearSideParams {
  int16_t invalid_q4 = -16;
  int radius_px = 3;
  int jump_q4 = 32;
};

template <class B>
void discontinuity_near_side_body(const TileArgs& args) {
  using VU16 = typename B::VU16;
  using VS16 = typename B::VS16;
  constexpr int kLanes = B::kLanesU16;
  const auto& params = *static_cast<const NearSideParams*>(args.params);
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int radius = params.radius_px;
  const int readable_end = width + radius;  // the right halo's last column is the last readable one
  const int scratch_end = width + 2 * radius;
  uint16_t* column_minimum = reinterpret_cast<uint16_t*>(args.scratch);  // index = column + radius

  const VU16 valid_base = B::set1_u16(static_cast<uint16_t>(params.invalid_q4 + 1));
  const VU16 jump = B::set1_u16(static_cast<uint16_t>(params.jump_q4));
  const VS16 invalid = B::set1_s16(params.invalid_q4);
  for (int y = 0; y < destination.height; ++y) {
    // Pass 1: the unsigned minimum of t(v) down each column of the window.
    for (int x = -radius; x < readable_end; x += kLanes) {
      VU16 lowest = B::sub(B::as_u16(load_clipped<B>(plane_row<const int16_t>(source, y - radius), x, readable_end)), valid_base);
      for (int dy = -radius + 1; dy <= radius; ++dy) {
        const VU16 value = B::sub(B::as_u16(load_clipped<B>(plane_row<const int16_t>(source, y + dy), x, readable_end)), valid_base);
        lowest = B::min(lowest, value);
      }
      store_clipped<B>(column_minimum, x + radius, scratch_end, lowest);
    }
    // Pass 2: the window minimum along the row, and the jump test.
    const int16_t* centre_row = plane_row<const int16_t>(source, y);
    int16_t* out_row = plane_row<int16_t>(destination, y);
    for (int x = 0; x < width; x += kLanes) {
      VU16 window = load_clipped<B>(column_minimum, x, scratch_end);
      for (int dx = 1; dx <= 2 * radius; ++dx) window = B::min(window, load_clipped<B>(column_minimum, x + dx, scratch_end));
      const VS16 centre = load_clipped<B>(centre_row, x, readable_end);
      const VU16 beyond = B::cmpgt(B::sub(B::as_u16(centre), valid_base), B::adds(window, jump));
      const VU16 near_side = B::bit_and(beyond, B::as_u16(B::cmpgt(centre, invalid)));
      store_clipped<B>(out_row, x, width, B::select(B::as_s16(near_side), invalid, centre));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(discontinuity_near_side, discontinuity_near_side_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(discontinuity_near_side)

namespace lpstereo::kernels {
namespace {

void discontinuity_near_side_counting(const TileArgs& args) { discontinuity_near_side_body<simd::Counting>(args); }

constexpr int kMaxLanesU16 = 32;  // the widest back end's u16 lanes (512-bit), sizes scratch

size_t scratch_elements(int tile_width, int radius_px) {
  const int columns = tile_width + 2 * radius_px;
  return static_cast<size_t>((columns + kMaxLanesU16 - 1) / kMaxLanesU16 * kMaxLanesU16);
}

// Scalar reference: the rule as written, the window clipped to the image (which the replicate border
// gives the vector body), in plain int arithmetic.
void discontinuity_near_side_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                       const void* params_pointer, BorderMode /*border_mode*/, uint32_t /*border_value*/) {
  const auto& params = *static_cast<const NearSideParams*>(params_pointer);
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  const int width = source.width, height = source.height, radius = params.radius_px;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const int value = plane_row<const int16_t>(source, y)[x];
      int16_t result = static_cast<int16_t>(value);
      if (value > params.invalid_q4) {
        int lowest = value;  // the centre is valid and in its own window
        for (int v = std::max(0, y - radius); v <= std::min(height - 1, y + radius); ++v) {
          for (int u = std::max(0, x - radius); u <= std::min(width - 1, x + radius); ++u) {
            const int other = plane_row<const int16_t>(source, v)[u];
            if (other > params.invalid_q4) lowest = std::min(lowest, other);
          }
        }
        if (value - lowest > params.jump_q4) result = params.invalid_q4;
      }
      plane_row<int16_t>(destination, y)[x] = result;
    }
  }
}

PreparedKernel discontinuity_near_side_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"invalid_q4", "radius_px", "jump_q4"});
  auto prepared = std::make_shared<NearSideParams>();
  prepared->invalid_q4 = static_cast<int16_t>(param_int(params, "invalid_q4", -16, -32768, 32766));
  prepared->radius_px = param_int(params, "radius_px", 3, 1, kMaxRadiusPx);
  prepared->jump_q4 = param_int(params, "jump_q4", 32, 1, 32767);
  const int radius = prepared->radius_px;
  PreparedKernel result{prepared, {input_shapes.at(0)}};
  result.input_halos = {Halo{radius, radius, radius, radius}};
  return result;
}

KernelDescriptor make_discontinuity_near_side() {
  KernelDescriptor descriptor;
  descriptor.name = "discontinuity_near_side";
  descriptor.summary =
      "drops the near side of every disparity jump (s16 Q4): a valid pixel more than jump_q4 above the smallest valid value "
      "within radius_px becomes invalid_q4 (the fattened object edges)";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::s16, 4}, PortAccess::window},
                      {"output", PortDirection::output, {ElementType::s16, 4}, PortAccess::window}};
  descriptor.halo = {kMaxRadiusPx, kMaxRadiusPx, kMaxRadiusPx, kMaxRadiusPx};  // the largest; prepare gives the real one
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = discontinuity_near_side_prepare;
  descriptor.scratch_bytes = [](int tile_width, int /*tile_height*/, const void* params) {
    return scratch_elements(tile_width, static_cast<const NearSideParams*>(params)->radius_px) * sizeof(uint16_t);
  };
  descriptor.counting = discontinuity_near_side_counting;
  descriptor.reference = discontinuity_near_side_reference;
  LPSTEREO_FILL_NATIVE_TABLE(discontinuity_near_side)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(discontinuity_near_side, lpstereo::kernels::make_discontinuity_near_side);
#endif
