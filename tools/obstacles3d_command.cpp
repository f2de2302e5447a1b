#include "tools/obstacles3d_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arm/disparity_engine.h"
#include "arm/obstacles3d/augmented_stixels.h"
#include "arm/obstacles3d/disparity_coverage.h"
#include "arm/obstacles3d/ego_motion.h"
#include "arm/obstacles3d/obstacle_candidates.h"
#include "arm/obstacles3d/obstacle_tracking.h"
#include "arm/obstacles3d/occupancy_grid.h"
#include "arm/obstacles3d/voxel_clustering.h"
#include "arm/obstacles3d/voxel_map.h"
#include "arm/odometry/stereo_odometry.h"
#include "arm/point_cloud.h"
#include "arm/terrain/terrain_model.h"
#include "arm/terrain_points.h"
#include "dag/atomic_file.h"
#include "io/camera/file_source.h"
#include "io/image_io.h"
#include "io/obstacles3d_pictures.h"
#include "io/rectification.h"
#include "kernels/disparity_to_points.h"
#include "tools/command_error.h"
#include "tools/frame_sequence.h"
#include "tools/obstacles_command.h"
#include "tools/rectified_pair.h"

namespace lpstereo::tools {

namespace {

namespace o3 = arm::obstacles3d;

constexpr double kVoxelMinM = 0.05, kVoxelMaxM = 0.5;  // VoxelMapParameters' range (issue 10)

nlohmann::json vector_json(const Eigen::Vector3d& value) { return nlohmann::json{value.x(), value.y(), value.z()}; }

nlohmann::json obstacle3d_json(const o3::Obstacle3d& obstacle) {
  return {{"id", obstacle.id},
          {"track_id", obstacle.track_id},
          {"bbox_px", nlohmann::json{obstacle.bbox_px[0], obstacle.bbox_px[1], obstacle.bbox_px[2], obstacle.bbox_px[3]}},
          {"position_m", vector_json(obstacle.position_m)},
          {"size_m", vector_json(obstacle.size_m)},
          {"min_height_m", obstacle.min_height_m},
          {"max_height_m", obstacle.max_height_m},
          {"velocity_mps", vector_json(obstacle.velocity_mps)},
          {"moving", obstacle.moving}};
}

std::string obstacle_label(const o3::Obstacle3d& obstacle) {
  char text[48];
  if (obstacle.track_id >= 0) {
    std::snprintf(text, sizeof text, "t%d %.1f m", obstacle.track_id, obstacle.position_m.z());
  } else {
    std::snprintf(text, sizeof text, "#%d %.1f m", obstacle.id, obstacle.position_m.z());
  }
  return text;
}

// Metric top view of the camera's horizontal plane: x (right) -12..12 m to the right, z (forward)
// 0..36 m up, 16 px per metre, 5 m grid lines; each obstacle's footprint (x +- w/2, z +- l/2) in the
// colour of its distance, its label, and its ground velocity as an arrow to where it is in 1 s
// (thicker when moving).
cv::Mat top_view(const std::vector<o3::Obstacle3d>& obstacles) {
  constexpr double kHalfWidthM = 12, kDepthM = 36, kScale = 16;
  cv::Mat picture(static_cast<int>(kDepthM * kScale), static_cast<int>(2 * kHalfWidthM * kScale), CV_8UC3, cv::Scalar(30, 30, 30));
  const auto pixel = [&](double x_m, double z_m) {
    return cv::Point(static_cast<int>(std::lround((x_m + kHalfWidthM) * kScale)), static_cast<int>(std::lround((kDepthM - z_m) * kScale)));
  };
  for (int metres = 5; metres < kDepthM; metres += 5) {
    cv::line(picture, pixel(-kHalfWidthM, metres), pixel(kHalfWidthM, metres), cv::Scalar(70, 70, 70), 1);
  }
  for (int metres = -10; metres <= 10; metres += 5) {
    cv::line(picture, pixel(metres, 0), pixel(metres, kDepthM), cv::Scalar(70, 70, 70), 1);
  }
  cv::circle(picture, pixel(0, 0), 5, cv::Scalar(255, 255, 255), cv::FILLED);  // the camera
  for (const o3::Obstacle3d& obstacle : obstacles) {
    const double x = obstacle.position_m.x(), z = obstacle.position_m.z();
    const cv::Scalar colour = io::distance_colour(z, 40.0);
    const double half_w = std::max(0.1, obstacle.size_m.x() / 2), half_l = std::max(0.1, obstacle.size_m.z() / 2);
    cv::rectangle(picture, pixel(x - half_w, z + half_l), pixel(x + half_w, z - half_l), colour, cv::FILLED);
    cv::putText(picture, obstacle_label(obstacle), pixel(x + half_w, z + half_l) + cv::Point(3, 0), cv::FONT_HERSHEY_SIMPLEX, 0.35,
                colour, 1, cv::LINE_AA);
    const Eigen::Vector3d& velocity = obstacle.velocity_mps;
    if (std::hypot(velocity.x(), velocity.z()) > 0.05) {
      cv::arrowedLine(picture, pixel(x, z), pixel(x + velocity.x(), z + velocity.z()), cv::Scalar(255, 255, 255), obstacle.moving ? 2 : 1,
                      cv::LINE_AA, 0, 0.2);
    }
  }
  return picture;
}

// The left image with each obstacle's pixel box, label and ground velocity projected over 1 s.
cv::Mat image_overlay(const cv::Mat& bgr, const std::vector<o3::Obstacle3d>& obstacles, const io::RectifiedGeometry& geometry) {
  cv::Mat picture = bgr.clone();
  const auto project = [&](const Eigen::Vector3d& p) {
    return cv::Point(static_cast<int>(std::lround(geometry.focal_px * p.x() / p.z() + geometry.cx_left_px)),
                     static_cast<int>(std::lround(geometry.focal_px * p.y() / p.z() + geometry.cy_px)));
  };
  for (const o3::Obstacle3d& obstacle : obstacles) {
    const cv::Scalar colour = io::distance_colour(obstacle.position_m.z(), 40.0);
    const cv::Point top_left(obstacle.bbox_px[0], obstacle.bbox_px[1]);
    cv::rectangle(picture, top_left, cv::Point(obstacle.bbox_px[2], obstacle.bbox_px[3]), colour, 1);
    cv::putText(picture, obstacle_label(obstacle), top_left + cv::Point(0, -3), cv::FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv::LINE_AA);
    const Eigen::Vector3d ahead = obstacle.position_m + obstacle.velocity_mps;
    if (obstacle.velocity_mps.norm() > 0.05 && obstacle.position_m.z() > 0.1 && ahead.z() > 0.1) {
      cv::arrowedLine(picture, project(obstacle.position_m), project(ahead), colour, obstacle.moving ? 2 : 1, cv::LINE_AA, 0, 0.2);
    }
  }
  return picture;
}

std::string view_file(const std::string& directory, const char* kind, int frame) {
  char name[48];
  std::snprintf(name, sizeof name, "/%s_%06d.png", kind, frame);
  return directory + name;
}

o3::GridKind grid_kind_of(const std::string& method) {
  if (method == "cartesian") return o3::GridKind::cartesian;
  if (method == "coldisp") return o3::GridKind::column_disparity;
  return o3::GridKind::polar;  // polar and stixels
}

}  // namespace

Obstacles3dCommand::Obstacles3dCommand(CLI::App& app) {
  command_ = app.add_subcommand("obstacles3d",
                                "3D obstacles over a rectified sequence: disparity, terrain fit (its outliers are the candidates), "
                                "visual odometry (ego-motion), then an occupancy grid, augmented stixels or the tracked voxel map; "
                                "one JSON line per frame (docs/obstacles3d.md)");
  command_->add_option("--left", left_pattern_, "the left frames, a printf pattern such as 'dir/%06d.png'")->required();
  command_->add_option("--right", right_pattern_, "the right frames, a pattern like --left")->required();
  command_->add_option("--calib", calibration_files_,
                       "calibration file, or two; its rectified geometry gives focal length, principal point and baseline")
      ->required();
  command_->add_option("-o,--output", output_, "tracks to write: JSON lines, one per input frame")->required();
  command_->add_option("--method", method_, "polar, cartesian, coldisp (occupancy grids), stixels (augmented stixels) or voxels "
                                            "(voxel map, colour clustering, Kalman tracking)")
      ->capture_default_str();
  command_->add_option("--view", view_directory_, "also write per frame top_NNNNNN.png, overlay_NNNNNN.png (and grid_NNNNNN.png) here");
  command_->add_option("--first", first_frame_, "the first frame's number")->capture_default_str()->check(CLI::NonNegativeNumber);
  command_->add_option("--frames", frame_limit_, "at most this many frames (0 = until the first missing file)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--fps", fps_, "frames per second (the tracker's frame period is 1 / fps)")->capture_default_str();
  command_->add_option("--voxel-m", voxel_m_, "voxels: voxel edge, m, in [0.05, 0.5]")->capture_default_str();
  command_->add_option("--acceptance-frames", acceptance_frames_, "voxels: associated frames before a track is reported")
      ->capture_default_str();
  command_->add_option("--obstacle-height-m", obstacle_height_m_, "a point this far above the fitted terrain is an obstacle candidate, m")
      ->capture_default_str();
  command_->add_option("--threads", threads_, "worker threads (0 = one per hardware thread)")->capture_default_str()->check(CLI::Range(0, 256));
  add_camera_mount_options(*command_, mount_options_);
  add_disparity_engine_options(*command_, engine_options_, "disparities searched: [min-disp, min-disp + num-disp) (default 64; 128 with --multires on "
                               "--multires-far 64: surfaces 1.3-2.6 m ahead measured at half resolution)");
}

int Obstacles3dCommand::run() const {
  // Arguments first: a bad one never costs a file read.
  static const std::set<std::string> methods{"polar", "cartesian", "coldisp", "stixels", "voxels"};
  if (methods.count(method_) == 0) {
    throw CommandError(kExitUsage, "--method: expected polar, cartesian, coldisp, stixels or voxels, got '" + method_ + "'");
  }
  if (!(voxel_m_ >= kVoxelMinM && voxel_m_ <= kVoxelMaxM)) {
    throw CommandError(kExitUsage, "--voxel-m: expected a voxel edge in [0.05, 0.5] m, got " + std::to_string(voxel_m_));
  }
  if (!(fps_ > 0 && fps_ <= 10000)) throw CommandError(kExitUsage, "--fps: expected a rate in (0, 10000], got " + std::to_string(fps_));
  if (!(obstacle_height_m_ > 0 && obstacle_height_m_ < 10)) {
    throw CommandError(kExitUsage, "--obstacle-height-m: expected a height in (0, 10) m, got " + std::to_string(obstacle_height_m_));
  }
  const arm::CameraMount mount = camera_mount_from(mount_options_);
  check_frame_patterns(left_pattern_, right_pattern_);

  // A SourceError (no first frame, a size change, an unreadable file) ends the command with its line, exit 1.
  const auto source = std::make_unique<io::ImageSequenceSource>(left_pattern_, right_pattern_, io::SourceOptions{}, first_frame_,
                                                                frame_limit_);
  const int frame_count = source->frame_count();
  const int width = source->width(), height = source->height();
  const io::RectifiedGeometry geometry = rectified_geometry(calibration_files_, width, height);
  check_obstacle_geometry(geometry, calibration_files_);

  const arm::DisparityParameters disparity_parameters =
      tools::disparity_parameters(engine_options_, width, arm::obstacles3d::obstacles3d_disparity_defaults().num_disparities);
  arm::DisparityEngine engine(width, height, disparity_parameters, {}, threads_);
  const arm::TriangulationParameters triangulation =
      triangulation_parameters(geometry, disparity_parameters.min_disparity, disparity_parameters.num_disparities);
  o3::CandidateParameters candidate_parameters;
  candidate_parameters.obstacle_height_m = obstacle_height_m_;
  candidate_parameters.threads = threads_ == 0 ? static_cast<int>(std::max(1u, std::thread::hardware_concurrency())) : threads_;

  arm::StereoOdometryParameters odometry_parameters;
  odometry_parameters.focal_px = geometry.focal_px;
  odometry_parameters.principal_point_x_px = geometry.cx_left_px;
  odometry_parameters.principal_point_y_px = geometry.cy_px;
  odometry_parameters.baseline_m = geometry.baseline_m;
  arm::StereoOdometry odometry(width, height, odometry_parameters, threads_ == 0 ? 2 : threads_);

  o3::StereoErrorModel error_model;
  error_model.focal_px = geometry.focal_px;
  error_model.baseline_m = geometry.baseline_m;
  // The method's state, built for a mount: once with the given (or default) one, which checks the
  // parameters before any frame is read, and again when the mount is estimated from a frame.
  struct Method {
    std::unique_ptr<arm::CameraToVehicle> to_vehicle;
    std::unique_ptr<o3::OccupancyGrid> grid;
    std::unique_ptr<o3::AugmentedStixels> stixels;
    std::unique_ptr<o3::VoxelMap> voxel_map;
    std::unique_ptr<o3::ObstacleTracker3d> tracker;
    o3::VoxelClusteringParameters clustering;
  };
  const auto build_method = [&](const arm::CameraMount& for_mount) {
    Method built;
    built.to_vehicle = std::make_unique<arm::CameraToVehicle>(for_mount);
    try {
      o3::OccupancyGridParameters grid_parameters = o3::OccupancyGridParameters::defaults(grid_kind_of(method_), width);
      grid_parameters.error_model = error_model;
      grid_parameters.principal_u_px = geometry.cx_left_px;
      grid_parameters.vehicle_from_camera = built.to_vehicle->vehicle_from_camera();
      if (method_ == "stixels") {
        o3::AugmentedStixelParameters stixel_parameters;
        stixel_parameters.grid = grid_parameters;
        built.stixels = std::make_unique<o3::AugmentedStixels>(stixel_parameters);
      } else if (method_ == "voxels") {
        o3::VoxelMapParameters map_parameters;
        map_parameters.voxel_size_m = voxel_m_;
        map_parameters.view_half_angle_rad = std::atan2(width / 2.0, geometry.focal_px);
        built.voxel_map = std::make_unique<o3::VoxelMap>(map_parameters);
        built.clustering.image_width_px = width;
        built.clustering.image_height_px = height;
        // The candidates end with the terrain area (obstacle_candidates.h); clusters at that edge are
        // cut by it (voxel_clustering.h: the candidates' far edge).
        built.clustering.candidate_forward_max_m = candidate_parameters.grid.forward_max_m;
        o3::validate_clustering_parameters(built.clustering);
        o3::ObstacleTrackingParameters tracking;
        tracking.frame_period_s = 1.0 / fps_;
        tracking.stereo_error = error_model;
        tracking.camera_mount = for_mount;
        tracking.acceptance_frames = acceptance_frames_;
        built.tracker = std::make_unique<o3::ObstacleTracker3d>(tracking);
      } else {
        built.grid = std::make_unique<o3::OccupancyGrid>(grid_parameters);
      }
    } catch (const std::invalid_argument& error) {
      throw CommandError(kExitUsage, error.what());
    }
    return built;
  };
  Method method = build_method(mount);
  // No mount flag: the mount comes from the ground plane (arm::estimate_ground_mount, as `lpstereo
  // terrain` does) of the first frame where it is found; frames before it have no candidates.
  const bool mount_given =
      command_->count("--camera-height-m") > 0 || command_->count("--pitch-deg") > 0 || command_->count("--roll-deg") > 0;
  bool mount_known = mount_given;
  std::string mount_reason;
  if (!view_directory_.empty()) {
    std::error_code error;
    std::filesystem::create_directories(view_directory_, error);
    if (error) throw CommandError(kExitInput, "--view " + view_directory_ + ": cannot create the folder (" + error.message() + ")");
  }
  if (mount_given) {
    std::printf("obstacles3d: %dx%d, method %s, %d frames, camera %.2f m high, pitch %.2f deg, roll %.2f deg\n", width, height,
                method_.c_str(), frame_count, mount_options_.camera_height_m, mount_options_.pitch_deg, mount_options_.roll_deg);
  } else {
    std::printf("obstacles3d: %dx%d, method %s, %d frames, camera mount estimated from the ground plane\n", width, height,
                method_.c_str(), frame_count);
  }
  if (frame_count == 1) std::fprintf(stderr, "obstacles3d: a single frame: no ego-motion, static camera assumed\n");

  const ProgressBar progress(frame_count);  // on a terminal only
  progress.show(0);
  std::string lines;  // written at the end in one atomic step: no half-written file
  std::set<int> track_ids;
  o3::OdometryEgoMotionParameters ego_motion_parameters;
  ego_motion_parameters.frame_period_s = 1.0 / fps_;
  o3::OdometryEgoMotion ego_motion_source(ego_motion_parameters);
  int dropout_frames = 0;  // frames after the first whose odometry failed ...
  int static_frames = 0;   // ... and of them those not bridged: static camera assumed
  int64_t obstacle_count = 0;
  int degraded_frames = 0;  // the view check's
  double processing_ms = 0;
  for (int i = 0; i < frame_count; ++i) {
    const int index = source->first_frame() + i;
    const io::SourceResult pair = source->next(std::chrono::milliseconds(0));  // frame_count pairs are there by name
    cv::Mat bgr = io::decode_image(source->left_pattern().path(index), cv::IMREAD_COLOR);
    if (bgr.depth() != CV_8U) bgr.convertTo(bgr, CV_8U, 1.0 / 256);
    const auto started = std::chrono::steady_clock::now();
    const Plane& disparity = engine.compute(pair.frame.left, pair.frame.right);
    const arm::CameraPoints camera = arm::triangulate(disparity, triangulation);
    // The view check (arm/obstacles3d/disparity_coverage.h): a frame with many invalid disparities
    // (typically a surface nearer than the search range) is flagged in its line and counted.
    const o3::DisparityCoverage coverage = o3::disparity_coverage(disparity, engine.invalid_disparity_q4(), o3::DisparityCoverageParameters{});
    if (coverage.degraded) {
      if (degraded_frames == 0) {
        std::fprintf(stderr, "obstacles3d: frame %d: view degraded: %.1f %% of the disparities invalid (a surface nearer than the search "
                             "range, or the matcher failing over much of the view): its obstacles are unreliable (later ones are counted in the summary)\n",
                     index, 100.0 * coverage.invalid_share);
      }
      ++degraded_frames;
    }
    if (!mount_known) {
      const arm::GroundMountEstimate estimate = arm::estimate_ground_mount(camera);
      if (estimate.found) {
        mount_known = true;
        method = build_method(estimate.mount);
        std::printf("obstacles3d: frame %d: camera mount estimated: %.2f m high, pitch %.2f deg, roll %.2f deg (%d of %d ground "
                    "candidates on the plane)\n",
                    index, estimate.camera_height_m, estimate.mount.pitch_rad * 180 / M_PI, estimate.mount.roll_rad * 180 / M_PI,
                    estimate.inliers, estimate.candidates);
      } else {
        mount_reason = "camera mount unknown (" + estimate.reason + "; give --camera-height-m): no obstacle candidates";
      }
    }
    o3::CandidatePoints candidates;
    if (mount_known) {
      candidates = o3::extract_obstacle_candidates(disparity, engine.invalid_disparity_q4(), camera, triangulation, pair.frame.left,
                                                   o3::ColourView{bgr.data, bgr.step, true}, *method.to_vehicle, candidate_parameters);
    } else {
      candidates.note = mount_reason;
    }

    // Ego-motion: the odometry's camera increment (t -> t-1) in the vehicle frame, V E_c V^-1; a
    // dropout bridged with the last valid increment for up to 5 frames, else static camera
    // (arm/obstacles3d/ego_motion.h).
    const arm::StereoOdometryFrame motion = odometry.process(pair.frame.left, pair.frame.right);
    const o3::EgoMotion ego_motion = ego_motion_source.next(
        motion.statistics.valid, motion.increment, mount_known ? method.to_vehicle->vehicle_from_camera() : Eigen::Isometry3d::Identity());
    if (i > 0 && (!motion.statistics.valid || ego_motion_source.rejected_implausible())) {
      if (dropout_frames == 0) {
        std::fprintf(stderr, "obstacles3d: frame %d (%d odometry inliers): %s (later ones are counted in the summary)\n", index,
                     motion.statistics.inliers, ego_motion_source.note().c_str());
      }
      ++dropout_frames;
      if (ego_motion_source.source() == o3::EgoMotionSource::static_camera) ++static_frames;
    }

    std::vector<o3::Obstacle3d> obstacles;
    std::string method_status;
    if (method.grid) {
      method.grid->update(candidates.points, ego_motion);
      obstacles = method.grid->obstacles();
      method_status = method.grid->status();
    } else if (method.stixels) {
      method.stixels->update(candidates.points, ego_motion);
      obstacles = method.stixels->obstacles();
      method_status = method.stixels->status();
    } else {
      const o3::VoxelMapStatus& map_status = method.voxel_map->update(candidates.points, ego_motion);
      const o3::ClusteringResult clusters = o3::cluster_voxels(*method.voxel_map, method.clustering);
      // The odometry's feature motion measures the clusters' velocities when the map moved by that
      // odometry's own increment (obstacle_tracking.h, "Feature motion").
      static const std::vector<arm::FeatureMotion> kNoFeatureMotion;
      const bool odometry_increment = ego_motion_source.source() == o3::EgoMotionSource::odometry;
      const o3::TrackingResult& tracks = method.tracker->update(clusters.clusters, method.voxel_map->world_from_current(),
                                                                odometry_increment ? motion.feature_motions : kNoFeatureMotion);
      obstacles = tracks.obstacles;
      char text[200];
      std::snprintf(text, sizeof text, "; %zu clusters, %lld new tracks, %lld confirmed, %lld ghosted, %lld deleted, %lld velocities from feature motion",
                    clusters.clusters.size(), static_cast<long long>(tracks.new_tracks), static_cast<long long>(tracks.confirmed),
                    static_cast<long long>(tracks.ghosted), static_cast<long long>(tracks.deleted),
                    static_cast<long long>(tracks.feature_velocity_updates));
      method_status = map_status.text() + text;
    }
    processing_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count();

    nlohmann::json obstacle_lines = nlohmann::json::array();
    for (const o3::Obstacle3d& obstacle : obstacles) {
      obstacle_lines.push_back(obstacle3d_json(obstacle));
      if (obstacle.track_id >= 0) track_ids.insert(obstacle.track_id);
    }
    obstacle_count += static_cast<int64_t>(obstacles.size());
    const std::string ego_note = ego_motion_source.note();
    const nlohmann::json line = {{"frame", index},
                                 {"status", candidates.note + "; " + ego_note + "; " + method_status},
                                 {"ego_motion", ego_motion.available},
                                 {"disparity_invalid_share", std::round(coverage.invalid_share * 10000) / 10000},
                                 {"view_degraded", coverage.degraded},
                                 {"obstacles", obstacle_lines}};
    lines += line.dump() + "\n";

    if (!view_directory_.empty()) {
      io::write_image(view_file(view_directory_, "top", index), top_view(obstacles));
      io::write_image(view_file(view_directory_, "overlay", index), image_overlay(bgr, obstacles, geometry));
      if (method.grid) io::write_image(view_file(view_directory_, "grid", index), io::occupancy_grid_picture(*method.grid));
      if (method.stixels) io::write_image(view_file(view_directory_, "grid", index), io::stixel_top_view(*method.stixels));
    }
    progress.show(i + 1);
  }
  write_file_atomically(output_, lines);
  std::printf("%d frames (%d .. %d), %lld obstacles, %zu tracks, visual odometry failed in %d frames after the first (%d bridged with "
              "the last increment, %d without ego-motion: static camera assumed), view degraded in %d (>= %.0f %% of the disparities "
              "invalid), mean %.1f ms per frame (disparity, terrain, odometry, %s) -> %s\n",
              frame_count, source->first_frame(), source->first_frame() + frame_count - 1, static_cast<long long>(obstacle_count),
              track_ids.size(), dropout_frames, dropout_frames - static_frames, static_frames, degraded_frames,
              100.0 * o3::DisparityCoverageParameters{}.degraded_invalid_share, processing_ms / frame_count, method_.c_str(), output_.c_str());
  return 0;
}

}  // namespace lpstereo::tools
