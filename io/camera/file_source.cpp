#include "io/camera/file_source.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>


#include "io/camera/video_decoder.h"
#include "io/image_io.h"

namespace lpstereo::io {

namespace {

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// "1226x370 at 10 fps", the end of both descriptions.
std::string size_and_rate_text(int width, int height, double frame_rate_hz) {
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.3g", frame_rate_hz);
  return size_text(width, height) + " at " + rate + " fps";
}

bool exists(const std::string& path) {
  std::error_code ignored;
  return std::filesystem::exists(path, ignored);
}

// frame / rate in ns (rounded): the capture time a recording's frame stands for.
int64_t recording_timestamp_ns(int64_t frame, double frame_rate_hz) {
  return static_cast<int64_t>(std::llround(static_cast<double>(frame) * 1e9 / frame_rate_hz));
}

double recording_rate_hz(const SourceOptions& options, double own_rate_hz) {
  if (options.frame_rate_hz > 0) return options.frame_rate_hz;
  return own_rate_hz > 0 && std::isfinite(own_rate_hz) ? own_rate_hz : kDefaultRecordingRateHz;
}

// A recording has the size it was recorded at: a different requested size is refused, not scaled.
void check_requested_size(const SourceOptions& options, int width, int height, const std::string& name) {
  if ((options.width != 0 && options.width != width) || (options.height != 0 && options.height != height)) {
    throw SourceError(name + ": a recording cannot be resized: expected the requested " +
                      size_text(options.width != 0 ? options.width : width, options.height != 0 ? options.height : height) +
                      ", got " + size_text(width, height));
  }
}


// The pair of recorded frame `frame` as delivered: timestamps frame / rate, sequences = frame number,
// index = pairs delivered before; counted in `statistics`.
SourceResult delivered_pair(Plane left, Plane right, int64_t frame, double frame_rate_hz, SourceStatistics& statistics) {
  SourceResult result;
  result.status = SourceStatus::frame;
  StereoFrame& pair = result.frame;
  pair.left = std::move(left);
  pair.right = std::move(right);
  pair.left_timestamp_ns = pair.right_timestamp_ns = recording_timestamp_ns(frame, frame_rate_hz);
  pair.left_sequence = pair.right_sequence = static_cast<uint64_t>(frame);
  pair.index = statistics.pairs_delivered;
  ++statistics.pairs_delivered;
  ++statistics.left_frames;
  ++statistics.right_frames;
  return result;
}

}  // namespace

// ---- image sequences ----

ImageSequenceSource::ImageSequenceSource(const std::string& left_pattern, const std::string& right_pattern,
                                         const SourceOptions& options, int first_frame, int frame_limit)
    : left_(left_pattern), right_(right_pattern), frame_limit_(frame_limit), frame_rate_hz_(recording_rate_hz(options, 0)) {
  if (first_frame < -1) throw std::invalid_argument("first frame: expected >= 0 (or -1: 0 or 1), got " + std::to_string(first_frame));
  if (frame_limit < 0) throw std::invalid_argument("frame limit: expected >= 0 (0 = no limit), got " + std::to_string(frame_limit));
  first_frame_ = first_frame >= 0 ? first_frame
                 : (!exists(left_.path(0)) && !exists(right_.path(0)) && exists(left_.path(1))) ? 1
                                                                                               : 0;
  // The pairs, found by name alone: from the first frame to the first number with a view missing.
  while ((frame_limit_ == 0 || frame_count_ < frame_limit_) && first_frame_ + frame_count_ < std::numeric_limits<int>::max() &&
         exists(left_.path(first_frame_ + frame_count_)) && exists(right_.path(first_frame_ + frame_count_))) {
    ++frame_count_;
  }
  if (frame_count_ == 0) {
    const std::string left_path = left_.path(first_frame_), right_path = right_.path(first_frame_);
    throw SourceError("frame " + std::to_string(first_frame_) + " (the first): expected " + left_path + " and " + right_path +
                      ", " + (exists(left_path) ? right_path : left_path) + " not found");
  }
  first_left_ = read_view(left_.path(first_frame_), first_frame_);
  first_right_ = read_view(right_.path(first_frame_), first_frame_);
  if (first_left_.width() != first_right_.width() || first_left_.height() != first_right_.height()) {
    throw SourceError("view sizes differ: left " + left_.path(first_frame_) + " is " +
                      size_text(first_left_.width(), first_left_.height()) + ", right " + right_.path(first_frame_) + " is " +
                      size_text(first_right_.width(), first_right_.height()));
  }
  width_ = first_left_.width();
  height_ = first_left_.height();
  check_requested_size(options, width_, height_, left_.pattern());
}

Plane ImageSequenceSource::read_view(const std::string& path, int frame) const {
  Plane view;
  try {
    view = read_luma_u8(path);
  } catch (const ImageError& error) {
    throw SourceError("frame " + std::to_string(frame) + ": " + error.what());
  }
  if (width_ != 0 && (view.width() != width_ || view.height() != height_)) {
    throw SourceError("frame " + std::to_string(frame) + ": " + path + " is " + size_text(view.width(), view.height()) +
                      ", expected " + size_text(width_, height_) + " (the size of frame " + std::to_string(first_frame_) + ")");
  }
  return view;
}

SourceResult ImageSequenceSource::next(std::chrono::milliseconds /*timeout*/) {
  SourceResult result;
  if (next_offset_ >= frame_count_) {
    const int frame = first_frame_ + frame_count_;
    const bool limited = frame_limit_ != 0 && frame_count_ == frame_limit_;
    if (!limited && frame_count_ < std::numeric_limits<int>::max() - first_frame_) {
      // The scan stopped here: both views missing is the end; one of them present, a lost frame.
      const std::string left_path = left_.path(frame), right_path = right_.path(frame);
      const bool left_there = exists(left_path), right_there = exists(right_path);
      if (left_there != right_there) {
        throw SourceError("frame " + std::to_string(frame) + ": " + (left_there ? left_path : right_path) + " exists but " +
                          (left_there ? right_path : left_path) + " is missing (expected both views or neither)");
      }
    }
    result.status = SourceStatus::end_of_stream;
    result.message = "end of the sequence after frame " + std::to_string(frame - 1);
    return result;
  }
  const int frame = first_frame_ + next_offset_;
  Plane left = next_offset_ == 0 ? std::move(first_left_) : read_view(left_.path(frame), frame);
  Plane right = next_offset_ == 0 ? std::move(first_right_) : read_view(right_.path(frame), frame);
  ++next_offset_;
  return delivered_pair(std::move(left), std::move(right), frame, frame_rate_hz_, statistics_);
}

std::string ImageSequenceSource::description() const {
  return "files " + left_.pattern() + " + " + right_.pattern() + ": frames " + std::to_string(first_frame_) + ".." +
         std::to_string(first_frame_ + frame_count_ - 1) + " (" + std::to_string(frame_count_) + " pairs), " +
         size_and_rate_text(width_, height_, frame_rate_hz_);
}

// ---- video files ----

VideoFileSource::VideoFileSource(const std::string& left_path, const std::string& right_path, const SourceOptions& options)
    : left_path_(left_path), right_path_(right_path) {
  struct Opened {
    int width, height;
    int64_t frames;
    double rate_hz;
  };
  const auto open = [](std::unique_ptr<VideoDecoder>& decoder, const std::string& path) {
    if (!exists(path)) throw SourceError(path + ": no such file");
    try {
      decoder = open_video_decoder(path);
    } catch (const std::runtime_error& error) {
      throw SourceError(error.what());
    }
    return Opened{decoder->width(), decoder->height(), decoder->frame_count(), decoder->rate_hz()};
  };
  const Opened left = open(left_, left_path);
  const Opened right = open(right_, right_path);
  if (left.width != right.width || left.height != right.height) {
    throw SourceError("view sizes differ: left " + left_path + " is " + size_text(left.width, left.height) + ", right " +
                      right_path + " is " + size_text(right.width, right.height));
  }
  if (left.frames != right.frames) {
    throw SourceError("frame counts differ: left " + left_path + " has " + std::to_string(left.frames) + " frames, right " +
                      right_path + " has " + std::to_string(right.frames));
  }
  width_ = left.width;
  height_ = left.height;
  frame_count_ = std::max<int64_t>(left.frames, 0);
  frame_rate_hz_ = recording_rate_hz(options, left.rate_hz);
  check_requested_size(options, width_, height_, left_path);
}

VideoFileSource::~VideoFileSource() = default;

SourceResult VideoFileSource::next(std::chrono::milliseconds /*timeout*/) {
  SourceResult result;
  if (ended_) {
    result.status = SourceStatus::end_of_stream;
    result.message = "end of the videos after " + std::to_string(statistics_.pairs_delivered) + " frames";
    return result;
  }
  const int64_t frame = static_cast<int64_t>(statistics_.pairs_delivered);
  cv::Mat left, right;
  bool left_read = false, right_read = false;
  try {
    left_read = left_->read(left);
    right_read = right_->read(right);
  } catch (const std::runtime_error& error) {
    throw SourceError(left_path_ + " / " + right_path_ + ": frame " + std::to_string(frame) + ": " + error.what());
  }
  if (!left_read && !right_read) {
    ended_ = true;
    return next(std::chrono::milliseconds(0));
  }
  if (left_read != right_read) {
    throw SourceError("frame " + std::to_string(frame) + ": " + (left_read ? right_path_ : left_path_) + " ended, " +
                      (left_read ? left_path_ : right_path_) + " has more frames (expected both to end together)");
  }
  Plane left_view, right_view;
  try {
    left_view = luma_u8(left, left_path_);
    right_view = luma_u8(right, right_path_);
  } catch (const ImageError& error) {
    throw SourceError("frame " + std::to_string(frame) + ": " + error.what());
  }
  for (const auto& [view, path] : {std::pair{&left_view, &left_path_}, std::pair{&right_view, &right_path_}}) {
    if (view->width() != width_ || view->height() != height_) {
      throw SourceError("frame " + std::to_string(frame) + ": " + *path + " decoded at " + size_text(view->width(), view->height()) +
                        ", expected " + size_text(width_, height_) + " (the size its container reports)");
    }
  }
  return delivered_pair(std::move(left_view), std::move(right_view), frame, frame_rate_hz_, statistics_);
}

std::string VideoFileSource::description() const {
  return "video files " + left_path_ + " + " + right_path_ + ": " + std::to_string(frame_count_) + " frames, " +
         size_and_rate_text(width_, height_, frame_rate_hz_);
}

}  // namespace lpstereo::io
