// The pose correction from a keyframe (thesis 003 §3.2.4-3.2.5): the descriptor matches between the
// current frame's validated features and the nearest keyframe's, filtered by the fundamental matrix
// in RANSAC (fundamental_ransac.h: image-plane consistency, drops wrong descriptor matches), then the
// rigid alignment of the surviving pairs' 3D points in RANSAC (rigid_alignment.h: 3D consistency,
// drops what the epipolar test lets through, e.g. matches near an epipolar line or on a flat ground
// where F is not unique), then the current camera's pose in the map:
//     keyframe_from_current = (R, t) with p_keyframe = R p_current + t   (eq. 3.2, a = current, b = keyframe)
//     world_from_current    = keyframe.world_from_camera * keyframe_from_current
// which the filter (ekf.h) takes as a measurement.
//
// F-RANSAC failing (fewer than 8 matches, collinear pixels, no consensus) does not stop the
// correction: its failure is reported and the rigid RANSAC runs on all matches (it rejects outliers
// on its own, with a minimal set of 3). The rigid step failing gives ok = false.
//
// Confidence in [0, 1]: (rigid inliers / matches) * min(1, rigid inliers / full_confidence_inliers):
// the share of matches that agree, damped when there are few of them. ok = false when the rigid
// inliers are fewer than min_inliers.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "arm/localization/fundamental_ransac.h"
#include "arm/localization/keyframe_database.h"
#include "arm/localization/rigid_alignment.h"

namespace lpstereo::arm::localization {

struct FeatureMatch {
  int current_index = 0;   // into the current frame's features
  int keyframe_index = 0;  // into the keyframe's features
};

struct PoseCorrectionParameters {
  FundamentalRansacParameters fundamental;  // Sampson threshold in px
  RigidRansacParameters rigid;              // inlier threshold in metres
  int min_inliers = 8;                      // fewer rigid inliers: no correction (>= 3)
  int full_confidence_inliers = 50;         // this many rigid inliers or more: no damping (>= 1)
};

struct PoseCorrection {
  bool ok = false;
  std::string failure;            // one line when !ok
  std::string fundamental_note;   // F-RANSAC's failure when it was skipped, else empty
  Eigen::Isometry3d keyframe_from_current = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d world_from_current = Eigen::Isometry3d::Identity();
  int matches = 0;
  int fundamental_inliers = 0;    // pairs passed to the rigid step
  int rigid_inliers = 0;
  double rms_error_m = 0;
  double confidence = 0;          // header comment
  std::vector<uint8_t> inlier_mask;  // per match: 1 when it survived both steps
};

// Throws std::invalid_argument for a match index outside the feature lists or parameters out of
// range (naming the index or parameter, the expected range and the value).
PoseCorrection correct_pose(const std::vector<KeyframeFeature>& current, const Keyframe& keyframe,
                            const std::vector<FeatureMatch>& matches, const PoseCorrectionParameters& parameters);

}  // namespace lpstereo::arm::localization
