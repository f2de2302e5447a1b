// The real stereo pairs with ground truth in ../shared/data (see each set's SOURCE.md), loaded into
// one form: u8 luma views, ground truth in pixels at the image's resolution, the non-occluded mask,
// and the disparity range to search.
//
//   collection       folder                     views          ground truth                        nonocc
//   middlebury2003   tsukuba venus teddy cones  imL, imR       groundtruth.png / info.txt divisor  nonocc.png
//                                                              (tsukuba: palette PNG, decoded via  (255)
//                                                              the palette), restricted to all.png
//   middlebury2005   Reindeer Cloth3 Wood2      view1, view5   disp1.png / 2 (half size)           derived: disp1
//                                                                                                  and disp5 agree
//   middlebury2014   Motorcycle                 im0, im1       disp0GT.pfm (+inf = unknown)         mask0nocc.png (255)
//   kitti2015        000046                     image_2/3      disp_occ_0 PNG / 256 (0 = none)      none (all only)
//
// Search range: min 0 and num = the set's own figure (2003: info.txt line 2; 2005: drange.txt dmax;
// 2014: calib.txt ndisp; KITTI: 128, the customary KITTI range, as the set has no figure), raised to
// cover the ground truth's largest disparity (venus: info.txt says 19, its ground truth reaches
// 19.75 px), then rounded up to a multiple of 16 so OpenCV's StereoSGBM (which requires it) searches
// exactly the same range. StereoPair::range_source says which figure was used.
//
// Every error is an ImageError naming the file (or folder), what was expected and what was found.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dag/plane.h"

namespace lpstereo::io {

struct StereoPair {
  std::string collection;   // "middlebury2003", "middlebury2005", "middlebury2014", "kitti2015"
  std::string name;         // "tsukuba", ..., "000046"
  Plane left, right;        // u8 luma (colour converted with BT.601 weights)
  cv::Mat ground_truth_px;  // CV_32FC1, left view, pixels; +inf = no ground truth (or outside "all")
  cv::Mat nonocc_mask;      // CV_8UC1, 255 = non-occluded; empty = the set has no occlusion data
  int min_disparity_px = 0;
  int num_disparities = 0;  // searched: [min_disparity_px, min_disparity_px + num_disparities)
  std::string range_source; // where num_disparities comes from
};

// --data, else $LPSTEREO_SHARED_DATA, else ../shared/data (relative to the current directory).
std::string shared_data_directory(const std::string& explicit_directory = "");

// One scene folder in each layout (see the table above).
StereoPair load_middlebury2003_scene(const std::string& scene_directory);
StereoPair load_middlebury2005_scene(const std::string& scene_directory);
StereoPair load_middlebury2014_scene(const std::string& scene_directory);
StereoPair load_kitti2015_frame(const std::string& kitti_directory, const std::string& frame = "000046");

// The 8 Middlebury pairs (tsukuba, venus, teddy, cones, Reindeer, Cloth3, Wood2, Motorcycle) and
// KITTI 2015 000046, from the shared data folder.
std::vector<StereoPair> load_middlebury_pairs(const std::string& data_directory);
std::vector<StereoPair> load_kitti_pairs(const std::string& data_directory);

// The search range rule: max(ndisp_from_set, round(largest ground truth) + 1) rounded up to 16.
int search_range_px(int ndisp_from_set, const cv::Mat& ground_truth_px);

// Middlebury 2005/2006 have no occlusion masks: a left pixel x with ground truth d is non-occluded
// when the right view's ground truth at x - d (rounded) exists and differs from d by at most
// max_difference_px.
cv::Mat nonocc_from_left_right(const cv::Mat& left_ground_truth_px, const cv::Mat& right_ground_truth_px,
                               double max_difference_px = 1.0);

}  // namespace lpstereo::io
