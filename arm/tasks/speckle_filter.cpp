// ARM task "speckle_filter": small-speckle removal on s16 Q4 disparity, the semantics of OpenCV's
// cv::filterSpeckles(img, newVal, maxSpeckleSize, maxDiff) on CV_16S (what StereoSGBM runs with
// newVal = (minDisparity - 1) * 16, maxDiff = 16 * speckleRange), written here without OpenCV.
//
// A speckle region is a 4-connected set of valid pixels (value != invalid_q4) in which neighbours
// differ by at most max_difference_q4 (|a - b| <= max_difference_q4, Q4 units); every region of at
// most max_speckle_size pixels (OpenCV's `count <= maxSpeckleSize`) becomes invalid_q4, every other
// pixel keeps its value. The regions are the connected components of that neighbour relation on the
// input map, so the result does not depend on the visiting order: OpenCV labels them by a
// depth-first wavefront from each unlabelled pixel in raster order, this task by a breadth-first
// one, and both give the same bits (tests/arm/speckle_filter_test.cpp compares with
// cv::filterSpeckles on random and structured maps and expects bit-exact agreement).
//
// Ports: "disparity" s16q4 in, "filtered" s16q4 out, same size. Parameters: max_speckle_size (px,
// default 100), max_difference_q4 (default 16 = 1 px), invalid_q4 (default -16, min_disparity 0).
//
// Counted work (deterministic, ArmWork), with P pixels, V valid pixels (each is explored exactly
// once), R regions and I pixels invalidated:
//   scalar_ops   = 3 P (scan: load, compare with invalid, visited test)
//                + 24 V (pop, count, and per neighbour 5: bounds, visited load, value load, invalid
//                  compare, difference compare; the push of the pixel itself)
//                + 4 R (region start, size compare, bookkeeping) + I (the store of invalid_q4);
//   memory_bytes = 5 P (2 read, 2 written to the output, 1 visited flag) + 2 I.
// Neighbour reads stay in rows the scan has just touched (cache hits): not counted as DRAM bytes.
#include <cstdlib>
#include <cstring>
#include <vector>

#include "dag/arm_task.h"

namespace lpstereo::arm {
namespace {

struct SpeckleParams {
  int max_speckle_size;
  int max_difference_q4;
  int16_t invalid_q4;
};

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"max_speckle_size", "max_difference_q4", "invalid_q4"});
  auto prepared = std::make_shared<SpeckleParams>();
  prepared->max_speckle_size = param_int(params, "max_speckle_size", 100, 0, 1 << 30);
  prepared->max_difference_q4 = param_int(params, "max_difference_q4", 16, 0, 65535);
  prepared->invalid_q4 = static_cast<int16_t>(param_int(params, "invalid_q4", -16, -32768, 32767));
  return PreparedKernel{prepared, {input_shapes.at(0)}};
}

void run(const ArmTaskArgs& args) {
  const auto& params = *static_cast<const SpeckleParams*>(args.params);
  const Plane& input = *args.inputs.at(0);
  Plane& output = *args.outputs.at(0);
  const int width = input.width();
  const int height = input.height();
  const size_t pixels = static_cast<size_t>(width) * static_cast<size_t>(height);
  for (int y = 0; y < height; ++y) std::memcpy(output.row<int16_t>(y), input.row<int16_t>(y), static_cast<size_t>(width) * 2);

  std::vector<uint8_t> visited(pixels, 0);
  std::vector<int32_t> region;  // the current region's pixels (y * width + x), in visiting order
  region.reserve(1024);
  uint64_t valid = 0, regions = 0, invalidated = 0;
  const int16_t invalid = params.invalid_q4;
  auto value_at = [&](int32_t index) { return input.row<const int16_t>(index / width)[index % width]; };

  for (int y = 0; y < height; ++y) {
    const int16_t* row = input.row<const int16_t>(y);
    for (int x = 0; x < width; ++x) {
      const int32_t seed = y * width + x;
      if (row[x] == invalid || visited[static_cast<size_t>(seed)]) continue;
      ++regions;
      region.clear();
      region.push_back(seed);
      visited[static_cast<size_t>(seed)] = 1;
      for (size_t head = 0; head < region.size(); ++head) {
        const int32_t index = region[head];
        const int px = index % width;
        const int py = index / width;
        const int value = value_at(index);
        auto visit = [&](bool inside, int32_t neighbour) {
          if (!inside || visited[static_cast<size_t>(neighbour)]) return;
          const int other = value_at(neighbour);
          if (other == invalid || std::abs(value - other) > params.max_difference_q4) return;
          visited[static_cast<size_t>(neighbour)] = 1;
          region.push_back(neighbour);
        };
        visit(py + 1 < height, index + width);
        visit(py > 0, index - width);
        visit(px + 1 < width, index + 1);
        visit(px > 0, index - 1);
      }
      valid += region.size();
      if (region.size() <= static_cast<size_t>(params.max_speckle_size)) {
        for (const int32_t index : region) output.row<int16_t>(index / width)[index % width] = invalid;
        invalidated += region.size();
      }
    }
  }
  if (args.work != nullptr) {
    args.work->scalar_ops += 3 * pixels + 24 * valid + 4 * regions + invalidated;
    args.work->memory_bytes += 5 * pixels + 2 * invalidated;
  }
}

ArmTaskDescriptor make_speckle_filter() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "speckle_filter";
  descriptor.summary = "invalidate small connected regions of s16 Q4 disparity (cv::filterSpeckles semantics)";
  descriptor.ports = {{"disparity", PortDirection::input, {ElementType::s16, 4}, PortAccess::whole},
                      {"filtered", PortDirection::output, {ElementType::s16, 4}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(speckle_filter, lpstereo::arm::make_speckle_filter);
