// The V4L2 capture path against a real kernel driver: vivid, in Debian's kernel booted under qemu
// by tests/vm/run-in-vm.sh (registered as the ctest test Vm.vivid_capture, tests/vm/vm_tests.cmake).
// Linked statically (the VM has busybox and nothing else). vivid is loaded as
//   vivid n_devs=2 node_types=0x101,0x101
// two instances, each with a video capture and a video output node; the nodes are found by their
// card names ("vivid-000-vid-cap", ...), not assumed numbers.
//
//   vivid_capture_test DATA_DIR
//     DATA_DIR/left.png, right.png   a stereo pair (8-bit grey, 640x480: `lpstereo synth`)
//     DATA_DIR/reference.s16         its disparity from `lpstereo disparity --num-disp 64 --format s16`
//                                    on the host (raw int16 Q4, little-endian, 640x480)
//
// (a) capture: both capture nodes on vivid's webcam input (input 0, discrete sizes and frame
//     intervals) through open_v4l2_stereo_source, once per format GREY, YUYV, UYVY, NV12, RGB888
//     and BGR888 at 320x180 and 30 fps: format and size as asked, sequence numbers and
//     CLOCK_MONOTONIC timestamps increasing on each side, the two views of each pair within the
//     pairing tolerance, and the luma of YUYV, UYVY and NV12 the same bytes, and of RGB888 and
//     BGR888 (vivid's test pattern, its text switched off); then one node side by side (640x360 as
//     two 320x360 views). Then driver drops on the right view (vivid's "Percentage of Dropped
//     Buffers" at 50 %: counted), a stalled right view (100 %: next() times out within its bound),
//     and the refusals: an output node as a view, a size the webcam does not have, two views of
//     different sizes.
// (b) loopback: each instance's HDMI output looped to its HDMI capture input (vivid's "Loop
//     Video" control; both sides 640x480p59.94 DV timings, GREY 640x480 progressive, OSD text off),
//     left.png on instance 0, right.png on instance 1; the captured pairs must equal the files byte
//     for byte, and the disparity of a captured pair must equal the disparity of the pair read from
//     the files here and the host's reference.s16. Then left.png | right.png as one 1280x720
//     HDMI picture through the side-by-side source: the two views must be the files.
// (c) disconnect: while the pair streams, vivid's "Disconnect" control on the right node (it
//     unregisters the node as a hot-unplug does); next() must report `disconnected` naming the
//     node, keep reporting it, and the source must tear down without hanging.
// Every wait is bounded (next() timeouts, and an alarm for the whole program). Exit 0 when every
// check passed; each failed check prints one "FAIL:" line.
#include <dirent.h>
#include <fcntl.h>
#include <linux/v4l2-dv-timings.h>
#include <linux/videodev2.h>
#include <png.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/disparity_engine.h"
#include "io/camera/pixel_format.h"
#include "io/camera/timestamp_pairing.h"
#include "io/camera/v4l2_device.h"
#include "io/camera/v4l2_stereo_source.h"

namespace {

using lpstereo::ElementType;
using lpstereo::Plane;
using namespace lpstereo::io;
using std::chrono::milliseconds;

// vivid's controls (drivers/media/test-drivers/vivid/vivid-ctrls.c): the driver's own class.
constexpr uint32_t kVividControlBase = 0x00f00000 | 0xf000;
constexpr uint32_t kVividOsdTextMode = kVividControlBase + 1;  // menu: 0 all, 1 counters only, 2 none
constexpr uint32_t kVividLoopVideo = kVividControlBase + 37;   // boolean
constexpr uint32_t kVividPercentDropped = kVividControlBase + 64;  // 0..100: buffers the driver drops
constexpr uint32_t kVividDisconnect = kVividControlBase + 65;  // button
constexpr int kLoopWidth = 640, kLoopHeight = 480;             // 640x480p59.94, the smallest CEA/DMT timings
constexpr milliseconds kFrameTimeout{3000};                    // generous: TCG runs vivid's threads slowly

int failures = 0;

void check(bool condition, const std::string& what) {
  if (!condition) {
    ++failures;
    std::printf("FAIL: %s\n", what.c_str());
  }
}

int64_t monotonic_now_ns() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return int64_t{now.tv_sec} * 1000000000 + now.tv_nsec;
}

std::string read_text(const std::string& path) {
  std::ifstream file(path);
  std::string line;
  std::getline(file, line);
  return line;
}

// The vivid nodes by card name ("vivid-000-vid-cap" -> /dev/videoN), from sysfs.
std::map<std::string, std::string> vivid_nodes() {
  std::map<std::string, std::string> nodes;
  DIR* directory = ::opendir("/sys/class/video4linux");
  if (!directory) return nodes;
  while (dirent* entry = ::readdir(directory)) {
    const std::string name = entry->d_name;
    if (name.rfind("video", 0) != 0) continue;
    nodes[read_text("/sys/class/video4linux/" + name + "/name")] = "/dev/" + name;
  }
  ::closedir(directory);
  return nodes;
}

// An 8-bit grey PNG (libpng's simplified API, statically linked: the VM has no OpenCV).
Plane read_grey_png(const std::string& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) {
    throw std::runtime_error(path + ": cannot read PNG (" + image.message + ")");
  }
  image.format = PNG_FORMAT_GRAY;
  Plane plane(static_cast<int>(image.width), static_cast<int>(image.height), {ElementType::u8, 0});
  if (!png_image_finish_read(&image, nullptr, plane.row<uint8_t>(0), static_cast<png_int_32>(plane.stride_bytes()),
                             nullptr)) {
    throw std::runtime_error(path + ": cannot decode PNG (" + image.message + ")");
  }
  return plane;
}

// Raw int16 Q4, little-endian, no padding (io/disparity_io.h's s16 format; that reader needs
// OpenCV's library, which this static program does not link).
Plane read_s16(const std::string& path, int width, int height) {
  std::ifstream file(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const size_t expected = size_t{2} * width * height;
  if (bytes.size() != expected) {
    throw std::runtime_error(path + ": expected " + std::to_string(expected) + " bytes (" + std::to_string(width) +
                             "x" + std::to_string(height) + " s16), got " + std::to_string(bytes.size()));
  }
  Plane plane(width, height, {ElementType::s16, 4});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t at = 2 * (size_t{1} * y * width + x);
      plane.at<int16_t>(x, y) = static_cast<int16_t>(static_cast<uint8_t>(bytes[at]) |
                                                     (static_cast<uint8_t>(bytes[at + 1]) << 8));
    }
  }
  return plane;
}

// Pixels that differ between two planes of one size and element type (-1: sizes differ).
long differing_pixels(const Plane& a, const Plane& b) {
  if (a.width() != b.width() || a.height() != b.height() || a.element_size() != b.element_size()) return -1;
  long differing = 0;
  const size_t row_bytes = static_cast<size_t>(a.width()) * a.element_size();
  for (int y = 0; y < a.height(); ++y) {
    const uint8_t* row_a = a.row<uint8_t>(y);
    const uint8_t* row_b = b.row<uint8_t>(y);
    for (size_t i = 0; i < row_bytes; i += a.element_size()) {
      differing += std::memcmp(row_a + i, row_b + i, a.element_size()) != 0;
    }
  }
  return differing;
}

double mean_and_spread(const Plane& luma, double& spread) {
  double sum = 0, sum_squares = 0;
  for (int y = 0; y < luma.height(); ++y) {
    for (int x = 0; x < luma.width(); ++x) {
      const double value = luma.at<uint8_t>(x, y);
      sum += value;
      sum_squares += value * value;
    }
  }
  const double count = static_cast<double>(luma.width()) * luma.height();
  const double mean = sum / count;
  spread = sum_squares / count - mean * mean;
  return mean;
}

// Runs `pairs` pairs through `source` and checks what every capture must satisfy. Returns the
// pairs (for the loopback's comparisons).
std::vector<StereoFrame> capture_and_check(StereoSource& source, int pairs, const std::string& label,
                                           int64_t tolerance_ns) {
  std::vector<StereoFrame> frames;
  for (int i = 0; i < pairs; ++i) {
    SourceResult result = source.next(kFrameTimeout);
    if (result.status != SourceStatus::frame) {
      check(false, label + ": pair " + std::to_string(i) + ": expected a frame, got status " +
                       std::to_string(static_cast<int>(result.status)) + " (" + result.message + ")");
      return frames;
    }
    const StereoFrame& frame = result.frame;
    const int64_t now_ns = monotonic_now_ns();
    std::printf("  %s pair %" PRIu64 ": left seq %" PRIu64 " t %.6f s, right seq %" PRIu64
                " t %.6f s, difference %+.3f ms\n",
                label.c_str(), frame.index, frame.left_sequence, frame.left_timestamp_ns * 1e-9, frame.right_sequence,
                frame.right_timestamp_ns * 1e-9, (frame.right_timestamp_ns - frame.left_timestamp_ns) * 1e-6);
    check(frame.left.width() == source.width() && frame.left.height() == source.height() &&
              frame.right.width() == source.width() && frame.right.height() == source.height(),
          label + ": view sizes differ from the source's");
    const int64_t difference_ns = frame.left_timestamp_ns - frame.right_timestamp_ns;
    check(difference_ns <= tolerance_ns && -difference_ns <= tolerance_ns,
          label + ": views " + std::to_string(difference_ns) + " ns apart, tolerance " + std::to_string(tolerance_ns));
    // CLOCK_MONOTONIC: near now (a CLOCK_REALTIME stamp would be decades off). vivid stamps the end
    // of exposure, 0.9 frame period after it fills the buffer (vivid-kthread-cap.c), so a stamp
    // may lie up to a period after the dequeue.
    for (int64_t stamp_ns : {frame.left_timestamp_ns, frame.right_timestamp_ns}) {
      check(stamp_ns < now_ns + 1000000000 && now_ns - stamp_ns < int64_t{10} * 1000000000,
            label + ": timestamp " + std::to_string(stamp_ns) + " ns is not on CLOCK_MONOTONIC (now " +
                std::to_string(now_ns) + ")");
    }
    if (!frames.empty()) {
      const StereoFrame& previous = frames.back();
      // vivid numbers a frame by the frame periods elapsed since STREAMON, rounded to the nearest
      // (vivid-kthread-cap.c); when its thread runs late under load, two consecutive frames can
      // get the same number. So: never backwards, and timestamps strictly increasing (below).
      check(frame.left_sequence >= previous.left_sequence && frame.right_sequence >= previous.right_sequence,
            label + ": sequence numbers went backwards");
      if (frame.left_sequence == previous.left_sequence || frame.right_sequence == previous.right_sequence) {
        std::printf("  %s: a sequence number repeated (vivid's thread ran late)\n", label.c_str());
      }
      check(frame.left_timestamp_ns > previous.left_timestamp_ns &&
                frame.right_timestamp_ns > previous.right_timestamp_ns,
            label + ": timestamps did not increase");
      check(frame.index == previous.index + 1, label + ": pair index did not count up");
    }
    frames.push_back(frame);
  }
  if (frames.size() > 1) {
    check(frames.back().left_sequence > frames.front().left_sequence &&
              frames.back().right_sequence > frames.front().right_sequence,
          label + ": sequence numbers did not increase over " + std::to_string(frames.size()) + " pairs");
  }
  return frames;
}

void print_statistics(const StereoSource& source) {
  const SourceStatistics statistics = source.statistics();
  std::printf("  statistics: %" PRIu64 " pairs; frames left %" PRIu64 " right %" PRIu64 "; driver drops left %" PRIu64
              " right %" PRIu64 "; unpaired left %" PRIu64 " right %" PRIu64 "\n",
              statistics.pairs_delivered, statistics.left_frames, statistics.right_frames, statistics.left_driver_drops,
              statistics.right_driver_drops, statistics.left_unpaired, statistics.right_unpaired);
}

// Selects an input on a capture node by the start of its name ("Webcam", "HDMI"); returns its index.
int select_input_named(V4l2CaptureDevice& device, const std::string& prefix) {
  for (uint32_t index = 0;; ++index) {
    v4l2_input input{};
    input.index = index;
    if (::ioctl(device.fd(), VIDIOC_ENUMINPUT, &input) != 0) break;
    if (std::string(reinterpret_cast<const char*>(input.name)).rfind(prefix, 0) == 0) {
      device.select_input(static_cast<int>(index));
      return static_cast<int>(index);
    }
  }
  throw std::runtime_error(device.name() + ": no input named " + prefix + "*");
}

// The HDMI timings of a picture size: the CEA-861 ones vivid accepts (linux/v4l2-dv-timings.h).
v4l2_dv_timings hdmi_timings(int width, int height) {
  if (width == 640 && height == 480) return V4L2_DV_BT_CEA_640X480P59_94;
  if (width == 1280 && height == 720) return V4L2_DV_BT_CEA_1280X720P60;
  throw std::runtime_error("no HDMI timings for " + std::to_string(width) + "x" + std::to_string(height) +
                           " (expected 640x480 or 1280x720)");
}

// A capture node on its HDMI input with the timings of width x height, looping its instance's
// video output, without text over the picture.
void loop_hdmi_input(const std::string& node, int width, int height) {
  V4l2CaptureDevice device(node);
  const int input = select_input_named(device, "HDMI");
  v4l2_dv_timings timings = hdmi_timings(width, height);
  if (::ioctl(device.fd(), VIDIOC_S_DV_TIMINGS, &timings) != 0) {
    throw std::runtime_error(node + ": VIDIOC_S_DV_TIMINGS " + std::to_string(width) + "x" + std::to_string(height) +
                             " failed (" + std::strerror(errno) + ")");
  }
  device.set_control(kVividLoopVideo, 1);
  device.set_control(kVividOsdTextMode, 2);  // no text drawn over the looped picture
  std::printf("  %s: input %d (HDMI), %dx%d timings, loop_video 1, osd_text_mode none\n", node.c_str(), input, width,
              height);
}

// A vivid video output node streaming one picture for ever: vivid's output thread keeps the last
// queued buffer as the current picture (vivid-kthread-out.c), so the looped capture input shows it.
class LoopOutput {
 public:
  LoopOutput(const std::string& path, const Plane& picture) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) fail("cannot open");
    int output = -1;
    for (uint32_t index = 0;; ++index) {
      v4l2_output description{};
      description.index = index;
      if (::ioctl(fd_, VIDIOC_ENUMOUTPUT, &description) != 0) break;
      if (std::string(reinterpret_cast<const char*>(description.name)).rfind("HDMI", 0) == 0) {
        output = static_cast<int>(index);
        break;
      }
    }
    if (output < 0 || ::ioctl(fd_, VIDIOC_S_OUTPUT, &output) != 0) fail("no HDMI output to select");
    v4l2_dv_timings timings = hdmi_timings(picture.width(), picture.height());
    if (::ioctl(fd_, VIDIOC_S_DV_TIMINGS, &timings) != 0) fail("VIDIOC_S_DV_TIMINGS");
    v4l2_format format{};
    format.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    format.fmt.pix.width = static_cast<uint32_t>(picture.width());
    format.fmt.pix.height = static_cast<uint32_t>(picture.height());
    format.fmt.pix.pixelformat = V4L2_PIX_FMT_GREY;
    format.fmt.pix.field = V4L2_FIELD_NONE;
    if (::ioctl(fd_, VIDIOC_S_FMT, &format) != 0) fail("VIDIOC_S_FMT GREY");
    if (format.fmt.pix.pixelformat != V4L2_PIX_FMT_GREY ||
        format.fmt.pix.width != static_cast<uint32_t>(picture.width()) ||
        format.fmt.pix.height != static_cast<uint32_t>(picture.height()) || format.fmt.pix.field != V4L2_FIELD_NONE) {
      throw std::runtime_error(path + ": expected GREY " + std::to_string(picture.width()) + "x" +
                               std::to_string(picture.height()) + " progressive, the driver set " +
                               fourcc_text(format.fmt.pix.pixelformat) + " " + std::to_string(format.fmt.pix.width) +
                               "x" + std::to_string(format.fmt.pix.height));
    }
    std::printf("  output %s: HDMI output %d, GREY %ux%u, bytesperline %u, sizeimage %u\n", path.c_str(), output,
                format.fmt.pix.width, format.fmt.pix.height, format.fmt.pix.bytesperline, format.fmt.pix.sizeimage);
    v4l2_requestbuffers request{};
    request.count = 2;
    request.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    request.memory = V4L2_MEMORY_MMAP;
    if (::ioctl(fd_, VIDIOC_REQBUFS, &request) != 0 || request.count < 1) fail("VIDIOC_REQBUFS");
    for (uint32_t index = 0; index < request.count; ++index) {
      v4l2_buffer buffer{};
      buffer.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
      buffer.memory = V4L2_MEMORY_MMAP;
      buffer.index = index;
      if (::ioctl(fd_, VIDIOC_QUERYBUF, &buffer) != 0) fail("VIDIOC_QUERYBUF");
      void* address = ::mmap(nullptr, buffer.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buffer.m.offset);
      if (address == MAP_FAILED) fail("mmap");
      mappings_.emplace_back(address, buffer.length);
      for (int y = 0; y < picture.height(); ++y) {
        std::memcpy(static_cast<uint8_t*>(address) + static_cast<size_t>(y) * format.fmt.pix.bytesperline,
                    picture.row<uint8_t>(y), static_cast<size_t>(picture.width()));
      }
      buffer.bytesused = format.fmt.pix.sizeimage;
      buffer.field = V4L2_FIELD_NONE;
      if (::ioctl(fd_, VIDIOC_QBUF, &buffer) != 0) fail("VIDIOC_QBUF");
    }
    int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    if (::ioctl(fd_, VIDIOC_STREAMON, &type) != 0) fail("VIDIOC_STREAMON");
  }
  ~LoopOutput() {
    int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    ::ioctl(fd_, VIDIOC_STREAMOFF, &type);
    for (const auto& [address, length] : mappings_) ::munmap(address, length);
    ::close(fd_);
  }
  LoopOutput(const LoopOutput&) = delete;
  LoopOutput& operator=(const LoopOutput&) = delete;

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(path_ + ": " + what + " (" + std::strerror(errno) + ")");
  }
  std::string path_;
  int fd_ = -1;
  std::vector<std::pair<void*, size_t>> mappings_;
};

void print_device(const std::string& path) {
  V4l2CaptureDevice device(path);
  std::string formats;
  for (const std::string& fourcc : device.offered_fourccs()) formats += " " + fourcc;
  std::printf("  %s: driver %s, card %s, formats%s\n", path.c_str(), device.driver().c_str(), device.card().c_str(),
              formats.c_str());
}

// 320x180 at 30 fps: one of vivid's webcam sizes and intervals, small enough for the VM.
SourceOptions webcam_options(const std::string& pixel_format) {
  SourceOptions options;
  options.width = 320;
  options.height = 180;
  options.frame_rate_hz = 30;
  options.pixel_format = pixel_format;
  return options;
}

// (a) Two webcam inputs through the stereo source in each format; then one node side by side.
void test_capture(const std::string& left_node, const std::string& right_node) {
  std::printf("== (a) capture from two vivid capture devices\n");
  for (const std::string& node : {left_node, right_node}) {
    V4l2CaptureDevice device(node);
    const int input = select_input_named(device, "Webcam");
    // No text over the test pattern: it changes with the time, and without it the pattern is the
    // same picture in every format, so the luma of the YUV formats can be compared.
    device.set_control(kVividOsdTextMode, 2);
    std::printf("  %s: input %d (Webcam), osd_text_mode none\n", node.c_str(), input);
  }
  std::map<std::string, Plane> luma_by_format;
  for (const char* format : {"GREY", "YUYV", "UYVY", "NV12", "RGB888", "BGR888"}) {
    auto source = open_v4l2_stereo_source({left_node, right_node}, false, webcam_options(format));
    std::printf("  %s\n", source->description().c_str());
    const std::string expected_format = std::string(format) + " 320x180";
    check(source->description().find(expected_format + " at 30 fps") != std::string::npos,
          std::string(format) + ": expected both devices at " + expected_format + " at 30 fps: " + source->description());
    check(source->width() == 320 && source->height() == 180, std::string(format) + ": source size is not 320x180");
    check(source->frame_rate_hz() == 30.0, std::string(format) + ": rate " + std::to_string(source->frame_rate_hz()));
    const std::vector<StereoFrame> frames =
        capture_and_check(*source, 6, format, default_pairing_tolerance_ns(source->frame_rate_hz()));
    check(frames.size() == 6, std::string(format) + ": expected 6 pairs, got " + std::to_string(frames.size()));
    if (!frames.empty()) {
      double spread = 0;
      const double mean = mean_and_spread(frames.back().left, spread);
      std::printf("  %s luma: mean %.1f, variance %.1f (vivid's test pattern)\n", format, mean, spread);
      check(spread > 100, std::string(format) + ": the luma is flat (variance " + std::to_string(spread) + ")");
      luma_by_format[format] = frames.back().left;
    }
    print_statistics(*source);
  }
  // vivid's test pattern generator computes one Y per pixel for every Y'CbCr format (GREY is
  // full range, the others limited range, so GREY differs): the luma of YUYV, UYVY and NV12 must
  // be the same bytes, which checks that each layout's Y samples were picked from the right places.
  // Likewise RGB888 and BGR888 carry one picture in two byte orders; red and blue weigh differently
  // in BT.601 luma, so a swapped order would show.
  for (const auto& [reference, format] : {std::pair<const char*, const char*>{"YUYV", "UYVY"},
                                          {"YUYV", "NV12"}, {"RGB888", "BGR888"}}) {
    if (!luma_by_format.count(reference) || !luma_by_format.count(format)) continue;
    const long differing = differing_pixels(luma_by_format[reference], luma_by_format[format]);
    std::printf("  luma of %s vs %s: %ld differing pixels\n", format, reference, differing);
    check(differing == 0, std::string(format) + ": luma differs from " + reference + "'s in " +
                              std::to_string(differing) + " pixels");
  }
  SourceOptions options;
  options.width = 320;  // of each view: the device runs 640x360, a vivid webcam size
  options.height = 360;
  options.frame_rate_hz = 30;
  options.pixel_format = "YUYV";
  auto source = open_v4l2_stereo_source({left_node}, true, options);
  std::printf("  %s\n", source->description().c_str());
  check(source->width() == 320 && source->height() == 360, "side by side: views are not 320x360");
  const std::vector<StereoFrame> frames = capture_and_check(*source, 3, "sbs", 0);
  check(frames.size() == 3, "side by side: expected 3 pairs");
  print_statistics(*source);
}

// What the real driver must refuse, one line each: a node that is not a capture node, a size the
// driver does not deliver, two views of different sizes.
void test_refusals(const std::string& left_node, const std::string& right_node, const std::string& output_node) {
  std::printf("== refusals\n");
  const auto refusal = [](const std::vector<std::string>& devices, const SourceOptions& options) -> std::string {
    try {
      open_v4l2_stereo_source(devices, false, options);
    } catch (const SourceError& error) {
      return error.what();
    }
    return "(no error)";
  };
  SourceOptions options;
  options.pixel_format = "YUYV";
  std::string message = refusal({left_node, output_node}, options);
  std::printf("  output node as a view: %s\n", message.c_str());
  check(message.rfind(output_node + " (vivid): expected a single-planar video capture device with streaming I/O, got "
                                    "video output",
                      0) == 0,
        "an output node was not refused as such: " + message);
  options.width = 1000;
  options.height = 1000;
  message = refusal({left_node, right_node}, options);
  std::printf("  1000x1000: %s\n", message.c_str());
  check(message.rfind(left_node + " (vivid): size 1000x1000 requested, the driver set ", 0) == 0,
        "a size the webcam does not have was not refused: " + message);
  {
    V4l2CaptureDevice left(left_node), right(right_node);
    left.set_format(CameraPixelFormat::yuyv, 320, 180);
    right.set_format(CameraPixelFormat::yuyv, 640, 360);
  }
  options.width = options.height = 0;  // each device's current size
  message = refusal({left_node, right_node}, options);
  std::printf("  different sizes: %s\n", message.c_str());
  check(message == "v4l2: left " + left_node + " (vivid) delivers 320x180 and right " + right_node +
                       " (vivid) 640x360: expected one size for both views",
        "views of different sizes were not refused: " + message);
}

// (b) Each instance's output looped to its capture: the pair back byte for byte, and its disparity.
void test_loopback(const std::string& left_node, const std::string& right_node, const std::string& left_output,
                   const std::string& right_output, const std::string& data_dir) {
  std::printf("== (b) loopback: video output -> HDMI -> video capture\n");
  const Plane left_file = read_grey_png(data_dir + "/left.png");
  const Plane right_file = read_grey_png(data_dir + "/right.png");
  const Plane reference = read_s16(data_dir + "/reference.s16", kLoopWidth, kLoopHeight);
  std::printf("  pair %dx%d from %s, reference disparity from the host's lpstereo disparity\n", left_file.width(),
              left_file.height(), data_dir.c_str());
  if (left_file.width() != kLoopWidth || left_file.height() != kLoopHeight || right_file.width() != kLoopWidth ||
      right_file.height() != kLoopHeight) {
    check(false, "loopback: the pair must be 640x480 (the HDMI timings)");
    return;
  }
  loop_hdmi_input(left_node, kLoopWidth, kLoopHeight);
  loop_hdmi_input(right_node, kLoopWidth, kLoopHeight);
  LoopOutput left_loop(left_output, left_file);
  LoopOutput right_loop(right_output, right_file);

  SourceOptions options;
  options.width = kLoopWidth;
  options.height = kLoopHeight;
  options.pixel_format = "GREY";
  // Pairs within one frame period (16.7 ms at 59.94 fps) rather than half: the two instances run
  // free at a phase set by when their threads started, and vivid stamps frames when its thread
  // wakes on a jiffy (4 ms at Debian's HZ = 250), so at 60 fps the views can sit near half a
  // period apart with jitter across it. This part checks the pictures; (a) checks the default.
  options.pairing_tolerance_ns = 17'000'000;
  auto source = open_v4l2_stereo_source({left_node, right_node}, false, options);
  std::printf("  %s\n", source->description().c_str());
  // The first frames may still show the input's own picture while the loop settles.
  const std::vector<StereoFrame> frames = capture_and_check(*source, 10, "loop", options.pairing_tolerance_ns);
  int first_equal = -1, equal = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const bool same = differing_pixels(frames[i].left, left_file) == 0 && differing_pixels(frames[i].right, right_file) == 0;
    if (same && first_equal < 0) first_equal = static_cast<int>(i);
    if (first_equal >= 0) {
      check(same, "loop: pair " + std::to_string(i) + " differs from the files after pair " +
                      std::to_string(first_equal) + " equalled them (" +
                      std::to_string(differing_pixels(frames[i].left, left_file)) + " left and " +
                      std::to_string(differing_pixels(frames[i].right, right_file)) + " right pixels)");
    }
    equal += same;
  }
  std::printf("  %d of %zu captured pairs equal left.png and right.png byte for byte (first: pair %d)\n", equal,
              frames.size(), first_equal);
  print_statistics(*source);
  check(equal >= 5, "loop: expected at least 5 captured pairs equal to the files, got " + std::to_string(equal));
  if (first_equal < 0) return;

  lpstereo::arm::DisparityParameters parameters;
  parameters.num_disparities = 64;
  lpstereo::arm::DisparityEngine engine(kLoopWidth, kLoopHeight, parameters, {}, 1);
  const Plane from_capture = engine.compute(frames[first_equal].left, frames[first_equal].right).clone();
  const Plane from_files = engine.compute(left_file, right_file).clone();
  const long capture_vs_files = differing_pixels(from_capture, from_files);
  const long capture_vs_host = differing_pixels(from_capture, reference);
  long valid = 0;
  for (int y = 0; y < kLoopHeight; ++y) {
    for (int x = 0; x < kLoopWidth; ++x) valid += from_capture.at<int16_t>(x, y) != engine.invalid_disparity_q4();
  }
  std::printf("  disparity (%s): %ld valid pixels; captured vs files %ld differing, captured vs host reference %ld "
              "differing\n",
              lpstereo::arm::settings_text(parameters).c_str(), valid, capture_vs_files, capture_vs_host);
  check(capture_vs_files == 0, "loop: the captured pair's disparity differs from the files' in " +
                                   std::to_string(capture_vs_files) + " pixels");
  check(capture_vs_host == 0, "loop: the captured pair's disparity differs from the host's reference in " +
                                  std::to_string(capture_vs_host) + " pixels");
  check(valid > kLoopWidth * kLoopHeight / 4, "loop: fewer than a quarter of the disparities are valid");
}

// Frames the driver drops on one view (vivid's "Percentage of Dropped Buffers": the sequence
// numbers still count them), then that view stalling completely while the other streams on.
void test_drops_and_stall(const std::string& left_node, const std::string& right_node) {
  std::printf("== drops and a stalled view\n");
  auto source = open_v4l2_stereo_source({left_node, right_node}, false, webcam_options("GREY"));
  std::printf("  %s\n", source->description().c_str());
  V4l2CaptureDevice right_controls(right_node);  // a second handle: controls may change while streaming
  right_controls.set_control(kVividPercentDropped, 50);
  std::printf("  %s: 50 %% of the buffers dropped by the driver\n", right_node.c_str());
  capture_and_check(*source, 10, "drops", default_pairing_tolerance_ns(30));
  print_statistics(*source);
  const SourceStatistics dropped = source->statistics();
  // 10 pairs take about 20 right ticks at 50 %: the chance that none was dropped is about 2^-20.
  check(dropped.right_driver_drops > 0, "drops: no driver drops counted on the right view");
  check(dropped.left_unpaired > 0, "drops: no left frame left unpaired although right frames were dropped");
  check(dropped.left_frames >= dropped.pairs_delivered + dropped.left_unpaired,
        "drops: more left frames paired or discarded than dequeued");

  right_controls.set_control(kVividPercentDropped, 100);
  std::printf("  %s: 100 %% dropped (a stalled view)\n", right_node.c_str());
  // Frames already dequeued may still make a pair or two before the stall shows.
  SourceResult stalled;
  int calls = 0;
  double waited_s = 0;
  do {
    const auto start = std::chrono::steady_clock::now();
    stalled = source->next(milliseconds(500));
    waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ++calls;
  } while (stalled.status == SourceStatus::frame && calls < 5);
  std::printf("  next(500 ms) after %d calls: %s in %.3f s: %s\n", calls,
              stalled.status == SourceStatus::timeout ? "timeout" : "NOT timeout", waited_s, stalled.message.c_str());
  check(stalled.status == SourceStatus::timeout, "stall: expected status timeout");
  // A bound against a hang, not a measurement (a loaded host slows the VM): the wait must end.
  check(waited_s < 5.0, "stall: next(500 ms) took " + std::to_string(waited_s) + " s");
  check(source->statistics().left_unpaired > dropped.left_unpaired,
        "stall: the streaming left view's frames were not discarded");
  right_controls.set_control(kVividPercentDropped, 0);
  const SourceResult resumed = source->next(kFrameTimeout);
  std::printf("  drops off: %s\n", resumed.status == SourceStatus::frame ? "pairs again" : resumed.message.c_str());
  check(resumed.status == SourceStatus::frame, "stall: no pair after the right view resumed");
  print_statistics(*source);
}

// The side-by-side source on a looped picture: left.png | right.png in one 1280x720 HDMI frame
// (the pair in the top 480 rows, black below), split into two 640x720 views that must be the
// files byte for byte (black below).
void test_side_by_side_loopback(const std::string& node, const std::string& output, const std::string& data_dir) {
  std::printf("== side by side through the loopback\n");
  const Plane left_file = read_grey_png(data_dir + "/left.png");
  const Plane right_file = read_grey_png(data_dir + "/right.png");
  constexpr int kViewWidth = 640, kViewHeight = 720;
  Plane picture(2 * kViewWidth, kViewHeight, {ElementType::u8, 0});
  Plane left_expected(kViewWidth, kViewHeight, {ElementType::u8, 0});
  Plane right_expected(kViewWidth, kViewHeight, {ElementType::u8, 0});
  for (int y = 0; y < left_file.height(); ++y) {
    std::memcpy(picture.row<uint8_t>(y), left_file.row<uint8_t>(y), static_cast<size_t>(left_file.width()));
    std::memcpy(picture.row<uint8_t>(y) + kViewWidth, right_file.row<uint8_t>(y), static_cast<size_t>(right_file.width()));
    std::memcpy(left_expected.row<uint8_t>(y), left_file.row<uint8_t>(y), static_cast<size_t>(left_file.width()));
    std::memcpy(right_expected.row<uint8_t>(y), right_file.row<uint8_t>(y), static_cast<size_t>(right_file.width()));
  }
  loop_hdmi_input(node, 2 * kViewWidth, kViewHeight);
  LoopOutput loop(output, picture);
  SourceOptions options;
  options.width = kViewWidth;  // of each view
  options.height = kViewHeight;
  options.pixel_format = "GREY";
  auto source = open_v4l2_stereo_source({node}, true, options);
  std::printf("  %s\n", source->description().c_str());
  const std::vector<StereoFrame> frames = capture_and_check(*source, 5, "sbs loop", 0);
  int first_equal = -1, equal = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const long left_differing = differing_pixels(frames[i].left, left_expected);
    const long right_differing = differing_pixels(frames[i].right, right_expected);
    const bool same = left_differing == 0 && right_differing == 0;
    if (same && first_equal < 0) first_equal = static_cast<int>(i);
    if (first_equal >= 0) {
      check(same, "sbs loop: frame " + std::to_string(i) + " differs from the pair (" + std::to_string(left_differing) +
                      " left and " + std::to_string(right_differing) + " right pixels)");
    }
    equal += same;
  }
  std::printf("  %d of %zu side-by-side frames split into left.png and right.png byte for byte (first: %d)\n", equal,
              frames.size(), first_equal);
  check(equal >= 3, "sbs loop: expected at least 3 frames equal to the pair, got " + std::to_string(equal));
}

// (c) A device removed while streaming: reported, sticky, and a clean teardown.
void test_disconnect(const std::string& left_node, const std::string& right_node) {
  std::printf("== (c) disconnect while streaming\n");
  for (const std::string& node : {left_node, right_node}) {
    V4l2CaptureDevice device(node);
    device.set_control(kVividLoopVideo, 0);
    select_input_named(device, "Webcam");
  }
  auto source = open_v4l2_stereo_source({left_node, right_node}, false, webcam_options("YUYV"));
  std::printf("  %s\n", source->description().c_str());
  capture_and_check(*source, 3, "before", default_pairing_tolerance_ns(30));
  {
    // A second handle on the right node, as a hot-unplug would come from outside the program.
    V4l2CaptureDevice control_handle(right_node);
    control_handle.set_control(kVividDisconnect, 1);
    std::printf("  %s: vivid Disconnect control pressed\n", right_node.c_str());
  }
  SourceResult result;
  int calls = 0;
  const auto start = std::chrono::steady_clock::now();
  do {
    result = source->next(milliseconds(1000));
    ++calls;
  } while (result.status == SourceStatus::frame && calls < 30);
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("  next() after %d calls (%.2f s): status %s: %s\n", calls, waited_s,
              result.status == SourceStatus::disconnected ? "disconnected" : "NOT disconnected", result.message.c_str());
  check(result.status == SourceStatus::disconnected, "disconnect: expected status disconnected");
  check(result.message.find(right_node) != std::string::npos, "disconnect: the message does not name " + right_node);
  const SourceResult again = source->next(milliseconds(100));
  check(again.status == SourceStatus::disconnected && again.message == result.message,
        "disconnect: a later next() does not report the same disconnect");
  print_statistics(*source);
  const auto teardown_start = std::chrono::steady_clock::now();
  source.reset();
  std::printf("  source closed in %.3f s (STREAMOFF, munmap, close)\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - teardown_start).count());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: vivid_capture_test DATA_DIR\n");
    return 2;
  }
  ::alarm(170);  // the whole run, whatever hangs (SIGALRM ends the program with a non-zero status)
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const auto start = std::chrono::steady_clock::now();
  try {
    const std::map<std::string, std::string> nodes = vivid_nodes();
    for (const auto& [card, path] : nodes) std::printf("node %s: %s\n", path.c_str(), card.c_str());
    const auto node = [&](const std::string& card) {
      const auto found = nodes.find(card);
      if (found == nodes.end()) throw std::runtime_error("no vivid node named " + card + " (is vivid loaded with n_devs=2 node_types=0x101,0x101?)");
      return found->second;
    };
    const std::string left_node = node("vivid-000-vid-cap"), right_node = node("vivid-001-vid-cap");
    const std::string left_output = node("vivid-000-vid-out"), right_output = node("vivid-001-vid-out");
    print_device(left_node);
    print_device(right_node);
    test_capture(left_node, right_node);
    test_drops_and_stall(left_node, right_node);
    test_refusals(left_node, right_node, left_output);
    test_loopback(left_node, right_node, left_output, right_output, argv[1]);
    test_side_by_side_loopback(left_node, left_output, argv[1]);
    test_disconnect(left_node, right_node);
  } catch (const std::exception& error) {
    check(false, std::string("exception: ") + error.what());
  }
  std::printf("vivid_capture_test: %s, %d failed checks, %.1f s\n", failures == 0 ? "PASSED" : "FAILED", failures,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return failures == 0 ? 0 : 1;
}
