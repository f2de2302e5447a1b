#include "io/rectification.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/calib3d.hpp>

#include "dag/remap_table.h"
#include "io/spherical.h"

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

void require_size_matches(const StereoCalibration& calibration, int width, int height) {
  const std::string& source = calibration.source;
  if (width <= 0 || height <= 0) throw CalibrationError(source + ": image size " + size_text(width, height) + " is empty");
  for (const CameraModel* camera : {&calibration.left, &calibration.right}) {
    if (camera->width_px > 0 && (camera->width_px != width || camera->height_px != height)) {
      throw CalibrationError(source + ": calibration is for " + size_text(camera->width_px, camera->height_px) +
                             " images, the images are " + size_text(width, height));
    }
  }
  if (calibration.right.lens != calibration.left.lens) {
    throw CalibrationError(source + ": left and right lens models differ (" + lens_name(calibration.left.lens) + ", " +
                           lens_name(calibration.right.lens) + ")");
  }
}

// Fills the inside shares and refuses maps whose output mostly comes from outside the sources.
void require_mostly_inside(RectificationMaps& maps, const std::string& source, int width, int height, const std::string& hint) {
  maps.left_inside = inside_share(maps.left_x, maps.left_y, width, height);
  maps.right_inside = inside_share(maps.right_x, maps.right_y, width, height);
  for (auto [share, view] : {std::pair{maps.left_inside, "left"}, std::pair{maps.right_inside, "right"}}) {
    if (!(share >= 0.5)) {
      char text[64];
      std::snprintf(text, sizeof(text), "%.1f %%", 100 * share);
      throw CalibrationError(source + ": the " + view + " rectification maps outside the source image (only " + text +
                             " of the output pixels come from inside it): " + hint);
    }
  }
}

double degrees(double radians) { return radians * 180.0 / 3.14159265358979323846; }

std::string degrees_text(double radians) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", degrees(radians));
  return text;
}

}  // namespace

RectificationMaps compute_rectification_maps(const StereoCalibration& calibration, int width, int height) {
  const std::string& source = calibration.source;
  require_size_matches(calibration, width, height);
  if (calibration.left.lens == LensModel::mei) {
    throw CalibrationError(source + ": a Mei (omnidirectional) camera has no pinhole rectification here: use the "
                                    "latitude-longitude one (lpstereo rectify --model latlong)");
  }
  RectificationMaps maps;
  maps.width = width;
  maps.height = height;
  const cv::Size size(width, height);
  const bool equidistant = calibration.left.lens == LensModel::equidistant;
  try {
    if (calibration.already_rectified) {
      identity_map(width, height, maps.left_x, maps.left_y);
      identity_map(width, height, maps.right_x, maps.right_y);
      maps.geometry.focal_px = calibration.left.fx_px;
      maps.geometry.cx_left_px = calibration.left.cx_px;
      maps.geometry.cx_right_px = calibration.right.cx_px;
      maps.geometry.cy_px = calibration.left.cy_px;
      maps.geometry.baseline_m = calibration.baseline_m();
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
    r1.convertTo(r1, CV_64F);
    r2.convertTo(r2, CV_64F);
    std::copy(r1.begin<double>(), r1.end<double>(), maps.geometry.r1.begin());
    std::copy(r2.begin<double>(), r2.end<double>(), maps.geometry.r2.begin());
  } catch (const cv::Exception& exception) {
    throw CalibrationError(source + ": OpenCV cannot rectify with this calibration: " + exception.err);
  }
  require_mostly_inside(maps, source, width, height, "calibration for another camera or image size?");
  return maps;
}

RectificationMaps compute_latlong_maps(const StereoCalibration& calibration, int width, int height, const LatLongOptions& options) {
  const std::string& source = calibration.source;
  require_size_matches(calibration, width, height);
  constexpr double kPi = 3.14159265358979323846;
  if (!(options.hfov_rad > 0 && options.hfov_rad <= kPi + 1e-12)) {
    throw CalibrationError(source + ": lat-long horizontal field of view " + degrees_text(options.hfov_rad) +
                           " deg: expected (0, 180] (a row runs along an epipolar plane from one epipole to the other)");
  }
  RectificationMaps maps;
  maps.width = options.width > 0 ? options.width : width;
  maps.height = options.height > 0 ? options.height : height;
  if (options.width < 0 || options.height < 0 || maps.width > 8192 || maps.height > 8192) {
    throw CalibrationError(source + ": lat-long output size " + size_text(options.width, options.height) +
                           ": expected 1..8192 per side, or 0 for the image size");
  }
  // Pixels per radian on both axes: the columns span hfov (thesis eq. 2.21, m_FOV), the rows as
  // many radians of epipolar planes as the height gives.
  const double f = maps.width / options.hfov_rad;
  const double cx = (maps.width - 1) / 2.0, cy = (maps.height - 1) / 2.0;
  const double vfov_rad = maps.height / f;
  if (!(vfov_rad <= kPi + 1e-12)) {
    throw CalibrationError(source + ": lat-long rows would span " + degrees_text(vfov_rad) + " deg of epipolar planes (" +
                           size_text(maps.width, maps.height) + " at hfov " + degrees_text(options.hfov_rad) +
                           " deg): at most 180; lower the output height or widen hfov");
  }
  // The rectifying rotation (see the header): x along the baseline, z the mean optical axis.
  const cv::Matx33d r(calibration.rotation.data());
  const cv::Vec3d t(calibration.translation_m.data());
  const cv::Vec3d right_centre = -(r.t() * t);  // in the left frame: X_right = R X_left + T
  const cv::Vec3d e_x = cv::normalize(right_centre);
  const cv::Vec3d forward = cv::normalize(cv::Vec3d(0, 0, 1) + cv::Vec3d(r(2, 0), r(2, 1), r(2, 2)));
  const cv::Vec3d e_z = cv::normalize(forward - forward.dot(e_x) * e_x);
  const cv::Vec3d e_y = e_z.cross(e_x);
  const cv::Matx33d r1(e_x[0], e_x[1], e_x[2], e_y[0], e_y[1], e_y[2], e_z[0], e_z[1], e_z[2]);  // X_rect = R1 X_left
  const cv::Matx33d r2 = r1 * r.t();                                                              // X_rect = R2 X_right
  struct View {
    const CameraModel* camera;
    cv::Matx33d camera_from_rectified;
    cv::Mat* map_x;
    cv::Mat* map_y;
    const char* name;
  };
  const View views[2] = {{&calibration.left, r1.t(), &maps.left_x, &maps.left_y, "left"},
                         {&calibration.right, r2.t(), &maps.right_x, &maps.right_y, "right"}};
  for (const View& view : views) {
    const double limit_rad = max_incidence_rad(*view.camera);
    view.map_x->create(maps.height, maps.width, CV_32FC1);
    view.map_y->create(maps.height, maps.width, CV_32FC1);
    double widest_rad = 0;
    for (int row = 0; row < maps.height; ++row) {
      const double beta = (row - cy) / f;
      for (int column = 0; column < maps.width; ++column) {
        const double psi = (column - cx) / f;
        // Thesis eq. 2.20-2.22 with the baseline as x and the forward direction at psi = 0.
        const cv::Vec3d ray = view.camera_from_rectified * cv::Vec3d(std::sin(psi), std::cos(psi) * std::sin(beta),
                                                                      std::cos(psi) * std::cos(beta));
        widest_rad = std::max(widest_rad, std::atan2(std::hypot(ray[0], ray[1]), ray[2]));
        const std::optional<Pixel> pixel = project_ray(*view.camera, {ray[0], ray[1], ray[2]}, limit_rad);
        // A ray the lens does not image, or one landing well outside the source: a position just
        // outside the source (constant border) near this pixel, so the table's displacement stays
        // small (Q10.5 holds +-1024 px).
        double x = -2, y = -2;
        if (pixel && (*pixel)[0] >= -1 && (*pixel)[0] <= width && (*pixel)[1] >= -1 && (*pixel)[1] <= height) {
          x = (*pixel)[0];
          y = (*pixel)[1];
        } else {
          x = column < width / 2 ? -2 : width + 1;
          y = row < height / 2 ? -2 : height + 1;
        }
        view.map_x->at<float>(row, column) = static_cast<float>(x);
        view.map_y->at<float>(row, column) = static_cast<float>(y);
      }
    }
    if (!(widest_rad < limit_rad)) {
      throw CalibrationError(source + ": the lat-long view (hfov " + degrees_text(options.hfov_rad) + " deg, " +
                             size_text(maps.width, maps.height) + ") needs rays " + degrees_text(widest_rad) + " deg from the " +
                             view.name + " camera's axis; its " + lens_name(view.camera->lens) + " model images at most " +
                             degrees_text(limit_rad) + " deg: lower --hfov-deg or the output height");
    }
  }
  maps.geometry.projection = RectifiedProjection::latlong;
  maps.geometry.focal_px = f;
  maps.geometry.cx_left_px = maps.geometry.cx_right_px = cx;
  maps.geometry.cy_px = cy;
  maps.geometry.baseline_m = calibration.baseline_m();
  std::copy(r1.val, r1.val + 9, maps.geometry.r1.begin());
  std::copy(r2.val, r2.val + 9, maps.geometry.r2.begin());
  require_mostly_inside(maps, source, width, height,
                        "the lens sees less than the view asks for (lower --hfov-deg), or a calibration for another camera?");
  return maps;
}

double latlong_range_m(const RectifiedGeometry& geometry, double column_left_px, double disparity_px) {
  const double theta_left_rad = 3.14159265358979323846 / 2 + (column_left_px - geometry.cx_left_px) / geometry.focal_px;
  return spherical_range_m(geometry.baseline_m, theta_left_rad, disparity_px / geometry.focal_px);
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
        check_param_names(params, {"calibration", "view", "model", "hfov_deg", "width", "height"});
        if (!params.contains("calibration")) throw std::invalid_argument("missing parameter 'calibration'");
        const std::string view = params.value("view", std::string());
        if (view != "left" && view != "right") throw std::invalid_argument("view: expected \"left\" or \"right\", got \"" + view + "\"");
        const std::string model = params.value("model", std::string("pinhole"));
        if (model != "pinhole" && model != "latlong") {
          throw std::invalid_argument("model: expected \"pinhole\" or \"latlong\", got \"" + model + "\"");
        }
        const StereoCalibration calibration = load_from_params(params["calibration"]);
        RectificationMaps maps;
        if (model == "latlong") {
          LatLongOptions options;
          options.hfov_rad = params.value("hfov_deg", 180.0) * 3.14159265358979323846 / 180.0;
          options.width = params.value("width", 0);
          options.height = params.value("height", 0);
          maps = compute_latlong_maps(calibration, width, height, options);
        } else {
          maps = compute_rectification_maps(calibration, width, height);
        }
        return view == "left" ? rectification_table(maps.left_x, maps.left_y, "left")
                              : rectification_table(maps.right_x, maps.right_y, "right");
      });
}

GraphSpec rectification_graph_spec(const std::vector<std::string>& calibration_files, const std::optional<LatLongOptions>& latlong) {
  GraphSpec spec;
  spec.name = "calibration-rectify";
  spec.description = "Rectify a stereo pair with fixed-point remap tables built from a calibration file.";
  spec.inputs = {{"left", {ElementType::u8, 0}}, {"right", {ElementType::u8, 0}}};
  const nlohmann::json files = calibration_files;
  for (const char* view : {"left", "right"}) {
    nlohmann::json params = {{"calibration", files}, {"view", view}};
    if (latlong) {
      params["model"] = "latlong";
      params["hfov_deg"] = latlong->hfov_rad * 180.0 / 3.14159265358979323846;
      params["width"] = latlong->width;
      params["height"] = latlong->height;
    }
    ConstantSpec constant{std::string(view) + "_map", "calibration_rectification", params};
    if (latlong) {
      constant.width = latlong->width;
      constant.height = latlong->height;
    }
    spec.constants.push_back(constant);
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
