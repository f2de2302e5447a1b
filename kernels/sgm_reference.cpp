// Scalar SGM reference (definitions in kernels/sgm_reference.h). Baseline build only: not compiled
// per ISA level.
#include "kernels/sgm_reference.h"

#include "kernels/census_cost.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

namespace lpstereo::kernels {

SgmVolume sgm_reference_costs(const PlaneView& left, const PlaneView& right, int word_bytes, int min_disparity,
                              int num_disparities) {
  SgmVolume cost{left.width, left.height, num_disparities, {}};
  cost.values.resize(static_cast<size_t>(left.width) * left.height * num_disparities);
  for (int y = 0; y < left.height; ++y) {
    for (int x = 0; x < left.width; ++x) {
      for (int i = 0; i < num_disparities; ++i) {
        cost.at(x, y, i) = census_cost_reference(left, right, word_bytes, x, y, min_disparity + i);
      }
    }
  }
  return cost;
}

int32_t sgm_reference_add_path(const SgmVolume& cost, int p1, int p2, SgmPathDirection direction, SgmVolume& sum) {
  const SgmVolume path = sgm_reference_path(cost, p1, p2, direction);
  int32_t largest = 0;
  for (size_t i = 0; i < sum.values.size(); ++i) {
    sum.values[i] += path.values[i];
    largest = std::max(largest, path.values[i]);
  }
  return largest;
}

SgmVolume sgm_reference_path(const SgmVolume& cost, int p1, int p2, SgmPathDirection direction) {
  const int width = cost.width, height = cost.height, count = cost.disparities;
  SgmVolume path{width, height, count, std::vector<int32_t>(cost.values.size(), 0)};
  // Visit every pixel after its predecessor (x + dx, y + dy) on the path.
  for (int row = 0; row < height; ++row) {
    const int y = direction.dy > 0 ? height - 1 - row : row;
    for (int column = 0; column < width; ++column) {
      const int x = direction.dx > 0 ? width - 1 - column : column;
      const int previous_x = x + direction.dx, previous_y = y + direction.dy;
      const bool has_previous = previous_x >= 0 && previous_x < width && previous_y >= 0 && previous_y < height;
      int32_t previous_min = 0;
      if (has_previous) {
        previous_min = std::numeric_limits<int32_t>::max();
        for (int i = 0; i < count; ++i) previous_min = std::min(previous_min, path.at(previous_x, previous_y, i));
      }
      for (int i = 0; i < count; ++i) {
        int32_t value = cost.at(x, y, i);
        if (has_previous) {
          int32_t best = std::min(path.at(previous_x, previous_y, i), previous_min + p2);
          if (i > 0) best = std::min(best, path.at(previous_x, previous_y, i - 1) + p1);
          if (i + 1 < count) best = std::min(best, path.at(previous_x, previous_y, i + 1) + p1);
          value += best - previous_min;
        }
        path.at(x, y, i) = value;
      }
    }
  }
  return path;
}

void sgm_reference_select(const SgmVolume& sum, const SgmParams& settings, const PlaneView& output) {
  const int width = sum.width, count = sum.disparities;
  const int invalid = (settings.min_disparity - 1) * 16;
  std::vector<int> right_best(static_cast<size_t>(width));
  std::vector<int> left_best(static_cast<size_t>(width));
  for (int y = 0; y < sum.height; ++y) {
    int16_t* out = plane_row<int16_t>(output, y);
    for (int x = 0; x < width; ++x) {
      int best = 0;
      for (int i = 1; i < count; ++i) {
        if (sum.at(x, y, i) < sum.at(x, y, best)) best = i;
      }
      left_best[static_cast<size_t>(x)] = best;
      const int64_t best_cost = sum.at(x, y, best);
      bool valid = true;
      for (int i = 0; i < count && settings.uniqueness_percent > 0; ++i) {
        if (std::abs(i - best) > 1 && int64_t{sum.at(x, y, i)} * (100 - settings.uniqueness_percent) <= best_cost * 100) {
          valid = false;
        }
      }
      int value = (settings.min_disparity + best) * 16;
      if (settings.subpixel && best > 0 && best < count - 1) {
        const int a = sum.at(x, y, best - 1) - sum.at(x, y, best);
        const int c = sum.at(x, y, best + 1) - sum.at(x, y, best);
        const int q = (16 * std::abs(a - c) + (a + c)) / (2 * (a + c));  // a > 0: best is the first minimum
        value += a >= c ? q : -q;
      }
      out[x] = static_cast<int16_t>(valid ? value : invalid);
    }
    if (settings.lr_max_diff < 0) continue;
    // Right view: D_R(xr) = argmin over d of S(xr + d, d), ties to the smallest d.
    for (int xr = 0; xr < width; ++xr) {
      int best = -1;
      for (int i = 0; i < count; ++i) {
        const int x = xr + settings.min_disparity + i;
        if (x < 0 || x >= width) continue;
        if (best < 0 || sum.at(x, y, i) < sum.at(xr + settings.min_disparity + best, y, best)) best = i;
      }
      right_best[static_cast<size_t>(xr)] = best;
    }
    for (int x = 0; x < width; ++x) {
      const int best = left_best[static_cast<size_t>(x)];
      const int xr = x - (settings.min_disparity + best);
      if (xr < 0 || xr >= width || right_best[static_cast<size_t>(xr)] < 0) continue;
      if (std::abs(best - right_best[static_cast<size_t>(xr)]) > settings.lr_max_diff) out[x] = static_cast<int16_t>(invalid);
    }
  }
}

namespace {
// Adds a sums plane (u16, element x * D + (D - 1 - i) for disparity index i) to the volume.
void add_sums_plane(const PlaneView& sums, SgmVolume& sum) {
  const int count = sum.disparities;
  for (int y = 0; y < sum.height; ++y) {
    const uint16_t* row = plane_row<const uint16_t>(sums, y);
    for (int x = 0; x < sum.width; ++x) {
      for (int i = 0; i < count; ++i) sum.at(x, y, i) += row[static_cast<size_t>(x) * count + (count - 1 - i)];
    }
  }
}
}  // namespace

void sgm_reference_checkpoints(SgmPass pass, int word_bytes, const std::vector<PlaneView>& inputs,
                               const std::vector<PlaneView>& outputs, const SgmParams& params) {
  const int count = params.num_disparities;
  const SgmVolume cost = sgm_reference_costs(inputs[0], inputs[1], word_bytes, params.min_disparity, count);
  const bool backward = sgm_rows_bottom_up(pass);
  const int width = cost.width, height = cost.height;
  // Regions: the three paths from the previous row, kSgmForwardPaths / kSgmBackwardPaths 1..3.
  std::vector<SgmVolume> paths;
  for (int path = 1; path < 4; ++path) {
    paths.push_back(sgm_reference_path(cost, params.p1, params.p2, backward ? kSgmBackwardPaths[path] : kSgmForwardPaths[path]));
  }
  const bool narrow = sgm_checkpoint_value_bytes(params, word_bytes) == 1;
  for (int band = 0; band < sgm_band_count(height); ++band) {
    uint8_t* out = plane_row<uint8_t>(outputs[0], band);
    const int y0 = band * kSgmBandRows;
    const int y1 = std::min(y0 + kSgmBandRows, height);
    const bool first_band = backward ? y1 == height : band == 0;
    const int previous_y = backward ? y1 : y0 - 1;  // the row the pass leaves before entering the band
    for (int region = 0; region < 3; ++region) {
      for (int position = 0; position < width; ++position) {
        const int x = backward ? width - 1 - position : position;
        for (int lane = 0; lane < count; ++lane) {
          const int32_t value = first_band ? 0 : paths[static_cast<size_t>(region)].at(x, previous_y, count - 1 - lane);
          const size_t index = (static_cast<size_t>(region) * width + position) * count + lane;
          if (narrow) {
            if (value > 255) throw std::logic_error("sgm_reference_checkpoints: a path cost above the u8 bound");
            out[index] = static_cast<uint8_t>(value);
          } else {
            const uint16_t wide = static_cast<uint16_t>(value);
            std::memcpy(out + 2 * index, &wide, 2);
          }
        }
      }
    }
  }
}

void sgm_reference_8path(int word_bytes, const PlaneView& left, const PlaneView& right, const PlaneView& output,
                         const SgmParams& params) {
  const SgmVolume cost = sgm_reference_costs(left, right, word_bytes, params.min_disparity, params.num_disparities);
  SgmVolume sum{cost.width, cost.height, cost.disparities, std::vector<int32_t>(cost.values.size(), 0)};
  for (int path = 0; path < 4; ++path) {
    sgm_reference_add_path(cost, params.p1, params.p2, kSgmForwardPaths[path], sum);
    sgm_reference_add_path(cost, params.p1, params.p2, kSgmBackwardPaths[path], sum);
  }
  sgm_reference_select(sum, params, output);
}

void sgm_reference(SgmPass pass, int word_bytes, const std::vector<PlaneView>& inputs,
                   const std::vector<PlaneView>& outputs, const SgmParams& params) {
  const int count = params.num_disparities;
  if (sgm_writes_checkpoints(pass)) {
    sgm_reference_checkpoints(pass, word_bytes, inputs, outputs, params);
    return;
  }
  if (pass == SgmPass::select) {  // inputs: the forward and the backward sums, W*D x H each
    SgmVolume sum{inputs[0].width / count, inputs[0].height, count,
                  std::vector<int32_t>(static_cast<size_t>(inputs[0].width) * inputs[0].height, 0)};
    add_sums_plane(inputs[0], sum);
    add_sums_plane(inputs[1], sum);
    sgm_reference_select(sum, params, outputs[0]);
    return;
  }
  const SgmVolume cost = sgm_reference_costs(inputs[0], inputs[1], word_bytes, params.min_disparity, params.num_disparities);
  SgmVolume sum{cost.width, cost.height, count, std::vector<int32_t>(cost.values.size(), 0)};
  if (pass == SgmPass::backward) add_sums_plane(inputs[2], sum);
  // kSgmForwardPaths order: along the row, top-left, top, top-right (the kernels' regions order).
  const bool runs[4] = {sgm_runs_row_path(pass), sgm_runs_down_diagonal(pass), sgm_runs_straight(pass), sgm_runs_up_diagonal(pass)};
  for (int path = 0; path < 4; ++path) {
    if (!runs[path]) continue;
    sgm_reference_add_path(cost, params.p1, params.p2,
                           sgm_rows_bottom_up(pass) ? kSgmBackwardPaths[path] : kSgmForwardPaths[path], sum);
  }
  if (sgm_selects(pass)) {
    sgm_reference_select(sum, params, outputs[0]);
    return;
  }
  for (int y = 0; y < cost.height; ++y) {
    uint16_t* out = plane_row<uint16_t>(outputs[0], y);
    for (int x = 0; x < cost.width; ++x) {
      for (int i = 0; i < count; ++i) out[static_cast<size_t>(x) * count + (count - 1 - i)] = static_cast<uint16_t>(sum.at(x, y, i));
    }
  }
}

namespace {

std::string shape_text(const PlaneShape& shape) { return std::to_string(shape.width) + "x" + std::to_string(shape.height); }

// The checkpoint passes' output: one row of 3 W D values (u8 or u16, as bytes) per band.
PlaneShape sgm_checkpoints_shape(const PlaneShape& image, const SgmParams& params, int word_bytes) {
  return PlaneShape{static_cast<int>(sgm_checkpoint_row_bytes(image.width, params.num_disparities,
                                                              sgm_checkpoint_value_bytes(params, word_bytes))),
                    sgm_band_count(image.height)};
}

PreparedKernel sgm_prepare(SgmPass pass, int word_bytes, const nlohmann::json& json, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(json, {"min_disparity", "num_disparities", "p1", "p2", "uniqueness_percent", "subpixel", "lr_max_diff"});
  auto params = std::make_shared<SgmParams>();
  params->min_disparity = param_int(json, "min_disparity", 0, -2047, 2046);
  params->num_disparities =
      param_int(json, "num_disparities", 64, 1, std::min(kSgmMaxDisparities, 2047 - params->min_disparity));
  params->p1 = param_int(json, "p1", 5, 0, kSgmMaxPenalty);
  params->p2 = param_int(json, "p2", std::max(45, params->p1), params->p1, kSgmMaxPenalty);
  params->uniqueness_percent = param_int(json, "uniqueness_percent", 0, 0, kSgmMaxUniquenessPercent);
  params->subpixel = param_int(json, "subpixel", 1, 0, 1);
  params->lr_max_diff = param_int(json, "lr_max_diff", -1, -1, 2047);
  if (!sgm_selects(pass) &&
      (json.contains("uniqueness_percent") || json.contains("subpixel") || json.contains("lr_max_diff"))) {
    throw KernelError(std::string("a pass that writes path ") + (sgm_writes_checkpoints(pass) ? "checkpoints" : "sums") +
                      " selects no disparity: parameters uniqueness_percent, subpixel and lr_max_diff belong to the "
                      "selecting kernel");
  }
  if (pass == SgmPass::select) {  // the two sums planes, W*D x H each, W = their width / D
    const PlaneShape first = input_shapes.at(0);
    if (first.width % params->num_disparities != 0) {
      throw KernelError("port 'first_sums': expected a width that is a multiple of num_disparities " +
                        std::to_string(params->num_disparities) + ", got " + std::to_string(first.width));
    }
    if (!(input_shapes.at(1) == first)) {
      throw KernelError("port 'second_sums': expected the first sums' size " + shape_text(first) + ", got " +
                        shape_text(input_shapes[1]));
    }
    return PreparedKernel{params, {{first.width / params->num_disparities, first.height}}, {}, {}};
  }
  const PlaneShape left = input_shapes.at(0);
  if (!(input_shapes.at(1) == left)) {
    throw KernelError("port 'right': expected the left view's size " + shape_text(left) + ", got " + shape_text(input_shapes[1]));
  }
  if (sgm_writes_checkpoints(pass)) {
    return PreparedKernel{params, {sgm_checkpoints_shape(left, *params, word_bytes)}, {}, {}};
  }
  const PlaneShape sums{left.width * params->num_disparities, left.height};
  if (pass == SgmPass::backward && !(input_shapes.at(2) == sums)) {
    throw KernelError("port 'forward': expected the forward sums of " + shape_text(left) + " x " +
                      std::to_string(params->num_disparities) + " disparities, " + shape_text(sums) + ", got " +
                      shape_text(input_shapes[2]));
  }
  PreparedKernel prepared{params, {sgm_writes_sums(pass) ? sums : left}, {}, {}};
  if (!sgm_writes_sums(pass)) {
    prepared.input_halos = {Halo{}, Halo{sgm_left_halo(*params), sgm_right_halo(*params), 0, 0}};
    if (pass == SgmPass::backward) prepared.input_halos.push_back(Halo{});
  }
  return prepared;
}

}  // namespace

KernelDescriptor sgm_descriptor(SgmPass pass, int word_bytes, const char* name, TileFunction counting) {
  KernelDescriptor descriptor;
  descriptor.name = name;
  const BufferFormat census{word_bytes == 4 ? ElementType::census32 : ElementType::census64, 0};
  const std::string census_name = word_bytes == 4 ? "census32" : "census64";
  const PortAccess census_access = sgm_stages_right_row(pass) ? PortAccess::whole : PortAccess::window;
  if (pass == SgmPass::select) {
    descriptor.ports = {{"first_sums", PortDirection::input, {ElementType::u16, 0}, PortAccess::whole},
                        {"second_sums", PortDirection::input, {ElementType::u16, 0}, PortAccess::whole}};
  } else {
    descriptor.ports = {{"left", PortDirection::input, census, census_access},
                        {"right", PortDirection::input, census, census_access}};
  }
  switch (pass) {
    case SgmPass::single:
      descriptor.summary = "semi-global matching, 4 paths in one row-streaming pass, on " + census_name +
                           " Hamming costs: s16 Q4 disparity with uniqueness, sub-pixel and LR check";
      break;
    case SgmPass::forward:
      descriptor.summary = "8-path SGM, forward pass (left, top-left, top, top-right) on " + census_name +
                           " Hamming costs: per-pixel path sums, u16 W*D per row";
      break;
    case SgmPass::backward:
      descriptor.summary = "8-path SGM, backward pass (right, bottom-right, bottom, bottom-left, rows bottom up) on " +
                           census_name + " costs plus the forward sums: s16 Q4 disparity";
      descriptor.ports.push_back({"forward", PortDirection::input, {ElementType::u16, 0}, PortAccess::whole});
      descriptor.rows_bottom_up = true;
      break;
    case SgmPass::backward_sums:
      descriptor.summary = "8-path SGM, backward paths (right, bottom-right, bottom, bottom-left, rows bottom up) on " +
                           census_name + " Hamming costs: their per-pixel sums, u16 W*D per row (runs beside the forward pass)";
      descriptor.rows_bottom_up = true;
      break;
    case SgmPass::row_pair_sums:
      descriptor.summary = "4-path SGM, two of the paths (along the row, top-left) on " + census_name +
                           " Hamming costs: their per-pixel sums, u16 W*D per row (runs beside the column pair)";
      break;
    case SgmPass::column_pair_sums:
      descriptor.summary = "4-path SGM, the other two paths (top, top-right) on " + census_name +
                           " Hamming costs: their per-pixel sums, u16 W*D per row (runs beside the row pair)";
      break;
    case SgmPass::select:
      descriptor.summary = "SGM selection from two path-sums planes (8-path forward + backward, or the two 4-path pairs): "
                           "winner takes all with uniqueness, sub-pixel and LR check, s16 Q4 (no row state: row bands "
                           "run in parallel)";
      descriptor.full_width_tiles = true;
      break;
    case SgmPass::forward_checkpoints:
      descriptor.summary = "8-path SGM by bands: the forward paths from the previous row (top-left, top, top-right) on " +
                           census_name + " Hamming costs: their state at the top of each band of " +
                           std::to_string(kSgmBandRows) + " rows (one row of 3 W D per band, u8 or u16 values as bytes)";
      break;
    case SgmPass::backward_checkpoints:
      descriptor.summary = "8-path SGM by bands: the backward paths from the next row (bottom-right, bottom, bottom-left; "
                           "rows bottom up) on " + census_name + " Hamming costs: their state below each band of " +
                           std::to_string(kSgmBandRows) + " rows (one row of 3 W D per band, u8 or u16 values as bytes)";
      descriptor.rows_bottom_up = true;
      break;
    case SgmPass::forward_band:
    case SgmPass::backward_band:
      throw std::logic_error("sgm_descriptor: the band passes run inside sgm_8path_bands, they are no kernel of their own");
  }
  if (sgm_writes_checkpoints(pass)) {
    descriptor.ports.push_back({"checkpoints", PortDirection::output, {ElementType::u8, 0}, PortAccess::window});
  } else if (sgm_writes_sums(pass)) {
    descriptor.ports.push_back({"sums", PortDirection::output, {ElementType::u16, 0}, PortAccess::window});
  } else {
    descriptor.ports.push_back({"disparity", PortDirection::output, {ElementType::s16, 4}, PortAccess::window});
  }
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.prepare = [pass, word_bytes](const nlohmann::json& json, const std::vector<PlaneShape>& shapes) {
    return sgm_prepare(pass, word_bytes, json, shapes);
  };
  // The forward pass's output is W*D wide: the image width is that over D.
  auto image_width = [pass, word_bytes](int output_width, const SgmParams& params) {
    if (sgm_writes_checkpoints(pass)) {
      return output_width / (3 * params.num_disparities * sgm_checkpoint_value_bytes(params, word_bytes));
    }
    return sgm_writes_sums(pass) ? output_width / params.num_disparities : output_width;
  };
  if (sgm_runs_paths(pass)) {
    descriptor.state_bytes = [image_width, pass](int width, int, const void* params_pointer) {
      const auto& params = *static_cast<const SgmParams*>(params_pointer);
      return sgm_state_bytes(image_width(width, params), params.num_disparities, sgm_state_regions(pass));
    };
  }
  descriptor.scratch_bytes = [pass, word_bytes, image_width](int tile_width, int, const void* params_pointer) {
    const auto& params = *static_cast<const SgmParams*>(params_pointer);
    return sgm_scratch_layout(image_width(tile_width, params), params, pass, word_bytes).total;
  };
  // Whole inputs (the forward pass's census rows, the backward pass's forward sums): the tile's rows;
  // the checkpoint passes' output rows are bands, so their census rows are the bands' rows.
  descriptor.source_rect = [pass](int, const PixelRect& tile, const PlaneShape& shape, const void*) {
    if (sgm_writes_checkpoints(pass)) {
      return PixelRect{0, std::min(tile.y0 * kSgmBandRows, shape.height), shape.width,
                       std::min(tile.y1 * kSgmBandRows, shape.height)};
    }
    return PixelRect{0, tile.y0, shape.width, tile.y1};
  };
  descriptor.counting = counting;
  descriptor.reference = [pass, word_bytes](const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                            const void* params, BorderMode, uint32_t) {
    sgm_reference(pass, word_bytes, inputs, outputs, *static_cast<const SgmParams*>(params));
  };
  return descriptor;
}

KernelDescriptor sgm_bands_descriptor(int word_bytes, const char* name, TileFunction counting) {
  KernelDescriptor descriptor;
  descriptor.name = name;
  const BufferFormat census{word_bytes == 4 ? ElementType::census32 : ElementType::census64, 0};
  const std::string census_name = word_bytes == 4 ? "census32" : "census64";
  descriptor.summary = "8-path SGM by bands of " + std::to_string(kSgmBandRows) + " rows on " + census_name +
                       " Hamming costs, from the two passes' checkpoints: per band the forward sums, then the backward "
                       "paths with winner takes all, uniqueness, sub-pixel and LR check, s16 Q4 (no W x H x D volume; "
                       "bands run in parallel)";
  descriptor.ports = {{"left", PortDirection::input, census, PortAccess::whole},
                      {"right", PortDirection::input, census, PortAccess::whole},
                      {"forward_checkpoints", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"backward_checkpoints", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"disparity", PortDirection::output, {ElementType::s16, 4}, PortAccess::window}};
  descriptor.border_modes = {BorderMode::replicate};
  descriptor.full_width_tiles = true;
  descriptor.block_height = kSgmBandRows;  // a tile is whole bands
  descriptor.prepare = [word_bytes](const nlohmann::json& json, const std::vector<PlaneShape>& shapes) {
    PreparedKernel prepared = sgm_prepare(SgmPass::single, word_bytes, json, {shapes.at(0), shapes.at(1)});
    const auto& params = *static_cast<const SgmParams*>(prepared.params.get());
    const PlaneShape expected = sgm_checkpoints_shape(shapes[0], params, word_bytes);
    const char* names[2] = {"forward_checkpoints", "backward_checkpoints"};
    for (int i = 0; i < 2; ++i) {
      if (!(shapes.at(2 + i) == expected)) {
        throw KernelError(std::string("port '") + names[i] + "': expected the checkpoints of " + shape_text(shapes[0]) + " x " +
                          std::to_string(params.num_disparities) + " disparities, " + shape_text(expected) + ", got " +
                          shape_text(shapes[2 + i]));
      }
    }
    prepared.input_halos.clear();  // every input is whole
    return prepared;
  };
  descriptor.scratch_bytes = [word_bytes](int tile_width, int, const void* params_pointer) {
    return sgm_bands_scratch_layout(tile_width, *static_cast<const SgmParams*>(params_pointer), word_bytes).total;
  };
  // Census: the tile's rows; checkpoints: the rows of the tile's bands.
  descriptor.source_rect = [](int input, const PixelRect& tile, const PlaneShape& shape, const void*) {
    if (input < 2) return PixelRect{0, tile.y0, shape.width, tile.y1};
    return PixelRect{0, tile.y0 / kSgmBandRows, shape.width,
                     std::min(shape.height, (tile.y1 + kSgmBandRows - 1) / kSgmBandRows)};
  };
  descriptor.counting = counting;
  descriptor.reference = [word_bytes](const std::vector<PlaneView>& inputs, const std::vector<PlaneView>& outputs,
                                      const void* params, BorderMode, uint32_t) {
    sgm_reference_8path(word_bytes, inputs[0], inputs[1], outputs[0], *static_cast<const SgmParams*>(params));
  };
  return descriptor;
}

}  // namespace lpstereo::kernels
