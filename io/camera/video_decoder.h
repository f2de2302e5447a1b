// A video file decoded frame by frame, for VideoFileSource (io/camera/file_source.h). The decoder
// is OpenCV's VideoCapture (FFmpeg, OpenCV's MJPEG reader, GStreamer), which pulls in FFmpeg,
// GStreamer and about a hundred more shared libraries: loading them took every lpstereo process
// 0.1 s and 20 MB at start-up, video or not. So it lives in a module of its own,
// liblpstereo_video_decoder.so (io/camera/video_decoder_module.cpp), loaded with dlopen the first
// time a video is opened (io/codec_module.h: where it is looked for; $LPSTEREO_VIDEO_DECODER names
// the file).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

namespace lpstereo::io {

class VideoDecoder {
 public:
  virtual ~VideoDecoder() = default;
  virtual int width() const = 0;
  virtual int height() const = 0;
  virtual int64_t frame_count() const = 0;  // what the container reports (0 or less when it reports none)
  virtual double rate_hz() const = 0;       // what the container reports (0 when none)
  // The next frame as decoded (BGR or grey); false at the end. Throws std::runtime_error when a
  // frame cannot be decoded.
  virtual bool read(cv::Mat& frame) = 0;
};

// Opens `path` with the first back end that decodes it. Throws std::runtime_error naming the path
// (no back end decodes it) or the module (not found, or not loadable: the places tried).
std::unique_ptr<VideoDecoder> open_video_decoder(const std::string& path);

// The module's entry point (extern "C", looked up by name): a new decoder, or nullptr with a
// one-line reason in `error` (at most error_bytes, terminated).
using OpenVideoDecoderFunction = VideoDecoder* (*)(const char* path, char* error, size_t error_bytes);
inline constexpr const char* kOpenVideoDecoderSymbol = "lpstereo_open_video_decoder";

}  // namespace lpstereo::io
