// The tensor-product B-spline surface of terrain estimation (issue 9 deliverable 2; thesis 000 =
// Sabbatelli 2015, ../shared/theses/000_*.txt, §3.1.4).
//
// Model (thesis eq. 3.3): with control heights Q (n0 x n1), control weights R (all 1 when empty, the
// polynomial case), degrees d0, d1 and basis functions N over clamped uniform knot vectors,
//     S(x, y) = sum_a sum_b R_ab N_a,d0(x) N_b,d1(y) Q_ab / sum_a sum_b R_ab N_a,d0(x) N_b,d1(y).
// The basis functions follow the Cox-de Boor recursion (Cox 1972, "The numerical evaluation of
// B-splines", IMA J. Appl. Math. 10; de Boor 1972, "On calculating with B-splines", J. Approx.
// Theory 6; thesis eq. 3.4, 3.5):
//     N_i,0(t) = 1 if t_i <= t < t_i+1 else 0
//     N_i,j(t) = (t - t_i) / (t_i+j - t_i) N_i,j-1(t) + (t_i+j+1 - t) / (t_i+j+1 - t_i+1) N_i+1,j-1(t)
// evaluated as the triangle of Piegl and Tiller, "The NURBS Book" (2nd ed. 1997), Algorithm A2.2:
// only the d + 1 functions non-zero on the knot span of t. First derivatives (Piegl and Tiller
// eq. 2.7): N'_i,d = d / (t_i+d - t_i) N_i,d-1 - d / (t_i+d+1 - t_i+1) N_i+1,d-1, and for the
// rational form the quotient rule S' = (A' - S W') / W with A = sum R N N Q, W = sum R N N.
// Clamped knots make the surface interpolate its corner control points and keep it defined up to
// the area's edges; the right end of each axis belongs to the last span (the half-open rule of
// eq. 3.5 would make every basis function zero there).
//
// Evaluation cost (used by the fit's and the traversability's counted work): per point and degree
// d per axis, the triangle is ~3 d (d + 1) operations per axis (6 with derivatives) and the tensor
// sum 2 (d0 + 1)(d1 + 1) (x2 with derivatives; x2 again for the rational form).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "arm/terrain/terrain_model.h"

namespace lpstereo::arm::terrain {

namespace {

constexpr int kMaxDegree = 7;  // the fit allows degrees up to this; the triangle below uses fixed-size arrays

double quiet_nan() { return std::numeric_limits<double>::quiet_NaN(); }

}  // namespace

std::vector<double> clamped_uniform_knots(int control_points, int degree, double min_m, double max_m) {
  if (degree < 1 || degree > kMaxDegree) {
    throw std::invalid_argument("degree: expected 1.." + std::to_string(kMaxDegree) + ", got " + std::to_string(degree));
  }
  if (control_points <= degree) {
    throw std::invalid_argument("control points: expected > degree = " + std::to_string(degree) + ", got " +
                                std::to_string(control_points));
  }
  if (!(min_m < max_m) || !std::isfinite(min_m) || !std::isfinite(max_m)) {
    throw std::invalid_argument("knot domain: expected finite min < max, got [" + std::to_string(min_m) + ", " +
                                std::to_string(max_m) + "]");
  }
  const int spans = control_points - degree;
  std::vector<double> knots;
  knots.reserve(static_cast<size_t>(control_points + degree + 1));
  for (int k = 0; k <= degree; ++k) knots.push_back(min_m);
  for (int k = 1; k < spans; ++k) knots.push_back(min_m + (max_m - min_m) * k / spans);
  for (int k = 0; k <= degree; ++k) knots.push_back(max_m);
  return knots;
}

int knot_span(const std::vector<double>& knots, int degree, double t) {
  const int control_points = static_cast<int>(knots.size()) - degree - 1;
  const double low = knots[static_cast<size_t>(degree)], high = knots[static_cast<size_t>(control_points)];
  if (!(t < high)) return control_points - 1;  // the domain's end (and beyond) belongs to the last span
  if (!(t > low)) return degree;
  // The largest s in [degree, n - 1] with knots[s] <= t. The knots are uniform between low and high
  // in every surface we build, so the span's position in the domain is a first guess, and the two
  // walks make it exact for any non-decreasing knots: after the first, knots[s] <= t (or s is the
  // first span, whose knot low < t); after the second, knots[s + 1] > t or s is the last span. This
  // replaced a binary search, which mispredicts a branch per step for every point a frame classifies
  // (the same spans).
  const int spans = control_points - degree;
  int s = degree + static_cast<int>(static_cast<double>(spans) * ((t - low) / (high - low)));
  s = std::clamp(s, degree, control_points - 1);
  while (s > degree && knots[static_cast<size_t>(s)] > t) --s;
  while (s < control_points - 1 && knots[static_cast<size_t>(s) + 1] <= t) ++s;
  return s;
}

void basis_functions(const std::vector<double>& knots, int degree, int span, double t, double* values, double* derivatives) {
  // lower[r]: N_{span-q+r, q}(t) for the current q; the last pass keeps degree - 1 for derivatives.
  double lower[kMaxDegree + 1] = {1.0};
  double current[kMaxDegree + 1] = {1.0};
  const auto knot = [&](int index) { return knots[static_cast<size_t>(index)]; };
  for (int q = 1; q <= degree; ++q) {
    for (int r = 0; r < q; ++r) lower[r] = current[r];
    for (int r = 0; r <= q; ++r) {
      const int i = span - q + r;
      double value = 0;
      if (r > 0) {
        const double width = knot(i + q) - knot(i);
        if (width > 0) value += (t - knot(i)) / width * lower[r - 1];
      }
      if (r < q) {
        const double width = knot(i + q + 1) - knot(i + 1);
        if (width > 0) value += (knot(i + q + 1) - t) / width * lower[r];
      }
      current[r] = value;
    }
  }
  for (int r = 0; r <= degree; ++r) values[r] = current[r];
  if (derivatives == nullptr) return;
  for (int r = 0; r <= degree; ++r) {
    const int i = span - degree + r;
    double value = 0;
    if (r > 0) {
      const double width = knot(i + degree) - knot(i);
      if (width > 0) value += degree / width * lower[r - 1];
    }
    if (r < degree) {
      const double width = knot(i + degree + 1) - knot(i + 1);
      if (width > 0) value -= degree / width * lower[r];
    }
    derivatives[r] = value;
  }
}

double basis_function_recursive(const std::vector<double>& knots, int index, int degree, double t) {
  const int last = static_cast<int>(knots.size()) - 1;
  if (degree == 0) {
    const double low = knots[static_cast<size_t>(index)], high = knots[static_cast<size_t>(index + 1)];
    if (low <= t && t < high) return 1.0;
    // The domain's right end closes the last non-empty span.
    const double end = knots[static_cast<size_t>(last)];
    return (t == end && high == end && low < high) ? 1.0 : 0.0;
  }
  double value = 0;
  const double left_width = knots[static_cast<size_t>(index + degree)] - knots[static_cast<size_t>(index)];
  if (left_width > 0) value += (t - knots[static_cast<size_t>(index)]) / left_width * basis_function_recursive(knots, index, degree - 1, t);
  const double right_width = knots[static_cast<size_t>(index + degree + 1)] - knots[static_cast<size_t>(index + 1)];
  if (right_width > 0) {
    value += (knots[static_cast<size_t>(index + degree + 1)] - t) / right_width *
             basis_function_recursive(knots, index + 1, degree - 1, t);
  }
  return value;
}

bool BsplineSurface::contains(double x_m, double y_m) const {
  return std::isfinite(x_m) && std::isfinite(y_m) && x_m >= forward_min_m && x_m <= forward_max_m && y_m >= lateral_min_m &&
         y_m <= lateral_max_m && control_z_m.size() > 0;
}

namespace {

// S and optionally its gradient at (x, y) inside the domain.
double evaluate(const BsplineSurface& surface, double x_m, double y_m, Eigen::Vector2d* gradient) {
  const int d0 = surface.degree_forward, d1 = surface.degree_lateral;
  const int span0 = knot_span(surface.knots_forward_m, d0, x_m), span1 = knot_span(surface.knots_lateral_m, d1, y_m);
  double n0[kMaxDegree + 1], dn0[kMaxDegree + 1], n1[kMaxDegree + 1], dn1[kMaxDegree + 1];
  basis_functions(surface.knots_forward_m, d0, span0, x_m, n0, gradient != nullptr ? dn0 : nullptr);
  basis_functions(surface.knots_lateral_m, d1, span1, y_m, n1, gradient != nullptr ? dn1 : nullptr);
  const bool rational = surface.control_weights.size() > 0;
  double sum = 0, sum_dx = 0, sum_dy = 0;           // A, dA/dx, dA/dy
  double weight = 0, weight_dx = 0, weight_dy = 0;  // W, dW/dx, dW/dy
  for (int a = 0; a <= d0; ++a) {
    for (int b = 0; b <= d1; ++b) {
      const int row = span0 - d0 + a, column = span1 - d1 + b;
      const double r = rational ? surface.control_weights(row, column) : 1.0;
      const double rq = r * surface.control_z_m(row, column);
      sum += n0[a] * n1[b] * rq;
      weight += n0[a] * n1[b] * r;
      if (gradient != nullptr) {
        sum_dx += dn0[a] * n1[b] * rq;
        sum_dy += n0[a] * dn1[b] * rq;
        weight_dx += dn0[a] * n1[b] * r;
        weight_dy += n0[a] * dn1[b] * r;
      }
    }
  }
  if (!(weight > 0)) {
    if (gradient != nullptr) *gradient = Eigen::Vector2d(quiet_nan(), quiet_nan());
    return quiet_nan();
  }
  const double height = sum / weight;
  if (gradient != nullptr) {
    *gradient = Eigen::Vector2d((sum_dx - height * weight_dx) / weight, (sum_dy - height * weight_dy) / weight);
  }
  return height;
}

}  // namespace

uint64_t surface_evaluation_ops(int degree_forward, int degree_lateral) {
  const uint64_t p = static_cast<uint64_t>(degree_forward), q = static_cast<uint64_t>(degree_lateral);
  return 6 * p * (p + 1) + 6 * q * (q + 1) + 2 * (p + 1) * (q + 1) + 8;
}

double BsplineSurface::height_m(double x_m, double y_m) const {
  if (!contains(x_m, y_m)) return quiet_nan();
  return evaluate(*this, x_m, y_m, nullptr);
}

Eigen::Vector2d BsplineSurface::gradient(double x_m, double y_m) const {
  if (!contains(x_m, y_m)) return Eigen::Vector2d(quiet_nan(), quiet_nan());
  Eigen::Vector2d slope;
  evaluate(*this, x_m, y_m, &slope);
  return slope;
}

namespace {

}  // namespace

Eigen::MatrixXd basis_matrix(const std::vector<double>& knots, int degree, const std::vector<double>& samples, bool derivative) {
  const int control_points = static_cast<int>(knots.size()) - degree - 1;
  Eigen::MatrixXd rows = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(samples.size()), control_points);
  double values[kMaxDegree + 1], derivatives[kMaxDegree + 1];
  for (size_t k = 0; k < samples.size(); ++k) {
    const int span = knot_span(knots, degree, samples[k]);
    basis_functions(knots, degree, span, samples[k], values, derivative ? derivatives : nullptr);
    for (int r = 0; r <= degree; ++r) rows(static_cast<Eigen::Index>(k), span - degree + r) = derivative ? derivatives[r] : values[r];
  }
  return rows;
}

Eigen::MatrixXd surface_heights_at_cells(const BsplineSurface& surface, const TerrainGridSpec& spec) {
  const int m0 = spec.forward_cells(), m1 = spec.lateral_cells();
  std::vector<double> xs(static_cast<size_t>(m0)), ys(static_cast<size_t>(m1));
  for (int i = 0; i < m0; ++i) xs[static_cast<size_t>(i)] = spec.cell_centre_x_m(i);
  for (int j = 0; j < m1; ++j) ys[static_cast<size_t>(j)] = spec.cell_centre_y_m(j);
  Eigen::MatrixXd heights;
  if (surface.control_z_m.size() == 0) return Eigen::MatrixXd::Constant(m0, m1, quiet_nan());
  const Eigen::MatrixXd basis0 = basis_matrix(surface.knots_forward_m, surface.degree_forward, xs);
  const Eigen::MatrixXd basis1 = basis_matrix(surface.knots_lateral_m, surface.degree_lateral, ys);
  if (surface.control_weights.size() > 0) {
    const Eigen::MatrixXd numerator = basis0 * surface.control_weights.cwiseProduct(surface.control_z_m) * basis1.transpose();
    const Eigen::MatrixXd denominator = basis0 * surface.control_weights * basis1.transpose();
    heights = numerator.cwiseQuotient(denominator);
  } else {
    heights = basis0 * surface.control_z_m * basis1.transpose();
  }
  for (int i = 0; i < m0; ++i) {
    for (int j = 0; j < m1; ++j) {
      if (!surface.contains(xs[static_cast<size_t>(i)], ys[static_cast<size_t>(j)])) heights(i, j) = quiet_nan();
    }
  }
  return heights;
}

}  // namespace lpstereo::arm::terrain
