#include "arm/point_cloud.h"

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "dag/atomic_file.h"
#include "kernels/disparity_to_points.h"
#include "kernels/kernel.h"
#include "kernels/simd/isa.h"

namespace lpstereo::arm {

CameraPoints triangulate(const Plane& disparity_q4, const TriangulationParameters& parameters, KernelBackend backend) {
  const KernelDescriptor* kernel = KernelRegistry::instance().find("disparity_to_points");
  if (kernel == nullptr) throw std::logic_error("kernel 'disparity_to_points' is not linked into this program");
  const BufferFormat expected{ElementType::s16, 4};
  if (disparity_q4.format() != expected) {
    throw std::invalid_argument("triangulate: disparity format: expected s16q4, got " + format_name(disparity_q4.format()));
  }
  const nlohmann::json params = {{"baseline_m", parameters.baseline_m}, {"focal_px", parameters.focal_px},
                                 {"u0_px", parameters.u0_px},           {"v0_px", parameters.v0_px},
                                 {"min_disparity", parameters.min_disparity},
                                 {"num_disparities", parameters.num_disparities},
                                 {"disparity_offset_px", parameters.disparity_offset_px}};
  const PlaneShape shape{disparity_q4.width(), disparity_q4.height()};
  const PreparedKernel prepared = kernel->prepare(params, {shape});
  const BufferFormat millimetres{ElementType::s32, 0};
  CameraPoints points{Plane(shape.width, shape.height, millimetres), Plane(shape.width, shape.height, millimetres),
                      Plane(shape.width, shape.height, millimetres)};
  VectorNodeBinding binding{kernel, prepared.params.get(), BorderMode::replicate, 0, {disparity_q4.view()},
                            {points.x_mm.view(), points.y_mm.view(), points.z_mm.view()}};
  // Tiles of 256 x 32: what a vector node gets on the chip; the result does not depend on them.
  run_vector_node(binding, 256, 32, backend, simd::active_isa());
  return points;
}

Eigen::Matrix3d rotation_zyx(double roll_rad, double pitch_rad, double yaw_rad) {
  return (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Matrix3d optical_to_body() {
  Eigen::Matrix3d axes;
  // Rows: body x (forward) = optical z; body y (left) = -optical x; body z (up) = -optical y.
  axes << 0, 0, 1,  //
      -1, 0, 0,     //
      0, -1, 0;
  return axes;
}

CameraToVehicle::CameraToVehicle(const CameraMount& mount)
    : rotation_(rotation_zyx(mount.roll_rad, mount.pitch_rad, mount.yaw_rad) * optical_to_body()),
      translation_m_(mount.position_m) {}

ColourImageView grey_view(const Plane& grey_u8) {
  if (grey_u8.format().type != ElementType::u8) {
    throw std::invalid_argument("grey_view: image format: expected u8, got " + format_name(grey_u8.format()));
  }
  return {grey_u8.row<uint8_t>(0), grey_u8.stride_bytes(), grey_u8.width(), grey_u8.height(), 1};
}

PointCloud collect_points(const CameraPoints& points, const ColourImageView& colours, const CameraToVehicle* to_vehicle) {
  const int width = points.z_mm.width(), height = points.z_mm.height();
  auto check_size = [&](const char* name, int actual_width, int actual_height) {
    if (actual_width != width || actual_height != height) {
      throw std::invalid_argument(std::string("collect_points: ") + name + " size: expected " + std::to_string(width) + "x" +
                                  std::to_string(height) + " (the z plane's), got " + std::to_string(actual_width) + "x" +
                                  std::to_string(actual_height));
    }
  };
  check_size("x plane", points.x_mm.width(), points.x_mm.height());
  check_size("y plane", points.y_mm.width(), points.y_mm.height());
  check_size("colour image", colours.width, colours.height);
  if (colours.channels != 1 && colours.channels != 3) {
    throw std::invalid_argument("collect_points: colour channels: expected 1 or 3, got " + std::to_string(colours.channels));
  }
  PointCloud cloud;
  cloud.frame = to_vehicle != nullptr ? "vehicle" : "camera";
  for (int v = 0; v < height; ++v) {
    const int32_t* xs = points.x_mm.row<int32_t>(v);
    const int32_t* ys = points.y_mm.row<int32_t>(v);
    const int32_t* zs = points.z_mm.row<int32_t>(v);
    const uint8_t* colour_row = colours.data + v * colours.stride_bytes;
    for (int u = 0; u < width; ++u) {
      if (zs[u] == kernels::kNoPointMm) continue;
      Eigen::Vector3d point_m(1e-3 * xs[u], 1e-3 * ys[u], 1e-3 * zs[u]);
      if (to_vehicle != nullptr) point_m = to_vehicle->apply(point_m);
      CloudPoint point;
      point.x_m = static_cast<float>(point_m.x());
      point.y_m = static_cast<float>(point_m.y());
      point.z_m = static_cast<float>(point_m.z());
      const uint8_t* colour = colour_row + static_cast<ptrdiff_t>(u) * colours.channels;
      point.red = colour[0];
      point.green = colours.channels == 3 ? colour[1] : colour[0];
      point.blue = colours.channels == 3 ? colour[2] : colour[0];
      cloud.points.push_back(point);
    }
  }
  return cloud;
}

namespace {

void append_little_endian_float(std::string& bytes, float value) {
  uint32_t bits = std::bit_cast<uint32_t>(value);
  for (int i = 0; i < 4; ++i, bits >>= 8) bytes.push_back(static_cast<char>(bits & 0xFFu));
}

}  // namespace

std::string ply_bytes(const PointCloud& cloud, PlyEncoding encoding) {
  std::string bytes = "ply\n";
  bytes += encoding == PlyEncoding::ascii ? "format ascii 1.0\n" : "format binary_little_endian 1.0\n";
  bytes += "comment lpstereo disparity_to_points: metres, " +
           std::string(cloud.frame == "vehicle" ? "vehicle frame (x forward, y left, z up)"
                                                : "camera frame (x right, y down, z forward)") +
           "\n";
  bytes += "element vertex " + std::to_string(cloud.points.size()) + "\n";
  bytes += "property float x\nproperty float y\nproperty float z\n";
  bytes += "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  if (encoding == PlyEncoding::ascii) {
    char line[128];
    for (const CloudPoint& point : cloud.points) {
      // %.9g: a float's shortest round-trip form, so the ASCII file holds the same values as the binary one.
      const int length = std::snprintf(line, sizeof(line), "%.9g %.9g %.9g %d %d %d\n", point.x_m, point.y_m, point.z_m,
                                       point.red, point.green, point.blue);
      bytes.append(line, static_cast<size_t>(length));
    }
  } else {
    bytes.reserve(bytes.size() + cloud.points.size() * 15);
    for (const CloudPoint& point : cloud.points) {
      append_little_endian_float(bytes, point.x_m);
      append_little_endian_float(bytes, point.y_m);
      append_little_endian_float(bytes, point.z_m);
      bytes.push_back(static_cast<char>(point.red));
      bytes.push_back(static_cast<char>(point.green));
      bytes.push_back(static_cast<char>(point.blue));
    }
  }
  return bytes;
}

void write_ply(const std::string& path, const PointCloud& cloud, PlyEncoding encoding) {
  write_file_atomically(path, ply_bytes(cloud, encoding));
}

}  // namespace lpstereo::arm
