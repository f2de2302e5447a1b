#include "io/camera/libcamera_source.h"

#include <libcamera/libcamera.h>
#include <sys/mman.h>
#include <sys/sysmacros.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "io/camera/timestamp_pairing.h"

namespace lpstereo::io {

namespace {

using Clock = std::chrono::steady_clock;

std::string quoted_id(const std::string& camera_id) { return "libcamera camera '" + camera_id + "'"; }

[[noreturn]] void fail(const std::string& camera_id, const std::string& message) {
  throw SourceError(quoted_id(camera_id) + ": " + message);
}

std::string error_text(int negative_errno) { return std::strerror(-negative_errno); }

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// libcamera names formats by DRM fourcc and component order in a 32-bit word: its BGR888 is
// R,G,B in memory (our RGB888), its RGB888 B,G,R (our BGR888), its R8 our GREY.
libcamera::PixelFormat to_libcamera_format(CameraPixelFormat format) {
  switch (format) {
    case CameraPixelFormat::grey:
      return libcamera::formats::R8;
    case CameraPixelFormat::yuyv:
      return libcamera::formats::YUYV;
    case CameraPixelFormat::uyvy:
      return libcamera::formats::UYVY;
    case CameraPixelFormat::nv12:
      return libcamera::formats::NV12;
    case CameraPixelFormat::rgb888:
      return libcamera::formats::BGR888;
    case CameraPixelFormat::bgr888:
      return libcamera::formats::RGB888;
  }
  return {};
}

std::optional<CameraPixelFormat> from_libcamera_format(const libcamera::PixelFormat& format) {
  for (CameraPixelFormat candidate : kCameraPixelFormatPreference) {
    if (to_libcamera_format(candidate) == format) return candidate;
  }
  return std::nullopt;
}

std::string format_list(const std::vector<libcamera::PixelFormat>& formats) {
  std::string text;
  for (const libcamera::PixelFormat& format : formats) text += (text.empty() ? "" : ", ") + format.toString();
  return text.empty() ? "none" : text;
}

// libcamera allows one CameraManager per process: list_libcamera_cameras() and every open source
// share this one, which stops when the last of them lets it go.
std::shared_ptr<libcamera::CameraManager> shared_camera_manager() {
  static std::mutex mutex;
  static std::weak_ptr<libcamera::CameraManager> current;
  std::lock_guard lock(mutex);
  if (auto manager = current.lock()) return manager;
  // libcamera logs at INFO by default (a version line per manager); warnings and errors are what a
  // user of lpstereo needs. LIBCAMERA_LOG_LEVELS, when set, is left as it is.
  setenv("LIBCAMERA_LOG_LEVELS", "*:WARN", 0);
  auto manager = std::make_shared<libcamera::CameraManager>();
  const int status = manager->start();
  if (status < 0) throw SourceError("libcamera: the camera manager did not start: " + error_text(status));
  current = manager;
  return manager;
}

// The V4L2 device nodes of `camera` (sysfs names such as "video2", with their device numbers):
// CameraManager::get(dev_t) maps a V4L2 device number to the camera that streams from it.
std::vector<std::pair<std::string, dev_t>> video_devices_of(libcamera::CameraManager& manager,
                                                            const std::shared_ptr<libcamera::Camera>& camera) {
  std::vector<std::pair<std::string, dev_t>> devices;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator("/sys/class/video4linux", error)) {
    unsigned major_number = 0, minor_number = 0;
    char separator = 0;
    std::ifstream(entry.path() / "dev") >> major_number >> separator >> minor_number;
    if (separator != ':') continue;
    const dev_t device_number = makedev(major_number, minor_number);
    if (manager.get(device_number) == camera) devices.emplace_back(entry.path().filename().string(), device_number);
  }
  std::sort(devices.begin(), devices.end());
  return devices;
}

bool device_present(dev_t device_number) {
  return std::filesystem::exists("/sys/dev/char/" + std::to_string(major(device_number)) + ":" +
                                 std::to_string(minor(device_number)));
}

// Cameras that went away while streaming, and the manager they belong to, kept until the process
// exits: libcamera 0.0.3 cannot stop them (PipelineHandler::stop() asserts that no request is
// still queued, and requests it failed to queue to a vanished device stay queued: a FATAL abort),
// and cannot release them or free their buffers while they run.
std::vector<std::shared_ptr<void>>& abandoned_objects() {
  static auto* objects = new std::vector<std::shared_ptr<void>>();  // never destroyed, on purpose
  return *objects;
}

std::string available_cameras(const libcamera::CameraManager& manager) {
  std::string text;
  for (const std::shared_ptr<libcamera::Camera>& camera : manager.cameras()) {
    text += (text.empty() ? "'" : ", '") + camera->id() + "'";
  }
  return text.empty() ? "libcamera finds no cameras" : "available: " + text;
}

// One mmapped dmabuf (the planes of a buffer may share one, at different offsets).
struct Mapping {
  void* address = MAP_FAILED;
  size_t length = 0;
};

// What the completion handler reads from a request, on libcamera's thread.
struct CompletedFrame {
  libcamera::Request* request = nullptr;
  int64_t timestamp_ns = 0;
  uint64_t sequence = 0;
  size_t bytes_used = 0;
};

// One camera: its configuration, buffers, mappings, requests and completed frames.
struct CameraStream {
  std::string id;
  std::shared_ptr<libcamera::Camera> camera;
  bool acquired = false;
  bool started = false;
  std::unique_ptr<libcamera::CameraConfiguration> configuration;
  libcamera::Stream* stream = nullptr;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator;
  std::vector<std::unique_ptr<libcamera::Request>> requests;
  std::vector<Mapping> mappings;
  std::map<const libcamera::FrameBuffer*, const uint8_t*> plane0_data;
  CameraPixelFormat format = CameraPixelFormat::grey;
  int width = 0, height = 0;  // the camera frame, px
  size_t bytes_per_line = 0;
  size_t luma_bytes = 0;   // the least of plane 0 a frame must fill (for NV12 the Y plane)
  std::string adjustment;  // what validate() changed, "" when nothing
  std::vector<std::pair<std::string, dev_t>> video_devices;  // its V4L2 nodes (sysfs name, number)
  // Guarded by LibcameraStereoSource::mutex_.
  std::deque<CompletedFrame> completed;
  bool gone = false;  // disconnected while streaming (libcamera's signal or its nodes vanished)
  std::optional<uint64_t> last_sequence;
  int64_t last_timestamp_ns = 0;
  int64_t frame_period_ns = 0;  // FrameDuration metadata, else the last timestamp step (0 = unknown)
};

class LibcameraStereoSource final : public StereoSource {
 public:
  LibcameraStereoSource(const std::vector<std::string>& camera_ids, const SourceOptions& options,
                        LibcameraRawFrameObserver observer)
      : manager_(shared_camera_manager()), options_(options), observer_(std::move(observer)) {
    side_by_side_ = camera_ids.size() == 1;
    for (const std::string& id : camera_ids) {
      auto& camera_stream = cameras_.emplace_back(std::make_unique<CameraStream>());
      camera_stream->id = id;
    }
    try {
      for (size_t index = 0; index < cameras_.size(); ++index) configure(*cameras_[index]);
      if (cameras_.size() == 2 &&
          (cameras_[0]->width != cameras_[1]->width || cameras_[0]->height != cameras_[1]->height)) {
        throw SourceError("libcamera cameras '" + cameras_[0]->id + "' (" +
                          size_text(cameras_[0]->width, cameras_[0]->height) + ") and '" + cameras_[1]->id + "' (" +
                          size_text(cameras_[1]->width, cameras_[1]->height) +
                          "): the two views must have the same size");
      }
      for (size_t index = 0; index < cameras_.size(); ++index) allocate(*cameras_[index], index);
      for (size_t index = 0; index < cameras_.size(); ++index) start(*cameras_[index]);
    } catch (...) {
      shut_down();
      throw;
    }
  }

  ~LibcameraStereoSource() override { shut_down(); }

  std::string description() const override {
    std::ostringstream text;
    const CameraStream& first = *cameras_[0];
    text << "libcamera '" << first.id << "'";
    if (side_by_side_) {
      text << " side by side";
    } else {
      text << " + '" << cameras_[1]->id << "'";
    }
    text << ": " << pixel_format_name(first.format) << " " << size_text(first.width, first.height);
    if (side_by_side_) text << " as two " << size_text(width(), height()) << " views";
    for (const auto& camera_stream : cameras_) {
      if (!camera_stream->adjustment.empty()) text << " (" << camera_stream->adjustment << ")";
    }
    if (!frame_rate_note_.empty()) text << ", " << frame_rate_note_;
    return text.str();
  }

  int width() const override { return side_by_side_ ? cameras_[0]->width / 2 : cameras_[0]->width; }
  int height() const override { return cameras_[0]->height; }

  double frame_rate_hz() const override {
    std::lock_guard lock(mutex_);
    const int64_t period_ns = cameras_[0]->frame_period_ns;
    return period_ns > 0 ? 1e9 / static_cast<double>(period_ns) : 0.0;
  }

  SourceResult next(std::chrono::milliseconds timeout) override {
    const Clock::time_point deadline = Clock::now() + timeout;
    std::array<CompletedFrame, 2> frames{};
    std::vector<std::pair<CameraStream*, libcamera::Request*>> discarded;
    {
      std::unique_lock lock(mutex_);
      while (true) {
        if (!failure_.empty()) {
          lock.unlock();
          return SourceResult{SourceStatus::disconnected, {}, failure_};
        }
        if (take_pair(frames, discarded)) break;
        if (Clock::now() >= deadline) {
          if (note_vanished_devices()) continue;
          lock.unlock();
          requeue_all(discarded);
          return SourceResult{SourceStatus::timeout, {}, timeout_message(timeout)};
        }
        completion_.wait_until(lock, deadline);
      }
    }
    requeue_all(discarded);
    SourceResult result{SourceStatus::frame, {}, ""};
    StereoFrame& pair = result.frame;
    pair.left = Plane(width(), height(), BufferFormat{});
    pair.right = Plane(width(), height(), BufferFormat{});
    const int views = side_by_side_ ? 1 : 2;
    for (int view = 0; view < views; ++view) {
      CameraStream& camera_stream = *cameras_[static_cast<size_t>(view)];
      const CompletedFrame& frame = frames[static_cast<size_t>(view)];
      const uint8_t* data = frame_data(camera_stream, frame);
      if (observer_) {
        observer_(LibcameraRawFrame{view, camera_stream.format, data, frame.bytes_used, camera_stream.bytes_per_line,
                                    camera_stream.width, camera_stream.height, frame.sequence, frame.timestamp_ns});
      }
      if (side_by_side_) {
        const size_t half_offset =
            static_cast<size_t>(width()) * static_cast<size_t>(pixel_format_bytes_per_pixel(camera_stream.format));
        convert_to_luma(camera_stream.format, data, camera_stream.bytes_per_line, width(), height(), pair.left);
        convert_to_luma(camera_stream.format, data + half_offset, camera_stream.bytes_per_line, width(), height(),
                        pair.right);
      } else {
        convert_to_luma(camera_stream.format, data, camera_stream.bytes_per_line, width(), height(),
                        view == 0 ? pair.left : pair.right);
      }
    }
    const CompletedFrame& right_frame = frames[side_by_side_ ? 0 : 1];
    pair.left_timestamp_ns = frames[0].timestamp_ns;
    pair.right_timestamp_ns = right_frame.timestamp_ns;
    pair.left_sequence = frames[0].sequence;
    pair.right_sequence = right_frame.sequence;
    for (int view = 0; view < views; ++view) {
      requeue(*cameras_[static_cast<size_t>(view)], frames[static_cast<size_t>(view)].request);
    }
    std::lock_guard lock(mutex_);
    pair.index = statistics_.pairs_delivered++;
    return result;
  }

  SourceStatistics statistics() const override {
    std::lock_guard lock(mutex_);
    return statistics_;
  }

 private:
  // Picks the pixel format and size, validates and configures the camera.
  void configure(CameraStream& camera_stream) {
    const std::string& id = camera_stream.id;
    camera_stream.camera = manager_->get(id);
    if (!camera_stream.camera) fail(id, "not found (" + available_cameras(*manager_) + ")");
    const int acquired = camera_stream.camera->acquire();
    if (acquired < 0) fail(id, "cannot acquire it, expected a camera not in use: " + error_text(acquired));
    camera_stream.acquired = true;
    camera_stream.video_devices = video_devices_of(*manager_, camera_stream.camera);
    camera_stream.configuration = camera_stream.camera->generateConfiguration({libcamera::StreamRole::Viewfinder});
    if (!camera_stream.configuration || camera_stream.configuration->empty()) {
      fail(id, "offers no viewfinder stream configuration");
    }
    libcamera::StreamConfiguration& stream_configuration = camera_stream.configuration->at(0);
    const std::vector<libcamera::PixelFormat> offered = stream_configuration.formats().pixelformats();

    std::optional<CameraPixelFormat> chosen;
    if (!options_.pixel_format.empty()) {
      chosen = pixel_format_from_name(options_.pixel_format);
      if (!chosen) {
        fail(id, "pixel format '" + options_.pixel_format +
                     "' is not one lpstereo converts (GREY, NV12, YUYV, "
                     "UYVY, RGB888, BGR888)");
      }
      if (std::find(offered.begin(), offered.end(), to_libcamera_format(*chosen)) == offered.end()) {
        fail(id, "pixel format " + std::string(pixel_format_name(*chosen)) + " (libcamera " +
                     to_libcamera_format(*chosen).toString() + ") not offered; the camera offers " +
                     format_list(offered));
      }
    } else {
      for (CameraPixelFormat candidate : kCameraPixelFormatPreference) {
        if (std::find(offered.begin(), offered.end(), to_libcamera_format(candidate)) != offered.end()) {
          chosen = candidate;
          break;
        }
      }
      if (!chosen) {
        fail(id,
             "offers no format lpstereo converts, expected one of R8, NV12, YUYV, UYVY, BGR888, RGB888; "
             "it offers " +
                 format_list(offered));
      }
    }
    if ((options_.width > 0) != (options_.height > 0)) {
      throw std::invalid_argument("libcamera source: give both width and height or neither, got " +
                                  size_text(options_.width, options_.height));
    }
    stream_configuration.pixelFormat = to_libcamera_format(*chosen);
    if (options_.width > 0) {
      stream_configuration.size =
          libcamera::Size(static_cast<unsigned>(side_by_side_ ? 2 * options_.width : options_.width),
                          static_cast<unsigned>(options_.height));
    }
    if (options_.buffer_count > 0) stream_configuration.bufferCount = static_cast<unsigned>(options_.buffer_count);
    const std::string requested = stream_configuration.toString();
    const libcamera::Size requested_size = stream_configuration.size;
    const unsigned requested_buffers = stream_configuration.bufferCount;
    const libcamera::CameraConfiguration::Status validation = camera_stream.configuration->validate();
    if (validation == libcamera::CameraConfiguration::Invalid) {
      fail(id, "configuration " + requested + " rejected by validate(), expected a valid or adjusted one");
    }
    if (validation == libcamera::CameraConfiguration::Adjusted) {
      // The format cannot change (checked below); say what did, in lpstereo's terms.
      const libcamera::Size& size = stream_configuration.size;
      if (size != requested_size) {
        camera_stream.adjustment =
            "requested " + size_text(static_cast<int>(requested_size.width), static_cast<int>(requested_size.height)) +
            ", adjusted to " + size_text(static_cast<int>(size.width), static_cast<int>(size.height));
      } else if (stream_configuration.bufferCount != requested_buffers) {
        camera_stream.adjustment = "requested " + std::to_string(requested_buffers) + " buffers, adjusted to " +
                                   std::to_string(stream_configuration.bufferCount);
      } else {
        camera_stream.adjustment = "adjusted by libcamera to " + stream_configuration.toString();
      }
    }
    const std::optional<CameraPixelFormat> granted = from_libcamera_format(stream_configuration.pixelFormat);
    if (!granted || *granted != *chosen) {
      fail(id, "validate() changed the pixel format from " + to_libcamera_format(*chosen).toString() + " to " +
                   stream_configuration.pixelFormat.toString() + ", expected it kept");
    }
    const int configured = camera_stream.camera->configure(camera_stream.configuration.get());
    if (configured < 0)
      fail(id, "configure(" + stream_configuration.toString() + ") failed: " + error_text(configured));

    camera_stream.format = *granted;
    camera_stream.width = static_cast<int>(stream_configuration.size.width);
    camera_stream.height = static_cast<int>(stream_configuration.size.height);
    camera_stream.bytes_per_line = stream_configuration.stride;
    camera_stream.stream = stream_configuration.stream();
    if (side_by_side_ && camera_stream.width % 2 != 0) {
      fail(id, "side-by-side frames need an even width, got " + std::to_string(camera_stream.width) + " px");
    }
    const size_t row_bytes = static_cast<size_t>(camera_stream.width) *
                             static_cast<size_t>(pixel_format_bytes_per_pixel(camera_stream.format));
    if (camera_stream.width <= 0 || camera_stream.height <= 0 || camera_stream.bytes_per_line < row_bytes) {
      fail(id, "configured " + stream_configuration.toString() + " with a stride of " +
                   std::to_string(camera_stream.bytes_per_line) + " bytes, expected at least " +
                   std::to_string(row_bytes));
    }
    // NV12's luma is its first plane: the rows of a GREY frame of the same size and stride.
    camera_stream.luma_bytes = pixel_format_min_buffer_bytes(
        camera_stream.format == CameraPixelFormat::nv12 ? CameraPixelFormat::grey : camera_stream.format,
        camera_stream.width, camera_stream.height, camera_stream.bytes_per_line);
  }

  // Allocates the buffers, maps them and creates one request per buffer (cookie = camera index).
  void allocate(CameraStream& camera_stream, size_t camera_index) {
    const std::string& id = camera_stream.id;
    camera_stream.allocator = std::make_unique<libcamera::FrameBufferAllocator>(camera_stream.camera);
    const int allocated = camera_stream.allocator->allocate(camera_stream.stream);
    if (allocated <= 0) {
      fail(id, "FrameBufferAllocator gave no buffers: " + (allocated < 0 ? error_text(allocated) : "0 buffers"));
    }
    std::map<int, size_t> mapping_of_fd;
    for (const std::unique_ptr<libcamera::FrameBuffer>& buffer :
         camera_stream.allocator->buffers(camera_stream.stream)) {
      // Each dmabuf once, over the extent its planes use.
      std::map<int, size_t> extent_of_fd;
      for (const libcamera::FrameBuffer::Plane& plane : buffer->planes()) {
        size_t& extent = extent_of_fd[plane.fd.get()];
        extent = std::max(extent, static_cast<size_t>(plane.offset) + plane.length);
      }
      for (const auto& [fd, extent] : extent_of_fd) {
        void* address = mmap(nullptr, extent, PROT_READ, MAP_SHARED, fd, 0);
        if (address == MAP_FAILED)
          fail(id, "mmap of a " + std::to_string(extent) + "-byte buffer failed: " + error_text(-errno));
        mapping_of_fd[fd] = camera_stream.mappings.size();
        camera_stream.mappings.push_back(Mapping{address, extent});
      }
      const libcamera::FrameBuffer::Plane& plane0 = buffer->planes()[0];
      if (plane0.length < camera_stream.luma_bytes) {
        fail(id, "buffer plane 0 holds " + std::to_string(plane0.length) + " bytes, expected at least " +
                     std::to_string(camera_stream.luma_bytes) + " for " +
                     std::string(pixel_format_name(camera_stream.format)) + " " +
                     size_text(camera_stream.width, camera_stream.height));
      }
      const Mapping& mapping = camera_stream.mappings[mapping_of_fd[plane0.fd.get()]];
      camera_stream.plane0_data[buffer.get()] = static_cast<const uint8_t*>(mapping.address) + plane0.offset;

      std::unique_ptr<libcamera::Request> request = camera_stream.camera->createRequest(camera_index);
      if (!request) fail(id, "createRequest() failed");
      const int added = request->addBuffer(camera_stream.stream, buffer.get());
      if (added < 0) fail(id, "adding a buffer to a request failed: " + error_text(added));
      camera_stream.requests.push_back(std::move(request));
    }
  }

  void start(CameraStream& camera_stream) {
    const std::string& id = camera_stream.id;
    camera_stream.camera->requestCompleted.connect(this, &LibcameraStereoSource::on_request_completed);
    camera_stream.camera->disconnected.connect(this, [this, &camera_stream]() {
      std::lock_guard lock(mutex_);
      camera_stream.gone = true;
      if (failure_.empty()) failure_ = quoted_id(camera_stream.id) + ": disconnected (libcamera's disconnected signal)";
      completion_.notify_all();
    });
    libcamera::ControlList start_controls(libcamera::controls::controls);
    const bool rate_controllable =
        camera_stream.camera->controls().count(libcamera::controls::FrameDurationLimits.id()) > 0;
    if (options_.frame_rate_hz > 0) {
      const auto period_us = static_cast<int64_t>(1e6 / options_.frame_rate_hz + 0.5);
      if (rate_controllable) {
        start_controls.set(libcamera::controls::FrameDurationLimits, {period_us, period_us});
        frame_rate_note_ = "frame duration limits " + std::to_string(period_us) + " us requested";
      } else {
        frame_rate_note_ = "frame rate not controllable (the camera has no FrameDurationLimits control)";
      }
    }
    const int started = camera_stream.camera->start(&start_controls);
    if (started < 0) fail(id, "start() failed: " + error_text(started));
    camera_stream.started = true;
    for (const std::unique_ptr<libcamera::Request>& request : camera_stream.requests) {
      const int queued = camera_stream.camera->queueRequest(request.get());
      if (queued < 0) fail(id, "queueRequest() failed: " + error_text(queued));
    }
  }

  // On libcamera's thread: records the frame (or the failure) and wakes next().
  void on_request_completed(libcamera::Request* request) {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    const size_t camera_index = static_cast<size_t>(request->cookie());
    if (camera_index >= cameras_.size()) return;  // not one of ours (cannot happen: each camera is acquired)
    CameraStream& camera_stream = *cameras_[camera_index];
    const libcamera::FrameBuffer* buffer = request->findBuffer(camera_stream.stream);
    if (request->status() != libcamera::Request::RequestComplete || buffer == nullptr ||
        buffer->metadata().status != libcamera::FrameMetadata::FrameSuccess) {
      if (failure_.empty()) {
        failure_ = quoted_id(camera_stream.id) + ": a request completed " +
                   (request->status() == libcamera::Request::RequestCancelled ? "cancelled" : "unfinished") +
                   (buffer != nullptr && buffer->metadata().status == libcamera::FrameMetadata::FrameError
                        ? " with a failed buffer"
                        : "") +
                   " while streaming, expected a captured frame";
      }
      completion_.notify_all();
      return;
    }
    const libcamera::FrameMetadata& metadata = buffer->metadata();
    CompletedFrame frame;
    frame.request = request;
    frame.sequence = metadata.sequence;
    frame.timestamp_ns = static_cast<int64_t>(request->metadata()
                                                  .get(libcamera::controls::SensorTimestamp)
                                                  .value_or(static_cast<int64_t>(metadata.timestamp)));
    frame.bytes_used = metadata.planes().empty() ? 0 : metadata.planes()[0].bytesused;
    if (frame.bytes_used < camera_stream.luma_bytes) {
      if (failure_.empty()) {
        failure_ = quoted_id(camera_stream.id) + ": a frame of " + std::to_string(frame.bytes_used) +
                   " bytes, expected at least " + std::to_string(camera_stream.luma_bytes);
      }
      completion_.notify_all();
      return;
    }
    if (const std::optional<int64_t> duration_us = request->metadata().get(libcamera::controls::FrameDuration)) {
      camera_stream.frame_period_ns = *duration_us * 1000;
    } else if (camera_stream.last_sequence && frame.sequence > *camera_stream.last_sequence &&
               frame.timestamp_ns > camera_stream.last_timestamp_ns) {
      camera_stream.frame_period_ns = (frame.timestamp_ns - camera_stream.last_timestamp_ns) /
                                      static_cast<int64_t>(frame.sequence - *camera_stream.last_sequence);
    }
    uint64_t& frames = camera_index == 0 ? statistics_.left_frames : statistics_.right_frames;
    uint64_t& drops = camera_index == 0 ? statistics_.left_driver_drops : statistics_.right_driver_drops;
    ++frames;
    if (side_by_side_) ++statistics_.right_frames;
    if (camera_stream.last_sequence && frame.sequence > *camera_stream.last_sequence + 1) {
      const uint64_t missing = frame.sequence - *camera_stream.last_sequence - 1;
      drops += missing;
      if (side_by_side_) statistics_.right_driver_drops += missing;
    }
    camera_stream.last_sequence = frame.sequence;
    camera_stream.last_timestamp_ns = frame.timestamp_ns;
    camera_stream.completed.push_back(frame);
    completion_.notify_all();
  }

  // Under mutex_: the next pair, if there is one. Heads that cannot pair are moved to `discarded`.
  bool take_pair(std::array<CompletedFrame, 2>& frames,
                 std::vector<std::pair<CameraStream*, libcamera::Request*>>& discarded) {
    std::deque<CompletedFrame>& left = cameras_[0]->completed;
    if (side_by_side_) {
      if (left.empty()) return false;
      frames[0] = left.front();
      left.pop_front();
      return true;
    }
    std::deque<CompletedFrame>& right = cameras_[1]->completed;
    const int64_t tolerance_ns = pairing_tolerance_ns();
    // The V4L2 source's rule (io/camera/timestamp_pairing.h) on the completed-request queues.
    const auto timestamp = [](const std::deque<CompletedFrame>& queue, size_t i) -> std::optional<int64_t> {
      if (queue.size() <= i) return std::nullopt;
      return queue[i].timestamp_ns;
    };
    while (true) {
      const PairingStep step = next_pairing_step(timestamp(left, 0), timestamp(left, 1), timestamp(right, 0),
                                                 timestamp(right, 1), tolerance_ns);
      if (step == PairingStep::wait) return false;
      if (step == PairingStep::pair) {
        frames[0] = left.front();
        frames[1] = right.front();
        left.pop_front();
        right.pop_front();
        return true;
      }
      const bool discard_left = step == PairingStep::discard_left;
      std::deque<CompletedFrame>& discarded_queue = discard_left ? left : right;
      discarded.emplace_back(cameras_[discard_left ? 0 : 1].get(), discarded_queue.front().request);
      ++(discard_left ? statistics_.left_unpaired : statistics_.right_unpaired);
      discarded_queue.pop_front();
    }
  }

  // Under mutex_: SourceOptions' tolerance, or half the frame period (the measured one, else the
  // requested rate, else 30 fps).
  int64_t pairing_tolerance_ns() const {
    if (options_.pairing_tolerance_ns >= 0) return options_.pairing_tolerance_ns;
    const int64_t period_ns = cameras_[0]->frame_period_ns;
    return default_pairing_tolerance_ns(period_ns > 0 ? 1e9 / static_cast<double>(period_ns) : options_.frame_rate_hz);
  }

  // Under mutex_, when a wait timed out: a camera whose V4L2 nodes have all left sysfs is gone,
  // whether or not libcamera says so (in 0.0.3 only the UVC pipeline handler watches unplugs: the
  // others, vimc's included, leave the stream stalled). Returns true when it set failure_.
  bool note_vanished_devices() {
    for (const auto& camera_stream : cameras_) {
      if (camera_stream->video_devices.empty()) continue;
      bool any_present = false;
      for (const auto& [name, device_number] : camera_stream->video_devices)
        any_present |= device_present(device_number);
      if (any_present) continue;
      camera_stream->gone = true;
      if (failure_.empty()) {
        std::string names;
        for (const auto& [name, device_number] : camera_stream->video_devices) {
          names += (names.empty() ? "/dev/" : ", /dev/") + name;
        }
        failure_ = quoted_id(camera_stream->id) + ": its V4L2 devices (" + names +
                   ") are gone, expected them present; the stream stopped and libcamera reported no disconnect";
      }
      return true;
    }
    return false;
  }

  std::string timeout_message(std::chrono::milliseconds timeout) const {
    std::string text = quoted_id(cameras_[0]->id);
    if (!side_by_side_) text += " + '" + cameras_[1]->id + "'";
    return text + ": no frame pair within " + std::to_string(timeout.count()) + " ms";
  }

  const uint8_t* frame_data(const CameraStream& camera_stream, const CompletedFrame& frame) const {
    const libcamera::FrameBuffer* buffer = frame.request->findBuffer(camera_stream.stream);
    return camera_stream.plane0_data.at(buffer);
  }

  // Hands a request back to its camera; a camera that refuses it has gone.
  void requeue(CameraStream& camera_stream, libcamera::Request* request) {
    request->reuse(libcamera::Request::ReuseBuffers);
    const int queued = camera_stream.camera->queueRequest(request);
    if (queued < 0) {
      std::lock_guard lock(mutex_);
      if (failure_.empty()) {
        failure_ = quoted_id(camera_stream.id) + ": re-queueing a request failed (" + error_text(queued) +
                   "), expected the camera to take it back";
      }
    }
  }

  void requeue_all(const std::vector<std::pair<CameraStream*, libcamera::Request*>>& requests) {
    for (const auto& [camera_stream, request] : requests) requeue(*camera_stream, request);
  }

  // Stops the cameras (libcamera completes the queued requests as cancelled, ignored here), then
  // frees the requests, mappings and buffers and releases the cameras. A camera that went away
  // while streaming is not stopped but abandoned (abandoned_objects()).
  void shut_down() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    bool abandoned = false;
    for (auto& camera_stream : cameras_) {
      if (camera_stream->camera) {
        camera_stream->camera->requestCompleted.disconnect(this);
        camera_stream->camera->disconnected.disconnect(this);
      }
      if (camera_stream->started && camera_stream->gone) {
        for (const Mapping& mapping : camera_stream->mappings) munmap(mapping.address, mapping.length);
        camera_stream->mappings.clear();
        abandoned_objects().push_back(std::shared_ptr<CameraStream>(std::move(camera_stream)));
        abandoned = true;
        continue;
      }
      if (camera_stream->started) camera_stream->camera->stop();
      camera_stream->started = false;
    }
    if (abandoned) abandoned_objects().push_back(manager_);
    for (const auto& camera_stream : cameras_) {
      if (!camera_stream) continue;  // abandoned above
      camera_stream->completed.clear();
      camera_stream->requests.clear();
      for (const Mapping& mapping : camera_stream->mappings) munmap(mapping.address, mapping.length);
      camera_stream->mappings.clear();
      camera_stream->plane0_data.clear();
      if (camera_stream->allocator && camera_stream->stream) camera_stream->allocator->free(camera_stream->stream);
      camera_stream->allocator.reset();
      if (camera_stream->acquired) camera_stream->camera->release();
      camera_stream->acquired = false;
      camera_stream->configuration.reset();
      camera_stream->camera.reset();
    }
  }

  std::shared_ptr<libcamera::CameraManager> manager_;  // declared first: outlives the cameras
  SourceOptions options_;
  LibcameraRawFrameObserver observer_;
  bool side_by_side_ = false;
  std::vector<std::unique_ptr<CameraStream>> cameras_;
  std::string frame_rate_note_;
  mutable std::mutex mutex_;
  std::condition_variable completion_;
  bool stopping_ = false;        // guarded by mutex_
  std::string failure_;          // guarded by mutex_: the one line next() returns as disconnected
  SourceStatistics statistics_;  // guarded by mutex_
};

}  // namespace

std::vector<LibcameraCameraInfo> list_libcamera_cameras() {
  const std::shared_ptr<libcamera::CameraManager> manager = shared_camera_manager();
  std::vector<LibcameraCameraInfo> cameras;
  for (const std::shared_ptr<libcamera::Camera>& camera : manager->cameras()) {
    LibcameraCameraInfo info;
    info.id = camera->id();
    info.model = camera->properties().get(libcamera::properties::Model).value_or("");
    // generateConfiguration() needs no acquire(): it reads what the pipeline handler offers.
    const std::unique_ptr<libcamera::CameraConfiguration> configuration =
        camera->generateConfiguration({libcamera::StreamRole::Viewfinder});
    if (configuration && !configuration->empty()) {
      const libcamera::StreamFormats& formats = configuration->at(0).formats();
      for (const libcamera::PixelFormat& pixel_format : formats.pixelformats()) {
        LibcameraStreamFormat format;
        format.pixel_format = pixel_format.toString();
        for (const libcamera::Size& size : formats.sizes(pixel_format)) {
          format.sizes.emplace_back(static_cast<int>(size.width), static_cast<int>(size.height));
        }
        const libcamera::SizeRange range = formats.range(pixel_format);
        format.min_width = static_cast<int>(range.min.width);
        format.min_height = static_cast<int>(range.min.height);
        format.max_width = static_cast<int>(range.max.width);
        format.max_height = static_cast<int>(range.max.height);
        info.formats.push_back(std::move(format));
      }
    }
    cameras.push_back(std::move(info));
  }
  return cameras;
}

std::unique_ptr<StereoSource> open_libcamera_stereo_source(const std::vector<std::string>& camera_ids,
                                                           const SourceOptions& options,
                                                           LibcameraRawFrameObserver observer) {
  if (camera_ids.empty() || camera_ids.size() > 2) {
    throw std::invalid_argument("libcamera source: expected 1 camera id (side by side) or 2 (left, right), got " +
                                std::to_string(camera_ids.size()));
  }
  if (camera_ids.size() == 2 && camera_ids[0] == camera_ids[1]) {
    throw std::invalid_argument("libcamera source: left and right are the same camera '" + camera_ids[0] +
                                "', expected two cameras (or one id for side by side)");
  }
  return std::make_unique<LibcameraStereoSource>(camera_ids, options, std::move(observer));
}

}  // namespace lpstereo::io
