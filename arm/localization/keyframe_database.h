// Keyframes for localization without GPS (thesis 003 §3.2.2, §3.2.3, §3.5): the 3D validation of
// features, the stored keyframes, the heuristics that decide when a frame becomes one, the lookup of
// the nearest keyframe by the filter's position, and the database's binary file.
//
// Frames: a keyframe's points are in its own left-camera frame (x right, y down, z forward, metres;
// DESIGN.md §4); its pose maps that frame into the map frame (world_from_camera, metres), the
// filter's estimate when the keyframe was taken.
//
// 3D validation (thesis §3.2.2): a feature is kept when its disparity is valid (not the matcher's
// invalid marker) and inside [min_disparity_px, max_disparity_px]; its point is
//     Z = f B / d,  X = (u - u0) Z / f,  Y = (v - v0) Z / f      (DESIGN.md §4).
//
// Heuristics (thesis §3.2.3 and §3.5, the three checks added when porting to the chip):
//   - the first keyframe when the height above the ground first reaches first_keyframe_height_m
//     (0.4 m: the stereo pair under the drone sees the take-off pad in focus and overlapping);
//   - a new keyframe when the nearest stored keyframe is farther than new_keyframe_distance_m (2 m:
//     chosen in the thesis so that keyframes share little of the scene, saving memory);
//   - a new keyframe when the matches with the previous frame fall below min_matches_with_previous
//     (the view changed faster than the distance rule notices: a yaw turn, a climb);
//   - no keyframe from a frame with fewer than min_keyframe_features validated features (textureless
//     ground: a keyframe nothing can match later).
//
// File format (little-endian; version 1):
//   header   "LPKF" (4 bytes), version u32, keyframe count u32
//   keyframe id u32, yaw_sector u32 (0 .. 15), pose: 12 f64 (the 3x4 [R | t] row-major, world_from_camera),
//            feature count u32, then per feature: pixel x, y f32 (px), point X, Y, Z f32 (m),
//            descriptor 8 u32 (kernels/brief256.cpp's word order)
//   trailer  CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, the zlib/PNG one) of every byte before it, u32
// Reading checks, in order, each failing with one line naming the file, the expected and the actual
// value: the file opens, is at least header + trailer long, the magic, the version, the checksum,
// then every count against the bytes left (truncation inside a valid checksum cannot happen, but a
// count is never trusted to size an allocation), the yaw sector, and that nothing trails.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kernels/brief_pattern.h"

namespace lpstereo::arm::localization {

using BriefDescriptor = std::array<uint32_t, kernels::kBriefWords>;  // kernels/brief256.cpp, one row

struct KeyframeFeature {
  Eigen::Vector2f pixel_px = Eigen::Vector2f::Zero();  // left image, rectified
  Eigen::Vector3f point_m = Eigen::Vector3f::Zero();   // keyframe's camera frame
  BriefDescriptor descriptor{};
  bool operator==(const KeyframeFeature&) const = default;
};

struct Keyframe {
  uint32_t id = 0;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  int yaw_sector = 0;  // 0 .. kernels::kBriefSectors - 1: the filter's yaw quantised (thesis fig. 3.7)
  std::vector<KeyframeFeature> features;
  Eigen::Vector3d position_m() const { return world_from_camera.translation(); }
};

// --- 3D validation ---------------------------------------------------------------------------

struct StereoGeometry {
  double focal_px = 0;    // rectified focal length, px (> 0)
  double baseline_m = 0;  // > 0
  double u0_px = 0;       // principal point of the rectified left view
  double v0_px = 0;
};

struct FeatureValidationParameters {
  double min_disparity_px = 1.0;    // nearer than f B / min: too far to trust (> 0)
  double max_disparity_px = 256.0;  // >= min_disparity_px
  int16_t invalid_disparity_q4 = -16;  // the matcher's invalid marker, (min_disp - 1) * 16 (DESIGN.md §4)
};

// One feature before validation: its pixel, its sparse disparity (s16 Q4: value / 16 = px) and descriptor.
struct CandidateFeature {
  Eigen::Vector2f pixel_px = Eigen::Vector2f::Zero();
  int16_t disparity_q4 = 0;
  BriefDescriptor descriptor{};
};

// The valid features with their 3D points, in input order. Throws std::invalid_argument for
// geometry or parameters out of range (naming the value).
std::vector<KeyframeFeature> validate_features_3d(const std::vector<CandidateFeature>& candidates,
                                                  const StereoGeometry& geometry,
                                                  const FeatureValidationParameters& parameters);

// --- heuristics -------------------------------------------------------------------------------

struct KeyframePolicyParameters {
  double first_keyframe_height_m = 0.4;  // the first keyframe at this height above the ground (> 0)
  double new_keyframe_distance_m = 2.0;  // nearest stored keyframe farther than this: a new one (> 0)
  int min_matches_with_previous = 30;    // fewer matches with the previous frame: a new one (>= 0)
  int min_keyframe_features = 20;        // a frame with fewer validated features is never stored (>= 0)
};

enum class KeyframeDecision {
  none,                      // keep the stored ones
  first_at_height,           // the database is empty and the height reached first_keyframe_height_m
  far_from_nearest,          // the nearest keyframe is farther than new_keyframe_distance_m
  few_matches_with_previous, // matches with the previous frame below min_matches_with_previous
  too_few_features,          // a rule fired but the frame has too few validated features to store
};
const char* to_string(KeyframeDecision decision);

struct FrameSummary {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // the filter's position, map frame
  double height_above_ground_m = 0;                      // visual height estimate
  std::optional<int> matches_with_previous;              // none on the first frame or after a gap
  int validated_features = 0;
};

// --- the database ----------------------------------------------------------------------------

class KeyframeDatabaseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class KeyframeDatabase {
 public:
  static constexpr uint32_t kFileVersion = 1;

  explicit KeyframeDatabase(const KeyframePolicyParameters& policy = {});

  KeyframeDecision decide(const FrameSummary& frame) const;
  // Stores a keyframe (its id is assigned: the next free one) and returns its id. Throws
  // std::invalid_argument for a yaw sector outside 0 .. 15.
  uint32_t add(Keyframe keyframe);

  // The keyframe nearest to position_m (Euclidean, metres; ties keep the earlier), none when empty.
  // A linear scan: a flight stores tens to hundreds of keyframes (one per 2 m).
  std::optional<size_t> nearest(const Eigen::Vector3d& position_m) const;

  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  size_t size() const { return keyframes_.size(); }
  const KeyframePolicyParameters& policy() const { return policy_; }

  // The file format of the header comment; save writes a temporary file and renames it. Both throw
  // KeyframeDatabaseError with one line naming the file.
  void save(const std::string& path) const;
  static KeyframeDatabase load(const std::string& path, const KeyframePolicyParameters& policy = {});

 private:
  KeyframePolicyParameters policy_;
  std::vector<Keyframe> keyframes_;
  uint32_t next_id_ = 0;
};

// CRC-32 (IEEE, reflected 0xEDB88320, initial and final xor 0xFFFFFFFF): crc32("123456789") = 0xCBF43926.
uint32_t crc32_ieee(const uint8_t* data, size_t size);

}  // namespace lpstereo::arm::localization
