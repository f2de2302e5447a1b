// Relocalization (issue 8 item 4; thesis 003 §3.5): finding the camera's pose in the keyframe map
// when the filter cannot say where to look.
//
// (a) From a known start point with unknown yaw (relocalize_sectors): the current frame's features
//     described with each of the 16 steered BRIEF patterns (kernels/brief_pattern.h, one per 22.5
//     degree yaw sector), each sector's descriptors matched to the keyframe (match_features of
//     arm/odometry/stereo_odometry.h over the whole image: best Hamming distance, Lowe's ratio test),
//     each set of matches through correct_pose (pose_correction.h: F-RANSAC then rigid RANSAC); the
//     sector with the most rigid inliers wins (ties: the lower sector). The pose corrections run in
//     decreasing order of matches and a sector with fewer matches than the best inliers so far is
//     skipped (it cannot win: inliers <= matches), which leaves the result unchanged and saves the
//     RANSAC runs of the sectors that only collect chance matches. The thesis chose the sector
//     from the filter's yaw; after a reset the yaw is unknown, so all 16 are tried.
//     Sector meaning (brief256.cpp): a keyframe described with sector k's pattern matches a current
//     image rotated by (s - k) x 22.5 degrees (positive from image +x towards +y, clockwise on the
//     screen) when the current frame uses sector s. For the downward camera of io/stereo_flight.h a
//     drone yaw of +psi (counter-clockwise seen from above) rotates the image by +psi in that sense, so
//     the sector gives the yaw change since the keyframe to within half a sector (11.25 degrees); the
//     pose correction's rotation gives it exactly (measured_image_rotation_rad: the rotation of the
//     current image relative to the keyframe's, atan2(R(0,1), R(0,0)) of keyframe_from_current, which
//     is the rotation about the optical axis of a level downward camera).
// (b) Anywhere (relocalize_anywhere): the vocabulary tree (vocabulary_tree.h) proposes the top_n
//     keyframes for the current descriptors, each is checked by matching and correct_pose, the one
//     with the most rigid inliers wins.
//
// Features (SteeredFeatureExtractor): the chain of graphs/localization-features.json through the
// graph runtime (harris_response 3x3, harris_nms, select_keypoints, gaussian5x5) followed by 16
// brief256 nodes, one per yaw_sector, on the smoothed view and the same keypoint list.
//
// Time is the benchmark's business (bench/relocalization_bench.cpp), never the tests'.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "arm/localization/keyframe_database.h"
#include "arm/localization/pose_correction.h"
#include "arm/localization/vocabulary_tree.h"
#include "dag/graph.h"
#include "dag/plane.h"

namespace lpstereo::arm {
class FrameRunner;
}

namespace lpstereo::arm::localization {

using SectorDescriptors = std::array<std::vector<BriefDescriptor>, kernels::kBriefSectors>;

struct SteeredFeatureParameters {
  int harris_threshold = 1000;  // harris_nms threshold (harris_response units, window 3)
  int cell_size_px = 32;        // the strongest per_cell_k corners of every cell ...
  int per_cell_k = 2;
  int max_keypoints = 1024;     // ... at most this many
  int border_px = 16;           // brief256's 31 x 31 patch stays inside the image
};

// The keypoints of one frame and their descriptors in every sector (row i of each sector's list is
// keypoint i).
struct SteeredFeatures {
  std::vector<Eigen::Vector2f> pixels_px;
  SectorDescriptors descriptors;
};

class SteeredFeatureExtractor {
 public:
  // Builds and verifies the graph for width x height u8 frames; throws std::invalid_argument (bad
  // parameters) or the graph layer's errors.
  SteeredFeatureExtractor(int width, int height, const SteeredFeatureParameters& parameters, int worker_threads = 1);
  ~SteeredFeatureExtractor();
  SteeredFeatureExtractor(const SteeredFeatureExtractor&) = delete;
  SteeredFeatureExtractor& operator=(const SteeredFeatureExtractor&) = delete;

  SteeredFeatures extract(const Plane& image_u8);
  static GraphSpec graph_spec(const SteeredFeatureParameters& parameters);

 private:
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<FrameRunner> runner_;
};

struct RelocalizationParameters {
  int max_hamming_distance = 80;  // a match's best distance, of 256 bits
  double ratio_test = 0.8;        // best < ratio_test x second best (Lowe)
  PoseCorrectionParameters pose;  // F-RANSAC and rigid RANSAC
  int top_n = 5;                  // relocalize_anywhere: vocabulary candidates checked (>= 1)
};

// The matches of current descriptors against a keyframe's features (match_features, whole image).
std::vector<FeatureMatch> match_to_keyframe(const std::vector<Eigen::Vector2f>& current_pixels_px,
                                            const std::vector<BriefDescriptor>& current_descriptors, const Keyframe& keyframe,
                                            const RelocalizationParameters& parameters);

struct SectorTrial {
  int matches = 0;
  bool checked = false;   // the pose correction ran (skipped: fewer matches than the winner's inliers)
  int rigid_inliers = 0;  // 0 when the pose correction failed or did not run
};

struct SectorRelocalization {
  bool ok = false;
  std::string failure;  // one line when !ok
  int sector = -1;      // the current frame's winning sector
  double sector_image_rotation_rad = 0;    // (sector - keyframe.yaw_sector) x 22.5 degrees, in [0, 2 pi)
  double measured_image_rotation_rad = 0;  // from the pose correction, in (-pi, pi]
  PoseCorrection correction;               // of the winning sector
  std::array<SectorTrial, kernels::kBriefSectors> trials{};
};

// current: the current frame's validated features (pixel and point; their descriptors are not
// used), descriptors: per sector, one row per current feature. Throws std::invalid_argument when a
// sector's list is not the length of current. No features or no consensus: ok = false, no throw.
SectorRelocalization relocalize_sectors(const std::vector<KeyframeFeature>& current, const SectorDescriptors& descriptors,
                                        const Keyframe& keyframe, const RelocalizationParameters& parameters);

struct AnywhereCandidate {
  size_t keyframe_index = 0;  // into the keyframe list
  double score = 0;           // vocabulary score
  int matches = 0;
  int rigid_inliers = 0;
};

struct AnywhereRelocalization {
  bool ok = false;
  std::string failure;
  size_t keyframe_index = 0;
  PoseCorrection correction;
  std::vector<AnywhereCandidate> candidates;  // in vocabulary order
};

// keyframes[i] must be the keyframe added i-th to index; current's descriptors are those of the
// sector the caller assumes (with no yaw at all, run it per sector). Throws std::invalid_argument when
// the index and the keyframe list differ in size or top_n < 1.
AnywhereRelocalization relocalize_anywhere(const std::vector<KeyframeFeature>& current, const std::vector<Keyframe>& keyframes,
                                           const BowDatabase& index, const RelocalizationParameters& parameters);

}  // namespace lpstereo::arm::localization
