#include "io/stereo_synth.h"

#include "io/synth_render.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

namespace lpstereo::io {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
// Hashing, value noise, textures and the sensor are shared with the flight (io/synth_render.h).
using synth_detail::kPi;
using synth_detail::mix64;
using synth_detail::Rgb;
using synth_detail::SplitMix;
using synth_detail::Texture;
using synth_detail::texture;
using synth_detail::value_noise;
using synth_detail::require;
using synth_detail::write_png;
using synth_detail::write_text;
using synth_detail::number;

constexpr Texture kAsphalt{{0.03, 0.09, 0.27, 0.8}, {0.3, 0.25, 0.2, 0.15}, 4};  // SynthRoadSurface::textured
constexpr Texture kRealAsphalt{{0.004, 0.012, 0.05, 2.5}, {0.15, 0.10, 0.05, 0.04}, 4};  // SynthRoadSurface::asphalt
constexpr Texture kVerge{{0.05, 0.15, 0.45, 1.5}, {0.3, 0.25, 0.25, 0.2}, 4};
constexpr Texture kObject{{0.012, 0.035, 0.1, 0.3}, {0.25, 0.2, 0.15, 0.1}, 4};
constexpr Texture kWall{{0.4, 1.2, 3.6, 11}, {0.3, 0.3, 0.25, 0.2}, 4};
constexpr Texture kSky{{4, 12, 36, 100}, {0.06, 0.08, 0.1, 0.1}, 4};  // milliradians

struct Vec {
  double x = 0, y = 0, z = 0;
};
double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec normalized(Vec a) {
  const double n = std::sqrt(dot(a, a));
  return {a.x / n, a.y / n, a.z / n};
}

// Towards the light, road frame (y down): from above, a little from the camera's side and left.
const Vec kLight = normalized({-0.3, -0.85, -0.45});

// ---- geometry ----

struct Camera {
  double focal_px, cx_px, cy_px;
  double cos_pitch, sin_pitch;
  bool rolled = false;  // roll 0 keeps the pitch-only arithmetic (the same bits as before roll existed)
  double cos_roll = 1, sin_roll = 0;
  // The road-frame direction of the ray through image point (u, v), scaled so its camera-frame z is
  // 1: the hit parameter t is then the camera-frame depth Z. Rz(roll) about the optical axis first
  // (z stays 1), then Rx(pitch).
  Vec ray(double u, double v) const {
    double x = (u - cx_px) / focal_px, y = (v - cy_px) / focal_px;
    if (rolled) {
      const double rolled_x = x * cos_roll - y * sin_roll;
      y = x * sin_roll + y * cos_roll;
      x = rolled_x;
    }
    const Vec d{x, y * cos_pitch + sin_pitch, -y * sin_pitch + cos_pitch};
    return moved ? yawed(d) : d;
  }
  // A camera moved on the road (StereoSynthOptions::camera_x_m ...): position and heading; not
  // moved keeps the arithmetic above (the same bits as before the camera could move).
  bool moved = false;
  Vec position{};
  double cos_yaw = 1, sin_yaw = 0;
  // Turned by the heading about the road's vertical: forward (0, 0, 1) -> (sin yaw, 0, cos yaw).
  Vec yawed(Vec a) const { return {a.x * cos_yaw + a.z * sin_yaw, a.y, -a.x * sin_yaw + a.z * cos_yaw}; }
  Vec unyawed(Vec a) const { return {a.x * cos_yaw - a.z * sin_yaw, a.y, a.x * sin_yaw + a.z * cos_yaw}; }
  // Road frame -> camera frame (of a camera centred at road point `origin`).
  Vec to_camera(Vec p, Vec origin) const {
    if (moved) {
      p = unyawed({p.x - origin.x, p.y - origin.y, p.z - origin.z});
      origin = {};
    }
    const Vec c{p.x - origin.x, (p.y - origin.y) * cos_pitch - (p.z - origin.z) * sin_pitch,
                (p.y - origin.y) * sin_pitch + (p.z - origin.z) * cos_pitch};
    if (!rolled) return c;
    return {c.x * cos_roll + c.y * sin_roll, -c.x * sin_roll + c.y * cos_roll, c.z};
  }
  // The centre of view 0 (left, the origin) or 1 (right: baseline_m along the camera's x axis).
  Vec origin(int view, double baseline_m) const {
    if (moved) {
      Camera fixed = *this;
      fixed.moved = false;
      const Vec offset = yawed(fixed.origin(view, baseline_m));
      return {position.x + offset.x, position.y + offset.y, position.z + offset.z};
    }
    if (view == 0) return {0, 0, 0};
    if (!rolled) return {baseline_m, 0, 0};
    return {baseline_m * cos_roll, baseline_m * sin_roll * cos_pitch, -baseline_m * sin_roll * sin_pitch};
  }
};

constexpr int kRoughOctaves = 4;

}  // namespace

struct SynthGroundTruth::NoiseCache {
  synth_detail::NoiseCell octave[kRoughOctaves];
};

namespace {

struct Road {
  double height_m, slope_tan, slope_start_m, end_m;
  const SynthGroundTruth* field = nullptr;  // the height field, or null: the flat or sloped road alone
  double rate_bound = 0;                     // Lipschitz constant of the ground height: field + slope

  double y_at(double z) const { return z <= slope_start_m ? height_m : height_m - slope_tan * (z - slope_start_m); }
  // The ground's Y (down) under road point (x, z).
  double ground_y(double x, double z) const { return field ? y_at(z) - field->elevation_m(x, z) : y_at(z); }
  // The same, bit for bit, through a ray's noise cache (ray marching).
  double ground_y(double x, double z, SynthGroundTruth::NoiseCache& cache) const {
    return field ? y_at(z) - field->elevation_m(x, z, cache) : y_at(z);
  }

  // Nearest hit of a ray from o along d with the flat or sloped road before its end, or +inf.
  double plane_hit(Vec o, Vec d) const {
    double best = kInfinity;
    if (d.y > 0) {
      const double t = (height_m - o.y) / d.y;
      if (o.z + t * d.z <= slope_start_m && o.z + t * d.z > 0) best = t;
    }
    const double denominator = d.y + slope_tan * d.z;
    if (denominator > 0) {
      const double t = ((height_m + slope_tan * slope_start_m) - o.y - slope_tan * o.z) / denominator;
      if (o.z + t * d.z > slope_start_m && t < best) best = t;
    }
    return o.z + best * d.z <= end_m ? best : kInfinity;
  }

  // Nearest hit with the ground: the road's planes, or with a height field the first crossing of
  // gap(t) = ground Y - ray Y (> 0 above the ground) from + to -.
  double hit(Vec o, Vec d) const {
    if (!field) return plane_hit(o, d);
    // No crossing before the ray meets the road raised by the hills' and rough part's highest
    // elevation, or enters a berm's strip: start at the first of these.
    double t = 0;
    Road raised = *this;
    raised.field = nullptr;
    raised.height_m = height_m - field->smooth_max_elevation_m();
    if (raised.height_m - o.y > 0) {
      t = raised.plane_hit(o, d);
      for (const SynthGroundTruth::Strip& strip : field->strips()) {
        if (strip.raise_m <= 0) continue;
        if (o.x >= strip.x_min_m && o.x <= strip.x_max_m) t = 0;
        else if (d.x != 0) {
          const double enter = ((d.x > 0 ? strip.x_min_m : strip.x_max_m) - o.x) / d.x;
          if (enter > 0) t = std::min(t, enter);
        }
      }
      if (!std::isfinite(t)) return kInfinity;  // above every possible ground until the background
    }
    const double t_end = d.z > 0 ? (end_m - o.z) / d.z : 2 * end_m;
    // gap changes along the ray at most this fast per unit t: |dY/dt| + L |d(x, z)/dt|, with L the
    // smooth part's bound outside the strips, the whole field's within.
    const double horizontal = std::hypot(d.x, d.z);
    const double smooth_rate = std::abs(d.y) + (field->smooth_lipschitz() + std::abs(slope_tan)) * horizontal;
    const double full_rate = std::abs(d.y) + rate_bound * horizontal;
    SynthGroundTruth::NoiseCache cache;
    auto gap = [&](double at) { return ground_y(o.x + at * d.x, o.z + at * d.z, cache) - (o.y + at * d.y); };
    // A ray that rises (or runs level) while above the highest ground there can be (flat or falling
    // road: no ground Y below height_m - max elevation; 1 um margin against rounding) never meets it:
    // the march below would step on to the background and return +inf; it returns that now.
    const bool can_rise_clear = d.y <= 0 && slope_tan <= 0;
    const double clear_y = height_m - field->max_elevation_m() - 1e-6;
    auto touches_strip = [&](double from, double to) {
      const double x0 = o.x + from * d.x, x1 = o.x + to * d.x;
      for (const SynthGroundTruth::Strip& strip : field->strips()) {
        if (std::max(x0, x1) >= strip.x_min_m && std::min(x0, x1) <= strip.x_max_m) return true;
      }
      return false;
    };
    double g = gap(t);
    if (g <= 0) return t;
    // Steps of gap / rate cannot pass a crossing; the floor (0.4 % of the depth, a few mm near the
    // camera) keeps grazing rays from creeping; it can only skip a bump thinner than the floor along
    // the ray, which these smooth fields (finest cell 0.375 m) do not have within the rendered range.
    for (int step = 0; step < 20000 && t < t_end; ++step) {
      if (can_rise_clear && o.y + t * d.y < clear_y) return kInfinity;
      const double floor = 0.004 * t + 0.002;
      double t_next = t + std::max(g / smooth_rate, floor);
      if (touches_strip(t, t_next)) t_next = t + std::max(g / full_rate, floor);
      t_next = std::min(t_next, t_end);
      const double g_next = gap(t_next);
      if (g_next <= 0) return refine_crossing(gap, t, g, t_next, g_next);
      t = t_next;
      g = g_next;
    }
    return kInfinity;
  }

  // The crossing inside [lo, hi] (gap(lo) > 0 >= gap(hi)): Illinois regula falsi, to 1e-9 of the depth
  // or a gap under a micrometre.
  template <typename Gap>
  static double refine_crossing(const Gap& gap, double lo, double g_lo, double hi, double g_hi) {
    int side = 0;
    for (int iteration = 0; iteration < 60 && hi - lo > 1e-9 * hi; ++iteration) {
      const double t = (lo * g_hi - hi * g_lo) / (g_hi - g_lo);
      const double g = gap(t);
      if (std::abs(g) < 1e-6) return t;
      if (g > 0) {
        lo = t, g_lo = g;
        if (side == 1) g_hi *= 0.5;
        side = 1;
      } else {
        hi = t, g_hi = g;
        if (side == -1) g_lo *= 0.5;
        side = -1;
      }
    }
    return 0.5 * (lo + hi);
  }
};

enum class Shape { cone, cylinder, capsule, box, board_on_poles, hanging_sign, ball_on_post };

struct Placed {
  SynthObject object;
  Shape shape = Shape::box;
  double base_y;  // road-frame Y of the base (the road surface under the base centre)
  double centre_y;       // road-frame Y of the ground under the base centre (base_y without a height field)
  double top_height_m;   // the object's height_m above centre_y (object.height_m grows on a height field)
  double top_radius_m;
  uint64_t seed;
  Rgb colour, second_colour;
  int bbox[2][4];  // per view: conservative pixel bounds x0 y0 x1 y1 (inclusive)
};

struct ObjectHit {
  double t = kInfinity;
  Vec normal;
  double s = 0;       // texture coordinates on the surface, metres: around / across,
  double r = 0;       // and up (continued across a top face, so the texture has no seam there)
  double height = 0;  // height above the base, metres (the class's colour bands)
  int part = 0;       // floating objects: 0 = the board or ball, 1 = a post, arm or wire
};

bool solve_quadratic(double a, double b, double c, double& t0, double& t1) {
  if (std::abs(a) < 1e-15) {
    if (std::abs(b) < 1e-15) return false;
    t0 = t1 = -c / b;
    return true;
  }
  const double disc = b * b - 4 * a * c;
  if (disc < 0) return false;
  const double root = std::sqrt(disc);
  t0 = (-b - root) / (2 * a);
  t1 = (-b + root) / (2 * a);
  if (t0 > t1) std::swap(t0, t1);
  return true;
}

// A vertical surface of revolution about (x_m, z_m): radius r0 at the base, r1 at height h.
void hit_round(const Placed& p, Vec o, Vec d, double r0, double r1, double h, bool cap, ObjectHit& best) {
  const double px = o.x - p.object.x_m, pz = o.z - p.object.z_m;
  const double base = p.base_y - o.y;  // the base, below the ray's origin
  const double k = (r0 - r1) / h;
  // radius at the ray point: q = r0 - k (base - y) = q0 + q1 t (y measured from the origin)
  const double q0 = r0 - k * base, q1 = k * d.y;
  double t0, t1;
  if (solve_quadratic(d.x * d.x + d.z * d.z - q1 * q1, 2 * (px * d.x + pz * d.z - q0 * q1), px * px + pz * pz - q0 * q0, t0, t1)) {
    for (double t : {t0, t1}) {
      if (!(t > 1e-6) || t >= best.t) continue;
      const double height = base - t * d.y;
      if (height < 0 || height > h || q0 + q1 * t < 0) continue;
      const double x = px + t * d.x, z = pz + t * d.z, q = q0 + q1 * t;
      best.t = t;
      best.normal = normalized({x, -q * k, z});
      best.s = std::atan2(x, -z) * std::max(r0, r1);
      best.r = best.height = height;
      break;
    }
  }
  if (cap && d.y != 0) {  // the top disc
    const double t = (base - h) / d.y;
    if (t > 1e-6 && t < best.t) {
      const double x = px + t * d.x, z = pz + t * d.z;
      if (x * x + z * z <= r1 * r1) {
        best.t = t;
        best.normal = {0, -1, 0};
        best.s = x;
        best.r = h + z;
        best.height = h;
      }
    }
  }
}

// A sphere of `radius` centred centre_height above p.base_y on the object's axis; only the upper half
// unless `whole` (the capsule's lower half is inside its cylinder).
void hit_sphere(const Placed& p, Vec origin, Vec d, double radius, double centre_height, ObjectHit& best, bool whole = false) {
  const Vec o{origin.x - p.object.x_m, origin.y - (p.base_y - centre_height), origin.z - p.object.z_m};
  double t0, t1;
  if (!solve_quadratic(dot(d, d), 2 * dot(o, d), dot(o, o) - radius * radius, t0, t1)) return;
  const double t = t0 > 1e-6 ? t0 : t1;
  if (!(t > 1e-6) || t >= best.t) return;
  const Vec n{(o.x + t * d.x) / radius, (o.y + t * d.y) / radius, (o.z + t * d.z) / radius};
  if (n.y > 0 && !whole) return;  // the lower half is inside the cylinder below
  best.t = t;
  best.normal = n;
  best.s = std::atan2(n.x, -n.z) * radius;
  best.r = best.height = (p.base_y - origin.y) - t * d.y;
}

// An axis-aligned box [low, high] (road frame); texture height measured up from base_y, continued
// across the top face by top_height.
void hit_aabb(const double low[3], const double high[3], double base_y, double top_height, Vec o_ray, Vec d, ObjectHit& best) {
  const double origin[3] = {o_ray.x, o_ray.y, o_ray.z}, direction[3] = {d.x, d.y, d.z};
  double t_near = -kInfinity, t_far = kInfinity;
  int axis = -1, sign = 0;
  for (int a = 0; a < 3; ++a) {
    if (direction[a] == 0) {
      if (origin[a] < low[a] || origin[a] > high[a]) return;
      continue;
    }
    double ta = (low[a] - origin[a]) / direction[a], tb = (high[a] - origin[a]) / direction[a];
    int face_sign = -1;  // entering through the low face: outward normal points to -axis
    if (ta > tb) {
      std::swap(ta, tb);
      face_sign = 1;
    }
    if (ta > t_near) {
      t_near = ta;
      axis = a;
      sign = face_sign;
    }
    t_far = std::min(t_far, tb);
  }
  if (axis < 0 || t_near > t_far || !(t_near > 1e-6) || t_near >= best.t) return;
  const double hit[3] = {o_ray.x + t_near * d.x, o_ray.y + t_near * d.y, o_ray.z + t_near * d.z};
  best.t = t_near;
  best.normal = {axis == 0 ? double(sign) : 0, axis == 1 ? double(sign) : 0, axis == 2 ? double(sign) : 0};
  best.r = best.height = base_y - hit[1];
  best.s = axis == 0 ? hit[2] : hit[0];
  if (axis == 1) best.r = top_height + hit[2] - low[2];
}

void hit_box(const Placed& p, Vec o_ray, Vec d, ObjectHit& best) {
  const SynthObject& o = p.object;
  const double low[3] = {o.x_m - o.width_m / 2, p.base_y - o.height_m, o.z_m - o.length_m / 2};
  const double high[3] = {o.x_m + o.width_m / 2, p.base_y, o.z_m + o.length_m / 2};
  hit_aabb(low, high, p.base_y, o.height_m, o_ray, d, best);
}

// A part of a floating object: the box x in [x0, x1], z in [z0, z1] (road frame), from height h0 up
// to h1 above the ground under the base centre (h0 < 0: from the base, down into a height field).
void hit_part(const Placed& p, double x0, double x1, double h0, double h1, double z0, double z1, int part, Vec o, Vec d,
              ObjectHit& best) {
  const double low[3] = {x0, p.centre_y - h1, z0};
  const double high[3] = {x1, h0 < 0 ? p.base_y : p.centre_y - h0, z1};
  const double before = best.t;
  hit_aabb(low, high, p.base_y, p.object.height_m, o, d, best);
  if (best.t < before) best.part = part;
}

// The floating objects (SynthObject's comment): boards, posts, arm, wires, ball.
constexpr double kBoardPost = 0.08, kSignArm = 0.10, kSignPost = 0.10, kSignPostGap = 0.5, kSignWire = 0.02,
                 kSignHang = 0.35, kBallPost = 0.05;

void hit_floating(const Placed& p, Vec o, Vec d, ObjectHit& best) {
  const SynthObject& b = p.object;
  const double x = b.x_m, z = b.z_m, w = b.width_m / 2, l = b.length_m / 2, top = p.top_height_m;
  switch (p.shape) {
    case Shape::board_on_poles:
      hit_part(p, x - w, x + w, b.clearance_m, top, z - l, z + l, 0, o, d, best);
      for (const double post_x : {x - w + kBoardPost / 2, x + w - kBoardPost / 2}) {
        hit_part(p, post_x - kBoardPost / 2, post_x + kBoardPost / 2, -1, b.clearance_m, z - kBoardPost / 2, z + kBoardPost / 2, 1, o, d,
                 best);
      }
      break;
    case Shape::hanging_sign: {
      hit_part(p, x - w, x + w, b.clearance_m, top - kSignHang, z - l, z + l, 0, o, d, best);
      const double post_x = x + w + kSignPostGap;
      hit_part(p, x - w, post_x + kSignPost / 2, top - kSignArm, top, z - kSignArm / 2, z + kSignArm / 2, 1, o, d, best);
      hit_part(p, post_x - kSignPost / 2, post_x + kSignPost / 2, -1, top - kSignArm, z - kSignPost / 2, z + kSignPost / 2, 1, o, d, best);
      for (const double wire_x : {x - w / 2, x + w / 2}) {
        hit_part(p, wire_x - kSignWire / 2, wire_x + kSignWire / 2, top - kSignHang, top - kSignArm, z - kSignWire / 2, z + kSignWire / 2, 1,
                 o, d, best);
      }
      break;
    }
    case Shape::ball_on_post: {
      const double radius = b.width_m / 2, centre = top - radius;
      const double before = best.t;
      hit_sphere(p, o, d, radius, (p.base_y - p.centre_y) + centre, best, true);
      if (best.t < before) best.part = 0;
      hit_part(p, x - kBallPost / 2, x + kBallPost / 2, -1, centre, z - kBallPost / 2, z + kBallPost / 2, 1, o, d, best);
      break;
    }
    default: break;
  }
}

void hit_object(const Placed& p, Vec o, Vec d, ObjectHit& best) {
  const double r = p.object.width_m / 2, h = p.object.height_m;
  switch (p.shape) {
    case Shape::cone: hit_round(p, o, d, r, p.top_radius_m, h, true, best); break;
    case Shape::cylinder: hit_round(p, o, d, r, r, h, true, best); break;
    case Shape::capsule:
      hit_round(p, o, d, r, r, h - r, false, best);
      hit_sphere(p, o, d, r, h - r, best);
      break;
    case Shape::box: hit_box(p, o, d, best); break;
    case Shape::board_on_poles:
    case Shape::hanging_sign:
    case Shape::ball_on_post: hit_floating(p, o, d, best); break;
  }
}

Rgb object_albedo(const Placed& p, const ObjectHit& hit, double footprint, synth_detail::NoiseCell (&cells)[4]) {
  const double f = hit.height / p.object.height_m;  // 0 at the base, 1 at the top
  Rgb base = p.colour;
  switch (p.object.object_class) {
    case SynthClass::cone: if (f > 0.45 && f < 0.7) base = {235, 235, 235}; break;   // reflective band
    case SynthClass::can: if (f > 0.2 && f < 0.8) base = p.second_colour; break;      // label
    case SynthClass::bin: if (f > 0.92) base = p.colour * 0.7; break;                 // lid
    case SynthClass::pedestrian:
      if (hit.height > 1.45) base = {205, 160, 130};                                  // head
      else if (hit.height < 0.85) base = p.second_colour;                             // legs
      break;
    case SynthClass::car: if (f > 0.6) base = {45, 50, 58}; break;                    // windows
    case SynthClass::board_on_poles:
    case SynthClass::hanging_sign:
    case SynthClass::ball_on_post: if (hit.part == 1) base = {150, 150, 155}; break;  // galvanised supports
    default: break;
  }
  return base * (1.0 + texture(kObject, hit.s, hit.r, p.seed, footprint, cells));
}

struct Sample {
  Rgb colour;
  double depth = kInfinity;  // camera-frame z, +inf for sky
  int id = 0;
};

class Renderer {
 public:
  Renderer(const StereoSynthOptions& options) : options_(options) {
    camera_.focal_px = options.width / 2.0 / std::tan(options.hfov_deg * kPi / 360.0);
    camera_.cx_px = (options.width - 1) / 2.0;
    camera_.cy_px = (options.height - 1) / 2.0;
    camera_.cos_pitch = std::cos(options.pitch_rad);
    camera_.sin_pitch = std::sin(options.pitch_rad);
    if (options.roll_rad != 0) {
      camera_.rolled = true;
      camera_.cos_roll = std::cos(options.roll_rad);
      camera_.sin_roll = std::sin(options.roll_rad);
    }
    road_ = {options.camera_height_m, std::tan(options.slope_deg * kPi / 180.0), options.slope_start_m,
             options.background_distance_m};
    if (options.ground.any()) {
      field_.emplace(options);
      road_.field = &*field_;
      road_.rate_bound = field_->lipschitz() + std::abs(road_.slope_tan);
    }
    if (options.camera_x_m != 0 || options.camera_z_m != 0 || options.camera_yaw_rad != 0) {
      camera_.moved = true;
      camera_.cos_yaw = std::cos(options.camera_yaw_rad);
      camera_.sin_yaw = std::sin(options.camera_yaw_rad);
      // camera_height_m above the ground under the camera (Y down: the ground's Y minus the height).
      camera_.position = {options.camera_x_m, road_.ground_y(options.camera_x_m, options.camera_z_m) - options.camera_height_m,
                          options.camera_z_m};
    }
    origins_[0] = camera_.origin(0, options.baseline_m);
    origins_[1] = camera_.origin(1, options.baseline_m);
    SplitMix colours{uint64_t{options.seed} * 7777u + 5};
    for (size_t i = 0; i < options.objects.size(); ++i) place(options.objects[i], i, colours);
  }

  const Camera& camera() const { return camera_; }
  const Road& road() const { return road_; }
  const std::vector<Placed>& placed() const { return placed_; }

  // Per thread: the noise cells of the textures (one set per surface; objects share one) and of the
  // background wall's outline. Only speeds the lookups up: the values are the same bits.
  struct TextureCache {
    synth_detail::NoiseCell asphalt[4], verge[4], object[4], wall[4], sky[4];
    synth_detail::NoiseCell wall_top;
    SynthGroundTruth::NoiseCache normal;  // the height field's, for ground_normal
  };

  // The sample along the ray from view `view`'s centre in direction d (camera_.ray) through pixel
  // (pixel_u, pixel_v) (the objects' pixel bounds), whose ground hit road_.hit() is t_road. Without
  // `shade` only depth and id (the colour stays black). `sky` (may be null): the sky's colour along d
  // when known (the sky depends on the direction alone, so the two views share it) or to be filled in.
  Sample trace(int view, Vec d, int pixel_u, int pixel_v, double t_road, bool shade, TextureCache& cache,
               std::optional<Rgb>* sky = nullptr) const {
    const Vec o = origins_[view];
    const double length = std::sqrt(dot(d, d));
    const double footprint_per_t = length / camera_.focal_px;  // metres per pixel per unit depth
    const uint64_t seed = options_.seed;
    Sample sample;

    ObjectHit object;
    int object_index = -1;
    for (size_t i = 0; i < placed_.size(); ++i) {
      const int* b = placed_[i].bbox[view];
      if (pixel_u < b[0] || pixel_u > b[2] || pixel_v < b[1] || pixel_v > b[3]) continue;
      const double before = object.t;
      hit_object(placed_[i], o, d, object);
      if (object.t < before) object_index = static_cast<int>(i);
    }
    double t_wall = kInfinity, wall_y = 0;
    // A ground hit before the wall's plane decides every comparison below whether or not the ray
    // meets the wall (its outline), so the outline's noise is looked up only when it can matter.
    if (d.z > 0 && !(t_road < (road_.end_m - o.z) / d.z)) {
      t_wall = (road_.end_m - o.z) / d.z;
      wall_y = o.y + t_wall * d.y;
      const double x = o.x + t_wall * d.x;
      const double top = road_.y_at(road_.end_m) - (30 + 20 * value_noise(x / 80.0, 0.5, seed + 11, cache.wall_top));
      // With a height field the wall reaches down to the field's lowest point (a ditch runs under it).
      const double bottom = road_.y_at(road_.end_m) + (field_ ? std::max(0.0, -field_->min_elevation_m()) : 0.0);
      if (wall_y < top || wall_y > bottom + 1e-9) t_wall = kInfinity;
    }

    if (object_index >= 0 && object.t <= t_road && object.t <= t_wall) {
      sample.depth = object.t;
      sample.id = object_index + 1;
      if (!shade) return sample;
      const Placed& p = placed_[static_cast<size_t>(object_index)];
      const double grazing = std::max(std::abs(dot(object.normal, d)) / length, 0.1);
      const double footprint = object.t * footprint_per_t / std::sqrt(grazing);
      const double shade_factor = 0.55 + 0.45 * std::max(0.0, dot(object.normal, kLight));
      sample.colour = object_albedo(p, object, footprint, cache.object) * shade_factor;
    } else if (t_road < t_wall) {
      sample.depth = t_road;
      if (!shade) return sample;
      const double x = o.x + t_road * d.x, z = o.z + t_road * d.z;
      const double grazing = std::max(std::abs(field_ ? dot(ground_normal(x, z, cache.normal), d) : d.y) / length, 0.02);
      const double footprint = t_road * footprint_per_t / std::sqrt(grazing);
      sample.colour = road_albedo(x, z, footprint, cache);
    } else if (t_wall < kInfinity) {
      sample.depth = t_wall;
      if (!shade) return sample;
      const double x = o.x + t_wall * d.x;
      const double footprint = t_wall * footprint_per_t;
      sample.colour = Rgb{95, 105, 90} * (1.0 + texture(kWall, x, wall_y, seed + 101, footprint, cache.wall));
    } else {
      if (!shade) return sample;
      if (sky != nullptr && sky->has_value()) {
        sample.colour = **sky;
        return sample;
      }
      // Sky: a texture of the direction only, so both views see it at the same pixel (disparity 0).
      const double azimuth = std::atan2(d.x, d.z) * 1000, elevation = std::atan2(-d.y, std::hypot(d.x, d.z)) * 1000;
      sample.colour = Rgb{185, 200, 220} * (1.0 + texture(kSky, azimuth, elevation, seed + 202, 1000.0 / camera_.focal_px, cache.sky));
      if (sky != nullptr) *sky = sample.colour;
    }
    return sample;
  }

  // View `view`'s centre (camera_.origin), computed once.
  Vec origin(int view) const { return origins_[view]; }

 private:
  // The unit normal of the height-field ground at (x, z), from central differences (1 cm).
  Vec ground_normal(double x, double z, SynthGroundTruth::NoiseCache& cache) const {
    const double step = 0.01;
    const double dydx = (road_.ground_y(x + step, z, cache) - road_.ground_y(x - step, z, cache)) / (2 * step);
    const double dydz = (road_.ground_y(x, z + step, cache) - road_.ground_y(x, z - step, cache)) / (2 * step);
    return normalized({-dydx, 1, -dydz});
  }

  Rgb road_albedo(double x, double z, double footprint, TextureCache& cache) const {
    const double ax = std::abs(x);
    if (ax > 5.6) return Rgb{80, 105, 65} * (1.0 + texture(kVerge, x, z, options_.seed + 303, footprint, cache.verge));
    // Lane markings 0.15 m wide: solid road edges at +-5.25 m, dashed lane lines at +-1.75 m
    // (3 m dashes every 9 m); the left camera is centred in the middle lane.
    const bool edge = std::abs(ax - 5.25) < 0.075;
    const bool lane = std::abs(ax - 1.75) < 0.075 && std::fmod(std::max(z, 0.0), 9.0) < 3.0;
    const Texture& surface = options_.road_surface == SynthRoadSurface::asphalt ? kRealAsphalt : kAsphalt;
    const double grain = 1.0 + texture(surface, x, z, options_.seed + 404, footprint, cache.asphalt);
    return (edge || lane) ? Rgb{225, 225, 220} * (0.85 + 0.15 * grain) : Rgb{100, 100, 104} * grain;
  }

  void place(const SynthObject& object, size_t index, SplitMix& colours) {
    Placed p;
    p.object = object;
    p.base_y = road_.y_at(object.z_m);
    p.centre_y = p.base_y;
    p.top_height_m = object.height_m;
    p.top_radius_m = object.width_m / 2 * 0.15;
    p.seed = uint64_t{options_.seed} * 1000003u + index * 7919u + 17u;
    const Rgb palette[] = {{200, 40, 40}, {40, 70, 160}, {230, 200, 60}, {60, 140, 70}, {220, 220, 225}, {30, 30, 35}, {150, 90, 160}};
    const Rgb picked = palette[colours.next() % 7];
    const Rgb second = palette[colours.next() % 7];
    switch (object.object_class) {
      case SynthClass::cone: p.shape = Shape::cone; p.colour = {235, 95, 25}; break;
      case SynthClass::can: p.shape = Shape::cylinder; p.colour = {165, 165, 172}; p.second_colour = picked; break;
      case SynthClass::tape_roll: p.shape = Shape::cylinder; p.colour = {205, 195, 150}; break;
      case SynthClass::box: p.shape = Shape::box; p.colour = {175, 135, 85}; break;
      case SynthClass::bin: p.shape = Shape::box; p.colour = {45, 95, 55}; break;
      case SynthClass::pedestrian: p.shape = Shape::capsule; p.colour = picked; p.second_colour = Rgb{55, 55, 95}; break;
      case SynthClass::car: p.shape = Shape::box; p.colour = second; break;
      case SynthClass::board_on_poles: p.shape = Shape::board_on_poles; p.colour = picked; break;
      case SynthClass::hanging_sign: p.shape = Shape::hanging_sign; p.colour = {30, 90, 170}; break;
      case SynthClass::ball_on_post: p.shape = Shape::ball_on_post; p.colour = {230, 120, 30}; break;
    }
    if (field_) {
      // Stand on the field: the top stays height_m above the ground under the base centre, the solid
      // reaches down to the lowest ground under the footprint (sampled 9 x 9), so no gap shows.
      const double centre_y = p.centre_y = road_.ground_y(object.x_m, object.z_m);
      const double half_x = object.width_m / 2, half_z = (p.shape == Shape::box ? object.length_m : object.width_m) / 2;
      double lowest_y = centre_y;
      for (int i = 0; i <= 8; ++i) {
        for (int j = 0; j <= 8; ++j) {
          lowest_y = std::max(lowest_y, road_.ground_y(object.x_m + half_x * (i / 4.0 - 1), object.z_m + half_z * (j / 4.0 - 1)));
        }
      }
      p.base_y = lowest_y + 0.02;  // 2 cm into the ground against the sampling's gaps
      p.object.height_m = object.height_m + (p.base_y - centre_y);
    }
    // Conservative pixel bounds per view from the 8 corners of the object's bounding box; a corner
    // behind (or almost at) the camera leaves the whole image.
    // (The hanging sign's post stands beyond the board's right end.)
    const double extra_x = object.object_class == SynthClass::hanging_sign ? kSignPostGap + kSignPost : 0.0;
    for (int view = 0; view < 2; ++view) {
      const Vec origin = camera_.origin(view, options_.baseline_m);
      const double half_x = (object.width_m / 2 + extra_x) * 1.01 + 0.01;
      const double half_z = (p.shape == Shape::box ? object.length_m : object.width_m) / 2 * 1.01 + 0.01;
      double u0 = kInfinity, v0 = kInfinity, u1 = -kInfinity, v1 = -kInfinity;
      bool behind = false;
      for (int corner = 0; corner < 8; ++corner) {
        const Vec road_point{object.x_m + ((corner & 1) ? half_x : -half_x), p.base_y - ((corner & 2) ? p.object.height_m * 1.01 + 0.01 : -0.01),
                             object.z_m + ((corner & 4) ? half_z : -half_z)};
        const Vec c = camera_.to_camera(road_point, origin);
        if (c.z < 0.05) {
          behind = true;
          break;
        }
        const double u = camera_.focal_px * c.x / c.z + camera_.cx_px, v = camera_.focal_px * c.y / c.z + camera_.cy_px;
        u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
      }
      int* b = p.bbox[view];
      if (behind) {
        b[0] = b[1] = -1, b[2] = options_.width, b[3] = options_.height;
      } else {
        auto clamp_to = [](double x, int high) { return static_cast<int>(std::clamp(x, -2.0, static_cast<double>(high) + 1)); };
        b[0] = clamp_to(std::floor(u0) - 1, options_.width), b[1] = clamp_to(std::floor(v0) - 1, options_.height);
        b[2] = clamp_to(std::ceil(u1) + 1, options_.width), b[3] = clamp_to(std::ceil(v1) + 1, options_.height);
      }
    }
    placed_.push_back(p);
  }

  const StereoSynthOptions& options_;
  Camera camera_{};
  Road road_{};
  std::optional<SynthGroundTruth> field_;
  std::vector<Placed> placed_;
  Vec origins_[2];
};

}  // namespace

// ---- the height-field ground ----

namespace {

void validate_ground(const SynthGround& g) {
  require(g.hills_amplitude_m >= 0 && g.hills_amplitude_m <= 5, "hills-amplitude-m", "[0, 5] metres", g.hills_amplitude_m);
  require(g.hills_wavelength_m >= 2 && g.hills_wavelength_m <= 1000, "hills-wavelength-m", "[2, 1000] metres", g.hills_wavelength_m);
  require(g.ditch_depth_m >= 0 && g.ditch_depth_m <= 5, "ditch-depth-m", "[0, 5] metres", g.ditch_depth_m);
  require(g.ditch_width_m >= 0.2 && g.ditch_width_m <= 50, "ditch-width-m", "[0.2, 50] metres", g.ditch_width_m);
  require(std::abs(g.ditch_x_m) <= 100, "ditch-x-m", "|x| <= 100 metres", g.ditch_x_m);
  require(g.berm_height_m >= 0 && g.berm_height_m <= 5, "berm-height-m", "[0, 5] metres", g.berm_height_m);
  require(g.berm_width_m >= 0.2 && g.berm_width_m <= 50, "berm-width-m", "[0.2, 50] metres", g.berm_width_m);
  require(std::abs(g.berm_x_m) <= 100, "berm-x-m", "|x| <= 100 metres", g.berm_x_m);
  require(g.rough_amplitude_m >= 0 && g.rough_amplitude_m <= 3, "rough-amplitude-m", "[0, 3] metres", g.rough_amplitude_m);
  require(g.rough_wavelength_m >= 0.5 && g.rough_wavelength_m <= 1000, "rough-wavelength-m", "[0.5, 1000] metres", g.rough_wavelength_m);
}

// The second swell of the hills runs obliquely (direction (0.6, 0.8) in X, Z) with a longer wavelength.
constexpr double kObliqueX = 0.6, kObliqueZ = 0.8, kObliqueStretch = 1.3;

}  // namespace

SynthGround parse_synth_ground(const std::string& spec) {
  const std::string expected = "ground: expected flat, or hills, ditch, ditch-u, berm, rough joined by '+' or ',', got '" + spec + "'";
  SynthGround ground;
  if (spec == "flat") return ground;
  const SynthGround defaults;
  size_t start = 0;
  for (;;) {
    const size_t end = spec.find_first_of("+,", start);
    const std::string kind = spec.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (kind == "hills") {
      ground.hills_amplitude_m = 0.6;
    } else if (kind == "ditch" || kind == "ditch-u") {
      ground.ditch_depth_m = 0.6;
      ground.ditch_u_shape = kind == "ditch-u";
    } else if (kind == "berm") {
      ground.berm_height_m = 0.8;
    } else if (kind == "rough") {
      ground.rough_amplitude_m = 0.25;
    } else {
      throw std::invalid_argument(expected);
    }
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return ground;
}

SynthGroundTruth::SynthGroundTruth(const StereoSynthOptions& options) : ground_(options.ground) {
  validate_ground(ground_);
  slope_tan_ = std::tan(options.slope_deg * kPi / 180.0);
  slope_start_m_ = options.slope_start_m;
  SplitMix random{uint64_t{options.seed} * 0x9E3779B97F4A7C15ull + 4242};
  hills_phase_[0] = random.uniform(0.0, 2 * kPi);
  hills_phase_[1] = random.uniform(0.0, 2 * kPi);
  rough_seed_ = random.next();
  origin_elevation_m_ = raw_elevation_m(0, 0, nullptr);
  // Bounds. Hills: each swell A/2 sin(2 pi s / lambda) has slope <= pi A / lambda. Ditch: V 2D/W, U
  // (1 - u^2 over half-width W/2) 4D/W. Berm: H/2 (1 + cos(pi u)) over W/2: pi H / W. Rough: an
  // octave of value noise (smoothstep slope <= 1.5, lattice in [-1, 1]) changes by <= 3 per cell
  // along each axis, so |grad| <= 3 sqrt(2) a_k / cell_k.
  const SynthGround& g = ground_;
  double amplitude_sum = 0, slope_sum = 0;
  for (int k = 0; k < kRoughOctaves; ++k) {
    amplitude_sum += std::ldexp(1.0, -k);
    slope_sum += std::ldexp(1.0, -k) * 3 * std::sqrt(2.0) / std::ldexp(g.rough_wavelength_m, -k);
  }
  smooth_lipschitz_ = kPi * g.hills_amplitude_m / g.hills_wavelength_m * (1 + 1 / kObliqueStretch) +
                      g.rough_amplitude_m / amplitude_sum * slope_sum;
  smooth_max_elevation_m_ = g.hills_amplitude_m + g.rough_amplitude_m - origin_elevation_m_;
  const double ditch_lipschitz = (g.ditch_u_shape ? 4 : 2) * g.ditch_depth_m / g.ditch_width_m;
  const double berm_lipschitz = kPi * g.berm_height_m / g.berm_width_m;
  lipschitz_ = smooth_lipschitz_ + ditch_lipschitz + berm_lipschitz;
  if (g.ditch_depth_m > 0) strips_.push_back({g.ditch_x_m - g.ditch_width_m / 2, g.ditch_x_m + g.ditch_width_m / 2, 0.0});
  if (g.berm_height_m > 0) strips_.push_back({g.berm_x_m - g.berm_width_m / 2, g.berm_x_m + g.berm_width_m / 2, g.berm_height_m});
  max_elevation_m_ = smooth_max_elevation_m_ + g.berm_height_m;
  min_elevation_m_ = -g.hills_amplitude_m - g.ditch_depth_m - g.rough_amplitude_m - origin_elevation_m_;
}

double SynthGroundTruth::raw_elevation_m(double x, double z, NoiseCache* cache) const {
  const SynthGround& g = ground_;
  double e = 0;
  if (g.hills_amplitude_m > 0) {
    const double along = 2 * kPi * z / g.hills_wavelength_m + hills_phase_[0];
    const double oblique = 2 * kPi * (kObliqueX * x + kObliqueZ * z) / (kObliqueStretch * g.hills_wavelength_m) + hills_phase_[1];
    e += 0.5 * g.hills_amplitude_m * (std::sin(along) + std::sin(oblique));
  }
  if (g.ditch_depth_m > 0) {
    const double u = std::abs(x - g.ditch_x_m) / (g.ditch_width_m / 2);
    if (u < 1) e -= g.ditch_depth_m * (g.ditch_u_shape ? 1 - u * u : 1 - u);
  }
  if (g.berm_height_m > 0) {
    const double u = std::abs(x - g.berm_x_m) / (g.berm_width_m / 2);
    if (u < 1) e += g.berm_height_m * 0.5 * (1 + std::cos(kPi * u));
  }
  if (g.rough_amplitude_m > 0) {
    // Octave k: cells of wavelength / 2^k, amplitude 2^-k (sum 1.875). x / (wavelength 2^-k) is
    // (x / wavelength) 2^k exactly (scaling by a power of two is exact, barring subnormal quotients,
    // |x| < 1e-300 m), so one division serves every octave with the same bits as dividing by each cell.
    constexpr double kScale[kRoughOctaves] = {1, 2, 4, 8}, kAmplitude[kRoughOctaves] = {1, 0.5, 0.25, 0.125};
    const double x_cells = x / g.rough_wavelength_m, z_cells = z / g.rough_wavelength_m;
    double sum = 0;
    for (int k = 0; k < kRoughOctaves; ++k) {
      const uint64_t seed = rough_seed_ + 7919u * static_cast<uint64_t>(k);
      const double noise = cache ? value_noise(x_cells * kScale[k], z_cells * kScale[k], seed, cache->octave[k])
                                 : value_noise(x_cells * kScale[k], z_cells * kScale[k], seed);
      sum += kAmplitude[k] * noise;
    }
    e += g.rough_amplitude_m * sum / 1.875;
  }
  return e;
}

double SynthGroundTruth::elevation_m(double x_m, double z_m) const { return raw_elevation_m(x_m, z_m, nullptr) - origin_elevation_m_; }

double SynthGroundTruth::elevation_m(double x_m, double z_m, NoiseCache& cache) const {
  return raw_elevation_m(x_m, z_m, &cache) - origin_elevation_m_;
}

double SynthGroundTruth::height_m(double x_m, double z_m) const {
  const double rise = z_m <= slope_start_m_ ? 0.0 : slope_tan_ * (z_m - slope_start_m_);
  return rise + elevation_m(x_m, z_m);
}

void use_real_camera_pair(StereoSynthOptions& options) {
  options.noise_sigma = 2;
  options.right_gain = 1.08;
  options.right_offset = -5;
  options.vignetting = 0.3;
  options.blur_sigma_px = 0.7;
}

const char* synth_road_surface_name(SynthRoadSurface surface) {
  return surface == SynthRoadSurface::asphalt ? "asphalt" : "textured";
}

SynthRoadSurface parse_synth_road_surface(const std::string& name) {
  if (name == "textured") return SynthRoadSurface::textured;
  if (name == "asphalt") return SynthRoadSurface::asphalt;
  throw std::invalid_argument("surface: expected textured or asphalt, got '" + name + "'");
}

const char* synth_class_name(SynthClass object_class) {
  switch (object_class) {
    case SynthClass::cone: return "cone";
    case SynthClass::can: return "can";
    case SynthClass::box: return "box";
    case SynthClass::tape_roll: return "tape_roll";
    case SynthClass::bin: return "bin";
    case SynthClass::pedestrian: return "pedestrian";
    case SynthClass::car: return "car";
    case SynthClass::board_on_poles: return "board_on_poles";
    case SynthClass::hanging_sign: return "hanging_sign";
    case SynthClass::ball_on_post: return "ball_on_post";
  }
  return "?";
}

SynthObject synth_object(SynthClass object_class, double x_m, double z_m) {
  SynthObject o;
  o.object_class = object_class;
  o.x_m = x_m;
  o.z_m = z_m;
  switch (object_class) {  // width, height, length (metres)
    case SynthClass::cone: o.width_m = 0.18, o.height_m = 0.30, o.length_m = 0.18; break;
    case SynthClass::can: o.width_m = 0.15, o.height_m = 0.19, o.length_m = 0.15; break;
    case SynthClass::box: o.width_m = 0.40, o.height_m = 0.43, o.length_m = 0.30; break;
    case SynthClass::tape_roll: o.width_m = 0.12, o.height_m = 0.07, o.length_m = 0.12; break;
    case SynthClass::bin: o.width_m = 0.58, o.height_m = 1.10, o.length_m = 0.74; break;
    case SynthClass::pedestrian: o.width_m = 0.50, o.height_m = 1.70, o.length_m = 0.50; break;
    case SynthClass::car: o.width_m = 1.80, o.height_m = 1.50, o.length_m = 4.50; break;
    // A barrier board 0.7 m high with 0.9 m free under it; a 1.2 x 0.4 m sign hanging 1.9 m above
    // the road (the board reaches 2.65 m, the arm 3 m); a 0.4 m ball 0.8 m above the road.
    case SynthClass::board_on_poles: o.width_m = 2.0, o.height_m = 1.6, o.length_m = 0.06, o.clearance_m = 0.9; break;
    case SynthClass::hanging_sign: o.width_m = 1.2, o.height_m = 3.0, o.length_m = 0.05, o.clearance_m = 1.9; break;
    case SynthClass::ball_on_post: o.width_m = 0.4, o.height_m = 1.2, o.length_m = 0.4; break;
  }
  return o;
}

double synth_object_min_height_m(const SynthObject& object) {
  switch (object.object_class) {
    case SynthClass::board_on_poles:
    case SynthClass::hanging_sign: return object.clearance_m;
    case SynthClass::ball_on_post: return object.height_m - object.width_m;
    default: return 0;
  }
}

SynthCameraPose synth_camera_pose(const StereoSynthOptions& options) {
  validate_synth_options(options);
  StereoSynthOptions no_objects = options;
  no_objects.objects.clear();
  const Renderer renderer(no_objects);
  const Camera& camera = renderer.camera();
  SynthCameraPose pose{};
  const Vec centre = camera.origin(0, options.baseline_m);
  pose.centre_m[0] = centre.x, pose.centre_m[1] = centre.y, pose.centre_m[2] = centre.z;
  // Column j: the road-frame direction of camera axis j, from to_camera (a rotation: its inverse is
  // its transpose, so row j of to_camera's matrix).
  const Vec axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < 3; ++i) {
    const Vec c = camera.to_camera({centre.x + axes[i].x, centre.y + axes[i].y, centre.z + axes[i].z}, centre);
    pose.rotation[i][0] = c.x, pose.rotation[i][1] = c.y, pose.rotation[i][2] = c.z;
  }
  return pose;
}

void validate_synth_options(const StereoSynthOptions& o) {
  synth_detail::validate_camera_and_sensor(o.width, o.height, o.hfov_deg, o.samples_per_axis, o.noise_sigma, o.right_gain, o.right_offset,
                                          o.threads);
  require(o.baseline_m > 0 && o.baseline_m <= 10, "baseline-m", "(0, 10] metres", o.baseline_m);
  require(o.camera_height_m > 0 && o.camera_height_m <= 100, "camera-height-m", "(0, 100] metres", o.camera_height_m);
  require(std::abs(o.pitch_rad) < 0.5, "pitch", "|pitch| < 0.5 rad (28.6 degrees)", o.pitch_rad);
  require(std::abs(o.roll_rad) < 0.5, "roll", "|roll| < 0.5 rad (28.6 degrees)", o.roll_rad);
  validate_ground(o.ground);
  require(std::abs(o.slope_deg) <= 10, "slope-deg", "a gentle slope, |slope| <= 10 degrees", o.slope_deg);
  require(o.slope_start_m >= 0, "slope-start-m", ">= 0 metres", o.slope_start_m);
  require(o.background_distance_m > 10 && o.background_distance_m <= 100000, "background-distance-m", "(10, 100000] metres",
          o.background_distance_m);
  require(std::abs(o.camera_x_m) <= 1000, "camera-x-m", "|x| <= 1000 metres", o.camera_x_m);
  require(o.camera_z_m >= -1000 && o.camera_z_m < o.background_distance_m - 10, "camera-z-m",
          "[-1000, background distance - 10) metres", o.camera_z_m);
  require(std::abs(o.camera_yaw_rad) <= kPi, "camera-yaw", "|yaw| <= pi rad", o.camera_yaw_rad);
  require(o.vignetting >= 0 && o.vignetting <= 0.6, "vignetting", "a share of light lost at the corners in [0, 0.6]", o.vignetting);
  require(o.blur_sigma_px >= 0 && o.blur_sigma_px <= 3, "blur-px", "a Gaussian sigma in [0, 3] px", o.blur_sigma_px);
  for (const SynthObject& object : o.objects) {
    const std::string name = std::string("object ") + synth_class_name(object.object_class);
    if (object.object_class == SynthClass::board_on_poles) {
      require(object.clearance_m > 0 && object.clearance_m < object.height_m, name + " clearance", "(0, height) metres", object.clearance_m);
      require(object.width_m > 2 * kBoardPost, name + " width", "> 0.16 metres (two posts)", object.width_m);
    } else if (object.object_class == SynthClass::hanging_sign) {
      require(object.clearance_m > 0 && object.clearance_m < object.height_m - kSignHang - 0.05, name + " clearance",
              "(0, height - 0.4) metres (the board, then the wires and arm above it)", object.clearance_m);
    } else if (object.object_class == SynthClass::ball_on_post) {
      require(object.width_m < object.height_m, name + " width", "a diameter below the height (the ball's top)", object.width_m);
    }
    require(object.width_m > 0 && object.height_m > 0 && object.length_m > 0, std::string("object ") + synth_class_name(object.object_class) + " size",
            "positive metres", std::min({object.width_m, object.height_m, object.length_m}));
    require(object.z_m > 0 && object.z_m < o.background_distance_m, std::string("object ") + synth_class_name(object.object_class) + " z",
            "between the camera and the background", object.z_m);
  }
}

std::vector<SynthObject> random_synth_objects(uint32_t seed) {
  SplitMix random{uint64_t{seed} * 0x2545F4914F6CDD1Dull + 99};
  const int count = 6 + static_cast<int>(random.next() % 9);
  std::vector<SynthObject> objects;
  for (int attempt = 0; attempt < 400 && static_cast<int>(objects.size()) < count; ++attempt) {
    const auto object_class = static_cast<SynthClass>(random.next() % 7);
    SynthObject o = synth_object(object_class, random.uniform(-5.0, 5.0), random.uniform(8.0, 80.0));
    const double radius = 0.5 * std::hypot(o.width_m, o.length_m);
    bool overlaps = false;
    for (const SynthObject& other : objects) {
      const double other_radius = 0.5 * std::hypot(other.width_m, other.length_m);
      if (std::hypot(o.x_m - other.x_m, o.z_m - other.z_m) < radius + other_radius + 0.5) overlaps = true;
    }
    if (!overlaps) objects.push_back(o);
  }
  return objects;
}

std::vector<SynthObject> lineup_synth_objects(double distance_m) {
  const SynthClass classes[] = {SynthClass::cone, SynthClass::can, SynthClass::box, SynthClass::tape_roll, SynthClass::bin,
                                SynthClass::pedestrian};
  std::vector<SynthObject> objects;
  for (int i = 0; i < 6; ++i) objects.push_back(synth_object(classes[i], -3.0 + 1.2 * i, distance_m));
  return objects;
}

double synth_road_disparity_px(const StereoSynthOptions& options, double u_px, double v_px) {
  StereoSynthOptions no_objects = options;
  no_objects.objects.clear();
  const Renderer renderer(no_objects);
  const double t = renderer.road().hit(renderer.camera().origin(0, options.baseline_m), renderer.camera().ray(u_px, v_px));
  return std::isfinite(t) ? renderer.camera().focal_px * options.baseline_m / t : kInfinity;
}

StereoSynthScene render_stereo_synth(const StereoSynthOptions& options, const std::function<void(double)>& progress) {
  validate_synth_options(options);
  const Renderer renderer(options);
  const int width = options.width, height = options.height, samples = options.samples_per_axis;
  StereoSynthScene scene;
  scene.focal_px = renderer.camera().focal_px;
  cv::Mat views[2] = {cv::Mat(height, width, CV_8UC1), cv::Mat(height, width, CV_8UC1)};
  cv::Mat colours[2];
  if (options.colour) colours[0].create(height, width, CV_8UC3), colours[1].create(height, width, CV_8UC3);
  scene.disparity_px.create(height, width, CV_32FC1);
  scene.object_ids.create(height, width, CV_16UC1);
  const double fb = scene.focal_px * options.baseline_m;

  synth_detail::SensorModel sensors[2] = {{options.noise_sigma, 1.0, 0.0},
                                          {options.noise_sigma, options.right_gain, options.right_offset}};
  for (int view = 0; view < 2; ++view) {
    sensors[view].vignetting = options.vignetting * (view == 0 ? 1.0 : kRightVignettingRatio);
    sensors[view].centre_u = (width - 1) / 2.0;
    sensors[view].centre_v = (height - 1) / 2.0;
    sensors[view].corner_radius_px = std::hypot(sensors[view].centre_u, sensors[view].centre_v);
  }
  // With blur, the radiance of both views is kept whole until the optics have spread it; without,
  // each row goes to the sensor as it is rendered.
  const bool blur = options.blur_sigma_px > 0;
  std::vector<synth_detail::Rgb> radiance[2];
  if (blur) {
    for (auto& view_radiance : radiance) view_radiance.resize(static_cast<size_t>(width) * static_cast<size_t>(height));
  }
  auto expose = [&](int view, int v, const synth_detail::Rgb* row) {
    synth_detail::expose_row(row, width, sensors[view], options.seed, view, v, views[view].ptr<uint8_t>(v),
                             options.colour ? colours[view].ptr<cv::Vec3b>(v) : nullptr);
  };
  // Per row and view: every ray's direction (samples^2 per pixel, then for the left view the pixel
  // centre's ray of the ground truth) and its ground hit, then each pixel's samples in the order of
  // their sum. The centre's ray needs no colour (trace without shading), and the right view's samples
  // take the sky's colour from the left view's (the same directions).
  const int per_pixel[2] = {samples * samples + 1, samples * samples};
  auto render_row = [&](int v) {
    std::vector<Rgb> row(static_cast<size_t>(width));
    std::vector<Vec> directions(static_cast<size_t>(width * per_pixel[0]));
    std::vector<double> t_road(directions.size());
    // The left view's sky colour per sample ray; the right view's ray of the same sample has the
    // same direction, and the sky depends on the direction alone.
    std::vector<std::optional<Rgb>> sky(static_cast<size_t>(width * samples * samples));
    Renderer::TextureCache cache;
    for (int view = 0; view < 2; ++view) {
      Vec* d = directions.data();
      for (int u = 0; u < width; ++u) {
        for (int j = 0; j < samples; ++j) {
          for (int i = 0; i < samples; ++i) *d++ = renderer.camera().ray(u + (i + 0.5) / samples - 0.5, v + (j + 0.5) / samples - 0.5);
        }
        if (view == 0) *d++ = renderer.camera().ray(u, v);
      }
      for (int i = 0; i < width * per_pixel[view]; ++i) t_road[static_cast<size_t>(i)] = renderer.road().hit(renderer.origin(view), directions[static_cast<size_t>(i)]);
      for (int u = 0; u < width; ++u) {
        const size_t first = static_cast<size_t>(u * per_pixel[view]);
        Rgb sum;
        for (int k = 0; k < samples * samples; ++k) {
          sum = sum + renderer.trace(view, directions[first + k], u, v, t_road[first + k], true, cache,
                                     &sky[static_cast<size_t>(u * samples * samples + k)]).colour;
        }
        row[static_cast<size_t>(u)] = sum * (1.0 / (samples * samples));
        if (view == 0) {  // ground truth from the ray through the pixel centre
          const size_t c = first + static_cast<size_t>(samples * samples);
          const Sample centre = renderer.trace(0, directions[c], u, v, t_road[c], false, cache);
          scene.disparity_px.at<float>(v, u) = std::isfinite(centre.depth) ? static_cast<float>(fb / centre.depth)
                                                                            : std::numeric_limits<float>::infinity();
          scene.object_ids.at<uint16_t>(v, u) = static_cast<uint16_t>(centre.id);
        }
      }
      if (blur) {
        std::copy(row.begin(), row.end(), radiance[view].begin() + static_cast<ptrdiff_t>(v) * width);
      } else {
        expose(view, v, row.data());
      }
    }
  };
  synth_detail::render_rows(height, options.threads, render_row, progress);
  if (blur) {
    for (int view = 0; view < 2; ++view) {
      synth_detail::blur_radiance(radiance[view], width, height, options.blur_sigma_px, options.threads);
      synth_detail::render_rows(height, options.threads, [&](int v) { expose(view, v, radiance[view].data() + static_cast<ptrdiff_t>(v) * width); }, {});
    }
  }

  scene.left = views[0];
  scene.right = views[1];
  scene.left_colour = colours[0];
  scene.right_colour = colours[1];

  // Truth per object: its pixels in the id image, and its base centre in the left camera frame.
  for (size_t i = 0; i < renderer.placed().size(); ++i) {
    const Placed& p = renderer.placed()[i];
    SynthObjectTruth truth;
    truth.id = static_cast<int>(i) + 1;
    truth.object = options.objects[i];
    // The base centre: on the ground under it (a height-field object's solid reaches lower).
    const Vec c = renderer.camera().to_camera({p.object.x_m, renderer.road().ground_y(p.object.x_m, p.object.z_m), p.object.z_m},
                                              renderer.camera().origin(0, options.baseline_m));
    truth.position_m[0] = c.x, truth.position_m[1] = c.y, truth.position_m[2] = c.z;
    truth.distance_m = c.z;
    truth.disparity_px = fb / c.z;
    truth.min_height_m = synth_object_min_height_m(options.objects[i]);
    truth.max_height_m = options.objects[i].height_m;
    scene.objects.push_back(truth);
  }
  for (int v = 0; v < height; ++v) {
    const uint16_t* ids = scene.object_ids.ptr<uint16_t>(v);
    for (int u = 0; u < width; ++u) {
      if (ids[u] == 0) continue;
      SynthObjectTruth& t = scene.objects[ids[u] - 1u];
      if (t.visible_pixels++ == 0) {
        t.bbox_px[0] = t.bbox_px[2] = u, t.bbox_px[1] = t.bbox_px[3] = v;
      } else {
        t.bbox_px[0] = std::min(t.bbox_px[0], u), t.bbox_px[2] = std::max(t.bbox_px[2], u);
        t.bbox_px[1] = std::min(t.bbox_px[1], v), t.bbox_px[3] = std::max(t.bbox_px[3], v);
      }
    }
  }

  scene.calibration = synth_detail::pinhole_pair_calibration(width, height, scene.focal_px, renderer.camera().cx_px,
                                                                 renderer.camera().cy_px, options.baseline_m);
  return scene;
}

namespace {

// ground.json: the parameters and the true height sampled every 0.25 m (what a script compares with).
nlohmann::json ground_json(const StereoSynthOptions& options) {
  const SynthGroundTruth truth(options);
  const SynthGround& g = options.ground;
  nlohmann::json json;
  json["frame"] = "road: x right, z forward from the left camera centre; height_m up from the plane camera_height_m below the camera";
  json["camera_height_m"] = options.camera_height_m;
  json["pitch_rad"] = options.pitch_rad;
  json["roll_rad"] = options.roll_rad;
  json["slope_deg"] = options.slope_deg;
  json["slope_start_m"] = options.slope_start_m;
  json["seed"] = options.seed;
  json["hills"] = {{"amplitude_m", g.hills_amplitude_m}, {"wavelength_m", g.hills_wavelength_m}};
  json["ditch"] = {{"depth_m", g.ditch_depth_m}, {"x_m", g.ditch_x_m}, {"width_m", g.ditch_width_m}, {"shape", g.ditch_u_shape ? "U" : "V"}};
  json["berm"] = {{"height_m", g.berm_height_m}, {"x_m", g.berm_x_m}, {"width_m", g.berm_width_m}};
  json["rough"] = {{"amplitude_m", g.rough_amplitude_m}, {"wavelength_m", g.rough_wavelength_m}};
  nlohmann::json xs = nlohmann::json::array(), zs = nlohmann::json::array(), heights = nlohmann::json::array();
  for (int j = 0; j <= 96; ++j) xs.push_back(-12 + 0.25 * j);
  for (int i = 0; i <= 160; ++i) {
    const double z = 0.25 * i;
    zs.push_back(z);
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j <= 96; ++j) row.push_back(std::round(truth.height_m(-12 + 0.25 * j, z) * 1e6) / 1e6);
    heights.push_back(row);
  }
  json["grid"] = {{"x_m", xs}, {"z_m", zs}, {"height_m", heights}};
  return json;
}

}  // namespace

void write_stereo_synth(const std::string& directory, const StereoSynthScene& scene, const StereoSynthOptions& options) {
  synth_detail::write_folder_atomically(directory, [&](const std::filesystem::path& temporary) {
    write_png(temporary / "left.png", scene.left);
    write_png(temporary / "right.png", scene.right);
    if (!scene.left_colour.empty()) {
      write_png(temporary / "left_colour.png", scene.left_colour);
      write_png(temporary / "right_colour.png", scene.right_colour);
    }
    write_png(temporary / "disparity.png", synth_detail::kitti_disparity_truth(scene.disparity_px));
    write_png(temporary / "object_ids.png", scene.object_ids);

    nlohmann::json json;
    json["width"] = options.width;
    json["height"] = options.height;
    json["focal_px"] = scene.focal_px;
    json["baseline_m"] = options.baseline_m;
    json["hfov_deg"] = options.hfov_deg;
    json["camera_height_m"] = options.camera_height_m;
    json["pitch_rad"] = options.pitch_rad;
    json["roll_rad"] = options.roll_rad;
    json["slope_deg"] = options.slope_deg;
    json["slope_start_m"] = options.slope_start_m;
    json["background_distance_m"] = options.background_distance_m;
    synth_detail::add_sensor_settings(json, options.samples_per_axis, options.noise_sigma, options.right_gain, options.right_offset,
                                      options.seed);
    synth_detail::add_surface_and_lens_settings(json, synth_road_surface_name(options.road_surface), options.vignetting,
                                                options.vignetting * kRightVignettingRatio, options.blur_sigma_px);
    json["frame"] = "left camera: x right, y down, z forward, metres";
    json["objects"] = nlohmann::json::array();
    for (const SynthObjectTruth& t : scene.objects) {
      nlohmann::json o;
      o["id"] = t.id;
      o["class"] = synth_class_name(t.object.object_class);
      o["position_m"] = {t.position_m[0], t.position_m[1], t.position_m[2]};
      o["road_position_m"] = {t.object.x_m, t.object.z_m};
      o["size_m"] = {{"w", t.object.width_m}, {"h", t.object.height_m}, {"l", t.object.length_m}};
      o["distance_m"] = t.distance_m;
      o["disparity_px"] = t.disparity_px;
      o["min_height_m"] = t.min_height_m;
      o["max_height_m"] = t.max_height_m;
      o["bbox_px"] = t.visible_pixels > 0 ? nlohmann::json{t.bbox_px[0], t.bbox_px[1], t.bbox_px[2], t.bbox_px[3]} : nlohmann::json();
      o["visible_pixels"] = t.visible_pixels;
      json["objects"].push_back(o);
    }
    write_text(temporary / "objects.json", json.dump(2) + "\n");
    write_text(temporary / "ground.json", ground_json(options).dump(1) + "\n");

    write_opencv_yaml((temporary / "calib.yaml").string(), scene.calibration,
                      "lpstereo synth: rectified pinhole pair, baseline " + number(options.baseline_m) + " m");
    const double f = scene.focal_px, cx = scene.calibration.left.cx_px, cy = scene.calibration.left.cy_px;
    const std::string size = number(options.width) + " " + number(options.height) + "\n";
    const std::string kitti_text = "S_rect_02: " + size + synth_detail::kitti_projection_line("P_rect_02", f, cx, cy, 0) +
                                   "S_rect_03: " + size + synth_detail::kitti_projection_line("P_rect_03", f, cx, cy, options.baseline_m);
    write_text(temporary / "calib_cam_to_cam.txt", kitti_text);
  });
}

}  // namespace lpstereo::io
