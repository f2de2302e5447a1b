// One V4L2 video capture device (a /dev/videoN node): opened non-blocking, checked to be a
// single-planar capture device that streams, a pixel format negotiated, a frame rate requested,
// memory-mapped buffers streamed, and each frame dequeued with a bounded wait.
//
// What the V4L2 API asks for, in the order this class does it (the kernel's
// Documentation/userspace-api/media/v4l/ "Streaming I/O (Memory Mapping)"):
//   open(O_RDWR | O_NONBLOCK)  a non-blocking fd, so VIDIOC_DQBUF returns EAGAIN instead of waiting
//                              and every wait is a poll() with a timeout (never a hang);
//   VIDIOC_QUERYCAP            device_caps (the node's own) must have VIDEO_CAPTURE and STREAMING;
//   VIDIOC_ENUM_FMT            the formats offered; the requested one, or the first of
//                              kCameraPixelFormatPreference (io/camera/pixel_format.h) offered;
//   VIDIOC_S_FMT               the size asked for; the driver answers with what it will deliver, and
//                              the answer (format, size, bytesperline, sizeimage, field) is checked;
//   VIDIOC_S_PARM / G_PARM     the frame interval (the driver rounds it: the actual rate is reported);
//   VIDIOC_REQBUFS, QUERYBUF, mmap, QBUF, STREAMON   the buffers, all queued, then streaming;
//   poll + VIDIOC_DQBUF        the next filled buffer; QBUF gives it back once converted.
// Timestamps are the driver's when it stamps them on CLOCK_MONOTONIC (V4L2_BUF_FLAG_TIMESTAMP_
// MONOTONIC, what vb2 drivers do); otherwise the time of the dequeue on CLOCK_MONOTONIC, which the
// description says. Sequence numbers are the driver's 32-bit counter unwrapped to 64 bits.
// A device that goes away (ENODEV; EIO, which vb2 returns when its queue failed; poll's
// POLLERR/POLLHUP without a buffer) is reported `disconnected` and stays so; the destructor still
// stops streaming, unmaps and closes (a removed device accepts munmap and close).
//
// Errors: SourceError, one line naming the device (path and, once known, driver), what was expected
// and what the device gave.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "io/camera/pixel_format.h"
#include "io/camera/stereo_source.h"

namespace lpstereo::io {

// The negotiated format: what the driver answered to VIDIOC_S_FMT.
struct V4l2Format {
  CameraPixelFormat pixel_format = CameraPixelFormat::grey;
  int width = 0;                     // px
  int height = 0;
  size_t bytes_per_line = 0;         // of the first plane (NV12: of the Y and the UV plane)
  size_t size_image = 0;             // bytes of one frame
};

// A filled buffer, valid until it is given back with requeue().
struct V4l2Buffer {
  int index = -1;                    // the driver's buffer index
  const uint8_t* data = nullptr;     // the mapped frame
  size_t bytes_used = 0;
  int64_t timestamp_ns = 0;          // CLOCK_MONOTONIC
  uint64_t sequence = 0;             // unwrapped
};

struct V4l2Dequeue {
  SourceStatus status = SourceStatus::timeout;  // frame, timeout or disconnected
  V4l2Buffer buffer;                 // status == frame
  std::string message;               // disconnected: one line (device, call, error)
};

class V4l2CaptureDevice {
 public:
  // Opens `path` non-blocking and checks VIDIOC_QUERYCAP (see the header comment).
  explicit V4l2CaptureDevice(const std::string& path);
  ~V4l2CaptureDevice();
  V4l2CaptureDevice(const V4l2CaptureDevice&) = delete;
  V4l2CaptureDevice& operator=(const V4l2CaptureDevice&) = delete;

  const std::string& path() const { return path_; }
  const std::string& driver() const { return driver_; }   // "vivid", "uvcvideo", ...
  const std::string& card() const { return card_; }       // "vivid-000-vid-cap"
  // "/dev/video0 (vivid)": how errors and descriptions name the device.
  std::string name() const;
  int fd() const { return fd_; }

  // The fourccs VIDIOC_ENUM_FMT lists, as text ("YUYV", "NV12", ...), and those lpstereo converts.
  std::vector<std::string> offered_fourccs() const;
  std::vector<CameraPixelFormat> supported_formats() const;

  // VIDIOC_S_INPUT (index as VIDIOC_ENUMINPUT numbers them). Not while streaming.
  void select_input(int index);
  // VIDIOC_S_CTRL; throws SourceError naming the control id and the value.
  void set_control(uint32_t control_id, int32_t value);

  // Negotiates `requested` (nullopt: the first of kCameraPixelFormatPreference offered) at
  // width x height (0 x 0: the device's current size). Not while streaming.
  V4l2Format set_format(std::optional<CameraPixelFormat> requested, int width, int height);
  const V4l2Format& format() const { return format_; }
  // Requests frame_rate_hz (> 0) with VIDIOC_S_PARM when the driver has V4L2_CAP_TIMEPERFRAME,
  // then returns the rate it runs at (VIDIOC_G_PARM; 0 when the driver does not say).
  double set_frame_rate(double frame_rate_hz);
  double frame_rate_hz() const { return frame_rate_hz_; }

  // REQBUFS(buffer_count, at least 2), map, queue all, STREAMON.
  void start(int buffer_count) {
    prepare_buffers(buffer_count);
    stream_on();
  }
  // start() in two steps, so that two devices can be switched on back to back: a driver that
  // starts its frame clock at STREAMON (vivid does) then runs both views nearly in phase, which
  // keeps their timestamps well inside the pairing tolerance.
  void prepare_buffers(int buffer_count);  // REQBUFS, QUERYBUF, mmap, QBUF
  void stream_on();                        // STREAMON
  bool streaming() const { return streaming_; }
  // Whether the timestamps are the driver's (true) or taken at the dequeue (false).
  bool driver_timestamps() const { return driver_timestamps_; }

  // The next filled buffer within `timeout` (0: only what is ready now). Never waits longer.
  V4l2Dequeue dequeue(std::chrono::milliseconds timeout);
  // Gives a dequeued buffer back to the driver. A failure here means the device went away: it is
  // remembered and the next dequeue() reports it.
  void requeue(const V4l2Buffer& buffer);
  // Buffers the driver marked V4L2_BUF_FLAG_ERROR or filled short: skipped, given back, not
  // delivered (the gap they leave in the delivered sequence numbers counts them as drops).
  uint64_t corrupt_buffers() const { return corrupt_buffers_; }

  // STREAMOFF, munmap, REQBUFS(0); errors from a removed device are ignored. The destructor calls it.
  void stop();

 private:
  [[noreturn]] void fail(const std::string& message) const;
  V4l2Dequeue try_dequeue();
  V4l2Dequeue disconnect(const std::string& message);

  struct Mapping {
    void* address = nullptr;
    size_t length = 0;
  };
  std::string path_;
  std::string driver_, card_;
  int fd_ = -1;
  V4l2Format format_;
  double frame_rate_hz_ = 0;
  std::vector<Mapping> mappings_;
  bool streaming_ = false;
  bool driver_timestamps_ = true;
  bool disconnected_ = false;
  std::string disconnect_message_;
  uint32_t last_sequence32_ = 0;
  uint64_t sequence_high_ = 0;       // 2^32 x the wraps of the driver's counter seen so far
  bool have_sequence_ = false;
  uint64_t corrupt_buffers_ = 0;
};

// "YUYV" from a V4L2 fourcc (non-printable bytes as '?').
std::string fourcc_text(uint32_t fourcc);

}  // namespace lpstereo::io
