#include "tools/terrain_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arm/disparity_engine.h"
#include "arm/point_cloud.h"
#include "arm/terrain/terrain_model.h"
#include "arm/terrain_points.h"
#include "dag/atomic_file.h"
#include "io/image_io.h"
#include "kernels/disparity_to_points.h"
#include "tools/command_error.h"
#include "tools/rectified_pair.h"

namespace lpstereo::tools {
namespace {

namespace terrain = arm::terrain;

constexpr double kDegree = M_PI / 180.0;

// "AxB" with two numbers > 0 (metres or counts); bad usage otherwise.
std::pair<double, double> parse_pair(const std::string& flag, const std::string& text) {
  const size_t x = text.find('x');
  try {
    if (x != std::string::npos) {
      size_t used_first = 0, used_second = 0;
      const double first = std::stod(text.substr(0, x), &used_first);
      const double second = std::stod(text.substr(x + 1), &used_second);
      if (used_first == x && used_second == text.size() - x - 1 && first > 0 && second > 0 && std::isfinite(first) &&
          std::isfinite(second)) {
        return {first, second};
      }
    }
  } catch (const std::exception&) {
  }
  throw CommandError(kExitUsage, flag + ": expected AxB with two numbers > 0 (e.g. 34x22), got '" + text + "'");
}

nlohmann::json finite_or_null(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr); }

nlohmann::json matrix_json(const Eigen::MatrixXd& matrix) {
  nlohmann::json rows = nlohmann::json::array();
  for (int i = 0; i < matrix.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < matrix.cols(); ++j) row.push_back(finite_or_null(matrix(i, j)));
    rows.push_back(row);
  }
  return rows;
}

// Green (cost 0) to red (cost >= 1); occupied magenta; unknown black. BGR.
cv::Vec3b cost_colour(double cost, double occupancy) {
  if (!std::isfinite(cost)) return {0, 0, 0};
  if (occupancy == 1.0) return {255, 0, 255};
  const double t = std::clamp(cost, 0.0, 1.0);
  return {0, static_cast<uint8_t>(std::lround(200 * (1 - t))), static_cast<uint8_t>(std::lround(255 * t))};
}

// The cost grid as a top view: forward row i at the bottom for i = 0 (near), lateral column j = 0
// (rightmost, y = lateral_min) on the right.
cv::Mat map_picture(const terrain::TraversabilityMap& map) {
  const int rows = static_cast<int>(map.cost.rows()), columns = static_cast<int>(map.cost.cols());
  const int scale = std::max(1, 768 / std::max(rows, columns));
  cv::Mat picture(rows * scale, columns * scale, CV_8UC3, cv::Scalar(0, 0, 0));
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < columns; ++j) {
      const cv::Vec3b colour = cost_colour(map.cost(i, j), map.occupancy(i, j));
      cv::rectangle(picture, cv::Rect((columns - 1 - j) * scale, (rows - 1 - i) * scale, scale, scale),
                    cv::Scalar(colour[0], colour[1], colour[2]), cv::FILLED);
    }
  }
  return picture;
}

const cv::Vec3b kTerrainBgr(0, 200, 0), kObstacleBgr(0, 0, 255), kOutsideBgr(128, 128, 128);

}  // namespace

TerrainCommand::TerrainCommand(CLI::App& app) {
  command_ = app.add_subcommand("terrain",
                                "terrain in front of the vehicle from a rectified pair: disparity engine, 3D points, 2.5D grid, "
                                "iterative re-weighted B-spline surface, traversability cost, obstacle points (issue 9)");
  command_->add_option("LEFT", left_, "rectified left image")->required();
  command_->add_option("RIGHT", right_, "rectified right image, same size")->required();
  command_->add_option("--calib", calibration_files_,
                       "calibration file, or two (intrinsics + extrinsics, or left + right); its rectified geometry gives "
                       "focal length, baseline and principal point")
      ->required();
  command_->add_option("-o,--output", output_, "terrain JSON file to write")->required();
  command_->add_option("--area-m", area_m_, "area FORWARDxLATERAL in metres (x 0 .. FORWARD, y +-LATERAL/2)")->capture_default_str();
  command_->add_option("--cell-m", cell_m_, "grid cell size, metres")->capture_default_str()->check(CLI::Range(0.02, 10.0));
  command_->add_option("--control", control_, "control points N0xN1 (forward x lateral) of the final fit")->capture_default_str();
  command_->add_option("--degree", degree_, "B-spline degree in both directions")->capture_default_str()->check(CLI::Range(1, 5));
  command_->add_option("--camera-height-m", camera_height_m_,
                       "camera height above the ground under it, m (without it the mount is estimated from a ground plane)")
      ->check(CLI::Range(0.05, 100.0));
  command_->add_option("--pitch-deg", pitch_deg_, "camera pitch, degrees, + = looking down (with --camera-height-m)")
      ->capture_default_str()
      ->check(CLI::Range(-89.0, 89.0));
  command_->add_option("--roll-deg", roll_deg_, "camera roll, degrees, + = the right side lower (with --camera-height-m)")
      ->capture_default_str()
      ->check(CLI::Range(-89.0, 89.0));
  command_->add_option("--obstacle-height-m", obstacle_height_m_, "points more than this above the surface are obstacles, m")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 10.0));
  command_->add_option("--discontinuity-radius", discontinuity_filter_.radius_px,
                       "drop the near side of every disparity jump, this many px wide: the fattened object edges a window "
                       "matcher gives, whose points stand in the air beside the object (0 = off)")
      ->capture_default_str()
      ->check(CLI::Range(0, 32));
  command_->add_option("--discontinuity-jump", discontinuity_filter_.jump_px, "the jump the discontinuity filter acts on, px")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 256.0));
  command_->add_option("--map", map_path_, "also write a top view of the cost grid (PNG)");
  command_->add_option("--points", points_path_, "also write the points coloured by class (PLY, camera frame)");
  command_->add_option("--overlay", overlay_path_, "also write the left image with terrain (green) and obstacle (red) points (PNG)");
  command_->add_option("--threads", threads_, "worker threads (0 = one per hardware thread)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  add_disparity_engine_options(*command_, engine_options_, "disparities searched: [min-disp, min-disp + num-disp) (default 64)");
}

int TerrainCommand::run() const {
  // Usage first: nothing is read before the flags are known to be good.
  const auto [forward_m, lateral_m] = parse_pair("--area-m", area_m_);
  const auto [control_forward, control_lateral] = parse_pair("--control", control_);
  if (control_forward != std::floor(control_forward) || control_lateral != std::floor(control_lateral) ||
      control_forward < degree_ + 1 || control_lateral < degree_ + 1 || control_forward > 200 || control_lateral > 200) {
    throw CommandError(kExitUsage, "--control: expected two integers in [degree + 1, 200] = [" + std::to_string(degree_ + 1) +
                                       ", 200], got '" + control_ + "'");
  }
  if ((command_->count("--pitch-deg") > 0 || command_->count("--roll-deg") > 0) && command_->count("--camera-height-m") == 0) {
    throw CommandError(kExitUsage, "--pitch-deg/--roll-deg need --camera-height-m (a given mount); without them the mount is estimated");
  }
  terrain::TerrainGridSpec grid;
  grid.forward_min_m = 0;
  grid.forward_max_m = forward_m;
  grid.lateral_min_m = -lateral_m / 2;
  grid.lateral_max_m = lateral_m / 2;
  grid.cell_m = cell_m_;
  try {
    grid.validate();
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, std::string("--area-m/--cell-m: ") + error.what());
  }
  if (forward_m > 65.0 || lateral_m > 130.0) {
    throw CommandError(kExitUsage, "--area-m: expected at most 65x130 m (the binning kernel's range), got '" + area_m_ + "'");
  }

  const RectifiedPair pair = read_rectified_pair(left_, right_, calibration_files_);
  const Plane& left = pair.left;
  const io::RectifiedGeometry& geometry = pair.geometry;
  if (!(geometry.baseline_m > 0.0) || geometry.projection != io::RectifiedProjection::pinhole) {
    throw CommandError(kExitInput, "calibration " + calibration_files_[0] + ": expected a pinhole rectification with a baseline > 0 m, got " +
                                       std::to_string(geometry.baseline_m) + " m");
  }
  const arm::DisparityParameters disparity_parameters =
      tools::disparity_parameters(engine_options_, left.width(), arm::DisparityParameters{}.num_disparities);
  arm::DisparityEngine engine(left.width(), left.height(), disparity_parameters, {}, threads_);
  const auto started = std::chrono::steady_clock::now();
  Plane disparity = engine.compute(left, pair.right).clone();  // filtered in place below, not the engine's buffer
  // The fattened object edges out before any point is made (arm/terrain_points.h).
  const int64_t discontinuity_invalidated_px = discontinuity_filter_.apply(disparity, engine.invalid_disparity_q4());
  const arm::TriangulationParameters triangulation =
      triangulation_parameters(geometry, disparity_parameters.min_disparity, disparity_parameters.num_disparities);
  const arm::CameraPoints points = arm::triangulate(disparity, triangulation);
  const auto disparity_done = std::chrono::steady_clock::now();

  // The mount: given, or estimated from the ground plane.
  std::string reason;
  arm::CameraMount mount;
  std::string mount_source = "given";
  bool mount_found = true;
  if (command_->count("--camera-height-m") > 0) {
    mount.pitch_rad = pitch_deg_ * kDegree;
    mount.roll_rad = roll_deg_ * kDegree;
    mount.position_m = Eigen::Vector3d(0, 0, camera_height_m_);
  } else {
    mount_source = "estimated";
    const arm::GroundMountEstimate estimate = arm::estimate_ground_mount(points);
    if (estimate.found) {
      mount = estimate.mount;
    } else {
      mount_found = false;
      reason = estimate.reason + "; give --camera-height-m (and --pitch-deg, --roll-deg)";
    }
  }
  const arm::CameraToVehicle to_vehicle(mount);

  // The grid, the fit, the traversability, the classes.
  terrain::TerrainFitParameters fit_parameters;
  fit_parameters.degree_forward = fit_parameters.degree_lateral = degree_;
  fit_parameters.control_forward = static_cast<int>(control_forward);
  fit_parameters.control_lateral = static_cast<int>(control_lateral);
  fit_parameters.initial_control_forward = std::min(5, fit_parameters.control_forward);
  fit_parameters.initial_control_lateral = std::min(5, fit_parameters.control_lateral);
  terrain::TraversabilityParameters traversability_parameters;
  traversability_parameters.obstacle_height_m = obstacle_height_m_;
  terrain::HeightGridAccumulator accumulator(grid);
  terrain::TerrainEstimate estimate;
  estimate.known = false;
  std::optional<terrain::HeightGrid> measured;
  std::optional<terrain::TraversabilityMap> map;
  if (reason.empty()) {
    arm::accumulate_binned(arm::bin_points(points, to_vehicle, grid), grid, accumulator);
    measured = accumulator.finish();
    const std::string extent_problem = arm::ground_extent_problem(*measured);
    if (extent_problem.empty()) {
      estimate = terrain::fit_terrain(*measured, fit_parameters);
    } else {
      estimate.reason = extent_problem;
    }
    if (estimate.known) {
      map = terrain::compute_traversability(estimate, *measured, traversability_parameters);
    } else {
      reason = estimate.reason.empty() ? "terrain fit refused the grid" : estimate.reason;
    }
  }
  const auto fit_done = std::chrono::steady_clock::now();

  // Every point, its class.
  std::vector<Eigen::Vector3d> vehicle_points;
  std::vector<Eigen::Vector3d> camera_points;
  std::vector<std::pair<int, int>> pixels;
  for (int v = 0; v < points.z_mm.height(); ++v) {
    for (int u = 0; u < points.z_mm.width(); ++u) {
      const int32_t z_mm = points.z_mm.at<int32_t>(u, v);
      if (z_mm == kernels::kNoPointMm) continue;
      const Eigen::Vector3d camera(points.x_mm.at<int32_t>(u, v) / 1000.0, points.y_mm.at<int32_t>(u, v) / 1000.0, z_mm / 1000.0);
      camera_points.push_back(camera);
      vehicle_points.push_back(to_vehicle.apply(camera));
      pixels.emplace_back(u, v);
    }
  }
  const std::vector<terrain::PointClass> classes = terrain::classify_points(vehicle_points, estimate, obstacle_height_m_);

  // terrain.json.
  nlohmann::json json;
  json["width"] = left.width();
  json["height"] = left.height();
  json["known"] = estimate.known;
  json["reason"] = estimate.known ? nlohmann::json(nullptr) : nlohmann::json(reason);
  nlohmann::json rotation = nlohmann::json::array();
  for (int k = 0; k < 3; ++k) rotation.push_back({to_vehicle.rotation()(k, 0), to_vehicle.rotation()(k, 1), to_vehicle.rotation()(k, 2)});
  json["mount"] = {{"source", mount_source},
                   {"found", mount_found},
                   {"camera_height_m", mount.position_m.z()},
                   {"pitch_rad", mount.pitch_rad},
                   {"roll_rad", mount.roll_rad},
                   {"camera_to_vehicle",
                    {{"rotation", rotation},
                     {"translation_m", {to_vehicle.translation_m().x(), to_vehicle.translation_m().y(), to_vehicle.translation_m().z()}},
                     {"formula", "p_vehicle = rotation p_camera + translation_m"}}}};
  int measured_cells = 0;
  if (measured) {
    for (int i = 0; i < measured->state.rows(); ++i) {
      for (int j = 0; j < measured->state.cols(); ++j) measured_cells += measured->state(i, j) == terrain::kCellMeasured;
    }
  }
  json["grid"] = {{"frame", "vehicle"},
                  {"forward_min_m", grid.forward_min_m},
                  {"forward_max_m", grid.forward_max_m},
                  {"lateral_min_m", grid.lateral_min_m},
                  {"lateral_max_m", grid.lateral_max_m},
                  {"cell_m", grid.cell_m},
                  {"forward_cells", grid.forward_cells()},
                  {"lateral_cells", grid.lateral_cells()},
                  {"valid_cells", measured ? measured->valid_cells() : 0},
                  {"measured_cells", measured_cells},
                  {"points", accumulator.accepted()}};
  if (estimate.known) {
    const terrain::BsplineSurface& surface = estimate.surface;
    json["spline"] = {{"frame", "vehicle"},
                      {"axes", "x forward, y left, z up, metres (ISO 8855); z = S(x, y)"},
                      {"degree_forward", surface.degree_forward},
                      {"degree_lateral", surface.degree_lateral},
                      {"knots_forward_m", surface.knots_forward_m},
                      {"knots_lateral_m", surface.knots_lateral_m},
                      {"control_z_m", matrix_json(surface.control_z_m)},
                      {"control_weights", surface.control_weights.size() == 0 ? nlohmann::json(nullptr) : matrix_json(surface.control_weights)},
                      {"domain_m",
                       {{"forward_min", surface.forward_min_m},
                        {"forward_max", surface.forward_max_m},
                        {"lateral_min", surface.lateral_min_m},
                        {"lateral_max", surface.lateral_max_m}}},
                      {"iterations", estimate.iterations},
                      {"equalised_cells_last", estimate.equalised_cells_last},
                      {"mean_abs_error_m", estimate.mean_abs_error_m}};
  } else {
    json["spline"] = nullptr;
  }
  if (map) {
    std::vector<double> forward_centres, lateral_centres;
    for (int i = 0; i < grid.forward_cells(); ++i) forward_centres.push_back(grid.cell_centre_x_m(i));
    for (int j = 0; j < grid.lateral_cells(); ++j) lateral_centres.push_back(grid.cell_centre_y_m(j));
    json["cost_grid"] = {{"frame", "vehicle"},
                         {"forward_m", forward_centres},
                         {"lateral_m", lateral_centres},
                         {"cost", matrix_json(map->cost)},
                         {"slope", matrix_json(map->slope)},
                         {"occupancy", matrix_json(map->occupancy)},
                         {"occupancy_weight", traversability_parameters.occupancy_weight},
                         {"slope_weight", traversability_parameters.slope_weight}};
  } else {
    json["cost_grid"] = nullptr;
  }
  // The sampled surface in the camera frame: camera x across the area's width, camera z along its
  // length, at the cell pitch.
  std::vector<double> x_m, z_m;
  for (double x = grid.lateral_min_m + grid.cell_m / 2; x < grid.lateral_max_m; x += grid.cell_m) x_m.push_back(x);
  for (double z = grid.forward_min_m + grid.cell_m / 2; z < grid.forward_max_m; z += grid.cell_m) z_m.push_back(z);
  nlohmann::json y_m = nlohmann::json::array();
  for (double z : z_m) {
    nlohmann::json row = nlohmann::json::array();
    for (double x : x_m) {
      const std::optional<double> y = arm::surface_camera_y_m(estimate, to_vehicle, x, z);
      row.push_back(y ? nlohmann::json(*y) : nlohmann::json(nullptr));
    }
    y_m.push_back(row);
  }
  json["surface_grid"] = {{"frame", "camera"}, {"x_m", x_m}, {"z_m", z_m}, {"y_m", y_m}};
  nlohmann::json obstacle_points = nlohmann::json::array();
  int counts[3] = {0, 0, 0};
  for (size_t n = 0; n < classes.size(); ++n) {
    counts[static_cast<int>(classes[n])] += 1;
    if (classes[n] == terrain::PointClass::obstacle) {
      // Millimetre precision: what the kernel gives.
      obstacle_points.push_back({std::round(camera_points[n].x() * 1000) / 1000, std::round(camera_points[n].y() * 1000) / 1000,
                                 std::round(camera_points[n].z() * 1000) / 1000});
    }
  }
  json["obstacle_points_camera_m"] = obstacle_points;
  json["point_counts"] = {{"terrain", counts[1]}, {"obstacle", counts[2]}, {"outside", counts[0]}};
  json["discontinuity_filter"] = {
      {"radius_px", discontinuity_filter_.radius_px}, {"jump_px", discontinuity_filter_.jump_px}, {"invalidated_px", discontinuity_invalidated_px}};
  write_file_atomically(output_, json.dump(1) + "\n");

  // Pictures.
  if (!map_path_.empty()) {
    if (map) {
      io::write_image(map_path_, map_picture(*map));
    } else {
      io::write_image(map_path_, cv::Mat(grid.forward_cells(), grid.lateral_cells(), CV_8UC3, cv::Scalar(0, 0, 0)));
    }
  }
  if (!overlay_path_.empty() || !points_path_.empty()) {
    cv::Mat picture = io::decode_image(left_, cv::IMREAD_COLOR);
    if (picture.depth() != CV_8U) picture.convertTo(picture, CV_8U, 1.0 / 256);
    arm::PointCloud cloud;
    cloud.frame = "camera";
    for (size_t n = 0; n < classes.size(); ++n) {
      const cv::Vec3b colour = classes[n] == terrain::PointClass::terrain    ? kTerrainBgr
                               : classes[n] == terrain::PointClass::obstacle ? kObstacleBgr
                                                                             : kOutsideBgr;
      if (classes[n] != terrain::PointClass::outside) {
        cv::Vec3b& pixel = picture.at<cv::Vec3b>(pixels[n].second, pixels[n].first);
        for (int c = 0; c < 3; ++c) pixel[c] = static_cast<uint8_t>((pixel[c] + 2 * colour[c]) / 3);
      }
      cloud.points.push_back({static_cast<float>(camera_points[n].x()), static_cast<float>(camera_points[n].y()),
                              static_cast<float>(camera_points[n].z()), colour[2], colour[1], colour[0]});
    }
    if (!overlay_path_.empty()) io::write_image(overlay_path_, picture);
    if (!points_path_.empty()) {
      // The frame comment of ply_bytes names the frame; the classes are in the colours.
      cloud.frame = "camera (classes by colour: terrain 0 200 0, obstacle 255 0 0, outside the area 128 128 128)";
      arm::write_ply(points_path_, cloud, arm::PlyEncoding::binary_little_endian);
    }
  }

  const double disparity_ms = std::chrono::duration<double, std::milli>(disparity_done - started).count();
  const double terrain_ms = std::chrono::duration<double, std::milli>(fit_done - disparity_done).count();
  if (!estimate.known) {
    std::cerr << "lpstereo: terrain unknown: " << reason << " (" << output_ << " written with \"known\": false)\n";
    return kExitTerrainUnknown;
  }
  std::printf("terrain known: %d of %d cells valid, %lld points binned, mean |error| %.3f m after %d iterations; %d obstacle "
              "points; mount %s (height %.2f m, pitch %.4f rad, roll %.4f rad); %lld edge px dropped; disparity %.1f ms, terrain "
              "%.1f ms -> %s\n",
              measured->valid_cells(), grid.forward_cells() * grid.lateral_cells(), static_cast<long long>(accumulator.accepted()),
              estimate.mean_abs_error_m, estimate.iterations, counts[2], mount_source.c_str(), mount.position_m.z(), mount.pitch_rad,
              mount.roll_rad, static_cast<long long>(discontinuity_invalidated_px), disparity_ms, terrain_ms, output_.c_str());
  return 0;
}

}  // namespace lpstereo::tools
