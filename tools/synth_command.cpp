#include "tools/synth_command.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "tools/command_error.h"

namespace lpstereo::tools {

SynthCommand::SynthCommand(CLI::App& app) {
  command_ = app.add_subcommand("synth", "render a synthetic road scene as a rectified stereo pair with exact ground truth "
                                         "(docs/synth.md)");
  command_->add_option("-o,--output", output_, "folder to write (replaced if it exists)")->required();
  command_->add_option("--width", options_.width, "image width, px")->capture_default_str();
  command_->add_option("--height", options_.height, "image height, px")->capture_default_str();
  command_->add_option("--hfov-deg", options_.hfov_deg, "horizontal field of view, degrees")->capture_default_str();
  command_->add_option("--baseline-m", options_.baseline_m, "stereo baseline, metres")->capture_default_str();
  command_->add_option("--camera-height-m", options_.camera_height_m, "camera height above the road, metres")->capture_default_str();
  command_->add_option("--pitch-deg", pitch_deg_, "camera pitch, degrees (+ = looking down)")->capture_default_str();
  command_->add_option("--slope-deg", options_.slope_deg, "road slope beyond --slope-start-m, degrees (+ = uphill)")->capture_default_str();
  command_->add_option("--slope-start-m", options_.slope_start_m, "where the slope starts, metres ahead")->capture_default_str();
  command_->add_option("--noise-sigma", options_.noise_sigma, "Gaussian sensor noise, grey levels")->capture_default_str();
  command_->add_option("--gain", options_.right_gain, "right camera gain")->capture_default_str();
  command_->add_option("--offset", options_.right_offset, "right camera offset, grey levels")->capture_default_str();
  command_->add_option("--seed", options_.seed, "scene, texture and noise seed")->capture_default_str();
  command_->add_option("--samples", options_.samples_per_axis, "anti-aliasing: N x N rays per pixel")->capture_default_str();
  command_->add_option("--threads", options_.threads, "rendering threads")->capture_default_str();
  command_->add_flag("--colour,--color", options_.colour, "also write left_colour.png and right_colour.png");
  lineup_option_ = command_->add_option("--lineup", lineup_m_,
                                        "range-test row at this distance, metres: cone 0.30 m, can 0.19 m, box 0.43 m, "
                                        "tape roll 0.07 m, bin 1.10 m, pedestrian 1.70 m across the road");
  command_->add_flag("--empty", empty_, "no objects (false-positive tests)")->excludes(lineup_option_);
}

int SynthCommand::run() {
  // The library checks radians; the user gave degrees, so the message must speak degrees.
  if (!(std::abs(pitch_deg_) < 28.6)) {
    throw CommandError(kExitUsage, "--pitch-deg: expected |pitch| < 28.6 degrees, got " + std::to_string(pitch_deg_));
  }
  options_.pitch_rad = pitch_deg_ * 3.14159265358979323846 / 180.0;
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

  // A progress bar on a terminal only (logs and pipes get the summary line alone).
  const bool terminal = ::isatty(STDERR_FILENO) != 0;
  auto progress = [terminal](double fraction) {
    if (!terminal) return;
    const int filled = static_cast<int>(fraction * 40);
    std::fprintf(stderr, "\rrendering [%-40s] %3d %%", std::string(static_cast<size_t>(filled), '#').c_str(),
                 static_cast<int>(fraction * 100));
    if (fraction >= 1) std::fprintf(stderr, "\n");
  };
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
  std::printf("%dx%d, hfov %.1f deg (focal %.2f px), baseline %.3f m, camera height %.2f m, pitch %.2f deg, slope %.1f deg, "
              "%zu objects (%d visible), %d samples/pixel, noise %.1f: rendered in %.2f s on %d threads -> %s\n",
              options_.width, options_.height, options_.hfov_deg, scene.focal_px, options_.baseline_m, options_.camera_height_m,
              pitch_deg_, options_.slope_deg, scene.objects.size(), visible, options_.samples_per_axis * options_.samples_per_axis,
              options_.noise_sigma, render_s, options_.threads, output_.c_str());
  return 0;
}

}  // namespace lpstereo::tools
