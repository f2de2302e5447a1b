// lpstereo run --source SPEC --calib C [--calib C2] --graph disparity|obstacles [--frames N]
//     [--record DIR] [--out DIR] [--target cv1-class|none] [--timeout-ms T] [--fps F] [--realtime]
//     [--width W --height H --pixel-format F] [--pairing-tolerance-ms T] [--status-every N] [--threads T] [the disparity options]
//     [the obstacle tuning options of lpstereo obstacles]
// A stereo source (io/camera/stereo_source.h: v4l2:, v4l2-sbs:, libcamera:, files:) through a graph,
// pair after pair:
//   pair -> rectification with the calibration unless it says the views are already rectified (the
//   fixed-point remap of `lpstereo rectify`, tools/geometry_commands.h ViewRectifier)
//        -> arm::DisparityEngine (--graph disparity)
//        -> then arm::ObstacleDetector with tracking (--graph obstacles; frame period 1 / the source's
//           rate), records as `lpstereo obstacles` sequence mode writes them (obstacle_frame_json)
//           plus "frame" (the pair's index) and "timestamp_ns" (the left view's capture time).
// Status on stderr, refreshed in place on a terminal, a plain line every --status-every frames
// otherwise: fps in (pairs from the source), fps out (pairs processed), dropped (driver drops +
// unpaired frames + pairs skipped because processing lagged), latency (live: CLOCK_MONOTONIC now
// minus the left capture timestamp when the pair is done; recordings: the processing time) and the
// simulated cost on --target: the same graphs (rectification when used, the engine, the detector)
// profiled once on the first pair at its size with host_sim (host_sim/simulator.h), against the
// budget of the source's frame rate (30 fps when it has none):
//   "cv1-class 412.3 ms/frame (budget 100.0 ms at 10 fps: over)".
// Live sources (and recordings with --realtime, replayed at their frame rate with CLOCK_MONOTONIC
// timestamps) are read on a capture thread that keeps only the newest pair: a pair the processing
// has not taken when the next arrives is skipped (counted). Recordings without --realtime are
// processed pair by pair, none skipped.
// Outputs: --out DIR: DIR/disparity/%06d.png (KITTI 16-bit), DIR/disparity_color/%06d.png (the colour
// view of `lpstereo disparity --color`) and, for obstacles, DIR/obstacles.jsonl, one line per pair,
// each written as the pair is done. --record DIR (new or empty): the raw pairs as they come, lossless
// PNG DIR/left/%06d.png and DIR/right/%06d.png (by pair index), and DIR/timestamps.txt
// ("index left_timestamp_ns right_timestamp_ns left_sequence right_sequence" per line, flushed per
// pair), so `--source files:DIR/left/%06d.png,DIR/right/%06d.png` replays them; every file is
// complete on every way out (end, --frames, SIGINT/SIGTERM: the run stops after the current pair,
// a disconnect, a stall, an error).
// Exit codes: 0 done (end of stream, --frames reached, SIGINT/SIGTERM); 1 bad input (a source that
// cannot be opened, views of different sizes, a missing or unreadable file mid-sequence, a
// calibration that does not fit), a disconnect, or no pair within --timeout-ms (a stalled stream),
// each one line; 2 bad usage (an unparseable --source among them). A summary on stdout at the end:
// frames, why the run ended, fps, drops, latency and the budget line.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "arm/obstacle_detector.h"
#include "tools/disparity_options.h"

namespace lpstereo::tools {

class RunCommand {
 public:
  explicit RunCommand(CLI::App& app);
  bool selected() const { return command_ != nullptr && command_->parsed(); }
  int run() const;  // throws CommandError (one line) on bad input

 private:
  CLI::App* command_ = nullptr;
  std::string source_spec_;
  std::vector<std::string> calibration_files_;
  std::string graph_ = "disparity";
  int frame_limit_ = 0;  // 0: until the source ends
  std::string record_directory_, out_directory_;
  std::string target_name_ = "cv1-class";  // "none": no budget line
  int timeout_ms_ = 5000;
  double fps_ = 0;                  // SourceOptions.frame_rate_hz (0: the source's own; recordings 10)
  int width_ = 0, height_ = 0;      // requested size of a live source (0: the device's)
  std::string pixel_format_;
  double pairing_tolerance_ms_ = -1;  // SourceOptions.pairing_tolerance_ns in ms (-1: half the frame period)
  bool realtime_ = false;
  int status_every_ = 10;
  int threads_ = 0;
  int in_flight_ = 0;  // tools/disparity_lanes.h (0: resolved_lanes)
  DisparityEngineOptions engine_options_{arm::obstacle_disparity_defaults()};
  arm::ObstacleParameters detector_parameters_;
};

}  // namespace lpstereo::tools
