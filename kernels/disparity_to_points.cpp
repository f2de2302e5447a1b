// disparity_to_points: s16 Q4 disparity -> the camera-frame point of every pixel, three s32 planes
// in millimetres (kernels/disparity_to_points.h declares the format and the "no point" value).
//
// The geometry (rectified pinhole pair, Hartley & Zisserman, "Multiple View Geometry", 2nd ed.,
// §9.3 and the Q matrix of OpenCV's stereoRectify / reprojectImageTo3D; DESIGN.md §4):
//   x = b (u - u0) / d,   y = b (v - v0) / d,   z = b f / d
// with b the baseline, f the focal length in px, (u0, v0) the principal point of the rectified
// left view, d the disparity in px. With d_q4 = 16 d and the principal point on the same 1/16 px
// grid (u0_q4 = round(16 u0), du_q4 = 16 u - u0_q4) the 16s cancel:
//   x_mm = b_mm du_q4 / d_q4,   y_mm = b_mm dv_q4 / d_q4,   z_mm = 16 b_mm f / d_q4.
//
// No divide op in the simd contract, so the divisions are tables indexed by d_q4 (built by prepare,
// never from frame data; 4 u16 per entry, 8 bytes per Q4 disparity, 16 KiB for a 256 px range):
//   W(d_q4) = round(2^15 b_mm / d_q4)       Q15 mm per Q4 pixel, < 2^30 since b <= 32 m, d_q4 >= 1;
//                                           stored as its 15-bit halves Wh = W >> 15, Wl = W & 0x7FFF;
//   Z(d_q4) = min(round(16 b_mm f / d_q4), 2^31 - 1)   z in mm, saturated; stored as u16 halves.
// With a disparity offset (Middlebury's doffs: the right view's principal point doffs px right of
// the left one's, Z = f B / (d + doffs)) every d_q4 in the formulas and tables becomes
// d_q4 + 16 doffs: the table is indexed by the measured disparity and holds the offset one's
// values, at no cost per pixel; pixels whose d_q4 + 16 doffs < 1 have no point (so W < 2^30 holds).
// Entries 0 (d <= 0: no finite point), dmax_q4 + 1 (above the range) and the invalid marker
// (min_disparity - 1) * 16 when it is positive carry the flag Wh = 0x8000 (valid Wh < 2^15): the
// kernel clamps d_q4 to [0, dmax_q4 + 1], gathers, and one compare finds every pixel with no point.
// dmax_q4 = 16 (min_disparity + num_disparities): one pixel above the searched range, room for the
// sub-pixel step above the last whole disparity.
//
// x and y without a 64-bit product (mullo is the low 32 bits): W du = Wh du 2^15 + Wl du, so
//   x = Wh du + ((Wl du + 2^14) >> 15) = floor((W du + 2^14) / 2^15) = round-half-up(W du / 2^15),
// exactly (Wh du 2^15 is a multiple of 2^15; >> is arithmetic). No overflow, by the parameter limits
// prepare enforces (|du_q4|, |dv_q4| <= 2^16 over the image; b <= 32 m so W < 2^30, Wh < 2^15):
//   |Wh du| <= (2^15 - 1) 2^16 = 2^31 - 2^16;   |Wl du + 2^14| <= (2^15 - 1) 2^16 + 2^14 < 2^31;
//   the sum is the rounded quotient itself, so no intermediate exceeds the result:
//   |x| <= round(2^15 32000 / 1) 2^16 / 2^15 + 1/2 = 2,097,152,000.5 mm < 2^31 - 2^25 (b = 32 m,
//   |du_q4| = 2^16, d_q4 = 1), and x never reaches the no-point value INT32_MIN.
// (Lanes past the row's end compute garbage in wrapping arithmetic and are never stored.)
//
// Error bound against double precision (tests/kernels/disparity_to_points_test.cpp checks it for
// every Q4 disparity of the largest range):
//   |z - 16 b_mm f / d_q4| <= 0.5 mm (unsaturated);
//   |x - b_mm du_q4 / d_q4| <= 0.5 + |du_q4| / 2^16 <= 1.5 mm (table rounding <= 1/2 in Q15, times
//   |du_q4| <= 2^16, plus the final rounding); the same for y.
// Against the real principal point, its rounding to 1/16 px adds at most b / (32 d) = z / (32 f)
// to |x| and |y|: 1/32 px of lateral offset, far below the uncertainty of a calibrated u0.
//
// Ports: input "disparity" s16q4 (window, no halo); outputs "x", "y", "z" s32 (fraction bits 0,
// millimetres), same size. Border modes: replicate (unused: no halo). Parameters: baseline_m (0, 32],
// focal_px (0, 1e5], u0_px, v0_px (the rectified left view's principal point, px),
// min_disparity (the map's; gives the invalid marker), num_disparities (1 .. 2047 - min_disparity),
// disparity_offset_px (doffs, default 0).
//
// Vector schedule: one chunk = B::kLanesU32 pixels of a row (s16 loaded, widened to s32). Op count
// per chunk (closed form, checked by tests/kernels/disparity_to_points_test.cpp):
//   load     = 1   (disparity)
//   permute  = 1   (widen_lo)
//   arith    = 7   (clamp: max, min; x: 2 adds; y: 2 adds; du += 16 L)
//   gather   = 4   (Wh, Wl, Zl, Zh)
//   compare  = 1   (Wh > 0x7FFF: no point)
//   multiply = 4   (Wh du, Wl du, Wh dv, Wl dv)
//   shift    = 3   (Zh << 16, two >> 15)
//   logic    = 4   (Zh | Zl, three selects of the no-point value)
//   store    = 3
// per tile row 2 permutes (broadcast u and v offsets) and 1 arith (plus the lane ramp), per tile
// 6 permutes (constants) and 1 load (the lane ramp).
#include "kernels/disparity_to_points.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

// What the tile body reads: plain data (see PlaneView for why). The tables belong to the
// PreparedTables object the params pointer is aliased into.
struct DisparityToPointsParams {
  int32_t u0_q4 = 0;
  int32_t v0_q4 = 0;
  int32_t index_end = 0;  // dmax_q4 + 1: the flagged entry above the range
  const uint16_t* factor_high = nullptr;  // Wh, 0x8000 = no point
  const uint16_t* factor_low = nullptr;   // Wl
  const uint16_t* depth_low = nullptr;    // Z & 0xFFFF
  const uint16_t* depth_high = nullptr;   // Z >> 16
  // For prepare and the reference only (the body reads the tables):
  double baseline_mm = 0;
  double focal_px = 0;
  double offset_q4 = 0;          // 16 disparity_offset_px
  int32_t invalid_q4 = 0;        // (min_disparity - 1) * 16
  int32_t max_disparity_q4 = 0;  // dmax_q4
};

// Lane i holds 16 i: the Q4 column offset of lane i from the chunk's first pixel.
alignas(64) constexpr int32_t kLaneOffsetQ4[16] = {0, 16, 32, 48, 64, 80, 96, 112, 128, 144, 160, 176, 192, 208, 224, 240};

template <class B>
void disparity_to_points_body(const TileArgs& args) {
  using VS32 = typename B::VS32;
  using VU32 = typename B::VU32;
  constexpr int kLanes = B::kLanesU32;
  static_assert(kLanes <= 16, "kLaneOffsetQ4 covers 16 s32 lanes");
  const auto& params = *static_cast<const DisparityToPointsParams*>(args.params);
  const PlaneView& disparity = args.inputs[0];
  const int width = args.outputs[0].width;
  const int height = args.outputs[0].height;

  const VS32 lane_offset_q4 = B::load(kLaneOffsetQ4);
  const VS32 zero = B::set1_s32(0);
  const VS32 index_end = B::set1_s32(params.index_end);
  const VS32 rounding = B::set1_s32(1 << (kPointFactorFractionBits - 1));
  const VS32 largest_factor_high = B::set1_s32(0x7FFF);
  const VS32 no_point = B::set1_s32(kNoPointMm);
  const VS32 chunk_step_q4 = B::set1_s32(16 * kLanes);

  for (int y = 0; y < height; ++y) {
    const int16_t* disparity_row = plane_row<const int16_t>(disparity, y);
    int32_t* x_row = plane_row<int32_t>(args.outputs[0], y);
    int32_t* y_row = plane_row<int32_t>(args.outputs[1], y);
    int32_t* z_row = plane_row<int32_t>(args.outputs[2], y);
    VS32 du_q4 = B::add(B::set1_s32(16 * args.tile_x - params.u0_q4), lane_offset_q4);
    const VS32 dv_q4 = B::set1_s32(16 * (args.tile_y + y) - params.v0_q4);
    for (int x = 0; x < width; x += kLanes) {
      const VS32 d_q4 = B::widen_lo(load_clipped<B>(disparity_row, x, width));
      const VS32 index = B::min(B::max(d_q4, zero), index_end);
      const VS32 factor_high = B::as_s32(B::gather_u16(params.factor_high, index));
      const VS32 factor_low = B::as_s32(B::gather_u16(params.factor_low, index));
      const VU32 depth_low = B::gather_u16(params.depth_low, index);
      const VU32 depth_high = B::gather_u16(params.depth_high, index);
      const VS32 missing = B::cmpgt(factor_high, largest_factor_high);
      // Wh du + ((Wl du + 2^14) >> 15): round(W du / 2^15) exactly, in 32-bit lanes (header).
      auto scaled = [&](const VS32& offset_q4) {
        return B::add(B::mullo(factor_high, offset_q4),
                      B::template shr<kPointFactorFractionBits>(B::add(B::mullo(factor_low, offset_q4), rounding)));
      };
      const VS32 point_x = scaled(du_q4);
      const VS32 point_y = scaled(dv_q4);
      const VS32 point_z = B::as_s32(B::bit_or(B::template shl<16>(depth_high), depth_low));
      store_clipped<B>(x_row, x, width, B::select(missing, no_point, point_x));
      store_clipped<B>(y_row, x, width, B::select(missing, no_point, point_y));
      store_clipped<B>(z_row, x, width, B::select(missing, no_point, point_z));
      du_q4 = B::add(du_q4, chunk_step_q4);
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(disparity_to_points, disparity_to_points_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(disparity_to_points)

namespace lpstereo::kernels {
namespace {

// The prepared parameters and the tables they point into.
struct PreparedTables {
  DisparityToPointsParams params;
  std::vector<uint16_t> factor_high, factor_low, depth_low, depth_high;
};

// W(d_q4) = round(2^15 b_mm / (d_q4 + 16 doffs)), denominator >= 1 (header).
int64_t factor_q15(const DisparityToPointsParams& params, int32_t d_q4) {
  return std::llround(std::ldexp(params.baseline_mm, kPointFactorFractionBits) / (d_q4 + params.offset_q4));
}

// Z(d_q4) = round(16 b_mm f / (d_q4 + 16 doffs)), saturated to the s32 range (header).
int64_t depth_mm(const DisparityToPointsParams& params, int32_t d_q4) {
  const double z_mm = 16.0 * params.baseline_mm * params.focal_px / (d_q4 + params.offset_q4);
  return z_mm >= 2147483647.0 ? int64_t{2147483647} : std::llround(z_mm);
}

bool has_point(const DisparityToPointsParams& params, int32_t d_q4) {
  return d_q4 >= 1 && d_q4 <= params.max_disparity_q4 && d_q4 != params.invalid_q4 && d_q4 + params.offset_q4 >= 1.0;
}

void disparity_to_points_counting(const TileArgs& args) { disparity_to_points_body<simd::Counting>(args); }

// Scalar reference: the formulas of the header in 64-bit integers, no split of W.
void disparity_to_points_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                   const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const DisparityToPointsParams*>(params_pointer);
  const PlaneView& disparity = inputs[0];
  for (int v = 0; v < disparity.height; ++v) {
    for (int u = 0; u < disparity.width; ++u) {
      const int32_t d_q4 = plane_row<const int16_t>(disparity, v)[u];
      int32_t point[3] = {kNoPointMm, kNoPointMm, kNoPointMm};
      if (has_point(params, d_q4)) {
        const int64_t factor = factor_q15(params, d_q4);
        const int64_t du_q4 = 16 * u - params.u0_q4;
        const int64_t dv_q4 = 16 * v - params.v0_q4;
        // floor((W du + 2^14) / 2^15): >> on a negative int64 is arithmetic in C++20.
        point[0] = static_cast<int32_t>((factor * du_q4 + (int64_t{1} << 14)) >> kPointFactorFractionBits);
        point[1] = static_cast<int32_t>((factor * dv_q4 + (int64_t{1} << 14)) >> kPointFactorFractionBits);
        point[2] = static_cast<int32_t>(depth_mm(params, d_q4));
      }
      for (int c = 0; c < 3; ++c) plane_row<int32_t>(outputs[static_cast<size_t>(c)], v)[u] = point[c];
    }
  }
}

// |16 i - offset_q4| for i in [0, size) must stay <= 2^16 (the no-overflow proof).
void check_offset_range(const char* name, double centre_px, int size, int32_t centre_q4) {
  const int64_t largest = std::max<int64_t>(std::abs(int64_t{0} - centre_q4), std::abs(16 * int64_t{size - 1} - centre_q4));
  if (largest > kMaxPointOffsetQ4) {
    throw KernelError("parameter '" + std::string(name) + "': |16 (pixel - " + name + ")| over an image of " +
                      std::to_string(size) + " px must stay <= " + std::to_string(kMaxPointOffsetQ4) + " (4096 px), got " +
                      std::to_string(largest) + " with " + name + " = " + std::to_string(centre_px));
  }
}

PreparedKernel disparity_to_points_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params,
                    {"baseline_m", "focal_px", "u0_px", "v0_px", "min_disparity", "num_disparities", "disparity_offset_px"});
  auto tables = std::make_shared<PreparedTables>();
  const double baseline_m = param_double(params, "baseline_m", 0.0, 1e-6, kMaxPointBaselineM);
  tables->params.baseline_mm = 1000.0 * baseline_m;
  tables->params.focal_px = param_double(params, "focal_px", 0.0, 1e-3, 1e5);
  const double u0_px = param_double(params, "u0_px", 0.0, -1e5, 1e5);
  const double v0_px = param_double(params, "v0_px", 0.0, -1e5, 1e5);
  const int min_disparity = param_int(params, "min_disparity", 0, -kMaxPointDisparityPx, kMaxPointDisparityPx - 1);
  const int num_disparities = param_int(params, "num_disparities", 64, 1, kMaxPointDisparityPx - min_disparity);
  tables->params.offset_q4 = 16.0 * param_double(params, "disparity_offset_px", 0.0, -kMaxPointDisparityPx, kMaxPointDisparityPx);
  if (min_disparity + num_disparities < 1) {
    throw KernelError("parameters 'min_disparity' + 'num_disparities': expected a range reaching a positive disparity "
                      "(sum >= 1), got " + std::to_string(min_disparity) + " + " + std::to_string(num_disparities));
  }
  const PlaneShape shape = input_shapes.at(0);
  tables->params.u0_q4 = static_cast<int32_t>(std::lround(16.0 * u0_px));
  tables->params.v0_q4 = static_cast<int32_t>(std::lround(16.0 * v0_px));
  check_offset_range("u0_px", u0_px, shape.width, tables->params.u0_q4);
  check_offset_range("v0_px", v0_px, shape.height, tables->params.v0_q4);
  DisparityToPointsParams& plain = tables->params;
  plain.invalid_q4 = (min_disparity - 1) * 16;
  plain.max_disparity_q4 = 16 * (min_disparity + num_disparities);
  plain.index_end = plain.max_disparity_q4 + 1;

  const size_t entries = static_cast<size_t>(tables->params.index_end) + 1;
  tables->factor_high.assign(entries, 0x8000);
  tables->factor_low.assign(entries, 0);
  tables->depth_low.assign(entries, 0);
  tables->depth_high.assign(entries, 0);
  for (int32_t d_q4 = 1; d_q4 <= plain.max_disparity_q4; ++d_q4) {
    if (!has_point(plain, d_q4)) continue;
    const auto factor = static_cast<uint32_t>(factor_q15(plain, d_q4));
    const auto depth = static_cast<uint32_t>(depth_mm(plain, d_q4));
    const auto index = static_cast<size_t>(d_q4);
    tables->factor_high[index] = static_cast<uint16_t>(factor >> kPointFactorFractionBits);
    tables->factor_low[index] = static_cast<uint16_t>(factor & 0x7FFFu);
    tables->depth_low[index] = static_cast<uint16_t>(depth & 0xFFFFu);
    tables->depth_high[index] = static_cast<uint16_t>(depth >> 16);
  }
  tables->params.factor_high = tables->factor_high.data();
  tables->params.factor_low = tables->factor_low.data();
  tables->params.depth_low = tables->depth_low.data();
  tables->params.depth_high = tables->depth_high.data();
  // The tile body sees only the plain part; the aliasing pointer keeps the tables alive with it.
  return PreparedKernel{std::shared_ptr<const void>(tables, &tables->params), {shape, shape, shape}};
}

KernelDescriptor make_disparity_to_points() {
  const BufferFormat millimetres{ElementType::s32, 0};
  KernelDescriptor descriptor;
  descriptor.name = "disparity_to_points";
  descriptor.summary = "s16 Q4 disparity -> camera-frame x, y, z per pixel, s32 mm (reciprocal tables, no divide)";
  descriptor.ports = {{"disparity", PortDirection::input, {ElementType::s16, 4}, PortAccess::window},
                      {"x", PortDirection::output, millimetres, PortAccess::window},
                      {"y", PortDirection::output, millimetres, PortAccess::window},
                      {"z", PortDirection::output, millimetres, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = disparity_to_points_prepare;
  descriptor.counting = disparity_to_points_counting;
  descriptor.reference = disparity_to_points_reference;
  LPSTEREO_FILL_NATIVE_TABLE(disparity_to_points)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(disparity_to_points, lpstereo::kernels::make_disparity_to_points);
#endif
