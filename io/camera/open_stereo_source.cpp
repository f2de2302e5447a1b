// open_stereo_source: the spec grammar of io/camera/stereo_source.h, dispatched to the source of
// each kind. Recordings (files:) are io/camera/file_source.h; the live kinds are the V4L2 and
// libcamera sources.
#include <stdexcept>
#include <string>
#include <vector>

#include "io/camera/file_source.h"
#include "io/camera/stereo_source.h"
#include "io/camera/v4l2_stereo_source.h"
#include "io/frame_pattern.h"
#if LPSTEREO_WITH_LIBCAMERA
#include "io/camera/libcamera_source.h"
#endif

namespace lpstereo::io {

namespace {

const char* const kSpecForms =
    "v4l2:/dev/videoL,/dev/videoR, v4l2-sbs:/dev/videoN, libcamera:ID[,ID], files:LEFT_PATTERN,RIGHT_PATTERN or "
    "files:LEFT_VIDEO,RIGHT_VIDEO";

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> parts;
  size_t begin = 0;
  for (size_t comma = text.find(','); comma != std::string::npos; comma = text.find(',', begin)) {
    parts.push_back(text.substr(begin, comma - begin));
    begin = comma + 1;
  }
  parts.push_back(text.substr(begin));
  return parts;
}

std::unique_ptr<StereoSource> open_files(const std::string& spec, const std::string& arguments, const SourceOptions& options) {
  const std::vector<std::string> files = split_commas(arguments);
  if (files.size() != 2 || files[0].empty() || files[1].empty()) {
    throw std::invalid_argument("source '" + spec + "': expected files:LEFT,RIGHT (two printf patterns or two video files), got " +
                                std::to_string(files.size()) + " comma-separated name(s)" +
                                (files.size() == 2 ? " with one empty" : ""));
  }
  const bool left_pattern = FramePattern::has_conversion(files[0]), right_pattern = FramePattern::has_conversion(files[1]);
  if (left_pattern != right_pattern) {
    throw std::invalid_argument("source '" + spec + "': expected two patterns (with a %d conversion) or two video files, got " +
                                (left_pattern ? "a pattern and a file name" : "a file name and a pattern"));
  }
  if (!left_pattern) return std::make_unique<VideoFileSource>(files[0], files[1], options);
  try {
    return std::make_unique<ImageSequenceSource>(files[0], files[1], options);
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument("source '" + spec + "': " + error.what());
  }
}

}  // namespace

std::unique_ptr<StereoSource> open_stereo_source(const std::string& spec, const SourceOptions& options) {
  const size_t colon = spec.find(':');
  if (colon == std::string::npos || colon == 0) {
    throw std::invalid_argument("source '" + spec + "': expected KIND:ARGUMENTS, one of " + kSpecForms);
  }
  const std::string kind = spec.substr(0, colon), arguments = spec.substr(colon + 1);
  if (arguments.empty()) throw std::invalid_argument("source '" + spec + "': nothing after '" + kind + ":'; expected one of " + kSpecForms);
  if (kind == "files") return open_files(spec, arguments, options);
  if (kind == "v4l2" || kind == "v4l2-sbs") {
    const bool side_by_side = kind == "v4l2-sbs";
    const std::vector<std::string> devices = split_commas(arguments);
    const size_t expected = side_by_side ? 1 : 2;
    bool any_empty = false;
    for (const std::string& device : devices) any_empty = any_empty || device.empty();
    if (devices.size() != expected || any_empty) {
      throw std::invalid_argument("source '" + spec + "': expected " +
                                  (side_by_side ? std::string("v4l2-sbs:/dev/videoN (one device)")
                                                : std::string("v4l2:/dev/videoL,/dev/videoR (two devices)")) +
                                  ", got " + std::to_string(devices.size()) + " comma-separated name(s)" +
                                  (any_empty ? " with an empty one" : ""));
    }
    return open_v4l2_stereo_source(devices, side_by_side, options);
  }
  if (kind == "libcamera") {
#if LPSTEREO_WITH_LIBCAMERA
    return open_libcamera_stereo_source(split_commas(arguments), options);
#else
    throw SourceError("source '" + spec + "': this build has no libcamera source (libcamera-dev was not found when it was configured)");
#endif
  }
  throw std::invalid_argument("source '" + spec + "': unknown kind '" + kind + "'; expected one of " + kSpecForms);
}

}  // namespace lpstereo::io
