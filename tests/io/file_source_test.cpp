// Recordings as stereo sources (io/camera/file_source.h) and the spec parser (open_stereo_source):
// image sequences deliver every pair with frame-number sequences and frame / rate timestamps, then
// end_of_stream; a sequence numbered from 1 starts at 1; views of different sizes, a size change, a
// view missing or corrupt mid-sequence and a missing first frame give SourceError naming the files;
// videos written here with cv::VideoWriter (OpenCV's own MJPEG writer: no codec package needed)
// come back frame by frame as luma with their count and rate checked; FramePattern expands and
// refuses patterns; bad specs give std::invalid_argument, live kinds without a source SourceError.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "io/camera/file_source.h"
#include "io/camera/stereo_source.h"
#include "io/frame_pattern.h"
#include "io/image_io.h"
#include "tests/support/scratch_directory.h"

namespace {

using lpstereo::Plane;
using namespace lpstereo::io;
using std::chrono::milliseconds;

constexpr int kWidth = 37, kHeight = 23;  // odd sizes

// Pixel (x, y) of frame `frame`'s `view` (0 left, 1 right): distinct per frame, view and position.
uint8_t pixel_value(int frame, int view, int x, int y) { return static_cast<uint8_t>(frame * 50 + view * 20 + x + 3 * y); }

cv::Mat test_image(int frame, int view, int width = kWidth, int height = kHeight) {
  cv::Mat image(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) image.at<uint8_t>(y, x) = pixel_value(frame, view, x, y);
  }
  return image;
}

std::string numbered(const std::string& folder, const char* view, int frame) {
  char name[64];
  std::snprintf(name, sizeof name, "/%s_%06d.png", view, frame);
  return folder + name;
}

class FileSource : public ::testing::Test {
 protected:
  // Frames [first, first + count) of both views as PNG.
  void write_sequence(int first, int count) {
    for (int frame = first; frame < first + count; ++frame) {
      ASSERT_TRUE(cv::imwrite(numbered(folder(), "left", frame), test_image(frame, 0)));
      ASSERT_TRUE(cv::imwrite(numbered(folder(), "right", frame), test_image(frame, 1)));
    }
  }
  std::string folder() const { return scratch_.root().string(); }
  std::string left_pattern() const { return folder() + "/left_%06d.png"; }
  std::string right_pattern() const { return folder() + "/right_%06d.png"; }
  std::string files_spec() const { return "files:" + left_pattern() + "," + right_pattern(); }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_file_source"};
};

void expect_view(const Plane& plane, int frame, int view) {
  ASSERT_EQ(plane.width(), kWidth);
  ASSERT_EQ(plane.height(), kHeight);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      ASSERT_EQ(plane.at<uint8_t>(x, y), pixel_value(frame, view, x, y))
          << "frame " << frame << " view " << view << " at " << x << "," << y;
    }
  }
}

// The message of the SourceError `call` throws ("" when it throws none).
template <typename Call>
std::string source_error(Call&& call) {
  try {
    call();
  } catch (const SourceError& error) {
    return error.what();
  }
  return "";
}

TEST_F(FileSource, SequenceDeliversEveryPairThenEndOfStream) {
  write_sequence(0, 3);
  const auto source = open_stereo_source(files_spec(), SourceOptions{});
  ASSERT_NE(dynamic_cast<ImageSequenceSource*>(source.get()), nullptr);
  EXPECT_EQ(source->width(), kWidth);
  EXPECT_EQ(source->height(), kHeight);
  EXPECT_EQ(source->frame_rate_hz(), 10.0);  // the default rate of a recording
  EXPECT_NE(source->description().find("3 pairs"), std::string::npos) << source->description();
  for (int frame = 0; frame < 3; ++frame) {
    const SourceResult result = source->next(milliseconds(0));
    ASSERT_EQ(result.status, SourceStatus::frame);
    expect_view(result.frame.left, frame, 0);
    expect_view(result.frame.right, frame, 1);
    EXPECT_EQ(result.frame.index, static_cast<uint64_t>(frame));
    EXPECT_EQ(result.frame.left_sequence, static_cast<uint64_t>(frame));
    EXPECT_EQ(result.frame.right_sequence, static_cast<uint64_t>(frame));
    EXPECT_EQ(result.frame.left_timestamp_ns, frame * 100'000'000LL);  // frame / 10 Hz
    EXPECT_EQ(result.frame.right_timestamp_ns, result.frame.left_timestamp_ns);
  }
  for (int again = 0; again < 2; ++again) EXPECT_EQ(source->next(milliseconds(0)).status, SourceStatus::end_of_stream);
  const SourceStatistics statistics = source->statistics();
  EXPECT_EQ(statistics.pairs_delivered, 3u);
  EXPECT_EQ(statistics.left_frames, 3u);
  EXPECT_EQ(statistics.right_frames, 3u);
  EXPECT_EQ(statistics.left_driver_drops + statistics.right_driver_drops + statistics.left_unpaired + statistics.right_unpaired, 0u);
}

TEST_F(FileSource, SequenceNumberedFromOneStartsAtOneWithTheRequestedRate) {
  write_sequence(1, 2);
  SourceOptions options;
  options.frame_rate_hz = 25;
  ImageSequenceSource source(left_pattern(), right_pattern(), options);
  EXPECT_EQ(source.first_frame(), 1);
  EXPECT_EQ(source.frame_count(), 2);
  const SourceResult first = source.next(milliseconds(0));
  ASSERT_EQ(first.status, SourceStatus::frame);
  expect_view(first.frame.left, 1, 0);
  EXPECT_EQ(first.frame.index, 0u);
  EXPECT_EQ(first.frame.left_sequence, 1u);
  EXPECT_EQ(first.frame.left_timestamp_ns, 40'000'000);  // frame 1 at 25 Hz
}

TEST_F(FileSource, SequenceFirstFrameAndLimit) {
  write_sequence(0, 5);
  ImageSequenceSource source(left_pattern(), right_pattern(), SourceOptions{}, 2, 2);
  EXPECT_EQ(source.frame_count(), 2);
  EXPECT_EQ(source.next(milliseconds(0)).frame.left_sequence, 2u);
  EXPECT_EQ(source.next(milliseconds(0)).frame.left_sequence, 3u);
  EXPECT_EQ(source.next(milliseconds(0)).status, SourceStatus::end_of_stream);  // frame 4 exists, the limit holds
}

TEST_F(FileSource, ColourFramesBecomeLuma) {
  // A colour frame is read as BT.601 luma, as every image reader of lpstereo does.
  cv::Mat colour(kHeight, kWidth, CV_8UC3, cv::Scalar(200, 100, 50));  // B, G, R
  ASSERT_TRUE(cv::imwrite(numbered(folder(), "left", 0), colour));
  ASSERT_TRUE(cv::imwrite(numbered(folder(), "right", 0), colour));
  ImageSequenceSource source(left_pattern(), right_pattern(), SourceOptions{});
  const SourceResult result = source.next(milliseconds(0));
  ASSERT_EQ(result.status, SourceStatus::frame);
  const double luma = 0.299 * 50 + 0.587 * 100 + 0.114 * 200;  // 96.35
  EXPECT_NEAR(result.frame.left.at<uint8_t>(5, 5), luma, 1.0);
}

TEST_F(FileSource, ViewsOfDifferentSizesNameBothFiles) {
  ASSERT_TRUE(cv::imwrite(numbered(folder(), "left", 0), test_image(0, 0)));
  ASSERT_TRUE(cv::imwrite(numbered(folder(), "right", 0), test_image(0, 1, kWidth - 1, kHeight)));
  const std::string message = source_error([&] { open_stereo_source(files_spec(), SourceOptions{}); });
  EXPECT_NE(message.find("sizes differ"), std::string::npos) << message;
  EXPECT_NE(message.find("left_000000.png is 37x23"), std::string::npos) << message;
  EXPECT_NE(message.find("right_000000.png is 36x23"), std::string::npos) << message;
}

TEST_F(FileSource, SizeChangeMidSequenceNamesTheFrame) {
  write_sequence(0, 1);
  ASSERT_TRUE(cv::imwrite(numbered(folder(), "left", 1), test_image(1, 0, kWidth, kHeight + 2)));
  ASSERT_TRUE(cv::imwrite(numbered(folder(), "right", 1), test_image(1, 1, kWidth, kHeight + 2)));
  ImageSequenceSource source(left_pattern(), right_pattern(), SourceOptions{});
  ASSERT_EQ(source.next(milliseconds(0)).status, SourceStatus::frame);
  const std::string message = source_error([&] { source.next(milliseconds(0)); });
  EXPECT_NE(message.find("frame 1: "), std::string::npos) << message;
  EXPECT_NE(message.find("is 37x25, expected 37x23"), std::string::npos) << message;
}

TEST_F(FileSource, ViewMissingMidSequenceIsAnErrorNotTheEnd) {
  write_sequence(0, 2);
  ASSERT_TRUE(cv::imwrite(numbered(folder(), "left", 2), test_image(2, 0)));  // its right view is missing
  ImageSequenceSource source(left_pattern(), right_pattern(), SourceOptions{});
  EXPECT_EQ(source.frame_count(), 2);
  ASSERT_EQ(source.next(milliseconds(0)).status, SourceStatus::frame);
  ASSERT_EQ(source.next(milliseconds(0)).status, SourceStatus::frame);
  const std::string message = source_error([&] { source.next(milliseconds(0)); });
  EXPECT_NE(message.find("frame 2"), std::string::npos) << message;
  EXPECT_NE(message.find("right_000002.png is missing"), std::string::npos) << message;
}

TEST_F(FileSource, CorruptFileMidSequenceNamesIt) {
  write_sequence(0, 2);
  std::ofstream(numbered(folder(), "right", 1), std::ios::trunc) << "not a PNG";
  ImageSequenceSource source(left_pattern(), right_pattern(), SourceOptions{});
  ASSERT_EQ(source.next(milliseconds(0)).status, SourceStatus::frame);
  const std::string message = source_error([&] { source.next(milliseconds(0)); });
  EXPECT_NE(message.find("right_000001.png"), std::string::npos) << message;
  EXPECT_NE(message.find("cannot decode"), std::string::npos) << message;
}

TEST_F(FileSource, NoFirstFrameOrAnotherSizeIsRefused) {
  std::string message = source_error([&] { ImageSequenceSource(left_pattern(), right_pattern(), SourceOptions{}); });
  EXPECT_NE(message.find("left_000000.png not found"), std::string::npos) << message;
  write_sequence(0, 1);
  SourceOptions options;
  options.width = 640;
  message = source_error([&] { ImageSequenceSource(left_pattern(), right_pattern(), options); });
  EXPECT_NE(message.find("expected the requested 640x23, got 37x23"), std::string::npos) << message;
}

// A video of `frames` flat grey frames, level 30 + 40 * i, at 25 fps (OpenCV's MJPEG writer).
void write_video(const std::string& path, int frames, int width = 64, int height = 48) {
  cv::VideoWriter writer(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0, cv::Size(width, height), true);
  ASSERT_TRUE(writer.isOpened()) << path;
  for (int i = 0; i < frames; ++i) writer.write(cv::Mat(height, width, CV_8UC3, cv::Scalar::all(30 + 40 * i)));
}

TEST_F(FileSource, VideosDeliverEveryFrameAsLuma) {
  const std::string left = scratch_.path("left.avi"), right = scratch_.path("right.avi");
  write_video(left, 4);
  write_video(right, 4);
  const auto source = open_stereo_source("files:" + left + "," + right, SourceOptions{});
  auto* video = dynamic_cast<VideoFileSource*>(source.get());
  ASSERT_NE(video, nullptr);
  EXPECT_EQ(video->frame_count(), 4);
  EXPECT_EQ(source->width(), 64);
  EXPECT_EQ(source->height(), 48);
  EXPECT_DOUBLE_EQ(source->frame_rate_hz(), 25.0);  // the container's rate
  for (int i = 0; i < 4; ++i) {
    const SourceResult result = source->next(milliseconds(0));
    ASSERT_EQ(result.status, SourceStatus::frame);
    ASSERT_EQ(result.frame.left.format().type, lpstereo::ElementType::u8);
    // MJPEG is lossy; a flat frame comes back within a few levels (the levels are 40 apart).
    EXPECT_NEAR(result.frame.left.at<uint8_t>(10, 10), 30 + 40 * i, 3) << "frame " << i;
    EXPECT_NEAR(result.frame.right.at<uint8_t>(63, 47), 30 + 40 * i, 3) << "frame " << i;
    EXPECT_EQ(result.frame.left_sequence, static_cast<uint64_t>(i));
    EXPECT_EQ(result.frame.left_timestamp_ns, i * 40'000'000LL);
  }
  EXPECT_EQ(source->next(milliseconds(0)).status, SourceStatus::end_of_stream);
  EXPECT_EQ(source->next(milliseconds(0)).status, SourceStatus::end_of_stream);
}

TEST_F(FileSource, VideosOfDifferentLengthsOrSizesOrMissingAreRefused) {
  const std::string four = scratch_.path("four.avi"), three = scratch_.path("three.avi"), small = scratch_.path("small.avi");
  write_video(four, 4);
  write_video(three, 3);
  write_video(small, 4, 32, 48);
  std::string message = source_error([&] { VideoFileSource(four, three, SourceOptions{}); });
  EXPECT_NE(message.find("frame counts differ"), std::string::npos) << message;
  EXPECT_NE(message.find("four.avi has 4 frames"), std::string::npos) << message;
  EXPECT_NE(message.find("three.avi has 3"), std::string::npos) << message;
  message = source_error([&] { VideoFileSource(four, small, SourceOptions{}); });
  EXPECT_NE(message.find("four.avi is 64x48"), std::string::npos) << message;
  EXPECT_NE(message.find("small.avi is 32x48"), std::string::npos) << message;
  message = source_error([&] { VideoFileSource(four, scratch_.path("absent.avi"), SourceOptions{}); });
  EXPECT_NE(message.find("absent.avi: no such file"), std::string::npos) << message;
  std::ofstream(scratch_.path("text.avi")) << "not a video";
  message = source_error([&] { VideoFileSource(four, scratch_.path("text.avi"), SourceOptions{}); });
  EXPECT_NE(message.find("text.avi: cannot open as a video"), std::string::npos) << message;
}

TEST(FramePattern, ExpandsEachConversion) {
  EXPECT_EQ(FramePattern("d/left_%06d.png").path(42), "d/left_000042.png");
  EXPECT_EQ(FramePattern("%d.png").path(1234567), "1234567.png");
  EXPECT_EQ(FramePattern("f%3d").path(7), "f  7");
  EXPECT_EQ(FramePattern("100%%_%02d.pgm").path(5), "100%_05.pgm");
  EXPECT_EQ(FramePattern("x%02d").path(123), "x123");  // wider numbers are not cut
}

TEST(FramePattern, RefusesPatternsWithoutOneConversion) {
  for (const auto& [pattern, got] : {std::pair<std::string, std::string>{"plain.png", "got none"},
                                     {"a%d_%d.png", "more than one"},
                                     {"a%s.png", "got '%s'"},
                                     {"a%06x.png", "got '%06x'"},
                                     {"100%%.png", "got none"}}) {
    try {
      FramePattern{pattern};
      ADD_FAILURE() << pattern << " accepted";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(got), std::string::npos) << error.what();
      EXPECT_NE(std::string(error.what()).find("'" + pattern + "'"), std::string::npos) << error.what();
    }
  }
  EXPECT_TRUE(FramePattern::has_conversion("a%s"));
  EXPECT_FALSE(FramePattern::has_conversion("100%%.avi"));
}

TEST(OpenStereoSource, UnparseableSpecsAreInvalidArguments) {
  for (const std::string spec : {"", "left.png", ":x", "files:", "files:only_%06d.png", "files:a_%06d.png,", "files:a,b,c",
                                 "files:a_%06d.png,b.avi", "files:a_%s.png,b_%s.png", "camera:/dev/video0"}) {
    EXPECT_THROW(open_stereo_source(spec, SourceOptions{}), std::invalid_argument) << spec;
  }
}

// The live kinds reach their sources: a device that does not exist is that source's one-line
// SourceError naming it (not the dispatcher's), a wrong number of devices an unparseable spec.
TEST(OpenStereoSource, LiveKindsReachTheirSources) {
  const std::string missing_left = "/dev/lpstereo-no-such-video-device-0";
  const std::string missing_right = "/dev/lpstereo-no-such-video-device-1";
  for (const std::string& spec : {"v4l2:" + missing_left + "," + missing_right, "v4l2-sbs:" + missing_left}) {
    try {
      open_stereo_source(spec, SourceOptions{});
      ADD_FAILURE() << spec << " opened";
    } catch (const SourceError& error) {
      EXPECT_NE(std::string(error.what()).find(missing_left), std::string::npos) << error.what();
      EXPECT_EQ(std::string(error.what()).find('\n'), std::string::npos) << error.what();
    }
  }
  for (const std::string spec : {"v4l2:/dev/video0", "v4l2:/dev/video0,/dev/video1,/dev/video2", "v4l2:/dev/video0,",
                                 "v4l2-sbs:/dev/video0,/dev/video1"}) {
    EXPECT_THROW(open_stereo_source(spec, SourceOptions{}), std::invalid_argument) << spec;
  }
  try {
    open_stereo_source("libcamera:lpstereo-no-such-camera", SourceOptions{});
    ADD_FAILURE() << "libcamera:lpstereo-no-such-camera opened";
  } catch (const SourceError& error) {
#if LPSTEREO_WITH_LIBCAMERA
    EXPECT_NE(std::string(error.what()).find("lpstereo-no-such-camera"), std::string::npos) << error.what();
#else
    EXPECT_NE(std::string(error.what()).find("no libcamera source"), std::string::npos) << error.what();
#endif
  }
}

}  // namespace
