// The libcamera source against a real kernel driver: vimc (libcamera's reference virtual camera),
// built out of tree by tests/vm/build-vimc-module.sh and loaded in Debian's kernel under qemu
// (tests/vm/vimc_libcamera.sh boots the VM and runs this program in it, with libcamera's IPA
// module, its signature, its proxy and configuration, and systemd-udevd).
//
// Steps, each printed with "ok" or "FAIL" and what was expected and found:
//   1. udev: libcamera's device enumerator lists only media and V4L2 devices udev has initialised
//      (udev_enumerate_add_match_is_initialized) and learns of removals from udevd's monitor, so
//      systemd-udevd runs in the VM and `udevadm trigger` + `settle` initialise the devices;
//   2. the cameras libcamera finds: a vimc camera among them, with its formats;
//   2b. refusals on the real camera (a format it does not offer, one lpstereo does not convert, the
//      camera while in use: one line each) and a size validate() adjusts, reported;
//   3. side-by-side luma from the vimc camera through open_libcamera_stereo_source, with the default
//      format and then with the other RGB order requested: sizes, formats, increasing sequence
//      numbers, increasing CLOCK_MONOTONIC timestamps, the luma equal to a scalar BT.601 conversion
//      of the raw buffer, and the same colours read from both RGB orders;
//   4. a disconnect: the vimc platform device is unbound through sysfs while streaming; the source
//      must report SourceStatus::disconnected with one line within a bounded number of waits and
//      close without hanging or aborting. (libcamera 0.0.3's vimc pipeline handler does not watch
//      unplugs, so the source notices the vanished device nodes itself; the log shows what
//      libcamera did: udev's remove events, the failed re-queues, whether it still lists the camera.)
// Exit 0 when every check passed, 1 otherwise. A watchdog (alarm) turns a hang into a failure.
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "io/camera/libcamera_source.h"
#include "kernels/simd/isa.h"

namespace {

using namespace lpstereo;
using namespace lpstereo::io;
namespace fs = std::filesystem;

int failures = 0;

void check(bool passed, const std::string& what) {
  std::printf("%s %s\n", passed ? "ok  " : "FAIL", what.c_str());
  std::fflush(stdout);
  if (!passed) ++failures;
}

void note(const std::string& text) {
  std::printf("     %s\n", text.c_str());
  std::fflush(stdout);
}

// A hang anywhere (libcamera waiting on a vanished device) becomes a failure with the step's name.
const char* current_step = "start";
void on_watchdog(int) {
  const char prefix[] = "FAIL watchdog: stuck for 60 s in step: ";
  (void)!write(STDOUT_FILENO, prefix, sizeof(prefix) - 1);
  (void)!write(STDOUT_FILENO, current_step, std::char_traits<char>::length(current_step));
  (void)!write(STDOUT_FILENO, "\n", 1);
  _exit(1);
}
void step(const char* name) {
  current_step = name;
  alarm(60);
  std::printf("--- %s\n", name);
  std::fflush(stdout);
}

const char* status_name(SourceStatus status) {
  switch (status) {
    case SourceStatus::frame:
      return "frame";
    case SourceStatus::timeout:
      return "timeout";
    case SourceStatus::end_of_stream:
      return "end_of_stream";
    case SourceStatus::disconnected:
      return "disconnected";
  }
  return "?";
}

int64_t monotonic_now_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

// The scalar reference: luma of pixel x of a raw row. RGB: BT.601 Y = 0.299 R + 0.587 G + 0.114 B
// in Q14 with rounding (ITU-R BT.601; the integer weights round 0.299, 0.587, 0.114 x 2^14), as
// OpenCV's cvtColor integer path.
uint8_t reference_luma(CameraPixelFormat format, const uint8_t* row, int x) {
  switch (format) {
    case CameraPixelFormat::grey:
    case CameraPixelFormat::nv12:
      return row[x];
    case CameraPixelFormat::yuyv:
      return row[2 * x];
    case CameraPixelFormat::uyvy:
      return row[2 * x + 1];
    case CameraPixelFormat::rgb888:
      return static_cast<uint8_t>((row[3 * x] * 4899 + row[3 * x + 1] * 9617 + row[3 * x + 2] * 1868 + 8192) >> 14);
    case CameraPixelFormat::bgr888:
      return static_cast<uint8_t>((row[3 * x + 2] * 4899 + row[3 * x + 1] * 9617 + row[3 * x] * 1868 + 8192) >> 14);
  }
  return 0;
}

// A copy of the last raw buffer the source handed to its observer.
struct RawCopy {
  LibcameraRawFrame frame;
  std::vector<uint8_t> bytes;
  int frames_seen = 0;
};

LibcameraRawFrameObserver keep_in(RawCopy& copy) {
  return [&copy](const LibcameraRawFrame& frame) {
    copy.frame = frame;
    copy.bytes.assign(frame.data, frame.data + frame.bytes_per_line * static_cast<size_t>(frame.height));
    copy.frame.data = copy.bytes.data();
    ++copy.frames_seen;
  };
}

bool run(const std::string& program, const std::string& what) {
  const int status = std::system(program.c_str());
  check(status == 0, what + " (`" + program + "` exit status " + std::to_string(status) + ")");
  return status == 0;
}

void start_udev() {
  step("1. udev (libcamera's enumerator lists only devices udev initialised)");
  fs::create_directories("/run/udev");
  if (!run("/lib/systemd/systemd-udevd --daemon --resolve-names=never", "systemd-udevd started")) return;
  run("udevadm trigger --type=devices --action=add && udevadm settle --timeout=30", "udevadm trigger and settle");
  int media = 0, initialised = 0;
  for (const auto& entry : fs::directory_iterator("/sys/bus/media/devices")) {
    ++media;
    std::string device_number;
    std::ifstream(entry.path() / "dev") >> device_number;
    initialised += fs::exists("/run/udev/data/c" + device_number) ? 1 : 0;
  }
  check(media > 0 && initialised == media, "media devices initialised by udev: expected all of " +
                                               std::to_string(media) + ", found " + std::to_string(initialised));
}

std::string find_vimc_camera() {
  step("2. cameras libcamera finds");
  const std::vector<LibcameraCameraInfo> cameras = list_libcamera_cameras();
  std::string vimc_id;
  for (const LibcameraCameraInfo& camera : cameras) {
    note("camera '" + camera.id + "' model '" + camera.model + "'");
    for (const LibcameraStreamFormat& format : camera.formats) {
      note("  " + format.pixel_format + " " + std::to_string(format.min_width) + "x" +
           std::to_string(format.min_height) + " to " + std::to_string(format.max_width) + "x" +
           std::to_string(format.max_height) + ", " + std::to_string(format.sizes.size()) + " listed sizes");
    }
    if (vimc_id.empty() && camera.id.find("vimc") != std::string::npos) vimc_id = camera.id;
  }
  check(!vimc_id.empty(), "a vimc camera among the " + std::to_string(cameras.size()) + " found" +
                              (vimc_id.empty() ? "" : ": '" + vimc_id + "'"));
  return vimc_id;
}

// Expects opening to throw SourceError with one line containing every needle.
void expect_refused(const std::string& what, const std::vector<std::string>& camera_ids, const SourceOptions& options,
                    const std::vector<std::string>& needles) {
  try {
    open_libcamera_stereo_source(camera_ids, options);
    check(false, what + ": opened, expected a SourceError");
  } catch (const SourceError& error) {
    const std::string message = error.what();
    bool all = message.find('\n') == std::string::npos;
    for (const std::string& needle : needles) all = all && message.find(needle) != std::string::npos;
    check(all, what + ": " + message);
  }
}

void refusals_and_adjustments(const std::string& camera_id) {
  step("2b. what the vimc camera refuses or adjusts");
  SourceOptions nv12;
  nv12.pixel_format = "NV12";
  expect_refused("a format vimc does not offer", {camera_id}, nv12, {camera_id, "NV12", "BGR888", "RGB888"});
  SourceOptions unknown;
  unknown.pixel_format = "Y10P";
  expect_refused("a format lpstereo does not convert", {camera_id}, unknown,
                 {camera_id, "Y10P", "not one lpstereo converts"});
  // libcamera's vimc pipeline handler aligns the width down to a multiple of 6 (the x3 scaler of
  // older vimc times the sensor's 2-pixel alignment): 2 x 320 = 640 becomes 636, views of 318.
  SourceOptions unaligned;
  unaligned.width = 320;
  unaligned.height = 240;
  try {
    const std::unique_ptr<StereoSource> source = open_libcamera_stereo_source({camera_id}, unaligned);
    note(source->description());
    check(source->width() == 318 &&
              source->description().find("requested 640x240, adjusted to 636x240") != std::string::npos,
          "a 640-wide side-by-side request adjusted by validate() to 636 and reported, views of " +
              std::to_string(source->width()) + " px");
    expect_refused("the camera while a source streams from it", {camera_id}, SourceOptions{},
                   {camera_id, "cannot acquire"});
  } catch (const std::exception& error) {
    check(false, std::string("open 320x240 views: ") + error.what());
  }
}

// R,G,B of the middle row at 8 points across the frame, read in the byte order the source says
// the format has. Two streams of the same scene in the two RGB orders must give the same values:
// libcamera's BGR888 and RGB888 must be each other's byte swap in the way pixel_format.h maps them.
using ColourProfile = std::vector<std::array<int, 3>>;
ColourProfile colour_profile(const LibcameraRawFrame& frame) {
  ColourProfile profile;
  if (frame.format != CameraPixelFormat::rgb888 && frame.format != CameraPixelFormat::bgr888) return profile;
  const int red_byte = frame.format == CameraPixelFormat::rgb888 ? 0 : 2;
  const uint8_t* row = frame.data + frame.bytes_per_line * static_cast<size_t>(frame.height / 2);
  for (int point = 0; point < 8; ++point) {
    const uint8_t* pixel = row + 3 * ((2 * point + 1) * frame.width / 16);
    profile.push_back({pixel[red_byte], pixel[1], pixel[2 - red_byte]});
  }
  return profile;
}

std::string profile_text(const ColourProfile& profile) {
  std::string text;
  for (const auto& [red, green, blue] : profile) {
    text += " (" + std::to_string(red) + "," + std::to_string(green) + "," + std::to_string(blue) + ")";
  }
  return text;
}

ColourProfile stream(const std::string& camera_id, const std::string& pixel_format, int pairs_wanted) {
  const std::string title = "3. side-by-side luma from '" + camera_id + "', pixel format " +
                            (pixel_format.empty() ? std::string("default") : pixel_format);
  step(title.c_str());
  constexpr int kViewWidth = 321, kViewHeight = 240;
  SourceOptions options;
  options.width = kViewWidth;
  options.height = kViewHeight;
  options.pixel_format = pixel_format;
  RawCopy raw;
  std::unique_ptr<StereoSource> source;
  try {
    source = open_libcamera_stereo_source({camera_id}, options, keep_in(raw));
  } catch (const std::exception& error) {
    check(false, std::string("open: ") + error.what());
    return {};
  }
  note(source->description());
  check(source->width() == kViewWidth && source->height() == kViewHeight,
        "view size: expected " + std::to_string(kViewWidth) + "x" + std::to_string(kViewHeight) + ", got " +
            std::to_string(source->width()) + "x" + std::to_string(source->height()));
  int64_t previous_timestamp_ns = -1;
  int64_t previous_sequence = -1;
  uint64_t sequence_gaps = 0;
  int pairs = 0, luma_mismatches = 0, bad_timestamps = 0, bad_sequences = 0;
  int luma_min = 255, luma_max = 0;
  for (int attempt = 0; attempt < pairs_wanted + 5 && pairs < pairs_wanted; ++attempt) {
    const SourceResult result = source->next(std::chrono::milliseconds(3000));
    if (result.status != SourceStatus::frame) {
      check(false, "next(): expected a frame, got " + std::string(status_name(result.status)) + ": " + result.message);
      continue;
    }
    const StereoFrame& pair = result.frame;
    ++pairs;
    const int64_t now_ns = monotonic_now_ns();
    const bool timestamp_ok = pair.left_timestamp_ns == pair.right_timestamp_ns &&
                              pair.left_timestamp_ns > previous_timestamp_ns && pair.left_timestamp_ns <= now_ns &&
                              now_ns - pair.left_timestamp_ns < 10'000'000'000;
    const bool sequence_ok =
        pair.left_sequence == pair.right_sequence && static_cast<int64_t>(pair.left_sequence) > previous_sequence;
    bad_timestamps += timestamp_ok ? 0 : 1;
    bad_sequences += sequence_ok ? 0 : 1;
    if (previous_sequence >= 0 && sequence_ok) sequence_gaps += pair.left_sequence - previous_sequence - 1;
    std::printf("     pair %llu: sequence %llu, timestamp %.6f s (%.3f s ago)\n",
                static_cast<unsigned long long>(pair.index), static_cast<unsigned long long>(pair.left_sequence),
                static_cast<double>(pair.left_timestamp_ns) * 1e-9,
                static_cast<double>(now_ns - pair.left_timestamp_ns) * 1e-9);
    previous_timestamp_ns = pair.left_timestamp_ns;
    previous_sequence = static_cast<int64_t>(pair.left_sequence);
    // The luma against the raw buffer the observer saw for this pair.
    const LibcameraRawFrame& frame = raw.frame;
    if (frame.sequence != pair.left_sequence || frame.width != 2 * kViewWidth || frame.height != kViewHeight ||
        pair.left.width() != kViewWidth || pair.right.width() != kViewWidth || pair.left.height() != kViewHeight ||
        pair.right.height() != kViewHeight || pair.left.format().type != ElementType::u8) {
      check(false, "raw frame " + std::to_string(frame.width) + "x" + std::to_string(frame.height) + " sequence " +
                       std::to_string(frame.sequence) + " for pair sequence " + std::to_string(pair.left_sequence) +
                       ", expected " + std::to_string(2 * kViewWidth) + "x" + std::to_string(kViewHeight) +
                       " and the same sequence");
      continue;
    }
    for (int y = 0; y < kViewHeight; ++y) {
      const uint8_t* row = frame.data + frame.bytes_per_line * static_cast<size_t>(y);
      for (int x = 0; x < kViewWidth; ++x) {
        const uint8_t left = pair.left.at<uint8_t>(x, y), right = pair.right.at<uint8_t>(x, y);
        luma_mismatches += left != reference_luma(frame.format, row, x) ? 1 : 0;
        luma_mismatches += right != reference_luma(frame.format, row, x + kViewWidth) ? 1 : 0;
        luma_min = std::min({luma_min, static_cast<int>(left), static_cast<int>(right)});
        luma_max = std::max({luma_max, static_cast<int>(left), static_cast<int>(right)});
      }
    }
  }
  check(pairs == pairs_wanted,
        "pairs delivered: expected " + std::to_string(pairs_wanted) + ", got " + std::to_string(pairs));
  check(bad_sequences == 0,
        "sequence numbers increasing, left = right: " + std::to_string(bad_sequences) + " pairs out of order");
  check(bad_timestamps == 0, "timestamps increasing, left = right, CLOCK_MONOTONIC within 10 s of now: " +
                                 std::to_string(bad_timestamps) + " pairs wrong");
  check(luma_mismatches == 0, "luma equal to the scalar conversion of the raw " +
                                  std::string(pixel_format_name(raw.frame.format)) +
                                  " buffer: " + std::to_string(luma_mismatches) + " pixels differ");
  check(luma_max - luma_min > 100,
        "luma has content (vimc's colour bars): range " + std::to_string(luma_min) + ".." + std::to_string(luma_max));
  if (!pixel_format.empty()) {
    check(pixel_format_name(raw.frame.format) == pixel_format,
          "requested format " + pixel_format + ", got " + std::string(pixel_format_name(raw.frame.format)));
  }
  const SourceStatistics statistics = source->statistics();
  note("statistics: pairs " + std::to_string(statistics.pairs_delivered) + ", frames " +
       std::to_string(statistics.left_frames) + ", driver drops " + std::to_string(statistics.left_driver_drops) +
       ", sequence gaps between delivered pairs " + std::to_string(sequence_gaps) + ", frame rate " +
       std::to_string(source->frame_rate_hz()) + " Hz");
  check(statistics.pairs_delivered == static_cast<uint64_t>(pairs) &&
            statistics.left_frames >= statistics.pairs_delivered && statistics.left_driver_drops >= sequence_gaps &&
            statistics.right_frames == statistics.left_frames,
        "statistics consistent with the pairs (pairs = delivered, frames >= pairs, drops >= gaps seen)");
  const ColourProfile profile = raw.frames_seen > 0 ? colour_profile(raw.frame) : ColourProfile{};
  note("R,G,B of the middle row at 8 points, read as " + std::string(pixel_format_name(raw.frame.format)) + ":" +
       profile_text(profile));
  return profile;
}

void disconnect(const std::string& camera_id) {
  step("4. disconnect: unbind the vimc platform device while streaming");
  SourceOptions options;
  options.width = 160;
  options.height = 120;
  std::unique_ptr<StereoSource> source;
  try {
    source = open_libcamera_stereo_source({camera_id}, options);
  } catch (const std::exception& error) {
    check(false, std::string("open: ") + error.what());
    return;
  }
  const SourceResult first = source->next(std::chrono::milliseconds(3000));
  check(first.status == SourceStatus::frame, "a pair before the unbind");
  std::ofstream("/sys/bus/platform/drivers/vimc/unbind") << "vimc.0" << std::flush;
  check(!fs::exists("/sys/bus/platform/drivers/vimc/vimc.0"), "vimc.0 unbound (written to the driver's unbind)");
  SourceResult result;
  int waits = 0;
  for (; waits < 10; ++waits) {
    result = source->next(std::chrono::milliseconds(1000));
    note("after the unbind, next(1000 ms) #" + std::to_string(waits + 1) + ": " + status_name(result.status) +
         (result.message.empty() ? "" : ": " + result.message));
    if (result.status == SourceStatus::disconnected) break;
  }
  check(result.status == SourceStatus::disconnected, "the source reports disconnected within 10 waits: " +
                                                         (result.message.empty() ? "(no message)" : result.message));
  check(result.message.find(camera_id) != std::string::npos && result.message.find('\n') == std::string::npos,
        "the disconnect message is one line naming the camera");
  const SourceResult again = source->next(std::chrono::milliseconds(100));
  check(again.status == SourceStatus::disconnected, "and says so again on the next call");
  step("4. disconnect: closing the source");
  source.reset();  // libcamera would abort here if the source stopped the vanished camera; the watchdog catches a hang
  note("source closed after the disconnect");
  // libcamera 0.0.3 forgets a camera only when its pipeline handler watches unplugs (UVC only).
  bool still_listed = false;
  for (const LibcameraCameraInfo& camera : list_libcamera_cameras()) still_listed |= camera.id == camera_id;
  note(std::string("after the unbind libcamera ") + (still_listed ? "still lists" : "no longer lists") + " '" +
       camera_id + "'");
}

}  // namespace

int main() {
  signal(SIGALRM, on_watchdog);
  // The device enumerator's debug lines show udev's add and remove events (the disconnect path).
  setenv("LIBCAMERA_LOG_LEVELS", "DeviceEnumerator:DEBUG,*:WARN", 0);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  // convert_to_luma runs vector kernels at the best ISA level this (emulated) CPU has.
  std::printf("     luma kernels at ISA level %s\n", std::string(simd::isa_name(simd::active_isa())).c_str());
  start_udev();
  const std::string camera_id = find_vimc_camera();
  if (!camera_id.empty()) {
    refusals_and_adjustments(camera_id);
    const ColourProfile default_order = stream(camera_id, "", 8);
    const ColourProfile swapped_order = stream(camera_id, "BGR888", 4);
    bool red_differs_from_blue = false;
    for (const auto& [red, green, blue] : default_order) red_differs_from_blue |= red != blue;
    check(!default_order.empty() && default_order == swapped_order && red_differs_from_blue,
          "the same colours read from libcamera's BGR888 (our RGB888) and RGB888 (our BGR888), with red != blue "
          "somewhere:" +
              profile_text(default_order) + " and" + profile_text(swapped_order));
    disconnect(camera_id);
  }
  alarm(0);
  std::printf("=== vimc libcamera test: %s (%d failed checks)\n", failures == 0 ? "PASSED" : "FAILED", failures);
  return failures == 0 ? 0 : 1;
}
