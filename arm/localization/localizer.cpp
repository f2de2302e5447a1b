#include "arm/localization/localizer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "arm/scheduler.h"
#include "arm/tasks/keypoint_record.h"
#include "dag/tile_executor.h"
#include "kernels/kernel.h"
#include "kernels/match_record.h"
#include "kernels/simd/isa.h"

namespace lpstereo::arm::localization {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSectorRad = 2.0 * kPi / kernels::kBriefSectors;

void check(bool ok, const char* name, const std::string& expected, double actual) {
  if (!ok) {
    char text[64];
    std::snprintf(text, sizeof text, "%g", actual);
    throw std::invalid_argument(std::string("localizer parameter '") + name + "': expected " + expected + ", got " + text);
  }
}

double yaw_of(const Eigen::Matrix3d& rotation) { return std::atan2(rotation(1, 0), rotation(0, 0)); }

Eigen::Isometry3d body_pose(const Eigen::Vector3d& position_m, double yaw_rad) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = position_m;
  return pose;
}

// The steering sector of a yaw difference (header comment): nearest multiple of 22.5 degrees, 0 .. 15.
int sector_of(double yaw_difference_rad) {
  const long sector = std::lround(wrap_angle_rad(yaw_difference_rad) / kSectorRad);
  return static_cast<int>(((sector % kernels::kBriefSectors) + kernels::kBriefSectors) % kernels::kBriefSectors);
}

OdometryFeature odometry_feature(const Eigen::Vector2f& pixel_px, const BriefDescriptor& descriptor) {
  OdometryFeature feature;
  feature.x_px = pixel_px.x();
  feature.y_px = pixel_px.y();
  std::copy(descriptor.begin(), descriptor.end(), feature.descriptor);
  return feature;
}

}  // namespace

void KeyframeLocalizerParameters::validate() const {
  check(focal_px > 0, "focal_px", "> 0", focal_px);
  check(std::isfinite(principal_point_x_px), "principal_point_x_px", "finite", principal_point_x_px);
  check(std::isfinite(principal_point_y_px), "principal_point_y_px", "finite", principal_point_y_px);
  check(baseline_m > 0, "baseline_m", "> 0", baseline_m);
  check(start_height_m > 0, "start_height_m", "> 0", start_height_m);
  check(std::isfinite(start_yaw_rad), "start_yaw_rad", "finite", start_yaw_rad);
  check(cell_size_px >= 8, "cell_size_px", ">= 8", cell_size_px);
  check(per_cell_k >= 1, "per_cell_k", ">= 1", per_cell_k);
  check(max_keypoints >= 8, "max_keypoints", ">= 8", max_keypoints);
  check(num_disparities >= 1 && num_disparities <= 256, "num_disparities", "1 .. 256", num_disparities);
  check(uniqueness_percent >= 0 && uniqueness_percent <= 50, "uniqueness_percent", "0 .. 50", uniqueness_percent);
  check(previous_ratio_q8 >= 0 && previous_ratio_q8 <= 256, "previous_ratio_q8", "0 .. 256", previous_ratio_q8);
  check(previous_max_distance >= 0 && previous_max_distance <= 256, "previous_max_distance", "0 .. 256", previous_max_distance);
  check(min_disparity_px > 0, "min_disparity_px", "> 0", min_disparity_px);
  check(max_disparity_px >= min_disparity_px, "max_disparity_px", ">= min_disparity_px", max_disparity_px);
  check(min_height_points >= 1, "min_height_points", ">= 1", min_height_points);
  check(keyframe_max_hamming_distance >= 0 && keyframe_max_hamming_distance <= 256, "keyframe_max_hamming_distance", "0 .. 256",
        keyframe_max_hamming_distance);
  check(keyframe_ratio_test > 0 && keyframe_ratio_test <= 1, "keyframe_ratio_test", "(0, 1]", keyframe_ratio_test);
  check(lost_frame_translation_sigma_m >= 0, "lost_frame_translation_sigma_m", ">= 0", lost_frame_translation_sigma_m);
  check(lost_frame_yaw_sigma_rad >= 0, "lost_frame_yaw_sigma_rad", ">= 0", lost_frame_yaw_sigma_rad);
  check(confidence_scale_m > 0, "confidence_scale_m", "> 0", confidence_scale_m);
  check(low_confidence_sigma_m > 0, "low_confidence_sigma_m", "> 0", low_confidence_sigma_m);
}

std::string KeyframeLocalizerParameters::summary() const {
  char text[512];
  std::snprintf(text, sizeof text,
                "corrections %s, height %s, harris %d, cell %d px x %d, disparities %d, keyframe hamming <= %d ratio %.2f, "
                "new keyframe %.1f m, first at %.2f m, gate %.2f, keyframe sigma %.3f m",
                keyframe_corrections ? "on" : "off", height_updates ? "on" : "off", harris_threshold, cell_size_px, per_cell_k,
                num_disparities, keyframe_max_hamming_distance, keyframe_ratio_test, keyframe_policy.new_keyframe_distance_m,
                keyframe_policy.first_keyframe_height_m, filter.gate_chi_square, filter.keyframe_position_sigma_m);
  return text;
}

GraphSpec KeyframeLocalizer::graph_spec(const KeyframeLocalizerParameters& p) {
  p.validate();
  GraphSpec spec;
  spec.name = "localization-features";
  spec.description = "graphs/localization-features.json's nodes with the localizer's parameters (arm/localization/localizer.h)";
  spec.inputs = {{"left", {ElementType::u8, 0}}, {"right", {ElementType::u8, 0}}};
  spec.nodes.push_back({.name = "harris_left",
                        .kernel = "harris_response",
                        .inputs = {{"image", {"left", false}}},
                        .outputs = {{"response", "left_response"}},
                        .params = {{"window_size", 3}, {"k_numerator", 3}, {"k_shift", 6}}});
  spec.nodes.push_back({.name = "nms_left",
                        .kernel = "harris_nms",
                        .inputs = {{"response", {"left_response", false}}},
                        .outputs = {{"corners", "left_corners"}},
                        .params = {{"radius", 1}, {"threshold", p.harris_threshold}}});
  spec.nodes.push_back({.name = "select_left",
                        .task = "select_keypoints",
                        .inputs = {{"corners", {"left_corners", false}}, {"response", {"left_response", false}}},
                        .outputs = {{"keypoints", "left_keypoints"}},
                        .params = {{"cell_size_px", p.cell_size_px},
                                   {"per_cell_k", p.per_cell_k},
                                   {"max_keypoints", p.max_keypoints},
                                   {"border_px", 16}}});
  spec.nodes.push_back({.name = "smooth_left",
                        .kernel = "gaussian5x5",
                        .inputs = {{"input", {"left", false}}},
                        .outputs = {{"output", "left_smoothed"}}});
  spec.nodes.push_back({.name = "brief_left",
                        .kernel = "brief256",
                        .inputs = {{"image", {"left_smoothed", false}}, {"keypoints", {"left_keypoints", false}}},
                        .outputs = {{"descriptors", "left_descriptors"}},
                        .params = {{"yaw_sector", 0}}});
  for (const std::string view : {"left", "right"}) {
    spec.nodes.push_back({.name = "census_" + view,
                          .kernel = "census5x5",
                          .inputs = {{"input", {view, false}}},
                          .outputs = {{"output", view + "_census"}}});
  }
  spec.nodes.push_back({.name = "sparse_disparity",
                        .kernel = "sparse_disparity",
                        .inputs = {{"left", {"left_census", false}}, {"right", {"right_census", false}}, {"keypoints", {"left_keypoints", false}}},
                        .outputs = {{"disparity", "left_keypoint_disparity"}},
                        .params = {{"min_disparity", 0},
                                   {"num_disparities", p.num_disparities},
                                   {"window_radius", 1},
                                   {"uniqueness_percent", p.uniqueness_percent}}});
  spec.nodes.push_back({.name = "match_previous",
                        .kernel = "hamming_match",
                        .inputs = {{"query_descriptors", {"left_descriptors", false}},
                                   {"query_keypoints", {"left_keypoints", false}},
                                   {"train_descriptors", {"left_descriptors", true}},
                                   {"train_keypoints", {"left_keypoints", true}}},
                        .outputs = {{"matches", "left_matches_previous"}},
                        .params = {{"ratio_q8", p.previous_ratio_q8}, {"max_distance", p.previous_max_distance}}});
  spec.outputs = {"left_keypoints", "left_descriptors", "left_smoothed", "left_keypoint_disparity", "left_matches_previous"};
  return spec;
}

Eigen::Isometry3d KeyframeLocalizer::body_from_camera() {
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  return mount;
}

namespace {

StereoOdometryParameters odometry_parameters(const KeyframeLocalizerParameters& p) {
  p.validate();
  StereoOdometryParameters odometry = p.odometry;
  odometry.focal_px = p.focal_px;
  odometry.principal_point_x_px = p.principal_point_x_px;
  odometry.principal_point_y_px = p.principal_point_y_px;
  odometry.baseline_m = p.baseline_m;
  return odometry;
}

}  // namespace

KeyframeLocalizer::KeyframeLocalizer(int width, int height, const KeyframeLocalizerParameters& parameters, int worker_threads)
    : parameters_(parameters),
      width_(width),
      height_(height),
      odometry_(width, height, odometry_parameters(parameters), worker_threads),
      filter_(parameters.filter, Eigen::Vector3d(0, 0, parameters.start_height_m), parameters.start_yaw_rad),
      database_(parameters.keyframe_policy) {
  graph_ = make_verified_graph(graph_spec(parameters_), width, height, MemoryBudget{});
  runner_ = std::make_unique<FrameRunner>(*graph_, worker_threads);
}

KeyframeLocalizer::~KeyframeLocalizer() = default;

struct KeyframeLocalizer::FrameFeatures {
  std::vector<CandidateFeature> candidates;  // every listed keypoint, in list order
  std::vector<KeyframeFeature> validated;    // the 3D-valid ones
  std::vector<int> validated_row;            // their keypoint rows
  int matches_with_previous = 0;
};

KeyframeLocalizer::FrameFeatures KeyframeLocalizer::extract() const {
  const Plane& keypoints = runner_->buffer("left_keypoints");
  const Plane& descriptors = runner_->buffer("left_descriptors");
  const Plane& disparity = runner_->buffer("left_keypoint_disparity");
  const Plane& matches = runner_->buffer("left_matches_previous");
  FrameFeatures features;
  for (int row = 0; row < keypoints.height(); ++row) {
    const int32_t* word = keypoints.row<const int32_t>(row);
    if (word[kKeypointValid] == 0) break;  // used rows come first
    CandidateFeature candidate;
    candidate.pixel_px = Eigen::Vector2f(static_cast<float>(word[kKeypointXPx]), static_cast<float>(word[kKeypointYPx]));
    candidate.disparity_q4 = disparity.at<int16_t>(row, 0);
    const uint32_t* descriptor = descriptors.row<const uint32_t>(row);
    std::copy(descriptor, descriptor + kernels::kBriefWords, candidate.descriptor.begin());
    features.candidates.push_back(candidate);
    features.matches_with_previous += matches.at<int32_t>(kernels::kMatchAccepted, row) != 0 ? 1 : 0;
  }
  const StereoGeometry geometry{parameters_.focal_px, parameters_.baseline_m, parameters_.principal_point_x_px,
                                parameters_.principal_point_y_px};
  FeatureValidationParameters validation;
  validation.min_disparity_px = parameters_.min_disparity_px;
  validation.max_disparity_px = parameters_.max_disparity_px;
  validation.invalid_disparity_q4 = -16;  // sparse_disparity with min_disparity 0: (0 - 1) * 16
  features.validated = validate_features_3d(features.candidates, geometry, validation);
  // validate_features_3d keeps input order: recover each survivor's row by its pixel and descriptor.
  size_t next = 0;
  for (size_t row = 0; row < features.candidates.size() && next < features.validated.size(); ++row) {
    if (features.candidates[row].pixel_px == features.validated[next].pixel_px &&
        features.candidates[row].descriptor == features.validated[next].descriptor) {
      features.validated_row.push_back(static_cast<int>(row));
      ++next;
    }
  }
  return features;
}

// The same brief256 kernel as the graph's node, run once more with the sector's pattern on the graph's
// smoothed view and keypoint list: a verified graph's parameters are fixed, the sector changes from
// frame to frame (on the chip: the same node with the sector's pattern table loaded).
std::vector<BriefDescriptor> KeyframeLocalizer::steered_descriptors(int sector) const {
  const Plane& smoothed = runner_->buffer("left_smoothed");
  const Plane& keypoints = runner_->buffer("left_keypoints");
  const KernelDescriptor* kernel = KernelRegistry::instance().find("brief256");
  if (kernel == nullptr) throw std::logic_error("kernel 'brief256' is not registered");
  const PreparedKernel prepared =
      kernel->prepare({{"yaw_sector", sector}}, {{smoothed.width(), smoothed.height()}, {keypoints.width(), keypoints.height()}});
  Plane output(kernels::kBriefWords, keypoints.height(), {ElementType::u32, 0});
  const VectorNodeBinding binding{kernel, prepared.params.get(), BorderMode::replicate, 0, {smoothed.view(), keypoints.view()},
                                  {output.view()}};
  run_vector_node(binding, kernels::kBriefWords, 16, KernelBackend::native, simd::active_isa());
  std::vector<BriefDescriptor> descriptors(static_cast<size_t>(keypoints.height()));
  for (int row = 0; row < keypoints.height(); ++row) {
    const uint32_t* word = output.row<const uint32_t>(row);
    std::copy(word, word + kernels::kBriefWords, descriptors[static_cast<size_t>(row)].begin());
  }
  return descriptors;
}

Eigen::Isometry3d KeyframeLocalizer::world_from_body() const {
  return body_pose(filter_.position_m(), filter_.yaw_rad());
}

void KeyframeLocalizer::correct(const FrameFeatures& features, LocalizerFrame& result) {
  const std::optional<size_t> nearest = database_.nearest(filter_.position_m());
  if (!nearest) {
    result.correction_note = "no keyframe stored yet";
    return;
  }
  const Keyframe& keyframe = database_.keyframes()[*nearest];
  result.keyframe_id = static_cast<int>(keyframe.id);
  if (features.validated.size() < 3 || keyframe.features.size() < 3) {
    result.correction_note = "too few validated features to match (" + std::to_string(features.validated.size()) + ")";
    return;
  }
  const double keyframe_yaw_rad = yaw_of((keyframe.world_from_camera * body_from_camera().inverse()).linear());
  result.yaw_sector = sector_of(filter_.yaw_rad() - keyframe_yaw_rad);

  std::vector<OdometryFeature> queries;
  queries.reserve(features.validated.size());
  if (result.yaw_sector == 0) {
    for (const KeyframeFeature& feature : features.validated) queries.push_back(odometry_feature(feature.pixel_px, feature.descriptor));
  } else {
    const std::vector<BriefDescriptor> steered = steered_descriptors(result.yaw_sector);
    for (size_t i = 0; i < features.validated.size(); ++i) {
      queries.push_back(odometry_feature(features.validated[i].pixel_px, steered[static_cast<size_t>(features.validated_row[i])]));
    }
  }
  std::vector<OdometryFeature> candidates;
  candidates.reserve(keyframe.features.size());
  for (const KeyframeFeature& feature : keyframe.features) candidates.push_back(odometry_feature(feature.pixel_px, feature.descriptor));
  // The whole image: the filter may have drifted by more than any prediction window.
  MatchWindow window;
  window.kind = MatchWindow::Kind::radius;
  window.radius_px = 4.0 * std::max(width_, height_);
  std::vector<Eigen::Vector2d> centres;
  centres.reserve(queries.size());
  for (const OdometryFeature& query : queries) centres.emplace_back(query.x_px, query.y_px);
  const std::vector<int> best =
      match_features(queries, centres, candidates, window, parameters_.keyframe_max_hamming_distance, parameters_.keyframe_ratio_test);
  std::vector<FeatureMatch> matches;
  for (size_t q = 0; q < best.size(); ++q) {
    if (best[q] >= 0) matches.push_back({static_cast<int>(q), best[q]});
  }
  result.keyframe_matches = static_cast<int>(matches.size());
  if (matches.size() < 3) {
    result.correction_note = "only " + std::to_string(matches.size()) + " descriptor matches with keyframe " + std::to_string(keyframe.id);
    return;
  }
  const PoseCorrection correction = correct_pose(features.validated, keyframe, matches, parameters_.correction);
  result.correction_inliers = correction.rigid_inliers;
  result.correction_confidence = correction.confidence;
  if (!correction.ok) {
    result.correction_note = correction.failure;
    return;
  }
  const Eigen::Isometry3d measured_body = correction.world_from_current * body_from_camera().inverse();
  const KeyframePoseMeasurement measurement{measured_body.translation(), yaw_of(measured_body.linear()), correction.confidence};
  result.correction_accepted = filter_.update_keyframe(measurement);
  if (!result.correction_accepted) {
    char text[160];
    std::snprintf(text, sizeof text, "refused by the filter (confidence %.2f, %d inliers, %.2f m from the estimate)", correction.confidence,
                  correction.rigid_inliers, (measured_body.translation() - filter_.position_m()).norm());
    result.correction_note = text;
  }
}

LocalizerFrame KeyframeLocalizer::process(const Plane& left, const Plane& right) {
  for (const auto& [name, plane] : {std::pair{"left", &left}, std::pair{"right", &right}}) {
    if (plane->width() != width_ || plane->height() != height_ || plane->format().type != ElementType::u8) {
      throw std::invalid_argument(std::string("localizer ") + name + " view: expected u8 " + std::to_string(width_) + "x" +
                                  std::to_string(height_) + ", got " + std::to_string(plane->width()) + "x" +
                                  std::to_string(plane->height()));
    }
  }
  LocalizerFrame result;
  result.frame_index = frame_index_;

  // 1. Odometry -> prediction (the first frame is the reference: nothing to predict).
  const StereoOdometryFrame odometry = odometry_.process(left, right);
  result.odometry_valid = odometry.statistics.valid;
  result.odometry_inliers = odometry.statistics.inliers;
  if (frame_index_ > 0) {
    OdometryIncrement increment;
    if (odometry.statistics.valid) {
      const Eigen::Isometry3d body_increment = body_from_camera() * odometry.increment * body_from_camera().inverse();
      increment.translation_m = body_increment.translation();
      increment.yaw_rad = yaw_of(body_increment.linear());
    } else {
      increment.extra_translation_sigma_m = parameters_.lost_frame_translation_sigma_m;
      increment.extra_yaw_sigma_rad = parameters_.lost_frame_yaw_sigma_rad;
    }
    filter_.predict(increment);
  }

  // 2. Features of the left view with their disparities.
  runner_->process({{"left", &left}, {"right", &right}});
  const FrameFeatures features = extract();
  result.keypoints = static_cast<int>(features.candidates.size());
  result.validated_features = static_cast<int>(features.validated.size());
  result.matches_with_previous = frame_index_ > 0 ? features.matches_with_previous : -1;

  // 3. Visual height: the median depth of the validated ground points.
  if (static_cast<int>(features.validated.size()) >= parameters_.min_height_points) {
    std::vector<float> depths;
    depths.reserve(features.validated.size());
    for (const KeyframeFeature& feature : features.validated) depths.push_back(feature.point_m.z());
    std::nth_element(depths.begin(), depths.begin() + static_cast<ptrdiff_t>(depths.size() / 2), depths.end());
    result.visual_height_m = depths[depths.size() / 2];
    if (parameters_.height_updates) result.height_accepted = filter_.update_height(result.visual_height_m);
  }

  // 4. Keyframe correction.
  if (parameters_.keyframe_corrections) {
    correct(features, result);
  } else {
    result.correction_note = "corrections off";
  }

  // 5. Keyframe decision, with the corrected filter.
  if (parameters_.keyframe_corrections) {
    FrameSummary summary;
    summary.position_m = filter_.position_m();
    summary.height_above_ground_m = result.visual_height_m > 0 ? result.visual_height_m : filter_.position_m().z();
    if (frame_index_ > 0) summary.matches_with_previous = features.matches_with_previous;
    summary.validated_features = result.validated_features;
    result.keyframe_decision = database_.decide(summary);
    if (result.keyframe_decision != KeyframeDecision::none && result.keyframe_decision != KeyframeDecision::too_few_features) {
      Keyframe keyframe;
      keyframe.world_from_camera = world_from_body() * body_from_camera();
      keyframe.yaw_sector = sector_of(filter_.yaw_rad());
      keyframe.features = features.validated;
      result.stored_keyframe_id = static_cast<int>(database_.add(std::move(keyframe)));
    }
  }

  result.world_from_camera = world_from_body() * body_from_camera();
  if (frame_index_ == 0) first_world_from_camera_ = result.world_from_camera;
  result.pose = first_world_from_camera_.inverse() * result.world_from_camera;
  result.state = filter_.state();
  result.covariance = filter_.covariance();
  result.position_sigma_m = filter_.position_sigma_m();
  result.confidence = std::exp(-result.position_sigma_m / parameters_.confidence_scale_m);
  result.low_confidence = result.position_sigma_m > parameters_.low_confidence_sigma_m;
  ++frame_index_;
  return result;
}

}  // namespace lpstereo::arm::localization
