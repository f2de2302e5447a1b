#include "tools/points_command.h"

#include <cmath>
#include <cstdio>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "arm/disparity_engine.h"
#include "arm/point_cloud.h"
#include "io/image_io.h"
#include "io/rectification.h"
#include "tools/disparity_options.h"
#include "tools/command_error.h"
#include "tools/rectified_pair.h"

namespace lpstereo::tools {

PointsCommand::PointsCommand(CLI::App& app) {
  command_ = app.add_subcommand("points", "PLY point cloud of a rectified pair: disparity engine, then disparity_to_points");
  command_->add_option("left", left_, "rectified left image (its colours go into the cloud)")->required();
  command_->add_option("right", right_, "rectified right image, same size")->required();
  command_->add_option("--calib", calibration_files_,
                       "calibration file, or two (intrinsics + extrinsics, or left + right); its rectified geometry gives "
                       "focal length, baseline and principal point")
      ->required();
  command_->add_option("-o,--output", output_, "PLY file to write")->required();
  command_->add_flag("--ascii", ascii_, "ASCII PLY instead of binary little-endian");
  command_->add_option("--min-disp", min_disparity_, "smallest disparity searched, px")->capture_default_str();
  command_->add_option("--num-disp", num_disparities_, "disparities searched")->capture_default_str();
  command_->add_option("--roll-rad", roll_rad_, "camera mount roll about the vehicle's x (forward), radians");
  command_->add_option("--pitch-rad", pitch_rad_, "camera mount pitch about the vehicle's y (left), radians (+ = looking down)");
  command_->add_option("--yaw-rad", yaw_rad_, "camera mount yaw about the vehicle's z (up), radians (+ = looking left)");
  command_->add_option("--position-m", position_m_, "camera centre in the vehicle frame X Y Z, metres; with the angles, "
                                                    "writes the cloud in the vehicle frame (x forward, y left, z up)")
      ->expected(3);
}

int PointsCommand::run() const {
  const RectifiedPair pair = read_rectified_pair(left_, right_, calibration_files_);
  const Plane& left = pair.left;
  const Plane& right = pair.right;
  const io::RectifiedGeometry& geometry = pair.geometry;

  check_disparity_range(min_disparity_, num_disparities_, left.width());
  arm::DisparityParameters parameters;
  parameters.min_disparity = min_disparity_;
  parameters.num_disparities = num_disparities_;
  arm::DisparityEngine engine(left.width(), left.height(), parameters);
  const Plane& disparity = engine.compute(left, right);
  const arm::TriangulationParameters triangulation = triangulation_parameters(geometry, min_disparity_, num_disparities_);
  const arm::CameraPoints points = arm::triangulate(disparity, triangulation);

  // Colours: the left file decoded as colour (a grey file gives equal channels), BGR to RGB.
  cv::Mat colour = io::decode_image(left_, cv::IMREAD_COLOR);
  if (colour.depth() != CV_8U) colour.convertTo(colour, CV_8U, 1.0 / 256);
  cv::cvtColor(colour, colour, cv::COLOR_BGR2RGB);
  const arm::ColourImageView colours{colour.data, static_cast<ptrdiff_t>(colour.step[0]), colour.cols, colour.rows, 3};
  std::optional<arm::CameraToVehicle> to_vehicle;
  if (!position_m_.empty()) {
    arm::CameraMount mount;
    mount.roll_rad = roll_rad_;
    mount.pitch_rad = pitch_rad_;
    mount.yaw_rad = yaw_rad_;
    mount.position_m = Eigen::Vector3d(position_m_[0], position_m_[1], position_m_[2]);
    to_vehicle.emplace(mount);
  } else if (roll_rad_ != 0 || pitch_rad_ != 0 || yaw_rad_ != 0) {
    throw CommandError(kExitUsage, "--roll-rad/--pitch-rad/--yaw-rad need --position-m X Y Z (the camera centre in the vehicle frame)");
  }
  const arm::PointCloud cloud = arm::collect_points(points, colours, to_vehicle ? &*to_vehicle : nullptr);
  arm::write_ply(output_, cloud, ascii_ ? arm::PlyEncoding::ascii : arm::PlyEncoding::binary_little_endian);
  std::printf("%zu points (%.1f %% of %dx%d pixels), %s frame, focal %.3f px, baseline %.6f m, principal point (%.2f, %.2f) "
              "px -> %s\n",
              cloud.points.size(), 100.0 * static_cast<double>(cloud.points.size()) / (left.width() * left.height()),
              left.width(), left.height(), cloud.frame.c_str(), geometry.focal_px, geometry.baseline_m, geometry.cx_left_px,
              geometry.cy_px, output_.c_str());
  return 0;
}

}  // namespace lpstereo::tools
