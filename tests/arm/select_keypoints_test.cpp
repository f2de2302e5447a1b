// ARM task select_keypoints: by hand (cells, ties, border, the max_keypoints cut, zero rows after
// the list), against a brute-force selection (sort each cell, sort the union) on random masks, the
// counted work in the closed form of arm/tasks/select_keypoints.cpp, and refused shapes and
// parameters.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>

#include "arm/tasks/keypoint_record.h"
#include "dag/arm_task.h"

namespace lpstereo {
namespace {

using arm::kKeypointResponse;
using arm::kKeypointValid;
using arm::kKeypointWords;
using arm::kKeypointXPx;
using arm::kKeypointYPx;

const ArmTaskDescriptor& task() {
  const ArmTaskDescriptor* found = ArmTaskRegistry::instance().find("select_keypoints");
  if (found == nullptr) throw std::runtime_error("ARM task 'select_keypoints' is not registered");
  return *found;
}

struct TaskRun {
  Plane keypoints;
  ArmWork work;
};

TaskRun run_task(const Plane& corners, const Plane& response, const nlohmann::json& params) {
  const PreparedKernel prepared =
      task().prepare(params, {{corners.width(), corners.height()}, {response.width(), response.height()}});
  TaskRun result{Plane(prepared.output_shapes[0].width, prepared.output_shapes[0].height, {ElementType::s32, 0})};
  for (int y = 0; y < result.keypoints.height(); ++y) {
    for (int x = 0; x < result.keypoints.width(); ++x) result.keypoints.at<int32_t>(x, y) = -7;  // must be overwritten
  }
  ArmTaskArgs args{{&corners, &response}, {&result.keypoints}, prepared.params.get(), &result.work};
  task().run(args);
  return result;
}

struct Point {
  int x, y, response;
  bool operator==(const Point&) const = default;
};

std::vector<Point> listed(const Plane& keypoints) {
  std::vector<Point> points;
  bool ended = false;
  for (int row = 0; row < keypoints.height(); ++row) {
    const int32_t* word = keypoints.row<const int32_t>(row);
    if (word[kKeypointValid] == 0) {
      ended = true;
      for (int i = 0; i < kKeypointWords; ++i) EXPECT_EQ(word[i], 0) << "unused row " << row << " word " << i;
      continue;
    }
    EXPECT_FALSE(ended) << "a used row after an unused one: " << row;
    EXPECT_EQ(word[kKeypointValid], 1);
    points.push_back({word[kKeypointXPx], word[kKeypointYPx], word[kKeypointResponse]});
  }
  return points;
}

struct Planes {
  Plane corners, response;
};

Planes empty_planes(int width, int height) {
  Planes planes{Plane(width, height, {ElementType::u8, 0}, width + 5), Plane(width, height, {ElementType::s32, 0})};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      planes.corners.at<uint8_t>(x, y) = 0;
      planes.response.at<int32_t>(x, y) = 1000 + x;  // non-corners carry responses too: must be ignored
    }
  }
  return planes;
}

void put(Planes& planes, int x, int y, int response) {
  planes.corners.at<uint8_t>(x, y) = 1;
  planes.response.at<int32_t>(x, y) = response;
}

// Cells of 16 px, 2 per cell, border 4. Cell (0, 0) has three corners (the weakest drops), cell
// (1, 0) two with equal responses (both kept; the upper row first), one corner sits in the border
// band (dropped), and the list is strongest first.
TEST(SelectKeypoints, KeepsTheStrongestPerCellInsideTheBorderStrongestFirst) {
  Planes planes = empty_planes(40, 30);
  put(planes, 5, 5, 300);
  put(planes, 10, 8, 500);
  put(planes, 12, 12, 100);   // third in cell (0, 0): dropped
  put(planes, 20, 9, 400);
  put(planes, 25, 6, 400);    // tie with (20, 9): row 6 first
  put(planes, 2, 20, 900);    // x < border 4: dropped
  put(planes, 35, 25, 50);    // x = 35 < 40 - 4 and y = 25 < 26: kept, cell (2, 1)
  put(planes, 37, 10, 950);   // x = 37 >= 36: dropped
  const TaskRun run = run_task(planes.corners, planes.response, {{"cell_size_px", 16}, {"per_cell_k", 2}, {"max_keypoints", 10}, {"border_px", 4}});
  const std::vector<Point> expected = {{10, 8, 500}, {25, 6, 400}, {20, 9, 400}, {5, 5, 300}, {35, 25, 50}};
  EXPECT_EQ(listed(run.keypoints), expected);
  EXPECT_EQ(run.keypoints.height(), 10);
  EXPECT_EQ(run.keypoints.width(), kKeypointWords);

  // max_keypoints 3: the three strongest of the same selection.
  const TaskRun cut = run_task(planes.corners, planes.response, {{"cell_size_px", 16}, {"per_cell_k", 2}, {"max_keypoints", 3}, {"border_px", 4}});
  EXPECT_EQ(listed(cut.keypoints), std::vector<Point>(expected.begin(), expected.begin() + 3));
}

TEST(SelectKeypoints, NoCornersGiveAnAllZeroList) {
  Planes planes = empty_planes(33, 17);
  const TaskRun run = run_task(planes.corners, planes.response, {{"max_keypoints", 5}});
  EXPECT_TRUE(listed(run.keypoints).empty());
  // An image smaller than twice the border has no inside at all.
  Planes tiny = empty_planes(20, 20);
  put(tiny, 10, 10, 5000);
  EXPECT_TRUE(listed(run_task(tiny.corners, tiny.response, {{"border_px", 16}}).keypoints).empty());
}

// Random masks against a brute force (every cell's candidates sorted, the union sorted), with the
// counted work recomputed from the closed form.
TEST(SelectKeypoints, MatchesBruteForceAndCountsItsWork) {
  std::mt19937 generator(51);
  for (int trial = 0; trial < 6; ++trial) {
    const int width = 97 + 13 * trial, height = 61 + 7 * trial;
    const int cell = 8 + 5 * trial, k = 1 + trial % 3, max_keypoints = 10 + 17 * trial, border = trial;
    Planes planes = empty_planes(width, height);
    std::uniform_int_distribution<int> response(0, 40);  // few values: many ties
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        if (unit(generator) < 0.05) put(planes, x, y, response(generator) * 1000);
      }
    }
    const TaskRun run = run_task(planes.corners, planes.response,
                             {{"cell_size_px", cell}, {"per_cell_k", k}, {"max_keypoints", max_keypoints}, {"border_px", border}});
    auto order = [](const Point& a, const Point& b) { return std::make_tuple(-a.response, a.y, a.x) < std::make_tuple(-b.response, b.y, b.x); };
    const int cells_x = (width + cell - 1) / cell, cells_y = (height + cell - 1) / cell;
    std::vector<std::vector<Point>> by_cell(static_cast<size_t>(cells_x * cells_y));
    int64_t candidates = 0, words_with_corner = 0, words = 0;
    for (int y = border; y < height - border; ++y) {
      for (int x = border; x < width - border; x += 8) {
        ++words;
        bool any = false;
        for (int i = x; i < std::min(x + 8, width - border); ++i) {
          if (planes.corners.at<uint8_t>(i, y) == 0) continue;
          any = true;
          ++candidates;
          by_cell[static_cast<size_t>((y / cell) * cells_x + i / cell)].push_back({i, y, planes.response.at<int32_t>(i, y)});
        }
        words_with_corner += any ? 1 : 0;
      }
    }
    std::vector<Point> all;
    for (std::vector<Point>& points : by_cell) {
      std::sort(points.begin(), points.end(), order);
      all.insert(all.end(), points.begin(), points.begin() + std::min<ptrdiff_t>(k, static_cast<ptrdiff_t>(points.size())));
    }
    std::sort(all.begin(), all.end(), order);
    const int64_t kept = static_cast<int64_t>(all.size());
    if (static_cast<int>(all.size()) > max_keypoints) all.resize(static_cast<size_t>(max_keypoints));
    EXPECT_EQ(listed(run.keypoints), all) << "trial " << trial;
    ASSERT_GT(candidates, 0);
    int64_t log_term = 0;
    while ((int64_t{1} << log_term) < kept + 1) ++log_term;  // ceil(log2(S + 1))
    EXPECT_EQ(run.work.scalar_ops, static_cast<uint64_t>(2 * words + 16 * words_with_corner + candidates * (4 + k) +
                                                         2 * kept * log_term + 8 * max_keypoints))
        << "trial " << trial;
    EXPECT_EQ(run.work.memory_bytes, static_cast<uint64_t>(8 * words + 4 * candidates + 4 * kKeypointWords * max_keypoints));
  }
}

TEST(SelectKeypointsMustFail, RefusesBadShapesAndParameters) {
  EXPECT_THROW(task().prepare({{"cells", 3}}, {{10, 10}, {10, 10}}), KernelError);
  EXPECT_THROW(task().prepare({{"per_cell_k", 0}}, {{10, 10}, {10, 10}}), KernelError);
  EXPECT_THROW(task().prepare({}, {{10, 10}}), KernelError);
  try {
    task().prepare({}, {{10, 10}, {11, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "input 'response': expected the corner mask's size 10x10, got 11x10");
  }
  try {
    task().prepare({{"cell_size_px", 4}}, {{10, 10}, {10, 10}});
    FAIL() << "expected KernelError";
  } catch (const KernelError& error) {
    EXPECT_STREQ(error.what(), "parameter 'cell_size_px': expected an integer in [8, 4096], got 4");
  }
}

}  // namespace
}  // namespace lpstereo
