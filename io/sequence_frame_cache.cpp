// The disk cache of rendered sequence frames: key, file format and atomic writes in sequence_frame_cache.h.
#include "io/sequence_frame_cache.h"

#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace lpstereo::io {
namespace {

constexpr char kMagic[8] = {'L', 'P', 'S', 'E', 'Q', 'F', 'C', '1'};
constexpr char kEnd[4] = {'E', 'N', 'D', '1'};

static_assert(std::is_trivially_copyable_v<SynthCameraPose>);
static_assert(std::is_trivially_copyable_v<SynthObjectTruth>);
static_assert(std::is_trivially_copyable_v<SequenceObjectTruth>);

// FNV-1a, 64 bit.
struct Fnv {
  uint64_t hash = 0xCBF29CE484222325ull;
  void add(const void* data, size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i) hash = (hash ^ p[i]) * 0x100000001B3ull;
  }
  template <class T>
  void add_value(const T& value) {
    static_assert(std::is_arithmetic_v<T> || std::is_enum_v<T>);
    add(&value, sizeof(T));
  }
  void add_image(const cv::Mat& image) {
    add_value(image.rows);
    add_value(image.cols);
    add_value(image.type());
    for (int y = 0; y < image.rows; ++y) add(image.ptr(y), image.cols * image.elemSize());
  }
};

// The fields one by one (no padding bytes in the key).
void add_object(Fnv& fnv, const SynthObject& object) {
  fnv.add_value(object.object_class);
  for (const double value : {object.x_m, object.z_m, object.width_m, object.height_m, object.length_m, object.clearance_m}) {
    fnv.add_value(value);
  }
}
void add_truth(Fnv& fnv, const SynthObjectTruth& truth) {
  fnv.add_value(truth.id);
  add_object(fnv, truth.object);
  for (const double value : truth.position_m) fnv.add_value(value);
  for (const double value : {truth.distance_m, truth.disparity_px, truth.min_height_m, truth.max_height_m}) fnv.add_value(value);
  for (const int value : truth.bbox_px) fnv.add_value(value);
  fnv.add_value(truth.visible_pixels);
}

// The six images in file order (left, right, left_colour, right_colour, disparity_px, object_ids), as
// pointers to const or mutable Mats after the scene's constness.
template <class Scene>
auto images_of(Scene& scene) {
  return std::array{&scene.left, &scene.right, &scene.left_colour, &scene.right_colour, &scene.disparity_px, &scene.object_ids};
}

class Reader {
 public:
  explicit Reader(std::ifstream& in) : in_(in) {}
  bool bytes(void* data, size_t count) { return static_cast<bool>(in_.read(static_cast<char*>(data), static_cast<std::streamsize>(count))); }
  template <class T>
  bool value(T& out) {
    return bytes(&out, sizeof(T));
  }

 private:
  std::ifstream& in_;
};

}  // namespace

namespace {

// The frame's digest into `fnv`: every image, focal_px, the pose, every object's truth.
void add_frame(Fnv& fnv, const StereoSequenceFrame& frame) {
  for (const cv::Mat* image : images_of(frame.scene)) fnv.add_image(*image);
  fnv.add_value(frame.scene.focal_px);
  for (const auto& row : frame.pose.rotation) {
    for (const double value : row) fnv.add_value(value);
  }
  for (const double value : frame.pose.centre_m) fnv.add_value(value);
  for (const SynthObjectTruth& truth : frame.scene.objects) add_truth(fnv, truth);
  for (const SequenceObjectTruth& object : frame.objects) {
    add_truth(fnv, object.truth);
    for (const double value : object.velocity_mps) fnv.add_value(value);
    fnv.add_value(object.moving);
  }
}

}  // namespace

uint64_t sequence_frame_digest(const StereoSequenceFrame& frame) {
  Fnv fnv;
  add_frame(fnv, frame);
  return fnv.hash;
}

uint64_t sequence_cache_key(const StereoSequenceOptions& options, const StereoSequenceFrame& first_frame) {
  Fnv fnv;
  fnv.add(kMagic, sizeof(kMagic));
  add_frame(fnv, first_frame);
  fnv.add_value(options.camera_speed_mps);
  fnv.add_value(options.yaw_rate_rad_s);
  fnv.add_value(options.fps);
  for (const SynthMovingObject& moving : options.moving) {
    add_object(fnv, moving.object);
    fnv.add_value(moving.velocity_x_mps);
    fnv.add_value(moving.velocity_z_mps);
  }
  return fnv.hash;
}

std::string sequence_frame_cache_path(const std::string& directory, uint64_t key, int frame) {
  char name[64];
  std::snprintf(name, sizeof(name), "%016llx/%06d.frame", static_cast<unsigned long long>(key), frame);
  return (std::filesystem::path(directory) / name).string();
}

CachedFrame read_cached_sequence_frame(const std::string& path, uint64_t key, int frame, const StereoCalibration& calibration,
                                       StereoSequenceFrame& out, std::string* problem) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return CachedFrame::missing;
  auto damaged = [&](const std::string& why) {
    if (problem != nullptr) *problem = path + ": " + why;
    return CachedFrame::damaged;
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) return damaged("cannot be opened");
  Reader reader(in);
  char magic[sizeof(kMagic)];
  uint64_t file_key = 0;
  int32_t file_frame = -1;
  if (!reader.bytes(magic, sizeof(magic)) || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) return damaged("not a frame cache file of this version");
  if (!reader.value(file_key) || file_key != key) return damaged("another sequence's key");
  if (!reader.value(file_frame) || file_frame != frame) return damaged("expected frame " + std::to_string(frame) + ", got " + std::to_string(file_frame));
  StereoSequenceFrame loaded;
  for (cv::Mat* image_pointer : images_of(loaded.scene)) {
    int32_t rows = 0, cols = 0, type = 0;
    if (!reader.value(rows) || !reader.value(cols) || !reader.value(type)) return damaged("truncated image header");
    if (rows < 0 || cols < 0 || rows > 100000 || cols > 100000) return damaged("image size out of range");
    cv::Mat& image = *image_pointer;
    if (rows == 0) continue;
    image.create(rows, cols, type);
    for (int y = 0; y < rows; ++y) {
      if (!reader.bytes(image.ptr(y), image.cols * image.elemSize())) return damaged("truncated image");
    }
  }
  uint32_t count = 0;
  if (!reader.value(loaded.scene.focal_px) || !reader.value(loaded.pose)) return damaged("truncated pose");
  if (!reader.value(count) || count > 100000) return damaged("object count missing or out of range");
  loaded.scene.objects.resize(count);
  if (!reader.bytes(loaded.scene.objects.data(), count * sizeof(SynthObjectTruth))) return damaged("truncated objects");
  if (!reader.value(count) || count > 100000) return damaged("sequence object count missing or out of range");
  loaded.objects.resize(count);
  if (!reader.bytes(loaded.objects.data(), count * sizeof(SequenceObjectTruth))) return damaged("truncated sequence objects");
  char end[sizeof(kEnd)];
  if (!reader.bytes(end, sizeof(end)) || std::memcmp(end, kEnd, sizeof(kEnd)) != 0) return damaged("no end mark");
  if (in.peek() != std::char_traits<char>::eof()) return damaged("bytes after the end mark");
  loaded.scene.calibration = calibration;
  out = std::move(loaded);
  return CachedFrame::loaded;
}

void write_cached_sequence_frame(const std::string& path, uint64_t key, int frame, const StereoSequenceFrame& rendered) {
  const std::filesystem::path target(path);
  std::error_code error;
  std::filesystem::create_directories(target.parent_path(), error);
  if (error) throw std::runtime_error(target.parent_path().string() + ": cannot create the cache folder: " + error.message());
  const std::filesystem::path temporary = target.string() + ".partial";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    auto bytes = [&](const void* data, size_t count) { out.write(static_cast<const char*>(data), static_cast<std::streamsize>(count)); };
    bytes(kMagic, sizeof(kMagic));
    bytes(&key, sizeof(key));
    const int32_t frame_index = frame;
    bytes(&frame_index, sizeof(frame_index));
    for (const cv::Mat* image_pointer : images_of(rendered.scene)) {
      const cv::Mat& image = *image_pointer;
      const int32_t header[3] = {image.empty() ? 0 : image.rows, image.empty() ? 0 : image.cols, image.type()};
      bytes(header, sizeof(header));
      if (image.empty()) continue;
      for (int y = 0; y < image.rows; ++y) bytes(image.ptr(y), image.cols * image.elemSize());
    }
    bytes(&rendered.scene.focal_px, sizeof(rendered.scene.focal_px));
    bytes(&rendered.pose, sizeof(rendered.pose));
    const uint32_t objects = static_cast<uint32_t>(rendered.scene.objects.size());
    bytes(&objects, sizeof(objects));
    bytes(rendered.scene.objects.data(), objects * sizeof(SynthObjectTruth));
    const uint32_t sequence_objects = static_cast<uint32_t>(rendered.objects.size());
    bytes(&sequence_objects, sizeof(sequence_objects));
    bytes(rendered.objects.data(), sequence_objects * sizeof(SequenceObjectTruth));
    bytes(kEnd, sizeof(kEnd));
    out.flush();
    if (!out) {
      out.close();
      std::filesystem::remove(temporary, error);
      throw std::runtime_error(temporary.string() + ": cannot write the cached frame");
    }
  }
  std::filesystem::rename(temporary, target, error);
  if (error) {
    const std::string why = error.message();
    std::filesystem::remove(temporary, error);
    throw std::runtime_error(target.string() + ": cannot rename the cached frame into place: " + why);
  }
}

}  // namespace lpstereo::io
