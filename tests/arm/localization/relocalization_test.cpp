// Relocalization (arm/localization/relocalization.h): the 16-sector search from a known start point
// with unknown yaw on the project's rendered textured ground (io/stereo_flight.h), a textureless
// view, and relocalization anywhere through the vocabulary tree.
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "arm/localization/relocalization.h"
#include "io/image_io.h"
#include "io/stereo_flight.h"

namespace lpstereo::arm::localization {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

io::StereoFlightOptions ground_options() {
  io::StereoFlightOptions options;  // 640 x 480, 90 degrees: f = 320 px, baseline 0.1 m
  options.samples_per_axis = 1;
  options.noise_sigma = 2;
  options.seed = 5;
  return options;
}

io::FlightState state_at(const io::StereoFlightOptions& options, double x_m, double y_m, double height_m, double yaw_rad) {
  return io::flight_state_at_pose(options, Eigen::Vector3d(x_m, y_m, height_m), yaw_rad);
}

struct ViewFeatures {
  std::vector<KeyframeFeature> validated;  // pixel, point, sector-0 descriptor
  SectorDescriptors descriptors;
  io::FlightState state;
};

// Features of the left view: keypoints and all 16 sectors from the extractor, 3D points from the
// rendered disparity (exact: the flat ground) through validate_features_3d.
ViewFeatures features_of(SteeredFeatureExtractor& extractor, const io::StereoFlightOptions& options, const io::FlightState& state,
                         int frame_index) {
  const io::StereoFlightFrame frame = io::render_flight_frame(options, state, frame_index);
  const SteeredFeatures steered = extractor.extract(io::mat_to_plane(frame.left, {ElementType::u8, 0}));
  std::vector<CandidateFeature> candidates;
  for (size_t i = 0; i < steered.pixels_px.size(); ++i) {
    CandidateFeature candidate;
    candidate.pixel_px = steered.pixels_px[i];
    const float disparity_px = frame.disparity_px.at<float>(static_cast<int>(candidate.pixel_px.y()), static_cast<int>(candidate.pixel_px.x()));
    candidate.disparity_q4 = static_cast<int16_t>(std::lround(16.0 * disparity_px));
    candidate.descriptor = steered.descriptors[0][i];
    candidates.push_back(candidate);
  }
  const double focal_px = io::flight_focal_px(options);
  const StereoGeometry geometry{focal_px, options.baseline_m, (options.width - 1) / 2.0, (options.height - 1) / 2.0};
  ViewFeatures view;
  view.validated = validate_features_3d(candidates, geometry, {});
  view.descriptors = steered.descriptors;
  view.state = state;
  return view;
}

Keyframe keyframe_of(const ViewFeatures& view) {
  Keyframe keyframe;
  keyframe.world_from_camera = view.state.left_camera;
  keyframe.yaw_sector = 0;
  keyframe.features = view.validated;
  return keyframe;
}

double wrap(double angle_rad) { return std::remainder(angle_rad, 2.0 * std::numbers::pi); }

TEST(Relocalization, SixteenSectorsFindTheYawOfARotatedGround) {
  const io::StereoFlightOptions options = ground_options();
  SteeredFeatureExtractor extractor(options.width, options.height, {});
  const ViewFeatures stored = features_of(extractor, options, state_at(options, 0.0, 0.0, 1.5, 0.0), 0);
  ASSERT_GT(stored.validated.size(), 200u);
  const Keyframe keyframe = keyframe_of(stored);

  // The drone back near the keyframe, yawed by a known angle (not a multiple of 22.5 degrees).
  for (const double yaw_deg : {100.0, 200.0, 305.0}) {
    const ViewFeatures now = features_of(extractor, options, state_at(options, 0.08, -0.05, 1.5, yaw_deg * kDegree), 1);
    ASSERT_EQ(now.validated.size(), now.descriptors[0].size());  // every disparity valid: rows stay aligned
    const SectorRelocalization result = relocalize_sectors(now.validated, now.descriptors, keyframe, {});
    ASSERT_TRUE(result.ok) << result.failure;
    // The image rotates by +yaw in brief256's sense (stereo_flight.h), so sector round(yaw / 22.5) is
    // expected, give or take one (the angle falls between two sectors).
    const int expected_sector = static_cast<int>(std::lround(yaw_deg / 22.5)) % 16;
    const int sector_error = std::abs(((result.sector - expected_sector) % 16 + 24) % 16 - 8);
    EXPECT_LE(sector_error, 1) << "yaw " << yaw_deg << " deg: sector " << result.sector;
    EXPECT_LT(std::abs(wrap(result.sector_image_rotation_rad - yaw_deg * kDegree)), 22.5 * kDegree) << "yaw " << yaw_deg;
    EXPECT_LT(std::abs(wrap(result.measured_image_rotation_rad - yaw_deg * kDegree)), 22.5 * kDegree) << "yaw " << yaw_deg;
    // Skipped sectors could not have won: fewer matches than the winner's inliers.
    for (const SectorTrial& trial : result.trials) {
      if (!trial.checked) {
        EXPECT_LT(trial.matches, result.correction.rigid_inliers);
      }
    }
    EXPECT_TRUE(result.trials[static_cast<size_t>(result.sector)].checked);
    // The winner has many more inliers than a sector half a turn away.
    const int opposite = (result.sector + 8) % 16;
    EXPECT_GT(result.trials[static_cast<size_t>(result.sector)].rigid_inliers,
              3 * std::max(1, result.trials[static_cast<size_t>(opposite)].rigid_inliers));
    // The pose: the true current left camera, from the keyframe's.
    const Eigen::Isometry3d truth = now.state.left_camera;
    EXPECT_LT((result.correction.world_from_current.translation() - truth.translation()).norm(), 0.05) << "yaw " << yaw_deg;
  }
}

TEST(Relocalization, TexturelessGroundFailsCleanly) {
  SteeredFeatureExtractor extractor(320, 240, {});
  Plane flat(320, 240, {ElementType::u8, 0});
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) flat.at<uint8_t>(x, y) = 128;
  }
  const SteeredFeatures features = extractor.extract(flat);
  EXPECT_TRUE(features.pixels_px.empty());
  for (const auto& sector : features.descriptors) EXPECT_TRUE(sector.empty());
  Keyframe keyframe;
  keyframe.features.resize(50);
  const SectorRelocalization result = relocalize_sectors({}, features.descriptors, keyframe, {});
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(result.sector, -1);
  EXPECT_NE(result.failure.find("textureless"), std::string::npos) << result.failure;
  EXPECT_EQ(result.failure.find('\n'), std::string::npos);
  // Misaligned descriptor lists are a caller error, not a failure to relocalize.
  std::vector<KeyframeFeature> one(1);
  EXPECT_THROW(relocalize_sectors(one, features.descriptors, keyframe, {}), std::invalid_argument);
}

TEST(Relocalization, AnywhereFindsTheRightKeyframeOfAMap) {
  const io::StereoFlightOptions options = ground_options();
  SteeredFeatureExtractor extractor(options.width, options.height, {});
  // A row of 6 keyframes 4 m apart at 1.5 m (3 m footprint: no overlap).
  std::vector<Keyframe> keyframes;
  std::vector<std::vector<BriefDescriptor>> training;
  for (int k = 0; k < 6; ++k) {
    const ViewFeatures view = features_of(extractor, options, state_at(options, 4.0 * k, 0.0, 1.5, 0.0), 10 + k);
    keyframes.push_back(keyframe_of(view));
    training.emplace_back();
    for (const KeyframeFeature& feature : view.validated) training.back().push_back(feature.descriptor);
  }
  const VocabularyTree vocabulary = VocabularyTree::train(training, {.branching = 8, .depth = 3, .max_iterations = 6, .seed = 1});
  BowDatabase index(vocabulary);
  for (const auto& descriptors : training) index.add(descriptors);
  // Back over keyframe 3, shifted and yawed a little (sector 0 still applies).
  const ViewFeatures now = features_of(extractor, options, state_at(options, 12.1, 0.1, 1.5, 4 * kDegree), 30);
  RelocalizationParameters parameters;
  parameters.top_n = 3;
  const AnywhereRelocalization result = relocalize_anywhere(now.validated, keyframes, index, parameters);
  ASSERT_TRUE(result.ok) << result.failure;
  EXPECT_EQ(result.keyframe_index, 3u);
  ASSERT_FALSE(result.candidates.empty());
  EXPECT_EQ(result.candidates[0].keyframe_index, 3u);
  EXPECT_LT((result.correction.world_from_current.translation() - now.state.left_camera.translation()).norm(), 0.05);
  const std::vector<Keyframe> fewer(keyframes.begin(), keyframes.begin() + 2);
  EXPECT_THROW(relocalize_anywhere(now.validated, fewer, index, parameters), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm::localization
