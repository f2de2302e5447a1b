// ARM task "augmented_stixels": the stixel half of issue 10's chain on the chip, after the terrain
// graph (graphs/terrain.json): the frame's obstacle candidates (the points more than
// obstacle_height_m above the terrain surface that the "terrain_estimate" task fitted) turned into
// augmented stixels and obstacles by arm::obstacles3d::AugmentedStixels (its public interface only;
// the model, the polar grid's likelihoods and the stixel rules are in
// arm/obstacles3d/augmented_stixels.h and occupancy_grid.h; thesis 004 §3.2.4). Record layouts:
// arm/tasks/stixel_record.h.
//
// Model. The terrain record holds the control heights of a clamped uniform B-spline over the area
// (arm/tasks/terrain_record.h); with this task's area and degrees (which must be the terrain task's)
// the surface S(x, y) is rebuilt exactly as fit_terrain built it (clamped_uniform_knots over the
// area). A camera point P_c (the disparity_to_points planes, mm) goes to the vehicle frame by
// arm::CameraToVehicle of the mount (a camera camera_height_m above the ground with pitch_rad and
// roll_rad: the mount point_cell_binning's rotation_q14 and translation_mm encode; graphs/terrain.json
// is a level camera 1.65 m up), P_v = (x, y, z); its height above the terrain is h = z - S(x, y);
// h > obstacle_height_m makes it a candidate (classify_points's rule, through
// arm::obstacles3d::CandidateTest, which skips S where the control heights already decide).
// A candidate's disparity, which the polar grid's error model takes, is d = f B / Z_c (the
// triangulation inverted, focal_px and baseline_m: disparity_to_points's parameters). The graph
// carries no colour to this task: every candidate's colour is 0 (the stixels' mean colour is 0).
// One frame's evidence: the task keeps no state between frames (a new polar grid per frame, static
// camera), so a cell is occupied when this frame's points alone say so; the per-frame work is that
// of the host's update() without the ego-motion resampling (one pass over the cells).
//
// Steps, per frame:
//   1. the terrain record: known = 0 gives an empty frame (header only, kStixelHeaderTerrainKnown 0);
//      otherwise its degrees, control counts and cell size must be this task's (else KernelError);
//   2. every sample_step-th row and column of the point planes: a pixel with a point is taken to the
//      vehicle frame; outside the surface's area it is counted (outside), else CandidateTest
//      classifies it and a candidate ObstaclePoint is kept (camera and vehicle position in m, h, d,
//      pixel);
//   2b. with local_ground 1, the candidates measured from the terrain inliers around them where the
//      surface stands above them (arm/obstacles3d/local_ground.h, the host chain's
//      CandidateParameters::local_ground_reference), over the sampled points;
//   3. AugmentedStixels::update(candidates, no ego-motion): polar grid update, stixels, obstacles;
//   4. the "stixels" and "obstacles" records (at most max_stixels and max_obstacles rows).
//
// Ports: inputs "x", "y", "z" s32 camera-frame mm planes (kernels/disparity_to_points.h; kNoPointMm
// where no point), all one size, and "terrain" s32 (kTerrainHeaderWords + control_forward
// control_lateral) x 1 (the terrain_estimate task's record); outputs "stixels" s32 kStixelWords x
// (1 + max_stixels) and "obstacles" s32 kObstacle3dWords x (1 + max_obstacles).
//
// Parameters (units in the names): the terrain task's area and surface: forward_min_m (0),
// forward_max_m (34), lateral_min_m (-11), lateral_max_m (11), cell_m (0.5), degree_forward,
// degree_lateral (3, 1 .. 5), control_forward, control_lateral (25, degree + 1 .. 64); the camera:
// focal_px (> 0, required), baseline_m (> 0, required), u0_px (principal point column, required),
// camera_height_m (1.65, [0, 100]), pitch_rad, roll_rad (0, [-1.5, 1.5]); obstacle_height_m (0.2,
// (0, 10)); sample_step (4, 1 .. 64); the stixels (AugmentedStixelParameters, the polar grid at
// OccupancyGridParameters::defaults(polar, input width)): min_points (3), max_height_gap_m (0.5),
// min_cluster_stixels (1), height_trim_fraction (0.02); max_stixels (4096, 1 .. 65536),
// max_obstacles (256, 1 .. 65536); local_ground (0 or 1, default 0: the graphs leave it off),
// local_ground_reach_cells (1, 0 .. 8), local_ground_min_points (8, 1 .. 100000: the host's count
// over every pixel; a sample_step of k sees about 1 / k^2 of those points).
//
// Counted work (deterministic, ArmWork), with S = ceil(W / step) ceil(H / step) sampled pixels of a
// W x H plane, V of them with a point, I of those inside the surface's area, E of those with S
// evaluated, N candidates, T the
// stixels written, O the obstacles written, p, q the degrees:
//   scalar_ops   = 3 S (load x, compare, branch) + 15 V (load y, z, convert, the 3 x 3 rotation and
//                  translation, the area test) + 24 I (the two knot-span searches over at most 64
//                  knots and the control-height bound of arm::obstacles3d::CandidateTest)
//                  + E (6 p (p + 1) + 6 q (q + 1) + 2 (p + 1) (q + 1) + 8) for the E points the bound
//                  cannot decide (S(x, y): the basis values of both axes, the tensor product, the
//                  subtraction and compare, terrain::surface_evaluation_ops; the per-point model
//                  arm/terrain/traversability.cpp gives classify_points)
//                  + 16 N (the candidate's fields and the disparity)
//                  + with local_ground, LocalGround's own counted work (local_ground.h; it evaluates
//                  S only for the points the classification did not)
//                  + the stixels' own counted work (AugmentedStixels::work(): the polar grid per
//                  point and cell, the stixels per point, the clustering per stixel) + 16 T + 16 O + 64;
//   memory_bytes = 12 W ceil(H / step) (the sampled rows of three planes, whole cache lines, as the
//                  terrain task counts them) + 4 (kTerrainHeaderWords + n0 n1) (the record)
//                  + sizeof(ObstaclePoint) N (the candidates written) + with local_ground, LocalGround's
//                  and 32 I (the points over the surface and their evaluated heights kept for its
//                  pass) + the stixels' own counted bytes + 4 kStixelWords (1 + T) + 4 kObstacle3dWords
//                  (1 + O).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/local_ground.h"
#include "arm/obstacles3d/obstacle_candidates.h"
#include "arm/point_cloud.h"
#include "arm/tasks/stixel_record.h"
#include "arm/tasks/terrain_record.h"
#include "arm/terrain/terrain_model.h"
#include "dag/arm_task.h"
#include "kernels/disparity_to_points.h"

namespace lpstereo::arm {
namespace {

namespace o3 = obstacles3d;

struct AugmentedStixelsTaskParams {
  terrain::TerrainGridSpec grid;
  int degree_forward = 3, degree_lateral = 3, control_forward = 25, control_lateral = 25;
  CameraMount mount;
  double focal_px = 0, baseline_m = 0;
  double obstacle_height_m = 0.2;
  int sample_step = 4;
  int max_stixels = 4096, max_obstacles = 256;
  o3::AugmentedStixelParameters stixels;
  bool local_ground = false;  // the host chain's local ground (arm/obstacles3d/local_ground.h)
  o3::LocalGroundParameters local_ground_parameters;
};

std::string shape_text(const PlaneShape& shape) { return std::to_string(shape.width) + "x" + std::to_string(shape.height); }

double required_double(const nlohmann::json& params, const char* name, double min_value, double max_value) {
  if (!params.contains(name)) {
    throw KernelError(std::string(name) + ": expected a value in [" + std::to_string(min_value) + ", " + std::to_string(max_value) +
                      "] (required), got none");
  }
  return param_double(params, name, 0.0, min_value, max_value);
}

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"forward_min_m", "forward_max_m", "lateral_min_m", "lateral_max_m", "cell_m", "degree_forward",
                             "degree_lateral", "control_forward", "control_lateral", "focal_px", "baseline_m", "u0_px",
                             "camera_height_m", "pitch_rad", "roll_rad", "obstacle_height_m", "sample_step", "min_points",
                             "max_height_gap_m", "min_cluster_stixels", "height_trim_fraction", "max_stixels", "max_obstacles",
                             "local_ground", "local_ground_reach_cells", "local_ground_min_points"});
  if (input_shapes.size() != 4) {
    throw KernelError("inputs: expected 4 (x, y, z, terrain), got " + std::to_string(input_shapes.size()));
  }
  const char* plane_names[3] = {"x", "y", "z"};
  for (int i = 1; i < 3; ++i) {
    if (input_shapes[static_cast<size_t>(i)].width != input_shapes[0].width || input_shapes[static_cast<size_t>(i)].height != input_shapes[0].height) {
      throw KernelError(std::string("input '") + plane_names[i] + "': expected the size of 'x' (" + shape_text(input_shapes[0]) + "), got " +
                        shape_text(input_shapes[static_cast<size_t>(i)]));
    }
  }
  auto prepared = std::make_shared<AugmentedStixelsTaskParams>();
  AugmentedStixelsTaskParams& p = *prepared;
  const TerrainRecordShape shape = terrain_record_shape_params(params);
  p.grid = shape.grid;
  p.degree_forward = shape.degree_forward;
  p.degree_lateral = shape.degree_lateral;
  p.control_forward = shape.control_forward;
  p.control_lateral = shape.control_lateral;
  const int record_words = shape.record_words();
  if (input_shapes[3].width != record_words || input_shapes[3].height != 1) {
    throw KernelError("input 'terrain': expected " + std::to_string(record_words) + "x1 (kTerrainHeaderWords + control_forward * control_lateral), got " +
                      shape_text(input_shapes[3]));
  }
  p.focal_px = required_double(params, "focal_px", 1e-3, 1e6);
  p.baseline_m = required_double(params, "baseline_m", 1e-4, 100.0);
  const double u0_px = required_double(params, "u0_px", -1e6, 1e6);
  p.mount.position_m = Eigen::Vector3d(0, 0, param_double(params, "camera_height_m", 1.65, 0.0, 100.0));
  p.mount.pitch_rad = param_double(params, "pitch_rad", 0.0, -1.5, 1.5);
  p.mount.roll_rad = param_double(params, "roll_rad", 0.0, -1.5, 1.5);
  p.obstacle_height_m = param_double(params, "obstacle_height_m", 0.2, 1e-6, 10.0);
  p.sample_step = param_int(params, "sample_step", 4, 1, 64);
  p.max_stixels = param_int(params, "max_stixels", 4096, 1, 65536);
  p.max_obstacles = param_int(params, "max_obstacles", 256, 1, 65536);

  const CameraToVehicle to_vehicle(p.mount);
  o3::OccupancyGridParameters& polar = p.stixels.grid;
  polar = o3::OccupancyGridParameters::defaults(o3::GridKind::polar, input_shapes[0].width);
  polar.error_model.focal_px = p.focal_px;
  polar.error_model.baseline_m = p.baseline_m;
  polar.principal_u_px = u0_px;
  polar.vehicle_from_camera = to_vehicle.vehicle_from_camera();
  polar.threads = 1;  // one ARM core; the scheduler places the task
  p.stixels.min_points = param_int(params, "min_points", 3, 1, 1 << 20);
  p.stixels.max_height_gap_m = param_double(params, "max_height_gap_m", 0.5, 0.0, 100.0);
  p.stixels.min_cluster_stixels = param_int(params, "min_cluster_stixels", 1, 1, 1 << 20);
  p.stixels.height_trim_fraction = param_double(params, "height_trim_fraction", 0.02, 0.0, 0.2499);
  try {
    p.stixels.validate();
  } catch (const std::invalid_argument& error) {
    throw KernelError(std::string("stixel parameters: ") + error.what());
  }
  p.local_ground = param_int(params, "local_ground", 0, 0, 1) == 1;
  p.local_ground_parameters.reach_cells = param_int(params, "local_ground_reach_cells", 1, 0, 8);
  p.local_ground_parameters.min_points = param_int(params, "local_ground_min_points", 8, 1, 100000);
  return PreparedKernel{prepared, {{kStixelWords, 1 + p.max_stixels}, {kObstacle3dWords, 1 + p.max_obstacles}}};
}

int32_t to_milli(double value) { return static_cast<int32_t>(std::lround(1000.0 * std::clamp(value, -2e6, 2e6))); }
int32_t to_micro_rad(double value) { return static_cast<int32_t>(std::lround(1e6 * std::clamp(value, -4.0, 4.0))); }
int32_t clamp_count(uint64_t value) { return static_cast<int32_t>(std::min<uint64_t>(value, 0x7FFFFFFF)); }

// The surface the terrain task fitted, from its record (the knots as fit_terrain makes them).
terrain::BsplineSurface surface_from_record(const int32_t* record, const AugmentedStixelsTaskParams& p) {
  const auto mismatch = [](const char* word, int expected, int actual) {
    throw KernelError(std::string("input 'terrain' word ") + word + ": expected " + std::to_string(expected) + " (this task's parameter), got " +
                      std::to_string(actual));
  };
  if (record[kTerrainDegreeForward] != p.degree_forward) mismatch("degree_forward", p.degree_forward, record[kTerrainDegreeForward]);
  if (record[kTerrainDegreeLateral] != p.degree_lateral) mismatch("degree_lateral", p.degree_lateral, record[kTerrainDegreeLateral]);
  if (record[kTerrainControlForward] != p.control_forward) mismatch("control_forward", p.control_forward, record[kTerrainControlForward]);
  if (record[kTerrainControlLateral] != p.control_lateral) mismatch("control_lateral", p.control_lateral, record[kTerrainControlLateral]);
  const int cell_mm = static_cast<int>(std::lround(1000.0 * p.grid.cell_m));
  if (record[kTerrainCellMm] != cell_mm) mismatch("cell_mm", cell_mm, record[kTerrainCellMm]);
  terrain::BsplineSurface surface;
  surface.degree_forward = p.degree_forward;
  surface.degree_lateral = p.degree_lateral;
  surface.forward_min_m = p.grid.forward_min_m;
  surface.forward_max_m = p.grid.forward_max_m;
  surface.lateral_min_m = p.grid.lateral_min_m;
  surface.lateral_max_m = p.grid.lateral_max_m;
  surface.knots_forward_m = terrain::clamped_uniform_knots(p.control_forward, p.degree_forward, p.grid.forward_min_m, p.grid.forward_max_m);
  surface.knots_lateral_m = terrain::clamped_uniform_knots(p.control_lateral, p.degree_lateral, p.grid.lateral_min_m, p.grid.lateral_max_m);
  surface.control_z_m.resize(p.control_forward, p.control_lateral);
  for (int i = 0; i < p.control_forward; ++i) {
    for (int j = 0; j < p.control_lateral; ++j) surface.control_z_m(i, j) = record[kTerrainHeaderWords + i * p.control_lateral + j] / 1000.0;
  }
  return surface;
}

void run(const ArmTaskArgs& args) {
  const auto& p = *static_cast<const AugmentedStixelsTaskParams*>(args.params);
  const Plane& x_plane = *args.inputs.at(0);
  const Plane& y_plane = *args.inputs.at(1);
  const Plane& z_plane = *args.inputs.at(2);
  const int32_t* record = args.inputs.at(3)->row<const int32_t>(0);
  Plane& stixel_plane = *args.outputs.at(0);
  Plane& obstacle_plane = *args.outputs.at(1);
  for (Plane* plane : {&stixel_plane, &obstacle_plane}) {
    for (int r = 0; r < plane->height(); ++r) std::memset(plane->row<int32_t>(r), 0, sizeof(int32_t) * static_cast<size_t>(plane->width()));
  }
  int32_t* header = stixel_plane.row<int32_t>(0);
  const uint64_t record_words = static_cast<uint64_t>(args.inputs.at(3)->width());
  ArmWork work;
  uint64_t ops = 64;
  header[kStixelHeaderTerrainKnown] = record[kTerrainKnown] == 1 ? 1 : 0;
  if (record[kTerrainKnown] == 1) {
    // 1-2. The surface, then the candidates.
    const terrain::BsplineSurface surface = surface_from_record(record, p);
    const CameraToVehicle to_vehicle(p.mount);
    const double focal_baseline = p.focal_px * p.baseline_m;
    std::vector<o3::ObstaclePoint> candidates;
    // With local_ground: every point over the surface, for its inliers, and its z - S where the
    // classification evaluated S (NaN where it did not), which LocalGround then need not evaluate.
    std::vector<Eigen::Vector3d> inside_points;
    std::vector<double> inside_heights_m;
    const o3::CandidateTest test(surface, p.obstacle_height_m);
    uint64_t sampled = 0, valid = 0, inside = 0, evaluated_points = 0;
    for (int v = 0; v < x_plane.height(); v += p.sample_step) {
      const int32_t* x_row = x_plane.row<const int32_t>(v);
      const int32_t* y_row = y_plane.row<const int32_t>(v);
      const int32_t* z_row = z_plane.row<const int32_t>(v);
      for (int u = 0; u < x_plane.width(); u += p.sample_step) {
        ++sampled;
        if (x_row[u] == kernels::kNoPointMm || z_row[u] <= 0) continue;
        ++valid;
        const Eigen::Vector3d camera_m(x_row[u] * 1e-3, y_row[u] * 1e-3, z_row[u] * 1e-3);
        const Eigen::Vector3d vehicle_m = to_vehicle.apply(camera_m);
        double height_m = 0;
        bool evaluated = false;
        const o3::CandidateTest::Class point_class = test.classify(vehicle_m, &height_m, &evaluated);
        if (point_class == o3::CandidateTest::Class::outside) continue;
        ++inside;
        if (p.local_ground) {
          inside_points.push_back(vehicle_m);
          inside_heights_m.push_back(evaluated ? height_m : std::numeric_limits<double>::quiet_NaN());
        }
        evaluated_points += evaluated;
        if (point_class != o3::CandidateTest::Class::candidate) continue;
        o3::ObstaclePoint point;
        point.camera_m = camera_m.cast<float>();
        point.vehicle_m = vehicle_m.cast<float>();
        point.height_above_ground_m = static_cast<float>(height_m);
        point.disparity_px = static_cast<float>(focal_baseline / camera_m.z());
        point.u_px = static_cast<uint16_t>(u);
        point.v_px = static_cast<uint16_t>(v);
        candidates.push_back(point);
      }
    }
    header[kStixelHeaderCandidatePoints] = clamp_count(candidates.size());
    header[kStixelHeaderSampledPixels] = clamp_count(sampled);
    header[kStixelHeaderValidPoints] = clamp_count(valid);
    header[kStixelHeaderOutsidePoints] = clamp_count(valid - inside);
    ops += 3 * sampled + 15 * valid + 24 * inside + evaluated_points * terrain::surface_evaluation_ops(p.degree_forward, p.degree_lateral) +
           16 * candidates.size();
    work.memory_bytes += sizeof(o3::ObstaclePoint) * candidates.size();
    if (p.local_ground && !candidates.empty()) {
      o3::LocalGround local_ground(p.grid, surface, p.obstacle_height_m, p.local_ground_parameters);
      local_ground.mark_candidates(candidates);
      for (size_t k = 0; k < inside_points.size(); ++k) local_ground.add_point(inside_points[k], 0, inside_heights_m[k]);
      local_ground.apply(candidates);
      work += local_ground.work();
      // the points and heights kept for the second pass
      work.memory_bytes += (sizeof(Eigen::Vector3d) + sizeof(double)) * inside_points.size();
    }

    // 3. The stixels (one frame's evidence, static camera).
    o3::AugmentedStixels stixels(p.stixels);
    stixels.update(candidates, o3::EgoMotion{});
    work += stixels.work();

    // 4. The records.
    const std::vector<o3::AugmentedStixel>& all_stixels = stixels.stixels();
    const std::vector<o3::Obstacle3d>& obstacles = stixels.obstacles();
    const int stixel_rows = static_cast<int>(std::min<size_t>(all_stixels.size(), static_cast<size_t>(p.max_stixels)));
    header[kStixelHeaderWritten] = stixel_rows;
    header[kStixelHeaderTotal] = clamp_count(all_stixels.size());
    header[kStixelHeaderObstacles] = clamp_count(obstacles.size());
    for (int s = 0; s < stixel_rows; ++s) {
      const o3::AugmentedStixel& stixel = all_stixels[static_cast<size_t>(s)];
      int32_t* row = stixel_plane.row<int32_t>(1 + s);
      row[kStixelAngleCell] = stixel.angle_cell;
      row[kStixelRangeCell] = stixel.range_cell;
      row[kStixelAngleMinUrad] = to_micro_rad(stixel.angle_min_rad);
      row[kStixelAngleMaxUrad] = to_micro_rad(stixel.angle_max_rad);
      row[kStixelRangeMinMm] = to_milli(stixel.range_min_m);
      row[kStixelRangeMaxMm] = to_milli(stixel.range_max_m);
      row[kStixelMinHeightMm] = to_milli(stixel.min_height_m);
      row[kStixelMaxHeightMm] = to_milli(stixel.max_height_m);
      row[kStixelMeanRangeMm] = to_milli(stixel.mean_range_m);
      row[kStixelPointCount] = stixel.point_count;
      row[kStixelOccupancyPermille] = static_cast<int32_t>(std::lround(1000.0 * stixel.occupancy_probability));
      row[kStixelCluster] = stixel.cluster;
    }
    const int obstacle_rows = static_cast<int>(std::min<size_t>(obstacles.size(), static_cast<size_t>(p.max_obstacles)));
    int32_t* obstacle_header = obstacle_plane.row<int32_t>(0);
    obstacle_header[0] = obstacle_rows;
    obstacle_header[1] = clamp_count(obstacles.size());
    for (int o = 0; o < obstacle_rows; ++o) {
      const o3::Obstacle3d& obstacle = obstacles[static_cast<size_t>(o)];
      int32_t* row = obstacle_plane.row<int32_t>(1 + o);
      for (int axis = 0; axis < 3; ++axis) {
        row[kObstacle3dPositionXMm + axis] = to_milli(obstacle.position_m[axis]);
        row[kObstacle3dSizeXMm + axis] = to_milli(obstacle.size_m[axis]);
      }
      row[kObstacle3dMinHeightMm] = to_milli(obstacle.min_height_m);
      row[kObstacle3dMaxHeightMm] = to_milli(obstacle.max_height_m);
      for (int k = 0; k < 4; ++k) row[kObstacle3dBboxX0 + k] = obstacle.bbox_px[static_cast<size_t>(k)];
    }
    ops += 16ull * static_cast<uint64_t>(stixel_rows) + 16ull * static_cast<uint64_t>(obstacle_rows);
    work.memory_bytes += 4ull * kStixelWords * static_cast<uint64_t>(stixel_rows) + 4ull * kObstacle3dWords * static_cast<uint64_t>(obstacle_rows);
  }
  if (args.work != nullptr) {
    work.scalar_ops += ops;
    work.memory_bytes += 12ull * static_cast<uint64_t>(x_plane.width()) *
                             ((static_cast<uint64_t>(x_plane.height()) + static_cast<uint64_t>(p.sample_step) - 1) / static_cast<uint64_t>(p.sample_step)) +
                         4ull * record_words + 4ull * kStixelWords + 4ull * kObstacle3dWords;
    *args.work += work;
  }
}

ArmTaskDescriptor make_augmented_stixels() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "augmented_stixels";
  descriptor.summary =
      "obstacle candidates above the terrain task's fitted surface, polar occupancy grid, augmented stixels (min and max height above "
      "the terrain) and obstacles";
  descriptor.ports = {{"x", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"y", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"z", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"terrain", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"stixels", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole},
                      {"obstacles", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(augmented_stixels, lpstereo::arm::make_augmented_stixels);
