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
// default 100), max_difference_q4 (default 16 = 1 px), invalid_q4 (default -16, min_disparity 0),
// threads (host threads, default 1: the chip runs the task on one ARM core).
//
// Threads (the host's disparity engine passes its workers: the other worker has nothing to do
// while the filter runs): the rows are cut into contiguous bands of about equal numbers of valid
// pixels, one per thread (arm/fork_join.h). Each band labels its regions as above, restricted to
// its rows; a region that reaches neither of the band's edge rows is a whole region of the map and
// is decided at once. A region that reaches an edge row may continue in the next band: the bands'
// edge-touching regions are joined by union-find wherever two vertically adjacent pixels across a
// seam are neighbours (both valid, within max_difference_q4), which gives exactly the map's regions
// (a region is connected, so its pieces in the bands are linked through seam pairs), and a joined
// region of at most max_speckle_size pixels is invalidated from the pixel lists its pieces kept
// (a piece larger than that is never invalidated, so it keeps none). Same bits as one thread
// (tests/arm/speckle_filter_test.cpp compares 1, 2, 3 and 8 threads), and the same counted work:
// R counts the joined regions.
//
// Counted work (deterministic, ArmWork), with P pixels, V valid pixels (each is explored exactly
// once), R regions and I pixels invalidated:
//   scalar_ops   = 3 P (scan: load, compare with invalid, visited test)
//                + 24 V (pop, count, and per neighbour 5: bounds, visited load, value load, invalid
//                  compare, difference compare; the push of the pixel itself)
//                + 4 R (region start, size compare, bookkeeping) + I (the store of invalid_q4);
//   memory_bytes = 5 P (2 read, 2 written to the output, 1 visited flag) + 2 I.
// Neighbour reads stay in rows the scan has just touched (cache hits): not counted as DRAM bytes.
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <numeric>
#include <vector>

#include "arm/fork_join.h"
#include "dag/arm_task.h"

namespace lpstereo::arm {
namespace {

struct SpeckleParams {
  int max_speckle_size;
  int max_difference_q4;
  int16_t invalid_q4;
  int threads;
};

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"max_speckle_size", "max_difference_q4", "invalid_q4", "threads"});
  auto prepared = std::make_shared<SpeckleParams>();
  prepared->max_speckle_size = param_int(params, "max_speckle_size", 100, 0, 1 << 30);
  prepared->max_difference_q4 = param_int(params, "max_difference_q4", 16, 0, 65535);
  prepared->invalid_q4 = static_cast<int16_t>(param_int(params, "invalid_q4", -16, -32768, 32767));
  prepared->threads = param_int(params, "threads", 1, 1, 64);
  return PreparedKernel{prepared, {input_shapes.at(0)}};
}

// A band's region that reaches one of the band's edge rows, and may go on across the seam.
struct EdgeRegion {
  int64_t size = 0;
  std::vector<int32_t> pixels;  // kept only while size <= max_speckle_size
};

// One band's result. alignas(64): each band's counters and vectors grow from its own thread.
struct alignas(64) BandResult {
  uint64_t valid = 0, regions = 0, invalidated = 0;
  std::vector<EdgeRegion> edge_regions;
  // Per column, the index in edge_regions of the region holding the band's first / last row's
  // pixel, -1 for none (invalid pixels).
  std::vector<int32_t> first_row_region, last_row_region;
};

// Union-find over the bands' edge regions (path halving, union by index: deterministic).
int32_t find_root(std::vector<int32_t>& parent, int32_t node) {
  while (parent[static_cast<size_t>(node)] != node) {
    parent[static_cast<size_t>(node)] = parent[static_cast<size_t>(parent[static_cast<size_t>(node)])];
    node = parent[static_cast<size_t>(node)];
  }
  return node;
}

void run(const ArmTaskArgs& args) {
  const auto& params = *static_cast<const SpeckleParams*>(args.params);
  const Plane& input = *args.inputs.at(0);
  Plane& output = *args.outputs.at(0);
  const int width = input.width();
  const int height = input.height();
  const size_t pixels = static_cast<size_t>(width) * static_cast<size_t>(height);
  const int16_t invalid = params.invalid_q4;
  const size_t max_size = static_cast<size_t>(params.max_speckle_size);
  for (int y = 0; y < height; ++y) std::memcpy(output.row<int16_t>(y), input.row<int16_t>(y), static_cast<size_t>(width) * 2);

  // The bands: at least 16 rows each, cut where the valid pixels (the work) reach equal shares.
  std::vector<int> band_first_row = {0, height};
  const int wanted_bands = std::max(1, std::min(params.threads, height / 16));
  if (wanted_bands > 1) {
    std::vector<int64_t> valid_before_row(static_cast<size_t>(height) + 1, 0);
    for (int y = 0; y < height; ++y) {
      const int16_t* row = input.row<const int16_t>(y);
      int64_t valid_in_row = 0;
      for (int x = 0; x < width; ++x) valid_in_row += row[x] != invalid ? 1 : 0;
      valid_before_row[static_cast<size_t>(y) + 1] = valid_before_row[static_cast<size_t>(y)] + valid_in_row;
    }
    band_first_row = balanced_row_bands(valid_before_row, wanted_bands);
    // No empty band: a seam joins the last row of one band and the first row of the next.
    band_first_row.erase(std::unique(band_first_row.begin(), band_first_row.end()), band_first_row.end());
  }

  const int band_count = static_cast<int>(band_first_row.size()) - 1;
  std::vector<uint8_t> visited(pixels, 0);
  std::vector<BandResult> bands(static_cast<size_t>(band_count));
  auto value_at = [&](int32_t index) { return input.row<const int16_t>(index / width)[index % width]; };
  fork_join(band_count, [&](int band_index) {
    BandResult& band = bands[static_cast<size_t>(band_index)];
    const int first_row = band_first_row[static_cast<size_t>(band_index)];
    const int end_row = band_first_row[static_cast<size_t>(band_index) + 1];
    // Edge rows that face another band (the image's own first and last rows face none).
    const bool first_row_faces_band = band_index > 0, last_row_faces_band = band_index + 1 < band_count;
    if (first_row_faces_band) band.first_row_region.assign(static_cast<size_t>(width), -1);
    if (last_row_faces_band) band.last_row_region.assign(static_cast<size_t>(width), -1);
    std::vector<int32_t> region;  // the current region's pixels (y * width + x), in visiting order
    region.reserve(1024);
    uint64_t valid = 0, regions = 0, invalidated = 0;
    for (int y = first_row; y < end_row; ++y) {
      const int16_t* row = input.row<const int16_t>(y);
      for (int x = 0; x < width; ++x) {
        const int32_t seed = y * width + x;
        if (row[x] == invalid || visited[static_cast<size_t>(seed)]) continue;
        ++regions;
        region.clear();
        region.push_back(seed);
        visited[static_cast<size_t>(seed)] = 1;
        bool reaches_edge = false;
        for (size_t head = 0; head < region.size(); ++head) {
          const int32_t index = region[head];
          const int px = index % width;
          const int py = index / width;
          const int value = value_at(index);
          reaches_edge |= (first_row_faces_band && py == first_row) || (last_row_faces_band && py == end_row - 1);
          auto visit = [&](bool inside, int32_t neighbour) {
            if (!inside || visited[static_cast<size_t>(neighbour)]) return;
            const int other = value_at(neighbour);
            if (other == invalid || std::abs(value - other) > params.max_difference_q4) return;
            visited[static_cast<size_t>(neighbour)] = 1;
            region.push_back(neighbour);
          };
          visit(py + 1 < end_row, index + width);
          visit(py > first_row, index - width);
          visit(px + 1 < width, index + 1);
          visit(px > 0, index - 1);
        }
        valid += region.size();
        if (reaches_edge) {
          // Decided after the join: its size so far, its pixels while it may still be a speckle.
          const int32_t edge_index = static_cast<int32_t>(band.edge_regions.size());
          EdgeRegion& edge = band.edge_regions.emplace_back();
          edge.size = static_cast<int64_t>(region.size());
          if (region.size() <= max_size) edge.pixels = region;
          for (const int32_t index : region) {
            const int py = index / width, px = index % width;
            if (first_row_faces_band && py == first_row) band.first_row_region[static_cast<size_t>(px)] = edge_index;
            if (last_row_faces_band && py == end_row - 1) band.last_row_region[static_cast<size_t>(px)] = edge_index;
          }
        } else if (region.size() <= max_size) {
          for (const int32_t index : region) output.row<int16_t>(index / width)[index % width] = invalid;
          invalidated += region.size();
        }
      }
    }
    band.valid = valid;
    band.regions = regions;
    band.invalidated = invalidated;
  });

  uint64_t valid = 0, regions = 0, invalidated = 0;
  for (const BandResult& band : bands) {
    valid += band.valid;
    regions += band.regions;
    invalidated += band.invalidated;
  }
  if (band_count > 1) {
    // The edge regions of every band, numbered band after band; joined across each seam.
    std::vector<int32_t> first_of_band(static_cast<size_t>(band_count) + 1, 0);
    for (int b = 0; b < band_count; ++b) {
      first_of_band[static_cast<size_t>(b) + 1] = first_of_band[static_cast<size_t>(b)] +
                                                  static_cast<int32_t>(bands[static_cast<size_t>(b)].edge_regions.size());
    }
    std::vector<int32_t> parent(static_cast<size_t>(first_of_band.back()));
    std::iota(parent.begin(), parent.end(), 0);
    std::vector<int64_t> size(parent.size(), 0);
    for (int b = 0; b < band_count; ++b) {
      const std::vector<EdgeRegion>& edges = bands[static_cast<size_t>(b)].edge_regions;
      for (size_t k = 0; k < edges.size(); ++k) size[static_cast<size_t>(first_of_band[static_cast<size_t>(b)]) + k] = edges[k].size;
    }
    for (int b = 0; b + 1 < band_count; ++b) {
      const int above_row = band_first_row[static_cast<size_t>(b) + 1] - 1;
      const int16_t* above = input.row<const int16_t>(above_row);
      const int16_t* below = input.row<const int16_t>(above_row + 1);
      const std::vector<int32_t>& above_region = bands[static_cast<size_t>(b)].last_row_region;
      const std::vector<int32_t>& below_region = bands[static_cast<size_t>(b) + 1].first_row_region;
      for (int x = 0; x < width; ++x) {
        if (above[x] == invalid || below[x] == invalid || std::abs(above[x] - below[x]) > params.max_difference_q4) continue;
        const int32_t a = find_root(parent, first_of_band[static_cast<size_t>(b)] + above_region[static_cast<size_t>(x)]);
        const int32_t c = find_root(parent, first_of_band[static_cast<size_t>(b) + 1] + below_region[static_cast<size_t>(x)]);
        if (a == c) continue;
        parent[static_cast<size_t>(std::max(a, c))] = std::min(a, c);
        size[static_cast<size_t>(std::min(a, c))] += size[static_cast<size_t>(std::max(a, c))];
        --regions;  // two pieces of one region
      }
    }
    for (int b = 0; b < band_count; ++b) {
      const std::vector<EdgeRegion>& edges = bands[static_cast<size_t>(b)].edge_regions;
      for (size_t k = 0; k < edges.size(); ++k) {
        const int32_t root = find_root(parent, first_of_band[static_cast<size_t>(b)] + static_cast<int32_t>(k));
        if (size[static_cast<size_t>(root)] > static_cast<int64_t>(max_size)) continue;
        for (const int32_t index : edges[k].pixels) output.row<int16_t>(index / width)[index % width] = invalid;
        invalidated += edges[k].pixels.size();
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
