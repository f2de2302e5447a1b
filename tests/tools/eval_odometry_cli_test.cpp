// lpstereo eval odometry as a user meets it: scores printed and saved, the top-view plot, and bad
// input (one line on stderr, exit 1 or 2, no output file).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/kitti_poses.h"
#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace {

using namespace lpstereo;
namespace fs = std::filesystem;
using lpstereo::testing::Result;
using lpstereo::testing::count_lines;
using lpstereo::testing::run;

// Frame i at z = i m (1 m per frame, straight ahead), positions scaled by `scale`.
std::vector<Eigen::Isometry3d> straight_drive(int frames, double scale = 1.0) {
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < frames; ++i) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(0, 0, i * scale);
    poses.push_back(pose);
  }
  return poses;
}

// Pixels within 40 grey levels (each channel) of a BGR colour.
int pixels_near(const cv::Mat& image, const cv::Vec3b& colour) {
  int count = 0;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const cv::Vec3b pixel = image.at<cv::Vec3b>(y, x);
      if (std::abs(pixel[0] - colour[0]) < 40 && std::abs(pixel[1] - colour[1]) < 40 && std::abs(pixel[2] - colour[2]) < 40) ++count;
    }
  }
  return count;
}

class EvalOdometryCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  std::string write(const std::string& name, const std::vector<Eigen::Isometry3d>& poses) const {
    io::write_kitti_poses(path(name), poses);
    return path(name);
  }
  std::string write_text(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
    return path(name);
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_odometry_cli"};
};

TEST_F(EvalOdometryCli, GroundTruthAgainstItselfScoresZeroWithJsonAndPlot) {
  // A drive that turns (0.05 rad and 2 m per frame: 62 m), so the plot has a curve.
  std::vector<Eigen::Isometry3d> truth = {Eigen::Isometry3d::Identity()};
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(0, 0, 2);
  step.linear() = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  while (truth.size() < 32) truth.push_back(truth.back() * step);
  const std::string poses = write("poses.txt", truth);
  const Result result = run("eval odometry " + poses + " " + poses + " --json " + path("r.json") + " --plot " + path("p.png"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  EXPECT_NE(result.out.find("translation error 0.000 %, rotation error 0.00000 deg/m\n"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("path length: ground truth 62.00 m, estimate 62.00 m\n"), std::string::npos) << result.out;
  std::ifstream report_file(path("r.json"));
  const nlohmann::json report = nlohmann::json::parse(report_file);
  EXPECT_EQ(report["frames"], 32);
  EXPECT_EQ(report["lengths_source"], "automatic");
  EXPECT_EQ(report["lengths_m"], nlohmann::json({5, 10, 15, 20, 25, 30, 35, 40, 45, 50, 55, 60}));
  EXPECT_EQ(report["translation_error_pct"], 0.0);
  EXPECT_EQ(report["ate_rmse_m"], 0.0);
  const cv::Mat plot = cv::imread(path("p.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(plot.empty());
  EXPECT_EQ(plot.rows, 900);
  EXPECT_GT(plot.cols, 900);  // the square plot area and the legend on its right
  // Both lines are drawn (the dashed estimate over the solid truth leaves the truth's blue between dashes).
  EXPECT_GT(pixels_near(plot, {178, 114, 0}), 500);
  EXPECT_GT(pixels_near(plot, {0, 94, 213}), 500);
}

TEST_F(EvalOdometryCli, ScaledEstimateGivesOnePercentPerLength) {
  const std::string truth = write("truth.txt", straight_drive(61));
  const std::string estimate = write("estimate.txt", straight_drive(61, 1.01));
  const Result result = run("eval odometry " + estimate + " " + truth + " --lengths 10,20 --step 10 --json " + path("r.json"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("segments from every 10 frame(s), lengths 10, 20 m (--lengths)"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("translation error 1.000 %"), std::string::npos) << result.out;
  std::ifstream report_file(path("r.json"));
  const nlohmann::json report = nlohmann::json::parse(report_file);
  ASSERT_EQ(report["per_length"].size(), 2u);
  // First frames 0, 10, ..., 50 reach 10 m further (6 segments); 0, ..., 40 reach 20 m (5).
  EXPECT_EQ(report["per_length"][0]["segments"], 6);
  EXPECT_EQ(report["per_length"][1]["segments"], 5);
  EXPECT_NEAR(report["per_length"][1]["translation_error_pct"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(report["end_point_error_m"].get<double>(), 0.6, 1e-9);
}

TEST_F(EvalOdometryCli, BadInputIsOneLineAndNoOutput) {
  const std::string truth = write("truth.txt", straight_drive(51));
  const std::string short_estimate = write("short.txt", straight_drive(50));
  const std::string tiny = write("tiny.txt", straight_drive(3));
  const std::string malformed = write_text("malformed.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  const std::string empty = write_text("empty.txt", "");
  struct Case {
    const char* name;
    std::string arguments;
    std::string message;  // the start of the stderr line
    int exit_code;
  };
  const std::vector<Case> cases = {
      {"missing file", "eval odometry " + path("none.txt") + " " + truth, "lpstereo: " + path("none.txt") + ": cannot open the pose file", 1},
      {"mismatched counts", "eval odometry " + short_estimate + " " + truth,
       "lpstereo: " + short_estimate + " has 50 poses, " + truth + " has 51: expected one pose per frame in both", 1},
      {"malformed line", "eval odometry " + malformed + " " + truth,
       "lpstereo: " + malformed + ":2: expected 12 numbers (a 3x4 pose, row-major), got 11", 1},
      {"empty file", "eval odometry " + truth + " " + empty, "lpstereo: " + empty + ": no pose (expected one line of 12 numbers per frame)", 1},
      {"path shorter than every length", "eval odometry " + tiny + " " + tiny + " --lengths 5,10",
       "lpstereo: " + tiny + ": the ground truth's path is 2 m over 3 frame(s): no segment of 5 m to 10 m fits", 1},
      {"one file", "eval odometry " + truth, "lpstereo: eval odometry: expected 2 files", 2},
      {"non-positive length", "eval odometry " + truth + " " + truth + " --lengths 5,0", "lpstereo: --lengths", 2},
      {"zero step", "eval odometry " + truth + " " + truth + " --step 0", "lpstereo: --step", 2},
      {"plot with middlebury", "eval middlebury", "lpstereo: --lengths, --step, --plot: only for eval odometry", 2},
      {"baseline with odometry", "eval odometry " + truth + " " + truth + " --baseline opencv",
       "lpstereo: --baseline: only for eval middlebury|kitti", 2},
      {"multires with odometry", "eval odometry " + truth + " " + truth + " --multires on",
       "lpstereo: --multires: only for eval middlebury|kitti", 2},
  };
  for (const Case& c : cases) {
    const Result result = run(c.arguments + " --json " + path("r.json") + " --plot " + path("plot.png"));
    EXPECT_EQ(result.exit_code, c.exit_code) << c.name << ": " << result.err;
    EXPECT_EQ(result.err.rfind(c.message, 0), 0u) << c.name << ": " << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << c.name << ": " << result.err;
    EXPECT_FALSE(fs::exists(path("r.json"))) << c.name;
    EXPECT_FALSE(fs::exists(path("plot.png"))) << c.name;
  }
}

}  // namespace
