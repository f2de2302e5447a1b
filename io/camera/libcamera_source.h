// Cameras through libcamera (Debian's libcamera-dev 0.0.3): enumeration, and a StereoSource that
// streams u8 luma from two cameras paired by their sensor timestamps, or from one camera whose
// frames hold the left and right views side by side. Host builds only, when pkg-config finds
// libcamera (io/camera/CMakeLists.txt); users see LPSTEREO_WITH_LIBCAMERA=1.
//
// Streaming, per camera: one Viewfinder stream; the pixel format is the requested one or the first
// the camera's StreamFormats offer in the order of kCameraPixelFormatPreference
// (io/camera/pixel_format.h; libcamera's BGR888 is R,G,B in memory = our RGB888, its RGB888 is
// our BGR888, its R8 is our GREY); the size is SourceOptions' (a side-by-side camera is configured
// at twice the width) or the camera's default; validate() may adjust it, and description() then
// says what was requested and what was granted. FrameBufferAllocator buffers are mmapped once;
// every buffer has one request, re-queued as soon as its frame has been converted to luma.
// libcamera completes requests on its own thread; the completion handler only queues them under a
// mutex and signals a condition variable, and next(timeout) converts them on the caller's thread,
// waiting at most `timeout`.
//
// Timestamps are the SensorTimestamp metadata (ns, CLOCK_MONOTONIC; FrameMetadata::timestamp
// when a pipeline does not report it), sequence numbers FrameMetadata::sequence, and a gap in the
// sequence counts as a driver drop. Two cameras pair by a simple rule (the timestamp pairing of
// two V4L2 streams, io/camera/timestamp_pairing.h, was not on main when this was written): while
// both have a frame queued, the heads pair when their timestamps differ by at most the tolerance,
// otherwise the older head is discarded (counted as unpaired) and its request re-queued.
//
// A camera's `disconnected` signal, a request that completes cancelled or with a failed buffer
// while streaming, a request the camera refuses to re-queue, or (checked when a wait times out)
// the camera's V4L2 device nodes gone from sysfs turn the source into SourceStatus::disconnected
// with one line naming the camera; every later next() says the same. The last check is needed
// because libcamera 0.0.3 reports unplugs only for UVC cameras (only its UVC pipeline handler
// calls hotplugMediaDevice()): for vimc, for example, requests queued after the device went away
// fail inside the pipeline ("Failed to queue buffer: No such device") and never complete. Such a
// camera is not stopped on close (libcamera 0.0.3 aborts in PipelineHandler::stop() when a
// request is stuck in its queue): its libcamera objects are left allocated until the process
// exits. See docs/cameras.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "io/camera/pixel_format.h"
#include "io/camera/stereo_source.h"

namespace lpstereo::io {

struct LibcameraStreamFormat {
  std::string pixel_format;                // libcamera's name ("BGR888", "NV12", "R8", ...)
  std::vector<std::pair<int, int>> sizes;  // discrete sizes the camera lists (width, height px)
  int min_width = 0, min_height = 0;       // the range of sizes it accepts, px
  int max_width = 0, max_height = 0;
};

struct LibcameraCameraInfo {
  std::string id;                              // what open_libcamera_stereo_source takes (`cam --list`)
  std::string model;                           // the Model property ("" when the camera has none)
  std::vector<LibcameraStreamFormat> formats;  // of the Viewfinder role's stream
};

// The cameras libcamera finds (empty when there are none). Throws SourceError when libcamera's
// camera manager cannot start. (libcamera allows one camera manager per process: this and every
// open source share one. Creating it sets LIBCAMERA_LOG_LEVELS=*:WARN when the variable is unset.)
std::vector<LibcameraCameraInfo> list_libcamera_cameras();

// One camera buffer as the driver filled it, handed to a RawFrameObserver before it is converted
// (valid only during the call): plane 0's bytes (for NV12 the Y plane), its layout, and the frame's
// sequence number and timestamp.
struct LibcameraRawFrame {
  int camera_index = 0;  // 0 = left camera (or the side-by-side one), 1 = right
  CameraPixelFormat format = CameraPixelFormat::grey;
  const uint8_t* data = nullptr;
  size_t bytes_used = 0;  // FrameMetadata's bytesused of plane 0
  size_t bytes_per_line = 0;
  int width = 0, height = 0;  // of the whole camera frame, px
  uint64_t sequence = 0;
  int64_t timestamp_ns = 0;
};
using LibcameraRawFrameObserver = std::function<void(const LibcameraRawFrame&)>;

// Opens one camera (side by side: each view is half its width) or two (left, right) by libcamera
// id. Throws SourceError (one line naming the camera, the expected and the actual) for an unknown
// id (listing the available ones, or saying there are none), a camera already in use, a pixel
// format the camera does not offer or lpstereo cannot convert, a configuration libcamera rejects,
// two cameras whose granted sizes differ, or buffers that cannot be allocated or mapped; and
// std::invalid_argument for an empty or over-long id list. `observer`, when given, sees every raw
// buffer that goes into a delivered pair, on the thread that calls next().
std::unique_ptr<StereoSource> open_libcamera_stereo_source(const std::vector<std::string>& camera_ids,
                                                           const SourceOptions& options,
                                                           LibcameraRawFrameObserver observer = {});

}  // namespace lpstereo::io
