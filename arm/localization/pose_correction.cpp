// Steps and sources: pose_correction.h.
#include "arm/localization/pose_correction.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace lpstereo::arm::localization {

PoseCorrection correct_pose(const std::vector<KeyframeFeature>& current, const Keyframe& keyframe,
                            const std::vector<FeatureMatch>& matches, const PoseCorrectionParameters& parameters) {
  if (parameters.min_inliers < 3) {
    throw std::invalid_argument("pose correction parameter min_inliers: expected >= 3, got " + std::to_string(parameters.min_inliers));
  }
  if (parameters.full_confidence_inliers < 1) {
    throw std::invalid_argument("pose correction parameter full_confidence_inliers: expected >= 1, got " +
                                std::to_string(parameters.full_confidence_inliers));
  }
  for (size_t m = 0; m < matches.size(); ++m) {
    const FeatureMatch& match = matches[m];
    if (match.current_index < 0 || static_cast<size_t>(match.current_index) >= current.size()) {
      throw std::invalid_argument("pose correction: match " + std::to_string(m) + " current_index expected 0 .. " +
                                  std::to_string(static_cast<long>(current.size()) - 1) + ", got " + std::to_string(match.current_index));
    }
    if (match.keyframe_index < 0 || static_cast<size_t>(match.keyframe_index) >= keyframe.features.size()) {
      throw std::invalid_argument("pose correction: match " + std::to_string(m) + " keyframe_index expected 0 .. " +
                                  std::to_string(static_cast<long>(keyframe.features.size()) - 1) + ", got " +
                                  std::to_string(match.keyframe_index));
    }
  }
  PoseCorrection result;
  result.matches = static_cast<int>(matches.size());
  result.inlier_mask.assign(matches.size(), 0);

  // 1. F-RANSAC on the pixels (view 1 = current, view 2 = keyframe).
  std::vector<Eigen::Vector2d> current_px, keyframe_px;
  for (const FeatureMatch& match : matches) {
    current_px.push_back(current[static_cast<size_t>(match.current_index)].pixel_px.cast<double>());
    keyframe_px.push_back(keyframe.features[static_cast<size_t>(match.keyframe_index)].pixel_px.cast<double>());
  }
  std::vector<int> survivors;  // indices into matches
  if (static_cast<int>(matches.size()) >= parameters.fundamental.min_inliers) {
    const FundamentalRansacResult epipolar = fundamental_ransac(current_px, keyframe_px, parameters.fundamental);
    if (epipolar.ok) {
      for (size_t m = 0; m < matches.size(); ++m) {
        if (epipolar.inlier_mask[m]) survivors.push_back(static_cast<int>(m));
      }
    } else {
      result.fundamental_note = epipolar.failure;
    }
  } else {
    result.fundamental_note = "fundamental RANSAC skipped: " + std::to_string(matches.size()) + " matches, fewer than min_inliers = " +
                              std::to_string(parameters.fundamental.min_inliers);
  }
  if (!result.fundamental_note.empty()) {
    for (size_t m = 0; m < matches.size(); ++m) survivors.push_back(static_cast<int>(m));
  }
  result.fundamental_inliers = static_cast<int>(survivors.size());

  // 2. Rigid RANSAC on the survivors' 3D points (a = current, b = keyframe).
  std::vector<Eigen::Vector3d> current_m, keyframe_m;
  for (const int m : survivors) {
    current_m.push_back(current[static_cast<size_t>(matches[static_cast<size_t>(m)].current_index)].point_m.cast<double>());
    keyframe_m.push_back(keyframe.features[static_cast<size_t>(matches[static_cast<size_t>(m)].keyframe_index)].point_m.cast<double>());
  }
  RigidRansacParameters rigid_parameters = parameters.rigid;
  rigid_parameters.min_inliers = std::max(rigid_parameters.min_inliers, parameters.min_inliers);
  if (static_cast<int>(survivors.size()) < rigid_parameters.min_inliers) {
    result.failure = "pose correction: " + std::to_string(survivors.size()) + " matches left after the epipolar test, expected at least " +
                     std::to_string(rigid_parameters.min_inliers);
    return result;
  }
  const RigidRansacResult rigid = align_rigid_ransac(current_m, keyframe_m, rigid_parameters);
  if (!rigid.ok) {
    result.failure = "pose correction: " + rigid.failure;
    return result;
  }
  for (size_t s = 0; s < survivors.size(); ++s) {
    if (rigid.inlier_mask[s]) result.inlier_mask[static_cast<size_t>(survivors[s])] = 1;
  }
  result.rigid_inliers = rigid.inlier_count;
  result.rms_error_m = rigid.rms_error_m;
  result.keyframe_from_current = rigid.target_from_source;
  result.world_from_current = keyframe.world_from_camera * rigid.target_from_source;
  result.confidence = static_cast<double>(rigid.inlier_count) / static_cast<double>(matches.size()) *
                      std::min(1.0, static_cast<double>(rigid.inlier_count) / parameters.full_confidence_inliers);
  result.ok = true;
  return result;
}

}  // namespace lpstereo::arm::localization
