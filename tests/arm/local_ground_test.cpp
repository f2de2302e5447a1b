// arm::obstacles3d::LocalGround (arm/obstacles3d/local_ground.h) on hand-placed points over a flat
// surface of known height: candidates over a surface that stands 0.12 m above the ground points seen
// around them are measured from those points; a surface under the seen ground, too few inliers, and
// points under the band (a ditch) leave them alone; neither the point order, nor the points' dealing
// to shares, nor heights given by the caller instead of evaluated changes the result; the counted
// work grows with the points evaluated; bad parameters are refused by name.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm/obstacles3d/local_ground.h"
#include "arm/terrain/terrain_model.h"

namespace lpstereo {
namespace {

namespace o3 = arm::obstacles3d;
namespace terrain = arm::terrain;

// A surface of constant height over the default 34 m x 22 m area (25 x 25 control points, degree 3:
// the basis sums to 1, so S = height_m everywhere).
terrain::BsplineSurface flat_surface(const terrain::TerrainGridSpec& spec, double height_m) {
  terrain::BsplineSurface surface;
  surface.knots_forward_m = terrain::clamped_uniform_knots(25, 3, spec.forward_min_m, spec.forward_max_m);
  surface.knots_lateral_m = terrain::clamped_uniform_knots(25, 3, spec.lateral_min_m, spec.lateral_max_m);
  surface.control_z_m = Eigen::MatrixXd::Constant(25, 25, height_m);
  surface.forward_min_m = spec.forward_min_m;
  surface.forward_max_m = spec.forward_max_m;
  surface.lateral_min_m = spec.lateral_min_m;
  surface.lateral_max_m = spec.lateral_max_m;
  return surface;
}

o3::ObstaclePoint candidate_at(double x_m, double y_m, double z_m, const terrain::BsplineSurface& surface) {
  o3::ObstaclePoint point;
  point.vehicle_m = Eigen::Vector3f(static_cast<float>(x_m), static_cast<float>(y_m), static_cast<float>(z_m));
  point.height_above_ground_m = static_cast<float>(z_m - surface.height_m(x_m, y_m));
  return point;
}

// `per_cell` ground points at height z_m (+-0.02 m, alternating) in each cell of the 3 x 3 cells
// around the cell holding (x_m, y_m).
std::vector<Eigen::Vector3d> ground_around(double x_m, double y_m, double z_m, int per_cell) {
  std::vector<Eigen::Vector3d> points;
  for (int a = -1; a <= 1; ++a) {
    for (int b = -1; b <= 1; ++b) {
      for (int k = 0; k < per_cell; ++k) {
        points.emplace_back(x_m + 0.5 * a + 0.05 * k, y_m + 0.5 * b, z_m + (k % 2 == 0 ? 0.02 : -0.02));
      }
    }
  }
  return points;
}

struct Outcome {
  std::vector<o3::ObstaclePoint> candidates;
  int cells = 0;
  ArmWork work;
};

// The points are dealt to `shares` gathers in turn.
Outcome run(const terrain::BsplineSurface& surface, const std::vector<o3::ObstaclePoint>& candidates,
            const std::vector<Eigen::Vector3d>& points, const o3::LocalGroundParameters& parameters = {}, int shares = 1) {
  const terrain::TerrainGridSpec spec;
  o3::LocalGround local_ground(spec, surface, 0.2, parameters, shares);
  Outcome outcome{candidates, 0, {}};
  local_ground.mark_candidates(outcome.candidates);
  for (size_t k = 0; k < points.size(); ++k) local_ground.add_point(points[k], static_cast<int>(k % static_cast<size_t>(shares)));
  for (const o3::ObstaclePoint& candidate : candidates) local_ground.add_point(candidate.vehicle_m.cast<double>());  // above the band
  outcome.cells = local_ground.apply(outcome.candidates);
  outcome.work = local_ground.work();
  return outcome;
}

// The far sign's case: the surface 0.12 m above the road seen around a sign 2.0 m up at 28.6 m.
TEST(LocalGround, MeasuresCandidatesFromTheGroundSeenUnderALiftedSurface) {
  const terrain::TerrainGridSpec spec;
  const terrain::BsplineSurface surface = flat_surface(spec, 0.12);
  const std::vector<o3::ObstaclePoint> candidates = {candidate_at(28.6, 0.3, 2.0, surface), candidate_at(28.7, 0.4, 2.5, surface),
                                                     candidate_at(12.2, -5.2, 1.0, surface)};  // no ground seen around the last
  ASSERT_NEAR(candidates[0].height_above_ground_m, 1.88, 1e-6);
  const Outcome outcome = run(surface, candidates, ground_around(28.6, 0.3, 0.0, 4));
  EXPECT_EQ(outcome.cells, 1);  // both sign points lie in one cell
  // The median of +-0.02 m around the ground, 0.12 m under the surface: -0.10 m (the upper median of
  // an even count of -0.10 and -0.14 values).
  EXPECT_NEAR(outcome.candidates[0].height_above_ground_m, 1.88 + 0.10, 1e-5);
  EXPECT_NEAR(outcome.candidates[1].height_above_ground_m, 2.38 + 0.10, 1e-5);
  EXPECT_EQ(outcome.candidates[2].height_above_ground_m, candidates[2].height_above_ground_m);
  for (size_t k = 0; k < candidates.size(); ++k) EXPECT_EQ(outcome.candidates[k].vehicle_m, candidates[k].vehicle_m);
}

TEST(LocalGround, LeavesCandidatesAloneOverASurfaceUnderTheSeenGround) {
  const terrain::TerrainGridSpec spec;
  const terrain::BsplineSurface surface = flat_surface(spec, -0.10);
  const std::vector<o3::ObstaclePoint> candidates = {candidate_at(20.1, 1.1, 0.6, surface)};
  const Outcome outcome = run(surface, candidates, ground_around(20.1, 1.1, 0.0, 4));
  EXPECT_EQ(outcome.cells, 0);
  EXPECT_EQ(outcome.candidates[0].height_above_ground_m, candidates[0].height_above_ground_m);
}

TEST(LocalGround, NeedsMinPointsInliersInTheWindow) {
  const terrain::TerrainGridSpec spec;
  const terrain::BsplineSurface surface = flat_surface(spec, 0.12);
  const std::vector<o3::ObstaclePoint> candidates = {candidate_at(28.6, 0.3, 2.0, surface)};
  std::vector<Eigen::Vector3d> ground = ground_around(28.6, 0.3, 0.0, 1);  // 9 points
  o3::LocalGroundParameters parameters;
  parameters.min_points = 10;
  EXPECT_EQ(run(surface, candidates, ground, parameters).cells, 0);
  parameters.min_points = 9;
  EXPECT_EQ(run(surface, candidates, ground, parameters).cells, 1);
  // reach 0: the cell alone holds one of them.
  parameters.min_points = 1;
  parameters.reach_cells = 0;
  const Outcome alone = run(surface, candidates, ground, parameters);
  EXPECT_EQ(alone.cells, 1);
  EXPECT_NEAR(alone.candidates[0].height_above_ground_m, 1.88 + 0.10, 1e-5);  // its point is the +0.02 one
}

TEST(LocalGround, PointsUnderTheBandAreNoGroundSamples) {
  const terrain::TerrainGridSpec spec;
  const terrain::BsplineSurface surface = flat_surface(spec, 0.0);
  const std::vector<o3::ObstaclePoint> candidates = {candidate_at(15.3, 2.2, 1.5, surface)};
  // A ditch's bottom, 0.6 m under the surface (the band reaches 0.4 m), and two road points on it.
  std::vector<Eigen::Vector3d> points = ground_around(15.3, 2.2, -0.6, 4);
  points.emplace_back(15.3, 2.2, -0.01);
  points.emplace_back(15.4, 2.2, -0.03);
  o3::LocalGroundParameters parameters;
  parameters.min_points = 2;
  const Outcome outcome = run(surface, candidates, points, parameters);
  EXPECT_EQ(outcome.cells, 1);
  EXPECT_NEAR(outcome.candidates[0].height_above_ground_m, 1.5 + 0.01, 1e-5);  // the upper median of the two
  parameters.band_below_m = 0.7;  // the ditch's points now count, and their median is -0.58 or -0.62
  const Outcome wide = run(surface, candidates, points, parameters);
  EXPECT_GT(wide.candidates[0].height_above_ground_m, 1.5 + 0.5);
}

TEST(LocalGround, ThePointOrderDoesNotMatterAndTheWorkIsCounted) {
  const terrain::TerrainGridSpec spec;
  const terrain::BsplineSurface surface = flat_surface(spec, 0.12);
  const std::vector<o3::ObstaclePoint> candidates = {candidate_at(28.6, 0.3, 2.0, surface)};
  std::vector<Eigen::Vector3d> points = ground_around(28.6, 0.3, 0.0, 5);
  for (int k = 0; k < 7; ++k) points.emplace_back(28.6, 0.3, -0.3 + 0.01 * k);
  const Outcome in_order = run(surface, candidates, points);
  std::mt19937 random(7);
  std::shuffle(points.begin(), points.end(), random);
  const Outcome shuffled = run(surface, candidates, points);
  EXPECT_EQ(shuffled.candidates[0].height_above_ground_m, in_order.candidates[0].height_above_ground_m);
  EXPECT_EQ(shuffled.work.scalar_ops, in_order.work.scalar_ops);
  // Nor how the points are dealt to shares (the gathers a caller runs on threads).
  for (int shares : {2, 3, 7}) {
    const Outcome dealt = run(surface, candidates, points, {}, shares);
    EXPECT_EQ(dealt.cells, in_order.cells) << shares;
    EXPECT_EQ(dealt.candidates[0].height_above_ground_m, in_order.candidates[0].height_above_ground_m) << shares;
    EXPECT_EQ(dealt.work.scalar_ops, in_order.work.scalar_ops) << shares;
    EXPECT_EQ(dealt.work.memory_bytes, in_order.work.memory_bytes) << shares;
  }
  // Nor whether the caller gives the points' heights above the surface (the classification has them
  // for the points its bound does not decide): the same result, without the evaluations' work.
  {
    o3::LocalGround given(spec, surface, 0.2, o3::LocalGroundParameters{});
    std::vector<o3::ObstaclePoint> measured = candidates;
    given.mark_candidates(measured);
    for (const Eigen::Vector3d& point : points) given.add_point(point, 0, point.z() - surface.height_m(point.x(), point.y()));
    EXPECT_EQ(given.apply(measured), in_order.cells);
    EXPECT_EQ(measured[0].height_above_ground_m, in_order.candidates[0].height_above_ground_m);
    const uint64_t evaluation_ops = terrain::surface_evaluation_ops(3, 3);
    // in_order also evaluated S at the candidate itself (run() adds the candidates as points)
    EXPECT_EQ(given.work().scalar_ops + (points.size() + 1) * evaluation_ops + 4, in_order.work.scalar_ops);
  }
  // Nor whether the caller gives the points' cells; a point outside the area (cell -1) costs its 4.
  {
    o3::LocalGround given(spec, surface, 0.2, o3::LocalGroundParameters{});
    std::vector<o3::ObstaclePoint> measured = candidates;
    given.mark_candidates(measured);
    for (const Eigen::Vector3d& point : points) {
      int i = -1, j = -1;
      ASSERT_TRUE(spec.cell_of(point.x(), point.y(), &i, &j));
      given.add_point_in_cell(point, i, j, 0, std::numeric_limits<double>::quiet_NaN());
    }
    const uint64_t ops_inside = given.work().scalar_ops;
    given.add_point_in_cell(Eigen::Vector3d(28.6, 0.3, 0.0), -1, -1, 0, std::numeric_limits<double>::quiet_NaN());
    EXPECT_EQ(given.work().scalar_ops, ops_inside + 4);
    EXPECT_EQ(given.apply(measured), in_order.cells);
    EXPECT_EQ(measured[0].height_above_ground_m, in_order.candidates[0].height_above_ground_m);
  }
  // Points outside every window cost their cell test only; those inside, a surface evaluation each.
  std::vector<Eigen::Vector3d> more = points;
  more.emplace_back(5.0, -8.0, 0.0);
  EXPECT_EQ(run(surface, candidates, more).work.scalar_ops, in_order.work.scalar_ops + 4);
  more.emplace_back(28.6, 0.3, 0.0);
  const uint64_t evaluation_ops = 6 * 3 * 4 + 6 * 3 * 4 + 2 * 4 * 4 + 8;
  // + 4 for the pooled value's copy and selection, in the one candidate cell
  EXPECT_EQ(run(surface, candidates, more).work.scalar_ops, in_order.work.scalar_ops + 4 + 4 + evaluation_ops + 4);
}

TEST(LocalGround, RefusesParametersOutOfRangeByName) {
  const auto message = [](const o3::LocalGroundParameters& parameters) {
    try {
      parameters.validate();
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string("accepted");
  };
  o3::LocalGroundParameters parameters;
  EXPECT_EQ(message(parameters), "accepted");
  parameters.reach_cells = 9;
  EXPECT_EQ(message(parameters), "reach_cells: expected a count of cells in [0, 8], got 9");
  parameters = {};
  parameters.band_below_m = 0;
  EXPECT_EQ(message(parameters), "band_below_m: expected a height in (0, 10) m, got 0");
  parameters = {};
  parameters.min_points = 0;
  EXPECT_EQ(message(parameters), "min_points: expected a count in [1, 100000], got 0");
  const terrain::TerrainGridSpec spec;
  const terrain::BsplineSurface surface = flat_surface(spec, 0.0);
  try {
    o3::LocalGround local_ground(spec, surface, 0.2, o3::LocalGroundParameters{}, 0);
    ADD_FAILURE() << "0 shares accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()), "shares: expected a count in [1, 1024], got 0");
  }
}

}  // namespace
}  // namespace lpstereo
