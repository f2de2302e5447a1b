#include "tools/run_command.h"

#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <deque>
#include <exception>
#include <filesystem>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "arm/disparity_engine.h"
#include "arm/obstacle_detector.h"
#include "arm/scheduler.h"
#include "host_sim/simulator.h"
#include "host_sim/target.h"
#include "io/camera/stereo_source.h"
#include "io/disparity_io.h"
#include "io/image_io.h"
#include "io/rectification.h"
#include "tools/command_error.h"
#include "tools/disparity_lanes.h"
#include "tools/geometry_commands.h"
#include "tools/obstacles_command.h"
#include "tools/target_profile.h"

namespace lpstereo::tools {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double milliseconds(Clock::duration duration) { return std::chrono::duration<double, std::milli>(duration).count(); }

// CLOCK_MONOTONIC now, ns: the clock V4L2 and libcamera stamp their buffers with.
int64_t monotonic_now_ns() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1000000000 + now.tv_nsec;
}

std::string frame_name(uint64_t index) {
  char name[32];
  std::snprintf(name, sizeof name, "%06llu.png", static_cast<unsigned long long>(index));
  return name;
}

// SIGINT and SIGTERM ask the run to stop after the current pair (so that every output is complete);
// the previous handlers come back when the run ends.
std::atomic<int> stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "set from a signal handler");

class StopOnSignals {
 public:
  StopOnSignals() {
    stop_signal = 0;
    struct sigaction action {};
    action.sa_handler = [](int signal_number) { stop_signal = signal_number; };
    sigemptyset(&action.sa_mask);
    ::sigaction(SIGINT, &action, &previous_interrupt_);
    ::sigaction(SIGTERM, &action, &previous_terminate_);
  }
  ~StopOnSignals() {
    ::sigaction(SIGINT, &previous_interrupt_, nullptr);
    ::sigaction(SIGTERM, &previous_terminate_, nullptr);
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

 private:
  struct sigaction previous_interrupt_ {}, previous_terminate_ {};
};

// A recording replayed as a live camera (--realtime): each pair is held back until its timestamp
// (relative to the first pair's) has passed on CLOCK_MONOTONIC, and leaves stamped with that time.
class RealtimeReplay : public io::StereoSource {
 public:
  explicit RealtimeReplay(std::unique_ptr<io::StereoSource> recording) : recording_(std::move(recording)) {}
  std::string description() const override { return recording_->description() + ", replayed in real time"; }
  int width() const override { return recording_->width(); }
  int height() const override { return recording_->height(); }
  double frame_rate_hz() const override { return recording_->frame_rate_hz(); }
  io::SourceStatistics statistics() const override { return recording_->statistics(); }

  io::SourceResult next(std::chrono::milliseconds timeout) override {
    if (!pending_) {
      io::SourceResult result = recording_->next(timeout);
      if (result.status != io::SourceStatus::frame) return result;
      pending_ = std::move(result);
      if (first_recorded_ns_ < 0) {
        first_recorded_ns_ = pending_->frame.left_timestamp_ns;
        first_replayed_ns_ = monotonic_now_ns();
      }
    }
    const int64_t due_ns = first_replayed_ns_ + (pending_->frame.left_timestamp_ns - first_recorded_ns_);
    const int64_t wait_ns = due_ns - monotonic_now_ns();
    if (wait_ns > std::chrono::nanoseconds(timeout).count()) {
      std::this_thread::sleep_for(timeout);
      return {io::SourceStatus::timeout, {}, "the next recorded pair is not due yet"};
    }
    if (wait_ns > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(wait_ns));
    io::SourceResult result = std::move(*pending_);
    pending_.reset();
    result.frame.right_timestamp_ns += due_ns - result.frame.left_timestamp_ns;
    result.frame.left_timestamp_ns = due_ns;
    return result;
  }

 private:
  std::unique_ptr<io::StereoSource> recording_;
  std::optional<io::SourceResult> pending_;
  int64_t first_recorded_ns_ = -1, first_replayed_ns_ = 0;
};

// --record DIR: the raw pairs as lossless PNG and one timestamps line per pair, each pair complete
// (both images written, renamed into place, then its line flushed) before the next.
class Recorder {
 public:
  explicit Recorder(const std::string& directory) : directory_(directory) {
    std::error_code error;
    if (fs::exists(directory_, error) && !(fs::is_directory(directory_, error) && fs::is_empty(directory_, error))) {
      throw CommandError(kExitInput, "--record " + directory + ": expected a new or empty folder (a recording is never mixed "
                                     "with an older one), got an existing " +
                                         std::string(fs::is_directory(directory_, error) ? "folder with files" : "file"));
    }
    for (const char* view : {"left", "right"}) {
      fs::create_directories(directory_ / view, error);
      if (error) throw CommandError(kExitInput, "--record " + (directory_ / view).string() + ": cannot create: " + error.message());
    }
    const std::string timestamps = (directory_ / "timestamps.txt").string();
    timestamps_ = std::fopen(timestamps.c_str(), "w");
    if (timestamps_ == nullptr) throw CommandError(kExitInput, "--record " + timestamps + ": cannot create");
    std::fprintf(timestamps_, "# index left_timestamp_ns right_timestamp_ns left_sequence right_sequence\n");
    std::fflush(timestamps_);
  }
  ~Recorder() { std::fclose(timestamps_); }
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  void record(const io::StereoFrame& pair) {
    io::write_image((directory_ / "left" / frame_name(pair.index)).string(), io::plane_to_mat(pair.left));
    io::write_image((directory_ / "right" / frame_name(pair.index)).string(), io::plane_to_mat(pair.right));
    std::fprintf(timestamps_, "%llu %lld %lld %llu %llu\n", static_cast<unsigned long long>(pair.index),
                 static_cast<long long>(pair.left_timestamp_ns), static_cast<long long>(pair.right_timestamp_ns),
                 static_cast<unsigned long long>(pair.left_sequence), static_cast<unsigned long long>(pair.right_sequence));
    std::fflush(timestamps_);
    ++pairs_;
  }
  uint64_t pairs() const { return pairs_; }
  const fs::path& directory() const { return directory_; }

 private:
  fs::path directory_;
  std::FILE* timestamps_ = nullptr;
  uint64_t pairs_ = 0;
};

// Events per second over the last `window` events (the status line's fps in and fps out).
class RateMeter {
 public:
  void add(Clock::time_point when) {
    times_.push_back(when);
    if (times_.size() > kWindow) times_.pop_front();
  }
  double per_second() const {
    if (times_.size() < 2) return 0.0;
    const double seconds = std::chrono::duration<double>(times_.back() - times_.front()).count();
    return seconds > 0 ? static_cast<double>(times_.size() - 1) / seconds : 0.0;
  }

 private:
  static constexpr size_t kWindow = 30;
  std::deque<Clock::time_point> times_;
};

// How a source's read ended (or a pair arrived), as the main loop sees it in both modes.
struct Arrival {
  io::SourceResult result;
  std::string failure;  // a SourceError (or a recording failure) while reading: the run ends with it
};

// A live source read on its own thread: every pair is recorded (--record) as it comes; only the
// newest waits for processing, an older one not yet taken is skipped (counted). Bounded waits only:
// the source's next() with at most 100 ms, so stop() returns promptly; no pair for `stall_timeout`
// ends the feed with a timeout.
class CaptureThread {
 public:
  CaptureThread(io::StereoSource& source, std::chrono::milliseconds stall_timeout, Recorder* recorder)
      : source_(source), stall_timeout_(stall_timeout), recorder_(recorder), thread_([this] { loop(); }) {}
  ~CaptureThread() { stop(); }
  CaptureThread(const CaptureThread&) = delete;
  CaptureThread& operator=(const CaptureThread&) = delete;

  void stop() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    if (thread_.joinable()) thread_.join();
  }

  // The newest pair or the feed's end, waiting at most `wait`; nullopt when neither came.
  std::optional<Arrival> take(std::chrono::milliseconds wait) {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, wait, [this] { return newest_.has_value() || end_.has_value(); });
    if (newest_) {
      Arrival arrival{std::move(*newest_), ""};
      newest_.reset();
      return arrival;
    }
    if (end_) return *end_;
    return std::nullopt;
  }

  uint64_t skipped() const {
    std::lock_guard lock(mutex_);
    return skipped_;
  }
  io::SourceStatistics statistics() const {
    std::lock_guard lock(mutex_);
    return statistics_;
  }
  double fps_in() const {
    std::lock_guard lock(mutex_);
    return arrivals_.per_second();
  }

 private:
  void loop() {
    Clock::time_point last_pair = Clock::now();
    for (;;) {
      {
        std::lock_guard lock(mutex_);
        if (stopping_) return;
      }
      Arrival arrival;
      try {
        arrival.result = source_.next(std::min(stall_timeout_, std::chrono::milliseconds(100)));
        if (arrival.result.status == io::SourceStatus::frame && recorder_ != nullptr) recorder_->record(arrival.result.frame);
      } catch (const std::exception& error) {
        arrival.failure = error.what();
      }
      const Clock::time_point now = Clock::now();
      const bool stalled = arrival.result.status == io::SourceStatus::timeout && now - last_pair >= stall_timeout_;
      std::lock_guard lock(mutex_);
      statistics_ = source_.statistics();
      if (arrival.failure.empty() && arrival.result.status == io::SourceStatus::frame) {
        last_pair = now;
        arrivals_.add(now);
        if (newest_) ++skipped_;
        newest_ = std::move(arrival.result);
      } else if (!arrival.failure.empty() || arrival.result.status != io::SourceStatus::timeout || stalled) {
        end_ = std::move(arrival);
        changed_.notify_all();
        return;
      }
      changed_.notify_all();
    }
  }

  io::StereoSource& source_;
  const std::chrono::milliseconds stall_timeout_;
  Recorder* const recorder_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool stopping_ = false;
  std::optional<io::SourceResult> newest_;
  std::optional<Arrival> end_;
  uint64_t skipped_ = 0;
  io::SourceStatistics statistics_;
  RateMeter arrivals_;
  std::thread thread_;  // last: started once every member above exists
};

// The simulated cost per frame on the target of what the run does to a pair: the rectification
// graph (when the views are rectified), the engine's graph in the chip's schedule and the detector's
// graph, each profiled on this pair (host_sim::profile_graph) and added up (they run one after the
// other on the chip). One line: "cv1-class 412.3 ms/frame (budget 100.0 ms at 10 fps: over)".
std::string budget_line(const host_sim::Target& target, double fps, int threads, const std::vector<std::string>& calibration_files,
                        const io::StereoFrame& raw, const Plane* rectified_left, const Plane* rectified_right,
                        const arm::DisparityParameters& disparity_parameters, const Plane& disparity,
                        const arm::ObstacleParameters* detector_parameters) {
  const int width = raw.left.width(), height = raw.left.height();
  host_sim::ProfileOptions options;
  options.fps_target = fps;
  options.worker_threads = threads;
  const Plane& left = rectified_left != nullptr ? *rectified_left : raw.left;
  const Plane& right = rectified_right != nullptr ? *rectified_right : raw.right;
  double frame_ms = 0;
  try {
    if (rectified_left != nullptr) {
      const Graph graph = verified_for_target(io::rectification_graph_spec(calibration_files), target, width, height);
      frame_ms += host_sim::profile_graph(graph, target, {{"left", &raw.left}, {"right", &raw.right}}, options).frame_ms;
    }
    frame_ms += profile_engine_on_target(disparity_parameters, width, height, target, {{"left", &left}, {"right", &right}}, options)
                    .frame_ms;
    if (detector_parameters != nullptr) {
      const Graph graph = verified_for_target(arm::ObstacleDetector::graph_spec(*detector_parameters), target, width, height);
      frame_ms += host_sim::profile_graph(graph, target, {{"disparity", &disparity}, {"left", &left}}, options).frame_ms;
    }
  } catch (const VerifyError& error) {
    return target.name + ": does not fit (" + error.what() + ")";
  }
  const double budget_ms = 1000.0 / fps;
  char line[256];
  std::snprintf(line, sizeof line, "%s %.1f ms/frame (budget %.1f ms at %.3g fps: %s)", target.name.c_str(), frame_ms, budget_ms, fps,
                frame_ms <= budget_ms ? "fits" : "over");
  return line;
}

}  // namespace

RunCommand::RunCommand(CLI::App& app) {
  command_ = app.add_subcommand("run",
                                "run a graph on a stereo source, pair after pair: a live camera (v4l2:, v4l2-sbs:, libcamera:) "
                                "or a recording (files:), with a status line, outputs and an optional recording of the pairs");
  command_->add_option("--source", source_spec_,
                       "v4l2:/dev/videoL,/dev/videoR | v4l2-sbs:/dev/videoN | libcamera:ID[,ID] | "
                       "files:LEFT_PATTERN,RIGHT_PATTERN (printf patterns such as dir/%06d.png) | files:LEFT_VIDEO,RIGHT_VIDEO")
      ->required();
  command_->add_option("--calib", calibration_files_,
                       "calibration file, or two (A,B: intrinsics + extrinsics, or left + right); pairs are rectified with it "
                       "unless it describes rectified views (KITTI, Middlebury)")
      ->required()
      ->delimiter(',');
  command_->add_option("--graph", graph_, "disparity (the disparity engine) or obstacles (then the obstacle detector, tracking)")
      ->capture_default_str()
      ->check(CLI::IsMember({"disparity", "obstacles"}));
  command_->add_option("--frames", frame_limit_, "stop after this many processed pairs (0 = until the source ends)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--record", record_directory_,
                       "record the raw pairs into this new or empty folder: left/%06d.png, right/%06d.png, timestamps.txt");
  command_->add_option("--out", out_directory_,
                       "write per pair disparity/%06d.png (KITTI 16-bit), disparity_color/%06d.png and, with --graph obstacles, "
                       "obstacles.jsonl into this folder");
  command_->add_option("--target", target_name_,
                       "target whose simulated cost per frame the status line shows (targets/NAME.json or file; none = no budget)")
      ->capture_default_str();
  command_->add_option("--timeout-ms", timeout_ms_, "a source that delivers no pair for this long has stalled: exit 1")
      ->capture_default_str()
      ->check(CLI::Range(1, 3600000));
  command_->add_option("--fps", fps_,
                       "frame rate: requested from a camera; a recording's rate (timestamps, tracker period, budget; default "
                       "10, a video's own); 0 = the source's")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10000.0));
  command_->add_option("--width", width_, "requested width of each view, px (live sources; 0 = the device's)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--height", height_, "requested height of each view, px (live sources; 0 = the device's)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command_->add_option("--pixel-format", pixel_format_, "requested pixel format (GREY, YUYV, UYVY, NV12, ...; live sources)");
  command_->add_option("--pairing-tolerance-ms", pairing_tolerance_ms_,
                       "two cameras' frames pair when their capture times differ by at most this, ms (-1 = half the "
                       "frame period; raise it for free-running cameras whose phases drift near half a period)")
      ->capture_default_str()
      ->check(CLI::Range(-1.0, 10000.0));
  command_->add_flag("--realtime", realtime_,
                     "replay a recording at its frame rate as a live camera would deliver it (pairs skipped when "
                     "processing lags, latency from the replayed capture time)");
  command_->add_option("--status-every", status_every_, "when stderr is not a terminal: a status line every N pairs")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  command_->add_option("--threads", threads_, "worker threads (0 = one per hardware thread)")
      ->capture_default_str()
      ->check(CLI::Range(0, 256));
  command_->add_option("--in-flight", in_flight_,
                       "pairs processed at once, each by its own disparity engine on its share of the threads (0 = 2 for a "
                       "recording with 2 threads or more and --paths 4 or 0, else 1; a live camera keeps 1 for its latency); "
                       "the maps are the same bits, the outputs come in order")
      ->check(CLI::Range(0, 16))
      ->capture_default_str();
  add_disparity_engine_options(*command_, engine_options_, "disparities searched: [min-disp, min-disp + num-disp) (default 64)");
  add_max_memory_option(*command_, engine_options_);
  add_obstacle_tuning_options(*command_, detector_parameters_);  // --graph obstacles: the tuning of lpstereo obstacles
}

int RunCommand::run() const {
  const bool recording = source_spec_.rfind("files:", 0) == 0;
  if (realtime_ && !recording) throw CommandError(kExitUsage, "--realtime replays a recording (--source files:...), got " + source_spec_);
  const bool obstacles = graph_ == "obstacles";
  const bool live = !recording || realtime_;

  io::SourceOptions source_options;
  source_options.width = width_;
  source_options.height = height_;
  source_options.frame_rate_hz = fps_;
  source_options.pixel_format = pixel_format_;
  source_options.pairing_tolerance_ns = pairing_tolerance_ms_ < 0 ? -1 : static_cast<int64_t>(pairing_tolerance_ms_ * 1e6);
  std::unique_ptr<io::StereoSource> source;
  try {
    source = io::open_stereo_source(source_spec_, source_options);
  } catch (const std::invalid_argument& error) {
    throw CommandError(kExitUsage, std::string("--source: ") + error.what());
  }
  if (realtime_) source = std::make_unique<RealtimeReplay>(std::move(source));
  const int width = source->width(), height = source->height();
  const double source_fps = source->frame_rate_hz() > 0 ? source->frame_rate_hz() : 30.0;

  // The calibration, checked against the views' size before any pair is processed.
  const CalibrationForImages calibration = load_calibration_for(calibration_files_, width, height);
  std::unique_ptr<ViewRectifier> rectifier;
  if (!calibration.calibration.already_rectified) {
    rectifier = std::make_unique<ViewRectifier>(calibration_files_, width, height, std::nullopt, threads_);
  }
  if (obstacles) check_obstacle_geometry(calibration.maps.geometry, calibration_files_);
  const arm::DisparityParameters disparity_parameters =
      tools::disparity_parameters(engine_options_, width, arm::DisparityParameters{}.num_disparities);
  // Frames in flight (tools/disparity_lanes.h): the worker threads are shared out among the lanes.
  const int lane_count = resolved_lanes(in_flight_, live, threads_, disparity_parameters);
  const int workers_per_lane = std::max(1, arm::resolved_worker_threads(threads_) / lane_count);
  check_engine_memory(engine_options_, width, height, disparity_parameters, lane_count > 1 ? workers_per_lane : threads_, lane_count);
  DisparityLanes lanes(width, height, disparity_parameters, lane_count, lane_count > 1 ? workers_per_lane : threads_);
  std::unique_ptr<arm::ObstacleDetector> detector;
  arm::ObstacleParameters parameters;
  if (obstacles) {
    parameters = detector_parameters_for(detector_parameters_, calibration.maps.geometry, disparity_parameters);
    parameters.tracking = true;
    parameters.tracking_settings.frame_period_s = 1.0 / source_fps;
    detector = std::make_unique<arm::ObstacleDetector>(width, height, parameters, MemoryBudget{}, threads_);
  }
  std::optional<host_sim::Target> target;
  if (target_name_ != "none") target = host_sim::load_target(target_name_);

  // Outputs: folders made before the first pair, so that a bad folder fails before the run starts.
  std::unique_ptr<Recorder> recorder;
  if (!record_directory_.empty()) recorder = std::make_unique<Recorder>(record_directory_);
  std::FILE* obstacle_lines = nullptr;
  const fs::path out(out_directory_);
  if (!out_directory_.empty()) {
    std::error_code error;
    for (const char* folder : {"disparity", "disparity_color"}) {
      fs::create_directories(out / folder, error);
      if (error) throw CommandError(kExitInput, "--out " + (out / folder).string() + ": cannot create: " + error.message());
    }
    if (obstacles) {
      obstacle_lines = std::fopen((out / "obstacles.jsonl").string().c_str(), "w");
      if (obstacle_lines == nullptr) throw CommandError(kExitInput, "--out " + (out / "obstacles.jsonl").string() + ": cannot create");
    }
  }
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> obstacle_lines_closer(obstacle_lines, [](std::FILE* file) {
    return file != nullptr ? std::fclose(file) : 0;
  });

  std::printf("source: %s\n", source->description().c_str());
  std::printf("graph %s at %dx%d, %s; disparities [%d, %d)\n", graph_.c_str(), width, height,
              rectifier ? ("rectified with " + calibration_files_.front()).c_str()
                        : ("already rectified (" + calibration.calibration.format + ")").c_str(),
              disparity_parameters.min_disparity, disparity_parameters.min_disparity + disparity_parameters.num_disparities);
  std::fflush(stdout);

  const StopOnSignals stop_on_signals;
  const std::chrono::milliseconds timeout(timeout_ms_);
  const bool terminal = ::isatty(STDERR_FILENO) != 0;
  std::string budget = target ? "" : "no target";
  uint64_t processed = 0;
  double processing_ms_total = 0, latency_ms = 0, latency_ms_total = 0;
  RateMeter arrivals, completions;
  std::unique_ptr<CaptureThread> capture;
  std::future<std::string> budget_profile;  // live sources: the budget line, profiled beside the run
  std::string end_reason, failure;
  Clock::time_point started = Clock::now();

  // Reads the next arrival: the source itself for a recording, the capture thread for a live source
  // (which starts after the first pair, so that the profile does not count as lag).
  const auto next_arrival = [&]() -> std::optional<Arrival> {
    if (capture) return capture->take(std::chrono::milliseconds(100));
    Arrival arrival;
    try {
      arrival.result = source->next(timeout);
      if (arrival.result.status == io::SourceStatus::frame) {
        arrivals.add(Clock::now());
        if (recorder) recorder->record(arrival.result.frame);
      }
    } catch (const io::SourceError& error) {
      arrival.failure = error.what();
    }
    return arrival;
  };
  const auto statistics = [&] { return capture ? capture->statistics() : source->statistics(); };
  const auto dropped = [&] {
    const io::SourceStatistics counts = statistics();
    return counts.left_driver_drops + counts.right_driver_drops + counts.left_unpaired + counts.right_unpaired +
           (capture ? capture->skipped() : 0);
  };
  const auto status_line = [&] {
    char line[512];
    std::snprintf(line, sizeof line, "frame %llu: in %.1f fps, out %.1f fps, dropped %llu, %s %.1f ms, %s",
                  static_cast<unsigned long long>(processed), capture ? capture->fps_in() : arrivals.per_second(),
                  completions.per_second(), static_cast<unsigned long long>(dropped()), live ? "latency" : "processing", latency_ms,
                  budget.c_str());
    return std::string(line);
  };

  // What is done with each pair once its map is ready, in the order the pairs came.
  const auto complete = [&](const InFlightPair& done) {
    const io::StereoFrame& pair = done.pair;
    const Clock::time_point pair_started = done.started;
    const Plane* left = &done.left();
    const Plane* right = &done.right();
    const Plane& disparity = *done.disparity;
    std::optional<arm::ObstacleFrame> detections;
    if (detector) detections = detector->run(disparity, *left);
    if (!out_directory_.empty()) {
      const int min_disparity_px = disparity_parameters.min_disparity;
      io::write_kitti_disparity_png((out / "disparity" / frame_name(pair.index)).string(), disparity, min_disparity_px);
      io::write_image((out / "disparity_color" / frame_name(pair.index)).string(),
                      io::colorize_disparity(disparity, min_disparity_px, min_disparity_px + disparity_parameters.num_disparities));
      if (detections) {
        nlohmann::json line = obstacle_frame_json(width, height, *detections, parameters);
        line["frame"] = pair.index;
        line["timestamp_ns"] = pair.left_timestamp_ns;
        std::fprintf(obstacle_lines, "%s\n", line.dump().c_str());
        std::fflush(obstacle_lines);
      }
    }
    const Clock::time_point pair_done = Clock::now();
    const double processing_ms = milliseconds(pair_done - pair_started);
    ++processed;
    processing_ms_total += processing_ms;
    latency_ms = live ? static_cast<double>(monotonic_now_ns() - pair.left_timestamp_ns) / 1e6 : processing_ms;
    latency_ms_total += latency_ms;
    completions.add(pair_done);

    if (processed == 1) {
      // The budget once, on this first pair. A recording waits for it; a live source does not (the
      // camera would drop frames meanwhile): the profile runs beside the processing on copies of the
      // pair and its planes, and the status line shows it once it is done. Then the clocks (and, live,
      // the capture thread) start.
      if (target && !live) {
        budget = budget_line(*target, source_fps, threads_, calibration_files_, pair, rectifier ? left : nullptr,
                             rectifier ? right : nullptr, disparity_parameters, disparity, detector ? &parameters : nullptr);
      } else if (target) {
        budget = target->name + " being profiled";
        io::StereoFrame raw = pair;
        raw.left = pair.left.clone();
        raw.right = pair.right.clone();
        const std::optional<Plane> rectified_left = rectifier ? std::optional<Plane>(left->clone()) : std::nullopt;
        const std::optional<Plane> rectified_right = rectifier ? std::optional<Plane>(right->clone()) : std::nullopt;
        budget_profile = std::async(std::launch::async, [&, raw, rectified_left, rectified_right, disparity_copy = disparity.clone()] {
          return budget_line(*target, source_fps, threads_, calibration_files_, raw, rectified_left ? &*rectified_left : nullptr,
                             rectified_right ? &*rectified_right : nullptr, disparity_parameters, disparity_copy,
                             detector ? &parameters : nullptr);
        });
      }
      started = Clock::now();
      if (live) capture = std::make_unique<CaptureThread>(*source, timeout, recorder.get());
    }
    if (budget_profile.valid() && budget_profile.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
      budget = budget_profile.get();
    }
    if (terminal) {
      std::fprintf(stderr, "\r%s\033[K", status_line().c_str());
    } else if (processed % static_cast<uint64_t>(status_every_) == 0) {
      std::fprintf(stderr, "%s\n", status_line().c_str());
    }
  };

  uint64_t submitted = 0;
  while (stop_signal == 0 && (frame_limit_ == 0 || submitted < static_cast<uint64_t>(frame_limit_))) {
    std::optional<Arrival> arrival = next_arrival();
    if (!arrival) continue;  // the capture thread had nothing within 100 ms: look at the signal flag again
    if (!arrival->failure.empty()) {
      failure = arrival->failure;
      break;
    }
    const io::SourceResult& result = arrival->result;
    if (result.status == io::SourceStatus::end_of_stream) {
      end_reason = "end of stream";
      break;
    }
    if (result.status == io::SourceStatus::disconnected) {
      failure = "source disconnected: " + result.message;
      break;
    }
    if (result.status == io::SourceStatus::timeout) {
      failure = "source stalled: no pair within " + std::to_string(timeout_ms_) + " ms (--timeout-ms)" +
                (result.message.empty() ? "" : ": " + result.message);
      break;
    }
    InFlightPair next;
    next.pair = std::move(arrival->result.frame);
    next.started = Clock::now();
    if (rectifier) {
      const auto [left_rectified, right_rectified] = rectifier->rectify(next.pair.left, next.pair.right);
      if (lanes.lanes() == 1) {
        next.borrowed_left = &left_rectified;
        next.borrowed_right = &right_rectified;
      } else {
        next.rectified_left = left_rectified.clone();  // the rectifier's planes are reused for the next pair
        next.rectified_right = right_rectified.clone();
      }
    }
    ++submitted;
    if (const std::optional<InFlightPair> done = lanes.submit(std::move(next))) complete(*done);
  }
  // The pairs still in flight when the source ended, failed or a signal came: read, so processed.
  while (const std::optional<InFlightPair> done = lanes.drain()) complete(*done);
  if (capture) capture->stop();
  if (budget_profile.valid()) budget = budget_profile.get();
  if (end_reason.empty() && failure.empty()) {
    end_reason = stop_signal != 0 ? (stop_signal == SIGINT ? "stopped by SIGINT" : "stopped by SIGTERM")
                                  : "--frames " + std::to_string(frame_limit_) + " reached";
  }
  if (terminal && processed > 0) std::fprintf(stderr, "\n");

  // The summary (also after a failure: what was done, and that the recording is complete).
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  const io::SourceStatistics counts = statistics();
  const uint64_t skipped = capture ? capture->skipped() : 0;
  const uint64_t mean_divisor = std::max<uint64_t>(processed, 1);
  char latency[64] = "";
  if (live) std::snprintf(latency, sizeof latency, ", %.1f ms latency", latency_ms_total / static_cast<double>(mean_divisor));
  std::printf("run: %llu pairs processed (%s); after the first, %.1f fps out over %.2f s; dropped %llu (driver %llu, unpaired "
              "%llu, skipped while processing %llu); %.1f ms processing%s per pair (mean, host, %d threads%s); %s\n",
              static_cast<unsigned long long>(processed), failure.empty() ? end_reason.c_str() : "failed",
              processed > 1 && seconds > 0 ? static_cast<double>(processed - 1) / seconds : 0.0, seconds,
              static_cast<unsigned long long>(dropped()),
              static_cast<unsigned long long>(counts.left_driver_drops + counts.right_driver_drops),
              static_cast<unsigned long long>(counts.left_unpaired + counts.right_unpaired), static_cast<unsigned long long>(skipped),
              processing_ms_total / static_cast<double>(mean_divisor), latency,
              threads_ > 0 ? threads_ : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())),
              lanes.lanes() > 1 ? (", " + std::to_string(lanes.lanes()) + " pairs in flight").c_str() : "", budget.c_str());
  if (recorder) {
    std::printf("recorded %llu pairs -> %s (replay: --source files:%s,%s)\n", static_cast<unsigned long long>(recorder->pairs()),
                recorder->directory().string().c_str(), (recorder->directory() / "left" / "%06d.png").string().c_str(),
                (recorder->directory() / "right" / "%06d.png").string().c_str());
  }
  if (!out_directory_.empty()) std::printf("outputs -> %s\n", out_directory_.c_str());
  std::fflush(stdout);
  if (!failure.empty()) throw CommandError(kExitInput, failure);
  return 0;
}

}  // namespace lpstereo::tools
