// Recordings as stereo sources (the `files:` kind of io/camera/stereo_source.h), so that a recorded
// run replays through the same path as a live one:
//   - ImageSequenceSource: two printf patterns (io/frame_pattern.h), frame numbers first, first + 1,
//     ... up to the first number where a view is missing (or frame_limit pairs). Each file is read
//     as u8 luma (io/image_io.h: colour becomes BT.601 luma, 16-bit images value >> 8).
//   - VideoFileSource: two video files OpenCV's VideoCapture decodes (io/camera/video_decoder.h: a
//     module loaded when a video is opened); both must report the same
//     frame count and size; frames become u8 luma with cv::cvtColor (BGR to grey: BT.601 weights).
// Timestamps: frame number / frame rate (options.frame_rate_hz; 0 = 10 Hz for image sequences, the
// container's rate for videos, else 10 Hz), in ns, the same for both views; sequence numbers are the
// frame numbers (the video's frame index), so a recording has no driver drops and no unpaired frames.
// next() never waits (the timeout is unused: a file is there or it is not) and returns end_of_stream
// after the last pair. It throws SourceError (one line naming the file, the expected and the actual
// value) for a pair it cannot read: a view missing mid-sequence (the other view's file exists), an
// unreadable or corrupt file, a size that differs from the first pair's, one video ending before
// the other. Construction throws SourceError for a first pair that is missing, unreadable or of two
// sizes, for videos that do not open or hold different frame counts, and for a requested size
// (options.width/height) other than the recording's.
#pragma once

#include <memory>
#include <string>

#include "io/camera/stereo_source.h"
#include "io/camera/video_decoder.h"
#include "io/frame_pattern.h"

namespace lpstereo::io {

// The frame rate of a recording without one of its own (SourceOptions.frame_rate_hz = 0), Hz.
inline constexpr double kDefaultRecordingRateHz = 10.0;

class ImageSequenceSource : public StereoSource {
 public:
  // first_frame: the first frame number (>= 0), or -1: 0, or 1 when the sequence has no frame 0
  // (sequences numbered from 1). frame_limit: at most this many pairs (0 = until a view is missing).
  // Throws std::invalid_argument for a pattern without exactly one frame-number conversion.
  ImageSequenceSource(const std::string& left_pattern, const std::string& right_pattern, const SourceOptions& options,
                      int first_frame = -1, int frame_limit = 0);

  std::string description() const override;
  int width() const override { return width_; }
  int height() const override { return height_; }
  double frame_rate_hz() const override { return frame_rate_hz_; }
  SourceResult next(std::chrono::milliseconds timeout) override;
  SourceStatistics statistics() const override { return statistics_; }

  int first_frame() const { return first_frame_; }
  // Complete pairs from first_frame() on, found by name when the source was opened (<= frame_limit).
  int frame_count() const { return frame_count_; }
  const FramePattern& left_pattern() const { return left_; }
  const FramePattern& right_pattern() const { return right_; }

 private:
  Plane read_view(const std::string& path, int frame) const;

  FramePattern left_, right_;
  int first_frame_ = 0;
  int frame_count_ = 0;
  int frame_limit_ = 0;
  int width_ = 0, height_ = 0;
  double frame_rate_hz_ = kDefaultRecordingRateHz;
  int next_offset_ = 0;  // pairs delivered so far
  Plane first_left_, first_right_;  // read (and checked) when opened; delivered by the first next()
  SourceStatistics statistics_;
};

class VideoFileSource : public StereoSource {
 public:
  VideoFileSource(const std::string& left_path, const std::string& right_path, const SourceOptions& options);
  ~VideoFileSource() override;

  std::string description() const override;
  int width() const override { return width_; }
  int height() const override { return height_; }
  double frame_rate_hz() const override { return frame_rate_hz_; }
  SourceResult next(std::chrono::milliseconds timeout) override;
  SourceStatistics statistics() const override { return statistics_; }

  // The frame count both containers report (0 when they report none).
  int64_t frame_count() const { return frame_count_; }

 private:
  std::string left_path_, right_path_;
  std::unique_ptr<VideoDecoder> left_, right_;  // io/camera/video_decoder.h: OpenCV videoio, loaded on first use
  int width_ = 0, height_ = 0;
  double frame_rate_hz_ = kDefaultRecordingRateHz;
  int64_t frame_count_ = 0;
  bool ended_ = false;
  SourceStatistics statistics_;
};

}  // namespace lpstereo::io
