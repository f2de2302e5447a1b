// Keyframe heuristics, nearest lookup, 3D validation and the database file (arm/localization/keyframe_database.h).
#include "arm/localization/keyframe_database.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/scratch_directory.h"

namespace lpstereo::arm::localization {
namespace {

Keyframe keyframe_at(const Eigen::Vector3d& position_m, int features, int yaw_sector = 0) {
  Keyframe keyframe;
  keyframe.world_from_camera.translation() = position_m;
  keyframe.world_from_camera.linear() = Eigen::AngleAxisd(0.3 * yaw_sector, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  keyframe.yaw_sector = yaw_sector;
  for (int i = 0; i < features; ++i) {
    KeyframeFeature feature;
    feature.pixel_px = Eigen::Vector2f(10.5f * i, 3.25f * i + 1);
    feature.point_m = Eigen::Vector3f(0.01f * i, -0.02f * i, 1.5f + 0.001f * i);
    for (int w = 0; w < kernels::kBriefWords; ++w) feature.descriptor[static_cast<size_t>(w)] = 0x9E3779B9u * static_cast<uint32_t>(i * 8 + w + 1);
    keyframe.features.push_back(feature);
  }
  return keyframe;
}

FrameSummary frame(const Eigen::Vector3d& position_m, double height_m, std::optional<int> matches, int features = 100) {
  FrameSummary summary;
  summary.position_m = position_m;
  summary.height_above_ground_m = height_m;
  summary.matches_with_previous = matches;
  summary.validated_features = features;
  return summary;
}

TEST(KeyframePolicy, FirstKeyframeAtFortyCentimetres) {
  const KeyframeDatabase database;
  EXPECT_EQ(database.decide(frame({0, 0, 0.1}, 0.1, std::nullopt)), KeyframeDecision::none);
  EXPECT_EQ(database.decide(frame({0, 0, 0.39}, 0.39, 5)), KeyframeDecision::none);  // low matches do not count before the first
  EXPECT_EQ(database.decide(frame({0, 0, 0.4}, 0.4, std::nullopt)), KeyframeDecision::first_at_height);
  EXPECT_EQ(database.decide(frame({0, 0, 0.4}, 0.4, std::nullopt, 5)), KeyframeDecision::too_few_features);  // textureless pad
}

TEST(KeyframePolicy, NewKeyframeAfterTwoMetresOrOnLowMatches) {
  KeyframeDatabase database;
  database.add(keyframe_at({0, 0, 0.4}, 10));
  EXPECT_EQ(database.decide(frame({1.9, 0, 0.4}, 0.4, 100)), KeyframeDecision::none);
  EXPECT_EQ(database.decide(frame({2.0, 0, 0.4}, 0.4, 100)), KeyframeDecision::none);  // "more than" 2 m
  EXPECT_EQ(database.decide(frame({2.01, 0, 0.4}, 0.4, 100)), KeyframeDecision::far_from_nearest);
  EXPECT_EQ(database.decide(frame({0, 0, 2.5}, 2.5, 100)), KeyframeDecision::far_from_nearest);  // climbing counts
  EXPECT_EQ(database.decide(frame({1, 0, 0.4}, 0.4, 29)), KeyframeDecision::few_matches_with_previous);
  EXPECT_EQ(database.decide(frame({1, 0, 0.4}, 0.4, 30)), KeyframeDecision::none);
  EXPECT_EQ(database.decide(frame({1, 0, 0.4}, 0.4, std::nullopt)), KeyframeDecision::none);
  // After a second keyframe the distance rule measures from the nearest one.
  database.add(keyframe_at({3, 0, 0.4}, 10));
  EXPECT_EQ(database.decide(frame({4.5, 0, 0.4}, 0.4, 100)), KeyframeDecision::none);
  EXPECT_EQ(database.decide(frame({5.5, 0, 0.4}, 0.4, 100)), KeyframeDecision::far_from_nearest);

  KeyframePolicyParameters policy;
  policy.new_keyframe_distance_m = 1.0;
  policy.min_matches_with_previous = 50;
  KeyframeDatabase tuned(policy);
  tuned.add(keyframe_at({0, 0, 0}, 1));
  EXPECT_EQ(tuned.decide(frame({1.5, 0, 0}, 0.4, 100)), KeyframeDecision::far_from_nearest);
  EXPECT_EQ(tuned.decide(frame({0.5, 0, 0}, 0.4, 40)), KeyframeDecision::few_matches_with_previous);
}

TEST(KeyframePolicy, ParametersOutOfRangeThrowNamingThem) {
  KeyframePolicyParameters policy;
  policy.new_keyframe_distance_m = 0;
  try {
    KeyframeDatabase database(policy);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "keyframe policy parameter new_keyframe_distance_m: expected > 0, got 0");
  }
  KeyframeDatabase database;
  Keyframe bad = keyframe_at({0, 0, 0}, 1);
  bad.yaw_sector = 16;
  EXPECT_THROW(database.add(bad), std::invalid_argument);
}

TEST(KeyframeDatabase, NearestByPosition) {
  KeyframeDatabase database;
  EXPECT_FALSE(database.nearest({0, 0, 0}).has_value());
  EXPECT_EQ(database.add(keyframe_at({0, 0, 0.4}, 1)), 0u);
  EXPECT_EQ(database.add(keyframe_at({2.5, 0, 2}, 1)), 1u);
  EXPECT_EQ(database.add(keyframe_at({2.5, 2.5, 2}, 1)), 2u);
  EXPECT_EQ(database.nearest({0.2, 0.1, 1.0}), std::optional<size_t>{0});
  EXPECT_EQ(database.nearest({2.4, 0.9, 2.0}), std::optional<size_t>{1});
  EXPECT_EQ(database.nearest({2.4, 1.6, 2.0}), std::optional<size_t>{2});
  EXPECT_EQ(database.nearest({1.25, 0, 1.2}), std::optional<size_t>{0});  // equidistant: the earlier
}

TEST(FeatureValidation3d, KeepsValidDisparitiesInRangeWithTheirPoints) {
  StereoGeometry geometry{700.0, 0.1, 320.0, 240.0};
  FeatureValidationParameters parameters;
  parameters.min_disparity_px = 2.0;
  parameters.max_disparity_px = 100.0;
  parameters.invalid_disparity_q4 = -16;
  std::vector<CandidateFeature> candidates(5);
  candidates[0] = {{420.0f, 240.0f}, 35 * 16, {}};  // Z = 700 * 0.1 / 35 = 2 m, X = 100 * 2 / 700
  candidates[1] = {{100.0f, 100.0f}, -16, {}};      // invalid marker
  candidates[2] = {{100.0f, 100.0f}, 1 * 16, {}};   // below the range
  candidates[3] = {{100.0f, 100.0f}, 101 * 16, {}}; // above the range
  candidates[4] = {{320.0f, 100.0f}, 140 * 4, {}};  // 35 px again (Q4: 560), Y = -140 * 2 / 700
  candidates[4].descriptor[3] = 77;
  const std::vector<KeyframeFeature> valid = validate_features_3d(candidates, geometry, parameters);
  ASSERT_EQ(valid.size(), 2u);
  EXPECT_NEAR(valid[0].point_m.z(), 2.0, 1e-6);
  EXPECT_NEAR(valid[0].point_m.x(), 100.0 * 2.0 / 700.0, 1e-6);
  EXPECT_NEAR(valid[0].point_m.y(), 0.0, 1e-6);
  EXPECT_NEAR(valid[1].point_m.y(), -0.4, 1e-6);
  EXPECT_EQ(valid[1].descriptor[3], 77u);
  EXPECT_EQ(valid[1].pixel_px, Eigen::Vector2f(320.0f, 100.0f));
  geometry.baseline_m = 0;
  EXPECT_THROW(validate_features_3d(candidates, geometry, parameters), std::invalid_argument);
}

class KeyframeFile : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = (directory_ / "map.bin").string();
  }
  std::vector<uint8_t> read_bytes() const {
    std::ifstream file(path_, std::ios::binary);
    return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
  }
  void write_bytes(const std::vector<uint8_t>& bytes) const {
    std::ofstream file(path_, std::ios::binary | std::ios::trunc);
    file.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  std::string load_error() const {
    try {
      KeyframeDatabase::load(path_);
    } catch (const KeyframeDatabaseError& error) {
      const std::string message = error.what();
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
      EXPECT_NE(message.find(path_), std::string::npos) << message;
      return message;
    }
    ADD_FAILURE() << "load accepted the file";
    return {};
  }
  void save_example() const {
    KeyframeDatabase database;
    database.add(keyframe_at({0, 0, 0.4}, 3, 0));
    database.add(keyframe_at({2.5, -1, 2}, 0, 5));
    database.add(keyframe_at({4.5, 1, 2}, 7, 15));
    database.save(path_);
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_keyframes"};  // per process and test: release and debug-asan may run it at once
  const std::filesystem::path& directory_ = scratch_.root();
  std::string path_;
};

TEST(KeyframeCrc, KnownCheckValue) {
  const std::string text = "123456789";
  EXPECT_EQ(crc32_ieee(reinterpret_cast<const uint8_t*>(text.data()), text.size()), 0xCBF43926u);
}

TEST_F(KeyframeFile, SaveLoadRoundTrip) {
  KeyframeDatabase database;
  database.add(keyframe_at({0, 0, 0.4}, 3, 0));
  database.add(keyframe_at({2.5, -1, 2}, 0, 5));
  database.add(keyframe_at({4.5, 1, 2}, 7, 15));
  database.save(path_);
  EXPECT_FALSE(std::filesystem::exists(path_ + ".tmp"));
  // Size from the format: header 12 + per keyframe 108 + 52 per feature + CRC 4.
  EXPECT_EQ(std::filesystem::file_size(path_), 12u + 3u * 108u + 10u * 52u + 4u);
  KeyframeDatabase loaded = KeyframeDatabase::load(path_);
  ASSERT_EQ(loaded.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    const Keyframe& a = database.keyframes()[k];
    const Keyframe& b = loaded.keyframes()[k];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.yaw_sector, b.yaw_sector);
    EXPECT_EQ(a.world_from_camera.matrix(), b.world_from_camera.matrix());
    EXPECT_EQ(a.features, b.features);
  }
  EXPECT_EQ(loaded.add(keyframe_at({9, 9, 2}, 1)), 3u);  // ids continue after the loaded ones
  EXPECT_EQ(loaded.nearest({4, 1, 2}), std::optional<size_t>{2});
}

TEST_F(KeyframeFile, CorruptByteIsAChecksumMismatch) {
  save_example();
  std::vector<uint8_t> bytes = read_bytes();
  bytes[200] ^= 0x10;
  write_bytes(bytes);
  EXPECT_NE(load_error().find("checksum"), std::string::npos);
}

TEST_F(KeyframeFile, WrongVersionNamesBoth) {
  save_example();
  std::vector<uint8_t> bytes = read_bytes();
  bytes[4] = 2;  // version u32 little-endian at offset 4
  write_bytes(bytes);
  EXPECT_NE(load_error().find(": version 2, expected 1"), std::string::npos);
}

TEST_F(KeyframeFile, TruncatedFiles) {
  save_example();
  const std::vector<uint8_t> bytes = read_bytes();
  write_bytes(std::vector<uint8_t>(bytes.begin(), bytes.end() - 10));
  EXPECT_NE(load_error().find("checksum"), std::string::npos);
  write_bytes(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 9));
  EXPECT_NE(load_error().find("9 bytes, expected at least 16"), std::string::npos);
  write_bytes({});
  EXPECT_NE(load_error().find("0 bytes"), std::string::npos);
}

TEST_F(KeyframeFile, CountsBeyondTheDataAreRefusedEvenWithAValidChecksum) {
  // A header claiming one keyframe with 2^31 features, its checksum correct: the count must not size an allocation.
  std::vector<uint8_t> bytes = {'L', 'P', 'K', 'F', 1, 0, 0, 0, 1, 0, 0, 0};
  bytes.resize(bytes.size() + 8 + 96, 0);                      // id, yaw sector, pose
  bytes.insert(bytes.end(), {0x00, 0x00, 0x00, 0x80});         // feature count 2^31
  const uint32_t crc = crc32_ieee(bytes.data(), bytes.size());
  for (int byte = 0; byte < 4; ++byte) bytes.push_back(static_cast<uint8_t>(crc >> (8 * byte)));
  write_bytes(bytes);
  EXPECT_NE(load_error().find("truncated or corrupt"), std::string::npos);
}

TEST_F(KeyframeFile, NotADatabaseAndMissingFile) {
  write_bytes(std::vector<uint8_t>(64, 'x'));
  EXPECT_NE(load_error().find("magic bytes 78 78 78 78, expected \"LPKF\""), std::string::npos);
  std::filesystem::remove(path_);
  EXPECT_NE(load_error().find("cannot open"), std::string::npos);
}

}  // namespace
}  // namespace lpstereo::arm::localization
