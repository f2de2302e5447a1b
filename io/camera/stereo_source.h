// A source of stereo frame pairs behind one interface: two V4L2 devices, one side-by-side V4L2
// device, a libcamera camera pair, or a recording (image sequences, video files). Whatever the
// source, a pair arrives as two u8 luma planes of one size with the capture timestamps and the
// driver's sequence numbers, so a recorded run replays through the same path as a live one.
//
// Spec strings (what `lpstereo run --source` takes; open_stereo_source parses them):
//   v4l2:/dev/videoL,/dev/videoR       two V4L2 capture devices, paired by timestamp
//   v4l2-sbs:/dev/videoN               one V4L2 device delivering left|right side by side
//   libcamera:ID_LEFT,ID_RIGHT         two libcamera cameras (IDs as `cam --list` prints them),
//   libcamera:ID                       or one side-by-side camera
//   files:LEFT_PATTERN,RIGHT_PATTERN   image sequences, printf patterns such as dir/%06d.png
//   files:LEFT_VIDEO,RIGHT_VIDEO       video files (anything OpenCV's VideoCapture decodes)
//
// Timestamps are nanoseconds on CLOCK_MONOTONIC (V4L2 buffer timestamps, libcamera's
// SensorTimestamp); a recording has frame_index / frame_rate_hz. Sequence numbers are the driver's
// (files: the frame number), so a gap in them is a frame the driver dropped.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include "dag/plane.h"

namespace lpstereo::io {

// A device or file that cannot be opened, is not a capture device, offers none of the supported
// formats, or a pair of views whose sizes differ. what() is one line naming the device or file,
// the expected and the actual value.
class SourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct StereoFrame {
  Plane left, right;                 // u8 luma, width() x height() of the source
  int64_t left_timestamp_ns = 0;     // capture time of each view (CLOCK_MONOTONIC, ns)
  int64_t right_timestamp_ns = 0;
  uint64_t left_sequence = 0;        // the driver's frame sequence number of each view
  uint64_t right_sequence = 0;
  uint64_t index = 0;                // pairs this source delivered before this one
};

// Counters since the source was opened.
struct SourceStatistics {
  uint64_t pairs_delivered = 0;
  uint64_t left_frames = 0;          // frames dequeued from each view
  uint64_t right_frames = 0;
  uint64_t left_driver_drops = 0;    // gaps in each view's sequence numbers (frames the driver lost)
  uint64_t right_driver_drops = 0;
  uint64_t left_unpaired = 0;        // frames dequeued but discarded: no partner within the tolerance
  uint64_t right_unpaired = 0;
};

enum class SourceStatus {
  frame,          // `frame` holds the next pair
  timeout,        // no pair within the timeout; the source may still deliver (a stalled stream)
  end_of_stream,  // a recording's last pair was delivered
  disconnected,   // the device went away (ENODEV, EIO, libcamera's disconnect); `message` says which
};

struct SourceResult {
  SourceStatus status = SourceStatus::timeout;
  StereoFrame frame;                 // valid when status == frame
  std::string message;               // one line for disconnected and timeout
};

struct SourceOptions {
  int width = 0;                     // requested size of each view, px (0 = the device's current)
  int height = 0;
  double frame_rate_hz = 0;          // requested frame rate (0 = the device's current; files: 10)
  std::string pixel_format;          // "GREY", "YUYV", "UYVY", "NV12", ... ("" = the first the device offers
                                     // in the order of io/camera/pixel_format.h)
  int64_t pairing_tolerance_ns = -1; // two views pair when their timestamps differ by at most this
                                     // (-1 = half the frame period)
  int buffer_count = 4;              // driver buffers per device
};

class StereoSource {
 public:
  virtual ~StereoSource() = default;
  // One line: the kind, devices or files, format, size and rate ("v4l2 /dev/video0 (vivid) +
  // /dev/video2 (vivid): YUYV 640x360 at 30 fps").
  virtual std::string description() const = 0;
  virtual int width() const = 0;     // of each view, px
  virtual int height() const = 0;
  // The frame rate the source runs at (0 when unknown).
  virtual double frame_rate_hz() const = 0;
  // The next pair, waiting at most `timeout` (bounded: never blocks longer). After disconnected or
  // end_of_stream every later call returns the same status. A recording that cannot go on (a view
  // missing, corrupt or of another size mid-sequence) throws SourceError naming the file.
  virtual SourceResult next(std::chrono::milliseconds timeout) = 0;
  virtual SourceStatistics statistics() const = 0;
};

// Opens a source from its spec (see the header comment). Throws SourceError (one line) for a spec
// it cannot open and std::invalid_argument for a spec it cannot parse.
std::unique_ptr<StereoSource> open_stereo_source(const std::string& spec, const SourceOptions& options);

}  // namespace lpstereo::io
