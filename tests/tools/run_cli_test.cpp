// lpstereo run as a user meets it, on a small rendered sequence (lpstereo synth: a lineup at 16, 15.5
// and 15 m, 640x288; no shared data needed):
//   - --graph disparity writes per frame the same disparity as `lpstereo disparity` on that frame
//     (a command with its own reading path), the colour view, a status line per --status-every
//     frames and the summary with the cv1-class budget at the recording's 10 fps;
//   - --graph obstacles writes one JSON line per frame with the frame index, the timestamp
//     (frame / 10 Hz), the road near the rendered camera height and tracked obstacles;
//   - --record then replaying the recording gives the same disparity, the recorded views are the
//     source's pixels (lossless) and timestamps.txt holds one line per pair;
//   - two video files run every frame at the container's rate;
//   - --realtime replays through the capture thread; SIGTERM stops it after the current pair with
//     exit 0 and a complete recording;
//   - pairs in flight (the default on a recording, 1 and 3) give the same outputs in the same order;
//   - bad input (no first frame, views of different sizes, a view missing mid-sequence, an unknown
//     kind, a live kind this build lacks, a missing or wrong-size calibration, a used --record
//     folder): one line on stderr, a non-zero exit.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "io/disparity_io.h"
#include "io/image_io.h"
#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace {

namespace fs = std::filesystem;
using lpstereo::Plane;
using lpstereo::testing::Result;
using lpstereo::testing::count_lines;
using lpstereo::testing::run;

constexpr int kFrames = 3;
constexpr const char* kEngine = " --num-disp 48 --threads 2";

std::string last_line(const std::string& text) {
  const std::string trimmed = text.substr(0, text.find_last_not_of('\n') + 1);
  return trimmed.substr(trimmed.find_last_of('\n') + 1);
}

std::string numbered(const std::string& folder, const std::string& view, int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "/%06d.png", frame);
  return folder + "/" + view + name;
}

// Pixels equal (same size, same values; any element type).
bool same_pixels(const Plane& a, const Plane& b) {
  const cv::Mat ma = lpstereo::io::plane_to_mat(a), mb = lpstereo::io::plane_to_mat(b);
  return ma.size() == mb.size() && ma.type() == mb.type() && cv::countNonZero(ma != mb) == 0;
}

std::vector<nlohmann::json> read_json_lines(const std::string& file) {
  std::vector<nlohmann::json> records;
  std::ifstream stream(file);
  for (std::string line; std::getline(stream, line);) records.push_back(nlohmann::json::parse(line));
  return records;
}

class RunCli : public ::testing::Test {
 protected:
  // The sequence, rendered once for the suite: seq/left/00000i.png, seq/right/00000i.png, calib.yaml.
  static void SetUpTestSuite() {
    sequence_ = (fs::temp_directory_path() / ("lpstereo_run_cli_" + std::to_string(::getpid()))).string();
    fs::remove_all(sequence_);
    for (const char* view : {"left", "right"}) fs::create_directories(sequence_ + "/" + view);
    for (int frame = 0; frame < kFrames; ++frame) {
      const std::string render = sequence_ + "/render";
      const Result result = run("synth -o " + render +
                                " --width 640 --height 288 --hfov-deg 60 --baseline-m 0.30 --camera-height-m 1.5 "
                                "--noise-sigma 1 --lineup " + std::to_string(16.0 - 0.5 * frame));
      ASSERT_EQ(result.exit_code, 0) << result.err;
      for (const char* view : {"left", "right"}) {
        fs::copy_file(render + "/" + view + ".png", numbered(sequence_, view, frame), fs::copy_options::overwrite_existing);
      }
      if (frame == 0) fs::copy_file(render + "/calib.yaml", sequence_ + "/calib.yaml", fs::copy_options::overwrite_existing);
    }
  }
  static void TearDownTestSuite() { fs::remove_all(sequence_); }

  std::string path(const std::string& name) const { return scratch_.path(name); }
  static std::string files(const std::string& folder) { return "files:" + folder + "/left/%06d.png," + folder + "/right/%06d.png"; }
  static std::string source() { return files(sequence_); }
  static std::string calib() { return " --calib " + sequence_ + "/calib.yaml"; }

  static std::string sequence_;
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_run_cli"};
};
std::string RunCli::sequence_;

TEST_F(RunCli, DisparityGraphMatchesTheDisparityCommand) {
  const std::string out = path("out");
  const Result result = run("run --source " + source() + calib() + " --graph disparity --out " + out + " --status-every 1" + kEngine);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("rectified with " + sequence_ + "/calib.yaml"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("3 pairs processed (end of stream)"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("cv1-class "), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("ms/frame (budget 100.0 ms at 10 fps: "), std::string::npos) << result.out;  // 10 Hz: a recording's rate
  // Not a terminal: one status line per frame (--status-every 1), each with every figure.
  ASSERT_EQ(count_lines(result.err), kFrames) << result.err;
  std::istringstream status(result.err);
  for (int frame = 1; frame <= kFrames; ++frame) {
    std::string line;
    std::getline(status, line);
    EXPECT_EQ(line.rfind("frame " + std::to_string(frame) + ": in ", 0), 0u) << line;
    for (const char* part : {" fps, out ", "dropped 0", "processing ", "cv1-class "}) EXPECT_NE(line.find(part), std::string::npos) << line;
  }
  for (int frame = 0; frame < kFrames; ++frame) {
    SCOPED_TRACE(frame);
    const std::string expected = path("expected_" + std::to_string(frame) + ".png");
    // The rendered calib.yaml is not marked rectified: both commands rectify with it first.
    const Result reference = run("disparity " + numbered(sequence_, "left", frame) + " " + numbered(sequence_, "right", frame) +
                                 calib() + " --rectify -o " + expected + kEngine);
    ASSERT_EQ(reference.exit_code, 0) << reference.err;
    const Plane produced = lpstereo::io::read_kitti_disparity_png(numbered(out, "disparity", frame));
    EXPECT_TRUE(same_pixels(produced, lpstereo::io::read_kitti_disparity_png(expected)));
    EXPECT_TRUE(fs::is_regular_file(numbered(out, "disparity_color", frame)));
  }
  EXPECT_FALSE(fs::exists(numbered(out, "disparity", kFrames)));
  EXPECT_FALSE(fs::exists(out + "/obstacles.jsonl"));  // the disparity graph has no detections
}

TEST_F(RunCli, ObstaclesGraphWritesTrackedJsonLines) {
  const std::string out = path("out");
  // --min-features 1 as tests/tools/obstacles_cli_test.cpp at this size (the defaults are the 4K tuning).
  const Result result = run("run --source " + source() + calib() + " --graph obstacles --out " + out + " --min-features 1" + kEngine);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");  // --status-every 10: no status line in 3 frames
  const std::vector<nlohmann::json> records = read_json_lines(out + "/obstacles.jsonl");
  ASSERT_EQ(records.size(), static_cast<size_t>(kFrames));
  for (int frame = 0; frame < kFrames; ++frame) {
    SCOPED_TRACE(frame);
    const nlohmann::json& record = records[static_cast<size_t>(frame)];
    EXPECT_EQ(record.at("frame"), frame);
    EXPECT_EQ(record.at("timestamp_ns"), frame * 100'000'000LL);  // frame / 10 Hz
    EXPECT_EQ(record.at("width"), 640);
    EXPECT_EQ(record.at("height"), 288);
    ASSERT_TRUE(record.at("road").at("valid").get<bool>());
    EXPECT_NEAR(record.at("road").at("camera_height_m").get<double>(), 1.5, 0.05);  // the rendered camera
    ASSERT_FALSE(record.at("obstacles").empty());
    for (const nlohmann::json& obstacle : record.at("obstacles")) {
      EXPECT_GE(obstacle.at("track_id").get<int>(), 1);  // tracking is on: every record has its track
      EXPECT_NEAR(obstacle.at("distance_m").get<double>(), 16.0 - 0.5 * frame, 1.5);
    }
  }
}

// Pairs in flight (tools/disparity_lanes.h): the default on a recording with 2 threads and 4 paths
// is 2 engines on one worker each; 1 (one engine on both workers) and 3 (more engines than workers)
// give the same maps, colour views and tracked obstacle lines in the same order, and the summary
// says how many. 8 paths (which keep both workers busy themselves) default to 1.
TEST_F(RunCli, PairsInFlightGiveTheSameOutputsInOrder) {
  const Result eight_paths = run("run --source " + source() + calib() + " --target none --frames 1" + kEngine);
  ASSERT_EQ(eight_paths.exit_code, 0) << eight_paths.err;
  EXPECT_EQ(eight_paths.out.find("in flight"), std::string::npos) << eight_paths.out;
  std::vector<std::string> lines;
  for (const int in_flight : {0, 1, 3}) {
    SCOPED_TRACE(in_flight);
    const std::string out = path("out" + std::to_string(in_flight));
    const Result result = run("run --source " + source() + calib() + " --graph obstacles --min-features 1 --target none --out " + out +
                              " --paths 4 --in-flight " + std::to_string(in_flight) + kEngine);
    ASSERT_EQ(result.exit_code, 0) << result.err;
    const std::string summary = last_line(result.out.substr(0, result.out.rfind("outputs ->")));
    if (in_flight == 1) {
      EXPECT_EQ(summary.find("in flight"), std::string::npos) << summary;
    } else {
      EXPECT_NE(summary.find(", " + std::to_string(in_flight == 0 ? 2 : 3) + " pairs in flight)"), std::string::npos) << summary;
    }
    std::ifstream jsonl(out + "/obstacles.jsonl");
    lines.push_back(std::string(std::istreambuf_iterator<char>(jsonl), std::istreambuf_iterator<char>()));
    const std::vector<nlohmann::json> records = read_json_lines(out + "/obstacles.jsonl");
    ASSERT_EQ(records.size(), static_cast<size_t>(kFrames));
    for (int frame = 0; frame < kFrames; ++frame) EXPECT_EQ(records[static_cast<size_t>(frame)].at("frame"), frame);
    if (in_flight == 0) continue;
    for (int frame = 0; frame < kFrames; ++frame) {
      for (const char* folder : {"disparity", "disparity_color"}) {
        const cv::Mat expected = cv::imread(numbered(path("out0"), folder, frame), cv::IMREAD_UNCHANGED);
        const cv::Mat actual = cv::imread(numbered(out, folder, frame), cv::IMREAD_UNCHANGED);
        ASSERT_FALSE(expected.empty());
        ASSERT_EQ(actual.size(), expected.size());
        EXPECT_EQ(cv::norm(actual, expected, cv::NORM_INF), 0.0) << folder << " " << frame;
      }
    }
  }
  EXPECT_EQ(lines[1], lines[0]);
  EXPECT_EQ(lines[2], lines[0]);
}

TEST_F(RunCli, RecordThenReplayGivesTheSameDisparity) {
  const std::string recording = path("recording"), first = path("first"), replay = path("replay");
  Result result = run("run --source " + source() + calib() + " --frames 2 --record " + recording + " --out " + first + kEngine);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("2 pairs processed (--frames 2 reached)"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("recorded 2 pairs"), std::string::npos) << result.out;
  // Lossless: the recorded views are the source's pixels.
  for (int frame = 0; frame < 2; ++frame) {
    for (const char* view : {"left", "right"}) {
      EXPECT_TRUE(same_pixels(lpstereo::io::read_luma_u8(numbered(recording, view, frame)),
                              lpstereo::io::read_luma_u8(numbered(sequence_, view, frame))))
          << view << " " << frame;
    }
  }
  EXPECT_FALSE(fs::exists(numbered(recording, "left", 2)));
  std::ifstream timestamps(recording + "/timestamps.txt");
  std::vector<std::string> rows;
  for (std::string row; std::getline(timestamps, row);) rows.push_back(row);
  ASSERT_EQ(rows.size(), 3u);  // the header and one line per pair
  EXPECT_EQ(rows[0].rfind("# index", 0), 0u);
  EXPECT_EQ(rows[2], "1 100000000 100000000 1 1");

  result = run("run --source " + files(recording) + calib() + " --out " + replay + kEngine);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("2 pairs processed (end of stream)"), std::string::npos) << result.out;
  for (int frame = 0; frame < 2; ++frame) {
    EXPECT_TRUE(same_pixels(lpstereo::io::read_kitti_disparity_png(numbered(replay, "disparity", frame)),
                            lpstereo::io::read_kitti_disparity_png(numbered(first, "disparity", frame))))
        << frame;
  }
}

TEST_F(RunCli, VideoFilesRunEveryFrame) {
  // The sequence as two MJPEG videos (OpenCV's own writer), at 20 fps: every frame is processed at
  // the container's rate.
  for (const char* view : {"left", "right"}) {
    cv::VideoWriter writer(path(std::string(view) + ".avi"), cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 20.0,
                           cv::Size(640, 288), true);
    ASSERT_TRUE(writer.isOpened());
    for (int frame = 0; frame < kFrames; ++frame) writer.write(cv::imread(numbered(sequence_, view, frame), cv::IMREAD_COLOR));
  }
  const std::string out = path("out");
  const Result result = run("run --source files:" + path("left.avi") + "," + path("right.avi") + calib() + " --out " + out + kEngine);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("video files"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("3 pairs processed (end of stream)"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("(budget 50.0 ms at 20 fps: "), std::string::npos) << result.out;
  for (int frame = 0; frame < kFrames; ++frame) EXPECT_TRUE(fs::is_regular_file(numbered(out, "disparity", frame))) << frame;
  EXPECT_FALSE(fs::exists(numbered(out, "disparity", kFrames)));
}

// Runs lpstereo with `arguments` in the background; the process id (the shell execs lpstereo).
pid_t start(const std::string& arguments, const std::string& out_file, const std::string& err_file) {
  const std::string command = "exec " + std::string(LPSTEREO_BINARY) + " " + arguments + " >" + out_file + " 2>" + err_file;
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

TEST_F(RunCli, SigtermStopsARealtimeReplayWithACompleteRecording) {
  // One pair a second (--fps 1): after the first pair is recorded the run waits for the second one
  // on the capture thread; SIGTERM then stops it after the current pair.
  const std::string recording = path("recording");
  const pid_t pid = start("run --source " + source() + calib() + " --realtime --fps 1 --target none --record " + recording + kEngine,
                          path("stdout"), path("stderr"));
  ASSERT_GT(pid, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  const auto recorded_pairs = [&] {
    std::ifstream timestamps(recording + "/timestamps.txt");
    return count_lines(std::string(std::istreambuf_iterator<char>(timestamps), {})) - 1;
  };
  while (recorded_pairs() < 1 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_GE(recorded_pairs(), 1) << "no pair recorded in 60 s";
  ::kill(pid, SIGTERM);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  std::ifstream out_file(path("stdout"));
  const std::string out(std::istreambuf_iterator<char>(out_file), {});
  EXPECT_NE(out.find("(stopped by SIGTERM)"), std::string::npos) << out;
  EXPECT_NE(out.find(" ms latency per pair"), std::string::npos) << out;  // a live run: latency from the capture time
  // Every recorded pair is complete: both views decode and are the source's pixels, one line each.
  const int pairs = recorded_pairs();
  ASSERT_GE(pairs, 1);
  ASSERT_LT(pairs, kFrames);  // stopped before the end
  for (int frame = 0; frame < pairs; ++frame) {
    for (const char* view : {"left", "right"}) {
      EXPECT_TRUE(same_pixels(lpstereo::io::read_luma_u8(numbered(recording, view, frame)),
                              lpstereo::io::read_luma_u8(numbered(sequence_, view, frame))));
    }
  }
  EXPECT_FALSE(fs::exists(numbered(recording, "left", pairs)));
}

TEST_F(RunCli, BadInputGivesOneLineAndANonZeroExit) {
  // Frame 1 of a copy lacks its right view; frame 0 of another has a narrower right view.
  const std::string gap = path("gap"), mixed = path("mixed");
  for (const std::string& folder : {gap, mixed}) {
    for (const char* view : {"left", "right"}) fs::create_directories(folder + "/" + view);
  }
  for (int frame = 0; frame < 2; ++frame) fs::copy_file(numbered(sequence_, "left", frame), numbered(gap, "left", frame));
  fs::copy_file(numbered(sequence_, "right", 0), numbered(gap, "right", 0));
  const cv::Mat right = cv::imread(numbered(sequence_, "right", 0), cv::IMREAD_UNCHANGED);
  fs::copy_file(numbered(sequence_, "left", 0), numbered(mixed, "left", 0));
  ASSERT_TRUE(cv::imwrite(numbered(mixed, "right", 0), right(cv::Rect(0, 0, 600, 288)).clone()));
  const std::string used = path("used");
  fs::create_directories(used);
  std::ofstream(used + "/note.txt") << "an older recording";
  std::ofstream(path("small_calib.txt")) << "cam0=[700 0 159.5; 0 700 79.5; 0 0 1]\ncam1=[700 0 159.5; 0 700 79.5; 0 0 1]\n"
                                            "doffs=0\nbaseline=120\nwidth=320\nheight=160\nndisp=64\n";

  const auto expect_refused = [](const Result& result, int exit_code, const std::string& needle) {
    EXPECT_EQ(result.exit_code, exit_code) << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find(needle), std::string::npos) << result.err;
  };
  expect_refused(run("run --source " + files(path("nothing")) + calib()), 1, "000000.png not found");
  expect_refused(run("run --source " + files(mixed) + calib()), 1, "sizes differ");
  expect_refused(run("run --source camera:/dev/video0" + calib()), 2, "unknown kind 'camera'");
  expect_refused(run("run --source files:" + sequence_ + "/left/%06d.png" + calib()), 2, "expected files:LEFT,RIGHT");
  expect_refused(run("run --source v4l2:/dev/lpstereo-no-such-camera-0,/dev/lpstereo-no-such-camera-1" + calib()), 1,
                 "/dev/lpstereo-no-such-camera-0: expected a V4L2 video capture device, got no such file");
  expect_refused(run("run --source " + source() + " --calib " + path("absent.yaml")), 1, "absent.yaml");
  expect_refused(run("run --source " + source() + " --calib " + path("small_calib.txt")), 1, "320x160");
  expect_refused(run("run --source " + source() + calib() + " --record " + used), 1, "expected a new or empty folder");
  expect_refused(run("run --source " + source() + calib() + " --graph stixels"), 2, "--graph");
  expect_refused(run("run --source v4l2:/dev/video0" + calib() + " --realtime"), 2, "--realtime");
  expect_refused(run("run --source " + source() + calib() + " --in-flight 17"), 2, "--in-flight");
  expect_refused(run("run --source " + source() + calib() + " --in-flight 2 --max-memory 1M" + kEngine), 1, "2 pairs in flight");

  // A view missing mid-sequence: frame 0 is processed (and summarised on stdout), then one line and exit 1.
  const Result gap_result = run("run --source " + files(gap) + calib() + kEngine);
  EXPECT_EQ(gap_result.exit_code, 1) << gap_result.err;
  EXPECT_EQ(count_lines(gap_result.err), 1) << gap_result.err;
  EXPECT_NE(last_line(gap_result.err).find("right/000001.png is missing"), std::string::npos) << gap_result.err;
  EXPECT_NE(gap_result.out.find("1 pairs processed (failed)"), std::string::npos) << gap_result.out;
}

}  // namespace
