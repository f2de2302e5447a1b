// The end-to-end keyframe localizer (issue 8: localization without GPS; thesis 003 chapter 3, §3.5-3.6)
// as a small API in libSGM's style: one Parameters struct with units, one class, process(left, right)
// per rectified pair of the downward-looking stereo camera, one result per frame. docs/localization.md,
// "The localizer", has the chain and the measured homing figures.
//
// Per frame:
//   1. visual odometry (StereoOdometry on the same pair: increment camera t -> camera t-1), converted
//      to the filter's levelled body frame (below) -> LocalizationEkf::predict. An invalid odometry
//      frame (textureless views, a jump) predicts a zero increment with the extra uncertainty
//      lost_frame_translation_sigma_m / lost_frame_yaw_sigma_rad (the motion the drone may have made
//      unseen), so the covariance grows and the confidence drops;
//   2. the localization feature graph (graphs/localization-features.json's nodes, built in C++ by
//      graph_spec(), run by arm::FrameRunner): Harris corners of the left view, BRIEF-256 (sector 0,
//      the view's own orientation), census sparse disparity at the corners, Hamming matches with the
//      previous frame (their count feeds the keyframe rule "few matches with the previous frame");
//   3. validate_features_3d -> the visual height: the median depth Z of the validated points (the
//      camera looks straight down at a level drone: the depth of a ground point is the camera's
//      height) -> LocalizationEkf::update_height, when at least min_height_points points are valid;
//   4. the nearest keyframe by the filter's position (KeyframeDatabase::nearest); the frame's
//      descriptors steered by the yaw sector of (filter yaw - keyframe yaw) (kernels/brief_pattern.h:
//      that is what lets a frame taken after a turn match a keyframe taken before it); matched
//      against the keyframe's (arm/odometry match_features: best Hamming distance, ratio test, over
//      the whole image) -> correct_pose (F-RANSAC, rigid RANSAC) -> KeyframePoseMeasurement ->
//      LocalizationEkf::update_keyframe (gated: a wrong correction is refused, not applied);
//   5. the keyframe decision (KeyframeDatabase::decide with the filter's position, the visual
//      height, the matches with the previous frame) and, when it says so, add() with the filter's
//      pose and the sector-0 descriptors.
// Nothing here throws on data: a frame without features, without odometry or without a correction
// is a result with its reason; only bad parameters or image sizes throw (std::invalid_argument).
//
// Frames (all metres, radians):
//   - camera frame (DESIGN.md §4): x right, y down, z forward (= down, the camera looks at the ground);
//   - body frame (ekf.h): x forward, y left, z up, origin at the LEFT camera's optical centre (the
//     point whose trajectory the KITTI output and io/stereo_flight.h's poses.txt give);
//   - map frame: the filter's; x, y horizontal, z up (height above the take-off ground), yaw about z;
//     the start is (0, 0, start_height_m) with yaw start_yaw_rad.
//   Mounting, body_from_camera: "forward" is the image's right (+x_camera), "left" is the image's top
//   (-y_camera), up is against the viewing direction (-z_camera):
//       R_bc = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]   (columns: the camera axes in the body frame)
//   a rotation of pi about x (det +1). Derivation against io/stereo_flight.h: at yaw psi the flight's
//   camera axes in its ground frame are x_c = (cos psi, sin psi, 0), y_c = (sin psi, -cos psi, 0),
//   z_c = (0, 0, -1); a body at yaw psi has x_b = (cos psi, sin psi, 0), y_b = (-sin psi, cos psi, 0),
//   z_b = (0, 0, 1); so x_c = x_b, y_c = -y_b, z_c = -z_b for every psi: with this mounting the
//   filter's yaw IS the flight's yaw, and the map frame is the flight's ground frame moved to the
//   left camera's start point.
//   Odometry increment: the camera increment T_c = (camera t -> camera t-1) becomes the body increment
//       T_b = R_bc T_c R_bc^-1   (body t -> body t-1; same origin, so only the axes change)
//   whose translation (dx, dy, dz) is the motion in the body frame of step t-1 and whose yaw is
//   atan2(R_b(1, 0), R_b(0, 0)) (the drone is level: R_b is a rotation about z up to noise), exactly
//   the OdometryIncrement of ekf.h. A keyframe's pose is world_from_camera = world_from_body R_bc;
//   a correction's world_from_current (camera) gives the body pose world_from_current R_bc^-1.
//   Yaw sector for the steering: a positive yaw turns the image content clockwise on the screen
//   (io/stereo_flight.h), which is brief256's positive sense (kernels/brief_pattern.h): a frame at
//   yaw psi_f matched against a keyframe at psi_k uses sector round((psi_f - psi_k) / 22.5 deg) mod 16.
//
// Confidence in [0, 1]: exp(-position_sigma_m / confidence_scale_m), position_sigma_m the filter's
// (sqrt of the trace of its position covariance): 1 cm -> 0.90, 10 cm -> 0.37, 30 cm -> 0.05 at the
// default scale; low_confidence when position_sigma_m > low_confidence_sigma_m.
//
// Threads: both feature graphs run on their FrameRunner's workers; the rest on the calling thread.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "arm/localization/ekf.h"
#include "arm/localization/keyframe_database.h"
#include "arm/localization/pose_correction.h"
#include "arm/odometry/stereo_odometry.h"
#include "dag/graph.h"
#include "dag/plane.h"

namespace lpstereo::arm {
class FrameRunner;
}

namespace lpstereo::arm::localization {

struct KeyframeLocalizerParameters {
  // The rectified camera (required > 0): focal length, the left view's principal point, baseline.
  double focal_px = 0.0;
  double principal_point_x_px = 0.0;
  double principal_point_y_px = 0.0;
  double baseline_m = 0.0;

  // The start: the left camera's height above the ground (m, > 0) and the yaw (rad) at frame 0.
  double start_height_m = 0.4;
  double start_yaw_rad = 0.0;

  // What corrects the odometry: false = visual odometry alone (the filter only predicts).
  bool keyframe_corrections = true;
  bool height_updates = true;

  // The localization feature graph (graphs/localization-features.json's nodes and defaults but the
  // cell size: 32 px cells give about 4 x more corners than 64 px, what keyframe matching at 2 m
  // altitude needs for tens of rigid inliers).
  int harris_threshold = 1000;   // harris_nms threshold (harris_response units, window 3)
  int cell_size_px = 32;         // the strongest per_cell_k corners of every cell ...
  int per_cell_k = 4;
  int max_keypoints = 2048;      // ... at most this many
  int num_disparities = 128;     // sparse disparity search [0, num_disparities) px
  int uniqueness_percent = 10;   // sparse disparity uniqueness (0 .. 50)
  int previous_ratio_q8 = 205;   // hamming_match with the previous frame: ratio test (Q8, 0.80)
  int previous_max_distance = 64;  // ... and the largest distance, bits of 256

  // 3D validation (keyframe_database.h): disparity range, px.
  double min_disparity_px = 2.0;
  double max_disparity_px = 127.0;
  int min_height_points = 10;     // fewer validated points: no visual height this frame (>= 1)

  // Keyframe matching (arm/odometry match_features over the whole image).
  int keyframe_max_hamming_distance = 64;  // of 256 bits
  double keyframe_ratio_test = 0.8;        // best < ratio x second best (Lowe)

  // A frame without odometry: the zero increment's extra sigma (the motion the drone may make in one
  // frame unseen: 1 m/s peak over 0.1 s at 10 fps).
  double lost_frame_translation_sigma_m = 0.1;
  double lost_frame_yaw_sigma_rad = 0.1;

  // Reported confidence (header comment).
  double confidence_scale_m = 0.1;     // > 0
  double low_confidence_sigma_m = 0.1; // > 0

  StereoOdometryParameters odometry;        // camera fields are copied from above
  EkfParameters filter;
  KeyframePolicyParameters keyframe_policy;
  PoseCorrectionParameters correction;

  // Throws std::invalid_argument "<parameter>: expected ..., got ..." for a value out of range.
  void validate() const;
  std::string summary() const;
};

struct LocalizerFrame {
  int64_t frame_index = 0;
  // The estimate: the left camera in the map frame, and relative to the first frame's left camera
  // (KITTI's convention, io/kitti_poses.h: X_first = pose * X_t).
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector4d state = Eigen::Vector4d::Zero();      // the filter's x, y, z (m), yaw (rad)
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
  double position_sigma_m = 0;
  double confidence = 0;        // header comment
  bool low_confidence = false;

  // Odometry.
  bool odometry_valid = false;
  int odometry_inliers = 0;
  // Features.
  int keypoints = 0;
  int validated_features = 0;
  int matches_with_previous = -1;  // -1: the first frame
  double visual_height_m = 0;      // 0 when there was none
  bool height_accepted = false;
  // Keyframe correction.
  int keyframe_id = -1;            // the nearest keyframe matched against, -1 none
  int yaw_sector = 0;              // the steering sector used
  int keyframe_matches = 0;        // descriptor matches with it
  int correction_inliers = 0;      // rigid RANSAC inliers
  double correction_confidence = 0;
  bool correction_accepted = false;  // the filter took it
  std::string correction_note;     // why there was no (accepted) correction, empty when accepted
  // Keyframe decision.
  KeyframeDecision keyframe_decision = KeyframeDecision::none;
  int stored_keyframe_id = -1;     // the keyframe made of this frame, -1 none
};

class KeyframeLocalizer {
 public:
  // Builds and verifies both feature graphs for width x height views; throws std::invalid_argument for
  // bad parameters (naming the parameter).
  KeyframeLocalizer(int width, int height, const KeyframeLocalizerParameters& parameters, int worker_threads = 2);
  ~KeyframeLocalizer();
  KeyframeLocalizer(const KeyframeLocalizer&) = delete;
  KeyframeLocalizer& operator=(const KeyframeLocalizer&) = delete;

  // A stored map (a previous flight's database) to localize against; new keyframes are added to it.
  void use_map(KeyframeDatabase map) { database_ = std::move(map); }

  // The next rectified pair (u8, width x height). Throws std::invalid_argument only for planes of
  // another size or format.
  LocalizerFrame process(const Plane& left, const Plane& right);

  const KeyframeDatabase& database() const { return database_; }
  const LocalizationEkf& filter() const { return filter_; }
  const KeyframeLocalizerParameters& parameters() const { return parameters_; }

  // The localization feature graph (inputs "left", "right"; outputs "left_keypoints",
  // "left_descriptors", "left_smoothed", "left_keypoint_disparity", "left_matches_previous").
  static GraphSpec graph_spec(const KeyframeLocalizerParameters& parameters);

  // R_bc of the header comment.
  static Eigen::Isometry3d body_from_camera();

 private:
  struct FrameFeatures;
  FrameFeatures extract() const;
  std::vector<BriefDescriptor> steered_descriptors(int sector) const;
  void correct(const FrameFeatures& features, LocalizerFrame& result);
  Eigen::Isometry3d world_from_body() const;

  KeyframeLocalizerParameters parameters_;
  int width_, height_;
  StereoOdometry odometry_;
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<FrameRunner> runner_;
  LocalizationEkf filter_;
  KeyframeDatabase database_;
  Eigen::Isometry3d first_world_from_camera_ = Eigen::Isometry3d::Identity();
  int64_t frame_index_ = 0;
};

}  // namespace lpstereo::arm::localization
