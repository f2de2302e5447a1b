#include "dag/remap_table.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

namespace lpstereo {

namespace {

// position_px - pixel in Q10.5: the source position rounded to the nearest 1/32 px (ties to even,
// as OpenCV's cvRound in cv::remap), minus the pixel's own coordinate; or an error naming the pixel
// and axis.
int16_t to_q5(float position_px, int pixel, int x, int y, const char* axis) {
  constexpr double kMinPx = std::numeric_limits<int16_t>::min() / 32.0;
  constexpr double kMaxPx = std::numeric_limits<int16_t>::max() / 32.0;
  const double delta_px = static_cast<double>(position_px) - pixel;
  // position * 32 is exact in double; nearbyint rounds ties to even in the default rounding mode.
  const double scaled = std::nearbyint(static_cast<double>(position_px) * 32.0) - 32.0 * pixel;
  if (!std::isfinite(delta_px) || scaled < std::numeric_limits<int16_t>::min() ||
      scaled > std::numeric_limits<int16_t>::max()) {
    std::ostringstream message;
    message << "remap map: pixel (" << x << ", " << y << "): source_" << axis << " - " << axis
            << ": expected a finite displacement in [" << kMinPx << ", " << kMaxPx << "] px (Q10.5), got "
            << delta_px << " px";
    throw std::invalid_argument(message.str());
  }
  return static_cast<int16_t>(scaled);
}

void check_size(int width, int height) {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("remap map size: expected width and height > 0, got " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
}

}  // namespace

Plane make_remap_q5_from_float(const float* map_x, const float* map_y, int width, int height,
                               ptrdiff_t stride_elements) {
  check_size(width, height);
  if (stride_elements < width) {
    throw std::invalid_argument("remap map stride: expected >= " + std::to_string(width) + " floats, got " +
                                std::to_string(stride_elements));
  }
  if (map_x == nullptr || map_y == nullptr) throw std::invalid_argument("remap map: map_x and map_y must not be null");
  Plane map(width, height, {ElementType::remap_q5, 0});
  for (int y = 0; y < height; ++y) {
    const float* row_x = map_x + static_cast<ptrdiff_t>(y) * stride_elements;
    const float* row_y = map_y + static_cast<ptrdiff_t>(y) * stride_elements;
    int16_t* out = map.row<int16_t>(y);
    for (int x = 0; x < width; ++x) {
      out[2 * x] = to_q5(row_x[x], x, x, y, "x");
      out[2 * x + 1] = to_q5(row_y[x], y, x, y, "y");
    }
  }
  return map;
}

void make_synthetic_rectification_float(int width, int height, const SyntheticRectification& model,
                                        std::vector<float>& map_x, std::vector<float>& map_y) {
  check_size(width, height);
  auto check = [](const char* name, double value, double low, double high) {
    if (!(value >= low && value <= high)) {
      std::ostringstream message;
      message << "synthetic rectification: " << name << ": expected [" << low << ", " << high << "], got " << value;
      throw std::invalid_argument(message.str());
    }
  };
  check("rotation_rad", model.rotation_rad, -0.2, 0.2);
  check("scale", model.scale, 0.5, 2.0);
  check("k1", model.k1, -1.0, 1.0);
  check("focal_px", model.focal_px, 0.0, 1e6);
  const double focal_px = model.focal_px > 0 ? model.focal_px : static_cast<double>(width > height ? width : height);
  const double centre_x = (width - 1) / 2.0;
  const double centre_y = (height - 1) / 2.0;
  const double cos_a = std::cos(model.rotation_rad) * model.scale;
  const double sin_a = std::sin(model.rotation_rad) * model.scale;
  map_x.resize(static_cast<size_t>(width) * height);
  map_y.resize(map_x.size());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double a = (x - centre_x) / focal_px;
      const double b = (y - centre_y) / focal_px;
      const double u = cos_a * a - sin_a * b;
      const double v = sin_a * a + cos_a * b;
      const double radial = 1.0 + model.k1 * (u * u + v * v);
      const size_t index = static_cast<size_t>(y) * width + x;
      map_x[index] = static_cast<float>(centre_x + focal_px * radial * u);
      map_y[index] = static_cast<float>(centre_y + focal_px * radial * v);
    }
  }
}

Plane make_synthetic_rectification_map(int width, int height, const SyntheticRectification& model) {
  std::vector<float> map_x;
  std::vector<float> map_y;
  make_synthetic_rectification_float(width, height, model, map_x, map_y);
  return make_remap_q5_from_float(map_x.data(), map_y.data(), width, height, width);
}

}  // namespace lpstereo
