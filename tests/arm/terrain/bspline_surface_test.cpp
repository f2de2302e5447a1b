// B-spline basis and surface (arm/terrain/bspline_surface.cpp): partition of unity, values and
// derivatives at the knots derived by hand from the Cox-de Boor recursion, the triangle against
// the plain recursion, the clamped ends, and the rational form against eq. 3.3 written out.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "arm/terrain/terrain_model.h"

namespace lpstereo::arm::terrain {
namespace {

TEST(BsplineBasis, ClampedUniformKnots) {
  const std::vector<double> knots = clamped_uniform_knots(5, 3, 0.0, 1.0);
  const std::vector<double> expected = {0, 0, 0, 0, 0.5, 1, 1, 1, 1};
  ASSERT_EQ(knots.size(), expected.size());
  for (size_t k = 0; k < knots.size(); ++k) EXPECT_DOUBLE_EQ(knots[k], expected[k]) << k;
  EXPECT_THROW(clamped_uniform_knots(3, 3, 0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(clamped_uniform_knots(5, 0, 0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(clamped_uniform_knots(5, 3, 1.0, 1.0), std::invalid_argument);
}

TEST(BsplineBasis, PartitionOfUnityAndNonNegative) {
  for (int degree = 1; degree <= 5; ++degree) {
    const std::vector<double> knots = clamped_uniform_knots(degree + 6, degree, -3.0, 7.0);
    for (int step = 0; step <= 1000; ++step) {
      const double t = -3.0 + 10.0 * step / 1000.0;
      const int span = knot_span(knots, degree, t);
      double values[8], derivatives[8];
      basis_functions(knots, degree, span, t, values, derivatives);
      double sum = 0, derivative_sum = 0;
      for (int r = 0; r <= degree; ++r) {
        EXPECT_GE(values[r], -1e-15);
        sum += values[r];
        derivative_sum += derivatives[r];
        // The triangle agrees with the plain recursion (eq. 3.4, 3.5).
        EXPECT_NEAR(values[r], basis_function_recursive(knots, span - degree + r, degree, t), 1e-12) << degree << " " << t;
      }
      EXPECT_NEAR(sum, 1.0, 1e-12) << "degree " << degree << " t " << t;
      EXPECT_NEAR(derivative_sum, 0.0, 1e-9) << "degree " << degree << " t " << t;  // d/dt of a constant 1
    }
  }
}

// knot_span guesses the span from t's place in a uniform domain and walks to the exact one: it must
// equal the definition (the largest s in [degree, n - 1] with knots[s] <= t, the last span at the
// end and beyond, the first before the start) for uniform knots, for knots far from uniform (a guess
// several spans off) and for repeated interior knots, at the knots themselves and between them.
TEST(BsplineBasis, KnotSpanIsTheLargestSpanStartingAtOrBeforeT) {
  const auto by_definition = [](const std::vector<double>& knots, int degree, double t) {
    const int control_points = static_cast<int>(knots.size()) - degree - 1;
    if (!(t < knots[static_cast<size_t>(control_points)])) return control_points - 1;
    int span = degree;
    for (int s = degree; s < control_points; ++s) {
      if (knots[static_cast<size_t>(s)] <= t) span = s;
    }
    return span;
  };
  const std::vector<std::vector<double>> knot_vectors = {
      clamped_uniform_knots(25, 3, 0.0, 34.0),
      clamped_uniform_knots(43, 3, -11.0, 11.0),
      {0, 0, 0, 0, 0.1, 0.2, 0.3, 9, 9.5, 10, 10, 10, 10},  // crowded at the start
      {0, 0, 0, 0, 2, 2, 2, 5, 7, 7, 10, 10, 10, 10},       // repeated interior knots
  };
  std::mt19937 random(7);
  for (const std::vector<double>& knots : knot_vectors) {
    const int degree = 3;
    const double low = knots.front(), high = knots.back();
    std::vector<double> samples = {low - 1, low, high, high + 1, std::nextafter(high, low), std::nextafter(low, high)};
    for (const double knot : knots) {
      samples.push_back(knot);
      samples.push_back(std::nextafter(knot, low - 1));
      samples.push_back(std::nextafter(knot, high + 1));
    }
    std::uniform_real_distribution<double> anywhere(low, high);
    for (int k = 0; k < 2000; ++k) samples.push_back(anywhere(random));
    for (const double t : samples) {
      EXPECT_EQ(knot_span(knots, degree, t), by_definition(knots, degree, t)) << "t " << t << ", knots from " << low << " to " << high;
    }
  }
}

// Cubic, knots {0,0,0,0,0.5,1,1,1,1}. By hand from eq. 3.4 at t = 0.5 (span 4, N_4,0 = 1):
// N_3,1 = (1 - .5)/.5 = 1; N_2,2 = (1 - .5)/1 = .5, N_3,2 = (.5 - 0)/1 = .5;
// N_1,3 = .5/1 * .5 = .25, N_2,3 = .5 * .5 + .5 * .5 = .5, N_3,3 = .5 * .5 = .25, N_4,3 = 0.
// At t = 0 only N_0 = 1, at t = 1 only N_4 = 1 (clamped ends). Derivatives at t = 0:
// N_0' = -3 / (t_4 - t_1) = -6, N_1' = +6 (Piegl and Tiller eq. 2.7).
TEST(BsplineBasis, KnownValuesAtTheKnots) {
  const std::vector<double> knots = clamped_uniform_knots(5, 3, 0.0, 1.0);
  const auto all = [&](double t) {
    std::vector<double> row(5, 0.0);
    for (int index = 0; index < 5; ++index) row[static_cast<size_t>(index)] = basis_function_recursive(knots, index, 3, t);
    return row;
  };
  const std::vector<double> middle = all(0.5), start = all(0.0), end = all(1.0);
  const double expected_middle[5] = {0, 0.25, 0.5, 0.25, 0};
  for (int index = 0; index < 5; ++index) {
    EXPECT_NEAR(middle[static_cast<size_t>(index)], expected_middle[index], 1e-15) << index;
    EXPECT_NEAR(start[static_cast<size_t>(index)], index == 0 ? 1.0 : 0.0, 1e-15) << index;
    EXPECT_NEAR(end[static_cast<size_t>(index)], index == 4 ? 1.0 : 0.0, 1e-15) << index;
  }
  double values[4], derivatives[4];
  basis_functions(knots, 3, knot_span(knots, 3, 0.5), 0.5, values, derivatives);
  EXPECT_EQ(knot_span(knots, 3, 0.5), 4);
  EXPECT_NEAR(values[0], 0.25, 1e-15);  // N_1
  EXPECT_NEAR(values[1], 0.5, 1e-15);   // N_2
  EXPECT_NEAR(values[2], 0.25, 1e-15);  // N_3
  EXPECT_NEAR(values[3], 0.0, 1e-15);   // N_4
  basis_functions(knots, 3, knot_span(knots, 3, 0.0), 0.0, values, derivatives);
  EXPECT_NEAR(derivatives[0], -6.0, 1e-12);
  EXPECT_NEAR(derivatives[1], 6.0, 1e-12);
  EXPECT_NEAR(derivatives[2], 0.0, 1e-12);
  EXPECT_EQ(knot_span(knots, 3, 1.0), 4);  // the end belongs to the last span
}

BsplineSurface random_surface(int n0, int n1, int degree, bool rational, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> height(-1.0, 2.0), weight(0.5, 3.0);
  BsplineSurface surface;
  surface.degree_forward = degree;
  surface.degree_lateral = degree - 1;
  surface.forward_min_m = 0, surface.forward_max_m = 10, surface.lateral_min_m = -4, surface.lateral_max_m = 4;
  surface.knots_forward_m = clamped_uniform_knots(n0, surface.degree_forward, 0, 10);
  surface.knots_lateral_m = clamped_uniform_knots(n1, surface.degree_lateral, -4, 4);
  surface.control_z_m.resize(n0, n1);
  for (int a = 0; a < n0; ++a)
    for (int b = 0; b < n1; ++b) surface.control_z_m(a, b) = height(random);
  if (rational) {
    surface.control_weights.resize(n0, n1);
    for (int a = 0; a < n0; ++a)
      for (int b = 0; b < n1; ++b) surface.control_weights(a, b) = weight(random);
  }
  return surface;
}

// Eq. 3.3 written out over every control point with the recursive basis.
double equation_3_3(const BsplineSurface& surface, double x, double y) {
  double numerator = 0, denominator = 0;
  for (int a = 0; a < surface.control_z_m.rows(); ++a) {
    for (int b = 0; b < surface.control_z_m.cols(); ++b) {
      const double r = surface.control_weights.size() > 0 ? surface.control_weights(a, b) : 1.0;
      const double basis = basis_function_recursive(surface.knots_forward_m, a, surface.degree_forward, x) *
                           basis_function_recursive(surface.knots_lateral_m, b, surface.degree_lateral, y);
      numerator += r * basis * surface.control_z_m(a, b);
      denominator += r * basis;
    }
  }
  return numerator / denominator;
}

TEST(BsplineSurface, HeightAndGradientMatchEquation33PolynomialAndRational) {
  for (const bool rational : {false, true}) {
    const BsplineSurface surface = random_surface(7, 6, 3, rational, rational ? 5u : 4u);
    for (double x = 0; x <= 10.0; x += 0.37) {
      for (double y = -4; y <= 4.0; y += 0.53) {
        EXPECT_NEAR(surface.height_m(x, y), equation_3_3(surface, x, y), 1e-12) << x << " " << y;
        // Central differences of eq. 3.3 for the gradient, away from the domain's edges.
        if (x < 0.01 || x > 9.99 || y < -3.99 || y > 3.99) continue;
        const double h = 1e-5;
        const Eigen::Vector2d gradient = surface.gradient(x, y);
        EXPECT_NEAR(gradient.x(), (equation_3_3(surface, x + h, y) - equation_3_3(surface, x - h, y)) / (2 * h), 1e-6);
        EXPECT_NEAR(gradient.y(), (equation_3_3(surface, x, y + h) - equation_3_3(surface, x, y - h)) / (2 * h), 1e-6);
      }
    }
    // Clamped: the corner control points are interpolated.
    EXPECT_NEAR(surface.height_m(0, -4), surface.control_z_m(0, 0), 1e-12);
    EXPECT_NEAR(surface.height_m(10, 4), surface.control_z_m(6, 5), 1e-12);
    EXPECT_TRUE(std::isnan(surface.height_m(10.01, 0)));
    EXPECT_TRUE(std::isnan(surface.gradient(5, -4.01).x()));
  }
}

TEST(BsplineSurface, HeightsAtCellsMatchPointEvaluation) {
  for (const bool rational : {false, true}) {
    const BsplineSurface surface = random_surface(6, 5, 3, rational, 9u);
    TerrainGridSpec spec;
    spec.forward_min_m = 0, spec.forward_max_m = 10, spec.lateral_min_m = -4, spec.lateral_max_m = 4, spec.cell_m = 0.7;
    const Eigen::MatrixXd heights = surface_heights_at_cells(surface, spec);
    ASSERT_EQ(heights.rows(), 15);  // ceil(10 / 0.7)
    ASSERT_EQ(heights.cols(), 12);  // ceil(8 / 0.7)
    for (int i = 0; i < 15; ++i) {
      for (int j = 0; j < 12; ++j) {
        const double x = spec.cell_centre_x_m(i), y = spec.cell_centre_y_m(j);
        if (surface.contains(x, y)) {
          EXPECT_NEAR(heights(i, j), surface.height_m(x, y), 1e-12);
        } else {
          EXPECT_TRUE(std::isnan(heights(i, j))) << i << " " << j;  // the last column's centre is past 4 m
        }
      }
    }
  }
}

}  // namespace
}  // namespace lpstereo::arm::terrain
