// liblpstereo_video_decoder.so: OpenCV's VideoCapture behind io/camera/video_decoder.h, loaded only
// when a video is opened (see the header for why).
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/videoio.hpp>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "io/camera/video_decoder.h"

namespace lpstereo::io {
namespace {

// OpenCV's video back ends log each failed probe on stderr; the source reports failures itself, in
// one line. Quiet for the scope of an open or a read.
class QuietOpenCvLog {
 public:
  QuietOpenCvLog() : previous_(cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT)) {}
  ~QuietOpenCvLog() { cv::utils::logging::setLogLevel(previous_); }
  QuietOpenCvLog(const QuietOpenCvLog&) = delete;
  QuietOpenCvLog& operator=(const QuietOpenCvLog&) = delete;

 private:
  cv::utils::logging::LogLevel previous_;
};

class OpenCvVideoDecoder : public VideoDecoder {
 public:
  explicit OpenCvVideoDecoder(std::unique_ptr<cv::VideoCapture> capture) : capture_(std::move(capture)) {}
  int width() const override { return static_cast<int>(capture_->get(cv::CAP_PROP_FRAME_WIDTH)); }
  int height() const override { return static_cast<int>(capture_->get(cv::CAP_PROP_FRAME_HEIGHT)); }
  int64_t frame_count() const override { return static_cast<int64_t>(capture_->get(cv::CAP_PROP_FRAME_COUNT)); }
  double rate_hz() const override { return capture_->get(cv::CAP_PROP_FPS); }
  bool read(cv::Mat& frame) override {
    const QuietOpenCvLog quiet;
    try {
      return capture_->read(frame);
    } catch (const cv::Exception& error) {
      throw std::runtime_error(std::string("cannot decode: ") + error.what());
    }
  }

 private:
  std::unique_ptr<cv::VideoCapture> capture_;
};

}  // namespace
}  // namespace lpstereo::io

extern "C" __attribute__((visibility("default"))) lpstereo::io::VideoDecoder* lpstereo_open_video_decoder(
    const char* path, char* error, size_t error_bytes) {
  using lpstereo::io::QuietOpenCvLog;
  const QuietOpenCvLog quiet;
  std::unique_ptr<cv::VideoCapture> capture;
  // The back ends that read files, in turn: FFmpeg, OpenCV's own MJPEG reader (AVI), GStreamer. Not
  // cv::CAP_ANY: on a file none of these opens it goes on to probe camera back ends (and libdc1394
  // enumerates USB devices).
  for (const int backend : {cv::CAP_FFMPEG, cv::CAP_OPENCV_MJPEG, cv::CAP_GSTREAMER}) {
    try {
      capture = std::make_unique<cv::VideoCapture>(path, backend);
    } catch (const cv::Exception&) {
      capture.reset();  // this back end refused it: the next one may not
    }
    if (capture && capture->isOpened()) return new lpstereo::io::OpenCvVideoDecoder(std::move(capture));
  }
  std::snprintf(error, error_bytes, "%s: cannot open as a video (neither FFmpeg, OpenCV's MJPEG reader nor GStreamer decodes it)",
                path);
  return nullptr;
}
