// ARM task speckle_filter: bit-exact agreement with cv::filterSpeckles (CV_16S) on random and
// structured maps for several parameter sets, golden regions, the counted ArmWork closed form
// of arm/tasks/speckle_filter.cpp, and its bands on 2, 3 and 8 threads giving the one-thread
// bits and work (regions that cross the seams, both kept and removed).
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include <random>
#include <string>

#include "dag/arm_task.h"
#include "tests/kernels/kernel_check.h"

namespace lpstereo {
namespace {

const ArmTaskDescriptor& speckle_task() {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("speckle_filter");
  if (task == nullptr) throw std::runtime_error("ARM task 'speckle_filter' is not registered");
  return *task;
}

struct SpeckleRun {
  Plane output;
  ArmWork work;
};

SpeckleRun run_speckle(const Plane& input, const nlohmann::json& params) {
  const ArmTaskDescriptor& task = speckle_task();
  const PreparedKernel prepared = task.prepare(params, {{input.width(), input.height()}});
  SpeckleRun result{Plane(input.width(), input.height(), {ElementType::s16, 4}), {}};
  ArmTaskArgs args{{&input}, {&result.output}, prepared.params.get(), &result.work};
  task.run(args);
  return result;
}

Plane opencv_speckle(const Plane& input, int invalid_q4, int max_speckle_size, int max_difference_q4) {
  cv::Mat image(input.height(), input.width(), CV_16SC1);
  for (int y = 0; y < input.height(); ++y) {
    for (int x = 0; x < input.width(); ++x) image.at<int16_t>(y, x) = input.at<int16_t>(x, y);
  }
  cv::filterSpeckles(image, invalid_q4, max_speckle_size, max_difference_q4);
  Plane result(input.width(), input.height(), {ElementType::s16, 4});
  for (int y = 0; y < input.height(); ++y) {
    for (int x = 0; x < input.width(); ++x) result.at<int16_t>(x, y) = image.at<int16_t>(y, x);
  }
  return result;
}

// Random levels: neighbours are joined when close, so regions of every size appear.
Plane random_map(int width, int height, uint32_t seed, int levels, int step_q4, double invalid_share, int invalid_q4) {
  Plane plane(width, height, {ElementType::s16, 4}, width * 2 + 14);
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> level(0, levels - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      plane.at<int16_t>(x, y) = static_cast<int16_t>(unit(generator) < invalid_share ? invalid_q4 : level(generator) * step_q4);
    }
  }
  return plane;
}

// A disparity-like map: a ground ramp, rectangles at constant disparity, sub-pixel noise, and
// speckles (small blobs of a wrong value, invalid holes) of sizes 1 to 60 scattered over it.
Plane structured_map(int width, int height, uint32_t seed, int invalid_q4) {
  Plane plane(width, height, {ElementType::s16, 4});
  std::mt19937 generator(seed);
  std::uniform_int_distribution<int> noise(-3, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) plane.at<int16_t>(x, y) = static_cast<int16_t>(16 * (y / 4) + noise(generator));
  }
  std::uniform_int_distribution<int> px(0, width - 1), py(0, height - 1), side(1, 8), disparity(0, 1000);
  for (int box = 0; box < 12; ++box) {
    const int x0 = px(generator), y0 = py(generator), w = 4 * side(generator), h = 4 * side(generator), d = disparity(generator);
    for (int y = y0; y < std::min(height, y0 + h); ++y) {
      for (int x = x0; x < std::min(width, x0 + w); ++x) plane.at<int16_t>(x, y) = static_cast<int16_t>(d + noise(generator));
    }
  }
  for (int blob = 0; blob < 300; ++blob) {
    const int x0 = px(generator), y0 = py(generator), w = side(generator), h = side(generator);
    const int value = blob % 3 == 0 ? invalid_q4 : disparity(generator);
    for (int y = y0; y < std::min(height, y0 + h); ++y) {
      for (int x = x0; x < std::min(width, x0 + w); ++x) plane.at<int16_t>(x, y) = static_cast<int16_t>(value);
    }
  }
  return plane;
}

struct Settings {
  int invalid_q4, max_speckle_size, max_difference_q4;
};

const std::vector<Settings> kSettings = {{-16, 100, 16}, {-16, 20, 0}, {-16, 1, 32}, {-16, 0, 16}, {-272, 300, 48}, {-16, 5000, 16}};

TEST(SpeckleFilter, BitExactWithOpenCvFilterSpecklesOnRandomMaps) {
  for (const Settings& settings : kSettings) {
    for (auto [levels, step] : std::vector<std::pair<int, int>>{{3, 16}, {8, 10}, {40, 4}}) {
      for (double invalid_share : {0.0, 0.2, 0.6}) {
        const Plane input = random_map(211, 97, 7u + static_cast<uint32_t>(levels), levels, step, invalid_share, settings.invalid_q4);
        const nlohmann::json params = {{"invalid_q4", settings.invalid_q4}, {"max_speckle_size", settings.max_speckle_size},
                                       {"max_difference_q4", settings.max_difference_q4}};
        EXPECT_TRUE(testing::planes_equal(
            opencv_speckle(input, settings.invalid_q4, settings.max_speckle_size, settings.max_difference_q4),
            run_speckle(input, params).output))
            << "levels " << levels << " step " << step << " invalid share " << invalid_share << " params " << params.dump();
      }
    }
  }
}

TEST(SpeckleFilter, BitExactWithOpenCvFilterSpecklesOnStructuredMaps) {
  for (const Settings& settings : kSettings) {
    for (auto [width, height] : std::vector<std::pair<int, int>>{{640, 480}, {631, 97}, {1, 1}, {1, 50}, {50, 1}}) {
      const Plane input = structured_map(width, height, 9, settings.invalid_q4);
      const nlohmann::json params = {{"invalid_q4", settings.invalid_q4}, {"max_speckle_size", settings.max_speckle_size},
                                     {"max_difference_q4", settings.max_difference_q4}};
      const Plane filtered = run_speckle(input, params).output;
      EXPECT_TRUE(testing::planes_equal(
          opencv_speckle(input, settings.invalid_q4, settings.max_speckle_size, settings.max_difference_q4), filtered))
          << width << "x" << height << " params " << params.dump();
    }
  }
}

// Golden: a 6x3 map, invalid -16, max_difference 16, max size 3.
//   row 0: 100 100 100 100 300 -16
//   row 1: 100 116 132 100 300 -16
//   row 2: 100 100 100 100 -16 500
// The 100/116 region joins 132 (|132 - 116| <= 16, not |132 - 100|): 11 pixels, kept; 300 x2 is a speckle; 500 alone
// is a speckle; invalid stays invalid.
TEST(SpeckleFilter, GoldenRegionsAndCountedWork) {
  const int values[3][6] = {{100, 100, 100, 100, 300, -16}, {100, 116, 132, 100, 300, -16}, {100, 100, 100, 100, -16, 500}};
  const int expected[3][6] = {{100, 100, 100, 100, -16, -16}, {100, 116, 132, 100, -16, -16}, {100, 100, 100, 100, -16, -16}};
  Plane input(6, 3, {ElementType::s16, 4});
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 6; ++x) input.at<int16_t>(x, y) = static_cast<int16_t>(values[y][x]);
  }
  const SpeckleRun run = run_speckle(input, {{"invalid_q4", -16}, {"max_speckle_size", 3}, {"max_difference_q4", 16}});
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 6; ++x) EXPECT_EQ(run.output.at<int16_t>(x, y), expected[y][x]) << "x=" << x << " y=" << y;
  }
  // P = 18 pixels, V = 15 valid, R = 3 regions, I = 3 invalidated (closed form in the task's header).
  EXPECT_EQ(run.work.scalar_ops, 3u * 18 + 24u * 15 + 4u * 3 + 3u);
  EXPECT_EQ(run.work.memory_bytes, 5u * 18 + 2u * 3);
}

// The closed form on a larger map, from the map's own statistics: valid pixels, regions (counted
// here by a separate flood fill) and invalidated pixels.
TEST(SpeckleFilter, CountedWorkEqualsClosedForm) {
  const Plane input = structured_map(300, 200, 11, -16);
  const SpeckleRun run = run_speckle(input, {{"invalid_q4", -16}, {"max_speckle_size", 50}, {"max_difference_q4", 16}});
  const uint64_t pixels = 300 * 200;
  uint64_t valid = 0, invalidated = 0;
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 300; ++x) {
      valid += input.at<int16_t>(x, y) != -16 ? 1 : 0;
      invalidated += (input.at<int16_t>(x, y) != -16 && run.output.at<int16_t>(x, y) == -16) ? 1 : 0;
    }
  }
  // Regions: a union-find over the 4-neighbour relation.
  std::vector<int> parent(pixels);
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<int>(i);
  auto find = [&](int i) {
    while (parent[static_cast<size_t>(i)] != i) i = parent[static_cast<size_t>(i)] = parent[static_cast<size_t>(parent[static_cast<size_t>(i)])];
    return i;
  };
  auto joined = [&](int a, int b) { return a != -16 && b != -16 && std::abs(a - b) <= 16; };
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 300; ++x) {
      const int here = input.at<int16_t>(x, y);
      if (x + 1 < 300 && joined(here, input.at<int16_t>(x + 1, y))) parent[static_cast<size_t>(find(y * 300 + x))] = find(y * 300 + x + 1);
      if (y + 1 < 200 && joined(here, input.at<int16_t>(x, y + 1))) parent[static_cast<size_t>(find(y * 300 + x))] = find((y + 1) * 300 + x);
    }
  }
  uint64_t regions = 0;
  for (int i = 0; i < static_cast<int>(pixels); ++i) {
    regions += (input.at<int16_t>(i % 300, i / 300) != -16 && find(i) == i) ? 1 : 0;
  }
  EXPECT_GT(invalidated, 0u);
  EXPECT_EQ(run.work.scalar_ops, 3 * pixels + 24 * valid + 4 * regions + invalidated);
  EXPECT_EQ(run.work.memory_bytes, 5 * pixels + 2 * invalidated);
}

// A comb: teeth of 30 rows joined by a back along the bottom rows (one region of far more than
// 100 pixels, whose teeth alone are speckles in any band that holds no part of the back), beside
// speckles of 40-90 pixels cut by every seam, on a background of invalid pixels.
Plane comb_map(int width, int height, int invalid_q4) {
  Plane plane(width, height, {ElementType::s16, 4}, width * 2 + 6);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) plane.at<int16_t>(x, y) = static_cast<int16_t>(invalid_q4);
  }
  for (int x = 0; x < width / 2; ++x) {
    for (int y = height - 3; y < height; ++y) plane.at<int16_t>(x, y) = 500;  // the back
    if (x % 4 == 0) {
      for (int y = height - 33; y < height - 3; ++y) plane.at<int16_t>(x, y) = static_cast<int16_t>(500 + (y % 2) * 8);  // a tooth
    }
  }
  for (int x = width / 2 + 2; x + 3 < width; x += 5) {
    const int rows = 10 + (x * 7) % 20;  // 40-116 pixels: speckles and not
    for (int y = 0; y < rows; ++y) {
      for (int dx = 0; dx < 4; ++dx) plane.at<int16_t>(x + dx, (y + x) % height) = static_cast<int16_t>(900 + y);
    }
  }
  return plane;
}

TEST(SpeckleFilter, BandsOnThreadsGiveTheOneThreadBitsAndWork) {
  std::vector<std::pair<std::string, Plane>> maps;
  maps.emplace_back("comb 120x97", comb_map(120, 97, -16));
  maps.emplace_back("comb 257x64", comb_map(257, 64, -16));
  maps.emplace_back("structured 640x480", structured_map(640, 480, 9, -16));
  maps.emplace_back("structured 631x97", structured_map(631, 97, 5, -16));
  maps.emplace_back("random 211x97", random_map(211, 97, 3, 8, 10, 0.2, -16));
  maps.emplace_back("random 64x200", random_map(64, 200, 4, 3, 16, 0.0, -16));
  maps.emplace_back("one row", random_map(50, 1, 5, 3, 16, 0.2, -16));
  for (const auto& [name, input] : maps) {
    for (const Settings& settings : {Settings{-16, 100, 16}, Settings{-16, 20, 0}, Settings{-16, 5000, 16}}) {
      nlohmann::json params = {{"invalid_q4", settings.invalid_q4}, {"max_speckle_size", settings.max_speckle_size},
                               {"max_difference_q4", settings.max_difference_q4}};
      const SpeckleRun one = run_speckle(input, params);
      EXPECT_TRUE(testing::planes_equal(
          opencv_speckle(input, settings.invalid_q4, settings.max_speckle_size, settings.max_difference_q4), one.output))
          << name << " " << params.dump();
      for (int threads : {2, 3, 8}) {
        params["threads"] = threads;
        const SpeckleRun banded = run_speckle(input, params);
        EXPECT_TRUE(testing::planes_equal(one.output, banded.output)) << name << " " << params.dump();
        EXPECT_EQ(banded.work.scalar_ops, one.work.scalar_ops) << name << " " << params.dump();
        EXPECT_EQ(banded.work.memory_bytes, one.work.memory_bytes) << name << " " << params.dump();
      }
    }
  }
}

TEST(SpeckleFilterMustFail, RefusesUnknownAndOutOfRangeParameters) {
  const ArmTaskDescriptor& task = speckle_task();
  EXPECT_THROW(task.prepare({{"speckle_range", 2}}, {{10, 10}}), KernelError);
  try {
    task.prepare({{"max_difference_q4", -1}}, {{10, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "parameter 'max_difference_q4': expected an integer in [0, 65535], got -1");
  }
  EXPECT_THROW(task.prepare({{"threads", 0}}, {{10, 10}}), KernelError);
  EXPECT_THROW(task.prepare({{"threads", 65}}, {{10, 10}}), KernelError);
}

}  // namespace
}  // namespace lpstereo
