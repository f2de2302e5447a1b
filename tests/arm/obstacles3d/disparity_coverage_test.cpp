// The view check (arm/obstacles3d/disparity_coverage.h): the invalid share counted over the map's
// pixels and not its padding, the threshold's boundary, the counted work, and bad input; the chip's
// form (the ARM task "disparity_coverage" on per-row counts, arm/tasks/disparity_coverage.cpp) gives
// the same record as the host function on the same map, and refuses bad shapes and parameters.
#include "arm/obstacles3d/disparity_coverage.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "arm/tasks/coverage_record.h"
#include "dag/arm_task.h"

namespace lpstereo::arm::obstacles3d {
namespace {

constexpr int16_t kInvalidQ4 = -16;  // (min_disparity - 1) * 16 with min_disparity 0

// An odd-sized s16 map in a padded buffer: every pixel valid (disparity 5 px), the padding filled
// with the invalid value so that a count reaching past the row's width would show.
Plane padded_map(int width, int height) {
  Plane map(width, height, BufferFormat{ElementType::s16, 4}, 4 * 64);
  for (int y = 0; y < height; ++y) {
    int16_t* row = map.row<int16_t>(y);
    for (int x = 0; x < 4 * 64 / 2; ++x) row[x] = x < width ? int16_t{5 * 16} : kInvalidQ4;
  }
  return map;
}

TEST(DisparityCoverage, CountsTheInvalidPixelsOfTheMapNotOfItsPadding) {
  Plane map = padded_map(37, 11);  // 407 pixels
  DisparityCoverageParameters parameters;
  ArmWork work;
  DisparityCoverage coverage = disparity_coverage(map, kInvalidQ4, parameters, &work);
  EXPECT_EQ(coverage.pixels, 407);
  EXPECT_EQ(coverage.invalid_pixels, 0);
  EXPECT_FALSE(coverage.degraded);
  EXPECT_EQ(work.scalar_ops, 2u * 407);
  EXPECT_EQ(work.memory_bytes, 2u * 407);
  // A block of 5 x 8 = 40 pixels invalid, and one pixel with a valid negative-looking value that is
  // not the invalid one (disparity -0.5 px is not produced, but only the exact value counts).
  for (int y = 2; y < 7; ++y) {
    for (int x = 29; x < 37; ++x) map.at<int16_t>(x, y) = kInvalidQ4;
  }
  map.at<int16_t>(0, 0) = -8;
  coverage = disparity_coverage(map, kInvalidQ4, parameters, nullptr);
  EXPECT_EQ(coverage.invalid_pixels, 40);
  EXPECT_DOUBLE_EQ(coverage.invalid_share, 40.0 / 407.0);
  EXPECT_FALSE(coverage.degraded);  // 9.8 % < 10 %
}

TEST(DisparityCoverage, TheViewIsDegradedFromTheThresholdOn) {
  Plane map = padded_map(10, 10);
  for (int x = 0; x < 10; ++x) map.at<int16_t>(x, 0) = kInvalidQ4;  // 10 of 100: exactly 10 %
  DisparityCoverageParameters parameters;
  EXPECT_TRUE(disparity_coverage(map, kInvalidQ4, parameters).degraded);
  parameters.degraded_invalid_share = 0.11;
  EXPECT_FALSE(disparity_coverage(map, kInvalidQ4, parameters).degraded);
  parameters.degraded_invalid_share = 1.0;  // only a map with no valid pixel at all
  for (int y = 0; y < 10; ++y) {
    for (int x = 0; x < 10; ++x) map.at<int16_t>(x, y) = kInvalidQ4;
  }
  const DisparityCoverage all_invalid = disparity_coverage(map, kInvalidQ4, parameters);
  EXPECT_DOUBLE_EQ(all_invalid.invalid_share, 1.0);
  EXPECT_TRUE(all_invalid.degraded);
}

TEST(DisparityCoverage, BadInputNamesTheThing) {
  const Plane map = padded_map(8, 4);
  for (const double share : {0.0, -0.1, 1.5}) {
    DisparityCoverageParameters parameters;
    parameters.degraded_invalid_share = share;
    try {
      disparity_coverage(map, kInvalidQ4, parameters);
      ADD_FAILURE() << "no error for " << share;
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("degraded_invalid_share: expected (0, 1], got"), std::string::npos) << error.what();
    }
  }
  const Plane bytes(8, 4, BufferFormat{ElementType::u8});
  EXPECT_THROW(disparity_coverage(bytes, kInvalidQ4, DisparityCoverageParameters{}), std::invalid_argument);
}

TEST(DisparityCoverage, CountsOutsideTheMapAreRefused) {
  EXPECT_THROW(coverage_of_invalid_count(5, 4, DisparityCoverageParameters{}), std::invalid_argument);
  EXPECT_THROW(coverage_of_invalid_count(-1, 4, DisparityCoverageParameters{}), std::invalid_argument);
  const DisparityCoverage empty = coverage_of_invalid_count(0, 0, DisparityCoverageParameters{});
  EXPECT_TRUE(empty.degraded);
  EXPECT_EQ(empty.invalid_share, 0.0);
}

const ArmTaskDescriptor& coverage_task() {
  const ArmTaskDescriptor* task = ArmTaskRegistry::instance().find("disparity_coverage");
  if (task == nullptr) throw std::runtime_error("ARM task 'disparity_coverage' is not registered");
  return *task;
}

// Runs the task on a map's per-row invalid counts (what the v_disparity node with one bin below the
// range gives; counted here directly) and returns its record.
std::vector<uint32_t> task_record(const Plane& map, const nlohmann::json& params, ArmWork* work) {
  Plane rows(1, map.height(), BufferFormat{ElementType::u16, 0});
  for (int y = 0; y < map.height(); ++y) {
    int count = 0;
    for (int x = 0; x < map.width(); ++x) count += map.at<int16_t>(x, y) == kInvalidQ4 ? 1 : 0;
    rows.at<uint16_t>(0, y) = static_cast<uint16_t>(count);
  }
  const ArmTaskDescriptor& task = coverage_task();
  const PreparedKernel prepared = task.prepare(params, {{1, map.height()}, {map.width(), map.height()}});
  EXPECT_EQ(prepared.output_shapes.at(0).width, arm::kCoverageWords);
  Plane record(arm::kCoverageWords, 1, BufferFormat{ElementType::u32, 0});
  task.run(ArmTaskArgs{{&rows, &map}, {&record}, prepared.params.get(), work});
  return std::vector<uint32_t>(record.row<uint32_t>(0), record.row<uint32_t>(0) + arm::kCoverageWords);
}

TEST(DisparityCoverageTask, GivesTheHostFunctionsVerdictFromRowCounts) {
  Plane map = padded_map(37, 11);
  for (int y = 2; y < 7; ++y) {
    for (int x = 29; x < 37; ++x) map.at<int16_t>(x, y) = kInvalidQ4;  // 40 of 407: 9.8 %
  }
  ArmWork work;
  std::vector<uint32_t> record = task_record(map, nlohmann::json::object(), &work);
  DisparityCoverage host = disparity_coverage(map, kInvalidQ4, DisparityCoverageParameters{});
  EXPECT_EQ(record[arm::kCoverageInvalidPixels], static_cast<uint32_t>(host.invalid_pixels));
  EXPECT_EQ(record[arm::kCoveragePixels], 407u);
  EXPECT_EQ(record[arm::kCoverageInvalidPer65536], 40u * 65536u / 407u);
  EXPECT_EQ(record[arm::kCoverageDegraded], host.degraded ? 1u : 0u);
  EXPECT_EQ(record[arm::kCoverageDegraded], 0u);
  EXPECT_EQ(work.scalar_ops, 2u * 11 + 8);
  EXPECT_EQ(work.memory_bytes, 2u * 11);
  // One more invalid pixel: 41 of 407 = 10.07 %, degraded with the default, not with 0.2.
  map.at<int16_t>(0, 0) = kInvalidQ4;
  record = task_record(map, nlohmann::json::object(), nullptr);
  host = disparity_coverage(map, kInvalidQ4, DisparityCoverageParameters{});
  EXPECT_TRUE(host.degraded);
  EXPECT_EQ(record[arm::kCoverageDegraded], 1u);
  EXPECT_EQ(task_record(map, {{"degraded_invalid_share", 0.2}}, nullptr)[arm::kCoverageDegraded], 0u);
  // Every pixel invalid (a texture-less view): the share is exactly 65536 / 65536.
  for (int y = 0; y < 11; ++y) {
    for (int x = 0; x < 37; ++x) map.at<int16_t>(x, y) = kInvalidQ4;
  }
  record = task_record(map, nlohmann::json::object(), nullptr);
  EXPECT_EQ(record[arm::kCoverageInvalidPer65536], 65536u);
  EXPECT_EQ(record[arm::kCoverageDegraded], 1u);
}

void expect_prepare_error(const nlohmann::json& params, const std::vector<PlaneShape>& shapes, const std::vector<std::string>& words) {
  try {
    coverage_task().prepare(params, shapes);
    ADD_FAILURE() << "no error";
  } catch (const KernelError& error) {
    for (const std::string& word : words) EXPECT_NE(std::string(error.what()).find(word), std::string::npos) << error.what();
  }
}

TEST(DisparityCoverageTask, PrepareRefusesBadShapesAndParameters) {
  const std::vector<PlaneShape> shapes = {{1, 11}, {37, 11}};
  EXPECT_NO_THROW(coverage_task().prepare(nlohmann::json::object(), shapes));
  expect_prepare_error(nlohmann::json::object(), {{1, 11}}, {"inputs", "expected 2", "got 1"});
  expect_prepare_error(nlohmann::json::object(), {{2, 11}, {37, 11}}, {"'invalid_rows'", "1x11", "2x11"});
  expect_prepare_error(nlohmann::json::object(), {{1, 12}, {37, 11}}, {"'invalid_rows'", "1x11", "1x12"});
  expect_prepare_error(nlohmann::json::object(), {{1, 11}, {65536, 11}}, {"'disparity'", "65535", "65536"});
  for (const double share : {0.0, 1.5}) expect_prepare_error({{"degraded_invalid_share", share}}, shapes, {"degraded_invalid_share"});
  expect_prepare_error({{"threshold", 0.1}}, shapes, {"threshold"});
}

}  // namespace
}  // namespace lpstereo::arm::obstacles3d
