#include "io/rectification.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/calib3d.hpp>

#include "dag/remap_table.h"

namespace lpstereo::io {

namespace {

cv::Mat camera_matrix(const CameraModel& camera) {
  return (cv::Mat_<double>(3, 3) << camera.fx_px, 0, camera.cx_px, 0, camera.fy_px, camera.cy_px, 0, 0, 1);
}

cv::Mat distortion(const CameraModel& camera) {
  if (camera.lens == LensModel::equidistant) {
    return (cv::Mat_<double>(1, 4) << camera.distortion[0], camera.distortion[1], camera.distortion[2], camera.distortion[3]);
  }
  return cv::Mat(1, 5, CV_64F, const_cast<double*>(camera.distortion.data())).clone();
}

cv::Mat matrix(const double* data, int rows, int cols) { return cv::Mat(rows, cols, CV_64F, const_cast<double*>(data)).clone(); }

void identity_map(int width, int height, cv::Mat& map_x, cv::Mat& map_y) {
  map_x.create(height, width, CV_32FC1);
  map_y.create(height, width, CV_32FC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      map_x.at<float>(y, x) = static_cast<float>(x);
      map_y.at<float>(y, x) = static_cast<float>(y);
    }
  }
}

double inside_share(const cv::Mat& map_x, const cv::Mat& map_y, int width, int height) {
  size_t inside = 0;
  for (int y = 0; y < map_x.rows; ++y) {
    for (int x = 0; x < map_x.cols; ++x) {
      const float sx = map_x.at<float>(y, x);
      const float sy = map_y.at<float>(y, x);
      if (sx >= 0 && sy >= 0 && sx <= static_cast<float>(width - 1) && sy <= static_cast<float>(height - 1)) ++inside;
    }
  }
  return static_cast<double>(inside) / static_cast<double>(map_x.total());
}

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

}  // namespace

RectificationMaps compute_rectification_maps(const StereoCalibration& calibration, int width, int height) {
  const std::string& source = calibration.source;
  if (width <= 0 || height <= 0) throw CalibrationError(source + ": image size " + size_text(width, height) + " is empty");
  for (const CameraModel* camera : {&calibration.left, &calibration.right}) {
    if (camera->width_px > 0 && (camera->width_px != width || camera->height_px != height)) {
      throw CalibrationError(source + ": calibration is for " + size_text(camera->width_px, camera->height_px) +
                             " images, the images are " + size_text(width, height));
    }
  }
  RectificationMaps maps;
  maps.width = width;
  maps.height = height;
  const cv::Size size(width, height);
  const bool equidistant = calibration.left.lens == LensModel::equidistant;
  if (calibration.right.lens != calibration.left.lens) {
    throw CalibrationError(source + ": left and right lens models differ (one pinhole, one equidistant)");
  }
  try {
    if (calibration.already_rectified) {
      identity_map(width, height, maps.left_x, maps.left_y);
      identity_map(width, height, maps.right_x, maps.right_y);
      maps.geometry = {calibration.left.fx_px, calibration.left.cx_px, calibration.right.cx_px, calibration.left.cy_px,
                       calibration.baseline_m()};
      return maps;
    }
    cv::Mat r1, r2, p1, p2, q;
    if (calibration.rectification) {
      const StereoRectification& given = *calibration.rectification;
      r1 = matrix(given.r1.data(), 3, 3);
      r2 = matrix(given.r2.data(), 3, 3);
      p1 = matrix(given.p1.data(), 3, 4);
      p2 = matrix(given.p2.data(), 3, 4);
    } else if (equidistant) {
      cv::fisheye::stereoRectify(camera_matrix(calibration.left), distortion(calibration.left), camera_matrix(calibration.right),
                                 distortion(calibration.right), size, matrix(calibration.rotation.data(), 3, 3),
                                 matrix(calibration.translation_m.data(), 3, 1), r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY,
                                 size, 0.0, 1.0);
    } else {
      cv::stereoRectify(camera_matrix(calibration.left), distortion(calibration.left), camera_matrix(calibration.right),
                        distortion(calibration.right), size, matrix(calibration.rotation.data(), 3, 3),
                        matrix(calibration.translation_m.data(), 3, 1), r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 0.0, size);
    }
    auto build = [&](const CameraModel& camera, const cv::Mat& r, const cv::Mat& p, cv::Mat& map_x, cv::Mat& map_y) {
      if (equidistant) {
        cv::fisheye::initUndistortRectifyMap(camera_matrix(camera), distortion(camera), r, p, size, CV_32FC1, map_x, map_y);
      } else {
        cv::initUndistortRectifyMap(camera_matrix(camera), distortion(camera), r, p, size, CV_32FC1, map_x, map_y);
      }
    };
    build(calibration.left, r1, p1, maps.left_x, maps.left_y);
    build(calibration.right, r2, p2, maps.right_x, maps.right_y);
    maps.geometry.focal_px = p1.at<double>(0, 0);
    maps.geometry.cx_left_px = p1.at<double>(0, 2);
    maps.geometry.cx_right_px = p2.at<double>(0, 2);
    maps.geometry.cy_px = p1.at<double>(1, 2);
    maps.geometry.baseline_m = std::abs(p2.at<double>(0, 3) / p2.at<double>(0, 0));
  } catch (const cv::Exception& exception) {
    throw CalibrationError(source + ": OpenCV cannot rectify with this calibration: " + exception.err);
  }
  maps.left_inside = inside_share(maps.left_x, maps.left_y, width, height);
  maps.right_inside = inside_share(maps.right_x, maps.right_y, width, height);
  for (auto [share, view] : {std::pair{maps.left_inside, "left"}, std::pair{maps.right_inside, "right"}}) {
    if (!(share >= 0.5)) {
      char text[64];
      std::snprintf(text, sizeof(text), "%.1f %%", 100 * share);
      throw CalibrationError(source + ": the " + view + " rectification maps outside the source image (only " + text +
                             " of the output pixels come from inside it): calibration for another camera or image size?");
    }
  }
  return maps;
}

Plane rectification_table(const cv::Mat& map_x, const cv::Mat& map_y, const std::string& view) {
  if (map_x.type() != CV_32FC1 || map_y.type() != CV_32FC1 || map_x.size() != map_y.size() || !map_x.isContinuous() ||
      !map_y.isContinuous()) {
    throw CalibrationError(view + " rectification: expected two continuous CV_32FC1 maps of one size");
  }
  try {
    return make_remap_q5_from_float(map_x.ptr<float>(), map_y.ptr<float>(), map_x.cols, map_x.rows, map_x.cols);
  } catch (const std::invalid_argument& error) {
    throw CalibrationError(view + " rectification does not fit the fixed-point table: " + error.what());
  }
}

namespace {

StereoCalibration load_from_params(const nlohmann::json& files) {
  if (files.is_string()) return load_stereo_calibration(files.get<std::string>());
  if (files.is_array() && files.size() == 1 && files[0].is_string()) return load_stereo_calibration(files[0].get<std::string>());
  if (files.is_array() && files.size() == 2 && files[0].is_string() && files[1].is_string()) {
    return load_stereo_calibration(files[0].get<std::string>(), files[1].get<std::string>());
  }
  throw std::invalid_argument("calibration: expected a file name or a list of one or two file names");
}

}  // namespace

void register_calibration_rectification_generator() {
  register_constant_generator(
      "calibration_rectification", {ElementType::remap_q5, 0}, [](const nlohmann::json& params, int width, int height) {
        check_param_names(params, {"calibration", "view"});
        if (!params.contains("calibration")) throw std::invalid_argument("missing parameter 'calibration'");
        const std::string view = params.value("view", std::string());
        if (view != "left" && view != "right") throw std::invalid_argument("view: expected \"left\" or \"right\", got \"" + view + "\"");
        const RectificationMaps maps = compute_rectification_maps(load_from_params(params["calibration"]), width, height);
        return view == "left" ? rectification_table(maps.left_x, maps.left_y, "left")
                              : rectification_table(maps.right_x, maps.right_y, "right");
      });
}

GraphSpec rectification_graph_spec(const std::vector<std::string>& calibration_files) {
  GraphSpec spec;
  spec.name = "calibration-rectify";
  spec.description = "Rectify a stereo pair with fixed-point remap tables built from a calibration file.";
  spec.inputs = {{"left", {ElementType::u8, 0}}, {"right", {ElementType::u8, 0}}};
  const nlohmann::json files = calibration_files;
  for (const char* view : {"left", "right"}) {
    spec.constants.push_back({std::string(view) + "_map", "calibration_rectification", {{"calibration", files}, {"view", view}}});
    NodeSpec node;
    node.name = std::string("rectify_") + view;
    node.kernel = "remap_bilinear";
    node.inputs = {{"source", {view, false}}, {"map", {std::string(view) + "_map", false}}};
    node.outputs = {{"output", std::string(view) + "_rectified"}};
    node.border_mode = BorderMode::constant;
    node.border_value = 0;
    spec.nodes.push_back(node);
    spec.outputs.push_back(std::string(view) + "_rectified");
  }
  return spec;
}

}  // namespace lpstereo::io
