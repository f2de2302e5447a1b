// Element formats of graph buffers: the fixed-point contract between kernels.
//
// A buffer format is an element type plus, for fixed-point types, the number of fraction bits
// (Q-format). Each element type below documents its encoding, its invalid value and its saturation.
// Two ports connect only if their formats are equal (type AND fraction bits).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace lpstereo {

enum class ElementType : uint8_t {
  u8,        // 8-bit luma or any unsigned byte plane. No invalid value.
  u16,       // unsigned 16-bit (10/12/16-bit luma, costs, histogram bins that fit). No invalid value.
  s16,       // signed 16-bit fixed point; fraction_bits gives the Q-format. Disparity is s16 Q4
             // (value / 16 = pixels), invalid = (min_disparity - 1) * 16 (DESIGN.md §4).
  u32,       // unsigned 32-bit (histograms, counters).
  s32,       // signed 32-bit fixed point (accumulators); fraction_bits gives the Q-format. Camera-frame
             // points (disparity_to_points "x", "y", "z"): s32 with 0 fraction bits = millimetres,
             // no point = INT32_MIN in all three (kernels/disparity_to_points.h), never saturated
             // except z at 2^31 - 1 mm.
  census32,  // census signature of a window of at most 32 pixels (5x5: 24 bits, bit k = neighbour k
             // in raster order, centre skipped, is darker than the centre; upper bits 0).
  census64,  // census signature of a window of at most 64 pixels (9x7: 62 bits, same bit order).
  remap_q5,  // rectification look-up entry: two s16 per pixel, (source_x - x) and (source_y - y) in
             // Q10.5 (1/32 px, range -1024 .. +1023.96875 px), interleaved; the positions cv::remap
             // uses. Out-of-range sources follow the border mode (kernels/remap_bilinear.cpp).
  bytes,     // opaque bytes of an ARM-side structure (feature lists, statistics); size in bytes.
};

struct BufferFormat {
  ElementType type = ElementType::u8;
  int fraction_bits = 0;  // Q-format fraction bits for s16 / s32; 0 for every other type

  bool operator==(const BufferFormat&) const = default;
};

// Bytes one element of `type` occupies.
int element_bytes(ElementType type);

std::string_view element_type_name(ElementType type);
std::optional<ElementType> parse_element_type(std::string_view name);

// "u8", "s16q4", "census32", ... (the spelling graph JSON files use).
std::string format_name(const BufferFormat& format);
std::optional<BufferFormat> parse_format(std::string_view name);

}  // namespace lpstereo
