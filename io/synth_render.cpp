#include "io/synth_render.h"

#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "io/png_codec.h"

namespace lpstereo::io::synth_detail {

void require(bool ok, const std::string& option, const std::string& expected, double actual) {
  if (ok) return;
  std::ostringstream text;
  text << option << ": expected " << expected << ", got " << actual;
  throw std::invalid_argument(text.str());
}

void validate_camera_and_sensor(int width, int height, double hfov_deg, int samples_per_axis, double noise_sigma, double right_gain,
                                double right_offset, int threads) {
  require(width >= 16 && width <= 16384, "width", "16..16384 px", width);
  require(height >= 16 && height <= 16384, "height", "16..16384 px", height);
  require(hfov_deg > 1 && hfov_deg < 170, "hfov-deg", "a field of view in (1, 170) degrees", hfov_deg);
  require(samples_per_axis >= 1 && samples_per_axis <= 4, "samples", "1..4 per axis", samples_per_axis);
  require(noise_sigma >= 0 && noise_sigma <= 100, "noise-sigma", "0..100 grey levels", noise_sigma);
  require(right_gain > 0 && right_gain <= 4, "gain", "(0, 4]", right_gain);
  require(std::abs(right_offset) <= 255, "offset", "-255..255 grey levels", right_offset);
  require(threads >= 1 && threads <= 256, "threads", "1..256", threads);
}

void expose_row(const Rgb* colours, int width, const SensorModel& sensor, uint64_t seed, int view, int row, uint8_t* grey,
                cv::Vec3b* bgr) {
  SplitMix noise{mix64((seed << 32) ^ (static_cast<uint64_t>(view) << 31) ^ static_cast<uint64_t>(row))};
  const double dv = row - sensor.centre_v;
  const double falloff = sensor.vignetting / (sensor.corner_radius_px * sensor.corner_radius_px);
  for (int u = 0; u < width; ++u) {
    const double du = u - sensor.centre_u;
    // Exactly 1 without vignetting: the scene renders bit for bit as before the option existed.
    const double light = sensor.vignetting > 0 ? 1.0 - falloff * (du * du + dv * dv) : 1.0;
    const Rgb c = colours[u] * light;
    const double n = sensor.noise_sigma > 0 ? sensor.noise_sigma * noise.gaussian() : 0.0;
    grey[u] = to_u8(sensor.gain * (0.299 * c.r + 0.587 * c.g + 0.114 * c.b) + sensor.offset + n);
    if (bgr != nullptr) {
      bgr[u] = {to_u8(sensor.gain * c.b + sensor.offset + n), to_u8(sensor.gain * c.g + sensor.offset + n),
                to_u8(sensor.gain * c.r + sensor.offset + n)};
    }
  }
}

void blur_radiance(std::vector<Rgb>& image, int width, int height, double sigma_px, int threads) {
  // Taps to 3 sigma (99.7 % of the weight), normalised to sum 1.
  const int radius = std::max(1, static_cast<int>(std::ceil(3 * sigma_px)));
  std::vector<double> weights(static_cast<size_t>(2 * radius + 1));
  double total = 0;
  for (int k = -radius; k <= radius; ++k) total += weights[static_cast<size_t>(k + radius)] = std::exp(-0.5 * k * k / (sigma_px * sigma_px));
  for (double& weight : weights) weight /= total;
  const auto index = [width](int u, int v) { return static_cast<size_t>(v) * static_cast<size_t>(width) + static_cast<size_t>(u); };
  // One separable pass from `source` into `destination`, along the rows (horizontal) or the columns.
  const auto pass = [&](const std::vector<Rgb>& source, std::vector<Rgb>& destination, bool horizontal) {
    render_rows(height, threads, [&](int v) {
      for (int u = 0; u < width; ++u) {
        Rgb sum;
        for (int k = -radius; k <= radius; ++k) {
          const size_t tap = horizontal ? index(std::clamp(u + k, 0, width - 1), v) : index(u, std::clamp(v + k, 0, height - 1));
          sum = sum + source[tap] * weights[static_cast<size_t>(k + radius)];
        }
        destination[index(u, v)] = sum;
      }
    }, {});
  };
  std::vector<Rgb> across(image.size());
  pass(image, across, true);
  pass(across, image, false);
}

void render_rows(int height, int threads, const std::function<void(int)>& render_row,
                 const std::function<void(double)>& progress) {
  std::atomic<int> next_row{0}, rows_done{0};
  std::mutex progress_mutex;
  int reported_percent = -1;
  auto work = [&] {
    for (;;) {
      const int v = next_row.fetch_add(1);
      if (v >= height) return;
      render_row(v);
      const int done = rows_done.fetch_add(1) + 1;
      if (progress) {
        const int percent = static_cast<int>(100LL * done / height);
        std::lock_guard<std::mutex> lock(progress_mutex);
        if (percent != reported_percent) {
          reported_percent = percent;
          progress(static_cast<double>(done) / height);
        }
      }
    }
  };
  std::vector<std::thread> workers;
  for (int i = 1; i < threads; ++i) workers.emplace_back(work);
  work();
  for (std::thread& worker : workers) worker.join();
}

StereoCalibration pinhole_pair_calibration(int width, int height, double focal_px, double cx_px, double cy_px, double baseline_m) {
  StereoCalibration calibration;
  for (CameraModel* camera : {&calibration.left, &calibration.right}) {
    camera->width_px = width;
    camera->height_px = height;
    camera->fx_px = camera->fy_px = focal_px;
    camera->cx_px = cx_px;
    camera->cy_px = cy_px;
  }
  calibration.translation_m = {-baseline_m, 0, 0};
  calibration.already_rectified = true;
  StereoRectification rectification;
  const double f = focal_px, cx = cx_px, cy = cy_px;
  rectification.p1 = {f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0};
  rectification.p2 = {f, 0, cx, -f * baseline_m, 0, f, cy, 0, 0, 0, 1, 0};
  rectification.q = {1, 0, 0, -cx, 0, 1, 0, -cy, 0, 0, 0, f, 0, 0, 1 / baseline_m, 0};
  calibration.rectification = rectification;
  calibration.format = "opencv";
  calibration.source = "lpstereo synth";
  return calibration;
}

std::string kitti_projection_line(const std::string& name, double focal_px, double cx_px, double cy_px, double baseline_m) {
  const double tx = baseline_m == 0 ? 0.0 : -focal_px * baseline_m;  // the reference camera: 0, not -0
  return name + ": " + number(focal_px) + " 0 " + number(cx_px) + " " + number(tx) + " 0 " + number(focal_px) +
         " " + number(cy_px) + " 0 0 0 1 0\n";
}

cv::Mat kitti_disparity_truth(const cv::Mat& disparity_px) {
  cv::Mat kitti(disparity_px.size(), CV_16UC1);
  for (int v = 0; v < kitti.rows; ++v) {
    for (int u = 0; u < kitti.cols; ++u) {
      const float d = disparity_px.at<float>(v, u);
      const double scaled = std::round(static_cast<double>(d) * 256.0);
      kitti.at<uint16_t>(v, u) = std::isfinite(d) && d > 0 && scaled <= 65535 ? static_cast<uint16_t>(std::max(1.0, scaled)) : 0;
    }
  }
  return kitti;
}

void add_sensor_settings(nlohmann::json& json, int samples_per_axis, double noise_sigma, double right_gain, double right_offset,
                         uint32_t seed) {
  json["samples_per_pixel"] = samples_per_axis * samples_per_axis;
  json["noise_sigma"] = noise_sigma;
  json["right_gain"] = right_gain;
  json["right_offset"] = right_offset;
  json["seed"] = seed;
}

void add_surface_and_lens_settings(nlohmann::json& json, const char* road_surface, double vignetting, double right_vignetting,
                                   double blur_sigma_px) {
  json["road_surface"] = road_surface;
  json["vignetting"] = vignetting;
  json["right_vignetting"] = right_vignetting;
  json["blur_sigma_px"] = blur_sigma_px;
}

std::string number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.12e", x);
  return buffer;
}

void write_png(const std::filesystem::path& path, const cv::Mat& image) {
  if (!lpstereo::io::encode_png(path.string(), image)) throw std::runtime_error(path.string() + ": could not write the PNG");
}

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream file(path, std::ios::binary);
  file << text;
  file.close();
  if (!file) throw std::runtime_error(path.string() + ": could not write the file");
}

void write_folder_atomically(const std::string& directory, const std::function<void(const std::filesystem::path&)>& fill) {
  namespace fs = std::filesystem;
  const fs::path target = fs::absolute(fs::path(directory)).lexically_normal();
  const fs::path name = target.filename().empty() ? target.parent_path().filename() : target.filename();
  const fs::path parent = target.filename().empty() ? target.parent_path().parent_path() : target.parent_path();
  std::error_code error;
  if (!fs::is_directory(parent, error)) {
    throw std::runtime_error(directory + ": the parent folder " + parent.string() + " does not exist or is not a folder");
  }
  if (fs::exists(target, error) && !fs::is_directory(target, error)) {
    throw std::runtime_error(directory + ": exists and is not a folder");
  }
  const std::string suffix = "." + std::to_string(::getpid());
  const fs::path temporary = parent / ("." + name.string() + ".tmp" + suffix);
  const fs::path old = parent / ("." + name.string() + ".old" + suffix);
  fs::remove_all(temporary, error);
  if (!fs::create_directory(temporary, error)) {
    throw std::runtime_error(directory + ": could not create the temporary folder " + temporary.string() + ": " + error.message());
  }
  try {
    fill(temporary);
    // Swap the finished folder in: the old one (if any) aside, the new one in place, the old one away.
    const bool replacing = fs::exists(target, error);
    if (replacing) fs::rename(target, old);
    try {
      fs::rename(temporary, target);
    } catch (...) {
      if (replacing) fs::rename(old, target, error);  // put the previous folder back
      throw;
    }
    if (replacing) fs::remove_all(old, error);
  } catch (const fs::filesystem_error& e) {
    fs::remove_all(temporary, error);
    throw std::runtime_error(directory + ": " + e.what());
  } catch (...) {
    fs::remove_all(temporary, error);
    throw;
  }
}

}  // namespace lpstereo::io::synth_detail
