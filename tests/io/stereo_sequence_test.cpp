// io/stereo_sequence and the floating objects of io/stereo_synth: the truth of a ball and an elevated
// board against ray intersections computed here independently (with a moved, yawed camera), the
// free space under a hanging sign and a board on poles, and a written sequence: static objects fixed
// in the world through poses.txt, moving ones advancing by velocity / fps, truth.jsonl's fields,
// bad options in one line.
#include "io/stereo_sequence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "io/kitti_poses.h"
#include "tests/support/scratch_directory.h"

namespace {

using namespace lpstereo;
namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;

io::StereoSynthOptions small_options() {
  io::StereoSynthOptions options;
  options.width = 320;
  options.height = 240;
  options.hfov_deg = 60;
  options.samples_per_axis = 1;
  return options;
}

double focal_px(const io::StereoSynthOptions& o) { return o.width / 2.0 / std::tan(o.hfov_deg * kPi / 360.0); }

// The test's own camera model (docs/synth.md): the ray through pixel (u, v) in the road frame, as a
// camera-frame vector (x, y, 1) turned by Ry(yaw) Rx(pitch) (no roll here), so the hit parameter is
// the camera-frame depth; the camera centre is at (camera_x, 0, camera_z) on a flat road.
struct TestCamera {
  double f, cx, cy, pitch, yaw, x0, z0;
  explicit TestCamera(const io::StereoSynthOptions& o)
      : f(focal_px(o)), cx((o.width - 1) / 2.0), cy((o.height - 1) / 2.0), pitch(o.pitch_rad), yaw(o.camera_yaw_rad), x0(o.camera_x_m),
        z0(o.camera_z_m) {}
  Eigen::Vector3d ray(double u, double v) const {
    const Eigen::Vector3d camera((u - cx) / f, (v - cy) / f, 1);
    const Eigen::Matrix3d rotation =
        (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitX())).toRotationMatrix();
    return rotation * camera;
  }
  Eigen::Vector3d centre() const { return {x0, 0, z0}; }
};

TEST(StereoSequenceFloating, BallDisparityIsFocalTimesBaselineOverTheSphereHitDepth) {
  io::StereoSynthOptions options = small_options();
  options.camera_x_m = 0.4, options.camera_z_m = 3, options.camera_yaw_rad = 0.06, options.pitch_rad = 0.04;
  io::SynthObject ball = io::synth_object(io::SynthClass::ball_on_post, 0.9, 11);
  ball.width_m = 0.8, ball.height_m = 2.0;  // centre 1.6 m above the road: above the 1.5 m camera
  options.objects = {ball};
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const TestCamera camera(options);
  const double radius = ball.width_m / 2;
  // Y down: the road is Y = camera_height; the centre height_m - radius above it.
  const Eigen::Vector3d centre(ball.x_m, options.camera_height_m - (ball.height_m - radius), ball.z_m);
  int checked = 0;
  for (int v = 0; v < options.height; ++v) {
    for (int u = 0; u < options.width; ++u) {
      const Eigen::Vector3d d = camera.ray(u, v), o = camera.centre() - centre;
      const double a = d.dot(d), b = 2 * o.dot(d), c = o.dot(o) - radius * radius, disc = b * b - 4 * a * c;
      if (disc < 0) continue;
      const double t = (-b - std::sqrt(disc)) / (2 * a);
      // Rays grazing the rim or meeting the post's top first are left out: far inside the disc only.
      if (o.dot(o) - o.dot(d) * o.dot(d) / a > 0.64 * radius * radius) continue;
      ASSERT_EQ(scene.object_ids.at<uint16_t>(v, u), 1) << u << "," << v;
      EXPECT_NEAR(scene.disparity_px.at<float>(v, u), camera.f * options.baseline_m / t, 1e-4 * camera.f * options.baseline_m / t)
          << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_NEAR(scene.objects[0].min_height_m, 1.2, 1e-12);
  EXPECT_NEAR(scene.objects[0].max_height_m, 2.0, 1e-12);
}

TEST(StereoSequenceFloating, ElevatedBoardDisparityIsFocalTimesBaselineOverItsFrontFaceDepth) {
  io::StereoSynthOptions options = small_options();
  options.pitch_rad = 0.05;
  io::SynthObject board = io::synth_object(io::SynthClass::board_on_poles, -0.3, 9);
  options.objects = {board};
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const TestCamera camera(options);
  const double front_z = board.z_m - board.length_m / 2;
  int checked = 0;
  for (int v = 0; v < options.height; ++v) {
    for (int u = 0; u < options.width; ++u) {
      const Eigen::Vector3d d = camera.ray(u, v);
      const double t = front_z / d.z();
      const double x = t * d.x(), height = options.camera_height_m - t * d.y();
      // Inside the front face, 2 cm from its edges and clear of the 8 cm posts.
      if (std::abs(x - board.x_m) > board.width_m / 2 - 0.1 || height < board.clearance_m + 0.02 || height > board.height_m - 0.02) continue;
      ASSERT_EQ(scene.object_ids.at<uint16_t>(v, u), 1) << u << "," << v;
      EXPECT_NEAR(scene.disparity_px.at<float>(v, u), camera.f * options.baseline_m / t, 1e-5 * camera.f * options.baseline_m / t);
      ++checked;
    }
  }
  EXPECT_GT(checked, 500);
  EXPECT_NEAR(scene.objects[0].min_height_m, 0.9, 1e-12);
  EXPECT_NEAR(scene.objects[0].max_height_m, 1.6, 1e-12);
}

// The column through the board's centre: rows below its lower edge (projected here) show no object,
// and where they meet the road, the road's exact disparity; rows on the board show the board.
void expect_free_space_under(const io::SynthObject& object, double board_top_m) {
  io::StereoSynthOptions options = small_options();
  options.objects = {object};
  const io::StereoSynthScene scene = io::render_stereo_synth(options);
  const double f = focal_px(options), cx = (options.width - 1) / 2.0, cy = (options.height - 1) / 2.0;
  const double front_z = object.z_m - object.length_m / 2;
  const int u = static_cast<int>(std::lround(f * object.x_m / front_z + cx));
  // Y down from the camera: the lower edge at camera_height - clearance above the road.
  const double lower_edge_v = f * (options.camera_height_m - object.clearance_m) / front_z + cy;
  const double upper_edge_v = f * (options.camera_height_m - board_top_m) / front_z + cy;
  int board_rows = 0, road_rows = 0;
  for (int v = 0; v < options.height; ++v) {
    const int id = scene.object_ids.at<uint16_t>(v, u);
    if (v > upper_edge_v + 1 && v < lower_edge_v - 1) {
      EXPECT_EQ(id, 1) << "row " << v;
      ++board_rows;
    } else if (v > lower_edge_v + 1) {
      EXPECT_EQ(id, 0) << "row " << v << " under the board";
      const double road = io::synth_road_disparity_px(options, u, v);
      if (std::isfinite(road)) {
        EXPECT_NEAR(scene.disparity_px.at<float>(v, u), road, 1e-4 * road) << "row " << v;
        ++road_rows;
      }
    }
  }
  EXPECT_GT(board_rows, 3);
  EXPECT_GT(road_rows, 20);
}

TEST(StereoSequenceFloating, FreeSpaceUnderAHangingSignShowsTheRoad) {
  io::SynthObject sign = io::synth_object(io::SynthClass::hanging_sign, 0.2, 12);
  expect_free_space_under(sign, sign.height_m - 0.35);
}

TEST(StereoSequenceFloating, FreeSpaceUnderABoardOnPolesShowsTheRoad) {
  io::SynthObject board = io::synth_object(io::SynthClass::board_on_poles, 0.2, 8);
  expect_free_space_under(board, board.height_m);
}

TEST(StereoSequenceFloating, BadClearanceGivesOneLine) {
  io::StereoSynthOptions options = small_options();
  io::SynthObject board = io::synth_object(io::SynthClass::board_on_poles, 0, 8);
  board.clearance_m = 2.0;  // above its top
  options.objects = {board};
  try {
    io::validate_synth_options(options);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("board_on_poles clearance"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
}

TEST(StereoSequenceFloating, MovedCameraAtTheOriginRendersTheSameAsTheDefault) {
  // The moved-camera arithmetic with a pose of (0, 0, 0) would be the default: exercised by a tiny
  // yaw of 0 being exact, here by comparing a camera moved forward with objects moved back.
  io::StereoSynthOptions at_origin = small_options();
  at_origin.objects = {io::synth_object(io::SynthClass::box, 0.5, 10)};
  io::StereoSynthOptions moved = at_origin;
  moved.camera_z_m = 4;
  moved.objects[0].z_m = 14;
  const io::StereoSynthScene a = io::render_stereo_synth(at_origin), b = io::render_stereo_synth(moved);
  // The object's truth is the same in the camera frame; its pixels the same set.
  EXPECT_NEAR(a.objects[0].position_m[2], 10, 1e-12);
  EXPECT_NEAR(b.objects[0].position_m[2], 10, 1e-9);
  EXPECT_EQ(a.objects[0].visible_pixels, b.objects[0].visible_pixels);
  EXPECT_EQ(cv::countNonZero(a.object_ids != b.object_ids), 0);
}

io::StereoSequenceOptions small_sequence() {
  io::StereoSequenceOptions options;
  options.base = small_options();
  options.base.width = 160;
  options.base.height = 120;
  options.base.objects = {io::synth_object(io::SynthClass::bin, 1.5, 20), io::synth_object(io::SynthClass::hanging_sign, -1, 25)};
  options.moving = {{io::synth_object(io::SynthClass::pedestrian, -4, 18), 1.5, 0}, {io::synth_object(io::SynthClass::car, 3.5, 40), 0, -9}};
  options.camera_speed_mps = 6;
  options.yaw_rate_rad_s = 0.05;
  options.fps = 10;
  options.frames = 4;
  return options;
}

class StereoSequenceFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    options_ = small_sequence();
    options_.base.colour = true;
    io::write_stereo_sequence(folder(), options_);
  }
  std::string folder() const { return scratch_.path("sequence"); }
  std::vector<nlohmann::json> truth() const {
    std::ifstream file(folder() + "/truth.jsonl");
    std::vector<nlohmann::json> lines;
    std::string line;
    while (std::getline(file, line)) lines.push_back(nlohmann::json::parse(line));
    return lines;
  }
  static Eigen::Vector3d position(const nlohmann::json& object) {
    return {object["position_m"][0].get<double>(), object["position_m"][1].get<double>(), object["position_m"][2].get<double>()};
  }
  lpstereo::testing::ScratchDirectory scratch_{"lpstereo_stereo_sequence"};
  io::StereoSequenceOptions options_;
};

TEST_F(StereoSequenceFolder, HasEveryFileAndTruthJsonlHasTheFields) {
  for (const char* sub : {"left", "right", "left_colour", "right_colour", "disparity", "object_ids"}) {
    for (int frame = 0; frame < 4; ++frame) {
      char name[32];
      std::snprintf(name, sizeof name, "/%06d.png", frame);
      EXPECT_TRUE(fs::is_regular_file(folder() + "/" + sub + name)) << sub << name;
    }
  }
  for (const char* name : {"poses.txt", "times.txt", "calib.yaml", "calib_cam_to_cam.txt", "calib.txt", "truth.jsonl", "sequence.json"}) {
    EXPECT_TRUE(fs::is_regular_file(folder() + "/" + name)) << name;
  }
  const std::vector<nlohmann::json> lines = truth();
  ASSERT_EQ(lines.size(), 4u);
  for (size_t frame = 0; frame < lines.size(); ++frame) {
    EXPECT_EQ(lines[frame]["frame"].get<int>(), static_cast<int>(frame));
    ASSERT_EQ(lines[frame]["objects"].size(), 4u);
    for (const nlohmann::json& object : lines[frame]["objects"]) {
      for (const char* key : {"id", "class", "position_m", "size_m", "min_height_m", "max_height_m", "velocity_mps", "moving", "bbox_px",
                              "visible_pixels"}) {
        EXPECT_TRUE(object.contains(key)) << key;
      }
    }
    EXPECT_EQ(lines[frame]["objects"][1]["class"], "hanging_sign");
    EXPECT_NEAR(lines[frame]["objects"][1]["min_height_m"].get<double>(), 1.9, 1e-12);
    EXPECT_FALSE(lines[frame]["objects"][0]["moving"].get<bool>());
    EXPECT_TRUE(lines[frame]["objects"][2]["moving"].get<bool>());
    EXPECT_GT(lines[frame]["objects"][0]["visible_pixels"].get<int>(), 0);
  }
  EXPECT_EQ(io::read_kitti_poses(folder() + "/poses.txt").size(), 4u);
}

TEST_F(StereoSequenceFolder, StaticObjectsStayPutInTheWorldThroughPoses) {
  const std::vector<Eigen::Isometry3d> poses = io::read_kitti_poses(folder() + "/poses.txt");
  const std::vector<nlohmann::json> lines = truth();
  ASSERT_EQ(poses.size(), lines.size());
  EXPECT_TRUE(poses[0].isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  // The camera moves: 0.6 m a frame at 6 m/s and 10 fps.
  EXPECT_NEAR(poses[1].translation().norm(), 0.6, 0.01);
  for (int id : {0, 1}) {
    const Eigen::Vector3d first = position(lines[0]["objects"][id]);
    for (size_t frame = 1; frame < lines.size(); ++frame) {
      const Eigen::Vector3d in_first = poses[frame] * position(lines[frame]["objects"][id]);
      EXPECT_LT((in_first - first).norm(), 1e-6) << "object " << id << " frame " << frame;
      EXPECT_GT((position(lines[frame]["objects"][id]) - first).norm(), 0.3);  // while its camera-frame position changes
    }
  }
}

TEST_F(StereoSequenceFolder, MovingObjectsAdvanceByVelocityOverFpsEachFrame) {
  const std::vector<Eigen::Isometry3d> poses = io::read_kitti_poses(folder() + "/poses.txt");
  const std::vector<nlohmann::json> lines = truth();
  for (int id : {2, 3}) {
    const nlohmann::json& first = lines[0]["objects"][id];
    const Eigen::Vector3d velocity(first["velocity_mps"][0].get<double>(), first["velocity_mps"][1].get<double>(),
                                   first["velocity_mps"][2].get<double>());
    // The road velocity, turned into the first camera's axes: its length is the speed.
    const io::SynthMovingObject& moving = options_.moving[static_cast<size_t>(id - 2)];
    EXPECT_NEAR(velocity.norm(), std::hypot(moving.velocity_x_mps, moving.velocity_z_mps), 1e-9);
    for (size_t frame = 1; frame < lines.size(); ++frame) {
      const Eigen::Vector3d step = poses[frame] * position(lines[frame]["objects"][id]) -
                                   poses[frame - 1] * position(lines[frame - 1]["objects"][id]);
      EXPECT_LT((step - velocity / options_.fps).norm(), 1e-6) << "object " << id << " frame " << frame;
      // Each frame's velocity_mps is the same world velocity in that frame's axes.
      const nlohmann::json& now = lines[frame]["objects"][id]["velocity_mps"];
      const Eigen::Vector3d turned = poses[frame].linear() * Eigen::Vector3d(now[0].get<double>(), now[1].get<double>(), now[2].get<double>());
      EXPECT_LT((turned - velocity).norm(), 1e-9);
    }
  }
}

TEST(StereoSequence, FramesAreDeterministic) {
  const io::StereoSequenceOptions options = small_sequence();
  const io::StereoSequenceFrame a = io::render_sequence_frame(options, 2), b = io::render_sequence_frame(options, 2);
  EXPECT_EQ(cv::countNonZero(a.scene.left != b.scene.left), 0);
  EXPECT_EQ(cv::countNonZero(a.scene.right != b.scene.right), 0);
}

// The ego-motion the obstacle evaluations take from the poses: a camera driving straight ahead at
// v m/s, f fps, level on a flat road, moves v / f along its own z between frames, so the previous
// frame sees the current origin at (0, 0, v / f), with no rotation; on a yaw-rate arc the rotation
// angle between frames is rate / f.
TEST(StereoSequence, CameraPreviousFromCurrentIsTheDriveBetweenFrames) {
  io::StereoSequenceOptions options = small_sequence();
  options.base.ground = io::SynthGround{};
  options.base.pitch_rad = options.base.roll_rad = 0;
  options.yaw_rate_rad_s = 0;
  const auto pose = [&](int frame) { return io::synth_camera_pose(io::sequence_frame_options(options, frame)); };
  const Eigen::Isometry3d straight = io::camera_previous_from_current(pose(1), pose(2));
  EXPECT_NEAR((straight.translation() - Eigen::Vector3d(0, 0, options.camera_speed_mps / options.fps)).norm(), 0, 1e-9);
  EXPECT_NEAR((straight.linear() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  options.yaw_rate_rad_s = 0.2;
  const Eigen::Isometry3d turning = io::camera_previous_from_current(pose(1), pose(2));
  EXPECT_NEAR(Eigen::AngleAxisd(turning.linear()).angle(), 0.2 / options.fps, 1e-9);
  EXPECT_NEAR(turning.translation().norm(), 2 * options.camera_speed_mps / 0.2 * std::sin(0.2 / options.fps / 2), 1e-9);
}

TEST(StereoSequence, BadOptionsGiveOneLine) {
  auto message_of = [](const io::StereoSequenceOptions& options) -> std::string {
    try {
      io::validate_stereo_sequence(options);
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return "";
  };
  io::StereoSequenceOptions options = small_sequence();
  options.fps = 0;
  EXPECT_NE(message_of(options).find("fps: expected"), std::string::npos) << message_of(options);
  options = small_sequence();
  options.frames = 0;
  EXPECT_NE(message_of(options).find("frames: expected"), std::string::npos);
  options = small_sequence();
  options.frames = 60;  // the oncoming car (40 m at 9 m/s) passes the road's origin
  const std::string passed = message_of(options);
  EXPECT_NE(passed.find("object car z"), std::string::npos) << passed;
  EXPECT_EQ(passed.find('\n'), std::string::npos);
  EXPECT_THROW(io::preset_stereo_sequence("harbour", 1), std::invalid_argument);
}

// Issue 10 evaluates sequences of at least 300 frames (30 s at the presets' 10 fps), with several seeds.
TEST(StereoSequence, PresetsAreValidForThreeHundredFrames) {
  for (const char* name : {"urban", "country", "mining", "floating"}) {
    for (uint32_t seed = 1; seed <= 8; ++seed) {
      io::StereoSequenceOptions options = io::preset_stereo_sequence(name, seed);
      options.frames = 300;
      EXPECT_NO_THROW(io::validate_stereo_sequence(options)) << name << " seed " << seed;
    }
    io::StereoSequenceOptions options = io::preset_stereo_sequence(name, 7);
    EXPECT_FALSE(options.moving.empty()) << name;
    EXPECT_FALSE(options.base.objects.empty()) << name;
  }
  EXPECT_GT(io::preset_stereo_sequence("country", 7).base.ground.hills_amplitude_m, 0);
  EXPECT_GT(io::preset_stereo_sequence("mining", 7).base.ground.rough_amplitude_m, 0);
}

}  // namespace
