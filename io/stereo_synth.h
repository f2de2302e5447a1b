// A synthetic road scene rendered as a rectified stereo pair by ray casting, with exact ground truth
// (docs/synth.md). For the obstacle detector's range test and false-positive runs, and for any test
// or benchmark that needs a realistic pair with known geometry. (io/synthetic_scene.h is the small
// analytic scene the kernel tests use; this one is a separate, richer component.)
//
// Geometry (DESIGN.md §4): camera frame x right, y down, z forward, metres. The "road frame" has its
// origin at the left camera centre, X right, Y down (gravity), Z forward along the road; the camera
// is rolled by roll_rad about its optical axis, then pitched by pitch_rad about X (+ = looking down):
// camera-to-road rotation Rx(pitch) Rz(roll), the mount arm::CameraMount{roll_rad, pitch_rad} of
// arm/point_cloud.h describes (+ roll = the right side down). The flat road is the plane Y =
// +camera_height_m; with slope_deg != 0 it bends at slope_start_m into a plane rising (slope > 0) or
// falling ahead. A height-field ground (SynthGround: hills, ditch, berm, rough) adds its elevation
// e(X, Z) (up, e(0, 0) = 0) to that road: the ground is Y = road Y(Z) - e(X, Z), ray cast by marching
// in steps bounded by the field's Lipschitz constant, then refined to the crossing.
// The right camera sits baseline_m along the camera's x axis (road X = +B without roll), same
// orientation: a rectified pair,
// pinhole, square pixels, principal point at the image centre ((W - 1) / 2, (H - 1) / 2, pixel
// centres at integers), focal length f = (W / 2) / tan(hfov / 2).
//
// Every pixel of each view is the mean of samples_per_axis^2 rays on a regular sub-pixel grid (anti-
// aliased edges). The ground truth (left disparity, object id) comes from the ray through the pixel
// centre: disparity = f * B / Z with Z the camera-frame depth of that hit, exact (no quantisation
// until the KITTI file's 1/256 px). Sky (texture at infinity, the same in both views) has no ground
// truth.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "io/calibration.h"

namespace lpstereo::io {

enum class SynthClass { cone, can, box, tape_roll, bin, pedestrian, car, board_on_poles, hanging_sign, ball_on_post };

// "cone", "can", "box", "tape_roll", "bin", "pedestrian", "car", "board_on_poles", "hanging_sign",
// "ball_on_post".
const char* synth_class_name(SynthClass object_class);

// One object standing on the road. Shapes (all vertical, axis along road Y, standing on the road
// surface under their base centre; on a height-field ground the solid reaches down to the lowest
// ground under its footprint, so it stands on the field without a gap, its top at the ground under
// the base centre + height_m): cone = truncated cone (top diameter 0.15 x width), can, tape
// roll = cylinder (diameter = width_m), pedestrian = capsule (cylinder with a hemispherical top,
// diameter = width_m), box, bin, car = axis-aligned box (width_m across X, length_m along Z).
// Floating and concave objects (free space under a part; heights above the ground under the base
// centre): board_on_poles = a board width_m wide, length_m thick, from clearance_m up to height_m,
// on two 8 cm square posts under its ends reaching the ground; hanging_sign = a board width_m wide
// from clearance_m up to height_m - 0.35 m, hung by two 2 cm wires from a 10 cm arm at height_m that
// reaches sideways to a 10 cm post 0.5 m beyond the board's right end (nothing under the board);
// ball_on_post = a sphere of diameter width_m whose top is at height_m (lower edge height_m -
// width_m; clearance_m is not used) on a 5 cm square post from the ground to its centre.
struct SynthObject {
  SynthClass object_class = SynthClass::box;
  double x_m = 0;        // base centre, road frame: lateral (+ = right of the left camera)
  double z_m = 10;       // base centre, road frame: forward distance along the road
  double width_m = 0.4;  // across the road (diameter for round shapes)
  double height_m = 0.4;
  double length_m = 0.4;  // along the road (boxes; round shapes use width_m)
  double clearance_m = 0;  // board_on_poles, hanging_sign: the board's lower edge above the ground
};

// The lowest and highest point of the object's main part above the ground under its base centre:
// 0 and height_m for the standing classes; clearance_m (the ball: height_m - width_m) and height_m
// for the floating ones (their posts and wires reach lower, down to the ground).
double synth_object_min_height_m(const SynthObject& object);

// The standard test objects of the range test (issue 6): sizes in metres.
SynthObject synth_object(SynthClass object_class, double x_m, double z_m);

// The height-field ground (issue 9): any combination of the kinds below, each off when its amplitude
// is 0 (all off: today's flat or sloped road, rendered bit for bit as before). Heights in metres, up.
struct SynthGround {
  // Rolling hills: two sinusoidal swells, one along the road, one oblique (phases from the seed);
  // the elevation stays within +-hills_amplitude_m.
  double hills_amplitude_m = 0;
  double hills_wavelength_m = 35;
  // A ditch along the road (parallel to Z) centred at lateral X = ditch_x_m: V profile (depth at the
  // centre, 0 at +-width / 2), or U (parabolic) with ditch_u_shape.
  double ditch_depth_m = 0;
  double ditch_x_m = 6.5;
  double ditch_width_m = 2.5;
  bool ditch_u_shape = false;
  // A berm: a raised ridge along the road centred at X = berm_x_m, raised-cosine profile of base
  // width berm_width_m.
  double berm_height_m = 0;
  double berm_x_m = -7;
  double berm_width_m = 3;
  // Mining-like rough ground: 4 octaves of value noise (cells rough_wavelength_m / 2^k, amplitudes
  // halving), scaled so the elevation stays within +-rough_amplitude_m.
  double rough_amplitude_m = 0;
  double rough_wavelength_m = 6;

  bool any() const { return hills_amplitude_m > 0 || ditch_depth_m > 0 || berm_height_m > 0 || rough_amplitude_m > 0; }
};

// "flat", or kinds joined by '+' or ',': hills, ditch (V), ditch-u, berm, rough; each named kind gets
// its default size (hills 0.6 m over 35 m, ditch 0.6 m deep 2.5 m wide at X = 6.5 m, berm 0.8 m
// high 3 m wide at X = -7 m, rough 0.25 m over 6 m). Throws std::invalid_argument "ground: expected
// ..., got '<spec>'" otherwise.
SynthGround parse_synth_ground(const std::string& spec);

// The road's surface. textured: asphalt of strong grain at every scale (contrast about 30 % at 3 cm
// and still 15 % at 0.8 m), the generator's road since it exists: it gives a matcher texture at every
// distance. asphalt: the texture statistics of real asphalt, its aggregate a fine grain (4 and 12 mm
// cells, 15 % and 10 %) that blurs out within a few metres, 5 % at 5 cm, and 4 % patches of 2.5 m
// (wear, repairs, stains): smooth, low-contrast ground beyond a few metres, as real roads are under
// blur and sensor noise (docs/synth.md has how the amplitudes were chosen). The lane markings and
// verges are the same on both.
enum class SynthRoadSurface { textured, asphalt };
const char* synth_road_surface_name(SynthRoadSurface surface);
// "textured" or "asphalt"; throws std::invalid_argument "surface: expected textured or asphalt, got '...'".
SynthRoadSurface parse_synth_road_surface(const std::string& name);

struct StereoSynthOptions {
  int width = 1280;
  int height = 576;
  double hfov_deg = 60;          // horizontal field of view, degrees, (1, 170)
  double baseline_m = 0.30;      // > 0
  double camera_height_m = 1.5;  // above the road under the camera, > 0
  double pitch_rad = 0;          // + = looking down, |pitch| < 0.5
  double roll_rad = 0;           // about the optical axis, + = the right side down, |roll| < 0.5
  double slope_deg = 0;          // road slope beyond slope_start_m (+ = uphill), |slope| <= 10
  double slope_start_m = 20;     // where the slope starts, road Z
  double background_distance_m = 400;  // the far background wall (road Z); the road ends there
  int samples_per_axis = 2;      // anti-aliasing: samples_per_axis^2 rays per pixel, 1..4
  double noise_sigma = 0;        // Gaussian sensor noise, grey levels (each view independently)
  double right_gain = 1;         // the right camera's response: gain * value + offset, before noise
  double right_offset = 0;       // grey levels
  SynthRoadSurface road_surface = SynthRoadSurface::textured;
  // The lenses (0 = off, the scene renders bit for bit as without them): vignetting, the share of
  // light the left camera loses at the image corners, [0, 0.6] (the right camera loses
  // kRightVignettingRatio times as much: two lenses never match); blur_sigma_px, the optics' Gaussian
  // point spread in pixels, [0, 3], applied to the radiance before the sensor's gain and noise.
  double vignetting = 0;
  double blur_sigma_px = 0;
  bool colour = false;           // also render BGR views (left_colour, right_colour)
  // The camera's pose on the road (sequences move it through the fixed world): the left camera
  // centre at road (camera_x_m, camera_z_m), camera_height_m above the ground under it, heading
  // camera_yaw_rad (+ = turned right, towards +X) about the road's vertical, then pitch and roll as
  // above. All 0: the camera at the road frame's origin, rendered bit for bit as before.
  double camera_x_m = 0;
  double camera_z_m = 0;
  double camera_yaw_rad = 0;     // |yaw| <= pi
  uint32_t seed = 1;             // textures and noise (and random scenes, see random_synth_objects)
  int threads = 2;               // rows are shared between this many threads
  SynthGround ground;            // height field on the road (default: none)
  std::vector<SynthObject> objects;
};

inline constexpr double kRightVignettingRatio = 1.2;

// A camera pair as hard as a real one (docs/synth.md; `lpstereo synth --real-camera`): sensor noise 2
// grey levels, the right camera's gain 1.08 and offset -5 grey levels (auto-exposure per camera),
// vignetting 0.3, optics blur sigma 0.7 px. Sets those fields of `options` and nothing else.
void use_real_camera_pair(StereoSynthOptions& options);

// Throws std::invalid_argument "<option>: expected ..., got ..." for a value out of range.
void validate_synth_options(const StereoSynthOptions& options);

// A deterministic random scene: 6..14 objects of every class at random positions on the road
// (8 .. 80 m ahead, within the road's 10.5 m width), not overlapping.
std::vector<SynthObject> random_synth_objects(uint32_t seed);
// The range-test row at distance_m (road Z of the base centres): cone 0.30 m, can 0.19 m, box
// 0.43 m, tape roll 0.07 m, bin 1.10 m, pedestrian 1.70 m, 1.2 m apart across the road, centred on
// the camera.
std::vector<SynthObject> lineup_synth_objects(double distance_m);

struct SynthObjectTruth {
  int id = 0;  // the value in object_ids (1-based, in the order of options.objects)
  SynthObject object;
  double position_m[3] = {0, 0, 0};  // base centre in the LEFT CAMERA frame (x right, y down, z forward)
  double distance_m = 0;             // camera-frame depth z of the base centre
  double disparity_px = 0;           // f * B / distance_m
  double min_height_m = 0;           // synth_object_min_height_m
  double max_height_m = 0;           // height_m
  // The pixels that show the object (id image), inclusive [x0, y0, x1, y1]; visible_pixels = 0
  // (fully occluded or outside the view) leaves it {-1, -1, -1, -1}.
  int bbox_px[4] = {-1, -1, -1, -1};
  int64_t visible_pixels = 0;
};

struct StereoSynthScene {
  cv::Mat left, right;                // CV_8UC1
  cv::Mat left_colour, right_colour;  // CV_8UC3 BGR when options.colour, else empty
  cv::Mat disparity_px;               // CV_32FC1, left view, +inf = no ground truth (sky)
  cv::Mat object_ids;                 // CV_16UC1, 0 = road, background or sky
  std::vector<SynthObjectTruth> objects;
  StereoCalibration calibration;      // the rectified pinhole pair (already_rectified)
  double focal_px = 0;
};

// The left camera's pose in the road frame: road point = rotation * camera point + centre_m
// (rotation = Ry(yaw) Rx(pitch) Rz(roll), row-major; centre_m includes the camera's height over the
// ground at its position).
struct SynthCameraPose {
  double rotation[3][3];
  double centre_m[3];
};
SynthCameraPose synth_camera_pose(const StereoSynthOptions& options);

// Renders the scene; `progress` (if set) is called with the fraction of rows done, from any thread,
// one call at a time.
StereoSynthScene render_stereo_synth(const StereoSynthOptions& options,
                                     const std::function<void(double)>& progress = {});

// The exact ground-truth disparity of the road at a left-view pixel centre (ignoring objects),
// +inf where the ray does not meet the road before the background: the analytic reference (for a
// height-field ground, the ray-marched crossing the renderer uses).
double synth_road_disparity_px(const StereoSynthOptions& options, double u_px, double v_px);

// The true ground: its height at road-frame (x_m, z_m), metres up from the plane camera_height_m
// below the left camera (so 0 under the camera; the slope's rise beyond slope_start_m plus the
// height field). In arm/point_cloud.h's vehicle frame with the camera at (0, 0, camera_height_m) and
// no yaw, the ground is z_vehicle = height_m(x = -y_vehicle, z = x_vehicle).
class SynthGroundTruth {
 public:
  explicit SynthGroundTruth(const StereoSynthOptions& options);  // validates options.ground
  double height_m(double x_m, double z_m) const;
  // The height field alone (no slope), and bounds: |gradient| <= lipschitz(), elevation within
  // [min_elevation_m(), max_elevation_m()].
  double elevation_m(double x_m, double z_m) const;
  double lipschitz() const { return lipschitz_; }
  double max_elevation_m() const { return max_elevation_m_; }
  double min_elevation_m() const { return min_elevation_m_; }
  // For ray marching: the ditch and the berm only act within a strip of X; outside every strip the
  // field is the hills and the rough part alone, with these (smaller) bounds.
  struct Strip {
    double x_min_m, x_max_m;
    double raise_m;  // the most the strip raises the ground (0 for a ditch)
  };
  const std::vector<Strip>& strips() const { return strips_; }
  double smooth_lipschitz() const { return smooth_lipschitz_; }
  double smooth_max_elevation_m() const { return smooth_max_elevation_m_; }
  // For ray marching: elevation_m, the same value bit for bit, through a cache of the rough noise's
  // lattice cells (one per octave; a ray's consecutive steps mostly stay in the coarse octaves' cells).
  // A cache serves one SynthGroundTruth and one thread.
  struct NoiseCache;  // defined in stereo_synth.cpp (the renderer's march makes them)
  double elevation_m(double x_m, double z_m, NoiseCache& cache) const;

 private:
  double raw_elevation_m(double x_m, double z_m, NoiseCache* cache) const;
  SynthGround ground_;
  double slope_tan_ = 0, slope_start_m_ = 0;
  double hills_phase_[2] = {0, 0};
  uint64_t rough_seed_ = 0;
  double origin_elevation_m_ = 0;
  double lipschitz_ = 0, max_elevation_m_ = 0, min_elevation_m_ = 0;
  std::vector<Strip> strips_;
  double smooth_lipschitz_ = 0, smooth_max_elevation_m_ = 0;
};

// Writes left.png, right.png (grey; left_colour.png, right_colour.png too when rendered),
// disparity.png (KITTI 16-bit, x 256, 0 = no ground truth), object_ids.png (16-bit), objects.json
// (per object: position, size, distance, disparity, min/max_height_m, bbox, visible pixels),
// ground.json (the ground's parameters and its height sampled every 0.25 m over X in [-12, 12],
// Z in [0, 40] m: {"x_m": [...], "z_m": [...], "height_m": [[...]]}, height_m[i][j] at z_m[i], x_m[j]),
// calib.yaml (OpenCV, io::write_opencv_yaml) and calib_cam_to_cam.txt (KITTI P_rect_02/03,
// S_rect_02) into `directory`: first into a temporary sibling folder, renamed to `directory` when
// every file is written (an existing `directory` is replaced). Throws std::runtime_error naming the
// path on failure, leaving nothing behind.
void write_stereo_synth(const std::string& directory, const StereoSynthScene& scene, const StereoSynthOptions& options);

}  // namespace lpstereo::io
