// ARM task "obstacle_feature_validation": thesis 003 §4.2.4, the clusters of the grid validated by
// image features. A cluster with no corner inside its bounding box is a false positive (an untextured
// patch where the disparity is noise, or a road artefact): the matcher had nothing to lock on to.
// Record layouts: arm/tasks/obstacle_record.h (in and out), arm/tasks/keypoint_record.h.
//
// Steps, per frame: for each valid obstacle record (in order), count the valid keypoints (x, y) with
// x0 - margin_px <= x <= x1 + margin_px and y0 - margin_px <= y <= y1 + margin_px (the bounding box,
// inclusive, grown by margin_px: a corner on the object's outline lies on or just outside the box of
// its mask pixels) and, with mask_radius_px >= 0, an obstacle-mask pixel (kMaskObstacle) within
// mask_radius_px of (x, y) (Chebyshev distance): the corner itself must stand on the obstacle, above
// the road. Without that, the corners of painted lane-marking dashes validate the disparity artefact
// SGM leaves above a dash (a few rows at the dash's disparity, vertical and above the road: the
// detector's commonest false positive on the 4K range test; docs/obstacles.md), since a dash's
// corners lie in that box but on road pixels. Write the count into kObstacleFeatures; keep the record when the count >=
// min_features. Kept records are written in their input order from row 0 on (compacted), every word
// but kObstacleFeatures unchanged (the ids too, so a dropped record leaves a gap); the rows after them
// are zero. Both lists end at their first row with valid = 0.
//
// Ports: "obstacles" s32 kObstacleWords x N, "keypoints" s32 kKeypointWords x K, "mask" u8 (the
// vldh_mask output, kernels/obstacle_mask.h); output "validated" s32 kObstacleWords x N.
//
// Near and far: a record nearer than far_distance_m (its kObstacleDistanceMm) needs min_features
// corners, a farther one far_min_features. The clusters' own threshold is permissive near the vehicle
// (Y_min 0.03 m, arm/tasks/obstacle_clusters.cpp) and strict far away, and so are the artefacts that
// pass it: on the 4K range test the SGM artefacts above lane-marking dashes within ~60 m carry one
// corner (the dash's), the small real objects there three and more, while the far objects (a cone
// at 92 m, a bin at 130 m) have one or two (docs/obstacles.md).
//
// Parameters: margin_px (>= 0), min_features (>= 0; 0 keeps every record and only counts),
// far_min_features (>= 0), far_distance_m (> 0),
// mask_radius_px (-1 = the mask is not consulted, 0 .. 8). Defaults: FeatureValidationSettings in
// arm/tasks/obstacle_clusters.h.
//
// Counted work (deterministic, ArmWork), with O valid obstacle records, V valid keypoints, N rows:
//   scalar_ops   = O (6 + 6 V) (per record the grown box; per keypoint two loads, four compares, an
//                  add) + 2 (2 r + 1)^2 per keypoint inside a box when mask_radius_px = r >= 0 (a load
//                  and a compare per mask pixel looked at) + V + 1 (the keypoint list's end) +
//                  kObstacleWords per kept record (the copy);
//   memory_bytes = 4 kKeypointWords V + 2 * 4 kObstacleWords N (records read and written) + (2 r + 1)^2
//                  per keypoint inside a box (mask bytes).
#include <algorithm>
#include <cstring>
#include <string>

#include "arm/tasks/keypoint_record.h"
#include "arm/tasks/obstacle_clusters.h"
#include "arm/tasks/obstacle_record.h"
#include "dag/arm_task.h"
#include "kernels/obstacle_mask.h"

namespace lpstereo::arm {

namespace {

struct FeatureValidationParams {
  int margin_px = 0;
  int min_features = 0;
  int far_min_features = 0;
  double far_distance_m = 0;
  int mask_radius_px = -1;
};

PreparedKernel prepare(const nlohmann::json& params, const std::vector<PlaneShape>& input_shapes) {
  check_param_names(params, {"margin_px", "min_features", "far_min_features", "far_distance_m", "mask_radius_px"});
  if (input_shapes.size() != 3) {
    throw KernelError("inputs: expected 3 (obstacles, keypoints, mask), got " + std::to_string(input_shapes.size()));
  }
  const FeatureValidationSettings defaults;
  auto prepared = std::make_shared<FeatureValidationParams>();
  prepared->margin_px = param_int(params, "margin_px", defaults.margin_px, 0, 1 << 20);
  prepared->min_features = param_int(params, "min_features", defaults.min_features, 0, 1 << 30);
  prepared->far_min_features = param_int(params, "far_min_features", defaults.far_min_features, 0, 1 << 30);
  prepared->far_distance_m = param_double(params, "far_distance_m", defaults.far_distance_m, 1e-3, 1e6);
  prepared->mask_radius_px = param_int(params, "mask_radius_px", defaults.mask_radius_px, -1, 8);
  const PlaneShape& obstacles = input_shapes[0];
  const PlaneShape& keypoints = input_shapes[1];
  if (obstacles.width != kObstacleWords) {
    throw KernelError("input 'obstacles': expected " + std::to_string(int(kObstacleWords)) + " words per record, got " +
                      std::to_string(obstacles.width));
  }
  if (keypoints.width != kKeypointWords) {
    throw KernelError("input 'keypoints': expected " + std::to_string(int(kKeypointWords)) + " words per keypoint, got " +
                      std::to_string(keypoints.width));
  }
  return PreparedKernel{prepared, {obstacles}};
}

void run(const ArmTaskArgs& args) {
  const auto& p = *static_cast<const FeatureValidationParams*>(args.params);
  const Plane& obstacles = *args.inputs.at(0);
  const Plane& keypoints = *args.inputs.at(1);
  const Plane& mask = *args.inputs.at(2);
  Plane& output = *args.outputs.at(0);
  uint64_t mask_bytes = 0;
  // True when an obstacle-mask pixel lies within mask_radius_px of (x, y) (or the mask is not used).
  auto on_obstacle = [&](int32_t x, int32_t y) {
    if (p.mask_radius_px < 0) return true;
    const int r = p.mask_radius_px;
    mask_bytes += static_cast<uint64_t>((2 * r + 1) * (2 * r + 1));
    for (int dy = -r; dy <= r; ++dy) {
      for (int dx = -r; dx <= r; ++dx) {
        const int64_t mx = int64_t{x} + dx, my = int64_t{y} + dy;
        if (mx < 0 || my < 0 || mx >= mask.width() || my >= mask.height()) continue;
        if (mask.row<const uint8_t>(static_cast<int>(my))[mx] == kernels::kMaskObstacle) return true;
      }
    }
    return false;
  };
  uint64_t ops = 1;
  int keypoint_count = 0;
  while (keypoint_count < keypoints.height() && keypoints.row<const int32_t>(keypoint_count)[kKeypointValid] != 0) {
    ++keypoint_count;
  }
  ops += static_cast<uint64_t>(keypoint_count);
  int written = 0;
  for (int row = 0; row < obstacles.height(); ++row) {
    const int32_t* record = obstacles.row<const int32_t>(row);
    if (record[kObstacleValid] == 0) break;
    const int64_t x0 = int64_t{record[kObstacleX0]} - p.margin_px, x1 = int64_t{record[kObstacleX1]} + p.margin_px;
    const int64_t y0 = int64_t{record[kObstacleY0]} - p.margin_px, y1 = int64_t{record[kObstacleY1]} + p.margin_px;
    int features = 0;
    for (int k = 0; k < keypoint_count; ++k) {
      const int32_t* keypoint = keypoints.row<const int32_t>(k);
      const int32_t x = keypoint[kKeypointXPx], y = keypoint[kKeypointYPx];
      if (x >= x0 && x <= x1 && y >= y0 && y <= y1 && on_obstacle(x, y)) ++features;
    }
    ops += 6ull + 6ull * keypoint_count;
    const bool far = record[kObstacleDistanceMm] >= p.far_distance_m * 1000.0;
    if (features < (far ? p.far_min_features : p.min_features)) continue;
    int32_t* out = output.row<int32_t>(written++);
    std::memcpy(out, record, sizeof(int32_t) * kObstacleWords);
    out[kObstacleFeatures] = features;
    ops += kObstacleWords;
  }
  for (int row = written; row < output.height(); ++row) {
    int32_t* out = output.row<int32_t>(row);
    std::fill(out, out + kObstacleWords, 0);
  }
  if (args.work != nullptr) {
    args.work->scalar_ops += ops;
    args.work->scalar_ops += 2 * mask_bytes;
    args.work->memory_bytes += 4ull * kKeypointWords * keypoint_count + 2ull * 4 * kObstacleWords * obstacles.height() + mask_bytes;
  }
}

ArmTaskDescriptor make_obstacle_feature_validation() {
  ArmTaskDescriptor descriptor;
  descriptor.name = "obstacle_feature_validation";
  descriptor.summary = "counts the keypoints inside each obstacle's grown bounding box, drops obstacles with fewer than min_features";
  descriptor.ports = {{"obstacles", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"keypoints", PortDirection::input, {ElementType::s32, 0}, PortAccess::whole},
                      {"mask", PortDirection::input, {ElementType::u8, 0}, PortAccess::whole},
                      {"validated", PortDirection::output, {ElementType::s32, 0}, PortAccess::whole}};
  descriptor.prepare = prepare;
  descriptor.run = run;
  return descriptor;
}

}  // namespace
}  // namespace lpstereo::arm

LPSTEREO_REGISTER_ARM_TASK(obstacle_feature_validation, lpstereo::arm::make_obstacle_feature_validation);
