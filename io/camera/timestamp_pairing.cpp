#include "io/camera/timestamp_pairing.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace lpstereo::io {

int64_t default_pairing_tolerance_ns(double frame_rate_hz) {
  const double rate_hz = frame_rate_hz > 0 ? frame_rate_hz : 30.0;
  return static_cast<int64_t>(std::llround(0.5e9 / rate_hz));
}

void check_timestamp_pairing_settings(int64_t tolerance_ns, size_t max_queued_per_side) {
  if (tolerance_ns < 0) {
    throw std::invalid_argument("timestamp pairing: tolerance_ns must be >= 0, got " + std::to_string(tolerance_ns));
  }
  if (max_queued_per_side < 1) {
    throw std::invalid_argument("timestamp pairing: max_queued_per_side must be >= 1, got 0");
  }
}

PairingStep next_pairing_step(std::optional<int64_t> left_oldest_ns, std::optional<int64_t> left_next_ns,
                              std::optional<int64_t> right_oldest_ns, std::optional<int64_t> right_next_ns,
                              int64_t tolerance_ns) {
  if (!left_oldest_ns || !right_oldest_ns) return PairingStep::wait;
  const int64_t left_ns = *left_oldest_ns;
  const int64_t right_ns = *right_oldest_ns;
  const int64_t difference_ns = left_ns > right_ns ? left_ns - right_ns : right_ns - left_ns;
  if (difference_ns > tolerance_ns) {
    // The older one cannot pair with anything that comes later on the other side.
    return left_ns < right_ns ? PairingStep::discard_left : PairingStep::discard_right;
  }
  // Within the tolerance, but the other side's next frame may be the better partner (a tolerance
  // wider than half the period, or jitter): then the other side's oldest is the odd one out.
  const auto distance = [](int64_t a, int64_t b) { return a > b ? a - b : b - a; };
  if (right_next_ns && distance(*right_next_ns, left_ns) < difference_ns) return PairingStep::discard_right;
  if (left_next_ns && distance(*left_next_ns, right_ns) < difference_ns) return PairingStep::discard_left;
  return PairingStep::pair;
}

}  // namespace lpstereo::io
