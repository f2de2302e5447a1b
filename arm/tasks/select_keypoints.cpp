// ARM task "select_keypoints": the keypoint list (arm/tasks/keypoint_record.h) from the Harris corner
// mask (kernels/harris_nms.cpp) and response (kernels/harris_response.cpp): the strongest
// per_cell_k corners of every cell of a grid, at most max_keypoints in all. Bucketing by cells (as
// libviso2 and ORB-SLAM do when they extract features) spreads the keypoints over the image so that
// localization (thesis 003 §3.5) is not dominated by one textured patch; the thesis itself names no
// selection rule. The obstacle detector's feature validation (issue 6 item 5) reads the same list.
//
// Model. Candidates are the pixels with corner mask 1 inside [border_px, W - border_px) x
// [border_px, H - border_px) (border_px keeps the BRIEF patch inside the image: 16 for brief256's
// 31 x 31 patch). Cell (i, j) covers columns [i cell_size_px, (i + 1) cell_size_px) and rows
// [j cell_size_px, (j + 1) cell_size_px) of the image (the grid starts at pixel (0, 0), not at the
// border). Order "stronger": larger response first, then smaller row, then smaller column: a total
// order (positions are unique), so every choice below is deterministic.
// Steps, per frame:
//   1. scan the mask's rows inside the border, 8 bytes (one u64 word) at a time; per corner, its
//      response and its cell;
//   2. per cell keep the per_cell_k stronger candidates (insertion into a sorted list of at most
//      per_cell_k entries);
//   3. all kept candidates, sorted stronger first; the first max_keypoints of them are the list.
// Output rows 0 .. n - 1: valid 1, x, y, response (in that order: strongest first, so a consumer
// that wants fewer takes a prefix); rows n .. max_keypoints - 1 all zero.
//
// Ports: "corners" u8 (harris_nms's mask: 0 or 1; any nonzero byte counts as a corner), "response"
// s32 (harris_response's, the same size), output "keypoints" s32 kKeypointWords x max_keypoints.
// Parameters: cell_size_px (8 .. 4096, default 64), per_cell_k (1 .. 64, default 4), max_keypoints
// (1 .. 65536, default 2048), border_px (0 .. 1024, default 16).
//
// Counted work (deterministic, ArmWork), with Wi x Hi the inside of the border, Z the words of 8 mask
// bytes per row inside it (ceil(Wi / 8)), N the u64 words holding a corner, C the candidates, S the
// kept candidates, M = max_keypoints:
//   scalar_ops   = 2 Z Hi (load, test the word) + 16 N (per byte of such a word: test, branch)
//                  + C (4 + per_cell_k) (response load, cell index, insertion compares)
//                  + 2 S ceil(log2(S + 1)) (sort) + 8 M (records written);
//   memory_bytes = 8 Z Hi (mask words) + 4 C (responses) + 4 kKeypointWords M (the output).
#include <algorithm>
#include <bit>
#include <cstring>
#include <string>
#include <vector>

#include "arm/tasks/keypoint_record.h"
#include "dag/arm_task.h"

namespace lpstereo::arm {
namespace {

struct SelectKeypointsParams {
  int cell_size_px = 64;
  int per_cell_k = 4;
  int max_keypoints = 2048;
  int border_px = 16;
};

struct Candidate {
  int32_t response;
  int32_t x, y;
};

// "Stronger": larger response, then smaller row, then smaller column.
bool stronger(const Candidate& a, const Candidate& b) {
  if (a.response != b.response) return a.response > b.response;
  if (a.y != b.y) return a.y < b.y;
  return a.x < b.x;
}

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"cell_size_px", "per_cell_k", "max_keypoints", "border_px"});
  if (input_shapes.size() != 2) {
    throw KernelError("inputs: expected 2 (corners, response), got " + std::to_string(input_shapes.size()));
  }
  if (!(input_shapes[0] == input_shapes[1])) {
    throw KernelError("input 'response': expected the corner mask's size " + std::to_string(input_shapes[0].width) + "x" +
                      std::to_string(input_shapes[0].height) + ", got " + std::to_string(input_shapes[1].width) + "x" +
                      std::to_string(input_shapes[1].height));
  }
  auto prepared = std::make_shared<SelectKeypointsParams>();
  prepared->cell_size_px = param_int(params, "cell_size_px", 64, 8, 4096);
  prepared->per_cell_k = param_int(params, "per_cell_k", 4, 1, 64);
  prepared->max_keypoints = param_int(params, "max_keypoints", 2048, 1, 65536);
  prepared->border_px = param_int(params, "border_px", 16, 0, 1024);
  return PreparedKernel{prepared, {{kKeypointWords, prepared->max_keypoints}}};
}

void run(const ArmTaskArgs& args) {
  const auto& p = *static_cast<const SelectKeypointsParams*>(args.params);
  const Plane& corners = *args.inputs.at(0);
  const Plane& response = *args.inputs.at(1);
  Plane& output = *args.outputs.at(0);
  if (corners.width() != response.width() || corners.height() != response.height()) {
    throw KernelError("input 'response': expected the corner mask's size " + std::to_string(corners.width()) + "x" +
                      std::to_string(corners.height()) + ", got " + std::to_string(response.width()) + "x" +
                      std::to_string(response.height()));
  }
  const int width = corners.width();
  const int height = corners.height();
  const int x0 = p.border_px, y0 = p.border_px;
  const int x1 = std::max(x0, width - p.border_px), y1 = std::max(y0, height - p.border_px);
  const int cells_x = (width + p.cell_size_px - 1) / p.cell_size_px;
  const int cells_y = (height + p.cell_size_px - 1) / p.cell_size_px;
  const auto k = static_cast<size_t>(p.per_cell_k);
  std::vector<std::vector<Candidate>> cells(static_cast<size_t>(cells_x) * static_cast<size_t>(cells_y));
  uint64_t ops = 0, mask_words = 0, candidates = 0;

  // 1 and 2: scan in u64 words; per corner, insert into its cell's sorted top-k.
  for (int y = y0; y < y1; ++y) {
    const uint8_t* row = corners.row<const uint8_t>(y);
    const int32_t* responses = response.row<const int32_t>(y);
    for (int x = x0; x < x1; x += 8) {
      const int bytes = std::min(8, x1 - x);
      uint64_t word = 0;
      std::memcpy(&word, row + x, static_cast<size_t>(bytes));
      ++mask_words;
      if (word == 0) continue;
      ops += 16;
      for (int i = 0; i < bytes; ++i) {
        if (row[x + i] == 0) continue;
        ++candidates;
        const Candidate candidate{responses[x + i], x + i, y};
        std::vector<Candidate>& cell =
            cells[static_cast<size_t>(y / p.cell_size_px) * static_cast<size_t>(cells_x) + static_cast<size_t>((x + i) / p.cell_size_px)];
        if (cell.size() == k && !stronger(candidate, cell.back())) continue;
        if (cell.size() == k) cell.pop_back();
        cell.insert(std::upper_bound(cell.begin(), cell.end(), candidate, stronger), candidate);
      }
    }
  }
  ops += 2 * mask_words + candidates * (4 + k);

  // 3: all kept, stronger first, the first max_keypoints.
  std::vector<Candidate> kept;
  for (const std::vector<Candidate>& cell : cells) kept.insert(kept.end(), cell.begin(), cell.end());
  std::sort(kept.begin(), kept.end(), stronger);
  const uint64_t kept_count = kept.size();
  ops += 2 * kept_count * static_cast<uint64_t>(std::bit_width(kept_count));  // ceil(log2(S + 1)) = bit_width(S)
  const int count = static_cast<int>(std::min<size_t>(kept.size(), static_cast<size_t>(p.max_keypoints)));
  for (int row = 0; row < output.height(); ++row) {
    int32_t* word = output.row<int32_t>(row);
    std::fill(word, word + kKeypointWords, 0);
    if (row >= count) continue;
    word[kKeypointValid] = 1;
    word[kKeypointXPx] = kept[static_cast<size_t>(row)].x;
    word[kKeypointYPx] = kept[static_cast<size_t>(row)].y;
    word[kKeypointResponse] = kept[static_cast<size_t>(row)].response;
  }
  ops += 8ull * static_cast<uint64_t>(p.max_keypoints);
  if (args.work != nullptr) {
    args.work->scalar_ops += ops;
    args.work->memory_bytes += 8 * mask_words + 4 * candidates + 4ull * kKeypointWords * static_cast<uint64_t>(p.max_keypoints);
  }
}

ArmTaskDescriptor make_select_keypoints() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "select_keypoints";
  descriptor.summary =
      "keypoint list from a corner mask and response: strongest per_cell_k per grid cell inside border_px, at most max_keypoints, strongest first";
  descriptor.ports = {{"corners", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"response", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"keypoints", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(select_keypoints, lpstereo::arm::make_select_keypoints);
