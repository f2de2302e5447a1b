// Census transform over a W x H window (Zabih & Woodfill 1994), shared by census5x5, census9x7 and
// census9x9_sparse.
//
// Signature bit k (k = 0 .. W*H-2) is 1 when neighbour k of the window, in raster order with the
// centre skipped, is strictly darker than the centre pixel. 5x5 gives 24 bits in a census32 word,
// 9x7 gives 62 bits in a census64 word; the unused upper bits are 0. A sparse census samples every
// kStep-th pixel of every kStep-th row: W x H samples spread over a ((W - 1) kStep + 1)-wide window
// (census9x9_sparse: 5x5 samples at step 2 over 9x9, 24 bits; the sparse census of Humenberger et
// al., CVIU 2010, who sample every second pixel of a 16x16 window).
//
// Vector schedule (one chunk = B::kLanesU8 pixels of a row): the signature is built as
// sizeof(Word) byte planes (plane g holds bits 8g .. 8g+7 of every pixel: compare, and with the
// bit, or into the plane), then the planes are interleaved into Words with a zip tree.
// Op count per chunk (documented closed form, checked by tests/kernels/census_test.cpp):
//   load    = N + 1             (N = W*H - 1 neighbours (samples), plus the centre)
//   compare = N
//   logic   = 2 N               (and with the bit, or into the plane)
//   permute = census_chunk_permutes<Word>()   (8 zips for 32-bit words, 24 for 64-bit words)
// per output row ceil(width / L) chunks (L = B::kLanesU8) and ceil(width / (L / sizeof(Word)))
// stores, and per tile 9 broadcasts (permute: 8 bit masks and zero).
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/kernel.h"
#include "kernels/row_access.h"

namespace lpstereo::kernels {

// Number of zip ops that interleave sizeof(Word) byte planes into Words for one chunk:
// 4 planes (u32): 4 + 4 = 8; 8 planes (u64): 8 + 8 + 8 = 24.
template <class Word>
constexpr int census_chunk_permutes() {
  return sizeof(Word) == 4 ? 8 : 24;
}

// The tile body, written once against back end B. Input 0: u8 tile with halo (W/2) kStep x
// (H/2) kStep around it; output 0: Word tile.
template <class B, int kWindowWidth, int kWindowHeight, class Word, int kStep = 1>
void census_tile(const TileArgs& args) {
  static_assert(sizeof(Word) == 4 || sizeof(Word) == 8, "census words are 32 or 64 bits");
  static_assert(kWindowWidth * kWindowHeight - 1 <= 8 * static_cast<int>(sizeof(Word)), "window too large for word");
  using VU8 = typename B::VU8;
  constexpr int kLanes = B::kLanesU8;
  constexpr int kPlanes = static_cast<int>(sizeof(Word));
  constexpr int kWordLanes = kLanes / kPlanes;
  constexpr int kRadiusX = kWindowWidth / 2 * kStep;
  constexpr int kRadiusY = kWindowHeight / 2 * kStep;

  const PlaneView& source = args.inputs[0];
  const PlaneView& destination = args.outputs[0];
  const int width = destination.width;
  const int height = destination.height;
  // Readable source columns end at width + kRadiusX (the halo).
  const int readable_end = width + kRadiusX;

  VU8 bit_masks[8];
  for (int bit = 0; bit < 8; ++bit) bit_masks[bit] = B::set1_u8(static_cast<uint8_t>(1u << bit));
  const VU8 zero = B::set1_u8(0);

  for (int y = 0; y < height; ++y) {
    const uint8_t* centre_row = plane_row<const uint8_t>(source, y);
    Word* out_row = plane_row<Word>(destination, y);
    for (int x = 0; x < width; x += kLanes) {
      auto load_at = [&](const uint8_t* row, int column) { return load_clipped<B>(row, column, readable_end); };
      const VU8 centre = load_at(centre_row, x);
      VU8 planes[kPlanes];
      for (int plane = 0; plane < kPlanes; ++plane) planes[plane] = zero;
      int bit_index = 0;
      for (int dy = -kRadiusY; dy <= kRadiusY; dy += kStep) {
        const uint8_t* row = plane_row<const uint8_t>(source, y + dy);
        for (int dx = -kRadiusX; dx <= kRadiusX; dx += kStep) {
          if (dx == 0 && dy == 0) continue;
          const VU8 neighbour = load_at(row, x + dx);
          const VU8 darker = B::cmpgt(centre, neighbour);
          planes[bit_index / 8] = B::bit_or(planes[bit_index / 8], B::bit_and(darker, bit_masks[bit_index % 8]));
          ++bit_index;
        }
      }
      // Zip tree: byte planes -> u16 -> u32 (-> u64). Stage results stay in pixel order.
      if constexpr (kPlanes == 4) {
        const auto low_lo = B::zip_lo(planes[0], planes[1]);
        const auto low_hi = B::zip_hi(planes[0], planes[1]);
        const auto high_lo = B::zip_lo(planes[2], planes[3]);
        const auto high_hi = B::zip_hi(planes[2], planes[3]);
        const typename B::VU32 words[4] = {B::zip_lo(low_lo, high_lo), B::zip_hi(low_lo, high_lo),
                                           B::zip_lo(low_hi, high_hi), B::zip_hi(low_hi, high_hi)};
        for (int part = 0; part < 4 && x + part * kWordLanes < width; ++part) {
          store_clipped<B>(reinterpret_cast<uint32_t*>(out_row), x + part * kWordLanes, width, words[part]);
        }
      } else {
        typename B::VU16 pairs[8];
        for (int pair = 0; pair < 4; ++pair) {
          pairs[2 * pair] = B::zip_lo(planes[2 * pair], planes[2 * pair + 1]);      // pixels [0, L/2)
          pairs[2 * pair + 1] = B::zip_hi(planes[2 * pair], planes[2 * pair + 1]);  // pixels [L/2, L)
        }
        // quads[q][part]: bytes 4q .. 4q+3 of pixels [part * L/4, (part + 1) * L/4)
        typename B::VU32 quads[2][4];
        for (int quad = 0; quad < 2; ++quad) {
          for (int half = 0; half < 2; ++half) {
            const auto& low = pairs[4 * quad + half];
            const auto& high = pairs[4 * quad + 2 + half];
            quads[quad][2 * half] = B::zip_lo(low, high);
            quads[quad][2 * half + 1] = B::zip_hi(low, high);
          }
        }
        for (int part = 0; part < 8; ++part) {
          const auto word = (part % 2 == 0) ? B::zip_lo(quads[0][part / 2], quads[1][part / 2])
                                            : B::zip_hi(quads[0][part / 2], quads[1][part / 2]);
          // The zip above runs for every part, which keeps the count per chunk fixed (census_chunk_permutes).
          if (x + part * kWordLanes >= width) continue;
          store_clipped<B>(reinterpret_cast<uint64_t*>(out_row), x + part * kWordLanes, width, word);
        }
      }
    }
  }
}

// Scalar reference: full planes, border applied here (replicate or constant).
template <int kWindowWidth, int kWindowHeight, class Word, int kStep = 1>
void census_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                      const void* /*params*/, BorderMode border_mode, uint32_t border_value) {
  const PlaneView& source = inputs[0];
  const PlaneView& destination = outputs[0];
  auto pixel = [&](int x, int y) -> int { return reference_pixel_u8(source, x, y, border_mode, border_value); };
  for (int y = 0; y < destination.height; ++y) {
    for (int x = 0; x < destination.width; ++x) {
      const int centre = pixel(x, y);
      Word signature = 0;
      int bit = 0;
      for (int sample_y = -kWindowHeight / 2; sample_y <= kWindowHeight / 2; ++sample_y) {
        for (int sample_x = -kWindowWidth / 2; sample_x <= kWindowWidth / 2; ++sample_x) {
          if (sample_x == 0 && sample_y == 0) continue;
          if (pixel(x + sample_x * kStep, y + sample_y * kStep) < centre) signature |= Word{1} << bit;
          ++bit;
        }
      }
      plane_row<Word>(destination, y)[x] = signature;
    }
  }
}

// The descriptor the census kernels share; the caller fills the native table and registers it.
template <int kWindowWidth, int kWindowHeight, class Word, int kStep = 1>
KernelDescriptor census_descriptor(const char* name, ElementType word_type, TileFunction counting) {
  constexpr int kRadiusX = kWindowWidth / 2 * kStep;
  constexpr int kRadiusY = kWindowHeight / 2 * kStep;
  KernelDescriptor descriptor;
  descriptor.name = name;
  descriptor.summary = "census transform over a " + std::to_string(2 * kRadiusX + 1) + "x" + std::to_string(2 * kRadiusY + 1) +
                       " window" +
                       (kStep > 1 ? " (" + std::to_string(kWindowWidth) + "x" + std::to_string(kWindowHeight) + " samples " +
                                        std::to_string(kStep) + " px apart)"
                                  : std::string()) +
                       " (bit = neighbour darker than centre)";
  descriptor.ports = {{"input", PortDirection::input, {ElementType::u8, 0}, PortAccess::window},
                      {"output", PortDirection::output, {word_type, 0}, PortAccess::window}};
  descriptor.halo = {kRadiusX, kRadiusX, kRadiusY, kRadiusY};
  descriptor.border_modes = {BorderMode::replicate, BorderMode::constant};
  descriptor.prepare = [](const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
    check_param_names(params, {});
    return PreparedKernel{nullptr, {input_shapes.at(0)}};
  };
  descriptor.counting = counting;
  descriptor.reference = census_reference<kWindowWidth, kWindowHeight, Word, kStep>;
  return descriptor;
}

}  // namespace lpstereo::kernels
