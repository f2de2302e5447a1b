#include "arm/obstacles3d/obstacle_candidates.h"

#include <cstdio>
#include <stdexcept>

#include "kernels/disparity_to_points.h"

namespace lpstereo::arm::obstacles3d {

namespace {

std::string size_text(const Plane& plane) { return std::to_string(plane.width()) + "x" + std::to_string(plane.height()); }

}  // namespace

CandidatePoints extract_obstacle_candidates(const Plane& disparity_q4, int16_t invalid_disparity_q4, const CameraPoints& camera,
                                            const Plane& grey, const ColourView& colour, const CameraToVehicle& to_vehicle,
                                            const CandidateParameters& parameters) {
  if (!(parameters.obstacle_height_m > 0 && parameters.obstacle_height_m < 10)) {
    throw std::invalid_argument("obstacle_height_m: expected a height in (0, 10) m, got " + std::to_string(parameters.obstacle_height_m));
  }
  for (const Plane* plane : {&camera.x_mm, &camera.y_mm, &camera.z_mm, &grey}) {
    if (plane->width() != disparity_q4.width() || plane->height() != disparity_q4.height()) {
      throw std::invalid_argument("obstacle candidates: expected every plane " + size_text(disparity_q4) + " like the disparity map, got " +
                                  size_text(*plane));
    }
  }
  CandidatePoints result;
  std::vector<Eigen::Vector3d> vehicle_points;
  std::vector<ObstaclePoint> all;
  const int red_channel = colour.blue_first ? 2 : 0, blue_channel = colour.blue_first ? 0 : 2;
  for (int v = 0; v < disparity_q4.height(); ++v) {
    const uint8_t* colour_row = colour.pixels == nullptr ? nullptr : colour.pixels + static_cast<size_t>(v) * colour.row_stride_bytes;
    for (int u = 0; u < disparity_q4.width(); ++u) {
      const int32_t x_mm = camera.x_mm.at<int32_t>(u, v);
      const int16_t d_q4 = disparity_q4.at<int16_t>(u, v);
      if (x_mm == kernels::kNoPointMm || d_q4 == invalid_disparity_q4 || d_q4 <= 0) continue;
      ObstaclePoint point;
      point.camera_m = Eigen::Vector3f(static_cast<float>(x_mm) * 1e-3f, static_cast<float>(camera.y_mm.at<int32_t>(u, v)) * 1e-3f,
                                       static_cast<float>(camera.z_mm.at<int32_t>(u, v)) * 1e-3f);
      const Eigen::Vector3d vehicle = to_vehicle.apply(point.camera_m.cast<double>());
      point.vehicle_m = vehicle.cast<float>();
      point.disparity_px = static_cast<float>(d_q4) / 16.0f;
      point.u_px = static_cast<uint16_t>(u);
      point.v_px = static_cast<uint16_t>(v);
      if (colour_row != nullptr) {
        const uint8_t* pixel = colour_row + 3 * static_cast<size_t>(u);
        point.rgb = {pixel[red_channel], pixel[1], pixel[blue_channel]};
      } else {
        const uint8_t value = grey.at<uint8_t>(u, v);
        point.rgb = {value, value, value};
      }
      all.push_back(point);
      vehicle_points.push_back(vehicle);
    }
  }
  result.cloud_points = static_cast<int64_t>(all.size());
  if (all.empty()) {
    result.note = "empty cloud (no valid disparity)";
    return result;
  }
  terrain::HeightGridAccumulator accumulator(parameters.grid);
  for (const Eigen::Vector3d& point : vehicle_points) accumulator.add_point(point);
  result.measured_grid = accumulator.finish();
  result.terrain = terrain::fit_terrain(result.measured_grid, parameters.fit);
  if (!result.terrain.known) {
    result.note = "terrain unknown (" + result.terrain.reason + "): no obstacle candidates";
    result.outside_area = result.cloud_points;
    return result;
  }
  const std::vector<terrain::PointClass> classes = terrain::classify_points(vehicle_points, result.terrain, parameters.obstacle_height_m);
  for (size_t i = 0; i < all.size(); ++i) {
    if (classes[i] == terrain::PointClass::outside) {
      ++result.outside_area;
    } else if (classes[i] == terrain::PointClass::obstacle) {
      ObstaclePoint point = all[i];
      point.height_above_ground_m =
          static_cast<float>(vehicle_points[i].z() - result.terrain.surface.height_m(vehicle_points[i].x(), vehicle_points[i].y()));
      result.points.push_back(point);
    }
  }
  char note[160];
  std::snprintf(note, sizeof note, "terrain: %lld points, %zu obstacle candidates, %lld outside the terrain area",
                static_cast<long long>(result.cloud_points), result.points.size(), static_cast<long long>(result.outside_area));
  result.note = note;
  return result;
}

}  // namespace lpstereo::arm::obstacles3d
