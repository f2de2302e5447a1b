// brief256: BRIEF-256 binary descriptors (Calonder, Lepetit, Strecha, Fua, ECCV 2010) of the
// keypoint list, sampled with the steered pattern of one yaw sector (thesis 003 §3.5, fig. 3.7), u8 image +
// keypoint list -> u32 descriptors. Pattern, bit order and steering: kernels/brief_pattern.h.
//
// Ports: "image" u8 (PortAccess::whole: the keypoints are anywhere), "keypoints" s32 (the list of
//   arm/tasks/keypoint_record.h, kKeypointWords x max_keypoints, PortAccess::whole), output
//   "descriptors" u32, kBriefWords (8) x max_keypoints: row k is keypoint k's descriptor, word w bit
//   b = pair 32 w + b (1 when I(a) < I(b)).
// Smoothing: BRIEF compares single pixels, so the image must be smoothed first (Calonder et al.
//   §4.1: a 9x9 Gaussian, sigma 2, or any low-pass of similar width). graphs/features.json feeds
//   it "gaussian5x5" (kernels/gaussian5x5.cpp: the 5x5 binomial, a Gaussian of sigma 1, exact and
//   rounded); a wider one may be chained for noisier sensors. The kernel samples the pixels it is
//   given.
// Parameters: yaw_sector (0 .. 15, default 0): the pattern rotated by yaw_sector x 22.5 degrees.
//   Thesis 003 §3.5 picks the sector of the difference between the filter's yaw and the stored
//   keyframe's yaw; the caller maps that difference to the image rotation its camera mounting gives
//   (an image rotated by +s x 22.5 degrees in this header's sense is matched by sector s).
// Zero descriptors: a row whose record has kKeypointValid == 0, or whose keypoint is not in
//   15 <= x < W - 15, 15 <= y < H - 15 (the 31 x 31 patch would leave the image). Images narrower or lower than 31 px give all-zero descriptors.
//   select_keypoints' default border_px = 16 keeps every listed keypoint usable.
// Limits: the image plane (stride x height) must span less than 2^31 bytes (s32 gather offsets);
//   x and y are read as full 32-bit words (any value is safe: unusable ones give zero).
//
// Vector schedule (tiles are whole rows of the output, i.e. runs of keypoints; L = B::kLanesU32):
// lane l of a chunk is word (w0 + l) % 8 of the keypoint; a keypoint takes Q = max(8, L) / L chunks
// (SSE4.2 and NEON: 2; AVX2: 1; AVX-512 and counting: 1, lanes 8 .. 15 repeating words 0 .. 7).
//   per tile: the sector's pair offsets as byte offsets, dy stride + dx, for both points of every
//     bit into scratch: 64 Q x (2 loads, 1 mullo, 1 add, 1 store); broadcasts: stride, 32 bit masks,
//     6 record offsets, 5 bounds and constants (14, W - 15, H - 15, zero, the image centre);
//   per keypoint: 6 gather_u16 (the low and high halves of valid, x, y), 2 shifts and 3 ors (the
//     32-bit words), 5 compares (valid == 0 and the four bounds), 4 logic (their combination),
//     1 mullo and 1 add (base = y stride + x), 1 select (an unusable keypoint samples around the
//     image centre instead, so no gather leaves the image);
//   per chunk: per bit 2 loads (offsets), 2 adds, 2 gather_u8, 1 compare (u32 a < b), 2 logic (and
//     with the bit, or into the word), then 1 and with the usable mask and 1 store.
// Op count (closed form, checked by tests/kernels/brief256_test.cpp), K keypoint rows in a tile:
//   load = 128 Q + 64 Q K,  store = 64 Q + Q K,  arith = 64 Q + K + 64 Q K,  multiply = 64 Q + K,
//   gather = 6 K + 64 Q K,  compare = 5 K + 32 Q K,  logic = 8 K + 64 Q K + Q K,  shift = 2 K,
//   permute = 44 (1 stride + 32 bit masks + 6 record offsets + 5 bounds and constants).
// Images under 31 x 31: per tile 1 broadcast (zero), per keypoint Q stores of zeros, nothing else.
// source_rect: the simulator charges a rectangle of area 32 x 32 x K (one 2-D DMA of a 32 x 32
//   patch per keypoint of the tile, as a chip fetches patches from the list; per-DMA setup is not
//   modelled) - its position means nothing.
#include <algorithm>
#include <string>

#include "arm/tasks/keypoint_record.h"
#include "kernels/brief_pattern.h"
#include "kernels/kernel.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int kMaxLanesU32 = 16;  // the widest back end's u32 lanes; each table row holds 16 lanes

struct Brief256Params {
  int yaw_sector = 0;
  // [point a/b][bit][lane]: the offset of pair 32 (lane % 8) + bit, lanes 8 .. 15 repeating 0 .. 7.
  alignas(64) int32_t dx[2][32][kMaxLanesU32] = {};
  alignas(64) int32_t dy[2][32][kMaxLanesU32] = {};
};

template <class B>
void brief256_body(const TileArgs& args) {
  using VS32 = typename B::VS32;
  using VU32 = typename B::VU32;
  constexpr int kLanes = B::kLanesU32;
  constexpr int kChunkLanes = kLanes < kBriefWords ? kBriefWords : kLanes;  // table entries used per bit
  constexpr int kChunks = kChunkLanes / kLanes;                             // Q
  static_assert(kLanes <= kMaxLanesU32);
  const auto& params = *static_cast<const Brief256Params*>(args.params);
  const PlaneView& image = args.inputs[0];
  const PlaneView& keypoints = args.inputs[1];
  const PlaneView& destination = args.outputs[0];
  constexpr int kPatch = 2 * kBriefPatchRadius + 1;

  if (image.width < kPatch || image.height < kPatch) {
    const VU32 zero = B::set1_u32(0);
    for (int row = 0; row < destination.height; ++row) {
      for (int chunk = 0; chunk < kChunks; ++chunk) {
        store_clipped<B>(plane_row<uint32_t>(destination, row), chunk * kLanes, kBriefWords, zero);
      }
    }
    return;
  }

  // Per tile: byte offsets of the pattern for this image's stride.
  int32_t* offsets = reinterpret_cast<int32_t*>(args.scratch);  // [point][bit][kChunkLanes]
  const VS32 stride = B::set1_s32(static_cast<int32_t>(image.stride_bytes));
  for (int point = 0; point < 2; ++point) {
    for (int bit = 0; bit < 32; ++bit) {
      for (int chunk = 0; chunk < kChunks; ++chunk) {
        const VS32 dx = B::load(&params.dx[point][bit][chunk * kLanes]);
        const VS32 dy = B::load(&params.dy[point][bit][chunk * kLanes]);
        B::store(offsets + (point * 32 + bit) * kChunkLanes + chunk * kLanes, B::add(B::mullo(dy, stride), dx));
      }
    }
  }
  VU32 bit_masks[32];
  for (int bit = 0; bit < 32; ++bit) bit_masks[bit] = B::set1_u32(uint32_t{1} << bit);
  // u16 element offsets of the record words' halves (little-endian: word w = halves 2w, 2w + 1).
  const VS32 valid_low = B::set1_s32(2 * arm::kKeypointValid), valid_high = B::set1_s32(2 * arm::kKeypointValid + 1);
  const VS32 x_low = B::set1_s32(2 * arm::kKeypointXPx), x_high = B::set1_s32(2 * arm::kKeypointXPx + 1);
  const VS32 y_low = B::set1_s32(2 * arm::kKeypointYPx), y_high = B::set1_s32(2 * arm::kKeypointYPx + 1);
  const VS32 low_bound = B::set1_s32(kBriefPatchRadius - 1);  // coordinate > 14
  const VS32 x_end = B::set1_s32(image.width - kBriefPatchRadius);
  const VS32 y_end = B::set1_s32(image.height - kBriefPatchRadius);
  const VU32 zero = B::set1_u32(0);
  const VS32 centre = B::set1_s32(static_cast<int32_t>((image.height / 2) * image.stride_bytes + image.width / 2));

  for (int row = 0; row < destination.height; ++row) {
    const uint16_t* record = plane_row<const uint16_t>(keypoints, args.tile_y + row);
    const VU32 valid = B::bit_or(B::gather_u16(record, valid_low), B::gather_u16(record, valid_high));
    const VS32 x = B::as_s32(B::bit_or(B::gather_u16(record, x_low), B::template shl<16>(B::gather_u16(record, x_high))));
    const VS32 y = B::as_s32(B::bit_or(B::gather_u16(record, y_low), B::template shl<16>(B::gather_u16(record, y_high))));
    const VS32 inside = B::bit_and(B::bit_and(B::cmpgt(x, low_bound), B::cmplt(x, x_end)),
                                   B::bit_and(B::cmpgt(y, low_bound), B::cmplt(y, y_end)));
    const VU32 usable = B::bit_andnot(B::cmpeq(valid, zero), B::as_u32(inside));
    const VS32 base = B::select(B::as_s32(usable), B::add(B::mullo(y, stride), x), centre);
    uint32_t* out_row = plane_row<uint32_t>(destination, row);
    for (int chunk = 0; chunk < kChunks; ++chunk) {
      VU32 word = zero;
      for (int bit = 0; bit < 32; ++bit) {
        const VS32 offset_a = B::add(base, B::load(offsets + bit * kChunkLanes + chunk * kLanes));
        const VS32 offset_b = B::add(base, B::load(offsets + (32 + bit) * kChunkLanes + chunk * kLanes));
        const VU32 darker = B::cmplt(B::gather_u8(image.origin, offset_a), B::gather_u8(image.origin, offset_b));
        word = B::bit_or(word, B::bit_and(darker, bit_masks[bit]));
      }
      store_clipped<B>(out_row, chunk * kLanes, kBriefWords, B::bit_and(word, usable));
    }
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(brief256, brief256_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(brief256)

namespace lpstereo::kernels {
namespace {

void brief256_counting(const TileArgs& args) { brief256_body<simd::Counting>(args); }

// Scalar reference: per listed keypoint, the 256 comparisons of the sector's pattern.
void brief256_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                        const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const Brief256Params*>(params_pointer);
  const PlaneView& image = inputs[0];
  const PlaneView& keypoints = inputs[1];
  const PlaneView& destination = outputs[0];
  const auto& pattern = kBriefSteeredPatterns[static_cast<size_t>(params.yaw_sector)];
  for (int row = 0; row < destination.height; ++row) {
    const int32_t* record = plane_row<const int32_t>(keypoints, row);
    uint32_t* words = plane_row<uint32_t>(destination, row);
    std::fill(words, words + kBriefWords, 0u);
    const int32_t x = record[arm::kKeypointXPx], y = record[arm::kKeypointYPx];
    if (record[arm::kKeypointValid] == 0 || x < kBriefPatchRadius || y < kBriefPatchRadius ||
        x >= image.width - kBriefPatchRadius || y >= image.height - kBriefPatchRadius) {
      continue;
    }
    auto pixel = [&](int u, int v) { return plane_row<const uint8_t>(image, v)[u]; };
    for (int i = 0; i < kBriefPairs; ++i) {
      const BriefPair& pair = pattern[static_cast<size_t>(i)];
      if (pixel(x + pair.ax, y + pair.ay) < pixel(x + pair.bx, y + pair.by)) words[i / 32] |= uint32_t{1} << (i % 32);
    }
  }
}

PreparedKernel brief256_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"yaw_sector"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (image, keypoints), got " + std::to_string(input_shapes.size()));
  }
  if (input_shapes[1].width != arm::kKeypointWords) {
    throw KernelError("input 'keypoints': expected a width of " + std::to_string(int(arm::kKeypointWords)) +
                      " words (arm/tasks/keypoint_record.h), got " + std::to_string(input_shapes[1].width));
  }
  if (static_cast<int64_t>(input_shapes[0].width) * input_shapes[0].height >= (int64_t{1} << 30)) {
    throw KernelError("input 'image': expected fewer than 2^30 pixels (s32 gather offsets), got " +
                      std::to_string(static_cast<int64_t>(input_shapes[0].width) * input_shapes[0].height));
  }
  auto prepared = std::make_shared<Brief256Params>();
  prepared->yaw_sector = param_int(params, "yaw_sector", 0, 0, kBriefSectors - 1);
  const auto& pattern = kBriefSteeredPatterns[static_cast<size_t>(prepared->yaw_sector)];
  for (int bit = 0; bit < 32; ++bit) {
    for (int lane = 0; lane < kMaxLanesU32; ++lane) {
      const BriefPair& pair = pattern[static_cast<size_t>(32 * (lane % kBriefWords) + bit)];
      prepared->dx[0][bit][lane] = pair.ax;
      prepared->dy[0][bit][lane] = pair.ay;
      prepared->dx[1][bit][lane] = pair.bx;
      prepared->dy[1][bit][lane] = pair.by;
    }
  }
  return PreparedKernel{prepared, {{kBriefWords, input_shapes[1].height}}};
}

KernelDescriptor make_brief256() {
  KernelDescriptor descriptor;
  descriptor.name = "brief256";
  descriptor.summary =
      "BRIEF-256 descriptors (8 u32 words) of a keypoint list on a smoothed u8 image, pattern steered by yaw_sector x 22.5 degrees";
  descriptor.ports = {{"image", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"keypoints", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"descriptors", PortDirection::output, {ElementType::u32, 0}, PortAccess::window}};
  descriptor.halo = {0, 0, 0, 0};
  descriptor.border_modes = {BorderMode::replicate};  // no pixel outside the image is ever read
  descriptor.full_width_tiles = true;                 // a row is one keypoint's 8 words
  descriptor.prepare = brief256_prepare;
  descriptor.scratch_bytes = [](int, int, const void*) { return sizeof(int32_t) * 2 * 32 * kMaxLanesU32; };
  descriptor.source_rect = [](int input, const PixelRect& output_tile, const PlaneShape& input_shape, const void*) {
    const int keypoints = output_tile.y1 - output_tile.y0;
    if (input == 1) return PixelRect{0, output_tile.y0, input_shape.width, output_tile.y1};  // the tile's records
    return PixelRect{0, 0, 32 * keypoints, 32};  // area = the tile's 32 x 32 patches (see the header)
  };
  descriptor.counting = brief256_counting;
  descriptor.reference = brief256_reference;
  LPSTEREO_FILL_NATIVE_TABLE(brief256)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(brief256, lpstereo::kernels::make_brief256);
#endif
