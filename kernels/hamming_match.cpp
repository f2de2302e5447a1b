// hamming_match: brute-force matching of BRIEF-256 descriptors by Hamming distance with Lowe's ratio
// test (Lowe, IJCV 2004, §7.1; for binary descriptors as in Calonder et al., ECCV 2010, and the
// keyframe matching of thesis 003 §3.5): for every query descriptor, the nearest and second-nearest
// train descriptors over the whole train set, and whether the match is accepted.
//
// Ports (all inputs PortAccess::whole; the output is a list with one row per query):
//   "query_descriptors" u32, kBriefWords (8) x Nq: kernels/brief256.cpp's output, row k = keypoint k;
//   "query_keypoints"   s32, kKeypointWords (4) x Nq: the list those descriptors were made from
//                       (arm/tasks/keypoint_record.h);
//   "train_descriptors" u32, 8 x Nt, and "train_keypoints" s32, 4 x Nt: the same for the set matched
//                       against (the previous frame over a delayed edge, a keyframe's stored set);
//   output "matches" s32, kMatchWords (4) x Nq: the record of kernels/match_record.h.
// The count travels in the keypoint lists: a descriptor row is used when its keypoint row has
//   kKeypointValid != 0 (the same rule brief256 applies; select_keypoints lists the used rows first
//   and zeroes the rest). No count parameter: the number of keypoints changes every frame, the plane
//   sizes (the graph's max_keypoints) do not, and a data-oblivious kernel scans every row anyway.
//   Descriptor and keypoint planes of one set must have the same number of rows (prepare checks).
// Parameters:
//   ratio_q8     (0 .. 256, default 205 = 0.80 x 256): the ratio test in Q8, accepted when
//                best x 256 < ratio_q8 x second (strictly; 256: the best must only be strictly nearer).
//                Lowe's 0.8; exact in u32: best and second are at most 1280 (256 + the penalty below;
//                second is a real lane value because every back end has at least 4 lanes), so
//                best x 256 and ratio_q8 x second stay below 2^19.
//   max_distance (0 .. 256, default 256 = no limit): accepted also requires best <= max_distance.
// Output record, per query q:
//   train index = the lowest-numbered valid train row at the smallest distance (ties: lowest row);
//   best = that distance; second = the smallest distance over the other valid train rows (equal to
//   best when two trains tie); kMatchNoTrain / kMatchNoDistance where there is no such row;
//   accepted = 1 when the query row is valid, a second train exists, the ratio test passes and
//   best <= max_distance. With fewer than two valid trains nothing is accepted (the ratio test has
//   nothing to compare with). An invalid query row gives {-1, 257, 257, 0}.
//
// Popcount: the simd contract has a per-lane popcount for u32 lanes (kernels/simd/emulated.h; the
//   x86 back ends build it from a nibble table with (v)pshufb and byte sums, VPOPCNTDQ not assumed;
//   NEON from vcnt and pairwise widening adds; one popcount op in the cost model), so a distance is
//   8 xor + 8 popcount + 8 add per pair of descriptors.
//
// Vector schedule (L = B::kLanesU32; lanes are train descriptors; tiles are runs of query rows):
//   per tile: the train set transposed into scratch, word-major: word w of trains [c L, c L + L)
//     at scratch[w][c L ..], by two gather_u16 per word (the low and high halves; the contract has
//     no u32 gather), then a ninth row, the penalty: 0 for a valid train, 1024 for an invalid row
//     or a padding lane past Nt (its gathers read the last row, clamped), so an invalid train's
//     distance is >= 1024 and never beats a valid one (<= 256).
//   per query: 8 broadcasts of its words (a scalar load and a broadcast each) and one of its valid
//     word; per chunk of L trains: distance = penalty + sum_w popcount(train_w xor query_w); keep
//     per lane best, second = min(second, max(best, distance)), best index (strict <, so the
//     earliest); then over the lanes (min_across): b = min best, the winning index = the smallest
//     index among the lanes at b, s = min over lanes of (the winning lane's second, the other
//     lanes' best); the record assembled in lanes 0 .. 3 by selects with lane masks, one store.
// Op count (closed form, checked by tests/kernels/hamming_match_test.cpp), counting back end
// (L = 16, log2 L = 4), C = ceil(Nt / 16) train chunks, K query rows in a tile:
//   load     = 1 + 9 C K                       (lane-number table; 9 per chunk and query)
//   store    = 9 C + K                         (transposed words and penalty; one record per query)
//   arith    = 2 C + K (12 C + 12)             (min, index step; 8 adds, max, 2 min, index step;
//                                                3 min_across x 4 stages)
//   logic    = 11 C + K (9 C + 14)
//   compare  = 3 + 2 C + K (C + 7)
//   multiply = 2 C + K
//   shift    = 8 C + K
//   popcount = 8 C K
//   gather   = 18 C
//   permute  = 15 + 21 K                       (per tile 15 broadcasts; per query 9 broadcasts and
//                                                12 min_across stages)
// At Nq = Nt = 2048 (graphs/localization-features.json): 2048 x 128 x 39 = 10.2 M ops in the inner
// loop; profiled on cv1-class 1.96 M cycles, 2.45 ms. Linear in Nq x Nt.
// Limits: each input plane spans less than 2^31 bytes (s32 gather offsets in u16 elements).
#include <cstdint>
#include <string>
#include <vector>

#include "arm/tasks/keypoint_record.h"
#include "kernels/brief_hamming.h"
#include "kernels/brief_pattern.h"
#include "kernels/kernel.h"
#include "kernels/match_record.h"
#include "kernels/row_access.h"
#include "kernels/simd/native.h"

namespace lpstereo::kernels {
namespace {

constexpr int kMaxLanesU32 = 16;            // the widest back end's u32 lanes: the train padding unit
constexpr uint32_t kInvalidTrainPenalty = 1024;  // > 256: an invalid train never beats a valid one
alignas(64) constexpr int32_t kLaneNumbers[kMaxLanesU32] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};

struct HammingMatchParams {
  int ratio_q8 = 205;
  int max_distance = 256;
  int train_rows = 0;  // Nt, from the input shapes (sizes the scratch)
};

int padded_train_rows(int train_rows) { return (train_rows + kMaxLanesU32 - 1) / kMaxLanesU32 * kMaxLanesU32; }

template <class B>
void hamming_match_body(const TileArgs& args) {
  using VU32 = typename B::VU32;
  using VS32 = typename B::VS32;
  constexpr int kLanes = B::kLanesU32;
  static_assert(kLanes <= kMaxLanesU32);
  const auto& params = *static_cast<const HammingMatchParams*>(args.params);
  const PlaneView& query_descriptors = args.inputs[0];
  const PlaneView& query_keypoints = args.inputs[1];
  const PlaneView& train_descriptors = args.inputs[2];
  const PlaneView& train_keypoints = args.inputs[3];
  const PlaneView& destination = args.outputs[0];
  const int train_rows = train_descriptors.height;
  const int chunks = (train_rows + kLanes - 1) / kLanes;
  const int padded = padded_train_rows(train_rows);
  uint32_t* transposed = reinterpret_cast<uint32_t*>(args.scratch);  // [kBriefWords + 1][padded]

  // Per tile: the train set, word-major, and the penalty row.
  const VS32 lane_numbers = B::load(kLaneNumbers);
  const VS32 last_train = B::set1_s32(train_rows - 1);
  const VS32 descriptor_stride = B::set1_s32(static_cast<int32_t>(train_descriptors.stride_bytes / 2));
  const VS32 keypoint_stride = B::set1_s32(static_cast<int32_t>(train_keypoints.stride_bytes / 2));
  const VU32 zero = B::set1_u32(0);
  const VU32 penalty = B::set1_u32(kInvalidTrainPenalty);
  const VS32 step = B::set1_s32(kLanes);
  const auto* descriptor_halves = reinterpret_cast<const uint16_t*>(train_descriptors.origin);
  const auto* keypoint_halves = reinterpret_cast<const uint16_t*>(train_keypoints.origin);
  VS32 train_index = lane_numbers;
  for (int chunk = 0; chunk < chunks; ++chunk) {
    const VS32 clamped = B::min(train_index, last_train);
    const VU32 beyond = B::as_u32(B::cmpgt(train_index, last_train));
    const VS32 descriptor_offset = B::mullo(clamped, descriptor_stride);
    const VS32 keypoint_offset = B::mullo(clamped, keypoint_stride);
    for (int word = 0; word < kBriefWords; ++word) {
      const VU32 low = B::gather_u16(descriptor_halves + 2 * word, descriptor_offset);
      const VU32 high = B::gather_u16(descriptor_halves + 2 * word + 1, descriptor_offset);
      B::store(transposed + word * padded + chunk * kLanes, B::bit_or(low, B::template shl<16>(high)));
    }
    const VU32 valid = B::bit_or(B::gather_u16(keypoint_halves + 2 * arm::kKeypointValid, keypoint_offset),
                                 B::gather_u16(keypoint_halves + 2 * arm::kKeypointValid + 1, keypoint_offset));
    const VU32 unusable = B::bit_or(B::cmpeq(valid, zero), beyond);
    B::store(transposed + kBriefWords * padded + chunk * kLanes, B::bit_and(unusable, penalty));
    train_index = B::add(train_index, step);
  }

  const VU32 all_ones = B::set1_u32(0xFFFFFFFFu);
  const VU32 index_step = B::set1_u32(static_cast<uint32_t>(kLanes));
  const VU32 none = B::set1_u32(static_cast<uint32_t>(kMatchNoDistance));
  const VU32 one = B::set1_u32(1);
  const VU32 ratio = B::set1_u32(static_cast<uint32_t>(params.ratio_q8));
  const VU32 max_distance_plus_one = B::set1_u32(static_cast<uint32_t>(params.max_distance + 1));
  const VU32 is_lane0 = B::as_u32(B::cmpeq(lane_numbers, B::set1_s32(0)));
  const VU32 is_lane1 = B::as_u32(B::cmpeq(lane_numbers, B::set1_s32(1)));
  const VU32 is_lane2 = B::as_u32(B::cmpeq(lane_numbers, B::set1_s32(2)));

  for (int row = 0; row < destination.height; ++row) {
    const int query = args.tile_y + row;
    const uint32_t* query_words = plane_row<const uint32_t>(query_descriptors, query);
    VU32 query_word[kBriefWords];
    for (int word = 0; word < kBriefWords; ++word) query_word[word] = B::set1_u32(query_words[word]);
    const VU32 query_valid =
        B::set1_u32(static_cast<uint32_t>(plane_row<const int32_t>(query_keypoints, query)[arm::kKeypointValid]));

    VU32 best = all_ones, second = all_ones, best_index = zero;
    VU32 index = B::as_u32(lane_numbers);
    for (int chunk = 0; chunk < chunks; ++chunk) {
      VU32 distance = B::load(transposed + kBriefWords * padded + chunk * kLanes);
      for (int word = 0; word < kBriefWords; ++word) {
        const VU32 train_word = B::load(transposed + word * padded + chunk * kLanes);
        distance = B::add(distance, B::popcount(B::bit_xor(train_word, query_word[word])));
      }
      const VU32 better = B::cmplt(distance, best);
      second = B::min(second, B::max(best, distance));
      best = B::min(best, distance);
      best_index = B::select(better, index, best_index);
      index = B::add(index, index_step);
    }
    const VU32 best_distance = B::min_across(best);
    const VU32 winner_index = B::min_across(B::select(B::cmpeq(best, best_distance), best_index, all_ones));
    const VU32 second_distance = B::min_across(B::select(B::cmpeq(best_index, winner_index), second, best));

    const VU32 query_usable = B::bit_andnot(B::cmpeq(query_valid, zero), all_ones);
    const VU32 found = B::bit_and(query_usable, B::cmplt(best_distance, none));
    const VU32 has_second = B::bit_and(found, B::cmplt(second_distance, none));
    const VU32 index_out = B::select(found, winner_index, all_ones);  // -1 when none
    const VU32 best_out = B::select(found, best_distance, none);
    const VU32 second_out = B::select(has_second, second_distance, none);
    const VU32 ratio_passes = B::cmplt(B::template shl<8>(best_distance), B::mullo(ratio, second_distance));
    const VU32 near_enough = B::cmplt(best_distance, max_distance_plus_one);
    const VU32 accepted = B::bit_and(B::bit_and(has_second, ratio_passes), B::bit_and(near_enough, one));
    const VU32 record = B::select(is_lane0, index_out, B::select(is_lane1, best_out, B::select(is_lane2, second_out, accepted)));
    store_clipped<B>(plane_row<uint32_t>(destination, row), 0, kMatchWords, record);
  }
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_NATIVE_ENTRY(hamming_match, hamming_match_body)

#if LPSTEREO_ISA_TU == 0
LPSTEREO_DECLARE_NATIVE_ENTRIES(hamming_match)

namespace lpstereo::kernels {
namespace {

void hamming_match_counting(const TileArgs& args) { hamming_match_body<simd::Counting>(args); }

// Scalar reference: per valid query, every valid train in row order (brief_hamming_distance).
void hamming_match_reference(const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                             const void* params_pointer, BorderMode, uint32_t) {
  const auto& params = *static_cast<const HammingMatchParams*>(params_pointer);
  const PlaneView& query_descriptors = inputs[0];
  const PlaneView& query_keypoints = inputs[1];
  const PlaneView& train_descriptors = inputs[2];
  const PlaneView& train_keypoints = inputs[3];
  const PlaneView& destination = outputs[0];
  for (int query = 0; query < destination.height; ++query) {
    int32_t* record = plane_row<int32_t>(destination, query);
    int best = kMatchNoDistance, second = kMatchNoDistance, best_train = kMatchNoTrain;
    if (plane_row<const int32_t>(query_keypoints, query)[arm::kKeypointValid] != 0) {
      for (int train = 0; train < train_descriptors.height; ++train) {
        if (plane_row<const int32_t>(train_keypoints, train)[arm::kKeypointValid] == 0) continue;
        const int distance = brief_hamming_distance(plane_row<const uint32_t>(query_descriptors, query),
                                                    plane_row<const uint32_t>(train_descriptors, train));
        if (distance < best) {
          second = best;
          best = distance;
          best_train = train;
        } else if (distance < second) {
          second = distance;
        }
      }
    }
    record[kMatchTrainIndex] = best_train;
    record[kMatchBestDistance] = best;
    record[kMatchSecondDistance] = second;
    record[kMatchAccepted] = second != kMatchNoDistance && best * 256 < params.ratio_q8 * second && best <= params.max_distance;
  }
}

void check_list_pair(const std::vector<PlaneShape>& shapes, int descriptors, int keypoints, const char* set) {
  const std::string descriptor_port = std::string(set) + "_descriptors", keypoint_port = std::string(set) + "_keypoints";
  if (shapes[static_cast<size_t>(descriptors)].width != kBriefWords) {
    throw KernelError("input '" + descriptor_port + "': expected a width of 8 words (kernels/brief256.cpp), got " +
                      std::to_string(shapes[static_cast<size_t>(descriptors)].width));
  }
  if (shapes[static_cast<size_t>(keypoints)].width != arm::kKeypointWords) {
    throw KernelError("input '" + keypoint_port + "': expected a width of 4 words (arm/tasks/keypoint_record.h), got " +
                      std::to_string(shapes[static_cast<size_t>(keypoints)].width));
  }
  if (shapes[static_cast<size_t>(keypoints)].height != shapes[static_cast<size_t>(descriptors)].height) {
    throw KernelError("input '" + keypoint_port + "': expected as many rows as '" + descriptor_port + "' (" +
                      std::to_string(shapes[static_cast<size_t>(descriptors)].height) + "), got " +
                      std::to_string(shapes[static_cast<size_t>(keypoints)].height));
  }
  if (shapes[static_cast<size_t>(descriptors)].height < 1 || shapes[static_cast<size_t>(descriptors)].height > (1 << 20)) {
    throw KernelError("input '" + descriptor_port + "': expected 1 .. 1048576 rows, got " +
                      std::to_string(shapes[static_cast<size_t>(descriptors)].height));
  }
}

PreparedKernel hamming_match_prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"ratio_q8", "max_distance"});
  if (input_shapes.size() != 4) {
    throw KernelError("inputs: expected 4 (query_descriptors, query_keypoints, train_descriptors, train_keypoints), got " +
                      std::to_string(input_shapes.size()));
  }
  check_list_pair(input_shapes, 0, 1, "query");
  check_list_pair(input_shapes, 2, 3, "train");
  auto prepared = std::make_shared<HammingMatchParams>();
  prepared->ratio_q8 = param_int(params, "ratio_q8", 205, 0, 256);
  prepared->max_distance = param_int(params, "max_distance", 256, 0, 256);
  prepared->train_rows = input_shapes[2].height;
  return PreparedKernel{prepared, {{kMatchWords, input_shapes[0].height}}};
}

KernelDescriptor make_hamming_match() {
  KernelDescriptor descriptor;
  descriptor.name = "hamming_match";
  descriptor.summary =
      "brute-force BRIEF-256 matcher: per query the nearest and second train by Hamming distance (popcount), ratio test in Q8";
  descriptor.ports = {{"query_descriptors", PortDirection::input, {ElementType::u32, 0}, PortAccess::whole},
                      {"query_keypoints", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"train_descriptors", PortDirection::input, {ElementType::u32, 0}, PortAccess::whole},
                      {"train_keypoints", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"matches", PortDirection::output, {ElementType::s32, 0}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};  // no pixel outside a plane is ever read
  descriptor.full_width_tiles = true;                 // a row is one query's record
  descriptor.prepare = hamming_match_prepare;
  descriptor.scratch_bytes = [](int, int, const void* params) {
    const auto& prepared = *static_cast<const HammingMatchParams*>(params);
    return sizeof(uint32_t) * (kBriefWords + 1) * static_cast<size_t>(padded_train_rows(prepared.train_rows));
  };
  descriptor.source_rect = [](int input, const PixelRect& output_tile, const PlaneShape& input_shape, const void*) {
    if (input <= 1) return PixelRect{0, output_tile.y0, input_shape.width, output_tile.y1};  // the tile's queries
    return PixelRect{0, 0, input_shape.width, input_shape.height};                          // the whole train set
  };
  descriptor.counting = hamming_match_counting;
  descriptor.reference = hamming_match_reference;
  LPSTEREO_FILL_NATIVE_TABLE(hamming_match)
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::kernels

LPSTEREO_REGISTER_KERNEL(hamming_match, lpstereo::kernels::make_hamming_match);
#endif
