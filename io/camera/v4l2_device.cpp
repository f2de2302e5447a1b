#include "io/camera/v4l2_device.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace lpstereo::io {

namespace {

// ioctl, retried when a signal interrupted it (the V4L2 examples' xioctl).
int xioctl(int fd, unsigned long request, void* argument) {
  int result;
  do {
    result = ::ioctl(fd, request, argument);
  } while (result == -1 && errno == EINTR);
  return result;
}

int64_t monotonic_now_ns() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return int64_t{now.tv_sec} * 1000000000 + now.tv_nsec;
}

std::string error_text(int error) { return std::string(std::strerror(error)); }

// Errors that mean the device is gone rather than a bug in the call: the node was removed
// (ENODEV, ENXIO), or the driver failed its queue for good (EIO; vb2 answers DQBUF so then).
bool is_disconnect_error(int error) { return error == ENODEV || error == ENXIO || error == EIO; }

std::string file_kind(mode_t mode) {
  if (S_ISREG(mode)) return "a regular file";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a pipe";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISLNK(mode)) return "a symbolic link";
  return "not a character device";
}

// What a node is, from its capabilities, for "expected a video capture device, got ...".
std::string capabilities_text(uint32_t capabilities) {
  struct Named {
    uint32_t bit;
    const char* name;
  };
  static constexpr Named kNames[] = {
      {V4L2_CAP_VIDEO_CAPTURE, "video capture"},
      {V4L2_CAP_VIDEO_CAPTURE_MPLANE, "multi-planar video capture"},
      {V4L2_CAP_VIDEO_OUTPUT, "video output"},
      {V4L2_CAP_VIDEO_OUTPUT_MPLANE, "multi-planar video output"},
      {V4L2_CAP_VIDEO_M2M, "memory-to-memory"},
      {V4L2_CAP_VIDEO_M2M_MPLANE, "multi-planar memory-to-memory"},
      {V4L2_CAP_VBI_CAPTURE, "VBI capture"},
      {V4L2_CAP_VBI_OUTPUT, "VBI output"},
      {V4L2_CAP_SLICED_VBI_CAPTURE, "sliced VBI capture"},
      {V4L2_CAP_RADIO, "radio"},
      {V4L2_CAP_SDR_CAPTURE, "SDR capture"},
      {V4L2_CAP_META_CAPTURE, "metadata capture"},
      {V4L2_CAP_META_OUTPUT, "metadata output"},
      {V4L2_CAP_TOUCH, "touch"},
      {V4L2_CAP_STREAMING, "streaming"},
      {V4L2_CAP_READWRITE, "read/write"},
  };
  std::string text;
  for (const Named& named : kNames) {
    if (capabilities & named.bit) text += (text.empty() ? "" : ", ") + std::string(named.name);
  }
  return text.empty() ? "no capabilities" : text;
}

std::string field_text(uint32_t field) {
  switch (field) {
    case V4L2_FIELD_ANY: return "any";
    case V4L2_FIELD_NONE: return "progressive";
    case V4L2_FIELD_TOP: return "top field";
    case V4L2_FIELD_BOTTOM: return "bottom field";
    case V4L2_FIELD_INTERLACED: return "interlaced";
    case V4L2_FIELD_SEQ_TB: return "sequential top-bottom";
    case V4L2_FIELD_SEQ_BT: return "sequential bottom-top";
    case V4L2_FIELD_ALTERNATE: return "alternate fields";
    case V4L2_FIELD_INTERLACED_TB: return "interlaced top-bottom";
    case V4L2_FIELD_INTERLACED_BT: return "interlaced bottom-top";
  }
  return "field " + std::to_string(field);
}

}  // namespace

std::string fourcc_text(uint32_t fourcc) {
  std::string text;
  for (int shift = 0; shift < 32; shift += 8) {
    const char character = static_cast<char>((fourcc >> shift) & 0xff);
    text += (character >= 0x20 && character < 0x7f) ? character : '?';
  }
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

V4l2CaptureDevice::V4l2CaptureDevice(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    if (error == ENOENT) fail("expected a V4L2 video capture device, got no such file");
    fail("cannot open (" + error_text(error) + ")");
  }
  struct stat status{};
  if (::fstat(fd_, &status) != 0 || !S_ISCHR(status.st_mode)) {
    const std::string kind = file_kind(status.st_mode);
    ::close(fd_);
    fd_ = -1;
    fail("expected a V4L2 video capture device, got " + kind);
  }
  v4l2_capability capability{};
  if (xioctl(fd_, VIDIOC_QUERYCAP, &capability) != 0) {
    const int error = errno;
    ::close(fd_);
    fd_ = -1;
    fail("expected a V4L2 video capture device, got a character device that is not V4L2 (VIDIOC_QUERYCAP: " +
         error_text(error) + ")");
  }
  driver_ = reinterpret_cast<const char*>(capability.driver);
  card_ = reinterpret_cast<const char*>(capability.card);
  // device_caps describes this node; capabilities the whole physical device (all its nodes).
  const uint32_t node_capabilities =
      (capability.capabilities & V4L2_CAP_DEVICE_CAPS) ? capability.device_caps : capability.capabilities;
  if (!(node_capabilities & V4L2_CAP_VIDEO_CAPTURE) || !(node_capabilities & V4L2_CAP_STREAMING)) {
    const std::string what = capabilities_text(node_capabilities);
    ::close(fd_);
    fd_ = -1;
    fail("expected a single-planar video capture device with streaming I/O, got " + what + " ('" + card_ + "')");
  }
}

V4l2CaptureDevice::~V4l2CaptureDevice() {
  stop();
  if (fd_ >= 0) ::close(fd_);
}

std::string V4l2CaptureDevice::name() const { return driver_.empty() ? path_ : path_ + " (" + driver_ + ")"; }

void V4l2CaptureDevice::fail(const std::string& message) const { throw SourceError(name() + ": " + message); }

std::vector<std::string> V4l2CaptureDevice::offered_fourccs() const {
  std::vector<std::string> fourccs;
  for (uint32_t index = 0;; ++index) {
    v4l2_fmtdesc description{};
    description.index = index;
    description.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd_, VIDIOC_ENUM_FMT, &description) != 0) break;
    fourccs.push_back(fourcc_text(description.pixelformat));
  }
  return fourccs;
}

std::vector<CameraPixelFormat> V4l2CaptureDevice::supported_formats() const {
  std::vector<CameraPixelFormat> formats;
  for (uint32_t index = 0;; ++index) {
    v4l2_fmtdesc description{};
    description.index = index;
    description.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(fd_, VIDIOC_ENUM_FMT, &description) != 0) break;
    if (const auto format = pixel_format_from_fourcc(description.pixelformat)) formats.push_back(*format);
  }
  return formats;
}

void V4l2CaptureDevice::select_input(int index) {
  int input = index;
  if (xioctl(fd_, VIDIOC_S_INPUT, &input) != 0) {
    fail("VIDIOC_S_INPUT " + std::to_string(index) + " failed (" + error_text(errno) + ")");
  }
}

void V4l2CaptureDevice::set_control(uint32_t control_id, int32_t value) {
  v4l2_control control{};
  control.id = control_id;
  control.value = value;
  if (xioctl(fd_, VIDIOC_S_CTRL, &control) != 0) {
    char id_text[16];
    std::snprintf(id_text, sizeof id_text, "0x%08x", control_id);
    fail("VIDIOC_S_CTRL " + std::string(id_text) + " = " + std::to_string(value) + " failed (" + error_text(errno) +
         ")");
  }
}

V4l2Format V4l2CaptureDevice::set_format(std::optional<CameraPixelFormat> requested, int width, int height) {
  if (streaming_) fail("set_format while streaming");
  const std::vector<CameraPixelFormat> supported = supported_formats();
  auto offered_list = [&] {
    std::string list;
    for (const std::string& fourcc : offered_fourccs()) list += (list.empty() ? "" : " ") + fourcc;
    return list.empty() ? std::string("none") : list;
  };
  auto offers = [&](CameraPixelFormat format) {
    for (CameraPixelFormat candidate : supported) {
      if (candidate == format) return true;
    }
    return false;
  };
  std::optional<CameraPixelFormat> chosen;
  if (requested) {
    if (!offers(*requested)) {
      fail("pixel format " + std::string(pixel_format_name(*requested)) + " requested, the device offers " +
           offered_list());
    }
    chosen = requested;
  } else {
    for (CameraPixelFormat format : kCameraPixelFormatPreference) {
      if (offers(format)) {
        chosen = format;
        break;
      }
    }
    if (!chosen) fail("expected one of GREY NV12 YUYV UYVY RGB3 BGR3, the device offers " + offered_list());
  }

  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_G_FMT, &format) != 0) fail("VIDIOC_G_FMT failed (" + error_text(errno) + ")");
  const uint32_t fourcc = pixel_format_fourcc(*chosen);
  format.fmt.pix.pixelformat = fourcc;
  if (width > 0 && height > 0) {
    format.fmt.pix.width = static_cast<uint32_t>(width);
    format.fmt.pix.height = static_cast<uint32_t>(height);
  }
  format.fmt.pix.field = V4L2_FIELD_NONE;
  format.fmt.pix.bytesperline = 0;  // the driver's minimum
  if (xioctl(fd_, VIDIOC_S_FMT, &format) != 0) {
    fail("VIDIOC_S_FMT " + std::string(pixel_format_name(*chosen)) + " " + std::to_string(width) + "x" +
         std::to_string(height) + " failed (" + error_text(errno) + ")");
  }
  const v4l2_pix_format& answer = format.fmt.pix;
  if (answer.pixelformat != fourcc) {
    fail("pixel format " + fourcc_text(fourcc) + " requested, the driver set " + fourcc_text(answer.pixelformat));
  }
  if (width > 0 && height > 0 &&
      (answer.width != static_cast<uint32_t>(width) || answer.height != static_cast<uint32_t>(height))) {
    fail("size " + std::to_string(width) + "x" + std::to_string(height) + " requested, the driver set " +
         std::to_string(answer.width) + "x" + std::to_string(answer.height));
  }
  // A frame must hold the whole picture: progressive, or both fields interleaved.
  if (answer.field != V4L2_FIELD_NONE && answer.field != V4L2_FIELD_INTERLACED &&
      answer.field != V4L2_FIELD_INTERLACED_TB && answer.field != V4L2_FIELD_INTERLACED_BT) {
    fail("expected progressive or interlaced frames, the driver set " + field_text(answer.field));
  }
  V4l2Format negotiated;
  negotiated.pixel_format = *chosen;
  negotiated.width = static_cast<int>(answer.width);
  negotiated.height = static_cast<int>(answer.height);
  negotiated.bytes_per_line = answer.bytesperline;
  negotiated.size_image = answer.sizeimage;
  const size_t row_bytes = static_cast<size_t>(negotiated.width) *
                           static_cast<size_t>(pixel_format_bytes_per_pixel(negotiated.pixel_format));
  if (negotiated.bytes_per_line < row_bytes) {
    fail("bytesperline " + std::to_string(negotiated.bytes_per_line) + " is less than a " +
         std::string(pixel_format_name(negotiated.pixel_format)) + " row of " + std::to_string(negotiated.width) +
         " px (" + std::to_string(row_bytes) + " bytes)");
  }
  const size_t needed = pixel_format_min_buffer_bytes(negotiated.pixel_format, negotiated.width, negotiated.height,
                                                      negotiated.bytes_per_line);
  if (negotiated.size_image < needed) {
    fail("sizeimage " + std::to_string(negotiated.size_image) + " is less than the " + std::to_string(needed) +
         " bytes of a " + std::string(pixel_format_name(negotiated.pixel_format)) + " " +
         std::to_string(negotiated.width) + "x" + std::to_string(negotiated.height) + " frame");
  }
  format_ = negotiated;
  return negotiated;
}

double V4l2CaptureDevice::set_frame_rate(double frame_rate_hz) {
  v4l2_streamparm parameters{};
  parameters.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_G_PARM, &parameters) != 0) {
    frame_rate_hz_ = 0;  // a driver without VIDIOC_G_PARM does not say its rate
    return frame_rate_hz_;
  }
  if (frame_rate_hz > 0 && (parameters.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
    // The interval as a fraction in ms steps: 30 Hz = 1000/30000 s (the driver picks its nearest).
    parameters.parm.capture.timeperframe.numerator = 1000;
    parameters.parm.capture.timeperframe.denominator = static_cast<uint32_t>(std::lround(frame_rate_hz * 1000));
    if (xioctl(fd_, VIDIOC_S_PARM, &parameters) != 0) {
      fail("VIDIOC_S_PARM " + std::to_string(frame_rate_hz) + " Hz failed (" + error_text(errno) + ")");
    }
  }
  const v4l2_fract interval = parameters.parm.capture.timeperframe;
  frame_rate_hz_ = interval.numerator > 0 ? static_cast<double>(interval.denominator) / interval.numerator : 0;
  return frame_rate_hz_;
}

void V4l2CaptureDevice::prepare_buffers(int buffer_count) {
  if (streaming_ || !mappings_.empty()) fail("buffers prepared twice");
  if (format_.width == 0) fail("buffers prepared before set_format");
  v4l2_requestbuffers request{};
  request.count = static_cast<uint32_t>(buffer_count < 2 ? 2 : buffer_count);
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  if (xioctl(fd_, VIDIOC_REQBUFS, &request) != 0) {
    fail("expected memory-mapped streaming, VIDIOC_REQBUFS failed (" + error_text(errno) + ")");
  }
  // One buffer would leave the driver nothing to fill while the application holds it.
  if (request.count < 2) fail("expected at least 2 buffers, the driver gave " + std::to_string(request.count));
  for (uint32_t index = 0; index < request.count; ++index) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    buffer.index = index;
    if (xioctl(fd_, VIDIOC_QUERYBUF, &buffer) != 0) {
      fail("VIDIOC_QUERYBUF " + std::to_string(index) + " failed (" + error_text(errno) + ")");
    }
    if (buffer.length < format_.size_image) {
      fail("buffer " + std::to_string(index) + " has " + std::to_string(buffer.length) + " bytes, expected at least " +
           std::to_string(format_.size_image));
    }
    void* address = ::mmap(nullptr, buffer.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buffer.m.offset);
    if (address == MAP_FAILED) fail("mmap of buffer " + std::to_string(index) + " failed (" + error_text(errno) + ")");
    mappings_.push_back({address, buffer.length});
    if (xioctl(fd_, VIDIOC_QBUF, &buffer) != 0) {
      fail("VIDIOC_QBUF " + std::to_string(index) + " failed (" + error_text(errno) + ")");
    }
  }
}

void V4l2CaptureDevice::stream_on() {
  if (streaming_) return;
  if (mappings_.empty()) fail("STREAMON before the buffers were prepared");
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(fd_, VIDIOC_STREAMON, &type) != 0) fail("VIDIOC_STREAMON failed (" + error_text(errno) + ")");
  streaming_ = true;
  have_sequence_ = false;
}

V4l2Dequeue V4l2CaptureDevice::disconnect(const std::string& message) {
  if (!disconnected_) {
    disconnected_ = true;
    disconnect_message_ = name() + ": disconnected while streaming (" + message + ")";
  }
  V4l2Dequeue result;
  result.status = SourceStatus::disconnected;
  result.message = disconnect_message_;
  return result;
}

V4l2Dequeue V4l2CaptureDevice::try_dequeue() {
  for (;;) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd_, VIDIOC_DQBUF, &buffer) != 0) {
      const int error = errno;
      if (error == EAGAIN) return {};
      if (is_disconnect_error(error)) return disconnect("VIDIOC_DQBUF: " + error_text(error));
      fail("VIDIOC_DQBUF failed (" + error_text(error) + ")");
    }
    V4l2Buffer captured;
    captured.index = static_cast<int>(buffer.index);
    captured.data = static_cast<const uint8_t*>(mappings_.at(buffer.index).address);
    captured.bytes_used = buffer.bytesused > 0 ? buffer.bytesused : buffer.length;
    // The driver's 32-bit sequence, unwrapped: a smaller value than the last one is a wrap.
    if (have_sequence_ && buffer.sequence < last_sequence32_) sequence_high_ += uint64_t{1} << 32;
    last_sequence32_ = buffer.sequence;
    have_sequence_ = true;
    captured.sequence = sequence_high_ + buffer.sequence;
    driver_timestamps_ = (buffer.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
    captured.timestamp_ns = driver_timestamps_
                                ? int64_t{buffer.timestamp.tv_sec} * 1000000000 + int64_t{buffer.timestamp.tv_usec} * 1000
                                : monotonic_now_ns();
    const size_t needed = pixel_format_min_buffer_bytes(format_.pixel_format, format_.width, format_.height,
                                                        format_.bytes_per_line);
    if ((buffer.flags & V4L2_BUF_FLAG_ERROR) || captured.bytes_used < needed) {
      // A frame the driver says is damaged, or shorter than the format: skipped, given back.
      ++corrupt_buffers_;
      requeue(captured);
      if (disconnected_) return disconnect(disconnect_message_);
      continue;
    }
    V4l2Dequeue result;
    result.status = SourceStatus::frame;
    result.buffer = captured;
    return result;
  }
}

V4l2Dequeue V4l2CaptureDevice::dequeue(std::chrono::milliseconds timeout) {
  if (disconnected_) return disconnect(disconnect_message_);
  if (!streaming_) fail("dequeue before start");
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  bool polled = false;
  for (;;) {
    V4l2Dequeue result = try_dequeue();
    if (result.status != SourceStatus::timeout) return result;
    const auto remaining = std::max<std::chrono::milliseconds::rep>(
        0, std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count());
    // At least one poll (it is what reports a removed device), and none once the deadline passed.
    if (polled && remaining == 0) return result;
    pollfd waiting{fd_, POLLIN, 0};
    const int ready = ::poll(&waiting, 1, static_cast<int>(remaining));
    polled = true;
    if (ready < 0 && errno != EINTR) return disconnect("poll: " + error_text(errno));
    if (ready > 0 && (waiting.revents & (POLLERR | POLLHUP | POLLNVAL)) && !(waiting.revents & POLLIN)) {
      // No frame but an error condition: the DQBUF tells which (a removed node answers ENODEV).
      result = try_dequeue();
      if (result.status != SourceStatus::timeout) return result;
      return disconnect(std::string("poll: ") + ((waiting.revents & POLLHUP) ? "POLLHUP" : "POLLERR"));
    }
    if (ready == 0) return try_dequeue();  // the wait ran out: one last look
  }
}

void V4l2CaptureDevice::requeue(const V4l2Buffer& captured) {
  if (disconnected_ || !streaming_) return;
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.index = static_cast<uint32_t>(captured.index);
  if (xioctl(fd_, VIDIOC_QBUF, &buffer) != 0) {
    const int error = errno;
    if (is_disconnect_error(error)) {
      disconnect("VIDIOC_QBUF: " + error_text(error));
      return;
    }
    fail("VIDIOC_QBUF " + std::to_string(captured.index) + " failed (" + error_text(error) + ")");
  }
}

void V4l2CaptureDevice::stop() {
  if (fd_ < 0) return;
  if (streaming_) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    xioctl(fd_, VIDIOC_STREAMOFF, &type);  // fails with ENODEV on a removed device: nothing to stop then
    streaming_ = false;
  }
  for (const Mapping& mapping : mappings_) ::munmap(mapping.address, mapping.length);
  if (!mappings_.empty()) {
    mappings_.clear();
    v4l2_requestbuffers release{};
    release.count = 0;
    release.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    release.memory = V4L2_MEMORY_MMAP;
    xioctl(fd_, VIDIOC_REQBUFS, &release);
  }
}

}  // namespace lpstereo::io
