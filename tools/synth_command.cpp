#include "tools/synth_command.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "tools/command_error.h"

namespace lpstereo::tools {

SynthCommand::SynthCommand(CLI::App& app) {
  command_ = app.add_subcommand("synth", "render a synthetic road scene (or, with --flight, a downward-looking drone flight) as "
                                         "a rectified stereo pair with exact ground truth (docs/synth.md)");
  command_->add_option("-o,--output", output_, "folder to write (replaced if it exists)")->required();
  command_->add_option("--width", options_.width, "image width, px")->capture_default_str();
  command_->add_option("--height", options_.height, "image height, px")->capture_default_str();
  command_->add_option("--hfov-deg", options_.hfov_deg, "horizontal field of view, degrees")->capture_default_str();
  command_->add_option("--baseline-m", options_.baseline_m, "stereo baseline, metres")->capture_default_str();
  road_only_.push_back(
      command_->add_option("--camera-height-m", options_.camera_height_m, "camera height above the road, metres")->capture_default_str());
  road_only_.push_back(command_->add_option("--pitch-deg", pitch_deg_, "camera pitch, degrees (+ = looking down)")->capture_default_str());
  road_only_.push_back(
      command_->add_option("--roll-deg", roll_deg_, "camera roll about the optical axis, degrees (+ = the right side down)")->capture_default_str());
  road_only_.push_back(command_->add_option("--ground", ground_spec_,
                                            "ground: flat, or a height field of hills, ditch (V), ditch-u, berm, rough joined by '+' "
                                            "(e.g. hills+ditch+berm); ground.json holds its true height")
                           ->capture_default_str());
  using G = io::SynthGround;
  const std::pair<const char*, double G::*> sizes[] = {
      {"--hills-amplitude-m", &G::hills_amplitude_m}, {"--hills-wavelength-m", &G::hills_wavelength_m},
      {"--ditch-depth-m", &G::ditch_depth_m},         {"--ditch-x-m", &G::ditch_x_m},
      {"--ditch-width-m", &G::ditch_width_m},         {"--berm-height-m", &G::berm_height_m},
      {"--berm-x-m", &G::berm_x_m},                   {"--berm-width-m", &G::berm_width_m},
      {"--rough-amplitude-m", &G::rough_amplitude_m}, {"--rough-wavelength-m", &G::rough_wavelength_m}};
  for (const auto& [name, member] : sizes) {
    CLI::Option* option = command_->add_option(name, ground_sizes_given_.*member,
                                               "ground size, metres (replaces the --ground kind's default; an amplitude, depth or "
                                               "height alone adds that kind)");
    road_only_.push_back(option);
    ground_sizes_.emplace_back(option, member);
  }
  road_only_.push_back(
      command_->add_option("--slope-deg", options_.slope_deg, "road slope beyond --slope-start-m, degrees (+ = uphill)")->capture_default_str());
  road_only_.push_back(
      command_->add_option("--slope-start-m", options_.slope_start_m, "where the slope starts, metres ahead")->capture_default_str());
  command_->add_option("--noise-sigma,--noise", options_.noise_sigma, "Gaussian sensor noise, grey levels")->capture_default_str();
  command_->add_option("--gain", options_.right_gain, "right camera gain")->capture_default_str();
  command_->add_option("--offset", options_.right_offset, "right camera offset, grey levels")->capture_default_str();
  road_only_.push_back(command_->add_option("--surface", surface_,
                                            "road surface: textured (strong grain at every scale) or asphalt (real asphalt's "
                                            "statistics: fine grain that blurs out within metres, low contrast beyond; docs/synth.md)")
                           ->capture_default_str());
  road_only_.push_back(command_->add_option("--vignetting", options_.vignetting,
                                            "share of light the left lens loses at the image corners, 0..0.6 (the right lens loses "
                                            "1.2 times as much)")
                           ->capture_default_str());
  road_only_.push_back(
      command_->add_option("--blur-px", options_.blur_sigma_px, "optics blur: Gaussian point spread sigma, px, 0..3")->capture_default_str());
  road_only_.push_back(command_->add_flag("--real-camera", real_camera_,
                                          "a camera pair as hard as a real one: --noise 2 --gain 1.08 --offset -5 --vignetting 0.3 "
                                          "--blur-px 0.7 (those options, when also given, override it)"));
  command_->add_option("--seed", options_.seed, "scene, texture and noise seed")->capture_default_str();
  command_->add_option("--samples", options_.samples_per_axis, "anti-aliasing: N x N rays per pixel")->capture_default_str();
  command_->add_option("--threads", options_.threads, "rendering threads")->capture_default_str();
  road_only_.push_back(command_->add_flag("--colour,--color", options_.colour, "also write left_colour.png and right_colour.png"));
  lineup_option_ = command_->add_option("--lineup", lineup_m_,
                                        "range-test row at this distance, metres: cone 0.30 m, can 0.19 m, box 0.43 m, "
                                        "tape roll 0.07 m, bin 1.10 m, pedestrian 1.70 m across the road");
  road_only_.push_back(lineup_option_);
  road_only_.push_back(command_->add_flag("--empty", empty_, "no objects (false-positive tests)")->excludes(lineup_option_));

  // The drone flight (io/stereo_flight.h); --width --height --hfov-deg --baseline-m default to the
  // flight's own values (640x480, 90 degrees, 0.10 m) when not given.
  command_->add_flag("--flight", flight_,
                     "a downward-looking drone flight instead of the road: take-off from a 1 m pad, a square through four "
                     "waypoints, return, landing (frames in DIR/left, DIR/right, poses.txt, ...)");
  io::StereoFlightOptions& f = flight_options_;
  CLI::Option* frames = command_->add_option("--frames", f.frames, "--flight: this many frames over the whole flight; --sequence: frames");
  flight_only_.push_back(frames);
  flight_only_.push_back(command_->add_option("--fps", f.fps, "--flight, --sequence: frame rate, frames per second")->capture_default_str());
  flight_only_.push_back(command_->add_option("--yaw", yaw_spec_,
                                              "--flight: none, corners:DEG[,DEG,DEG,DEG] (turns at the waypoints, + = counter-"
                                              "clockwise seen from above) or continuous:DEG_PER_S")
                             ->capture_default_str());
  flight_only_.push_back(command_->add_option("--yaw-rate-deg-s", f.yaw_rate_deg_s, "--flight: peak yaw rate of a corner turn")
                             ->capture_default_str());
  flight_only_.push_back(command_->add_option("--side-m", f.side_m, "--flight: side of the square route, metres")->capture_default_str());
  flight_only_.push_back(
      command_->add_option("--altitude-m", f.altitude_m, "--flight: cruise height of the cameras above the ground, metres")->capture_default_str());
  flight_only_.push_back(command_->add_option("--start-height-m", f.start_height_m,
                                              "--flight: camera height above the ground standing on the pad, metres")
                             ->capture_default_str());
  flight_only_.push_back(command_->add_option("--speed-mps", f.speed_mps, "--flight: peak speed of a leg, m/s")->capture_default_str());
  flight_only_.push_back(
      command_->add_option("--climb-speed-mps", f.climb_speed_mps, "--flight: peak speed of take-off and landing, m/s")->capture_default_str());
  flight_only_.push_back(command_->add_option("--focal-px", focal_px_, "--flight: focal length, px (instead of --hfov-deg)"));
  flight_only_.push_back(command_->add_flag("--disparity", flight_disparity_, "--flight: also write DIR/disparity/%06d.png (KITTI, exact)"));

  // The road sequence (io/stereo_sequence.h).
  command_->add_option("--sequence", sequence_,
                       "a sequence driving through a preset scene with moving objects: urban (flat), country (hills), mining "
                       "(rough, berm) or floating (a board on poles, a hanging sign, a ball on a post); frames in DIR/left, ...");
  sequence_only_.push_back(
      command_->add_option("--camera-speed-mps", camera_speed_mps_, "--sequence: camera speed, m/s (default: the preset's)"));
  sequence_only_.push_back(
      command_->add_option("--camera-yaw-rate-deg-s", camera_yaw_rate_deg_s_, "--sequence: camera yaw rate, degrees/s (+ = turning right)"));
}

namespace {

// "none", "corners:A[,B,C,D]" (one angle for all four corners, or four), "continuous:R".
void parse_yaw(const std::string& spec, io::StereoFlightOptions& options) {
  const std::string expected = "--yaw: expected none, corners:DEG[,DEG,DEG,DEG] or continuous:DEG_PER_S, got '" + spec + "'";
  auto parse_numbers = [&](const std::string& text) {
    std::vector<double> values;
    size_t start = 0;
    for (;;) {
      const size_t comma = text.find(',', start);
      const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      size_t used = 0;
      double value = 0;
      try {
        value = std::stod(item, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (item.empty() || used != item.size() || !std::isfinite(value)) throw CommandError(kExitUsage, expected);
      values.push_back(value);
      if (comma == std::string::npos) return values;
      start = comma + 1;
    }
  };
  if (spec == "none") {
    options.yaw_mode = io::FlightYawMode::none;
  } else if (spec.rfind("corners:", 0) == 0) {
    const std::vector<double> angles = parse_numbers(spec.substr(8));
    if (angles.size() != 1 && angles.size() != 4) throw CommandError(kExitUsage, expected);
    options.yaw_mode = io::FlightYawMode::corners;
    for (size_t i = 0; i < 4; ++i) options.corner_yaw_deg[i] = angles[angles.size() == 1 ? 0 : i];
  } else if (spec.rfind("continuous:", 0) == 0) {
    const std::vector<double> rate = parse_numbers(spec.substr(11));
    if (rate.size() != 1) throw CommandError(kExitUsage, expected);
    options.yaw_mode = io::FlightYawMode::continuous;
    options.continuous_yaw_deg_s = rate[0];
  } else {
    throw CommandError(kExitUsage, expected);
  }
}

// A progress bar on a terminal only (logs and pipes get the summary line alone).
std::function<void(double)> progress_bar(const char* what) {
  const bool terminal = ::isatty(STDERR_FILENO) != 0;
  return [terminal, what](double fraction) {
    if (!terminal) return;
    const int filled = static_cast<int>(fraction * 40);
    std::fprintf(stderr, "\r%s [%-40s] %3d %%", what, std::string(static_cast<size_t>(filled), '#').c_str(),
                 static_cast<int>(fraction * 100));
    if (fraction >= 1) std::fprintf(stderr, "\n");
  };
}

}  // namespace

int SynthCommand::run_flight() {
  io::StereoFlightOptions& f = flight_options_;
  for (CLI::Option* option : sequence_only_) {
    if (option->count() > 0) throw CommandError(kExitUsage, option->get_name() + ": a --sequence option, not for --flight");
  }
  if (command_->get_option("--fps")->count() > 0 && command_->get_option("--frames")->count() > 0) {
    throw CommandError(kExitUsage, "--fps: give it or --frames for --flight, not both");
  }
  for (CLI::Option* option : road_only_) {
    if (option->count() > 0) throw CommandError(kExitUsage, option->get_name() + ": a road-scene option, not for --flight");
  }
  auto given = [this](const char* name) { return command_->get_option(name)->count() > 0; };
  if (given("--width")) f.width = options_.width;
  if (given("--height")) f.height = options_.height;
  if (given("--baseline-m")) f.baseline_m = options_.baseline_m;
  if (given("--hfov-deg")) f.hfov_deg = options_.hfov_deg;
  if (given("--focal-px")) {
    if (given("--hfov-deg")) throw CommandError(kExitUsage, "--focal-px: give it or --hfov-deg, not both");
    if (!(focal_px_ > 1 && focal_px_ < 1e6)) {
      throw CommandError(kExitUsage, "--focal-px: expected a focal length in (1, 1e6) px, got " + std::to_string(focal_px_));
    }
    f.hfov_deg = 2 * std::atan(f.width / 2.0 / focal_px_) * 180 / 3.14159265358979323846;
  }
  f.noise_sigma = options_.noise_sigma;
  f.right_gain = options_.right_gain;
  f.right_offset = options_.right_offset;
  f.seed = options_.seed;
  f.samples_per_axis = options_.samples_per_axis;
  f.threads = options_.threads;
  parse_yaw(yaw_spec_, f);
  io::FlightPlan plan;
  try {
    plan = io::plan_flight(f);
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, std::string("--") + error.what());
  }
  const auto start = std::chrono::steady_clock::now();
  try {
    io::write_stereo_flight(output_, f, flight_disparity_, progress_bar("rendering flight"));
  } catch (const std::exception& error) {
    throw CommandError(kExitInput, error.what());
  }
  const double render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const size_t frames = plan.frame_times_s.size();
  std::printf("flight: %dx%d, hfov %.1f deg (focal %.2f px), baseline %.3f m, square %.1f m at %.2f m from %.2f m, yaw %s, "
              "%zu frames over %.1f s, %d samples/pixel, noise %.1f: rendered in %.2f s (%.1f ms per frame) on %d threads -> %s\n",
              f.width, f.height, f.hfov_deg, io::flight_focal_px(f), f.baseline_m, f.side_m, f.altitude_m, f.start_height_m,
              yaw_spec_.c_str(), frames, plan.duration_s, f.samples_per_axis * f.samples_per_axis, f.noise_sigma, render_s,
              1000 * render_s / static_cast<double>(frames), f.threads, output_.c_str());
  return 0;
}

void SynthCommand::apply_mount_and_ground(io::StereoSynthOptions& target, bool parse_ground) const {
  // The library checks radians; the user gave degrees, so the message must speak degrees.
  if (!(std::abs(pitch_deg_) < 28.6)) {
    throw CommandError(kExitUsage, "--pitch-deg: expected |pitch| < 28.6 degrees, got " + std::to_string(pitch_deg_));
  }
  target.pitch_rad = pitch_deg_ * 3.14159265358979323846 / 180.0;
  if (!(std::abs(roll_deg_) < 28.6)) {
    throw CommandError(kExitUsage, "--roll-deg: expected |roll| < 28.6 degrees, got " + std::to_string(roll_deg_));
  }
  target.roll_rad = roll_deg_ * 3.14159265358979323846 / 180.0;
  if (parse_ground) {
    try {
      target.ground = io::parse_synth_ground(ground_spec_);
    } catch (const std::invalid_argument& error) {
      throw CommandError(kExitUsage, std::string("--") + error.what());
    }
  }
  for (const auto& [option, member] : ground_sizes_) {
    if (option->count() > 0) target.ground.*member = ground_sizes_given_.*member;
  }
}

int SynthCommand::run_sequence() {
  if (flight_) throw CommandError(kExitUsage, "--sequence: give it or --flight, not both");
  for (CLI::Option* option : flight_only_) {
    const std::string name = option->get_name();
    if (option->count() > 0 && name != "--frames" && name != "--fps") {
      throw CommandError(kExitUsage, name + ": a --flight option, not for --sequence");
    }
  }
  for (CLI::Option* option : {lineup_option_, command_->get_option("--empty")}) {
    if (option->count() > 0) throw CommandError(kExitUsage, option->get_name() + ": not for --sequence (the preset places the objects)");
  }
  io::StereoSequenceOptions sequence;
  try {
    sequence = io::preset_stereo_sequence(sequence_, options_.seed);
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, std::string("--") + error.what());
  }
  // The preset's scene with the user's camera and sensor.
  io::StereoSynthOptions& b = sequence.base;
  auto given = [this](const char* name) { return command_->get_option(name)->count() > 0; };
  if (given("--width")) b.width = options_.width;
  if (given("--height")) b.height = options_.height;
  if (given("--hfov-deg")) b.hfov_deg = options_.hfov_deg;
  if (given("--baseline-m")) b.baseline_m = options_.baseline_m;
  if (given("--camera-height-m")) b.camera_height_m = options_.camera_height_m;
  apply_mount_and_ground(b, given("--ground"));
  if (given("--slope-deg")) b.slope_deg = options_.slope_deg;
  if (given("--slope-start-m")) b.slope_start_m = options_.slope_start_m;
  b.noise_sigma = options_.noise_sigma;
  b.right_gain = options_.right_gain;
  b.right_offset = options_.right_offset;
  b.road_surface = road_surface();
  b.vignetting = options_.vignetting;
  b.blur_sigma_px = options_.blur_sigma_px;
  b.samples_per_axis = options_.samples_per_axis;
  b.threads = options_.threads;
  b.colour = options_.colour;
  if (given("--frames")) sequence.frames = flight_options_.frames;
  if (given("--fps")) sequence.fps = flight_options_.fps;
  if (given("--camera-speed-mps")) sequence.camera_speed_mps = camera_speed_mps_;
  sequence.yaw_rate_rad_s = camera_yaw_rate_deg_s_ * 3.14159265358979323846 / 180.0;
  try {
    io::validate_stereo_sequence(sequence);
  } catch (const std::invalid_argument& error) {
    std::string message = error.what();
    if (message.rfind("yaw-rate", 0) == 0) {
      message = "camera-yaw-rate-deg-s: expected |rate| <= 57.3 degrees/s, got " + std::to_string(camera_yaw_rate_deg_s_);
    }
    throw CommandError(kExitUsage, "--" + message);
  }
  const auto start = std::chrono::steady_clock::now();
  try {
    io::write_stereo_sequence(output_, sequence, progress_bar("rendering sequence"));
  } catch (const std::exception& error) {
    throw CommandError(kExitInput, error.what());
  }
  const double render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("sequence %s: %dx%d, hfov %.1f deg, baseline %.3f m, %d frames at %.1f fps, camera %.1f m/s, %zu static and %zu moving "
              "objects, %d samples/pixel, noise %.1f: rendered in %.2f s (%.1f ms per frame) on %d threads -> %s\n",
              sequence_.c_str(), b.width, b.height, b.hfov_deg, b.baseline_m, sequence.frames, sequence.fps, sequence.camera_speed_mps,
              b.objects.size(), sequence.moving.size(), b.samples_per_axis * b.samples_per_axis, b.noise_sigma, render_s,
              1000 * render_s / sequence.frames, b.threads, output_.c_str());
  return 0;
}

io::SynthRoadSurface SynthCommand::road_surface() const {
  try {
    return io::parse_synth_road_surface(surface_);
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, std::string("--") + error.what());
  }
}

void SynthCommand::apply_real_camera() {
  if (!real_camera_) return;
  const io::StereoSynthOptions given = options_;
  io::use_real_camera_pair(options_);
  const std::pair<const char*, double io::StereoSynthOptions::*> fields[] = {
      {"--noise-sigma", &io::StereoSynthOptions::noise_sigma}, {"--gain", &io::StereoSynthOptions::right_gain},
      {"--offset", &io::StereoSynthOptions::right_offset},     {"--vignetting", &io::StereoSynthOptions::vignetting},
      {"--blur-px", &io::StereoSynthOptions::blur_sigma_px}};
  for (const auto& [name, field] : fields) {
    if (command_->get_option(name)->count() > 0) options_.*field = given.*field;
  }
}

int SynthCommand::run() {
  apply_real_camera();
  if (command_->get_option("--sequence")->count() > 0) return run_sequence();
  if (flight_) return run_flight();
  for (CLI::Option* option : sequence_only_) {
    if (option->count() > 0) throw CommandError(kExitUsage, option->get_name() + ": a --sequence option, not for the road scene");
  }
  for (CLI::Option* option : flight_only_) {
    if (option->count() > 0) throw CommandError(kExitUsage, option->get_name() + ": a --flight option, not for the road scene");
  }
  apply_mount_and_ground(options_, true);
  options_.road_surface = road_surface();
  if (lineup_option_->count() > 0) {
    if (!(lineup_m_ > 0 && lineup_m_ < options_.background_distance_m)) {
      throw CommandError(kExitUsage, "--lineup: expected a distance in (0, " + std::to_string(options_.background_distance_m) +
                                         ") metres, got " + std::to_string(lineup_m_));
    }
    options_.objects = io::lineup_synth_objects(lineup_m_);
  } else if (!empty_) {
    options_.objects = io::random_synth_objects(options_.seed);
  }
  try {
    io::validate_synth_options(options_);
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, std::string("--") + error.what());
  }

  const auto progress = progress_bar("rendering");
  const auto start = std::chrono::steady_clock::now();
  const io::StereoSynthScene scene = io::render_stereo_synth(options_, progress);
  const double render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  try {
    io::write_stereo_synth(output_, scene, options_);
  } catch (const std::exception& error) {
    throw CommandError(kExitInput, error.what());
  }
  int visible = 0;
  for (const io::SynthObjectTruth& object : scene.objects) visible += object.visible_pixels > 0 ? 1 : 0;
  std::printf("%dx%d, hfov %.1f deg (focal %.2f px), baseline %.3f m, camera height %.2f m, pitch %.2f deg, roll %.2f deg, "
              "slope %.1f deg, ground %s, surface %s, %zu objects (%d visible), %d samples/pixel, noise %.1f, vignetting %.2f, blur %.2f px: "
              "rendered in %.2f s on %d threads -> %s\n",
              options_.width, options_.height, options_.hfov_deg, scene.focal_px, options_.baseline_m, options_.camera_height_m,
              pitch_deg_, roll_deg_, options_.slope_deg, ground_spec_.c_str(), surface_.c_str(), scene.objects.size(), visible,
              options_.samples_per_axis * options_.samples_per_axis, options_.noise_sigma, options_.vignetting, options_.blur_sigma_px,
              render_s, options_.threads, output_.c_str());
  return 0;
}

}  // namespace lpstereo::tools
