// Colour flood-fill clustering (arm/obstacles3d/voxel_clustering.h): split by colour, merge by
// colour, aggregation of a small cluster into a big neighbour, noise removal, the ground, and the
// Obstacle3d fields.
#include "arm/obstacles3d/voxel_clustering.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <string>
#include <cmath>
#include <stdexcept>

#include "tests/arm/obstacles3d/voxel_scene.h"

namespace lpstereo::arm::obstacles3d {
namespace {

using test::add_box;
using test::make_point;

constexpr std::array<uint8_t, 3> kRed{210, 40, 40};
constexpr std::array<uint8_t, 3> kBlue{40, 60, 200};
constexpr std::array<uint8_t, 3> kDarkRed{190, 45, 35};

ClusteringResult cluster_points(const std::vector<ObstaclePoint>& points, const VoxelClusteringParameters& parameters = {}) {
  VoxelMap map;  // 0.25 m voxels
  map.update(points, EgoMotion{});
  return cluster_voxels(map, parameters);
}

TEST(VoxelClustering, ColourDistanceIsEquation317WithACircularSaturationWeightedHue) {
  const Eigen::Vector3d rgb(0.5, 0.5, 0.5);
  // Hues 0.95 and 0.05 are 0.1 turn apart on the circle; saturations 0.8 and 0.6: hue term 0.1 * 0.6.
  const double distance = colour_distance(rgb, Hsl{0.95, 0.8, 0.4}, rgb, Hsl{0.05, 0.6, 0.5});
  EXPECT_NEAR(distance, 0.1 * 0.6 + 0.2 + 0.1, 1e-12);
  // Greys: hue does not count.
  EXPECT_NEAR(colour_distance(rgb, Hsl{0.0, 0.0, 0.5}, rgb, Hsl{0.5, 0.0, 0.5}), 0.0, 1e-12);
  // RGB part: the L2 norm.
  EXPECT_NEAR(colour_distance(Eigen::Vector3d(0, 0, 0), Hsl{}, Eigen::Vector3d(0.3, 0.4, 0), Hsl{}), 0.5, 1e-12);
}

// Two 3x3x3-voxel blobs touching face to face along the vehicle y axis.
std::vector<ObstaclePoint> touching_blobs(std::array<uint8_t, 3> first, std::array<uint8_t, 3> second) {
  std::vector<ObstaclePoint> points;
  add_box(points, {10.0, -0.75, 0.5}, {10.75, 0.0, 1.25}, first);
  add_box(points, {10.0, 0.0, 0.5}, {10.75, 0.75, 1.25}, second);
  return points;
}

TEST(VoxelClustering, TouchingBlobsOfDifferentColoursSplit) {
  const ClusteringResult result = cluster_points(touching_blobs(kRed, kBlue));
  EXPECT_EQ(result.candidate_voxels, 54);
  ASSERT_EQ(result.clusters.size(), 2u);
  for (const VoxelCluster& cluster : result.clusters) {
    EXPECT_EQ(cluster.voxels.size(), 27u);
    EXPECT_NEAR(cluster.density, 1.0, 1e-12);
    // One colour per cluster: every voxel on the same side of y = 0.
    const bool negative = cluster.voxels.front().y < 0;
    for (const VoxelKey& key : cluster.voxels) EXPECT_EQ(key.y < 0, negative);
  }
}

TEST(VoxelClustering, TouchingBlobsOfTheSameColourMerge) {
  const ClusteringResult result = cluster_points(touching_blobs(kRed, kDarkRed));
  ASSERT_EQ(result.clusters.size(), 1u);
  EXPECT_EQ(result.clusters[0].voxels.size(), 54u);
}

TEST(VoxelClustering, ASmallClusterAggregatesIntoItsBigNeighbourAndAnIsolatedOneIsRemoved) {
  std::vector<ObstaclePoint> points;
  add_box(points, {10.0, -0.75, 0.5}, {10.75, 0.0, 1.25}, kRed);   // 27 voxels
  add_box(points, {10.0, 0.0, 0.5}, {10.5, 0.25, 0.75}, kBlue);    // 2 voxels touching it, another colour
  add_box(points, {14.0, 2.0, 0.5}, {14.5, 2.25, 0.75}, kBlue);    // 2 voxels alone
  VoxelClusteringParameters parameters;
  parameters.small_cluster_voxels = 4;
  parameters.min_cluster_voxels = 3;
  const ClusteringResult result = cluster_points(points, parameters);
  EXPECT_EQ(result.flood_fill_clusters, 3);
  EXPECT_EQ(result.aggregated_clusters, 1);
  EXPECT_EQ(result.removed_small, 1);
  ASSERT_EQ(result.clusters.size(), 1u);
  EXPECT_EQ(result.clusters[0].voxels.size(), 29u);
  // Without aggregation (nothing is small) the blue pair stays on its own and survives.
  parameters.small_cluster_voxels = 1;
  parameters.min_cluster_voxels = 2;
  const ClusteringResult separate = cluster_points(points, parameters);
  EXPECT_EQ(separate.aggregated_clusters, 0);
  EXPECT_EQ(separate.clusters.size(), 3u);
}

TEST(VoxelClustering, SparseClustersAreRemoved) {
  // A diagonal line of 6 voxels: connected through corners (Chebyshev ball), density 6 / 6^3.
  std::vector<ObstaclePoint> points;
  for (int i = 0; i < 6; ++i) add_box(points, {10.0 + 0.25 * i, 0.25 * i, 0.5 + 0.25 * i}, {10.25 + 0.25 * i, 0.25 + 0.25 * i, 0.75 + 0.25 * i}, kRed);
  VoxelClusteringParameters parameters;
  parameters.min_density = 0.05;
  ClusteringResult result = cluster_points(points, parameters);
  EXPECT_EQ(result.flood_fill_clusters, 1);
  EXPECT_EQ(result.removed_sparse, 1);
  EXPECT_TRUE(result.clusters.empty());
  parameters.min_density = 6.0 / 216.0 - 1e-9;
  result = cluster_points(points, parameters);
  ASSERT_EQ(result.clusters.size(), 1u);
  EXPECT_NEAR(result.clusters[0].density, 6.0 / 216.0, 1e-12);
}

TEST(VoxelClustering, VoxelsOnTheGroundAreNotCandidates) {
  std::vector<ObstaclePoint> points;
  add_box(points, {10.0, 0.0, 0.0}, {11.0, 1.0, 0.0625}, kRed);  // a flat layer 3 cm above the ground
  add_box(points, {12.0, 0.0, 0.5}, {12.75, 0.75, 1.25}, kBlue);
  const ClusteringResult result = cluster_points(points);
  EXPECT_EQ(result.candidate_voxels, 27);
  ASSERT_EQ(result.clusters.size(), 1u);
}

TEST(VoxelClustering, ObstacleFieldsComeFromTheFramesPoints) {
  std::vector<ObstaclePoint> points;
  add_box(points, {10.0, -0.5, 0.25}, {10.5, 0.5, 1.5}, kBlue);
  const ClusteringResult result = cluster_points(points);
  ASSERT_EQ(result.clusters.size(), 1u);
  const Obstacle3d& obstacle = result.clusters[0].obstacle;
  // Expected from the points themselves.
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::max()), high = -low;
  int u0 = 10000, v0 = 10000, u1 = -1, v1 = -1;
  float min_height = 1e9f, max_height = -1e9f;
  Eigen::Vector3d world_sum = Eigen::Vector3d::Zero(), camera_sum = Eigen::Vector3d::Zero();
  for (const ObstaclePoint& point : points) {
    camera_sum += point.camera_m.cast<double>();
    low = low.cwiseMin(point.camera_m), high = high.cwiseMax(point.camera_m);
    u0 = std::min<int>(u0, point.u_px), v0 = std::min<int>(v0, point.v_px), u1 = std::max<int>(u1, point.u_px), v1 = std::max<int>(v1, point.v_px);
    min_height = std::min(min_height, point.height_above_ground_m), max_height = std::max(max_height, point.height_above_ground_m);
    world_sum += point.vehicle_m.cast<double>();
  }
  EXPECT_TRUE(obstacle.position_m.isApprox(camera_sum / double(points.size()), 1e-6));  // the points' mean
  EXPECT_TRUE(obstacle.size_m.isApprox((high - low).cast<double>(), 1e-6));
  EXPECT_TRUE(result.clusters[0].camera_min_m.isApprox(low.cast<double>(), 1e-6));
  EXPECT_TRUE(result.clusters[0].camera_max_m.isApprox(high.cast<double>(), 1e-6));
  EXPECT_EQ(obstacle.bbox_px, (std::array<int, 4>{u0, v0, u1, v1}));
  EXPECT_FLOAT_EQ(static_cast<float>(obstacle.min_height_m), min_height);
  EXPECT_FLOAT_EQ(static_cast<float>(obstacle.max_height_m), max_height);
  EXPECT_TRUE(result.clusters[0].centroid_world_m.isApprox(world_sum / double(points.size()), 1e-9));
  EXPECT_EQ(obstacle.track_id, -1);
  EXPECT_FALSE(obstacle.moving);
  // A level camera 1.5 m up: the box's camera-frame centre is (0, 1.5 - 0.875, 10.25) (x = -y, y = 1.5 - z).
  EXPECT_NEAR(obstacle.position_m.x(), 0.0, 1e-6);
  EXPECT_NEAR(obstacle.position_m.z(), 10.25, 1e-6);
}

TEST(VoxelClustering, ClustersCutByTheMapBoundsOrTheImageBorderAreTruncated) {
  std::vector<ObstaclePoint> points;
  add_box(points, {39.5, 0.0, 0.5}, {40.0, 0.5, 1.0}, kRed);     // against the 40 m far bound
  add_box(points, {15.0, 0.0, 0.5}, {15.5, 0.5, 1.0}, kBlue);    // in the middle of the map and the image
  add_box(points, {12.0, -9.0, 0.5}, {12.5, -8.5, 1.0}, kRed);   // 9 m right at 12 m: u = 320 + 500 * 8.75 / 12 > 639, clamped to 639
  VoxelClusteringParameters parameters;
  ClusteringResult result = cluster_points(points, parameters);
  ASSERT_EQ(result.clusters.size(), 3u);
  auto find = [&](double vehicle_x) -> const VoxelCluster& {
    for (const VoxelCluster& cluster : result.clusters) {
      if (std::abs(cluster.centroid_world_m.x() - vehicle_x) < 0.5) return cluster;
    }
    throw std::runtime_error("no cluster near x = " + std::to_string(vehicle_x));
  };
  EXPECT_TRUE(find(39.75).truncated);
  EXPECT_FALSE(find(15.25).truncated);
  EXPECT_FALSE(find(12.25).truncated);  // the image size is not given: no border test
  parameters.image_width_px = 640;
  parameters.image_height_px = 480;
  result = cluster_points(points, parameters);
  ASSERT_EQ(result.clusters.size(), 3u);
  EXPECT_TRUE(find(12.25).truncated);
  EXPECT_FALSE(find(15.25).truncated);
}

// The candidates' far edge (voxel_clustering.h): with the candidates ending at 34 m and a 3.5 m margin,
// a cluster with a voxel centre beyond 30.5 m forward in the current vehicle frame is cut by that edge.
// The camera has moved 5 m forward since the map's first frame, so world and current coordinates
// differ by 5 m: a test in world coordinates would also flag the 27 m box (world 32.1-32.4 m).
TEST(VoxelClustering, ClustersWithinTheMarginOfTheCandidatesFarEdgeAreCutByIt) {
  std::vector<ObstaclePoint> points;
  add_box(points, {31.5, 0.0, 0.5}, {32.0, 0.5, 1.0}, kRed);   // voxel centres 31.6-31.9 m: in the band
  add_box(points, {27.0, 3.0, 0.5}, {27.5, 3.5, 1.0}, kBlue);  // 27.1-27.4 m (world 32.1-32.4 m): before it
  add_box(points, {24.0, -3.0, 0.5}, {24.5, -2.5, 1.0}, kRed); // 24.1-24.4 m (world 29.1-29.4 m): before any
  VoxelMap map;  // 0.25 m voxels, bounds to 40 m: no map-bound truncation for any box
  map.update({}, EgoMotion{});
  EgoMotion moved{true, Eigen::Isometry3d(Eigen::Translation3d(5.0, 0.0, 0.0))};  // the camera drove 5 m forward
  map.update(points, moved);
  auto find = [](const ClusteringResult& result, double vehicle_x) -> const VoxelCluster& {
    for (const VoxelCluster& cluster : result.clusters) {
      if (std::abs(cluster.centroid_world_m.x() - 5.0 - vehicle_x) < 0.5) return cluster;
    }
    throw std::runtime_error("no cluster near current x = " + std::to_string(vehicle_x));
  };
  VoxelClusteringParameters parameters;  // candidate_forward_max_m 0: not tested
  ClusteringResult result = cluster_voxels(map, parameters);
  ASSERT_EQ(result.clusters.size(), 3u);
  for (const VoxelCluster& cluster : result.clusters) {
    EXPECT_FALSE(cluster.truncated);
    EXPECT_FALSE(cluster.at_candidate_far_edge);
  }
  parameters.candidate_forward_max_m = 34.0;
  parameters.candidate_far_edge_margin_m = 3.5;  // the band from 30.5 m
  result = cluster_voxels(map, parameters);
  ASSERT_EQ(result.clusters.size(), 3u);
  EXPECT_TRUE(find(result, 31.75).at_candidate_far_edge);
  EXPECT_TRUE(find(result, 31.75).truncated);
  EXPECT_FALSE(find(result, 27.25).at_candidate_far_edge);
  EXPECT_FALSE(find(result, 27.25).truncated);
  EXPECT_FALSE(find(result, 24.25).at_candidate_far_edge);
  parameters.candidate_far_edge_margin_m = 7.5;  // the band from 26.5 m: the 27 m box too, not the 24 m one
  result = cluster_voxels(map, parameters);
  ASSERT_EQ(result.clusters.size(), 3u);
  EXPECT_TRUE(find(result, 31.75).at_candidate_far_edge);
  EXPECT_TRUE(find(result, 27.25).at_candidate_far_edge);
  EXPECT_FALSE(find(result, 24.25).at_candidate_far_edge);
  // The test's work: 12 per candidate voxel on top of the untested count.
  parameters.candidate_forward_max_m = 0;
  const uint64_t untested_ops = cluster_voxels(map, parameters).work.scalar_ops;
  parameters.candidate_forward_max_m = 34.0;
  EXPECT_EQ(cluster_voxels(map, parameters).work.scalar_ops, untested_ops + 12u * static_cast<uint64_t>(result.candidate_voxels));
}

TEST(VoxelClustering, OnTheLeftAClusterIsCutWithinItsDisparityOfTheBorder) {
  // make_point's rig: f = 500 px, B = 0.3 m, so a point at depth Z has disparity 150 / Z px. A box 5.0-5.5 m
  // ahead and 2.2-3.0 m left reaches u = 319.5 - 500 * 3 / 5 = 19.5 px with disparity up to 150 / 5 = 30 px: its
  // left part is not in the right image (u - d < 0), so it is cut although 19 px from the border. The
  // same box 1.0-1.8 m left starts at u = 319.5 - 500 * 1.8 / 5 = 139.5 px: whole.
  std::vector<ObstaclePoint> points;
  add_box(points, {5.0, 2.2, 0.5}, {5.5, 3.0, 1.0}, kRed);
  add_box(points, {5.0, 1.0, 0.5}, {5.5, 1.8, 1.0}, kBlue);
  VoxelClusteringParameters parameters;
  parameters.image_width_px = 640;
  parameters.image_height_px = 480;
  const ClusteringResult result = cluster_points(points, parameters);
  ASSERT_EQ(result.clusters.size(), 2u);
  for (const VoxelCluster& cluster : result.clusters) {
    const bool left = cluster.centroid_world_m.y() > 2.0;
    EXPECT_EQ(cluster.truncated, left) << "cluster at y = " << cluster.centroid_world_m.y() << ", x0 = " << cluster.obstacle.bbox_px[0];
    if (left) {
      EXPECT_GT(cluster.obstacle.bbox_px[0], parameters.border_margin_px);  // the plain border test alone would keep it
      EXPECT_LE(cluster.obstacle.bbox_px[0], parameters.border_margin_px + 30);
    }
  }
}

// A hand-made cluster for the fragment merge: its camera box [low, high], pixel box, voxel and point counts.
VoxelCluster camera_box_cluster(const Eigen::Vector3d& low_m, const Eigen::Vector3d& high_m, std::array<int, 4> bbox_px, int voxels,
                                int64_t points, const Eigen::Vector3d& centroid_world_m) {
  VoxelCluster cluster;
  for (int i = 0; i < voxels; ++i) cluster.voxels.push_back(VoxelKey{i, 0, 0});
  cluster.min_key = VoxelKey{0, 0, 0};
  cluster.max_key = VoxelKey{voxels - 1, 0, 0};
  cluster.size_world_m = Eigen::Vector3d(voxels * 0.25, 0.25, 0.25);
  cluster.frame_points = points;
  cluster.centroid_world_m = centroid_world_m;
  cluster.rgb_mean = Eigen::Vector3d(0.5, 0.5, 0.5);
  cluster.hsl_mean = Hsl{0, 0, 0.5};
  cluster.density = 1.0;
  cluster.obstacle.position_m = (low_m + high_m) / 2;
  cluster.camera_min_m = low_m;
  cluster.camera_max_m = high_m;
  cluster.obstacle.size_m = high_m - low_m;
  cluster.obstacle.bbox_px = bbox_px;
  cluster.obstacle.min_height_m = 0.2;
  cluster.obstacle.max_height_m = 1.4;
  return cluster;
}

TEST(VoxelClustering, StereoFragmentsMergeIntoTheirObjectAndSeparateObjectsDoNot) {
  StereoErrorModel stereo;
  stereo.focal_px = 500;
  stereo.baseline_m = 0.3;  // sigma_Z(25 m) = 625 * 0.25 / 150 = 1.04 m
  // A car's rear at 25 m (40 voxels), a sliver 1.5 m behind it at its left edge (4 voxels, 1/10 of the car's): the gap
  // 1.5 m <= 0.5 m + 2 x 1.04 m, the boxes touch; a pedestrian 8 m behind the car (gap 8 m > 2.6 m) overlapping it in the image.
  const VoxelCluster car = camera_box_cluster({-0.9, -0.2, 25.0}, {0.9, 1.2, 25.5}, {302, 240, 338, 268}, 40, 400, {25.25, 0, 0.5});
  const VoxelCluster sliver = camera_box_cluster({-1.0, 0.0, 27.0}, {-0.9, 1.0, 27.5}, {300, 244, 302, 264}, 4, 20, {27.25, 0.95, 0.5});
  const VoxelCluster pedestrian = camera_box_cluster({0.5, -0.3, 33.5}, {1.0, 1.2, 34.0}, {327, 238, 335, 265}, 8, 60, {33.75, -0.75, 0.5});
  const FragmentMergeResult result = merge_stereo_fragments({car, sliver, pedestrian}, stereo, 0.25);
  ASSERT_EQ(result.clusters.size(), 2u);
  EXPECT_EQ(result.merged, 1);
  const VoxelCluster& merged = result.clusters[0];
  EXPECT_EQ(merged.voxels.size(), 44u);
  EXPECT_EQ(merged.frame_points, 420);
  // Point-weighted centroid: (400 x 25.25 + 20 x 27.25) / 420 on x.
  EXPECT_NEAR(merged.centroid_world_m.x(), (400 * 25.25 + 20 * 27.25) / 420.0, 1e-9);
  // Point-weighted position: the car's centre x 0, the sliver's -0.95. The union of the camera boxes: x -1.0..0.9,
  // z 25.0..27.5; of the pixel boxes: 300..338.
  EXPECT_NEAR(merged.obstacle.position_m.x(), 20 * -0.95 / 420.0, 1e-9);
  EXPECT_NEAR(merged.obstacle.size_m.z(), 2.5, 1e-9);
  EXPECT_NEAR(merged.camera_min_m.x(), -1.0, 1e-9);
  EXPECT_NEAR(merged.camera_max_m.z(), 27.5, 1e-9);
  EXPECT_EQ(merged.obstacle.bbox_px[0], 300);
  EXPECT_EQ(merged.obstacle.bbox_px[2], 338);
  EXPECT_EQ(result.clusters[1].frame_points, 60);  // the pedestrian stays itself
  // Without the error model the merge is off.
  EXPECT_EQ(merge_stereo_fragments({car, sliver, pedestrian}, StereoErrorModel{}, 0.25).clusters.size(), 3u);
}

TEST(VoxelClustering, StackedPartsOfOneSurfaceMergeWhateverTheirSizes) {
  StereoErrorModel stereo;
  stereo.focal_px = 500;
  stereo.baseline_m = 0.3;
  // A pedestrian split by colour into legs and torso of similar sizes at the same depth (20 m), one above the
  // other; a second pedestrian 0.4 m to the right of the first at the same depth: the pixel boxes are 10 px apart.
  const VoxelCluster torso = camera_box_cluster({-3.0, -0.3, 20.0}, {-2.5, 0.6, 20.5}, {244, 232, 257, 254}, 10, 80, {20.25, 2.75, 1.2});
  const VoxelCluster legs = camera_box_cluster({-3.0, 0.6, 20.0}, {-2.5, 1.5, 20.5}, {244, 254, 257, 277}, 9, 70, {20.25, 2.75, 0.4});
  const VoxelCluster other = camera_box_cluster({-2.1, -0.3, 20.0}, {-1.6, 1.5, 20.5}, {267, 232, 280, 277}, 19, 150, {20.25, 1.85, 0.8});
  const FragmentMergeResult result = merge_stereo_fragments({torso, legs, other}, stereo, 0.25);
  ASSERT_EQ(result.clusters.size(), 2u);
  EXPECT_EQ(result.clusters[0].frame_points, 150);  // torso + legs
  EXPECT_NEAR(result.clusters[0].obstacle.size_m.y(), 1.8, 1e-9);
  EXPECT_EQ(result.clusters[1].frame_points, 150);  // the other pedestrian
  EXPECT_NEAR(result.clusters[1].obstacle.position_m.x(), -1.85, 1e-9);
  // A pedestrian (0.5 m, 14 px wide, 8 voxels) in front of a crossing car's side (4 m wide, 40 voxels) at the same
  // depth: neither a sliver (wider than 8 px) nor a part of about the car's width (overlap 0.5 m < half of 4 m).
  const VoxelCluster car_side = camera_box_cluster({-2.0, -0.2, 15.0}, {2.0, 1.3, 15.5}, {186, 232, 453, 282}, 40, 400, {15.25, 0, 0.6});
  const VoxelCluster walker = camera_box_cluster({0.0, -0.3, 14.8}, {0.5, 1.5, 15.2}, {319, 229, 336, 289}, 8, 60, {15.0, -0.25, 0.9});
  EXPECT_EQ(merge_stereo_fragments({car_side, walker}, stereo, 0.25).clusters.size(), 2u);
  FragmentMergeParameters bad;
  bad.max_fragment_fraction = 2;
  EXPECT_THROW(validate_fragment_merge_parameters(bad), std::invalid_argument);
}

TEST(VoxelClustering, EmptyMapAndBadParameters) {
  VoxelMap map;
  map.update({}, EgoMotion{});
  const ClusteringResult result = cluster_voxels(map);
  EXPECT_TRUE(result.clusters.empty());
  EXPECT_EQ(result.candidate_voxels, 0);
  VoxelClusteringParameters parameters;
  parameters.similarity_threshold = 0;
  EXPECT_THROW(cluster_voxels(map, parameters), std::invalid_argument);
  parameters = {};
  parameters.min_density = 2;
  EXPECT_THROW(cluster_voxels(map, parameters), std::invalid_argument);
  parameters = {};
  parameters.candidate_forward_max_m = -34;
  EXPECT_THROW(cluster_voxels(map, parameters), std::invalid_argument);
  parameters = {};
  parameters.candidate_far_edge_margin_m = -1;
  EXPECT_THROW(cluster_voxels(map, parameters), std::invalid_argument);
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
