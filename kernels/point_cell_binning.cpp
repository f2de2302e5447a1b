// point_cell_binning: the per-point half of the 2.5D terrain sampling (issue 9 deliverable 1; thesis
// 004): camera-frame points (the s32 mm planes of disparity_to_points) -> each pixel's cell of the
// terrain grid and its vehicle-frame height. The ARM side (arm::terrain::HeightGridAccumulator::
// add_to_cell, arm/tasks/terrain_estimate.cpp) then sums the points per cell. Output format:
// kernels/point_cell_binning.h.
//
// The geometry (arm/point_cloud.h): p_vehicle = R C p_camera + T, vehicle frame x forward, y left,
// z up; the grid of arm/terrain/terrain_model.h: cell (i, j) covers x in [forward_min + i c,
// forward_min + (i + 1) c), y in [lateral_min + j c, ...), the area is [forward_min, forward_max) x
// [lateral_min, lateral_max), c the cell size. In integers (mm, rotation in Q14):
//   v_k  = floor((sum_l r_kl p_l + 2^13) / 2^14) + t_k          (round half up of R p, plus T)
//   n_x  = v_x - forward_min,   n_y = v_y - lateral_min
//   inside  iff  0 <= n_x < F_x and 0 <= n_y < F_y  (F = max - min, the extents)
//   cell = floor(n_x / c) * lateral_cells + floor(n_y / c),   lateral_cells = ceil(F_y / c)
//   height = v_z
// A pixel with no point (kNoPointMm), a point with a camera coordinate outside [-65536, 65535] mm
// (kBinningRangeMm: beyond the range the proof covers; a stereo point that far is metres uncertain
// and prepare requires the area to lie inside that range) or outside the area gets cell = kNoCell
// (-1) and height = kNoPointMm.
//
// Formats: inputs s32 mm (fraction 0, kNoPointMm = INT32_MIN = no point); rotation_q14 s32 Q14
// (value / 16384), row-major; translation_mm, area bounds, cell_mm integers in mm; outputs s32 cell
// index (kNoCell = -1) and s32 mm height (kNoPointMm where no cell). No saturation anywhere: every
// value stays in range by the bounds below.
//
// No overflow (s32 lanes, wrapping arithmetic; lanes of rejected points compute garbage that the
// final select discards):
//   range test without abs (abs(INT32_MIN) overflows): a = p ^ (p >> 31) is p for p >= 0 and
//   -p - 1 for p < 0 (INT32_MIN -> INT32_MAX), so a <= 65535 iff p in [-65536, 65535]; the three a's
//   are combined with max and tested once.
//   For accepted points |p_l| <= 2^16 and prepare requires sum_l |r_kl| <= 32767 per row, so
//   |sum r p + 2^13| <= 32767 * 2^16 + 2^13 = 2,147,426,304 < 2^31 - 1 (partial sums are smaller);
//   a rotation row has sum |r| <= sqrt(3) 2^14 = 28378 (Cauchy-Schwarz), so every rotation passes.
//   |v_k| <= 2^17 + |t_k| with |t_k| <= 2^20; n = v - min with |min| <= 2^20: |n| < 2^22.
// The divisions by c without a divide op (multiply by a reciprocal, then one correction step):
//   s = 17 (2^17 = kMaxBinningExtentMm >= every extent F), m = floor(2^s / c);
//   q = (n m) >> s is floor(n / c) or one less: 0 <= n / c - n m / 2^s = n (2^s - m c) / (c 2^s)
//   < n / 2^s < 1 for 0 <= n < F <= 2^s; then r = n - q c, and q += 1 where r > c - 1. Exact for
//   every inside point (tests check every n of the largest area against integer division).
//   n m <= (F - 1) m <= (2^17 - 1) 2^17 / 16 < 2^30 for inside lanes, since c >= kMinBinningCellMm
//   = 16 (prepare checks (F - 1) m < 2^31 itself as well); q c <= n < 2^17.
//   The index i * lateral_cells + j < forward_cells * lateral_cells <= (2^17 / 16)^2 = 2^26.
//
// Ports: inputs "x", "y", "z" s32 mm (window, no halo); outputs "cell", "height" s32, same size.
// Border modes: replicate (unused: no halo). Parameters: rotation_q14 (9 integers, row-major R C,
// default the level camera's axis change C: x_v = z_c, y_v = -x_c, z_v = -y_c), translation_mm (3
// integers, the camera centre in the vehicle frame, default 0), forward_min_mm (default 0),
// forward_max_mm (34000), lateral_min_mm (-11000), lateral_max_mm (11000), cell_mm (500).
//
// Vector schedule: one chunk = B::kLanesU32 pixels of a row. Op count per chunk (closed form,
// checked by tests/kernels/point_cell_binning_test.cpp):
//   load     = 3   (x, y, z)
//   shift    = 8   (3 sign spreads p >> 31, 3 rotation >> 14, 2 reciprocal >> s)
//   logic    = 9   (3 xor of the range test, 4 or of the inside test, 2 selects)
//   arith    = 22  (2 max of the range test; 3 x (2 adds + rounding + offset) = 12 for the rotation;
//                   3 subs of the inside test; 2 x (r = n - q c, q -= mask) = 4; 1 add of the index)
//   compare  = 3   (outside; 2 corrections r > c - 1)
//   multiply = 14  (9 rotation, 2 x 2 for the divisions, 1 i * lateral_cells)
//   store    = 2
// per tile 23 permutes (the broadcast constants: 9 rotation entries, 3 offsets, rounding, the
// range limit, 2 extents - 1, reciprocal, cell, cell - 1, lateral_cells, zero, the no-cell and the
// no-point values), nothing per tile row.
#include "kernels/point_cell_binning.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "kernels/disparity_to_points.h"
#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

// What the tile body reads: plain data.
struct PointCellBinningParams {
  int32_t rotation_q14[9] = {};
  int32_t forward_offset_mm = 0;  // t_x - forward_min
  int32_t lateral_offset_mm = 0;  // t_y - lateral_min
  int32_t height_offset_mm = 0;   // t_z
  int32_t forward_extent_mm = 0;  // F_x
  int32_t lateral_extent_mm = 0;  // F_y
  int32_t cell_mm = 0;
  int32_t lateral_cells = 0;
  int32_t reciprocal = 0;         // m = floor(2^17 / c)
};

// s of the reciprocal m = floor(2^s / c): 2^17 = kMaxBinningExtentMm >= every extent.
constexpr int kReciprocalShift = 17;

template <class B>
void point_cell_binning_body(const TileArgs& args) {
  using VS32 = typename B::VS32;
  const auto& params = *static_cast<const PointCellBinningParams*>(args.params);
  const int width = args.outputs[0].width;
  const int height = args.outputs[0].height;

  VS32 rotation[9];
  for (int k = 0; k < 9; ++k) rotation[k] = B::set1_s32(params.rotation_q14[k]);
  const VS32 offset[3] = {B::set1_s32(params.forward_offset_mm), B::set1_s32(params.lateral_offset_mm),
                          B::set1_s32(params.height_offset_mm)};
  const VS32 rounding = B::set1_s32(1 << (kRotationFractionBits - 1));
  const VS32 range_limit = B::set1_s32(kBinningRangeMm);
  const VS32 forward_last = B::set1_s32(params.forward_extent_mm - 1);
  const VS32 lateral_last = B::set1_s32(params.lateral_extent_mm - 1);
  const VS32 reciprocal = B::set1_s32(params.reciprocal);
  const VS32 cell = B::set1_s32(params.cell_mm);
  const VS32 cell_last = B::set1_s32(params.cell_mm - 1);
  const VS32 lateral_cells = B::set1_s32(params.lateral_cells);
  const VS32 zero = B::set1_s32(0);
  const VS32 no_cell = B::set1_s32(kNoCell);
  const VS32 no_point = B::set1_s32(kNoPointMm);

  // floor(n / c) for 0 <= n < F: reciprocal estimate, then one upward correction (header).
  auto divide_by_cell = [&](const VS32& n) {
    const VS32 estimate = B::template shr<kReciprocalShift>(B::mullo(n, reciprocal));
    const VS32 remainder = B::sub(n, B::mullo(estimate, cell));
    return B::sub(estimate, B::cmpgt(remainder, cell_last));  // mask is -1 where the estimate is one short
  };

  for (int y = 0; y < height; ++y) {
    const int32_t* rows[3] = {plane_row<const int32_t>(args.inputs[0], y), plane_row<const int32_t>(args.inputs[1], y),
                              plane_row<const int32_t>(args.inputs[2], y)};
    int32_t* cell_row = plane_row<int32_t>(args.outputs[0], y);
    int32_t* height_row = plane_row<int32_t>(args.outputs[1], y);
    for (int x = 0; x < width; x += B::kLanesU32) {
      VS32 point[3];
      for (int l = 0; l < 3; ++l) point[l] = load_clipped<B>(rows[l], x, width);
      // a = p ^ (p >> 31): |p| for p >= 0, -p - 1 below (no abs of INT32_MIN); the largest of three.
      VS32 magnitude[3];
      for (int l = 0; l < 3; ++l) magnitude[l] = B::bit_xor(point[l], B::template shr<31>(point[l]));
      const VS32 largest = B::max(B::max(magnitude[0], magnitude[1]), magnitude[2]);
      VS32 vehicle[3];
      for (int k = 0; k < 3; ++k) {
        const VS32 sum = B::add(B::add(B::mullo(rotation[3 * k], point[0]), B::mullo(rotation[3 * k + 1], point[1])),
                                B::mullo(rotation[3 * k + 2], point[2]));
        vehicle[k] = B::add(B::template shr<kRotationFractionBits>(B::add(sum, rounding)), offset[k]);
      }
      // Every term >= 0 exactly when the point is in range and inside: one sign test of their OR.
      const VS32 signs = B::bit_or(B::bit_or(B::bit_or(B::bit_or(vehicle[0], B::sub(forward_last, vehicle[0])), vehicle[1]),
                                             B::sub(lateral_last, vehicle[1])),
                                   B::sub(range_limit, largest));
      const VS32 outside = B::cmpgt(zero, signs);
      const VS32 index = B::add(B::mullo(divide_by_cell(vehicle[0]), lateral_cells), divide_by_cell(vehicle[1]));
      store_clipped<B>(cell_row, x, width, B::select(outside, no_cell, index));
      store_clipped<B>(height_row, x, width, B::select(outside, no_point, vehicle[2]));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(point_cell_binning, point_cell_binning_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(point_cell_binning)

namespace lpstereo::kernels {
namespace {

void point_cell_binning_counting(const TileArgs& args) { point_cell_binning_body<simd::Counting>(args); }

// floor(a / b) for b > 0 in 64-bit integers.
int64_t floor_divide(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// Scalar reference: the formulas of the header in 64-bit integers with true integer division.
void point_cell_binning_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                  const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const PointCellBinningParams*>(params_pointer);
  for (int v = 0; v < inputs[0].height; ++v) {
    for (int u = 0; u < inputs[0].width; ++u) {
      int64_t point[3];
      bool in_range = true;
      for (int l = 0; l < 3; ++l) {
        point[l] = plane_row<const int32_t>(inputs[static_cast<size_t>(l)], v)[u];
        in_range = in_range && point[l] >= -int64_t{kBinningRangeMm} - 1 && point[l] <= kBinningRangeMm;
      }
      const int64_t offsets[3] = {params.forward_offset_mm, params.lateral_offset_mm, params.height_offset_mm};
      int64_t vehicle[3];
      for (int k = 0; k < 3; ++k) {
        int64_t sum = 0;
        for (int l = 0; l < 3; ++l) sum += int64_t{params.rotation_q14[3 * k + l]} * point[l];
        vehicle[k] = floor_divide(sum + (int64_t{1} << (kRotationFractionBits - 1)), int64_t{1} << kRotationFractionBits) + offsets[k];
      }
      const bool inside = in_range && vehicle[0] >= 0 && vehicle[0] < params.forward_extent_mm && vehicle[1] >= 0 &&
                          vehicle[1] < params.lateral_extent_mm;
      plane_row<int32_t>(outputs[0], v)[u] =
          inside ? static_cast<int32_t>(vehicle[0] / params.cell_mm * params.lateral_cells + vehicle[1] / params.cell_mm) : kNoCell;
      plane_row<int32_t>(outputs[1], v)[u] = inside ? static_cast<int32_t>(vehicle[2]) : kNoPointMm;
    }
  }
}

// An integer array parameter of `count` entries in [min_value, max_value], or the default.
std::array<int32_t, 9> param_int_array(const nlohmann::json& params, const char* name, const std::array<int32_t, 9>& default_value,
                                       size_t count, int32_t min_value, int32_t max_value) {
  std::array<int32_t, 9> result = default_value;
  if (!params.contains(name)) return result;
  const nlohmann::json& value = params.at(name);
  if (!value.is_array() || value.size() != count) {
    throw KernelError("parameter '" + std::string(name) + "': expected an array of " + std::to_string(count) +
                      " integers, got " + value.dump());
  }
  for (size_t i = 0; i < count; ++i) {
    if (!value[i].is_number_integer() || value[i].get<int64_t>() < min_value || value[i].get<int64_t>() > max_value) {
      throw KernelError("parameter '" + std::string(name) + "' entry " + std::to_string(i) + ": expected an integer in [" +
                        std::to_string(min_value) + ", " + std::to_string(max_value) + "], got " + value[i].dump());
    }
    result[i] = value[i].get<int32_t>();
  }
  return result;
}

PreparedKernel point_cell_binning_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"rotation_q14", "translation_mm", "forward_min_mm", "forward_max_mm", "lateral_min_mm",
                             "lateral_max_mm", "cell_mm"});
  const PlaneShape shape = input_shapes.at(0);
  for (size_t i = 1; i < 3; ++i) {
    if (input_shapes.at(i).width != shape.width || input_shapes.at(i).height != shape.height) {
      throw KernelError("input " + std::to_string(i) + ": expected the size of input 0 (" + std::to_string(shape.width) + "x" +
                        std::to_string(shape.height) + "), got " + std::to_string(input_shapes[i].width) + "x" +
                        std::to_string(input_shapes[i].height));
    }
  }
  auto prepared = std::make_shared<PointCellBinningParams>();
  const std::array<int32_t, 9> rotation = param_int_array(params, "rotation_q14", {0, 0, 16384, -16384, 0, 0, 0, -16384, 0}, 9,
                                                          -kMaxRotationRowSumQ14, kMaxRotationRowSumQ14);
  for (int k = 0; k < 3; ++k) {
    const int64_t row_sum = int64_t{std::abs(rotation[3 * k])} + std::abs(rotation[3 * k + 1]) + std::abs(rotation[3 * k + 2]);
    if (row_sum > kMaxRotationRowSumQ14) {
      throw KernelError("parameter 'rotation_q14' row " + std::to_string(k) + ": expected sum of |entries| <= " +
                        std::to_string(kMaxRotationRowSumQ14) + " (a rotation has at most 28378), got " + std::to_string(row_sum));
    }
  }
  for (int k = 0; k < 9; ++k) prepared->rotation_q14[k] = rotation[static_cast<size_t>(k)];
  const std::array<int32_t, 9> translation =
      param_int_array(params, "translation_mm", {}, 3, -kMaxBinningOffsetMm, kMaxBinningOffsetMm);
  const int forward_min = param_int(params, "forward_min_mm", 0, -kMaxBinningOffsetMm, kMaxBinningOffsetMm);
  const int forward_max = param_int(params, "forward_max_mm", 34000, -kMaxBinningOffsetMm, kMaxBinningOffsetMm);
  const int lateral_min = param_int(params, "lateral_min_mm", -11000, -kMaxBinningOffsetMm, kMaxBinningOffsetMm);
  const int lateral_max = param_int(params, "lateral_max_mm", 11000, -kMaxBinningOffsetMm, kMaxBinningOffsetMm);
  const int cell_mm = param_int(params, "cell_mm", 500, kMinBinningCellMm, kMaxBinningExtentMm);
  auto check_extent = [](const char* name, int min_value, int max_value) {
    if (max_value <= min_value || max_value - min_value > kMaxBinningExtentMm) {
      throw KernelError("parameter '" + std::string(name) + "': expected an extent (max - min) in [1, " +
                        std::to_string(kMaxBinningExtentMm) + "] mm, got " + std::to_string(max_value) + " - " +
                        std::to_string(min_value) + " = " + std::to_string(int64_t{max_value} - min_value));
    }
  };
  check_extent("forward_max_mm", forward_min, forward_max);
  check_extent("lateral_max_mm", lateral_min, lateral_max);
  // The area must lie inside the range the kernel rotates: every corner within 65535 mm of the
  // camera horizontally (the proof's |p| bound; height is not bounded by the area).
  for (int corner = 0; corner < 4; ++corner) {
    const double dx = (corner & 1 ? forward_max : forward_min) - static_cast<double>(translation[0]);
    const double dy = (corner & 2 ? lateral_max : lateral_min) - static_cast<double>(translation[1]);
    if (std::hypot(dx, dy) > kBinningRangeMm) {
      throw KernelError("parameters 'forward_*_mm', 'lateral_*_mm': expected every area corner within " +
                        std::to_string(kBinningRangeMm) + " mm of the camera (translation_mm), got a corner at " +
                        std::to_string(std::hypot(dx, dy)) + " mm");
    }
  }
  prepared->forward_offset_mm = translation[0] - forward_min;
  prepared->lateral_offset_mm = translation[1] - lateral_min;
  prepared->height_offset_mm = translation[2];
  prepared->forward_extent_mm = forward_max - forward_min;
  prepared->lateral_extent_mm = lateral_max - lateral_min;
  prepared->cell_mm = cell_mm;
  prepared->lateral_cells = (prepared->lateral_extent_mm + cell_mm - 1) / cell_mm;
  const int32_t extent = std::max(prepared->forward_extent_mm, prepared->lateral_extent_mm);
  prepared->reciprocal = static_cast<int32_t>((int64_t{1} << kReciprocalShift) / cell_mm);
  if (int64_t{extent - 1} * prepared->reciprocal > 2147483647) {
    throw KernelError("parameter 'cell_mm': expected (extent - 1) * floor(2^s / cell) < 2^31, got " + std::to_string(extent - 1) +
                      " * " + std::to_string(prepared->reciprocal) + " with cell_mm = " + std::to_string(cell_mm));
  }
  return PreparedKernel{std::shared_ptr<const void>(prepared, prepared.get()), {shape, shape}};
}

KernelDescriptor make_point_cell_binning() {
  const BufferFormat millimetres{ElementType::s32, 0};
  KernelDescriptor descriptor;
  descriptor.name = "point_cell_binning";
  descriptor.summary = "camera-frame s32 mm points -> terrain grid cell index and vehicle-frame height (Q14 rotation)";
  descriptor.ports = {{"x", PortDirection::input, millimetres, PortAccess::window},
                      {"y", PortDirection::input, millimetres, PortAccess::window},
                      {"z", PortDirection::input, millimetres, PortAccess::window},
                      {"cell", PortDirection::output, millimetres, PortAccess::window},
                      {"height", PortDirection::output, millimetres, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = point_cell_binning_prepare;
  descriptor.counting = point_cell_binning_counting;
  descriptor.reference = point_cell_binning_reference;
  LPSTEREO_FILL_NATIVE_TABLE(point_cell_binning)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(point_cell_binning, lpstereo::kernels::make_point_cell_binning);
#endif
