// What the host can check of the V4L2 capture path without a driver: paths that are not capture
// devices are refused with one line naming them, what was expected and what they are. The real
// driver (vivid) is exercised in a VM: tests/vm/vivid_capture_test.cpp.
#include "io/camera/v4l2_device.h"

#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/camera/v4l2_stereo_source.h"
#include "tests/support/scratch_directory.h"

namespace lpstereo::io {
namespace {

std::string open_error(const std::string& path) {
  try {
    V4l2CaptureDevice device(path);
  } catch (const SourceError& error) {
    return error.what();
  }
  return "(no error)";
}

void expect_one_line(const std::string& message) { EXPECT_EQ(message.find('\n'), std::string::npos) << message; }

TEST(V4l2Device, ADeviceThatDoesNotExistIsNamed) {
  const std::string message = open_error("/dev/video-lpstereo-none");
  EXPECT_EQ(message, "/dev/video-lpstereo-none: expected a V4L2 video capture device, got no such file");
  expect_one_line(message);
}

TEST(V4l2Device, ACharacterDeviceThatIsNotV4l2IsRefused) {
  const std::string message = open_error("/dev/null");
  EXPECT_EQ(message.rfind("/dev/null: expected a V4L2 video capture device, got a character device that is not V4L2 "
                          "(VIDIOC_QUERYCAP: ",
                          0),
            0u)
      << message;
  expect_one_line(message);
}

TEST(V4l2Device, ARegularFileIsRefused) {
  testing::ScratchDirectory scratch("lpstereo_v4l2_device");
  const std::string path = scratch.path("video0");
  std::ofstream(path) << "not a device";
  EXPECT_EQ(open_error(path), path + ": expected a V4L2 video capture device, got a regular file");
}

TEST(V4l2Device, ADirectoryIsRefused) {
  testing::ScratchDirectory scratch("lpstereo_v4l2_device");
  const std::string path = scratch.root().string();
  // open(O_RDWR) of a directory fails with EISDIR before anything can be asked of it.
  EXPECT_EQ(open_error(path), path + ": cannot open (Is a directory)");
}

TEST(V4l2StereoSource, NamesTheDeviceThatCannotBeOpened) {
  try {
    open_v4l2_stereo_source({"/dev/null", "/dev/video-lpstereo-none"}, false, SourceOptions{});
    FAIL() << "no exception";
  } catch (const SourceError& error) {
    EXPECT_NE(std::string(error.what()).find("/dev/null: expected a V4L2 video capture device"), std::string::npos)
        << error.what();
  }
  try {
    open_v4l2_stereo_source({"/dev/video-lpstereo-none"}, true, SourceOptions{});
    FAIL() << "no exception";
  } catch (const SourceError& error) {
    EXPECT_STREQ(error.what(), "/dev/video-lpstereo-none: expected a V4L2 video capture device, got no such file");
  }
}

TEST(V4l2StereoSource, RefusesAWrongDeviceCount) {
  EXPECT_THROW(open_v4l2_stereo_source({"/dev/video0"}, false, SourceOptions{}), std::invalid_argument);
  EXPECT_THROW(open_v4l2_stereo_source({"/dev/video0", "/dev/video1"}, true, SourceOptions{}), std::invalid_argument);
  EXPECT_THROW(open_v4l2_stereo_source({"/dev/video0", "/dev/video0"}, false, SourceOptions{}), std::invalid_argument);
}

TEST(V4l2StereoSource, RefusesOptionsNoDeviceCanBeAskedForBeforeOpeningAnything) {
  // The device does not exist: the option's error must come first, so it is checked first.
  const auto option_error = [](const SourceOptions& options, bool side_by_side) -> std::string {
    const std::vector<std::string> devices = side_by_side ? std::vector<std::string>{"/dev/video-lpstereo-none"}
                                                          : std::vector<std::string>{"/dev/video-lpstereo-none",
                                                                                     "/dev/video-lpstereo-none2"};
    try {
      open_v4l2_stereo_source(devices, side_by_side, options);
    } catch (const std::invalid_argument& error) {
      return error.what();
    } catch (const SourceError& error) {
      return std::string("SourceError: ") + error.what();
    }
    return "(no error)";
  };
  SourceOptions options;
  options.pixel_format = "MJPG";
  EXPECT_EQ(option_error(options, false),
            "v4l2: pixel format 'MJPG' unknown, expected one of GREY YUYV UYVY NV12 RGB888 BGR888");
  options = SourceOptions{};
  options.width = 640;
  EXPECT_EQ(option_error(options, true),
            "v4l2-sbs: size 640x0: expected both positive, or 0x0 for the device's current size");
  options = SourceOptions{};
  options.frame_rate_hz = -30;
  EXPECT_EQ(option_error(options, false).rfind("v4l2: frame rate -30", 0), 0u);
  options = SourceOptions{};
  options.buffer_count = 1;
  EXPECT_EQ(option_error(options, false), "v4l2: buffer count 1: expected >= 2");
  options = SourceOptions{};
  options.pairing_tolerance_ns = -2;
  EXPECT_EQ(option_error(options, false),
            "v4l2: pairing tolerance -2 ns: expected >= 0 (or -1 = half the frame period)");
  options = SourceOptions{};
  options.pixel_format = "yuyv";  // names are case-insensitive: the device's error comes
  EXPECT_EQ(option_error(options, false),
            "SourceError: /dev/video-lpstereo-none: expected a V4L2 video capture device, got no such file");
}

TEST(V4l2Device, FourccTextIsTheFourCharacters) {
  EXPECT_EQ(fourcc_text(0x56595559), "YUYV");
  EXPECT_EQ(fourcc_text(0x20203859), "Y8");  // trailing spaces dropped
  EXPECT_EQ(fourcc_text(0x00000001), "????");  // non-printable bytes
}

}  // namespace
}  // namespace lpstereo::io
