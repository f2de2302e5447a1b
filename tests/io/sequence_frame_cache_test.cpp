// io/sequence_frame_cache: a frame written and read back is the rendered frame bit for bit (every
// image, the pose, every object's truth, the calibration given; the frame digest agrees and sees a
// one-bit change); missing and damaged files (truncated,
// another key, another frame, another format) are told apart and never loaded; the key follows frame 0
// and the options that move only the later frames; a file that cannot be written throws naming it and
// leaves nothing under its name.
#include "io/sequence_frame_cache.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "tests/support/scratch_directory.h"

namespace {

using namespace lpstereo;
namespace fs = std::filesystem;

io::StereoSequenceOptions small_sequence() {
  io::StereoSequenceOptions options;
  options.base.width = 96;
  options.base.height = 64;
  options.base.samples_per_axis = 1;
  options.base.colour = true;
  options.base.noise_sigma = 1;
  options.base.objects = {io::synth_object(io::SynthClass::bin, 1.0, 12)};
  options.moving = {{io::synth_object(io::SynthClass::pedestrian, -2, 15), 1.5, 0}};
  options.frames = 4;
  return options;
}

bool same_bits(const cv::Mat& a, const cv::Mat& b) {
  if (a.rows != b.rows || a.cols != b.cols || a.type() != b.type()) return false;
  for (int y = 0; y < a.rows; ++y) {
    if (std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()) != 0) return false;
  }
  return true;
}

void expect_same_truth(const io::SynthObjectTruth& a, const io::SynthObjectTruth& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.object.object_class, b.object.object_class);
  EXPECT_EQ(a.object.x_m, b.object.x_m);
  EXPECT_EQ(a.object.z_m, b.object.z_m);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(a.position_m[i], b.position_m[i]);
  EXPECT_EQ(a.distance_m, b.distance_m);
  EXPECT_EQ(a.disparity_px, b.disparity_px);
  EXPECT_EQ(a.min_height_m, b.min_height_m);
  EXPECT_EQ(a.max_height_m, b.max_height_m);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(a.bbox_px[i], b.bbox_px[i]);
  EXPECT_EQ(a.visible_pixels, b.visible_pixels);
}

TEST(SequenceFrameCache, AFrameReadBackIsTheRenderedFrameBitForBit) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_frame_cache");
  const io::StereoSequenceOptions options = small_sequence();
  const io::StereoSequenceFrame first = io::render_sequence_frame(options, 0);
  const io::StereoSequenceFrame rendered = io::render_sequence_frame(options, 2);
  ASSERT_FALSE(rendered.scene.left_colour.empty());
  ASSERT_EQ(rendered.objects.size(), 2u);
  const uint64_t key = io::sequence_cache_key(options, first);
  const std::string path = io::sequence_frame_cache_path(scratch.root().string(), key, 2);

  io::StereoSequenceFrame read;
  EXPECT_EQ(io::read_cached_sequence_frame(path, key, 2, first.scene.calibration, read), io::CachedFrame::missing);
  io::write_cached_sequence_frame(path, key, 2, rendered);
  EXPECT_FALSE(fs::exists(path + ".partial"));
  ASSERT_EQ(io::read_cached_sequence_frame(path, key, 2, first.scene.calibration, read), io::CachedFrame::loaded);

  EXPECT_TRUE(same_bits(read.scene.left, rendered.scene.left));
  EXPECT_TRUE(same_bits(read.scene.right, rendered.scene.right));
  EXPECT_TRUE(same_bits(read.scene.left_colour, rendered.scene.left_colour));
  EXPECT_TRUE(same_bits(read.scene.right_colour, rendered.scene.right_colour));
  EXPECT_TRUE(same_bits(read.scene.disparity_px, rendered.scene.disparity_px));
  EXPECT_TRUE(same_bits(read.scene.object_ids, rendered.scene.object_ids));
  EXPECT_EQ(read.scene.focal_px, rendered.scene.focal_px);
  EXPECT_EQ(std::memcmp(&read.pose, &rendered.pose, sizeof(read.pose)), 0);
  ASSERT_EQ(read.scene.objects.size(), rendered.scene.objects.size());
  for (size_t i = 0; i < read.scene.objects.size(); ++i) expect_same_truth(read.scene.objects[i], rendered.scene.objects[i]);
  ASSERT_EQ(read.objects.size(), rendered.objects.size());
  for (size_t i = 0; i < read.objects.size(); ++i) {
    expect_same_truth(read.objects[i].truth, rendered.objects[i].truth);
    for (int axis = 0; axis < 3; ++axis) EXPECT_EQ(read.objects[i].velocity_mps[axis], rendered.objects[i].velocity_mps[axis]);
    EXPECT_EQ(read.objects[i].moving, rendered.objects[i].moving);
  }
  EXPECT_EQ(read.scene.calibration.focal_px(), rendered.scene.calibration.focal_px());
  EXPECT_EQ(read.scene.calibration.baseline_m(), rendered.scene.calibration.baseline_m());
  // The moving pedestrian really moved between frame 0 and frame 2, so frame 2 is not frame 0 again.
  EXPECT_FALSE(same_bits(read.scene.left, first.scene.left));
  // The digest sees the same bits, and a change in any one of them.
  EXPECT_EQ(io::sequence_frame_digest(read), io::sequence_frame_digest(rendered));
  EXPECT_NE(io::sequence_frame_digest(read), io::sequence_frame_digest(first));
  io::StereoSequenceFrame changed = read;
  changed.scene.object_ids = read.scene.object_ids.clone();
  changed.scene.object_ids.at<uint16_t>(5, 7) ^= 1;
  EXPECT_NE(io::sequence_frame_digest(changed), io::sequence_frame_digest(read));
  changed = read;
  changed.objects[1].velocity_mps[0] += 0.5;
  EXPECT_NE(io::sequence_frame_digest(changed), io::sequence_frame_digest(read));
}

TEST(SequenceFrameCache, DamagedFilesAreToldApartAndNeverLoaded) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_frame_cache");
  const io::StereoSequenceOptions options = small_sequence();
  const io::StereoSequenceFrame first = io::render_sequence_frame(options, 0);
  const io::StereoSequenceFrame rendered = io::render_sequence_frame(options, 1);
  const uint64_t key = io::sequence_cache_key(options, first);
  const std::string path = io::sequence_frame_cache_path(scratch.root().string(), key, 1);
  io::write_cached_sequence_frame(path, key, 1, rendered);
  const uintmax_t whole_bytes = fs::file_size(path);

  io::StereoSequenceFrame read;
  read.scene.focal_px = -1;  // untouched unless loaded
  std::string problem;
  EXPECT_EQ(io::read_cached_sequence_frame(path, key + 1, 1, first.scene.calibration, read, &problem), io::CachedFrame::damaged);
  EXPECT_NE(problem.find("key"), std::string::npos) << problem;
  EXPECT_NE(problem.find(path), std::string::npos) << problem;
  EXPECT_EQ(io::read_cached_sequence_frame(path, key, 3, first.scene.calibration, read, &problem), io::CachedFrame::damaged);
  EXPECT_NE(problem.find("expected frame 3, got 1"), std::string::npos) << problem;

  fs::resize_file(path, whole_bytes - 1);  // the end mark cut
  EXPECT_EQ(io::read_cached_sequence_frame(path, key, 1, first.scene.calibration, read, &problem), io::CachedFrame::damaged);
  fs::resize_file(path, whole_bytes / 2);  // inside an image
  EXPECT_EQ(io::read_cached_sequence_frame(path, key, 1, first.scene.calibration, read, &problem), io::CachedFrame::damaged);
  EXPECT_NE(problem.find("truncated"), std::string::npos) << problem;
  {
    std::ofstream other(path, std::ios::binary | std::ios::trunc);
    other << "P5 96 64 255\n";  // another format under the name
  }
  EXPECT_EQ(io::read_cached_sequence_frame(path, key, 1, first.scene.calibration, read, &problem), io::CachedFrame::damaged);
  EXPECT_NE(problem.find("not a frame cache file"), std::string::npos) << problem;
  EXPECT_EQ(read.scene.focal_px, -1);

  // Extra bytes after a whole frame: damaged too.
  io::write_cached_sequence_frame(path, key, 1, rendered);
  {
    std::ofstream append(path, std::ios::binary | std::ios::app);
    append << 'x';
  }
  EXPECT_EQ(io::read_cached_sequence_frame(path, key, 1, first.scene.calibration, read, &problem), io::CachedFrame::damaged);
  EXPECT_NE(problem.find("after the end mark"), std::string::npos) << problem;
}

TEST(SequenceFrameCache, TheKeyFollowsFrameZeroAndTheOptionsOfTheLaterFrames) {
  const io::StereoSequenceOptions options = small_sequence();
  const io::StereoSequenceFrame first = io::render_sequence_frame(options, 0);
  const uint64_t key = io::sequence_cache_key(options, first);
  EXPECT_EQ(io::sequence_cache_key(options, io::render_sequence_frame(options, 0)), key);  // rendering is deterministic

  io::StereoSequenceOptions faster = options;  // frame 0 is the same, the later frames are not
  faster.camera_speed_mps += 1;
  EXPECT_TRUE(same_bits(io::render_sequence_frame(faster, 0).scene.left, first.scene.left));
  EXPECT_NE(io::sequence_cache_key(faster, first), key);
  io::StereoSequenceOptions walker = options;
  walker.moving[0].velocity_x_mps = -1.5;
  EXPECT_NE(io::sequence_cache_key(walker, first), key);
  io::StereoSequenceOptions turning = options;
  turning.yaw_rate_rad_s = 0.1;
  EXPECT_NE(io::sequence_cache_key(turning, first), key);

  io::StereoSequenceOptions other_seed = options;  // another texture: another frame 0
  other_seed.base.seed = 2;
  EXPECT_NE(io::sequence_cache_key(other_seed, io::render_sequence_frame(other_seed, 0)), key);
}

TEST(SequenceFrameCache, AFileThatCannotBeWrittenThrowsNamingIt) {
  lpstereo::testing::ScratchDirectory scratch("lpstereo_frame_cache");
  const io::StereoSequenceOptions options = small_sequence();
  const io::StereoSequenceFrame first = io::render_sequence_frame(options, 0);
  // The cache folder's place is taken by a plain file.
  const std::string blocked = scratch.path("blocked");
  { std::ofstream file(blocked); }
  const std::string path = io::sequence_frame_cache_path(blocked, 7, 1);
  try {
    io::write_cached_sequence_frame(path, 7, 1, first);
    ADD_FAILURE() << "written under a file";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(blocked), std::string::npos) << error.what();
  }
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
