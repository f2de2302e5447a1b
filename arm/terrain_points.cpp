#include "arm/terrain_points.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "arm/localization/ransac_sampling.h"
#include "kernels/disparity_to_points.h"
#include "kernels/kernel.h"

namespace lpstereo::arm {

GroundMountEstimate estimate_ground_mount(const CameraPoints& points, const GroundMountSettings& settings) {
  GroundMountEstimate estimate;
  const int width = points.z_mm.width(), height = points.z_mm.height();
  // Candidates: the lower image half (the ground in front of a forward-looking camera), a regular
  // stride so that at most max_candidates are considered.
  const int64_t area = static_cast<int64_t>(width) * (height - height / 2);
  const int stride = std::max<int>(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(area) / settings.max_candidates))));
  std::vector<Eigen::Vector3d> candidates;
  for (int v = height / 2; v < height; v += stride) {
    for (int u = 0; u < width; u += stride) {
      const int32_t z_mm = points.z_mm.at<int32_t>(u, v);
      if (z_mm == kernels::kNoPointMm) continue;
      const Eigen::Vector3d p(points.x_mm.at<int32_t>(u, v) / 1000.0, points.y_mm.at<int32_t>(u, v) / 1000.0, z_mm / 1000.0);
      if (p.z() >= settings.min_depth_m && p.z() <= settings.max_depth_m) candidates.push_back(p);
    }
  }
  estimate.candidates = static_cast<int>(candidates.size());
  if (estimate.candidates < std::max(3, settings.min_inliers)) {
    estimate.reason = "camera mount: " + std::to_string(estimate.candidates) + " points in the lower image half between " +
                      std::to_string(settings.min_depth_m) + " and " + std::to_string(settings.max_depth_m) +
                      " m, expected at least " + std::to_string(settings.min_inliers);
    return estimate;
  }
  // A plane is plausible ground when its upward normal is within max_tilt of the camera's -y and the
  // camera is min..max height above it.
  auto plausible = [&](const Eigen::Vector3d& normal, double camera_height_m) {
    return -normal.y() >= std::cos(settings.max_tilt_rad) && camera_height_m >= settings.min_height_m &&
           camera_height_m <= settings.max_height_m;
  };
  auto count_inliers = [&](const Eigen::Vector3d& normal, double offset) {
    int count = 0;
    for (const Eigen::Vector3d& p : candidates) count += std::abs(normal.dot(p) + offset) <= settings.inlier_distance_m;
    return count;
  };
  uint32_t state = 12345u;
  auto next_index = [&]() {
    state = state * 1664525u + 1013904223u;  // Numerical Recipes' LCG: deterministic draws
    return static_cast<size_t>((state >> 8) % candidates.size());
  };
  int best_inliers = 0;
  Eigen::Vector3d best_normal = Eigen::Vector3d::Zero();
  double best_offset = 0;
  for (int iteration = 0; iteration < settings.iterations; ++iteration) {
    const Eigen::Vector3d& a = candidates[next_index()];
    const Eigen::Vector3d& b = candidates[next_index()];
    const Eigen::Vector3d& c = candidates[next_index()];
    Eigen::Vector3d normal = (b - a).cross(c - a);
    if (normal.norm() < 1e-9) continue;
    normal.normalize();
    if (normal.y() > 0) normal = -normal;  // upward: towards the camera's -y
    const double offset = -normal.dot(a);  // n . p + offset = 0; offset = camera height
    if (!plausible(normal, offset)) continue;
    const int inliers = count_inliers(normal, offset);
    if (inliers > best_inliers) {
      best_inliers = inliers;
      best_normal = normal;
      best_offset = offset;
    }
  }
  if (best_inliers == 0) {
    estimate.reason = "camera mount: no plausible ground plane (normal within " + std::to_string(settings.max_tilt_rad) +
                      " rad of vertical, camera " + std::to_string(settings.min_height_m) + " .. " +
                      std::to_string(settings.max_height_m) + " m above it) among the lower image half's points";
    return estimate;
  }
  // Least squares on the inliers: centroid and the smallest principal axis.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> inliers;
  for (const Eigen::Vector3d& p : candidates) {
    if (std::abs(best_normal.dot(p) + best_offset) <= settings.inlier_distance_m) inliers.push_back(p);
  }
  for (const Eigen::Vector3d& p : inliers) centroid += p;
  centroid /= static_cast<double>(inliers.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : inliers) scatter += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  Eigen::Vector3d normal = solver.eigenvectors().col(0).normalized();
  if (normal.y() > 0) normal = -normal;
  const double offset = -normal.dot(centroid);
  estimate.inliers = static_cast<int>(inliers.size());
  if (!plausible(normal, offset) || estimate.inliers < settings.min_inliers ||
      estimate.inliers < settings.min_inlier_share * estimate.candidates) {
    estimate.reason = "camera mount: the best ground plane has " + std::to_string(estimate.inliers) + " of " +
                      std::to_string(estimate.candidates) + " points (expected at least " +
                      std::to_string(std::max<int>(settings.min_inliers, static_cast<int>(settings.min_inlier_share * estimate.candidates))) +
                      ") or an implausible camera height " + std::to_string(offset) + " m";
    return estimate;
  }
  estimate.found = true;
  estimate.camera_height_m = offset;
  estimate.mount.pitch_rad = std::asin(std::clamp(-normal.z(), -1.0, 1.0));
  estimate.mount.roll_rad = std::atan2(-normal.x(), -normal.y());
  estimate.mount.yaw_rad = 0;
  estimate.mount.position_m = Eigen::Vector3d(0, 0, offset);
  return estimate;
}

nlohmann::json binning_params(const CameraToVehicle& to_vehicle, const terrain::TerrainGridSpec& grid) {
  std::vector<int> rotation_q14;
  for (int k = 0; k < 3; ++k) {
    for (int l = 0; l < 3; ++l) rotation_q14.push_back(static_cast<int>(std::lround(16384.0 * to_vehicle.rotation()(k, l))));
  }
  std::vector<int> translation_mm;
  for (int k = 0; k < 3; ++k) translation_mm.push_back(static_cast<int>(std::lround(1000.0 * to_vehicle.translation_m()(k))));
  auto mm = [](double metres) { return static_cast<int>(std::lround(1000.0 * metres)); };
  return {{"rotation_q14", rotation_q14},
          {"translation_mm", translation_mm},
          {"forward_min_mm", mm(grid.forward_min_m)},
          {"forward_max_mm", mm(grid.forward_max_m)},
          {"lateral_min_mm", mm(grid.lateral_min_m)},
          {"lateral_max_mm", mm(grid.lateral_max_m)},
          {"cell_mm", mm(grid.cell_m)}};
}

BinnedPoints bin_points(const CameraPoints& points, const CameraToVehicle& to_vehicle, const terrain::TerrainGridSpec& grid,
                        KernelBackend backend) {
  const KernelDescriptor* kernel = KernelRegistry::instance().find("point_cell_binning");
  if (kernel == nullptr) throw std::logic_error("kernel 'point_cell_binning' is not linked into this program");
  const PlaneShape shape{points.z_mm.width(), points.z_mm.height()};
  const PreparedKernel prepared = kernel->prepare(binning_params(to_vehicle, grid), {shape, shape, shape});
  const BufferFormat millimetres{ElementType::s32, 0};
  BinnedPoints binned{Plane(shape.width, shape.height, millimetres), Plane(shape.width, shape.height, millimetres)};
  VectorNodeBinding binding{kernel, prepared.params.get(), BorderMode::replicate, 0,
                            {points.x_mm.view(), points.y_mm.view(), points.z_mm.view()},
                            {binned.cell.view(), binned.height_mm.view()}};
  run_vector_node(binding, 256, 32, backend, simd::active_isa());
  return binned;
}

void accumulate_binned(const BinnedPoints& binned, const terrain::TerrainGridSpec& grid, terrain::HeightGridAccumulator& accumulator,
                       const std::vector<uint8_t>* over_occluder) {
  const int lateral_cells = grid.lateral_cells(), width = binned.cell.width();
  if (over_occluder != nullptr && over_occluder->size() != static_cast<size_t>(width) * binned.cell.height()) {
    throw std::invalid_argument("over_occluder: expected " + std::to_string(static_cast<size_t>(width) * binned.cell.height()) +
                                " flags (one per binned pixel), got " + std::to_string(over_occluder->size()));
  }
  for (int v = 0; v < binned.cell.height(); ++v) {
    const int32_t* cells = binned.cell.row<const int32_t>(v);
    const int32_t* heights = binned.height_mm.row<const int32_t>(v);
    const uint8_t* flags = over_occluder == nullptr ? nullptr : over_occluder->data() + static_cast<size_t>(v) * width;
    for (int u = 0; u < width; ++u) {
      if (cells[u] >= 0) {
        accumulator.add_to_cell(cells[u] / lateral_cells, cells[u] % lateral_cells, heights[u] / 1000.0, flags != nullptr && flags[u] != 0);
      }
    }
  }
}

void OccluderTest::validate() const {
  if (rows_below_px < 1 || rows_below_px > 64) {
    throw std::invalid_argument("rows_below_px: expected in [1, 64], got " + std::to_string(rows_below_px));
  }
  if (!(jump_px > 0) || !std::isfinite(jump_px)) {
    throw std::invalid_argument("jump_px: expected a finite value > 0, got " + localization::format_number(jump_px));
  }
}

std::vector<uint8_t> pixels_over_occluder(const Plane& disparity_q4, int16_t invalid_q4, const OccluderTest& test) {
  test.validate();
  if (disparity_q4.format().type != ElementType::s16) throw std::invalid_argument("disparity_q4: expected an s16 plane");
  const int width = disparity_q4.width(), height = disparity_q4.height(), reach = test.rows_below_px;
  const int jump_q4 = static_cast<int>(std::ceil(16 * test.jump_px));
  std::vector<uint8_t> flags(static_cast<size_t>(width) * height, 0);
  // Per column: the nearest valid pixel below the current row (row -1: none yet), and the tops of
  // nearer surfaces met going up, a queue of at most reach + 1 (one per row) in the order found
  // (lowest first, so the oldest expire first).
  const size_t capacity = static_cast<size_t>(reach) + 1;
  std::vector<int> below_row(static_cast<size_t>(width), -1), below_q4(static_cast<size_t>(width), 0);
  std::vector<int> top_row(static_cast<size_t>(width) * capacity), top_q4(top_row.size());
  std::vector<int> first_top(static_cast<size_t>(width), 0), top_count(static_cast<size_t>(width), 0);
  for (int v = height - 1; v >= 0; --v) {
    const int16_t* row = disparity_q4.row<const int16_t>(v);
    uint8_t* flag_row = flags.data() + static_cast<size_t>(v) * width;
    for (int u = 0; u < width; ++u) {
      const int d = row[u];
      if (d <= invalid_q4) continue;
      int* rows = top_row.data() + static_cast<size_t>(u) * capacity;
      int* tops_q4 = top_q4.data() + static_cast<size_t>(u) * capacity;
      int& first = first_top[static_cast<size_t>(u)];
      int& count = top_count[static_cast<size_t>(u)];
      // Tops more than reach rows below are out of reach from here on.
      while (count > 0 && rows[first] - v > reach) first = (first + 1) % static_cast<int>(capacity), --count;
      // The valid pixel below, if it is more than the jump nearer than this one, is a nearer surface's
      // top (the queue then holds tops of distinct rows within reach: at most reach of them).
      if (below_row[u] >= 0 && below_row[u] - v <= reach && below_q4[u] - d > jump_q4) {
        const int slot = (first + count) % static_cast<int>(capacity);
        rows[slot] = below_row[u], tops_q4[slot] = below_q4[u];
        ++count;
      }
      for (int k = 0; k < count; ++k) {
        if (tops_q4[(first + k) % static_cast<int>(capacity)] - d > jump_q4) {
          flag_row[u] = 1;
          break;
        }
      }
      below_row[u] = v;
      below_q4[u] = d;
    }
  }
  return flags;
}

void FarSideTest::validate() const {
  if (rows_above_px < 0 || rows_above_px > 64) {
    throw std::invalid_argument("rows_above_px: expected in [0, 64], got " + std::to_string(rows_above_px));
  }
  if (columns_beside_px < 0 || columns_beside_px > 64) {
    throw std::invalid_argument("columns_beside_px: expected in [0, 64], got " + std::to_string(columns_beside_px));
  }
  if (!(jump_px > 0) || !std::isfinite(jump_px)) {
    throw std::invalid_argument("jump_px: expected a finite value > 0, got " + localization::format_number(jump_px));
  }
}

std::vector<uint8_t> pixels_on_far_side(const Plane& disparity_q4, int16_t invalid_q4, const FarSideTest& test, int first_row,
                                           int end_row) {
  test.validate();
  if (disparity_q4.format().type != ElementType::s16) throw std::invalid_argument("disparity_q4: expected an s16 plane");
  const int width = disparity_q4.width(), height = disparity_q4.height();
  if (end_row < 0) end_row = height;
  if (first_row < 0 || first_row > end_row || end_row > height) {
    throw std::invalid_argument("rows: expected 0 <= first_row <= end_row <= " + std::to_string(height) + ", got " +
                                std::to_string(first_row) + " and " + std::to_string(end_row));
  }
  const int jump_q4 = static_cast<int>(std::ceil(16 * test.jump_px));
  std::vector<uint8_t> flags(static_cast<size_t>(width) * static_cast<size_t>(end_row - first_row), 0);
  if (!test.enabled()) return flags;
  // An invalid pixel (<= invalid_q4, below every valid value) never raises the maximum.
  std::vector<int16_t> neighbour_maximum(static_cast<size_t>(width));
  for (int v = first_row; v < end_row; ++v) {
    std::fill(neighbour_maximum.begin(), neighbour_maximum.end(), invalid_q4);
    for (int k = std::max(0, v - test.rows_above_px); k < v; ++k) {
      const int16_t* above = disparity_q4.row<const int16_t>(k);
      for (int u = 0; u < width; ++u) neighbour_maximum[static_cast<size_t>(u)] = std::max(neighbour_maximum[static_cast<size_t>(u)], above[u]);
    }
    const int16_t* row = disparity_q4.row<const int16_t>(v);
    uint8_t* flag_row = flags.data() + static_cast<size_t>(v - first_row) * width;
    // The row itself, shifted (the shift 0 cannot flag: no pixel lies a jump above itself).
    for (int shift = -test.columns_beside_px; shift <= test.columns_beside_px; ++shift) {
      for (int u = std::max(0, -shift); u < std::min(width, width - shift); ++u) {
        neighbour_maximum[static_cast<size_t>(u)] = std::max(neighbour_maximum[static_cast<size_t>(u)], row[u + shift]);
      }
    }
    for (int u = 0; u < width; ++u) {
      flag_row[u] = static_cast<uint8_t>(row[u] > invalid_q4 && neighbour_maximum[static_cast<size_t>(u)] - row[u] > jump_q4);
    }
  }
  return flags;
}

std::string ground_extent_problem(const terrain::HeightGrid& grid, int min_rows, int min_columns) {
  // A row (column) counts when it holds at least 1 % of the points: a few mismatched pixels of a
  // wall, scattered into other rows, must not make up an extent.
  const int64_t total = grid.point_count.cast<int64_t>().sum();
  const int64_t least = std::max<int64_t>(1, total / 100);
  int rows = 0, columns = 0;
  for (int i = 0; i < grid.point_count.rows(); ++i) rows += grid.point_count.row(i).cast<int64_t>().sum() >= least;
  for (int j = 0; j < grid.point_count.cols(); ++j) columns += grid.point_count.col(j).cast<int64_t>().sum() >= least;
  if (rows >= min_rows && columns >= min_columns) return {};
  return "no ground extent: " + std::to_string(rows) + " forward row(s) and " + std::to_string(columns) +
         " lateral column(s) of cells hold at least 1 % of the " + std::to_string(total) + " points each, expected at least " +
         std::to_string(min_rows) + " and " + std::to_string(min_columns) + " (a wall filling the view, or points on one line)";
}

int64_t invalidate_near_side_of_discontinuities(Plane& disparity_q4, int16_t invalid_q4, int radius_px, double jump_px) {
  if (radius_px < 1) throw std::invalid_argument("radius_px: expected >= 1, got " + std::to_string(radius_px));
  if (!(jump_px > 0)) throw std::invalid_argument("jump_px: expected > 0, got " + std::to_string(jump_px));
  if (disparity_q4.format().type != ElementType::s16) throw std::invalid_argument("disparity_q4: expected an s16 plane");
  const int width = disparity_q4.width(), height = disparity_q4.height();
  const int jump_q4 = static_cast<int>(std::ceil(16 * jump_px));
  // Valid pixels only: invalid is invalid_q4 and below (DESIGN.md §4: (min_disparity - 1) * 16).
  const auto valid = [invalid_q4](int16_t d) { return d > invalid_q4; };
  // The minimum valid disparity of each pixel's window, separably: rows first, then columns.
  constexpr int kNoValue = INT32_MAX;
  std::vector<int> row_minimum(static_cast<size_t>(width) * height, kNoValue), window_minimum(row_minimum.size(), kNoValue);
  for (int v = 0; v < height; ++v) {
    const int16_t* row = disparity_q4.row<int16_t>(v);
    for (int u = 0; u < width; ++u) {
      int lowest = kNoValue;
      for (int k = std::max(0, u - radius_px); k <= std::min(width - 1, u + radius_px); ++k) {
        if (valid(row[k])) lowest = std::min<int>(lowest, row[k]);
      }
      row_minimum[static_cast<size_t>(v) * width + u] = lowest;
    }
  }
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      int lowest = kNoValue;
      for (int k = std::max(0, v - radius_px); k <= std::min(height - 1, v + radius_px); ++k) {
        lowest = std::min(lowest, row_minimum[static_cast<size_t>(k) * width + u]);
      }
      window_minimum[static_cast<size_t>(v) * width + u] = lowest;
    }
  }
  int64_t invalidated = 0;
  for (int v = 0; v < height; ++v) {
    int16_t* row = disparity_q4.row<int16_t>(v);
    for (int u = 0; u < width; ++u) {
      if (!valid(row[u]) || window_minimum[static_cast<size_t>(v) * width + u] == kNoValue) continue;
      if (row[u] - window_minimum[static_cast<size_t>(v) * width + u] > jump_q4) {
        row[u] = invalid_q4;
        ++invalidated;
      }
    }
  }
  return invalidated;
}

std::optional<double> surface_camera_y_m(const terrain::TerrainEstimate& terrain, const CameraToVehicle& to_vehicle, double x_c_m,
                                         double z_c_m, bool require_valid_cell) {
  if (!terrain.known) return std::nullopt;
  // r(y) = z_v(y) - S(x_v(y), y_v(y)); z_v is linear in y with slope (R C)(2, 1).
  const double dz_dy = to_vehicle.rotation()(2, 1);
  auto residual = [&](double y_c_m, Eigen::Vector3d* vehicle) {
    *vehicle = to_vehicle.apply(Eigen::Vector3d(x_c_m, y_c_m, z_c_m));
    return vehicle->z() - terrain.surface.height_m(vehicle->x(), vehicle->y());
  };
  if (std::abs(dz_dy) < 1e-6) return std::nullopt;  // the camera's y axis is horizontal: no vertical line
  // Start where the line meets the horizontal plane z_v = 0 through the vehicle origin.
  Eigen::Vector3d vehicle;
  double y = -(to_vehicle.apply(Eigen::Vector3d(x_c_m, 0.0, z_c_m)).z()) / dz_dy;
  double r = residual(y, &vehicle);
  double previous_y = y + 0.01, previous_r = residual(previous_y, &vehicle);
  for (int step = 0; step < 30 && std::isfinite(r); ++step) {
    if (std::abs(r) <= 1e-4) break;
    // Secant slope (dr/dy includes S's slope along the line), falling back to dz_dy.
    double slope = (r - previous_r) / (y - previous_y);
    if (!std::isfinite(slope) || std::abs(slope) < 0.1 * std::abs(dz_dy)) slope = dz_dy;
    previous_y = y;
    previous_r = r;
    y -= r / slope;
    r = residual(y, &vehicle);
  }
  if (!std::isfinite(r) || std::abs(r) > 1e-4) return std::nullopt;
  if (require_valid_cell) {
    int i = 0, j = 0;
    if (!terrain.grid.spec.cell_of(vehicle.x(), vehicle.y(), &i, &j)) return std::nullopt;
    if (terrain.grid.state(i, j) == terrain::kCellInvalid) return std::nullopt;
  }
  return y;
}

}  // namespace lpstereo::arm
