// What the host can check of the V4L2 capture path without a driver: paths that are not capture
// devices are refused with one line naming them, what was expected and what they are. The real
// driver (vivid) is exercised in a VM: tests/vm/vivid_capture_test.cpp.
#include "io/camera/v4l2_device.h"

#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>
#include <string>

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

TEST(V4l2Device, FourccTextIsTheFourCharacters) {
  EXPECT_EQ(fourcc_text(0x56595559), "YUYV");
  EXPECT_EQ(fourcc_text(0x20203859), "Y8");  // trailing spaces dropped
  EXPECT_EQ(fourcc_text(0x00000001), "????");  // non-printable bytes
}

}  // namespace
}  // namespace lpstereo::io
