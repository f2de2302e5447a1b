// harris_nms: non-maximum suppression of a corner response (kernels/harris_response.cpp), s32 -> u8
// corner mask (thesis 003 §3.5, fig. 3.7: Harris corners after non-maximum suppression).
//
// Ports: input "response" s32 (any Q format; window, halo = radius on every side), output "corners"
//   u8 of the same size: 1 = corner, 0 = not (no other value).
// Parameters: radius (1 or 2, default 1: a 3x3 or 5x5 neighbourhood), threshold (s32 in the
//   response's units, 0 .. 2^31 - 1, default 10000). harris_response's R grows with contrast^4: the
//   peak R at the corner of a step of C grey levels (a quarter plane), default window 3 and k = 3/64,
//   is 73 (C = 10), 1,156 (20), 18,824 (40), 95,703 (60), 739,714 (100), 9,647,256 (190); so the
//   default keeps corners of about 35 grey levels and more.
// Rule: (x, y) is a corner when R(x, y) > threshold and, over its (2 radius + 1)^2 - 1 neighbours,
//   R(x, y) > R(neighbour) for the neighbours BEFORE it in raster order (rows above, and the same
//   row to its left) and R(x, y) >= R(neighbour) for those AFTER it. Ties thus go to the first
//   pixel in raster order: a plateau of equal responses gives one corner, at its first pixel, as long
//   as each of its other pixels has an equal neighbour before it within the radius, as in
//   rectangles, straight lines and other convex plateaus; a plateau with two separate tops (a U
//   opening upwards whose arms are more than `radius` apart) gives one corner per top.
//   threshold >= 0, so harris_response's zero border band never holds a corner.
// Border: neighbours outside the image are the executor's halo, per border mode: replicate (a copy
//   of the edge pixel: equal, so a pixel of the first row or column, whose copies come BEFORE it, is
//   never a corner; one of the last row or column can be) or constant (border_value as an s32).
//
// Vector schedule, per chunk of L8 = B::kLanesU8 pixels of an output row (4 sub-chunks of L32 =
// L8 / 4 s32 pixels): per sub-chunk the centre and the n = (2 radius + 1)^2 - 1 neighbours loaded,
// the mask started with cmpgt(centre, threshold) and per neighbour one compare (cmpgt one way or the
// other) and one logic (and, or andnot for the "after" side); then the four masks narrowed to u8
// (narrow s32 -> s16 twice, u16 -> u8 once: all-ones lanes give 255), and-ed with 1, one store.
// Op count (closed form, checked by tests/kernels/harris_nms_test.cpp), per chunk:
//   load = 4 (n + 1), compare = 4 (n + 1), logic = 4 n + 1, permute = 3, store = 1
// and per tile 2 broadcasts (permute: the threshold and the u8 one). ceil(tile_width / L8) chunks
// per tile row.
#include <string>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

struct HarrisNmsParams {
  int radius = 1;
  int32_t threshold = 10000;
};

template <class B, int kRadius>
void harris_nms_tile(const TileArgs& args) {
  using VS32 = typename B::VS32;
  using VU8 = typename B::VU8;
  constexpr int kLanes8 = B::kLanesU8;
  constexpr int kLanes32 = B::kLanesU32;
  static_assert(kLanes8 == 4 * kLanes32);
  const auto& params = *static_cast<const HarrisNmsParams*>(args.params);
  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int readable_end = width + kRadius;
  const VS32 threshold = B::set1_s32(params.threshold);
  const VU8 one = B::set1_u8(1);

  for (int y = 0; y < destination.height; ++y) {
    const int32_t* rows[2 * kRadius + 1];
    for (int dy = -kRadius; dy <= kRadius; ++dy) rows[dy + kRadius] = plane_row<const int32_t>(source, y + dy);
    uint8_t* out_row = plane_row<uint8_t>(destination, y);
    for (int x = 0; x < width; x += kLanes8) {
      VS32 masks[4];
      for (int part = 0; part < 4; ++part) {
        const int column = x + part * kLanes32;
        const VS32 centre = load_clipped<B>(rows[kRadius], column, readable_end);
        VS32 corner = B::cmpgt(centre, threshold);
        for (int dy = -kRadius; dy <= kRadius; ++dy) {
          for (int dx = -kRadius; dx <= kRadius; ++dx) {
            if (dx == 0 && dy == 0) continue;
            const VS32 neighbour = load_clipped<B>(rows[dy + kRadius], column + dx, readable_end);
            const bool before = dy < 0 || (dy == 0 && dx < 0);
            if (before) {
              corner = B::bit_and(corner, B::cmpgt(centre, neighbour));  // strictly greater than earlier ones
            } else {
              corner = B::bit_andnot(B::cmpgt(neighbour, centre), corner);  // not smaller than later ones
            }
          }
        }
        masks[part] = corner;
      }
      const VU8 bytes = B::narrow_sat_u8(B::as_u16(B::narrow_sat_s16(masks[0], masks[1])),
                                         B::as_u16(B::narrow_sat_s16(masks[2], masks[3])));
      store_clipped<B>(out_row, x, width, B::bit_and(bytes, one));
    }
  }
}

template <class B>
void harris_nms_body(const TileArgs& args) {
  if (static_cast<const HarrisNmsParams*>(args.params)->radius == 1) {
    harris_nms_tile<B, 1>(args);
  } else {
    harris_nms_tile<B, 2>(args);
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(harris_nms, harris_nms_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(harris_nms)

namespace lpstereo::kernels {
namespace {

void harris_nms_counting(const TileArgs& args) { harris_nms_body<simd::Counting>(args); }

// Scalar reference: the rule of the header, outside pixels per border mode.
void harris_nms_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                          const void* params_pointer, BorderMode border_mode, uint32_t border_value) {
  const auto& params = *static_cast<const HarrisNmsParams*>(params_pointer);
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  auto response = [&](int x, int y) -> int32_t {
    if (x < 0 || y < 0 || x >= source.width || y >= source.height) {
      if (border_mode == BorderMode::constant) return static_cast<int32_t>(border_value);
      x = x < 0 ? 0 : (x >= source.width ? source.width - 1 : x);
      y = y < 0 ? 0 : (y >= source.height ? source.height - 1 : y);
    }
    return plane_row<const int32_t>(source, y)[x];
  };
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) {
      const int32_t centre = response(x, y);
      bool corner = centre > params.threshold;
      for (int dy = -params.radius; dy <= params.radius && corner; ++dy) {
        for (int dx = -params.radius; dx <= params.radius && corner; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const int32_t neighbour = response(x + dx, y + dy);
          const bool before = dy < 0 || (dy == 0 && dx < 0);
          corner = before ? centre > neighbour : centre >= neighbour;
        }
      }
      plane_row<uint8_t>(destination, y)[x] = corner ? 1 : 0;
    }
  }
}

PreparedKernel harris_nms_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"radius", "threshold"});
  if (input_shapes.size() != 1) throw KernelError("inputs: expected 1 (response), got " + std::to_string(input_shapes.size()));
  auto prepared = std::make_shared<HarrisNmsParams>();
  prepared->radius = param_int(params, "radius", 1, 1, 2);
  prepared->threshold = param_int(params, "threshold", 10000, 0, 2147483647);
  PreparedKernel result{prepared, {input_shapes[0]}};
  result.input_halos = {Halo{prepared->radius, prepared->radius, prepared->radius, prepared->radius}};
  return result;
}

KernelDescriptor make_harris_nms() {
  KernelDescriptor descriptor;
  descriptor.name = "harris_nms";
  descriptor.summary =
      "non-maximum suppression of a corner response (3x3 or 5x5, ties to the first pixel in raster order) above a threshold: u8 mask of 0/1";
  descriptor.ports = {{"response", PortDirection::input, {ElementType::s32, 0}, PortAccess::window},
                      {"corners", PortDirection::output, {ElementType::u8, 0}, PortAccess::window}};
  descriptor.halo = {2, 2, 2, 2};  // radius 2; radius 1 prepares a halo of 1
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = harris_nms_prepare;
  descriptor.counting = harris_nms_counting;
  descriptor.reference = harris_nms_reference;
  LPSTEREO_FILL_NATIVE_TABLE(harris_nms)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(harris_nms, lpstereo::kernels::make_harris_nms);
#endif
