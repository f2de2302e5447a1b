// Steps and sources: relocalization.h.
#include "arm/localization/relocalization.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "arm/localization/ransac_sampling.h"
#include "arm/odometry/stereo_odometry.h"
#include "arm/scheduler.h"
#include "arm/tasks/keypoint_record.h"

namespace lpstereo::arm::localization {
namespace {

constexpr double kSectorRad = 2.0 * std::numbers::pi / kernels::kBriefSectors;
// match_features' radius window centred on the query: this radius covers any image.
constexpr double kWholeImageRadiusPx = 1e6;

std::string sector_buffer(int sector) { return "descriptors_sector_" + std::to_string(sector); }

}  // namespace

GraphSpec SteeredFeatureExtractor::graph_spec(const SteeredFeatureParameters& p) {
  const std::string owner = "steered features";
  if (p.harris_threshold < 0) throw_parameter_error(owner, "harris_threshold", ">= 0", p.harris_threshold);
  if (p.cell_size_px < 8) throw_parameter_error(owner, "cell_size_px", ">= 8", p.cell_size_px);
  if (p.per_cell_k < 1) throw_parameter_error(owner, "per_cell_k", ">= 1", p.per_cell_k);
  if (p.max_keypoints < 1) throw_parameter_error(owner, "max_keypoints", ">= 1", p.max_keypoints);
  if (p.border_px < 16) throw_parameter_error(owner, "border_px", ">= 16 (brief256's 31 x 31 patch)", p.border_px);
  GraphSpec spec;
  spec.name = "relocalization-features";
  spec.description = "Harris corners of one view and their BRIEF-256 descriptors with all 16 steered patterns (relocalization)";
  spec.inputs = {{"image", {ElementType::u8, 0}}};
  spec.nodes.push_back({.name = "harris_response",
                        .kernel = "harris_response",
                        .inputs = {{"image", {"image", false}}},
                        .outputs = {{"response", "harris"}},
                        .params = {{"window_size", 3}, {"k_numerator", 3}, {"k_shift", 6}}});
  spec.nodes.push_back({.name = "harris_nms",
                        .kernel = "harris_nms",
                        .inputs = {{"response", {"harris", false}}},
                        .outputs = {{"corners", "corners"}},
                        .params = {{"radius", 1}, {"threshold", p.harris_threshold}}});
  spec.nodes.push_back({.name = "select_keypoints",
                        .task = "select_keypoints",
                        .inputs = {{"corners", {"corners", false}}, {"response", {"harris", false}}},
                        .outputs = {{"keypoints", "keypoints"}},
                        .params = {{"cell_size_px", p.cell_size_px},
                                   {"per_cell_k", p.per_cell_k},
                                   {"max_keypoints", p.max_keypoints},
                                   {"border_px", p.border_px}}});
  spec.nodes.push_back(
      {.name = "smooth", .kernel = "gaussian5x5", .inputs = {{"input", {"image", false}}}, .outputs = {{"output", "smoothed"}}});
  spec.outputs.push_back("keypoints");
  for (int sector = 0; sector < kernels::kBriefSectors; ++sector) {
    spec.nodes.push_back({.name = "brief256_sector_" + std::to_string(sector),
                          .kernel = "brief256",
                          .inputs = {{"image", {"smoothed", false}}, {"keypoints", {"keypoints", false}}},
                          .outputs = {{"descriptors", sector_buffer(sector)}},
                          .params = {{"yaw_sector", sector}}});
    spec.outputs.push_back(sector_buffer(sector));
  }
  return spec;
}

SteeredFeatureExtractor::SteeredFeatureExtractor(int width, int height, const SteeredFeatureParameters& parameters,
                                                 int worker_threads) {
  graph_ = make_verified_graph(graph_spec(parameters), width, height, MemoryBudget{});
  runner_ = std::make_unique<FrameRunner>(*graph_, worker_threads);
}

SteeredFeatureExtractor::~SteeredFeatureExtractor() = default;

SteeredFeatures SteeredFeatureExtractor::extract(const Plane& image_u8) {
  runner_->process({{"image", &image_u8}});
  const Plane& keypoints = runner_->buffer("keypoints");
  SteeredFeatures features;
  int count = 0;
  for (; count < keypoints.height(); ++count) {
    const int32_t* word = keypoints.row<const int32_t>(count);
    if (word[kKeypointValid] == 0) break;  // used rows come first
    features.pixels_px.emplace_back(static_cast<float>(word[kKeypointXPx]), static_cast<float>(word[kKeypointYPx]));
  }
  for (int sector = 0; sector < kernels::kBriefSectors; ++sector) {
    const Plane& plane = runner_->buffer(sector_buffer(sector));
    std::vector<BriefDescriptor>& list = features.descriptors[static_cast<size_t>(sector)];
    list.resize(static_cast<size_t>(count));
    for (int row = 0; row < count; ++row) {
      const uint32_t* words = plane.row<const uint32_t>(row);
      std::copy(words, words + kernels::kBriefWords, list[static_cast<size_t>(row)].begin());
    }
  }
  return features;
}

std::vector<FeatureMatch> match_to_keyframe(const std::vector<Eigen::Vector2f>& current_pixels_px,
                                            const std::vector<BriefDescriptor>& current_descriptors, const Keyframe& keyframe,
                                            const RelocalizationParameters& parameters) {
  if (current_pixels_px.size() != current_descriptors.size()) {
    throw std::invalid_argument("relocalization matching: expected one descriptor per current pixel (" +
                                std::to_string(current_pixels_px.size()) + "), got " + std::to_string(current_descriptors.size()));
  }
  const auto to_feature = [](const Eigen::Vector2f& pixel, const BriefDescriptor& descriptor) {
    OdometryFeature feature;
    feature.x_px = pixel.x();
    feature.y_px = pixel.y();
    std::copy(descriptor.begin(), descriptor.end(), feature.descriptor);
    return feature;
  };
  std::vector<OdometryFeature> queries, candidates;
  std::vector<Eigen::Vector2d> centres;
  for (size_t i = 0; i < current_pixels_px.size(); ++i) {
    queries.push_back(to_feature(current_pixels_px[i], current_descriptors[i]));
    centres.push_back(current_pixels_px[i].cast<double>());
  }
  for (const KeyframeFeature& feature : keyframe.features) candidates.push_back(to_feature(feature.pixel_px, feature.descriptor));
  MatchWindow window;
  window.kind = MatchWindow::Kind::radius;
  window.radius_px = kWholeImageRadiusPx;
  const std::vector<int> best = match_features(queries, centres, candidates, window, parameters.max_hamming_distance, parameters.ratio_test);
  std::vector<FeatureMatch> matches;
  for (size_t i = 0; i < best.size(); ++i) {
    if (best[i] >= 0) matches.push_back({static_cast<int>(i), best[i]});
  }
  return matches;
}

SectorRelocalization relocalize_sectors(const std::vector<KeyframeFeature>& current, const SectorDescriptors& descriptors,
                                        const Keyframe& keyframe, const RelocalizationParameters& parameters) {
  std::vector<Eigen::Vector2f> pixels;
  for (const KeyframeFeature& feature : current) pixels.push_back(feature.pixel_px);
  for (int sector = 0; sector < kernels::kBriefSectors; ++sector) {
    const size_t rows = descriptors[static_cast<size_t>(sector)].size();
    if (rows != current.size()) {
      throw std::invalid_argument("sector relocalization: sector " + std::to_string(sector) + " has " + std::to_string(rows) +
                                  " descriptors, expected one per current feature (" + std::to_string(current.size()) + ")");
    }
  }
  SectorRelocalization result;
  if (current.empty() || keyframe.features.empty()) {
    result.failure = "sector relocalization: " + std::to_string(current.size()) + " current features and " +
                     std::to_string(keyframe.features.size()) + " keyframe features, expected some of both (textureless view?)";
    return result;
  }
  // Every sector matched first (cheap), then the pose correction in decreasing order of matches,
  // skipping a sector with fewer matches than the best rigid inliers so far: inliers <= matches, so
  // it could neither win nor tie (an exact pruning: the result is the one of checking all 16).
  std::array<std::vector<FeatureMatch>, kernels::kBriefSectors> matches;
  std::array<int, kernels::kBriefSectors> order{};
  for (int sector = 0; sector < kernels::kBriefSectors; ++sector) {
    matches[static_cast<size_t>(sector)] = match_to_keyframe(pixels, descriptors[static_cast<size_t>(sector)], keyframe, parameters);
    result.trials[static_cast<size_t>(sector)].matches = static_cast<int>(matches[static_cast<size_t>(sector)].size());
    order[static_cast<size_t>(sector)] = sector;
  }
  std::stable_sort(order.begin(), order.end(), [&result](int a, int b) {
    return result.trials[static_cast<size_t>(a)].matches > result.trials[static_cast<size_t>(b)].matches;
  });
  std::string last_failure = "no sector was checked";
  for (const int sector : order) {
    SectorTrial& trial = result.trials[static_cast<size_t>(sector)];
    if (result.ok && trial.matches < result.correction.rigid_inliers) continue;
    trial.checked = true;
    PoseCorrection correction = correct_pose(current, keyframe, matches[static_cast<size_t>(sector)], parameters.pose);
    if (!correction.ok) {
      last_failure = correction.failure;
      continue;
    }
    trial.rigid_inliers = correction.rigid_inliers;
    const bool better = !result.ok || correction.rigid_inliers > result.correction.rigid_inliers ||
                        (correction.rigid_inliers == result.correction.rigid_inliers && sector < result.sector);
    if (better) {
      result.ok = true;
      result.sector = sector;
      result.correction = std::move(correction);
    }
  }
  if (!result.ok) {
    result.failure = "sector relocalization: no sector gave a pose (last: " + last_failure + ")";
    return result;
  }
  const int relative = ((result.sector - keyframe.yaw_sector) % kernels::kBriefSectors + kernels::kBriefSectors) % kernels::kBriefSectors;
  result.sector_image_rotation_rad = relative * kSectorRad;
  const Eigen::Matrix3d& rotation = result.correction.keyframe_from_current.linear();
  result.measured_image_rotation_rad = std::atan2(rotation(0, 1), rotation(0, 0));
  return result;
}

AnywhereRelocalization relocalize_anywhere(const std::vector<KeyframeFeature>& current, const std::vector<Keyframe>& keyframes,
                                           const BowDatabase& index, const RelocalizationParameters& parameters) {
  if (index.size() != keyframes.size()) {
    throw std::invalid_argument("relocalization anywhere: the vocabulary index holds " + std::to_string(index.size()) +
                                " keyframes, expected the keyframe list's " + std::to_string(keyframes.size()));
  }
  std::vector<Eigen::Vector2f> pixels;
  std::vector<BriefDescriptor> descriptors;
  for (const KeyframeFeature& feature : current) {
    pixels.push_back(feature.pixel_px);
    descriptors.push_back(feature.descriptor);
  }
  AnywhereRelocalization result;
  std::string last_failure = "no keyframe shares a word with the current frame";
  for (const BowCandidate& candidate : index.query(descriptors, parameters.top_n)) {
    const Keyframe& keyframe = keyframes[candidate.keyframe_index];
    const std::vector<FeatureMatch> matches = match_to_keyframe(pixels, descriptors, keyframe, parameters);
    AnywhereCandidate checked{candidate.keyframe_index, candidate.score, static_cast<int>(matches.size()), 0};
    PoseCorrection correction = correct_pose(current, keyframe, matches, parameters.pose);
    if (correction.ok) {
      checked.rigid_inliers = correction.rigid_inliers;
      if (!result.ok || correction.rigid_inliers > result.correction.rigid_inliers) {
        result.ok = true;
        result.keyframe_index = candidate.keyframe_index;
        result.correction = std::move(correction);
      }
    } else {
      last_failure = correction.failure;
    }
    result.candidates.push_back(checked);
  }
  if (!result.ok) result.failure = "relocalization anywhere: no candidate gave a pose (last: " + last_failure + ")";
  return result;
}

}  // namespace lpstereo::arm::localization
