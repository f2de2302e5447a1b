#include "io/camera/v4l2_stereo_source.h"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "io/camera/timestamp_pairing.h"
#include "io/camera/v4l2_device.h"

namespace lpstereo::io {

namespace {

using Clock = std::chrono::steady_clock;

std::chrono::milliseconds remaining_until(Clock::time_point deadline) {
  const auto remaining = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return remaining.count() > 0 ? remaining : std::chrono::milliseconds(0);
}

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

std::string rate_text(double frame_rate_hz) {
  if (frame_rate_hz <= 0) return "an unknown rate";
  std::ostringstream text;
  text.precision(4);
  text << "at " << frame_rate_hz << " fps";
  return text.str();
}

std::optional<CameraPixelFormat> requested_format(const SourceOptions& options) {
  if (options.pixel_format.empty()) return std::nullopt;
  return pixel_format_from_name(options.pixel_format);
}

// The options a device cannot be asked for, refused before any device is opened.
void check_options(const SourceOptions& options, bool side_by_side) {
  const std::string kind = side_by_side ? "v4l2-sbs" : "v4l2";
  if (!options.pixel_format.empty() && !requested_format(options)) {
    throw std::invalid_argument(kind + ": pixel format '" + options.pixel_format +
                                "' unknown, expected one of GREY YUYV UYVY NV12 RGB888 BGR888");
  }
  if (options.width < 0 || options.height < 0 || (options.width == 0) != (options.height == 0)) {
    throw std::invalid_argument(kind + ": size " + size_text(options.width, options.height) +
                                ": expected both positive, or 0x0 for the device's current size");
  }
  if (!(options.frame_rate_hz >= 0)) {
    throw std::invalid_argument(kind + ": frame rate " + std::to_string(options.frame_rate_hz) +
                                " Hz: expected >= 0 (0 = the device's current)");
  }
  if (options.buffer_count < 2) {
    throw std::invalid_argument(kind + ": buffer count " + std::to_string(options.buffer_count) + ": expected >= 2");
  }
  if (options.pairing_tolerance_ns < -1) {
    throw std::invalid_argument(kind + ": pairing tolerance " + std::to_string(options.pairing_tolerance_ns) +
                                " ns: expected >= 0 (or -1 = half the frame period)");
  }
}

// Opens and configures one device (format, size, rate); streaming starts later, once every
// device of the source is configured (so a failure on the second leaves nothing streaming).
std::unique_ptr<V4l2CaptureDevice> open_configured(const std::string& path, int width, int height,
                                                   const SourceOptions& options) {
  auto device = std::make_unique<V4l2CaptureDevice>(path);
  device->set_format(requested_format(options), width, height);
  device->set_frame_rate(options.frame_rate_hz);
  return device;
}

std::string format_text(const V4l2CaptureDevice& device) {
  const V4l2Format& format = device.format();
  return std::string(pixel_format_name(format.pixel_format)) + " " + size_text(format.width, format.height);
}

SourceResult terminal(SourceStatus status, const std::string& message) {
  SourceResult result;
  result.status = status;
  result.message = message;
  return result;
}

// ---------------------------------------------------------------------------------------------
// Two devices, paired by timestamp.

class V4l2PairSource final : public StereoSource {
 public:
  V4l2PairSource(const std::string& left_path, const std::string& right_path, const SourceOptions& options)
      : left_(open_configured(left_path, options.width, options.height, options)),
        right_(open_configured(right_path, options.width, options.height, options)),
        pairing_(options.pairing_tolerance_ns >= 0
                     ? options.pairing_tolerance_ns
                     : default_pairing_tolerance_ns(slower_rate(left_->frame_rate_hz(), right_->frame_rate_hz())),
                 kV4l2PairingQueueFrames) {
    const V4l2Format& left = left_->format();
    const V4l2Format& right = right_->format();
    if (left.width != right.width || left.height != right.height) {
      throw SourceError("v4l2: left " + left_->name() + " delivers " + size_text(left.width, left.height) +
                        " and right " + right_->name() + " " + size_text(right.width, right.height) +
                        ": expected one size for both views");
    }
    left_->prepare_buffers(options.buffer_count);
    right_->prepare_buffers(options.buffer_count);
    // Back to back, so that drivers that start their frame clock here run the views in phase.
    left_->stream_on();
    right_->stream_on();
  }

  std::string description() const override {
    std::string text = "v4l2 " + left_->name() + " " + format_text(*left_) + " " + rate_text(left_->frame_rate_hz()) +
                       " + " + right_->name() + " " + format_text(*right_) + " " + rate_text(right_->frame_rate_hz()) +
                       ", paired within " + std::to_string(pairing_.tolerance_ns() / 1000) + " us";
    if (!left_->driver_timestamps() || !right_->driver_timestamps()) text += " (timestamps taken at dequeue)";
    return text;
  }
  int width() const override { return left_->format().width; }
  int height() const override { return left_->format().height; }
  double frame_rate_hz() const override { return slower_rate(left_->frame_rate_hz(), right_->frame_rate_hz()); }

  SourceResult next(std::chrono::milliseconds timeout) override {
    if (stopped_) return *stopped_;
    const Clock::time_point deadline = Clock::now() + timeout;
    bool polled = false;
    for (;;) {
      if (auto pair = pairing_.pop_pair()) {
        SourceResult result;
        result.status = SourceStatus::frame;
        result.frame.left = std::move(pair->first.payload);
        result.frame.right = std::move(pair->second.payload);
        result.frame.left_timestamp_ns = pair->first.timestamp_ns;
        result.frame.right_timestamp_ns = pair->second.timestamp_ns;
        result.frame.left_sequence = pair->first.sequence;
        result.frame.right_sequence = pair->second.sequence;
        result.frame.index = pairs_delivered_++;
        return result;
      }
      // A stalled view with the other still streaming keeps poll() ready: the deadline is checked
      // on every round, after at least one look at the devices.
      if (polled && Clock::now() >= deadline) {
        return terminal(SourceStatus::timeout,
                        "v4l2: no pair within " + std::to_string(timeout.count()) + " ms (" +
                            std::to_string(pairing_.queued(PairingSide::left)) + " left and " +
                            std::to_string(pairing_.queued(PairingSide::right)) + " right frames waiting)");
      }
      // Wait for either device (together, so neither side's wait delays the other's frames).
      pollfd waiting[2] = {{left_->fd(), POLLIN, 0}, {right_->fd(), POLLIN, 0}};
      const int ready = ::poll(waiting, 2, static_cast<int>(remaining_until(deadline).count()));
      polled = true;
      if (ready < 0 && errno != EINTR) {
        return stop(terminal(SourceStatus::disconnected,
                             "v4l2: poll failed while streaming (" + std::string(std::strerror(errno)) + ")"));
      }
      for (int side = 0; side < 2 && ready > 0; ++side) {
        if (waiting[side].revents == 0) continue;
        if (std::optional<SourceResult> lost = drain(side)) return stop(*lost);
      }
    }
  }

  SourceStatistics statistics() const override {
    const PairingCounts& counts = pairing_.counts();
    SourceStatistics statistics;
    statistics.pairs_delivered = pairs_delivered_;
    statistics.left_frames = counts.pushed[0];
    statistics.right_frames = counts.pushed[1];
    statistics.left_driver_drops = counts.driver_drops[0];
    statistics.right_driver_drops = counts.driver_drops[1];
    statistics.left_unpaired = counts.unpaired[0];
    statistics.right_unpaired = counts.unpaired[1];
    return statistics;
  }

 private:
  static double slower_rate(double a, double b) {
    if (a <= 0) return b;
    if (b <= 0) return a;
    return std::min(a, b);
  }

  SourceResult stop(const SourceResult& result) {
    stopped_ = result;
    return result;
  }

  // Every frame the device has ready, converted to luma and its buffer given back at once.
  std::optional<SourceResult> drain(int side) {
    V4l2CaptureDevice& device = side == 0 ? *left_ : *right_;
    for (;;) {
      V4l2Dequeue dequeued = device.dequeue(std::chrono::milliseconds(0));
      if (dequeued.status == SourceStatus::timeout) return std::nullopt;
      if (dequeued.status == SourceStatus::disconnected) return terminal(SourceStatus::disconnected, dequeued.message);
      const V4l2Format& format = device.format();
      PairingFrame<Plane> frame;
      frame.timestamp_ns = dequeued.buffer.timestamp_ns;
      frame.sequence = dequeued.buffer.sequence;
      frame.payload = Plane(format.width, format.height, {ElementType::u8, 0});
      convert_to_luma(format.pixel_format, dequeued.buffer.data, format.bytes_per_line, format.width, format.height,
                      frame.payload);
      device.requeue(dequeued.buffer);
      pairing_.push(side == 0 ? PairingSide::left : PairingSide::right, std::move(frame));
    }
  }

  std::unique_ptr<V4l2CaptureDevice> left_, right_;
  TimestampPairing<Plane> pairing_;
  uint64_t pairs_delivered_ = 0;
  std::optional<SourceResult> stopped_;
};

// ---------------------------------------------------------------------------------------------
// One device, left | right side by side.

class V4l2SideBySideSource final : public StereoSource {
 public:
  V4l2SideBySideSource(const std::string& path, const SourceOptions& options)
      : device_(open_configured(path, options.width * 2, options.height, options)) {
    const V4l2Format& format = device_->format();
    if (format.width % 2 != 0) {
      throw SourceError(device_->name() + ": side by side needs an even width, the device delivers " +
                        size_text(format.width, format.height));
    }
    device_->start(options.buffer_count);
  }

  std::string description() const override {
    std::string text = "v4l2-sbs " + device_->name() + " " + format_text(*device_) + " as two " +
                       size_text(width(), height()) + " views " + rate_text(device_->frame_rate_hz());
    if (!device_->driver_timestamps()) text += " (timestamps taken at dequeue)";
    return text;
  }
  int width() const override { return device_->format().width / 2; }
  int height() const override { return device_->format().height; }
  double frame_rate_hz() const override { return device_->frame_rate_hz(); }

  SourceResult next(std::chrono::milliseconds timeout) override {
    if (stopped_) return *stopped_;
    V4l2Dequeue dequeued = device_->dequeue(timeout);
    if (dequeued.status == SourceStatus::disconnected) {
      stopped_ = terminal(SourceStatus::disconnected, dequeued.message);
      return *stopped_;
    }
    if (dequeued.status == SourceStatus::timeout) {
      return terminal(SourceStatus::timeout,
                      device_->name() + ": no frame within " + std::to_string(timeout.count()) + " ms");
    }
    const V4l2Buffer& buffer = dequeued.buffer;
    if (frames_ > 0 && buffer.sequence > last_sequence_ + 1) driver_drops_ += buffer.sequence - last_sequence_ - 1;
    last_sequence_ = buffer.sequence;
    ++frames_;

    const V4l2Format& format = device_->format();
    const int view_width = width();
    // The right half starts view_width pixels into each row; in 4:2:2 formats that may split a
    // Y-U-Y-V group, which convert_to_luma does not mind (it reads only the Y bytes).
    const size_t right_offset_bytes =
        static_cast<size_t>(view_width) * static_cast<size_t>(pixel_format_bytes_per_pixel(format.pixel_format));
    SourceResult result;
    result.status = SourceStatus::frame;
    result.frame.left = Plane(view_width, format.height, {ElementType::u8, 0});
    result.frame.right = Plane(view_width, format.height, {ElementType::u8, 0});
    convert_to_luma(format.pixel_format, buffer.data, format.bytes_per_line, view_width, format.height,
                    result.frame.left);
    convert_to_luma(format.pixel_format, buffer.data + right_offset_bytes, format.bytes_per_line, view_width,
                    format.height, result.frame.right);
    device_->requeue(buffer);
    result.frame.left_timestamp_ns = result.frame.right_timestamp_ns = buffer.timestamp_ns;
    result.frame.left_sequence = result.frame.right_sequence = buffer.sequence;
    result.frame.index = frames_ - 1;
    return result;
  }

  SourceStatistics statistics() const override {
    SourceStatistics statistics;
    statistics.pairs_delivered = statistics.left_frames = statistics.right_frames = frames_;
    statistics.left_driver_drops = statistics.right_driver_drops = driver_drops_;
    return statistics;
  }

 private:
  std::unique_ptr<V4l2CaptureDevice> device_;
  uint64_t frames_ = 0;
  uint64_t last_sequence_ = 0;
  uint64_t driver_drops_ = 0;
  std::optional<SourceResult> stopped_;
};

}  // namespace

std::unique_ptr<StereoSource> open_v4l2_stereo_source(const std::vector<std::string>& devices, bool side_by_side,
                                                      const SourceOptions& options) {
  check_options(options, side_by_side);
  if (side_by_side) {
    if (devices.size() != 1) {
      throw std::invalid_argument("v4l2-sbs: expected one device, got " + std::to_string(devices.size()));
    }
    return std::make_unique<V4l2SideBySideSource>(devices[0], options);
  }
  if (devices.size() != 2) {
    throw std::invalid_argument("v4l2: expected two devices (left,right), got " + std::to_string(devices.size()));
  }
  if (devices[0] == devices[1]) {
    throw std::invalid_argument("v4l2: left and right are the same device " + devices[0] +
                                " (for one side-by-side device use v4l2-sbs)");
  }
  return std::make_unique<V4l2PairSource>(devices[0], devices[1], options);
}

}  // namespace lpstereo::io
