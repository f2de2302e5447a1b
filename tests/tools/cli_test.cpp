// The lpstereo command line as a user meets it: the main job, profile outputs, and bad input
// (one clear line on stderr, a non-zero exit, nothing half-written).
#include <gtest/gtest.h>

#include <algorithm>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/disparity_io.h"
#include "tests/support/cli_runner.h"
#include "tests/support/scratch_directory.h"

namespace {

using namespace lpstereo;
namespace fs = std::filesystem;

using lpstereo::testing::Result;
using lpstereo::testing::count_lines;
using lpstereo::testing::run;

class Cli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return scratch_.path(name); }
  // Files in the case directory whose name starts with '.' (temporary names) must not remain.
  bool no_temporaries() const {
    for (const auto& entry : fs::recursive_directory_iterator(scratch_.root())) {
      if (entry.path().filename().string().rfind(".", 0) == 0) return false;
    }
    return true;
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_cli_case"};
};

TEST_F(Cli, MainJobWritesDisparityColourViewAndProfile) {
  const Result result = run("disparity --synthetic --width 320 --height 240 --out-dir " + path("out"));
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
  // The profile is the chip's schedule (the same bits as the host's): 8-path SGM as the forward
  // pass and the backward pass fused with the selection, not the host's two passes side by side.
  std::vector<std::string> implementations;
  for (const nlohmann::json& node : json["nodes"]) implementations.push_back(node["implementation"]);
  EXPECT_NE(std::find(implementations.begin(), implementations.end(), "sgm_8path_backward"), implementations.end());
  EXPECT_EQ(std::find(implementations.begin(), implementations.end(), "sgm_sums_select"), implementations.end());
  EXPECT_NE(result.out.find("synthetic scene: "), std::string::npos);
  EXPECT_TRUE(no_temporaries());
}

// The demo's run (scripts/run-demo.sh): the chip configuration, census and 4-path SGM on cv1-class's
// stereo unit over the unit's range that covers the scene's, its median there too, and a profile that fits.
TEST_F(Cli, ChipConfigurationRunsOnTheStereoUnitAndFits) {
  const Result result = run("disparity --synthetic --config chip --width 320 --height 240 --out-dir " + path("chip"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  std::ifstream report(path("chip/profile.json"));
  const nlohmann::json json = nlohmann::json::parse(report);
  EXPECT_TRUE(json["fits_budget"].get<bool>());
  std::map<std::string, std::string> engine_of;
  for (const nlohmann::json& node : json["nodes"]) engine_of[node["implementation"]] = node["engine"];
  EXPECT_EQ(engine_of["sgm_4path"], "stereo");
  EXPECT_EQ(engine_of["census5x5"], "stereo");
  EXPECT_EQ(engine_of["median3x3_s16"], "stereo");  // the unit's median filter, as TI's SDE has
  EXPECT_EQ(engine_of.count("speckle_filter"), 0u);
  EXPECT_NE(result.out.find("disparities [0, 64)"), std::string::npos) << result.out;  // the scene's 48, the unit's 64
  EXPECT_NE(result.out.find("fits the budget"), std::string::npos) << result.out;
  // The chip configuration fixes the matcher; a target without a stereo unit has none.
  const Result flags = run("disparity --synthetic --config chip --paths 8 --out-dir " + path("chip2"));
  EXPECT_EQ(flags.exit_code, 2);
  EXPECT_EQ(flags.err, "lpstereo: --config chip fixes the matcher (arm::chip_configuration): expected none of the matcher "
                       "flags, got --paths\n");
  std::ofstream no_units(path("no-units.json"));
  std::ifstream cv1(std::string(LPSTEREO_SOURCE_DIR) + "/targets/cv1-class.json");
  nlohmann::json target = nlohmann::json::parse(cv1);
  target.erase("units");
  target["name"] = "no-units";
  no_units << target.dump();
  no_units.close();
  const Result none = run("disparity --synthetic --config chip --target " + path("no-units.json") + " --out-dir " + path("chip3"));
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_EQ(none.err, "lpstereo: --config chip: expected a target with a stereo unit, target 'no-units' has none\n");
  EXPECT_FALSE(fs::exists(path("chip2")) || fs::exists(path("chip3")));
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
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_EQ(result.err.rfind("lpstereo: over budget: graph 'rectify-census' on cv1-class at 640x288: frame time ", 0), 0u)
      << result.err;
  // A graph marked as not meant to fit is reported, not enforced.
  const Result reported = run("profile --graph stereo-census-wta --width 640 --height 288 --fps 10000 --enforce");
  EXPECT_EQ(reported.exit_code, 0) << reported.err;
  EXPECT_NE(reported.out.find("OVER BUDGET: frame time "), std::string::npos) << reported.out;
  EXPECT_NE(reported.out.find("not enforced: graph 'stereo-census-wta' is marked as not meant to fit"), std::string::npos);
}

// A graph whose tiles do not fit the target's SRAM: the profile says so first, still reports the
// figures, and --enforce fails even for a graph marked as not meant to fit.
TEST_F(Cli, ProfileReportsAGraphThatDoesNotFitTheSram) {
  const std::string command =
      "profile --graph disparity-vector-sgm --target tda4vm-c7x --width 1280 --height 96 --report " + path("r.json");
  const Result reported = run(command);
  ASSERT_EQ(reported.exit_code, 0) << reported.err;
  EXPECT_EQ(reported.out.rfind("DOES NOT FIT: verify phase 4 (memory placement): node 'sgm_far': SRAM working set", 0), 0u)
      << reported.out;
  EXPECT_NE(reported.out.find("sgm_far                vector engine sgm_4path"), std::string::npos) << reported.out;
  std::ifstream report(path("r.json"));
  const nlohmann::json json = nlohmann::json::parse(report);
  EXPECT_FALSE(json["fits_budget"].get<bool>());
  const Result enforced = run(command + " --enforce");
  EXPECT_EQ(enforced.exit_code, 3);
  EXPECT_EQ(count_lines(enforced.err), 1) << enforced.err;
  EXPECT_EQ(enforced.err.rfind("lpstereo: over budget: graph 'disparity-vector-sgm' on tda4vm-c7x at 1280x96: does not fit the SRAM: ",
                               0),
            0u)
      << enforced.err;
}

// A node on a fixed-function unit beyond the unit's limits: one line naming node, unit, limit and
// actual value; exit 1; nothing written. A target without the unit refuses the node the same way.
TEST_F(Cli, ProfileRefusesAUnitNodeBeyondItsUnitsLimits) {
  const Result wide = run("profile --graph disparity --target tda4vm-c7x --report " + path("wide.json"));
  EXPECT_EQ(wide.exit_code, 1);
  EXPECT_EQ(count_lines(wide.err), 1) << wide.err;
  EXPECT_NE(wide.err.find("node 'census_left' on unit 'stereo': buffer 'left_rectified' is 3840x1728, the unit's limit is "
                          "2048x1024"),
            std::string::npos)
      << wide.err;
  EXPECT_FALSE(std::filesystem::exists(path("wide.json")));
  // At a size the SDE takes, its sourced 9x9 census window has no project kernel: refused by name.
  const Result census = run("profile --graph disparity --target tda4vm-c7x --width 1280 --height 720");
  EXPECT_EQ(census.exit_code, 1);
  EXPECT_NE(census.err.find("node 'census_left' on unit 'stereo': kernel 'census5x5' is not one of its functions"),
            std::string::npos)
      << census.err;
}

// The disparity graph on cv1-class: rectification on the warp unit, census and SGM on the stereo
// unit, each unit a track with its load; it fits 3840x1728 at 30 fps with the frames in flight bounded.
TEST_F(Cli, ProfileRunsTheDisparityGraphOnTheUnits) {
  const Result result = run("profile --graph disparity --width 1920 --height 864 --enforce --report " + path("r.json"));
  ASSERT_EQ(result.exit_code, 0) << result.err << result.out;
  EXPECT_NE(result.out.find("sgm                    stereo        sgm_4path"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("rectify_left           warp          remap_bilinear"), std::string::npos) << result.out;
  std::ifstream report(path("r.json"));
  const nlohmann::json json = nlohmann::json::parse(report);
  std::set<std::string> engines;
  for (const nlohmann::json& engine : json["engines"]) engines.insert(engine["name"].get<std::string>());
  EXPECT_TRUE(engines.count("unit stereo (stereo)") && engines.count("unit warp (warp)")) << json["engines"].dump();
  EXPECT_EQ(json["frames_in_flight"].get<int>(), 3);
}

// TI's measured loads as the independent check of the tda4vm-c7x units (TI Robotics SDK performance
// report, LDC + SDE at 1280x720, search range 128, 15 fps: SDE 16.3-16.5 %, two layers 21.1-21.3 %,
// LDC 4.4-4.5 %). The units' rates come from TI's rate documents (targets/tda4vm-c7x.json), never
// from these loads. Model, one layer: SDE 1280 x 720 / (0.1615 px/cycle x 520 MHz) + 100 us =
// 11.07 ms of the 66.7 ms a frame = 16.6 %; the second layer adds a quarter of the pixels and its
// own set-up: 20.9 %. LDC: two views of 1280 x 720 at 1 px/cycle, 650 MHz, + 100 us each = 3.04 ms
// = 4.6 %.
TEST_F(Cli, Tda4vmUnitsReproduceTisMeasuredSdeAndLdcLoads) {
  auto loads = [&](const std::string& graph) {
    const std::string report = path(graph + ".json");
    const Result result =
        run("profile --graph " + graph + " --target tda4vm-c7x --width 1280 --height 720 --fps 15 --enforce --report " + report);
    EXPECT_EQ(result.exit_code, 0) << result.err << result.out;
    std::ifstream file(report);
    const nlohmann::json json = nlohmann::json::parse(file);
    std::map<std::string, double> by_engine;
    for (const nlohmann::json& engine : json["engines"]) by_engine[engine["name"]] = engine["load_percent"].get<double>();
    return by_engine;
  };
  const std::map<std::string, double> one_layer = loads("tda4vm-ldc-sde");
  ASSERT_TRUE(one_layer.count("unit stereo (stereo)") && one_layer.count("unit warp (warp)"));
  EXPECT_NEAR(one_layer.at("unit stereo (stereo)"), 16.4, 3.0);
  EXPECT_NEAR(one_layer.at("unit warp (warp)"), 4.45, 1.0);
  const std::map<std::string, double> two_layers = loads("tda4vm-ldc-sde-2layer");
  ASSERT_TRUE(two_layers.count("unit stereo (stereo)") && two_layers.count("unit scaler (scaler)"));
  EXPECT_NEAR(two_layers.at("unit stereo (stereo)"), 21.2, 3.0);
}

// A graph whose input is a disparity map gets the synthetic scene's true disparity (s16 Q4).
TEST_F(Cli, ProfileFeedsADisparityInputTheScenesTrueDisparity) {
  const Result result = run("profile --graph road-profile --width 320 --height 160 --report " + path("r.json"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("v_disparity            vector engine v_disparity"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("road_profile           ARM           road_profile"), std::string::npos) << result.out;
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
  std::string must_not_exist = "";  // an output file the failed command must not leave behind
};

TEST_F(Cli, BadInputGetsOneClearLineAndANonZeroExit) {
  // Files for the cases.
  {
    std::ofstream(path("corrupt.png")) << "not a png at all";
    std::ofstream(path("empty.png"));
    std::ofstream(path("broken.json")) << "{\n  \"name\": \"x\",\n  \"nodes\": [ oops ]\n}\n";
    std::ofstream(path("unknown_kernel.json"))
        << R"({"name": "u", "inputs": [{"name": "left", "format": "u8"}], "nodes": [{"name": "n", "kernel": "sobel", "inputs": {"input": "left"}, "outputs": {"output": "o"}}]})";
  }
  run("disparity --synthetic --width 64 --height 48 --out-dir " + path("pair"));
  const std::string left = path("pair/left.png");
  const std::string right = path("pair/right.png");
  const std::string pair = left + " " + right;
  const std::vector<BadInput> cases = {
      {"missing image", "disparity " + path("none.png") + " " + left + " -o " + path("o1.png"),
       "lpstereo: " + path("none.png") + ": no such file", 1, "o1.png"},
      {"corrupt image", "disparity " + path("corrupt.png") + " " + left + " -o " + path("o2.png"),
       "lpstereo: " + path("corrupt.png") + ": cannot decode", 1, "o2.png"},
      {"empty image", "disparity " + left + " " + path("empty.png") + " -o " + path("o2.pfm"),
       "lpstereo: " + path("empty.png") + ": cannot decode", 1, "o2.pfm"},
      {"colour view of the same size", "disparity " + left + " " + path("pair/disparity_color.png") + " -o " + path("o3.png"),
       "", 0},  // accepted (colour becomes luma)
      {"one view only", "disparity " + left + " -o " + path("o4.png"), "lpstereo: give LEFT RIGHT -o OUT, or --synthetic", 2},
      {"no output", "disparity " + pair, "lpstereo: give LEFT RIGHT -o OUT, or --synthetic", 2},
      {"num-disp zero", "disparity " + pair + " -o " + path("o6.png") + " --num-disp 0",
       "lpstereo: --num-disp: expected a positive number, got 0", 2, "o6.png"},
      {"num-disp negative", "disparity " + pair + " -o " + path("o6b.png") + " --num-disp -16 --multires on",
       "lpstereo: --num-disp: expected a positive number, got -16", 2, "o6b.png"},
      {"num-disp wider than the image", "disparity " + pair + " -o " + path("o7.png") + " --num-disp 65",
       "lpstereo: --num-disp: expected at most 64 (the image width), got 65", 1, "o7.png"},
      {"range beyond the width", "disparity " + pair + " -o " + path("o8.s16") + " --min-disp 10 --num-disp 60",
       "lpstereo: --min-disp + --num-disp: expected at most 64 (the image width), got 10 + 60 = 70", 1, "o8.s16"},
      {"range beyond the width, multi-resolution",
       "disparity " + pair + " -o " + path("o8b.s16") + " --min-disp 20 --num-disp 50 --multires on",
       "lpstereo: --min-disp + --num-disp: expected at most 64 (the image width), got 20 + 50 = 70", 1, "o8b.s16"},
      {"rectify without a calibration", "disparity " + pair + " -o " + path("o13.png") + " --rectify",
       "lpstereo: --rectify needs --calib FILE", 2, "o13.png"},
      {"right view in another format", "disparity " + pair + " -o " + path("o14.png") + " --right-out " + path("r14.pfm"),
       "lpstereo: --right-out " + path("r14.pfm") + ": written as kitti like -o, a PNG; expected a .png name, got '.pfm'", 2,
       "o14.png"},
      {"right view with another format's extension",
       "disparity " + pair + " -o " + path("o15.pfm") + " --right-out " + path("r15.s16"),
       "lpstereo: --right-out " + path("r15.s16") + ": written as pfm like -o, but its extension '.s16' means s16", 2, "r15.s16"},
      {"right view over the left view", "disparity " + pair + " -o " + path("o16.png") + " --right-out " + path("o16.png"),
       "lpstereo: --right-out " + path("o16.png") + ": the same file as -o", 2, "o16.png"},
      {"right view into a missing folder (after the left map is done)",
       "disparity " + pair + " -o " + path("o17.png") + " --right-out " + path("no/such/dir/r17.png"),
       "lpstereo: " + path("no/such/dir/r17.png") + ": cannot write", 1, "o17.png"},
      {"colour view into a missing folder (after both maps are done)",
       "disparity " + pair + " -o " + path("o18.s16") + " --right-out " + path("r18.s16") + " --color " +
           path("no/such/dir/c18.png"),
       "lpstereo: " + path("no/such/dir/c18.png") + ": cannot write", 1, "r18.s16"},
      {"synthetic scene with a right view", "disparity --synthetic --out-dir " + path("s19") + " --right-out " + path("r19.png"),
       "lpstereo: --synthetic writes everything into --out-dir; it takes no", 2, "s19"},
      {"unknown output extension", "disparity " + pair + " -o " + path("o9.tif"),
       "lpstereo: -o " + path("o9.tif") + ": cannot tell the format from the extension '.tif'", 2, "o9.tif"},
      {"kitti format without .png", "disparity " + pair + " -o " + path("o10.pfm") + " --format kitti",
       "lpstereo: -o " + path("o10.pfm") + ": --format kitti writes a PNG", 2, "o10.pfm"},
      {"target without report", "disparity " + pair + " -o " + path("o11.png") + " --target cv1-class",
       "lpstereo: --target and --report go together", 2, "o11.png"},
      {"unknown target", "disparity " + pair + " -o " + path("o12.png") + " --target cv9 --report " + path("r12.json"),
       "lpstereo: no target named 'cv9'", 1, "o12.png"},
      {"eval without data", "eval middlebury --data " + path("no_data"), "lpstereo: " + path("no_data") + ": no such data folder", 1},
      {"eval multires-far without multires on", "eval kitti --multires-far 64 --data " + path("no_data"),
       "lpstereo: --multires-far: sets the multi-resolution engine's full-resolution pass; expected --multires on, got off", 2},
      {"eval num-disp not a multiple of 16 with opencv", "eval kitti --baseline opencv --num-disp 20 --data " + path("pair"),
       "lpstereo: --num-disp: OpenCV StereoSGBM needs a multiple of 16", 2},
      {"malformed graph", "profile --graph " + path("broken.json") + " --width 64 --height 64",
       "lpstereo: " + path("broken.json") + ":3:14: malformed JSON", 1},
      {"unknown kernel", "profile --graph " + path("unknown_kernel.json") + " --width 64 --height 64",
       "lpstereo: verify phase 2 (ports and formats): node 'n': unknown kernel 'sobel'", 1},
      {"unknown target", "profile --graph rectify-census --target cv9 --width 64 --height 64", "lpstereo: no target named 'cv9'", 1},
      {"unknown graph", "profile --graph no-such-graph --width 64 --height 64", "lpstereo: no graph named 'no-such-graph'", 1},
      {"missing required option", "profile --width 64 --height 64", "lpstereo: --graph is required", 2},
      {"unknown option", "profile --graph rectify-census --colour red", "lpstereo: The following arguments were not expected", 2},
      {"impossible size", "profile --graph rectify-census --width 0 --height 64", "lpstereo: frame size: expected", 2},
      {"impossible fps", "profile --graph rectify-census --width 64 --height 64 --fps -3", "lpstereo: --fps: expected", 2},
      {"unwritable report", "profile --graph rectify-census --width 64 --height 64 --report " + path("no/such/dir/r.json"),
       "lpstereo: " + path("no/such/dir/r.json") + ": cannot write", 1},
  };
  for (const BadInput& bad : cases) {
    const Result result = run(bad.arguments);
    EXPECT_EQ(result.exit_code, bad.exit_code) << bad.name << ": " << result.err;
    if (!bad.must_not_exist.empty()) {
      EXPECT_FALSE(fs::exists(path(bad.must_not_exist))) << bad.name;
    }
    if (bad.exit_code == 0) continue;
    EXPECT_EQ(count_lines(result.err), 1) << bad.name << ": " << result.err;
    EXPECT_EQ(result.err.rfind(bad.error_start, 0), 0u) << bad.name << ": " << result.err;
  }
  // A size mismatch between the views.
  run("disparity --synthetic --width 80 --height 48 --out-dir " + path("pair2"));
  const Result mismatch = run("disparity " + left + " " + path("pair2/right.png") + " -o " + path("o5.png") + " --right-out " +
                              path("r5.png"));
  EXPECT_EQ(mismatch.exit_code, 1);
  EXPECT_EQ(count_lines(mismatch.err), 1) << mismatch.err;
  EXPECT_EQ(mismatch.err, "lpstereo: image sizes differ: left " + left + " is 64x48, right " + path("pair2/right.png") +
                              " is 80x48\n");
  EXPECT_FALSE(fs::exists(path("o5.png")));
  EXPECT_FALSE(fs::exists(path("r5.png")));
  // A failed write after others were done takes them back: neither map of the colour-view case remains.
  EXPECT_FALSE(fs::exists(path("o18.s16")));
  EXPECT_TRUE(no_temporaries());
}

TEST_F(Cli, DisparityWritesTheSameMapInEveryFormat) {
  ASSERT_EQ(run("disparity --synthetic --width 96 --height 64 --out-dir " + path("pair")).exit_code, 0);
  const std::string pair = path("pair/left.png") + " " + path("pair/right.png");
  const Result kitti = run("disparity " + pair + " -o " + path("d.png") + " --num-disp 32 --threads 1 --color " + path("c.png") +
                           " --target cv1-class --report " + path("r.json"));
  ASSERT_EQ(kitti.exit_code, 0) << kitti.err;
  EXPECT_EQ(kitti.out.rfind("disparity 96x64, disparities [0, 32), ", 0), 0u) << kitti.out;
  ASSERT_EQ(run("disparity " + pair + " -o " + path("d.pfm") + " --num-disp 32").exit_code, 0);
  ASSERT_EQ(run("disparity " + pair + " -o " + path("d.bin") + " --format s16 --num-disp 32").exit_code, 0);
  const Plane from_png = io::read_kitti_disparity_png(path("d.png"));
  const Plane from_pfm = io::disparity_px_to_q4(io::read_pfm(path("d.pfm")), 0);
  const Plane from_s16 = io::read_s16_raw(path("d.bin"), 96, 64);
  int invalid = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 96; ++x) {
      ASSERT_EQ(from_pfm.at<int16_t>(x, y), from_s16.at<int16_t>(x, y)) << x << "," << y;
      ASSERT_EQ(from_png.at<int16_t>(x, y), from_s16.at<int16_t>(x, y)) << x << "," << y;
      invalid += from_s16.at<int16_t>(x, y) == -16 ? 1 : 0;
    }
  }
  EXPECT_GT(invalid, 0);  // the matcher leaves holes (occlusions, the left border) ...
  ASSERT_EQ(run("disparity " + pair + " -o " + path("f.s16") + " --num-disp 32 --fill").exit_code, 0);
  const Plane filled = io::read_s16_raw(path("f.s16"), 96, 64);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 96; ++x) ASSERT_NE(filled.at<int16_t>(x, y), -16) << "--fill left a hole at " << x << "," << y;
  }  // ... and --fill closes them.
  EXPECT_TRUE(fs::is_regular_file(path("c.png")));
  std::ifstream report(path("r.json"));
  EXPECT_EQ(nlohmann::json::parse(report)["target"], "cv1-class");
  EXPECT_TRUE(no_temporaries());
}

// The command does not load OpenCV's video I/O or image codecs (FFmpeg, GStreamer, GDAL, ... and
// their libraries) at start-up: they are modules loaded when a video, or an image that is not a PNG,
// is met (io/codec_module.h), and a module that cannot be loaded is one line and exit 1.
TEST_F(Cli, StartsWithoutTheVideoAndImageCodecLibrariesAndLoadsThemOnlyWhenNeeded) {
  FILE* pipe = popen((std::string("readelf -d ") + LPSTEREO_BINARY).c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string dynamic;
  char buffer[4096];
  while (size_t read = std::fread(buffer, 1, sizeof buffer, pipe)) dynamic.append(buffer, read);
  ASSERT_EQ(pclose(pipe), 0) << "readelf (binutils) is needed to read the command's dynamic section";
  EXPECT_NE(dynamic.find("libopencv_core"), std::string::npos) << dynamic;  // the check reads what it should
  EXPECT_EQ(dynamic.find("videoio"), std::string::npos) << dynamic;
  EXPECT_EQ(dynamic.find("imgcodecs"), std::string::npos) << dynamic;
  std::ofstream(path("left.avi")) << "not a video";
  std::ofstream(path("right.avi")) << "not a video";
  std::ofstream(path("not_a_module.so")) << "not a shared object";
  ::setenv("LPSTEREO_VIDEO_DECODER", path("not_a_module.so").c_str(), 1);
  ASSERT_EQ(run("synth -o " + path("scene") + " --width 64 --height 48").exit_code, 0);
  const Result result = run("run --source files:" + path("left.avi") + "," + path("right.avi") + " --calib " +
                            path("scene/calib.yaml") + " --frames 1");
  ::unsetenv("LPSTEREO_VIDEO_DECODER");
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_NE(result.err.find("the module " + path("not_a_module.so") + " cannot be loaded"), std::string::npos) << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;

  // A pair of PGM files needs the image codecs module; PNG files do not.
  ASSERT_TRUE(cv::imwrite(path("left.pgm"), cv::imread(path("scene/left.png"), cv::IMREAD_GRAYSCALE)));
  ASSERT_TRUE(cv::imwrite(path("right.pgm"), cv::imread(path("scene/right.png"), cv::IMREAD_GRAYSCALE)));
  ASSERT_EQ(run("disparity " + path("left.pgm") + " " + path("right.pgm") + " -o " + path("pgm.png") + " --num-disp 16").exit_code, 0);
  ::setenv("LPSTEREO_IMAGE_CODECS", path("not_a_module.so").c_str(), 1);
  const Result png = run("disparity " + path("scene/left.png") + " " + path("scene/right.png") + " -o " + path("png.png") + " --num-disp 16");
  const Result pgm = run("disparity " + path("left.pgm") + " " + path("right.pgm") + " -o " + path("pgm2.png") + " --num-disp 16");
  ::unsetenv("LPSTEREO_IMAGE_CODECS");
  EXPECT_EQ(png.exit_code, 0) << png.err;
  EXPECT_EQ(cv::imread(path("png.png"), cv::IMREAD_UNCHANGED).size(), cv::Size(64, 48));
  EXPECT_EQ(pgm.exit_code, 1) << pgm.err;
  EXPECT_NE(pgm.err.find("the module " + path("not_a_module.so") + " cannot be loaded"), std::string::npos) << pgm.err;
  EXPECT_EQ(std::count(pgm.err.begin(), pgm.err.end(), '\n'), 1) << pgm.err;
  EXPECT_FALSE(fs::exists(path("pgm2.png")));
}

// --max-memory: a size and range whose working set exceeds it fail before the engine allocates,
// with one line naming the need and the limit, and write nothing; the same run fits a larger limit;
// a limit that is not a size is bad usage.
TEST_F(Cli, DisparityRefusesAWorkingSetOverMaxMemoryBeforeAllocating) {
  ASSERT_EQ(run("disparity --synthetic --width 96 --height 64 --out-dir " + path("pair")).exit_code, 0);
  const std::string pair = path("pair/left.png") + " " + path("pair/right.png");
  const Result over = run("disparity " + pair + " -o " + path("d.png") + " --num-disp 32 --max-memory 64K");
  EXPECT_EQ(over.exit_code, 1);
  EXPECT_NE(over.err.find("needs "), std::string::npos) << over.err;
  EXPECT_NE(over.err.find("--max-memory 64K allows 0.1 MiB"), std::string::npos) << over.err;
  EXPECT_EQ(std::count(over.err.begin(), over.err.end(), '\n'), 1) << over.err;
  EXPECT_FALSE(fs::exists(path("d.png")));
  const Result fits = run("disparity " + pair + " -o " + path("d.png") + " --num-disp 32 --max-memory 1G");
  EXPECT_EQ(fits.exit_code, 0) << fits.err;
  EXPECT_TRUE(fs::is_regular_file(path("d.png")));
  const Result bad = run("disparity " + pair + " -o " + path("e.png") + " --num-disp 32 --max-memory 12X");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--max-memory: expected bytes or a number with K, M or G"), std::string::npos) << bad.err;
}

TEST_F(Cli, DisparityMatcherOptionsReachTheEngine) {
  ASSERT_EQ(run("disparity --synthetic --width 96 --height 64 --out-dir " + path("pair")).exit_code, 0);
  const std::string pair = path("pair/left.png") + " " + path("pair/right.png");
  auto map = [&](const std::string& name, const std::string& options) {
    const Result result = run("disparity " + pair + " -o " + path(name) + " --num-disp 32 " + options);
    EXPECT_EQ(result.exit_code, 0) << options << ": " << result.err;
    return io::read_s16_raw(path(name), 96, 64);
  };
  const Plane four_paths = map("4.s16", "--paths 4");
  const Plane counting = map("4c.s16", "--paths 4 --backend counting");
  const Plane eight_paths = map("8.s16", "--paths 8 --census 9x7");
  const Plane whole_pixels = map("w.s16", "--subpixel off --lr-check off --uniqueness 0");
  const Plane defaults = map("d.s16", "");
  const Plane raw = map("raw.s16", "--median off --speckle-size 0");
  const Plane median_only = map("m.s16", "--speckle-size 0");
  int eight_differs = 0, fractional = 0, whole_fractional = 0, raw_differs = 0;
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 96; ++x) {
      ASSERT_EQ(four_paths.at<int16_t>(x, y), counting.at<int16_t>(x, y)) << "counting back end differs at " << x << "," << y;
      eight_differs += four_paths.at<int16_t>(x, y) != eight_paths.at<int16_t>(x, y) ? 1 : 0;
      fractional += (four_paths.at<int16_t>(x, y) & 15) != 0 ? 1 : 0;
      whole_fractional += (whole_pixels.at<int16_t>(x, y) & 15) != 0 ? 1 : 0;
      raw_differs += raw.at<int16_t>(x, y) != median_only.at<int16_t>(x, y) ? 1 : 0;
      // The speckle filter only ever invalidates.
      if (defaults.at<int16_t>(x, y) != median_only.at<int16_t>(x, y)) {
        ASSERT_EQ(defaults.at<int16_t>(x, y), -16) << "the speckle filter changed a value at " << x << "," << y;
      }
    }
  }
  EXPECT_GT(raw_differs, 0) << "--median off gave the median's map";
  EXPECT_GT(eight_differs, 0) << "--paths 8 --census 9x7 gave the 4-path 5x5 map";
  EXPECT_GT(fractional, 0) << "sub-pixel on gave whole pixels only";
  EXPECT_EQ(whole_fractional, 0) << "--subpixel off gave fractions";
  for (const auto& [options, error_start] : std::vector<std::pair<std::string, std::string>>{
           {"--lr-check maybe", "lpstereo: --lr-check: expected a tolerance in px"},
           {"--paths 5", "lpstereo: --paths: 5 not in {0,4,8}"},
           {"--census 7x7", "lpstereo: --census: 7x7 not in {5x5,9x7}"},
           {"--median maybe", "lpstereo: --median: maybe not in {on,off}"},
           {"--speckle-size -1", "lpstereo: --speckle-size: Value -1 not in range"},
           {"--multires on --multires-far 0", "lpstereo: --multires-far: Value 0 not in range"},
           {"--multires-far 64", "lpstereo: --multires-far: sets the multi-resolution engine's full-resolution pass; expected --multires on, got off"}}) {
    const Result bad = run("disparity " + pair + " -o " + path("bad.s16") + " " + options);
    EXPECT_EQ(bad.exit_code, 2) << options << ": " << bad.err;
    EXPECT_EQ(count_lines(bad.err), 1) << bad.err;
    EXPECT_EQ(bad.err.rfind(error_start, 0), 0u) << bad.err;
    EXPECT_FALSE(fs::exists(path("bad.s16")));
  }
}

TEST_F(Cli, DisparityMultiresolutionAndRightViewReachTheEngine) {
  ASSERT_EQ(run("disparity --synthetic --width 320 --height 96 --out-dir " + path("pair")).exit_code, 0);
  const std::string pair = path("pair/left.png") + " " + path("pair/right.png");
  const int width = 320, height = 96;
  // [-112, 32): 144 disparities, more than the full-resolution pass's 128, so that it searches
  // [-112, 16) and the scene's larger disparities (up to 26 px) come from the half-resolution pass.
  const int16_t invalid = (-112 - 1) * 16;
  auto map = [&](const std::string& name, const std::string& options) {
    const Result result = run("disparity " + pair + " -o " + path(name) + " --min-disp -112 --num-disp 144 " + options);
    EXPECT_EQ(result.exit_code, 0) << options << ": " << result.err;
    return result;
  };
  map("single.s16", "");
  const Result multires = map("multi.s16", "--multires on --right-out " + path("multi_right.s16"));
  EXPECT_NE(multires.out.find("multi-resolution: full resolution [-112, 16) px, half resolution [-56, 17) half px"),
            std::string::npos)
      << multires.out;
  EXPECT_NE(multires.out.find(", right view -> " + path("multi_right.s16")), std::string::npos) << multires.out;
  map("counted.s16", "--multires on --backend counting");
  // --multires-far caps the full-resolution pass: [-112, -96) here, the rest at half resolution.
  const Result capped = map("capped.s16", "--multires on --multires-far 16");
  EXPECT_NE(capped.out.find("multi-resolution: full resolution [-112, -96) px, half resolution [-56, 17) half px"),
            std::string::npos)
      << capped.out;
  map("right.s16", "--right-out " + path("right_only.s16") + " --fill");
  const Plane single = io::read_s16_raw(path("single.s16"), width, height);
  const Plane multi = io::read_s16_raw(path("multi.s16"), width, height);
  const Plane counted = io::read_s16_raw(path("counted.s16"), width, height);
  const Plane right_view = io::read_s16_raw(path("multi_right.s16"), width, height);
  const Plane filled_right = io::read_s16_raw(path("right_only.s16"), width, height);
  int multires_differs = 0, right_valid = 0, right_consistent = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      ASSERT_EQ(multi.at<int16_t>(x, y), counted.at<int16_t>(x, y)) << "counting back end differs at " << x << "," << y;
      ASSERT_NE(filled_right.at<int16_t>(x, y), invalid) << "--fill left a hole in the right view at " << x << "," << y;
      multires_differs += single.at<int16_t>(x, y) != multi.at<int16_t>(x, y) ? 1 : 0;
      // Right pixel x with disparity d sees left pixel x + d, whose left-view disparity is d too.
      const int d = right_view.at<int16_t>(x, y);
      if (d == invalid) continue;
      ++right_valid;
      const int left_x = x + (d + 8) / 16;  // d > 0 here (the scene has no negative disparity)
      right_consistent += left_x >= 0 && left_x < width && std::abs(multi.at<int16_t>(left_x, y) - d) <= 16 ? 1 : 0;
    }
  }
  EXPECT_GT(multires_differs, 0) << "--multires on gave the single-resolution map";
  EXPECT_GT(right_valid, width * height * 6 / 10);
  EXPECT_GT(right_consistent, right_valid * 9 / 10) << right_consistent << " of " << right_valid;
  EXPECT_TRUE(no_temporaries());
}

TEST_F(Cli, EvalRunsTheEngineAndOpenCvOnAKittiLayoutAndWritesEveryNumber) {
  // A KITTI 2015 layout made of the synthetic scene (its truth is a KITTI 16-bit PNG already).
  ASSERT_EQ(run("disparity --synthetic --width 320 --height 240 --out-dir " + path("scene")).exit_code, 0);
  for (const char* folder : {"image_2", "image_3", "disp_occ_0"}) fs::create_directories(path("data/kitti2015/") + folder);
  fs::copy_file(path("scene/left.png"), path("data/kitti2015/image_2/000046_10.png"));
  fs::copy_file(path("scene/right.png"), path("data/kitti2015/image_3/000046_10.png"));
  fs::copy_file(path("scene/ground_truth.png"), path("data/kitti2015/disp_occ_0/000046_10.png"));
  const Result result = run("eval kitti --baseline opencv --data " + path("data") + " --json " + path("r.json"));
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "eval: kitti2015/000046 320x240, disparities [0, 128) ...\n");
  EXPECT_NE(result.out.find("mean over 1 pair(s) (kitti)"), std::string::npos) << result.out;
  std::ifstream file(path("r.json"));
  const nlohmann::json json = nlohmann::json::parse(file);
  const nlohmann::json& methods = json["pairs"][0]["methods"];
  for (const char* method : {"lpstereo", "opencv MODE_SGBM", "opencv MODE_SGBM_3WAY", "opencv MODE_HH"}) {
    ASSERT_TRUE(methods.contains(method)) << method;
    EXPECT_EQ(methods[method]["all"]["ground_truth_pixels"], 320 * 240) << method;  // the scene's truth is dense
    EXPECT_TRUE(methods[method]["nonocc"]["dense"]["bad2_pct"].is_null()) << method;  // KITTI: no occlusion mask
    EXPECT_GT(methods[method]["all"]["density_pct"].get<double>(), 50.0) << method;
  }
  // The harness lines up views, truth and scale: OpenCV's SGM gets most of this textured scene right.
  EXPECT_LT(methods["opencv MODE_HH"]["all"]["dense"]["bad2_pct"].get<double>(), 15.0);
  EXPECT_EQ(json["mean"]["lpstereo"], methods["lpstereo"]);
  EXPECT_EQ(json["settings"]["lpstereo"]["multires"], false);

  // The multi-resolution engine, its full-resolution pass capped at 32 of the 128 px: named in the
  // settings, and its own map (not the single pass's numbers).
  const Result multires = run("eval kitti --multires on --multires-far 32 --data " + path("data") + " --json " + path("m.json"));
  ASSERT_EQ(multires.exit_code, 0) << multires.err;
  EXPECT_NE(multires.out.find("multi-resolution: at most 32 px at full resolution"), std::string::npos) << multires.out;
  std::ifstream multires_file(path("m.json"));
  const nlohmann::json multires_json = nlohmann::json::parse(multires_file);
  EXPECT_EQ(multires_json["settings"]["lpstereo"]["multires"], true);
  EXPECT_EQ(multires_json["settings"]["lpstereo"]["multires_far_disparities"], 32);
  const nlohmann::json& multires_all = multires_json["pairs"][0]["methods"]["lpstereo"]["all"];
  EXPECT_NE(multires_all["valid"]["epe_px"], methods["lpstereo"]["all"]["valid"]["epe_px"]);
  EXPECT_LT(multires_all["dense"]["bad2_pct"].get<double>(), 15.0);
}

}  // namespace
