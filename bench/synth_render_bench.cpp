// synth_render_bench: the synthetic stereo renderer's time per frame (io::render_sequence_frame, what
// bench/obstacles3d_eval renders for issue 10's acceptance evaluation: 300 frames per scene, several
// seeds, on the urban, country, mining and floating presets).
//
// For each preset (640 x 480, the presets' own settings: 2 x 2 samples per pixel, grey + no colour)
// and each thread count (1 and 2): one warm-up frame, then `repetitions` renders of the same frame,
// median and minimum wall time in ms. Also prints the frame's 64-bit FNV-1a digest
// (io::sequence_frame_digest: its images, pose and truth), so an old and a new build can be checked for
// the same bits (the digest must not depend on the thread count; the program exits 1 if it does).
//
// Usage: synth_render_bench [--repetitions N] [--frame K] [--seed S] [--presets urban,mining,...]
//                           [--threads 1,2]
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "io/sequence_frame_cache.h"
#include "io/stereo_sequence.h"

namespace {

using namespace lpstereo;

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream stream(text);
  for (std::string part; std::getline(stream, part, ',');) parts.push_back(part);
  return parts;
}

}  // namespace

int main(int argc, char** argv) {
  int repetitions = 3, frame = 12;
  uint32_t seed = 1;
  std::vector<std::string> presets = {"urban", "country", "mining", "floating"};
  std::vector<int> thread_counts = {1, 2};
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string option = argv[i], value = argv[i + 1];
    if (option == "--repetitions") repetitions = std::max(1, std::atoi(value.c_str()));
    else if (option == "--frame") frame = std::atoi(value.c_str());
    else if (option == "--seed") seed = static_cast<uint32_t>(std::strtoul(value.c_str(), nullptr, 10));
    else if (option == "--presets") presets = split(value);
    else if (option == "--threads") {
      thread_counts.clear();
      for (const std::string& count : split(value)) thread_counts.push_back(std::atoi(count.c_str()));
    } else {
      std::fprintf(stderr, "synth_render_bench: unknown option %s\n", option.c_str());
      return 2;
    }
  }
  std::printf("synth_render_bench: io::render_sequence_frame, presets at their own settings (640 x 480), frame %d, seed %u, "
              "median of %d after 1 warm-up, wall ms per frame\n",
              frame, seed, repetitions);
  std::printf("%-9s %7s %12s %10s  %s\n", "preset", "threads", "median_ms", "min_ms", "digest (io::sequence_frame_digest)");
  bool consistent = true;
  for (const std::string& name : presets) {
    uint64_t first_digest = 0;
    for (size_t c = 0; c < thread_counts.size(); ++c) {
      io::StereoSequenceOptions options = io::preset_stereo_sequence(name, seed);
      options.base.threads = thread_counts[c];
      uint64_t hash = io::sequence_frame_digest(io::render_sequence_frame(options, frame));  // warm-up
      std::vector<double> ms;
      for (int r = 0; r < repetitions; ++r) {
        const auto start = std::chrono::steady_clock::now();
        const io::StereoSequenceFrame rendered = io::render_sequence_frame(options, frame);
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
        hash = io::sequence_frame_digest(rendered);
      }
      std::sort(ms.begin(), ms.end());
      if (c == 0) first_digest = hash;
      else if (hash != first_digest) consistent = false;
      std::printf("%-9s %7d %12.1f %10.1f  %016llx\n", name.c_str(), thread_counts[c], ms[ms.size() / 2], ms.front(),
                  static_cast<unsigned long long>(hash));
      std::fflush(stdout);
    }
  }
  if (!consistent) {
    std::printf("FAILED: a frame's digest depends on the thread count\n");
    return 1;
  }
  return 0;
}
