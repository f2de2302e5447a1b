// Stereo visual odometry after libviso2 (A. Geiger, J. Ziegler, C. Stiller, "StereoScan: Dense 3d
// reconstruction in real-time", IEEE IV 2011; issue 8 item 5) as a small API in libSGM's style: one
// Parameters struct with units, one class, process(left, right) per rectified pair.
//
// Per frame t (docs/odometry.md has the details and the figures):
//   1. features of both views through the graph runtime (graphs/features.json's nodes, built in C++
//      by graph_spec(), run by arm::FrameRunner): fixed-point Harris response, 3x3 non-maximum
//      suppression, the strongest per_cell_k corners of every cell_size_px cell (the bucketing that
//      spreads the features over the image), BRIEF-256 on the 5x5-smoothed view. Positions are refined
//      to sub-pixel by a parabola through the Harris response (3 samples per axis).
//   2. matching in a circle (libviso2): left t -> right t (stereo: same row within
//      epipolar_tolerance_px, disparity in [min_disparity_px, max_disparity_px]) -> right t-1
//      (temporal: within a search radius of where the constant-velocity prediction puts it) -> left
//      t-1 (the stereo match kept from frame t-1) -> left t (temporal, radius); a circle that does not
//      end on the feature it started from is dropped. Every leg is the best Hamming distance with
//      Lowe's ratio test (match_features(): the one function a vector matcher replaces).
//   3. the circle's stereo match at t-1 triangulated (Z = f B / d) and its observations at t (left
//      and right) give the motion: RANSAC over minimal sets of 3 points, each solved by Gauss-Newton
//      on the 6-DoF reprojection error in both images at t, inliers within inlier_threshold_px; then
//      twice Gauss-Newton on all inliers followed by a new selection of the inliers.
//   4. accepted when at least min_inliers inliers remain; otherwise the frame is reported invalid
//      (confidence 0) and the pose is HELD (identity increment, see process()).
//   5. on a valid frame, every circle's own motion (FeatureMotion): its point triangulated at t less
//      its point at t-1 carried by the estimated motion. A static point's is its stereo error; a
//      moving object's is its motion over the frame (the obstacle tracker's evidence, issue 10).
//
// Conventions (DESIGN.md §4): camera frame x right, y down, z forward, metres. The pose of frame t is
// camera-to-first-frame (KITTI's odometry convention, io/kitti_poses.h): X_first = pose * X_t. The
// increment is camera t to camera t-1: pose_t = pose_{t-1} * increment_t.
//
// Threads: the features of both views run on the FrameRunner's workers (worker_threads); matching
// and RANSAC run on the calling thread.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "dag/arm_task.h"
#include "dag/graph.h"
#include "dag/plane.h"

namespace lpstereo::arm {

class FrameRunner;

struct StereoOdometryParameters {
  // The rectified camera (from the calibration, required > 0): the focal length, the principal point
  // of the left view (the right view shares the rows: a rectified pair), the baseline.
  double focal_px = 0.0;
  double principal_point_x_px = 0.0;
  double principal_point_y_px = 0.0;
  double baseline_m = 0.0;

  // Features (kernels/harris_nms.cpp, arm/tasks/select_keypoints.cpp).
  int harris_threshold = 1000;  // harris_nms threshold (harris_response units, window 3)
  int cell_size_px = 32;        // bucketing: the strongest per_cell_k corners of every cell ...
  int per_cell_k = 4;
  int max_keypoints = 4096;     // ... at most this many per view
  int border_px = 16;           // brief256's 31 x 31 patch stays inside the image

  // Matching (every leg: best Hamming distance, accepted when <= max_hamming_distance and below
  // ratio_test times the second best).
  int max_hamming_distance = 80;        // of 256 bits
  double ratio_test = 0.9;              // best < ratio_test * second best (Lowe)
  double epipolar_tolerance_px = 1.5;   // stereo legs: |row_left - row_right| <= this
  double min_disparity_px = 1.0;        // stereo legs: disparity range (positive: in front of the rig)
  double max_disparity_px = 250.0;
  // Temporal legs: a match must lie within this radius of the position the constant-velocity
  // prediction gives (the previous increment applied to the triangulated point) ...
  double predicted_radius_px = 60.0;
  // ... or, without a prediction (first frame pair, after an invalid frame), within this radius of
  // the feature's own position.
  double search_radius_px = 250.0;

  // Motion estimation.
  int ransac_iterations = 200;        // minimal sets of 3 points (libviso2: 200)
  int gauss_newton_iterations = 20;   // per minimal set / refinement (stops earlier when converged)
  double inlier_threshold_px = 2.0;   // reprojection error in the left and the right image at t
  int min_inliers = 12;               // fewer: the frame is invalid (pose held)
  uint32_t ransac_seed = 1;           // deterministic: the same input gives the same trajectory

  // Throws std::invalid_argument "<parameter>: expected ..., got ..." for a value out of range.
  void validate() const;
  // One line with every value, for logs and benchmarks.
  std::string summary() const;
};

struct StereoOdometryStatistics {
  int left_features = 0;          // features of the left view at t
  int right_features = 0;
  int stereo_matches = 0;         // left t <-> right t matches
  int circle_matches = 0;         // closed circles (the motion's observations)
  int inliers = 0;                // RANSAC inliers after refinement
  double reprojection_rms_px = 0; // RMS of the inliers' reprojection errors (left and right), px
  bool predicted = false;         // the temporal legs used the constant-velocity prediction
  bool valid = false;             // the motion was estimated; false: the pose was held
  double confidence = 0;          // inliers / circle matches when valid, else 0
  // The ARM-side work after the feature graph, counted (deterministic, for the chip model):
  int64_t hamming_distances = 0;        // descriptor comparisons of the four legs
  int64_t gauss_newton_point_steps = 0; // one point's residuals and Jacobian rows in one iteration
  int64_t gauss_newton_solves = 0;      // 6x6 normal-equation solves
  int64_t reprojection_tests = 0;       // inlier tests (RANSAC scoring, refinement, RMS)
  int64_t feature_motions = 0;          // circles whose own motion was computed (step 5)
  // ... in ArmWork units (dag/arm_task.h) with the per-item costs of kOdometryWork* below.
  ArmWork work;
};

// The cost model of the counted work (scalar operations, bytes from DRAM-resident buffers), an
// estimate by counting the arithmetic of each step in stereo_odometry.cpp:
//   Hamming distance: 8 XOR + 8 popcount + 8 add = 24 ops; the candidate's 32-byte descriptor read.
//   Gauss-Newton point step: transform 18, two projections 12, Jacobian rows 2 x (2x3 * 3x6 = 72),
//     normal equations and gradient 2 x (2 x 21 + 12) x 2 = 216: about 400 ops; the point's 56 bytes.
//   6x6 LDLT solve and the update's exponential map: about 300 ops.
//   Reprojection (inlier) test: transform 18, two projections 12, two errors 10 = 40 ops; 56 bytes.
//   Feature motion: triangulation 12, transform 18, difference 3 = 33 ops; the point's 56 bytes
//   read, its FeatureMotion's 64 written.
inline constexpr uint64_t kOdometryWorkHammingOps = 24, kOdometryWorkHammingBytes = 32;
inline constexpr uint64_t kOdometryWorkPointStepOps = 400, kOdometryWorkPointBytes = 56;
inline constexpr uint64_t kOdometryWorkSolveOps = 300;
inline constexpr uint64_t kOdometryWorkReprojectionOps = 40;
inline constexpr uint64_t kOdometryWorkFeatureMotionOps = 33, kOdometryWorkFeatureMotionBytes = 120;

// One closed circle of a valid frame seen as a point of the scene (step 5): where it is at t and how
// it moved relative to the static scene over the frame, both in camera t axes (x right, y down, z
// forward, metres). displacement_m = position_m - motion * point_{t-1}, motion the frame's estimate
// (points t-1 -> t): about zero on a static point (its stereo errors at t and at t-1, growing as
// Z^2 sigma_d / (f B) in depth), the object's motion over one frame on a moving one. Rigid motion is
// all it describes: a point that slides along an occluding edge reads as moving.
struct FeatureMotion {
  Eigen::Vector2d left_px = Eigen::Vector2d::Zero();     // the left view at t
  double disparity_px = 0;                               // at t (> 0)
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // triangulated at t
  Eigen::Vector3d displacement_m = Eigen::Vector3d::Zero();
  bool inlier = false;                                   // an inlier of the frame's motion
};

struct StereoOdometryFrame {
  Eigen::Isometry3d increment = Eigen::Isometry3d::Identity();  // camera t -> camera t-1
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();       // camera t -> first frame
  StereoOdometryStatistics statistics;
  // Step 5: one per closed circle on a valid frame after the first; empty otherwise.
  std::vector<FeatureMotion> feature_motions;
};

// One feature of one view: sub-pixel position (px) and its BRIEF-256 descriptor (8 u32 words).
struct OdometryFeature {
  double x_px = 0, y_px = 0;
  uint32_t descriptor[8] = {};
};

// Where a query may find its match: a candidate qualifies when it is inside the window.
struct MatchWindow {
  enum class Kind { epipolar, radius } kind = Kind::radius;
  double epipolar_tolerance_px = 0;               // epipolar: |dy| <= this ...
  double min_disparity_px = 0, max_disparity_px = 0;  // ... and x_query - x_candidate in this range
  double radius_px = 0;                            // radius: within this distance of the centre
};

// The matcher behind every leg: for each query, the index of its best candidate inside its window
// (centre = query position for epipolar windows, centres[i] for radius windows: centres must then
// hold one entry per query, else std::invalid_argument; a non-finite centre finds nothing), or -1 when there is
// none, the distance exceeds max_hamming_distance or the ratio test fails. Candidates are bucketed by
// in 16 px cells so each query only looks at its window. A vector Hamming matcher replaces this one
// function. hamming_distances (optional) gets the number of descriptor comparisons added.
std::vector<int> match_features(const std::vector<OdometryFeature>& queries, const std::vector<Eigen::Vector2d>& centres,
                                const std::vector<OdometryFeature>& candidates, const MatchWindow& window,
                                int max_hamming_distance, double ratio_test, int64_t* hamming_distances = nullptr);

class StereoOdometry {
 public:
  // Builds and verifies the feature graph for width x height views; throws std::invalid_argument for
  // bad parameters (naming the parameter).
  StereoOdometry(int width, int height, const StereoOdometryParameters& parameters, int worker_threads = 2);
  ~StereoOdometry();
  StereoOdometry(const StereoOdometry&) = delete;
  StereoOdometry& operator=(const StereoOdometry&) = delete;

  // The next rectified pair (u8, width x height). The first call gives the identity (frame 0, valid,
  // confidence 1, no matches: it is the reference). A frame
  // whose motion cannot be estimated (too few circle matches or inliers: textureless views, a jump
  // after a dropped frame) does not throw: it reports valid = false, confidence 0, an identity
  // increment (the pose is held, not extrapolated: an outer filter predicts), and becomes the
  // reference for the next frame, which then searches without a prediction.
  StereoOdometryFrame process(const Plane& left, const Plane& right);

  const StereoOdometryParameters& parameters() const { return parameters_; }
  const Eigen::Isometry3d& pose() const { return pose_; }

  // The features graph of both views (inputs "left", "right"; outputs "left_keypoints",
  // "left_descriptors", "right_...").
  static GraphSpec graph_spec(const StereoOdometryParameters& parameters);

 private:
  std::vector<OdometryFeature> extract(const std::string& view) const;

  StereoOdometryParameters parameters_;
  int width_, height_;
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<FrameRunner> runner_;
  // Frame t-1: its features and stereo matches (left index -> right index, -1 none).
  std::vector<OdometryFeature> previous_left_, previous_right_;
  std::vector<int> previous_stereo_;
  bool has_previous_ = false;
  bool has_velocity_ = false;
  Eigen::Isometry3d velocity_ = Eigen::Isometry3d::Identity();  // last valid motion (points t-1 -> t)
  Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
  uint64_t frame_index_ = 0;
};

}  // namespace lpstereo::arm
