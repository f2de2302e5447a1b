#include "arm/obstacles3d/disparity_coverage.h"

#include <stdexcept>
#include <string>

#include "arm/obstacles3d/parameter_check.h"

namespace lpstereo::arm::obstacles3d {

void DisparityCoverageParameters::validate() const {
  require_parameter(degraded_invalid_share > 0 && degraded_invalid_share <= 1, "degraded_invalid_share", "(0, 1]", degraded_invalid_share);
}

DisparityCoverage disparity_coverage(const Plane& disparity_q4, int16_t invalid_q4, const DisparityCoverageParameters& parameters,
                                     ArmWork* work) {
  parameters.validate();
  if (disparity_q4.format().type != ElementType::s16) {
    throw std::invalid_argument("disparity_coverage: expected an s16 disparity map (Q4), got another element type");
  }
  const int64_t pixels = static_cast<int64_t>(disparity_q4.width()) * disparity_q4.height();
  int64_t invalid_pixels = 0;
  for (int y = 0; y < disparity_q4.height(); ++y) {
    const int16_t* row = disparity_q4.row<int16_t>(y);
    for (int x = 0; x < disparity_q4.width(); ++x) invalid_pixels += row[x] == invalid_q4 ? 1 : 0;
  }
  const DisparityCoverage coverage = coverage_of_invalid_count(invalid_pixels, pixels, parameters);
  if (work != nullptr) {
    work->scalar_ops += 2 * static_cast<uint64_t>(coverage.pixels);
    work->memory_bytes += 2 * static_cast<uint64_t>(coverage.pixels);
  }
  return coverage;
}

DisparityCoverage coverage_of_invalid_count(int64_t invalid_pixels, int64_t pixels, const DisparityCoverageParameters& parameters) {
  parameters.validate();
  if (pixels < 0 || invalid_pixels < 0 || invalid_pixels > pixels) {
    throw std::invalid_argument("disparity_coverage: expected 0 <= invalid pixels <= pixels, got " + std::to_string(invalid_pixels) +
                                " invalid of " + std::to_string(pixels));
  }
  DisparityCoverage coverage;
  coverage.pixels = pixels;
  coverage.invalid_pixels = invalid_pixels;
  coverage.invalid_share = pixels > 0 ? static_cast<double>(invalid_pixels) / static_cast<double>(pixels) : 0.0;
  coverage.degraded = pixels == 0 || coverage.invalid_share >= parameters.degraded_invalid_share;
  return coverage;
}

}  // namespace lpstereo::arm::obstacles3d
