// The lpstereo command line as a user meets it: the main job, profile outputs, and bad input
// (one clear line on stderr, a non-zero exit, nothing half-written).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;

struct Result {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// Runs lpstereo with the arguments (a shell word list), capturing stdout and stderr.
Result run(const std::string& arguments) {
  const fs::path directory = fs::temp_directory_path() / ("lpstereo_cli_" + std::to_string(::getpid()));
  fs::create_directories(directory);
  const std::string out_file = (directory / "stdout").string();
  const std::string err_file = (directory / "stderr").string();
  const std::string command = std::string(LPSTEREO_BINARY) + " " + arguments + " >" + out_file + " 2>" + err_file;
  const int status = std::system(command.c_str());
  Result result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::string& path) {
    std::ifstream file(path);
    std::ostringstream text;
    text << file.rdbuf();
    return text.str();
  };
  result.out = slurp(out_file);
  result.err = slurp(err_file);
  return result;
}

int lines(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    directory_ = fs::temp_directory_path() / ("lpstereo_cli_case_" + std::to_string(::getpid()) + "_" +
                                              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(directory_);
    fs::create_directories(directory_);
  }
  void TearDown() override { fs::remove_all(directory_); }
  std::string path(const std::string& name) const { return (directory_ / name).string(); }
  // Files in the case directory whose name starts with '.' (temporary names) must not remain.
  bool no_temporaries() const {
    for (const auto& entry : fs::recursive_directory_iterator(directory_)) {
      if (entry.path().filename().string().rfind(".", 0) == 0) return false;
    }
    return true;
  }
  fs::path directory_;
};

TEST_F(Cli, MainJobWritesDisparityColourViewAndProfile) {
  const Result result = run("disparity --width 320 --height 240 --out " + path("out"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  for (const char* file : {"disparity.png", "disparity_color.png", "profile.json", "trace.json", "profile.md", "left.png",
                           "right.png", "ground_truth.png"}) {
    EXPECT_TRUE(fs::is_regular_file(path("out/") + file)) << file;
    EXPECT_GT(fs::file_size(path("out/") + file), 100u) << file;
  }
  std::ifstream report(path("out/profile.json"));
  const nlohmann::json json = nlohmann::json::parse(report);
  EXPECT_EQ(json["target"], "cv1-class");
  EXPECT_EQ(json["width"], 320);
  EXPECT_NE(result.out.find("synthetic scene: "), std::string::npos);
  EXPECT_TRUE(no_temporaries());
}

TEST_F(Cli, ProfileWritesReportTraceAndSummary) {
  const Result result = run("profile --graph stereo-census-wta --target tda4vm-c7x --width 640 --height 288 --report " +
                            path("r.json") + " --trace " + path("t.json") + " --summary-md " + path("s.md"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  std::ifstream report(path("r.json"));
  EXPECT_EQ(nlohmann::json::parse(report)["target"], "tda4vm-c7x");
  std::ifstream trace(path("t.json"));
  EXPECT_TRUE(nlohmann::json::parse(trace).contains("traceEvents"));
  std::ifstream summary(path("s.md"));
  std::string first_line;
  std::getline(summary, first_line);
  EXPECT_EQ(first_line.rfind("### stereo-census-wta on tda4vm-c7x at 640x288", 0), 0u) << first_line;
}

TEST_F(Cli, EnforceExitsThreeWithOneLineWhenOverBudget) {
  const Result result = run("profile --graph rectify-census --width 640 --height 288 --fps 10000 --enforce");
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_EQ(lines(result.err), 1) << result.err;
  EXPECT_EQ(result.err.rfind("lpstereo: over budget: graph 'rectify-census' on cv1-class at 640x288: frame time ", 0), 0u)
      << result.err;
  // A graph marked as not meant to fit is reported, not enforced.
  const Result reported = run("profile --graph stereo-census-wta --width 640 --height 288 --fps 10000 --enforce");
  EXPECT_EQ(reported.exit_code, 0) << reported.err;
  EXPECT_NE(reported.out.find("OVER BUDGET: frame time "), std::string::npos) << reported.out;
  EXPECT_NE(reported.out.find("not enforced: graph 'stereo-census-wta' is marked as not meant to fit"), std::string::npos);
}

TEST_F(Cli, GraphVerifyAndDot) {
  Result verify = run("graph verify rectify-census --target cv1-class --width 3840 --height 1728");
  EXPECT_EQ(verify.exit_code, 0) << verify.err;
  EXPECT_NE(verify.out.find("graph 'rectify-census' verified for cv1-class at 3840x1728"), std::string::npos) << verify.out;
  Result dot = run("graph dot rectify-census");
  EXPECT_EQ(dot.exit_code, 0) << dot.err;
  EXPECT_EQ(dot.out.rfind("digraph \"rectify-census\"", 0), 0u);
}

struct BadInput {
  std::string name;
  std::string arguments;
  std::string error_start;  // expected beginning of the single stderr line
  int exit_code;
};

TEST_F(Cli, BadInputGetsOneClearLineAndANonZeroExit) {
  // Files for the cases.
  {
    std::ofstream(path("corrupt.png")) << "not a png at all";
    std::ofstream(path("broken.json")) << "{\n  \"name\": \"x\",\n  \"nodes\": [ oops ]\n}\n";
    std::ofstream(path("unknown_kernel.json"))
        << R"({"name": "u", "inputs": [{"name": "left", "format": "u8"}], "nodes": [{"name": "n", "kernel": "sobel", "inputs": {"input": "left"}, "outputs": {"output": "o"}}]})";
  }
  run("disparity --width 64 --height 48 --out " + path("pair"));
  const std::string left = path("pair/left.png");
  const std::vector<BadInput> cases = {
      {"missing image", "disparity --left " + path("none.png") + " --right " + left + " --out " + path("o1"),
       "lpstereo: " + path("none.png") + ": no such file", 1},
      {"corrupt image", "disparity --left " + path("corrupt.png") + " --right " + left + " --out " + path("o2"),
       "lpstereo: " + path("corrupt.png") + ": cannot decode", 1},
      {"mismatched images", "disparity --left " + left + " --right " + path("pair/disparity_color.png") + " --out " + path("o3"),
       "", 0},  // same size: accepted (colour becomes luma)
      {"one view only", "disparity --left " + left + " --out " + path("o4"), "lpstereo: give both --left and --right", 2},
      {"malformed graph", "profile --graph " + path("broken.json") + " --width 64 --height 64",
       "lpstereo: " + path("broken.json") + ":3:14: malformed JSON", 1},
      {"unknown kernel", "profile --graph " + path("unknown_kernel.json") + " --width 64 --height 64",
       "lpstereo: verify phase 2 (ports and formats): node 'n': unknown kernel 'sobel'", 1},
      {"unknown target", "profile --graph rectify-census --target cv9 --width 64 --height 64", "lpstereo: no target named 'cv9'", 1},
      {"unknown graph", "profile --graph no-such-graph --width 64 --height 64", "lpstereo: no graph named 'no-such-graph'", 1},
      {"impossible size", "profile --graph rectify-census --width 0 --height 64", "lpstereo: frame size: expected", 2},
      {"impossible fps", "profile --graph rectify-census --width 64 --height 64 --fps -3", "lpstereo: --fps: expected", 2},
      {"unwritable report", "profile --graph rectify-census --width 64 --height 64 --report " + path("no/such/dir/r.json"),
       "lpstereo: " + path("no/such/dir/r.json") + ": cannot write", 1},
  };
  for (const BadInput& bad : cases) {
    const Result result = run(bad.arguments);
    EXPECT_EQ(result.exit_code, bad.exit_code) << bad.name << ": " << result.err;
    if (bad.exit_code == 0) continue;
    EXPECT_EQ(lines(result.err), 1) << bad.name << ": " << result.err;
    EXPECT_EQ(result.err.rfind(bad.error_start, 0), 0u) << bad.name << ": " << result.err;
  }
  // A size mismatch between the views.
  run("disparity --width 80 --height 48 --out " + path("pair2"));
  const Result mismatch = run("disparity --left " + left + " --right " + path("pair2/right.png") + " --out " + path("o5"));
  EXPECT_EQ(mismatch.exit_code, 1);
  EXPECT_EQ(mismatch.err.rfind("lpstereo: image sizes differ: left ", 0), 0u) << mismatch.err;
  EXPECT_FALSE(fs::exists(path("o5/disparity.png")));
  EXPECT_TRUE(no_temporaries());
}

}  // namespace
