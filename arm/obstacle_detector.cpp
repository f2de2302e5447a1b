#include "arm/obstacle_detector.h"

#include <cstdio>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "arm/scheduler.h"
#include "kernels/kernel.h"

namespace lpstereo::arm {

namespace {

void check_positive(const char* name, double value) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("obstacle parameter '") + name + "': expected a number > 0, got " +
                                std::to_string(value));
  }
}

NodeSpec node(const std::string& name, const std::string& kernel, const std::string& task) {
  NodeSpec spec;
  spec.name = name;
  spec.kernel = kernel;
  spec.task = task;
  return spec;
}

std::string tracking_text(const TrackerSettings& t) {
  char text[160];
  std::snprintf(text, sizeof text, "every %.4f s, velocity after %d hits, at most %d tracks, %d missed frames", t.frame_period_s,
                t.min_hits_for_velocity, t.max_tracks, t.max_missed_frames);
  return text;
}

}  // namespace

DisparityParameters obstacle_disparity_defaults() { return DisparityParameters{}; }

std::string settings_text(const ObstacleParameters& p) {
  char text[1024];
  std::snprintf(text, sizeof text,
                "V-disparity from %d px; VLDH %d rows, %d matching within %d/16 px, road margin %d/16 px + %d per mille, "
                "%d rows above the horizon; AUD %d columns per cell, %d rows over [%.1f, %.1f) px, k %.2f, weights +%d / -%d; "
                "clusters: Y_min %.2f m to %.0f m then %.2f m, at least %d cell(s) and %d pixels; feature validation %s "
                "(Harris > %d, corners within %d px of an obstacle pixel, %d before %.0f m, %d beyond); tracking %s",
                p.v_disparity_min_px(), p.vldh.window_rows, p.vldh.min_count, p.vldh.match_tolerance_q4,
                p.vldh.road_margin_q4, p.vldh.road_margin_per_mille, p.vldh.rows_above_horizon, p.grid.columns_per_cell,
                p.grid.geometry.grid_rows, p.grid.geometry.min_disparity_px, p.grid.geometry.max_disparity_px,
                p.grid.geometry.exponent_k, p.grid.obstacle_weight, p.grid.free_weight, p.clusters.near_min_height_m,
                p.clusters.height_switch_distance_m, p.clusters.far_min_height_m, p.clusters.min_cells,
                p.clusters.min_pixels, p.feature_validation ? "on" : "off", p.features.harris_threshold,
                p.validation.mask_radius_px, p.validation.min_features, p.validation.far_distance_m,
                p.validation.far_min_features, p.tracking ? tracking_text(p.tracking_settings).c_str() : "off");
  return text;
}

ObstacleParameters ObstacleParameters::for_disparity_range(int min_disparity_px, int num_disparities) const {
  ObstacleParameters result = *this;
  result.min_disparity = min_disparity_px;
  // The V-disparity's cost grows with its bins (kernels/v_disparity.cpp: 10.6 ms at 3840x1728 for
  // 128); the road line needs the middle distances, not the rows nearer than 128 px of disparity
  // (the bottom tenth of a 4K frame), so at most kMaxVDisparityBins.
  result.v_disparity_bins = std::min(num_disparities, kMaxVDisparityBins);
  // The grid's rows end below d_max (exclusive): the largest disparity searched, with its sub-pixel
  // part, is below min + num.
  result.grid.geometry.max_disparity_px = std::max(result.grid.geometry.min_disparity_px + 1.0,
                                                   static_cast<double>(min_disparity_px + num_disparities));
  return result;
}

void add_keypoint_nodes(GraphSpec& spec, const ObstacleParameters& parameters) {
  // The feature stage of graphs/features.json on the graph input "left" (brief256 is not needed to
  // validate): the fixed-point Harris response, its 3x3 non-maximum suppression and the keypoint
  // list, with the settings of ObstacleParameters::features.
  const FeatureSettings& f = parameters.features;
  NodeSpec response = node("harris_response", "harris_response", "");
  response.inputs["image"] = {"left", false};
  response.outputs["response"] = "harris";
  response.params = {{"window_size", 3}, {"k_numerator", 3}, {"k_shift", 6}};
  spec.nodes.push_back(response);
  NodeSpec suppression = node("harris_nms", "harris_nms", "");
  suppression.inputs["response"] = {"harris", false};
  suppression.outputs["corners"] = "corners";
  suppression.params = {{"radius", 1}, {"threshold", f.harris_threshold}};
  spec.nodes.push_back(suppression);
  NodeSpec selection = node("select_keypoints", "", "select_keypoints");
  selection.inputs["corners"] = {"corners", false};
  selection.inputs["response"] = {"harris", false};
  selection.outputs["keypoints"] = "keypoints";
  selection.params = {{"cell_size_px", f.cell_size_px}, {"per_cell_k", f.per_cell_k}, {"max_keypoints", f.max_keypoints},
                      {"border_px", f.border_px}};
  spec.nodes.push_back(selection);
}

GraphSpec ObstacleDetector::graph_spec(const ObstacleParameters& p) {
  check_positive("focal_px", p.focal_px);
  check_positive("baseline_m", p.baseline_m);
  GraphSpec spec;
  spec.name = "obstacle-detector";
  spec.description =
      "obstacle detector after disparity: V-disparity, road profile (delayed edge), VLDH mask, Advanced U-disparity grid, "
      "clusters";
  spec.inputs = {{"disparity", {ElementType::s16, 4}}};

  NodeSpec v_disparity = node("v_disparity", "v_disparity", "");
  v_disparity.inputs["disparity"] = {"disparity", false};
  v_disparity.outputs["histogram"] = "vdisp";
  v_disparity.params = {{"min_disparity", p.v_disparity_min_px()}, {"num_bins", p.v_disparity_bin_count()}};
  spec.nodes.push_back(v_disparity);

  NodeSpec road = node("road_profile", "", "road_profile");
  road.inputs["v_disparity"] = {"vdisp", false};
  road.inputs["previous"] = {"road", true};
  road.outputs["profile"] = "road";
  road.params = {{"min_disparity", p.v_disparity_min_px()}, {"focal_px", p.focal_px}, {"baseline_m", p.baseline_m}};
  if (p.principal_point_y_px) road.params["principal_row_px"] = *p.principal_point_y_px;
  spec.nodes.push_back(road);

  NodeSpec vldh = node("vldh_mask", "vldh_mask", "");
  vldh.inputs["disparity"] = {"disparity", false};
  vldh.inputs["road"] = {"road", false};
  vldh.outputs["mask"] = "mask";
  vldh.params = {{"min_disparity", p.min_disparity},
                 {"window_rows", p.vldh.window_rows},
                 {"match_tolerance_q4", p.vldh.match_tolerance_q4},
                 {"min_count", p.vldh.min_count},
                 {"road_margin_q4", p.vldh.road_margin_q4},
                 {"road_margin_per_mille", p.vldh.road_margin_per_mille},
                 {"rows_above_horizon", p.vldh.rows_above_horizon}};
  spec.nodes.push_back(vldh);

  // The grid's geometry goes to the kernel and to obstacle_clusters from the one struct.
  const nlohmann::json grid_geometry = {{"columns_per_cell", p.grid.columns_per_cell},
                                        {"grid_rows", p.grid.geometry.grid_rows},
                                        {"min_disparity_px", p.grid.geometry.min_disparity_px},
                                        {"max_disparity_px", p.grid.geometry.max_disparity_px},
                                        {"exponent_k", p.grid.geometry.exponent_k},
                                        {"obstacle_weight", p.grid.obstacle_weight}};
  NodeSpec grid = node("advanced_u_disparity", "advanced_u_disparity", "");
  grid.inputs["disparity"] = {"disparity", false};
  grid.inputs["mask"] = {"mask", false};
  grid.outputs["grid"] = "grid";
  grid.params = grid_geometry;
  grid.params["free_weight"] = p.grid.free_weight;
  grid.tile_width = p.grid_tile_columns;
  grid.tile_height = p.grid.geometry.grid_rows;
  spec.nodes.push_back(grid);

  NodeSpec clusters = node("obstacle_clusters", "", "obstacle_clusters");
  clusters.inputs["grid"] = {"grid", false};
  clusters.inputs["disparity"] = {"disparity", false};
  clusters.inputs["mask"] = {"mask", false};
  clusters.outputs["obstacles"] = p.feature_validation ? "clusters" : p.tracking ? "validated" : "obstacles";
  clusters.params = grid_geometry;
  clusters.params.update({{"focal_px", p.focal_px},
                          {"baseline_m", p.baseline_m},
                          {"near_min_height_m", p.clusters.near_min_height_m},
                          {"far_min_height_m", p.clusters.far_min_height_m},
                          {"height_switch_distance_m", p.clusters.height_switch_distance_m},
                          {"min_width_m", p.clusters.min_width_m},
                          {"min_cells", p.clusters.min_cells},
                          {"min_pixels", p.clusters.min_pixels},
                          {"max_obstacles", p.clusters.max_obstacles}});
  if (p.principal_point_x_px) clusters.params["principal_point_x_px"] = *p.principal_point_x_px;
  if (p.principal_point_y_px) clusters.params["principal_point_y_px"] = *p.principal_point_y_px;
  spec.nodes.push_back(clusters);

  if (p.feature_validation) {
    spec.inputs.push_back({"left", {ElementType::u8, 0}});
    add_keypoint_nodes(spec, p);
    NodeSpec validation = node("obstacle_feature_validation", "", "obstacle_feature_validation");
    validation.inputs["obstacles"] = {"clusters", false};
    validation.inputs["keypoints"] = {"keypoints", false};
    validation.inputs["mask"] = {"mask", false};
    validation.outputs["validated"] = p.tracking ? "validated" : "obstacles";
    validation.params = {{"margin_px", p.validation.margin_px}, {"min_features", p.validation.min_features},
                         {"far_min_features", p.validation.far_min_features}, {"far_distance_m", p.validation.far_distance_m},
                         {"mask_radius_px", p.validation.mask_radius_px}};
    spec.nodes.push_back(validation);
    spec.description += ", feature validation";
  }
  spec.outputs = {"obstacles", "road", "vdisp", "mask", "grid"};
  if (p.tracking) {
    // The tracker after validation, its state on a delayed edge like road_profile's (zeros before
    // the first frame: no tracks, next id 1).
    const TrackerSettings& t = p.tracking_settings;
    NodeSpec tracker = node("obstacle_tracker", "", "obstacle_tracker");
    tracker.inputs["obstacles"] = {"validated", false};
    tracker.inputs["previous_tracks"] = {"tracks", true};
    tracker.outputs["tracked"] = "obstacles";
    tracker.outputs["tracks"] = "tracks";
    tracker.params = {{"focal_px", p.focal_px},
                      {"baseline_m", p.baseline_m},
                      {"max_tracks", t.max_tracks},
                      {"frame_period_s", t.frame_period_s},
                      {"accel_sigma_mps2", t.accel_sigma_mps2},
                      {"disparity_sigma_px", t.disparity_sigma_px},
                      {"lateral_sigma_m", t.lateral_sigma_m},
                      {"initial_speed_sigma_mps", t.initial_speed_sigma_mps},
                      {"gate_mahalanobis_sq", t.gate_mahalanobis_sq},
                      {"max_centroid_distance_m", t.max_centroid_distance_m},
                      {"pixel_weight", t.pixel_weight},
                      {"max_relative_pixel_difference", t.max_relative_pixel_difference},
                      {"max_missed_frames", t.max_missed_frames},
                      {"min_hits_for_velocity", t.min_hits_for_velocity}};
    spec.nodes.push_back(tracker);
    spec.outputs.push_back("tracks");
    spec.description += ", tracking";
  }
  return spec;
}

ObstacleDetector::ObstacleDetector(int width, int height, const ObstacleParameters& parameters, const MemoryBudget& memory,
                                   int worker_threads)
    : parameters_(parameters) {
  graph_ = make_verified_graph(graph_spec(parameters), width, height, memory);
  runner_ = std::make_unique<FrameRunner>(*graph_, worker_threads);
}

ObstacleDetector::~ObstacleDetector() = default;

ObstacleFrame ObstacleDetector::run(const Plane& disparity, const Plane& left) {
  std::map<std::string, const Plane*> inputs = {{"disparity", &disparity}};
  if (parameters_.feature_validation) inputs["left"] = &left;
  runner_->process(inputs);
  ObstacleFrame frame;
  frame.road = decode_road_profile(runner_->buffer("road"));
  frame.obstacles = decode_obstacles(runner_->buffer("obstacles"));
  frame.vdisp = &runner_->buffer("vdisp");
  frame.mask = &runner_->buffer("mask");
  frame.grid = &runner_->buffer("grid");
  return frame;
}

}  // namespace lpstereo::arm
