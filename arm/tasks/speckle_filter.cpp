// ARM task "speckle_filter": small-speckle removal on s16 Q4 disparity, the semantics of OpenCV's
// cv::filterSpeckles(img, newVal, maxSpeckleSize, maxDiff) on CV_16S (what StereoSGBM runs with
// newVal = (minDisparity - 1) * 16, maxDiff = 16 * speckleRange), written here without OpenCV.
//
// A speckle region is a 4-connected set of valid pixels (value != invalid_q4) in which neighbours
// differ by at most max_difference_q4 (|a - b| <= max_difference_q4, Q4 units); every region of at
// most max_speckle_size pixels (OpenCV's `count <= maxSpeckleSize`) becomes invalid_q4, every other
// pixel keeps its value. The regions are the connected components of that neighbour relation on the
// input map, so the result does not depend on the visiting order: OpenCV labels them by a
// depth-first wavefront from each unlabelled pixel in raster order, this task too, and both give
// the same bits (tests/arm/speckle_filter_test.cpp compares with cv::filterSpeckles on random and
// structured maps and expects bit-exact agreement).
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
#include <string>
#include <vector>

#include "arm/fork_join.h"
#include "dag/arm_task.h"

namespace lpstereo::arm {
namespace {

// A pixel is kept as y << 16 | x: no division by the width at every neighbour visit (one of the
// reasons the filter took 2.3 times OpenCV's time at 640x480, docs/evaluation.md); sides up to
// 65535 pixels.
using PackedPixel = uint32_t;
constexpr int kMaxSide = 65535;
inline PackedPixel pack(int x, int y) { return static_cast<PackedPixel>(y) << 16 | static_cast<PackedPixel>(x); }
inline int x_of(PackedPixel pixel) { return static_cast<int>(pixel & 0xFFFFu); }
inline int y_of(PackedPixel pixel) { return static_cast<int>(pixel >> 16); }

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
  const PlaneShape& shape = input_shapes.at(0);
  if (shape.width > kMaxSide || shape.height > kMaxSide) {
    throw KernelError("speckle_filter: expected a map of at most " + std::to_string(kMaxSide) + " x " + std::to_string(kMaxSide) +
                      " pixels, got " + std::to_string(shape.width) + " x " + std::to_string(shape.height));
  }
  return PreparedKernel{prepared, {shape}};
}

// A band's region that reaches one of the band's edge rows, and may go on across the seam.
struct EdgeRegion {
  int64_t size = 0;
  std::vector<PackedPixel> pixels;  // kept only while size <= max_speckle_size
};

// One band's result. alignas(64): each band's counters and vectors grow from its own thread.
struct alignas(64) BandResult {
  uint64_t valid = 0, regions = 0, invalidated = 0;
  std::vector<EdgeRegion> edge_regions;
  // Per column, the index in edge_regions of the region holding the band's first / last row's
  // pixel, -1 for none (invalid pixels).
  std::vector<int32_t> first_row_region, last_row_region;
};

// The first x' >= x of the row whose pixel is valid and not yet visited, width when none: the scan
// of every pixel, out of line so that its loop keeps its few values in registers (inlined into the
// flood fill, it kept x and the invalid value in memory).
[[gnu::noinline]] int next_seed(const int16_t* row, const uint8_t* visited_row, int x, int width, int16_t invalid) {
  while (x < width && (row[x] == invalid || visited_row[x] != 0)) ++x;
  return x;
}

// A band's working memory, kept by its thread from call to call (the disparity engine's workers and
// fork_join's helpers persist): fresh buffers each call were first touched page by page, and two
// threads faulting pages in at once held each other up (share 0 took 3.7 ms for the half that
// took its helper 1.7 ms, 640x480).
struct BandBuffers {
  std::vector<uint8_t> visited;        // the band's rows x width, zeroed per call
  std::vector<PackedPixel> pending;    // the depth-first stack, grown on demand
  std::vector<PackedPixel> speckle;    // the region's pixels while it may be a speckle
};
BandBuffers& band_buffers() {
  thread_local BandBuffers buffers;
  return buffers;
}

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

  // The bands: at most one per 16 rows, cut where the valid pixels (the work) reach equal shares.
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
  std::vector<BandResult> bands(static_cast<size_t>(band_count));
  fork_join(band_count, [&](int band_index) {
    BandResult& band = bands[static_cast<size_t>(band_index)];
    const int first_row = band_first_row[static_cast<size_t>(band_index)];
    const int end_row = band_first_row[static_cast<size_t>(band_index) + 1];
    // Edge rows that face another band (the image's own first and last rows face none).
    const bool first_row_faces_band = band_index > 0, last_row_faces_band = band_index + 1 < band_count;
    if (first_row_faces_band) band.first_row_region.assign(static_cast<size_t>(width), -1);
    if (last_row_faces_band) band.last_row_region.assign(static_cast<size_t>(width), -1);
    const ptrdiff_t stride = input.stride_bytes() / static_cast<ptrdiff_t>(sizeof(int16_t));  // elements per row
    // Locals, not the captures: the compiler reloaded a captured value per pixel.
    const int16_t invalid_value = invalid;
    const int max_difference = params.max_difference_q4;
    // Depth first, as OpenCV's wavefront: a stack of pixels to explore, and the region's pixels
    // listed only while it may be a speckle (at most max_speckle_size of them). Raw pointers into
    // the buffers (a vector's push_back checked its capacity per pixel); the stack's room for a
    // pixel's four neighbours is checked once per pixel popped.
    BandBuffers& buffers = band_buffers();
    const size_t band_pixels = static_cast<size_t>(end_row - first_row) * static_cast<size_t>(width);
    if (buffers.visited.size() < band_pixels) buffers.visited.resize(band_pixels);
    std::fill(buffers.visited.begin(), buffers.visited.begin() + static_cast<ptrdiff_t>(band_pixels), uint8_t{0});
    // visited of row y (a row of this band) starts at visited_rows + y * width.
    uint8_t* const visited_rows = buffers.visited.data() - static_cast<ptrdiff_t>(first_row) * width;
    if (buffers.pending.size() < 1024) buffers.pending.resize(1024);
    const size_t speckle_room = std::min(max_size, band_pixels);
    if (buffers.speckle.size() < speckle_room) buffers.speckle.resize(speckle_room);
    PackedPixel* const speckle = buffers.speckle.data();
    uint64_t valid = 0, regions = 0, invalidated = 0;
    for (int y = first_row; y < end_row; ++y) {
      const int16_t* row = input.row<const int16_t>(y);
      uint8_t* visited_row = visited_rows + static_cast<ptrdiff_t>(y) * width;
      for (int x = next_seed(row, visited_row, 0, width, invalid_value); x < width;
           x = next_seed(row, visited_row, x + 1, width, invalid_value)) {
        ++regions;
        PackedPixel* bottom = buffers.pending.data();
        PackedPixel* room_end = bottom + buffers.pending.size();
        PackedPixel* top = bottom;
        *top++ = pack(x, y);
        visited_row[x] = 1;
        size_t size = 0;
        int32_t edge_index = -1;  // in band.edge_regions once the region reaches an edge row
        while (top != bottom) {
          const PackedPixel pixel = *--top;
          if (room_end - top < 4) {
            const ptrdiff_t depth = top - bottom;
            buffers.pending.resize(2 * buffers.pending.size());
            bottom = buffers.pending.data();
            room_end = bottom + buffers.pending.size();
            top = bottom + depth;
          }
          if (size < max_size) speckle[size] = pixel;
          ++size;
          const int px = x_of(pixel), py = y_of(pixel);
          const bool on_first_row = first_row_faces_band && py == first_row, on_last_row = last_row_faces_band && py == end_row - 1;
          if (on_first_row || on_last_row) {
            if (edge_index < 0) {
              edge_index = static_cast<int32_t>(band.edge_regions.size());
              band.edge_regions.emplace_back();
            }
            if (on_first_row) band.first_row_region[static_cast<size_t>(px)] = edge_index;
            if (on_last_row) band.last_row_region[static_cast<size_t>(px)] = edge_index;
          }
          const int16_t* value_row = input.row<const int16_t>(py);
          uint8_t* visited_here = visited_rows + static_cast<ptrdiff_t>(py) * width;
          const int value = value_row[px];
          // The neighbour at (nx, ny), whose value row and visited row are given.
          auto visit = [&](const int16_t* neighbour_values, uint8_t* neighbour_visited, int nx, int ny) {
            if (neighbour_visited[nx]) return;
            const int other = neighbour_values[nx];
            if (other == invalid_value || std::abs(value - other) > max_difference) return;
            neighbour_visited[nx] = 1;
            *top++ = pack(nx, ny);
          };
          if (py + 1 < end_row) visit(value_row + stride, visited_here + width, px, py + 1);
          if (py > first_row) visit(value_row - stride, visited_here - width, px, py - 1);
          if (px + 1 < width) visit(value_row, visited_here, px + 1, py);
          if (px > 0) visit(value_row, visited_here, px - 1, py);
        }
        valid += size;
        if (edge_index >= 0) {
          // Decided after the join: its size so far, its pixels while it may still be a speckle.
          EdgeRegion& edge = band.edge_regions[static_cast<size_t>(edge_index)];
          edge.size = static_cast<int64_t>(size);
          if (size <= max_size) edge.pixels.assign(speckle, speckle + size);
        } else if (size <= max_size) {
          for (size_t k = 0; k < size; ++k) output.row<int16_t>(y_of(speckle[k]))[x_of(speckle[k])] = invalid_value;
          invalidated += size;
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
        for (const PackedPixel pixel : edges[k].pixels) output.row<int16_t>(y_of(pixel))[x_of(pixel)] = invalid;
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
