#include "arm/obstacles3d/obstacle_candidates.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "arm/fork_join.h"
#include "kernels/disparity_to_points.h"

namespace lpstereo::arm::obstacles3d {

namespace {

std::string size_text(const Plane& plane) { return std::to_string(plane.width()) + "x" + std::to_string(plane.height()); }

// CandidateParameters::ground_below_view_upper_bounds: marks the valid cells whose centre, on the
// vehicle frame's ground plane, projects below the bottom edge of the image's last row (or behind
// the camera); returns their count.
int mark_ground_below_view(terrain::HeightGrid& grid, const CameraToVehicle& to_vehicle, const TriangulationParameters& view,
                           int image_height) {
  const Eigen::Matrix3d camera_from_vehicle = to_vehicle.rotation().transpose();
  const double bottom_edge_px = image_height - 0.5;  // the last row's centre is image_height - 1
  int marked = 0;
  for (Eigen::Index i = 0; i < grid.height_m.rows(); ++i) {
    for (Eigen::Index j = 0; j < grid.height_m.cols(); ++j) {
      if (grid.state(i, j) == terrain::kCellInvalid) continue;
      const Eigen::Vector3d ground_vehicle_m(grid.spec.cell_centre_x_m(static_cast<int>(i)), grid.spec.cell_centre_y_m(static_cast<int>(j)), 0);
      const Eigen::Vector3d ground_camera_m = camera_from_vehicle * (ground_vehicle_m - to_vehicle.translation_m());
      const bool below_view = ground_camera_m.z() <= 0 || view.v0_px + view.focal_px * ground_camera_m.y() / ground_camera_m.z() > bottom_edge_px;
      if (!below_view) continue;
      if (grid.upper_bound.size() == 0) grid.upper_bound = Eigen::MatrixXi::Zero(grid.height_m.rows(), grid.height_m.cols());
      grid.upper_bound(i, j) = 1;
      ++marked;
    }
  }
  return marked;
}

}  // namespace

CandidateTest::CandidateTest(const terrain::BsplineSurface& surface, double obstacle_height_m)
    : surface_(surface), obstacle_height_m_(obstacle_height_m) {
  const int d0 = surface.degree_forward, d1 = surface.degree_lateral;
  const Eigen::Index spans0 = surface.control_z_m.rows() - d0, spans1 = surface.control_z_m.cols() - d1;
  if (spans0 <= 0 || spans1 <= 0) return;  // no surface: contains() is false everywhere
  span_minimum_m_.resize(spans0, spans1);
  for (Eigen::Index a = 0; a < spans0; ++a) {
    for (Eigen::Index b = 0; b < spans1; ++b) span_minimum_m_(a, b) = surface.control_z_m.block(a, b, d0 + 1, d1 + 1).minCoeff();
  }
}

CandidateTest::Class CandidateTest::classify(const Eigen::Vector3d& vehicle_m, double* height_above_m, bool* evaluated) const {
  constexpr double kRoundingMarginM = 1e-9;
  if (evaluated != nullptr) *evaluated = false;
  if (!vehicle_m.allFinite() || span_minimum_m_.size() == 0 || !surface_.contains(vehicle_m.x(), vehicle_m.y())) return Class::outside;
  const int span0 = terrain::knot_span(surface_.knots_forward_m, surface_.degree_forward, vehicle_m.x());
  const int span1 = terrain::knot_span(surface_.knots_lateral_m, surface_.degree_lateral, vehicle_m.y());
  if (vehicle_m.z() - obstacle_height_m_ < span_minimum_m_(span0 - surface_.degree_forward, span1 - surface_.degree_lateral) - kRoundingMarginM) {
    return Class::terrain;
  }
  if (evaluated != nullptr) *evaluated = true;
  const double above_m = vehicle_m.z() - surface_.height_m(vehicle_m.x(), vehicle_m.y());
  *height_above_m = above_m;
  return above_m > obstacle_height_m_ ? Class::candidate : Class::terrain;
}

CandidatePoints extract_obstacle_candidates(const Plane& disparity_q4, int16_t invalid_disparity_q4, const CameraPoints& camera,
                                            const TriangulationParameters& view, const Plane& grey, const ColourView& colour,
                                            const CameraToVehicle& to_vehicle, const CandidateParameters& parameters) {
  if (!(parameters.obstacle_height_m > 0 && parameters.obstacle_height_m < 10)) {
    throw std::invalid_argument("obstacle_height_m: expected a height in (0, 10) m, got " + std::to_string(parameters.obstacle_height_m));
  }
  for (const Plane* plane : {&camera.x_mm, &camera.y_mm, &camera.z_mm, &grey}) {
    if (plane->width() != disparity_q4.width() || plane->height() != disparity_q4.height()) {
      throw std::invalid_argument("obstacle candidates: expected every plane " + size_text(disparity_q4) + " like the disparity map, got " +
                                  size_text(*plane));
    }
  }
  if (!(view.focal_px > 0) || !std::isfinite(view.focal_px) || !std::isfinite(view.v0_px)) {
    throw std::invalid_argument("view.focal_px: expected a finite focal length > 0 px (and a finite v0_px), got " + std::to_string(view.focal_px) +
                                " (v0_px " + std::to_string(view.v0_px) + ")");
  }
  if (parameters.threads < 1 || parameters.threads > 16) {
    throw std::invalid_argument("threads: expected a count in [1, 16], got " + std::to_string(parameters.threads));
  }
  parameters.occluder.validate();
  parameters.far_side.validate();
  parameters.local_ground.validate();
  parameters.grid.validate();
  const int forward_cells = parameters.grid.forward_cells(), lateral_cells = parameters.grid.lateral_cells();
  CandidatePoints result;
  // The image split into contiguous bands of rows, one per thread: each band's points are built on
  // its own thread, then the points are classified in equal shares, one per thread; every sequential
  // step (the 2.5D grid's sums, the candidates' order) takes the points in row order, so the result
  // is the single-threaded one bit for bit whatever the scheduling.
  // alignas(64), as Share: each band's vectors grow from its own thread (fork_join.h).
  struct alignas(64) Band {
    // Per point, its pixel; the ObstaclePoint is built only for the candidates (make_point), a few
    // per cent of the points: the rest need only their vehicle coordinates and cell.
    std::vector<std::array<uint16_t, 2>> pixels;
    std::vector<Eigen::Vector3d> vehicle_points;
    std::vector<uint8_t> over_occluder;  // per point, with grid.occlusion_upper_bounds
    std::vector<uint8_t> far_side;  // per point, with the far-side test on
    // Per point, its 2.5D grid cell (TerrainGridSpec::cell_of, found here on the band's thread for
    // the grid's sums and the local ground); forward -1: outside the area.
    std::vector<std::array<int32_t, 2>> cells;
  };
  // One classification worker's share of the points: its candidates and its count outside the area.
  struct alignas(64) Share {  // counted per point from its own thread: a cache line of its own
    std::vector<ObstaclePoint> candidates;
    int64_t outside_area = 0;
    int64_t far_side = 0;
  };
  // A pixel that becomes a point (the build skips the others; the bands balance these).
  const auto has_disparity = [&](int16_t d_q4) { return d_q4 != invalid_disparity_q4 && d_q4 > 0; };
  const int band_count = std::max(1, std::min(parameters.threads, disparity_q4.height() / 16));
  std::vector<Band> bands(static_cast<size_t>(band_count));
  // The bands' row boundaries balance the valid disparities (the points to build), not the rows: a
  // road scene has its sky, with no disparity, in the top rows, and equal row bands left one thread
  // with almost every point (measured on the urban sequence: 300 against 144 000 points).
  std::vector<int> band_first_row = {0, disparity_q4.height()};
  if (band_count > 1) {
    std::vector<int64_t> valid_before_row(static_cast<size_t>(disparity_q4.height()) + 1, 0);
    for (int v = 0; v < disparity_q4.height(); ++v) {
      const int16_t* disparity_row = disparity_q4.row<const int16_t>(v);
      int64_t valid = 0;
      for (int u = 0; u < disparity_q4.width(); ++u) valid += has_disparity(disparity_row[u]) ? 1 : 0;
      valid_before_row[static_cast<size_t>(v) + 1] = valid_before_row[static_cast<size_t>(v)] + valid;
    }
    band_first_row = balanced_row_bands(valid_before_row, band_count);
  }
  const auto band_rows = [&](int band, int* first_row, int* end_row) {
    *first_row = band_first_row[static_cast<size_t>(band)];
    *end_row = band_first_row[static_cast<size_t>(band) + 1];
  };
  const auto run_bands = [&](const auto& work) { fork_join(band_count, work); };
  const bool occlusion = parameters.grid.occlusion_upper_bounds;
  const std::vector<uint8_t> over_occluder =
      occlusion ? pixels_over_occluder(disparity_q4, invalid_disparity_q4, parameters.occluder) : std::vector<uint8_t>{};
  // The pixels on the far side of an edge become ground samples only, never candidates (the header
  // says why); each band flags its own rows.
  const bool far_side_test = parameters.far_side.enabled();
  const int red_channel = colour.blue_first ? 2 : 0, blue_channel = colour.blue_first ? 0 : 2;
  // A camera point in metres from the triangulation's millimetres (x_mm != kNoPointMm).
  const auto camera_m_of = [](int32_t x_mm, int32_t y_mm, int32_t z_mm) {
    return Eigen::Vector3f(static_cast<float>(x_mm) * 1e-3f, static_cast<float>(y_mm) * 1e-3f, static_cast<float>(z_mm) * 1e-3f);
  };
  // The point of pixel (u, v), whose vehicle coordinates the band computed.
  const auto make_point = [&](const std::array<uint16_t, 2>& pixel, const Eigen::Vector3d& vehicle) {
    const int u = pixel[0], v = pixel[1];
    ObstaclePoint point;
    point.camera_m = camera_m_of(camera.x_mm.row<const int32_t>(v)[u], camera.y_mm.row<const int32_t>(v)[u],
                                 camera.z_mm.row<const int32_t>(v)[u]);
    point.vehicle_m = vehicle.cast<float>();
    point.disparity_px = static_cast<float>(disparity_q4.row<const int16_t>(v)[u]) / 16.0f;
    point.u_px = pixel[0];
    point.v_px = pixel[1];
    if (colour.pixels != nullptr) {
      const uint8_t* colour_pixel = colour.pixels + static_cast<size_t>(v) * colour.row_stride_bytes + 3 * static_cast<size_t>(u);
      point.rgb = {colour_pixel[red_channel], colour_pixel[1], colour_pixel[blue_channel]};
    } else {
      const uint8_t grey_value = grey.row<const uint8_t>(v)[u];
      point.rgb = {grey_value, grey_value, grey_value};
    }
    return point;
  };
  run_bands([&](int band) {
    Band& out = bands[static_cast<size_t>(band)];
    int first_row = 0, end_row = 0;
    band_rows(band, &first_row, &end_row);
    const size_t capacity = static_cast<size_t>(end_row - first_row) * static_cast<size_t>(disparity_q4.width());
    out.pixels.reserve(capacity);
    out.vehicle_points.reserve(capacity);
    out.cells.reserve(capacity);
    const std::vector<uint8_t> far_side_flags =
        far_side_test ? pixels_on_far_side(disparity_q4, invalid_disparity_q4, parameters.far_side, first_row, end_row) : std::vector<uint8_t>{};
    for (int v = first_row; v < end_row; ++v) {
      const int32_t* x_row = camera.x_mm.row<const int32_t>(v);
      const int32_t* y_row = camera.y_mm.row<const int32_t>(v);
      const int32_t* z_row = camera.z_mm.row<const int32_t>(v);
      const int16_t* disparity_row = disparity_q4.row<const int16_t>(v);
      for (int u = 0; u < disparity_q4.width(); ++u) {
        if (x_row[u] == kernels::kNoPointMm || !has_disparity(disparity_row[u])) continue;
        const Eigen::Vector3d vehicle = to_vehicle.apply(camera_m_of(x_row[u], y_row[u], z_row[u]).cast<double>());
        out.pixels.push_back({static_cast<uint16_t>(u), static_cast<uint16_t>(v)});
        out.vehicle_points.push_back(vehicle);
        std::array<int32_t, 2> cell = {-1, -1};
        if (!parameters.grid.cell_of(vehicle.x(), vehicle.y(), forward_cells, lateral_cells, &cell[0], &cell[1])) cell = {-1, -1};
        out.cells.push_back(cell);
        if (occlusion) out.over_occluder.push_back(over_occluder[static_cast<size_t>(v) * disparity_q4.width() + u]);
        if (far_side_test) out.far_side.push_back(far_side_flags[static_cast<size_t>(v - first_row) * disparity_q4.width() + u]);
      }
    }
  });
  for (const Band& band : bands) result.cloud_points += static_cast<int64_t>(band.pixels.size());
  if (result.cloud_points == 0) {
    result.note = "empty cloud (no valid disparity)";
    return result;
  }
  terrain::HeightGridAccumulator accumulator(parameters.grid);
  for (const Band& band : bands) {
    for (size_t k = 0; k < band.vehicle_points.size(); ++k) {
      // A cell of -1 is rejected as add_point would reject the point.
      accumulator.add_to_cell(band.cells[k][0], band.cells[k][1], band.vehicle_points[k].z(), occlusion && band.over_occluder[k] != 0);
    }
  }
  result.measured_grid = accumulator.finish();
  if (parameters.ground_below_view_upper_bounds) {
    result.below_view_cells = mark_ground_below_view(result.measured_grid, to_vehicle, view, disparity_q4.height());
  }
  result.terrain = terrain::fit_terrain(result.measured_grid, parameters.fit);
  if (!result.terrain.known) {
    result.note = "terrain unknown (" + result.terrain.reason + "): no obstacle candidates";
    result.outside_area = result.cloud_points;
    return result;
  }
  const CandidateTest test(result.terrain.surface, parameters.obstacle_height_m);
  // The classification splits the points, not the rows, into equal shares (worker w takes the
  // points [N w / T, N (w + 1) / T) of the bands' concatenation, in row order), and the shares'
  // candidates are joined in worker order: the candidates' order is the single-threaded one.
  std::vector<size_t> points_before_band(bands.size() + 1, 0);
  for (size_t b = 0; b < bands.size(); ++b) points_before_band[b + 1] = points_before_band[b] + bands[b].pixels.size();
  const size_t point_count = points_before_band.back();
  // Calls visit(band, i, k) for the points k in [N w / T, N (w + 1) / T) of the bands'
  // concatenation (i: the index in its band).
  const auto for_each_point_of_share = [&](int worker, const auto& visit) {
    const size_t first = point_count * static_cast<size_t>(worker) / static_cast<size_t>(band_count);
    const size_t end = point_count * static_cast<size_t>(worker + 1) / static_cast<size_t>(band_count);
    size_t band_index = static_cast<size_t>(std::upper_bound(points_before_band.begin(), points_before_band.end(), first) -
                                            points_before_band.begin()) - 1;
    for (size_t global = first; global < end; ++global) {
      while (global >= points_before_band[band_index + 1]) ++band_index;
      visit(bands[band_index], global - points_before_band[band_index], global);
    }
  };
  std::vector<Share> shares(bands.size());
  // z - S(x, y) of every point whose class needed S (NaN for the others): the local ground reuses it.
  const bool local_ground = parameters.local_ground_reference;
  std::vector<double> evaluated_height_m(local_ground ? point_count : 0, std::numeric_limits<double>::quiet_NaN());
  run_bands([&](int worker) {
    Share& share = shares[static_cast<size_t>(worker)];
    for_each_point_of_share(worker, [&](const Band& band, size_t i, size_t global) {
      double height_above_m = 0;
      bool evaluated = false;
      const CandidateTest::Class point_class = test.classify(band.vehicle_points[i], &height_above_m, &evaluated);
      if (local_ground && evaluated) evaluated_height_m[global] = height_above_m;
      if (point_class == CandidateTest::Class::outside) {
        ++share.outside_area;
      } else if (point_class == CandidateTest::Class::candidate && far_side_test && band.far_side[i] != 0) {
        ++share.far_side;
      } else if (point_class == CandidateTest::Class::candidate) {
        share.candidates.push_back(make_point(band.pixels[i], band.vehicle_points[i]));
        share.candidates.back().height_above_ground_m = static_cast<float>(height_above_m);
      }
    });
  });
  size_t candidate_count = 0;
  for (const Share& share : shares) candidate_count += share.candidates.size();
  result.points.reserve(candidate_count);
  for (const Share& share : shares) {
    result.points.insert(result.points.end(), share.candidates.begin(), share.candidates.end());
    result.outside_area += share.outside_area;
    result.far_side += share.far_side;
  }
  if (local_ground && !result.points.empty()) {
    // The gather needs z - S at every point near a candidate: the classification's where it has it
    // (the candidates among them), else evaluated, on the classification's shares and threads (the
    // result depends on neither, local_ground.h).
    LocalGround ground(parameters.grid, result.terrain.surface, parameters.obstacle_height_m, parameters.local_ground, band_count);
    ground.mark_candidates(result.points);
    run_bands([&](int worker) {
      for_each_point_of_share(worker, [&](const Band& band, size_t i, size_t global) {
        ground.add_point_in_cell(band.vehicle_points[i], band.cells[i][0], band.cells[i][1], worker, evaluated_height_m[global]);
      });
    });
    result.local_ground_cells = ground.apply(result.points);
  }
  char note[240];
  std::snprintf(note, sizeof note,
                "terrain: %lld points, %zu obstacle candidates, %lld outside the terrain area, %lld on the far side of an edge, %d cells "
                "with their ground below the view",
                static_cast<long long>(result.cloud_points), result.points.size(), static_cast<long long>(result.outside_area),
                static_cast<long long>(result.far_side), result.below_view_cells);
  result.note = note;
  if (local_ground) {
    result.note += ", " + std::to_string(result.local_ground_cells) + " candidate cells measured from their local ground";
  }
  return result;
}

DisparityParameters obstacles3d_disparity_defaults() { return DisparityParameters{}; }

DisparityParameters obstacles3d_near_guard_disparity_parameters() {
  DisparityParameters parameters = obstacles3d_disparity_defaults();
  parameters.num_disparities = 128;
  parameters.multires = true;
  parameters.multires_far_disparities = 64;
  return parameters;
}

}  // namespace lpstereo::arm::obstacles3d
