// The libcamera source where no camera is needed: enumeration returns (whatever this machine has,
// usually nothing) without hanging or crashing; an unknown camera id is refused with one line that
// names it and lists the cameras libcamera does find (or says there are none); malformed id lists
// are refused before libcamera is asked. Streaming from a real driver is tests/vm/vimc_libcamera_test.cpp.
#include "io/camera/libcamera_source.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace lpstereo::io {
namespace {

// Expects a SourceError whose message is one line containing every one of `needles`.
template <class Open>
void expect_source_error(const Open& open, const std::vector<std::string>& needles) {
  try {
    open();
    ADD_FAILURE() << "opened; expected a SourceError";
  } catch (const SourceError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    for (const std::string& needle : needles)
      EXPECT_NE(message.find(needle), std::string::npos) << needle << " in: " << message;
  }
}

// What the refusal of an unknown id must list: each camera libcamera finds, or that there are none.
std::vector<std::string> expected_listing() {
  std::vector<std::string> needles;
  for (const LibcameraCameraInfo& camera : list_libcamera_cameras()) needles.push_back("'" + camera.id + "'");
  if (needles.empty()) needles.push_back("libcamera finds no cameras");
  return needles;
}

TEST(LibcameraSource, EnumerationReturnsCamerasWithIdsAndFormats) {
  const std::vector<LibcameraCameraInfo> cameras = list_libcamera_cameras();
  for (const LibcameraCameraInfo& camera : cameras) {
    EXPECT_FALSE(camera.id.empty());
    for (const LibcameraStreamFormat& format : camera.formats) {
      EXPECT_FALSE(format.pixel_format.empty()) << camera.id;
      EXPECT_LE(format.min_width, format.max_width) << camera.id << " " << format.pixel_format;
      EXPECT_LE(format.min_height, format.max_height) << camera.id << " " << format.pixel_format;
    }
  }
  // libcamera allows one camera manager per process (a second aborts): the shared one must be
  // stopped and recreated, or reused, across calls.
  EXPECT_EQ(list_libcamera_cameras().size(), cameras.size());
}

TEST(LibcameraSource, UnknownSideBySideCameraIsNamedWithTheAvailableOnes) {
  std::vector<std::string> needles = expected_listing();
  needles.push_back("libcamera camera 'no-such-camera'");
  needles.push_back("not found");
  expect_source_error([] { open_libcamera_stereo_source({"no-such-camera"}, SourceOptions{}); }, needles);
}

TEST(LibcameraSource, UnknownCameraOfAPairIsNamed) {
  std::vector<std::string> needles = expected_listing();
  needles.push_back("libcamera camera 'missing-left'");
  expect_source_error(
      [] {
        open_libcamera_stereo_source({"missing-left", "missing-right"}, SourceOptions{});
      },
      needles);
}

TEST(LibcameraSource, MalformedIdListsAreRefused) {
  EXPECT_THROW(open_libcamera_stereo_source({}, SourceOptions{}), std::invalid_argument);
  EXPECT_THROW(open_libcamera_stereo_source({"a", "b", "c"}, SourceOptions{}), std::invalid_argument);
  try {
    open_libcamera_stereo_source({"same", "same"}, SourceOptions{});
    ADD_FAILURE() << "the same camera twice was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("'same'"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace lpstereo::io
