// Visual-odometry accuracy against ground-truth poses: the KITTI odometry benchmark's metric
// (Geiger, Lenz, Urtasun, "Are we ready for autonomous driving?", CVPR 2012; devkit_odometry,
// evaluate_odometry.cpp), plus end-point error and absolute trajectory error.
//
// Both trajectories are lists of camera-to-first-frame poses (io/kitti_poses.h), one per frame, in
// metres; both start at (or near) the identity, so nothing is aligned.
//
// The KITTI metric (devkit calcSequenceErrors):
//   - distance(i): the ground truth's path length from frame 0 to frame i (sum of the steps between
//     consecutive positions);
//   - for every first frame i = 0, step, 2 step, ... (the devkit: step 10 frames, one second at
//     10 Hz) and every segment length L (the devkit: 100, 200, ..., 800 m), the last frame j is the
//     first frame with distance(j) - distance(i) >= L (no such frame: no segment);
//   - the relative pose error E = (Pe_i^-1 Pe_j)^-1 (Pg_i^-1 Pg_j) (Pe estimate, Pg ground truth);
//   - translation error = |translation of E| / L, rotation error = angle of E / L;
//   - the reported figures are the means over ALL segments of all lengths (devkit saveStats), the
//     translation error in % and the rotation error in deg/m (the KITTI table's units).
//   Two details differ from the devkit, neither of them on measured data: the devkit's test is
//   strictly greater (distance(j) > distance(i) + L), which differs from >= only when a frame lands
//   exactly on the length (evenly spaced synthetic trajectories, where >= makes a segment exactly L
//   long); and the angle is atan2(|axis part|, (trace - 1) / 2) in double precision instead of
//   acos((trace - 1) / 2) in float. acos is steep near 1: pose files printed with 7 digits (KITTI's,
//   the shared kitti_odometry_06) are only nearly orthonormal, which moves the trace, and acos then
//   reads small angles short (0.25 degrees as 0.2497; a yaw drift of 0.05 degrees per frame injected
//   into kitti_odometry_06 as 0.0435 deg/m over all segments instead of 0.0442, while atan2 gives the
//   injected drift exactly at every length, e.g. 0.0500 over the 5-frame segments of 5 m); float adds
//   its own loss (acos(1 - 1e-8) has no float answer).
//
// Short sequences: KITTI's lengths need a path of more than 800 m; the project's sets are short
// (kitti_odometry_06 is 51 frames, 59.9 m). automatic_segment_lengths_m picks the lengths the data
// allows (see there), and the caller may give its own.
//
// End-point error: |t_e(last) - t_g(last)| in metres (and in % of the ground truth's path length).
// ATE: the root mean square over frames of |t_e(i) - t_g(i)|, without alignment.
#pragma once

#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>

namespace lpstereo::io {

// Trajectories that cannot be compared (different numbers of poses, no pose, a path too short for
// every length) or settings that make no sense (a non-positive length or step); what() names the
// expected and the actual value.
class OdometryEvaluationError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct OdometrySettings {
  std::vector<double> segment_lengths_m;  // empty: automatic_segment_lengths_m(ground-truth path)
  int step_frames = 1;                    // first frames 0, step, 2 step, ... (KITTI's devkit: 10)
};

// One sub-sequence [first_frame, last_frame] of nominal length length_m.
struct SegmentError {
  int first_frame = 0;
  int last_frame = 0;
  double length_m = 0;
  double translation_error_m = 0;   // |translation of E|
  double rotation_error_rad = 0;    // angle of E
};

// The means over the segments of one length (NaN when the data holds none of that length).
struct LengthErrors {
  double length_m = 0;
  int segments = 0;
  double translation_error_pct = 0;      // mean of translation_error_m / length_m, x 100
  double rotation_error_deg_per_m = 0;   // mean of rotation_error_rad / length_m, in degrees
};

struct OdometryErrors {
  int frames = 0;
  int step_frames = 0;
  double ground_truth_path_m = 0;        // distance(last frame)
  double estimate_path_m = 0;            // the same sum over the estimate's positions
  std::vector<LengthErrors> per_length;  // in the order of the lengths used
  std::vector<SegmentError> segments;    // every segment, by first frame then length
  double translation_error_pct = 0;      // mean over all segments (KITTI's figure)
  double rotation_error_deg_per_m = 0;   // mean over all segments (KITTI's figure)
  double end_point_error_m = 0;          // |t_e(last) - t_g(last)|
  double end_point_error_pct = 0;        // of ground_truth_path_m (NaN for a path of 0 m)
  double end_rotation_error_deg = 0;     // angle of Pe_last^-1 Pg_last
  double ate_rmse_m = 0;                 // RMS over frames of |t_e(i) - t_g(i)|, no alignment
};

// The KITTI devkit's segment lengths: 100, 200, ..., 800 m.
std::vector<double> kitti_segment_lengths_m();

// The lengths a path of `path_length_m` allows: KITTI's when the path is longer than 800 m (a full
// KITTI sequence evaluates as the devkit does); otherwise multiples of a spacing below the path
// length, the spacing being the multiple of 5 m nearest a tenth of the path (at least 5 m): a 59.9 m
// path gives 5, 10, ..., 55 m; a 400 m path 40, 80, ..., 360 m. Empty below 5 m.
std::vector<double> automatic_segment_lengths_m(double path_length_m);

// distance(i) of the devkit: path length from frame 0 to frame i, metres.
std::vector<double> trajectory_distances_m(const std::vector<Eigen::Isometry3d>& poses);

// The rotation angle of `rotation` in radians, [0, pi], accurate near 0.
double rotation_angle_rad(const Eigen::Matrix3d& rotation);

// Scores `estimate` against `ground_truth`. Throws OdometryEvaluationError when the numbers of
// poses differ, there is no pose, a length or the step is not positive, or no segment of any length
// fits the ground truth's path (the message gives the path length and the longest length tried).
OdometryErrors evaluate_odometry(const std::vector<Eigen::Isometry3d>& estimate,
                                 const std::vector<Eigen::Isometry3d>& ground_truth, const OdometrySettings& settings = {});

}  // namespace lpstereo::io
