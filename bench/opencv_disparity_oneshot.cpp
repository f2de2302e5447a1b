// OpenCV's StereoSGBM as a user's one-shot program: read two images, compute, write the map, exit;
// the other side of bench/oneshot-disparity.sh, which times whole processes. It links OpenCV and
// the matcher settings the evaluations use (io/opencv_sgbm.h, lpstereo_opencv_sgbm_matcher), nothing
// else of lpstereo's, so its start-up and peak memory are an OpenCV program's.
// Usage: opencv_disparity_oneshot LEFT RIGHT OUT.png --num-disp N [--min-disp M] [--mode sgbm|3way|hh]
//        [--threads T]
//        opencv_disparity_oneshot --convert IN OUT (an image rewritten in OUT's format: the streaming
//        benchmark's PGM frames, whose decoding is a copy)
// Output: KITTI 16-bit PNG (disparity x 256, 0 = invalid), as `lpstereo disparity -o OUT.png`.
// Bad input: one line on stderr, exit 2.
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

#include "io/opencv_sgbm.h"

namespace {

int integer_argument(const std::string& name, const char* text) {
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (end == text || *end != '\0') throw std::invalid_argument(name + ": expected an integer, got '" + text + "'");
  return static_cast<int>(value);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc == 4 && std::string(argv[1]) == "--convert") {
      const cv::Mat image = cv::imread(argv[2], cv::IMREAD_UNCHANGED);
      if (image.empty()) throw std::invalid_argument(std::string("cannot read '") + argv[2] + "'");
      if (!cv::imwrite(argv[3], image)) throw std::invalid_argument(std::string("cannot write '") + argv[3] + "'");
      return 0;
    }
    std::string paths[3];
    int path_count = 0, num_disparities = 0, min_disparity = 0, threads = 2;
    lpstereo::io::SgbmMode mode = lpstereo::io::SgbmMode::sgbm;
    for (int i = 1; i < argc; ++i) {
      const std::string argument = argv[i];
      const bool has_value = i + 1 < argc;
      if (argument == "--num-disp" && has_value) num_disparities = integer_argument(argument, argv[++i]);
      else if (argument == "--min-disp" && has_value) min_disparity = integer_argument(argument, argv[++i]);
      else if (argument == "--threads" && has_value) threads = integer_argument(argument, argv[++i]);
      else if (argument == "--mode" && has_value) {
        const std::string name = argv[++i];
        if (name == "sgbm") mode = lpstereo::io::SgbmMode::sgbm;
        else if (name == "3way") mode = lpstereo::io::SgbmMode::sgbm_3way;
        else if (name == "hh") mode = lpstereo::io::SgbmMode::hh;
        else throw std::invalid_argument("--mode: expected sgbm, 3way or hh, got '" + name + "'");
      } else if (argument.rfind("--", 0) != 0 && path_count < 3) {
        paths[path_count++] = argument;
      } else {
        throw std::invalid_argument("unexpected argument '" + argument + "'");
      }
    }
    if (path_count != 3) throw std::invalid_argument("expected LEFT RIGHT OUT.png, got " + std::to_string(path_count) + " paths");
    if (threads < 1) throw std::invalid_argument("--threads: expected >= 1, got " + std::to_string(threads));
    cv::setNumThreads(threads);
    const cv::Mat left = cv::imread(paths[0], cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(paths[1], cv::IMREAD_GRAYSCALE);
    if (left.empty()) throw std::invalid_argument("cannot read '" + paths[0] + "'");
    if (right.empty()) throw std::invalid_argument("cannot read '" + paths[1] + "'");
    if (left.size() != right.size()) throw std::invalid_argument("left and right sizes differ");
    cv::Mat disparity_q4;
    lpstereo::io::make_opencv_sgbm(min_disparity, num_disparities, mode)->compute(left, right, disparity_q4);
    // Q4 to KITTI (x 256): x 16; invalid and non-positive values become 0.
    cv::Mat kitti(disparity_q4.size(), CV_16U);
    for (int y = 0; y < disparity_q4.rows; ++y) {
      const int16_t* in = disparity_q4.ptr<int16_t>(y);
      uint16_t* out = kitti.ptr<uint16_t>(y);
      for (int x = 0; x < disparity_q4.cols; ++x) out[x] = in[x] > 0 ? static_cast<uint16_t>(in[x] * 16) : 0;
    }
    if (!cv::imwrite(paths[2], kitti)) throw std::runtime_error("cannot write '" + paths[2] + "'");
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "opencv_disparity_oneshot: %s\n", error.what());
    return 2;
  }
}
