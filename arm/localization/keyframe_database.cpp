// Heuristics, validation and file format: keyframe_database.h.
#include "arm/localization/keyframe_database.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <system_error>

namespace lpstereo::arm::localization {
namespace {

std::string fmt(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

constexpr char kMagic[4] = {'L', 'P', 'K', 'F'};
constexpr size_t kHeaderBytes = 12;   // magic, version, count
constexpr size_t kTrailerBytes = 4;   // CRC-32
constexpr size_t kKeyframeFixedBytes = 4 + 4 + 12 * 8 + 4;
constexpr size_t kFeatureBytes = 5 * 4 + kernels::kBriefWords * 4;

class Writer {
 public:
  void u32(uint32_t value) {
    for (int byte = 0; byte < 4; ++byte) bytes.push_back(static_cast<uint8_t>(value >> (8 * byte)));
  }
  void u64(uint64_t value) {
    for (int byte = 0; byte < 8; ++byte) bytes.push_back(static_cast<uint8_t>(value >> (8 * byte)));
  }
  void f32(float value) {
    uint32_t bits;
    std::memcpy(&bits, &value, 4);
    u32(bits);
  }
  void f64(double value) {
    uint64_t bits;
    std::memcpy(&bits, &value, 8);
    u64(bits);
  }
  std::vector<uint8_t> bytes;
};

class Reader {
 public:
  Reader(const std::vector<uint8_t>& bytes, size_t end, const std::string& path) : bytes_(bytes), end_(end), path_(path) {}
  void need(size_t count, const std::string& what) const {
    if (end_ - offset_ < count) {
      throw KeyframeDatabaseError("keyframe database " + path_ + ": " + what + " needs " + std::to_string(count) +
                                  " bytes at offset " + std::to_string(offset_) + ", only " + std::to_string(end_ - offset_) +
                                  " left (truncated or corrupt)");
    }
  }
  uint32_t u32() {
    uint32_t value = 0;
    for (int byte = 0; byte < 4; ++byte) value |= uint32_t{bytes_[offset_ + static_cast<size_t>(byte)]} << (8 * byte);
    offset_ += 4;
    return value;
  }
  uint64_t u64() {
    uint64_t value = 0;
    for (int byte = 0; byte < 8; ++byte) value |= uint64_t{bytes_[offset_ + static_cast<size_t>(byte)]} << (8 * byte);
    offset_ += 8;
    return value;
  }
  float f32() {
    const uint32_t bits = u32();
    float value;
    std::memcpy(&value, &bits, 4);
    return value;
  }
  double f64() {
    const uint64_t bits = u64();
    double value;
    std::memcpy(&value, &bits, 8);
    return value;
  }
  size_t offset() const { return offset_; }
  size_t left() const { return end_ - offset_; }

 private:
  const std::vector<uint8_t>& bytes_;
  size_t end_;
  const std::string& path_;
  size_t offset_ = 0;
};

void check_policy(const KeyframePolicyParameters& p) {
  auto fail = [](const std::string& name, const std::string& expected, double value) {
    throw std::invalid_argument("keyframe policy parameter " + name + ": expected " + expected + ", got " + fmt(value));
  };
  if (!(p.first_keyframe_height_m > 0)) fail("first_keyframe_height_m", "> 0", p.first_keyframe_height_m);
  if (!(p.new_keyframe_distance_m > 0)) fail("new_keyframe_distance_m", "> 0", p.new_keyframe_distance_m);
  if (p.min_matches_with_previous < 0) fail("min_matches_with_previous", ">= 0", p.min_matches_with_previous);
  if (p.min_keyframe_features < 0) fail("min_keyframe_features", ">= 0", p.min_keyframe_features);
}

void check_yaw_sector(int yaw_sector, const std::string& where) {
  if (yaw_sector < 0 || yaw_sector >= kernels::kBriefSectors) {
    throw std::invalid_argument(where + ": yaw_sector expected 0 .. " + std::to_string(kernels::kBriefSectors - 1) +
                                ", got " + std::to_string(yaw_sector));
  }
}

}  // namespace

uint32_t crc32_ieee(const uint8_t* data, size_t size) {
  static const auto table = [] {
    std::array<uint32_t, 256> entries{};
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int bit = 0; bit < 8; ++bit) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      entries[n] = c;
    }
    return entries;
  }();
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) crc = table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

std::vector<KeyframeFeature> validate_features_3d(const std::vector<CandidateFeature>& candidates,
                                                  const StereoGeometry& geometry,
                                                  const FeatureValidationParameters& parameters) {
  auto fail = [](const std::string& name, const std::string& expected, double value) {
    throw std::invalid_argument("feature validation: " + name + " expected " + expected + ", got " + fmt(value));
  };
  if (!(geometry.focal_px > 0)) fail("focal_px", "> 0", geometry.focal_px);
  if (!(geometry.baseline_m > 0)) fail("baseline_m", "> 0", geometry.baseline_m);
  if (!(parameters.min_disparity_px > 0)) fail("min_disparity_px", "> 0", parameters.min_disparity_px);
  if (!(parameters.max_disparity_px >= parameters.min_disparity_px)) {
    fail("max_disparity_px", ">= min_disparity_px = " + fmt(parameters.min_disparity_px), parameters.max_disparity_px);
  }
  std::vector<KeyframeFeature> valid;
  for (const CandidateFeature& candidate : candidates) {
    if (candidate.disparity_q4 == parameters.invalid_disparity_q4) continue;
    const double disparity_px = candidate.disparity_q4 / 16.0;
    if (disparity_px < parameters.min_disparity_px || disparity_px > parameters.max_disparity_px) continue;
    const double depth_m = geometry.focal_px * geometry.baseline_m / disparity_px;
    KeyframeFeature feature;
    feature.pixel_px = candidate.pixel_px;
    feature.point_m = Eigen::Vector3d((candidate.pixel_px.x() - geometry.u0_px) * depth_m / geometry.focal_px,
                                      (candidate.pixel_px.y() - geometry.v0_px) * depth_m / geometry.focal_px, depth_m)
                          .cast<float>();
    feature.descriptor = candidate.descriptor;
    valid.push_back(feature);
  }
  return valid;
}

const char* to_string(KeyframeDecision decision) {
  switch (decision) {
    case KeyframeDecision::none: return "none";
    case KeyframeDecision::first_at_height: return "first_at_height";
    case KeyframeDecision::far_from_nearest: return "far_from_nearest";
    case KeyframeDecision::few_matches_with_previous: return "few_matches_with_previous";
    case KeyframeDecision::too_few_features: return "too_few_features";
  }
  return "?";
}

KeyframeDatabase::KeyframeDatabase(const KeyframePolicyParameters& policy) : policy_(policy) { check_policy(policy_); }

KeyframeDecision KeyframeDatabase::decide(const FrameSummary& frame) const {
  KeyframeDecision rule = KeyframeDecision::none;
  if (keyframes_.empty()) {
    if (frame.height_above_ground_m >= policy_.first_keyframe_height_m) rule = KeyframeDecision::first_at_height;
  } else {
    const Keyframe& nearest_keyframe = keyframes_[*nearest(frame.position_m)];
    if ((nearest_keyframe.position_m() - frame.position_m).norm() > policy_.new_keyframe_distance_m) {
      rule = KeyframeDecision::far_from_nearest;
    } else if (frame.matches_with_previous && *frame.matches_with_previous < policy_.min_matches_with_previous) {
      rule = KeyframeDecision::few_matches_with_previous;
    }
  }
  if (rule != KeyframeDecision::none && frame.validated_features < policy_.min_keyframe_features) {
    return KeyframeDecision::too_few_features;
  }
  return rule;
}

uint32_t KeyframeDatabase::add(Keyframe keyframe) {
  check_yaw_sector(keyframe.yaw_sector, "keyframe database add");
  keyframe.id = next_id_++;
  keyframes_.push_back(std::move(keyframe));
  return keyframes_.back().id;
}

std::optional<size_t> KeyframeDatabase::nearest(const Eigen::Vector3d& position_m) const {
  std::optional<size_t> best;
  double best_distance_squared = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    const double distance_squared = (keyframes_[i].position_m() - position_m).squaredNorm();
    if (distance_squared < best_distance_squared) {
      best_distance_squared = distance_squared;
      best = i;
    }
  }
  return best;
}

void KeyframeDatabase::save(const std::string& path) const {
  Writer out;
  out.bytes.insert(out.bytes.end(), kMagic, kMagic + 4);
  out.u32(kFileVersion);
  out.u32(static_cast<uint32_t>(keyframes_.size()));
  for (const Keyframe& keyframe : keyframes_) {
    out.u32(keyframe.id);
    out.u32(static_cast<uint32_t>(keyframe.yaw_sector));
    const Eigen::Matrix<double, 3, 4> pose = keyframe.world_from_camera.matrix().topRows<3>();
    for (int row = 0; row < 3; ++row) {
      for (int column = 0; column < 4; ++column) out.f64(pose(row, column));
    }
    out.u32(static_cast<uint32_t>(keyframe.features.size()));
    for (const KeyframeFeature& feature : keyframe.features) {
      out.f32(feature.pixel_px.x());
      out.f32(feature.pixel_px.y());
      for (int axis = 0; axis < 3; ++axis) out.f32(feature.point_m(axis));
      for (const uint32_t word : feature.descriptor) out.u32(word);
    }
  }
  out.u32(crc32_ieee(out.bytes.data(), out.bytes.size()));

  const std::string temporary = path + ".tmp";
  {
    std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
    if (!file) throw KeyframeDatabaseError("keyframe database " + path + ": cannot create " + temporary);
    file.write(reinterpret_cast<const char*>(out.bytes.data()), static_cast<std::streamsize>(out.bytes.size()));
    if (!file.flush()) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      throw KeyframeDatabaseError("keyframe database " + path + ": writing " + temporary + " failed");
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    throw KeyframeDatabaseError("keyframe database " + path + ": cannot rename the temporary file into place");
  }
}

KeyframeDatabase KeyframeDatabase::load(const std::string& path, const KeyframePolicyParameters& policy) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw KeyframeDatabaseError("keyframe database " + path + ": cannot open the file");
  const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
  const std::string size_text = std::to_string(bytes.size());
  if (bytes.size() < kHeaderBytes + kTrailerBytes) {
    throw KeyframeDatabaseError("keyframe database " + path + ": " + size_text + " bytes, expected at least " +
                                std::to_string(kHeaderBytes + kTrailerBytes) + " (header and checksum; truncated)");
  }
  if (std::memcmp(bytes.data(), kMagic, 4) != 0) {
    char found[48];
    std::snprintf(found, sizeof found, "%02X %02X %02X %02X", bytes[0], bytes[1], bytes[2], bytes[3]);
    throw KeyframeDatabaseError("keyframe database " + path + ": magic bytes " + found +
                                ", expected \"LPKF\" (4C 50 4B 46): not a keyframe database");
  }
  const size_t body_end = bytes.size() - kTrailerBytes;
  Reader header(bytes, body_end, path);
  header.u32();  // magic, checked above
  const uint32_t version = header.u32();
  if (version != kFileVersion) {
    throw KeyframeDatabaseError("keyframe database " + path + ": version " + std::to_string(version) + ", expected " +
                                std::to_string(kFileVersion));
  }
  uint32_t stored_crc = 0;
  for (int byte = 0; byte < 4; ++byte) stored_crc |= uint32_t{bytes[body_end + static_cast<size_t>(byte)]} << (8 * byte);
  const uint32_t actual_crc = crc32_ieee(bytes.data(), body_end);
  if (stored_crc != actual_crc) {
    char text[96];
    std::snprintf(text, sizeof text, "checksum 0x%08X, expected 0x%08X (corrupt or truncated)", actual_crc, stored_crc);
    throw KeyframeDatabaseError("keyframe database " + path + ": " + text);
  }
  KeyframeDatabase database(policy);
  const uint32_t keyframe_count = header.u32();
  for (uint32_t k = 0; k < keyframe_count; ++k) {
    const std::string what = "keyframe " + std::to_string(k) + " of " + std::to_string(keyframe_count);
    header.need(kKeyframeFixedBytes, what);
    Keyframe keyframe;
    keyframe.id = header.u32();
    const uint32_t yaw_sector = header.u32();
    if (yaw_sector >= static_cast<uint32_t>(kernels::kBriefSectors)) {
      throw KeyframeDatabaseError("keyframe database " + path + ": " + what + " has yaw sector " + std::to_string(yaw_sector) +
                                  ", expected 0 .. " + std::to_string(kernels::kBriefSectors - 1));
    }
    keyframe.yaw_sector = static_cast<int>(yaw_sector);
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    for (int row = 0; row < 3; ++row) {
      for (int column = 0; column < 4; ++column) pose(row, column) = header.f64();
    }
    keyframe.world_from_camera.matrix() = pose;
    const uint32_t feature_count = header.u32();
    if (header.left() / kFeatureBytes < feature_count) {
      header.need(static_cast<size_t>(feature_count) * kFeatureBytes, what + " (" + std::to_string(feature_count) + " features)");
    }
    keyframe.features.resize(feature_count);
    for (KeyframeFeature& feature : keyframe.features) {
      feature.pixel_px.x() = header.f32();
      feature.pixel_px.y() = header.f32();
      for (int axis = 0; axis < 3; ++axis) feature.point_m(axis) = header.f32();
      for (uint32_t& word : feature.descriptor) word = header.u32();
    }
    database.next_id_ = std::max(database.next_id_, keyframe.id + 1);
    database.keyframes_.push_back(std::move(keyframe));
  }
  if (header.left() != 0) {
    throw KeyframeDatabaseError("keyframe database " + path + ": " + std::to_string(header.left()) +
                                " bytes after the last keyframe, expected 0");
  }
  return database;
}

}  // namespace lpstereo::arm::localization
