// The dense-disparity engine as a small API (after libSGM): one class, a Parameters struct, a
// documented output format. It builds the processing graph for the parameters (vector kernels for
// census, matching and refinement; see graphs/ for the same graphs as files), verifies it against a
// target's memory, and runs it frame after frame with the ARM-side scheduler.
//
// Output: s16 Q4 disparity of the left view (value / 16 = pixels); invalid pixels hold
// invalid_disparity_q4() = (min_disparity - 1) * 16, never 0-overloaded (DESIGN.md §4).
#pragma once

#include <memory>
#include <string>

#include "dag/graph.h"
#include "dag/plane.h"

namespace lpstereo::arm {

class FrameRunner;

struct DisparityParameters {
  int min_disparity = 0;     // pixels; may be negative
  int num_disparities = 64;  // pixels searched: [min_disparity, min_disparity + num_disparities)
  int census_width = 5;      // census window: 5x5 (census32 signatures)
  int max_cost_bits = 6;     // winner-takes-all: a best Hamming cost above this is invalid
};

class DisparityEngine {
 public:
  // Builds and verifies the graph for width x height frames against `memory` (unlimited by
  // default). Throws VerifyError (or std::invalid_argument for parameters out of range, naming
  // the parameter, the expected range and the actual value). worker_threads: the FrameRunner's
  // threads (0 = one per hardware thread). KernelBackend::counting runs the counting back end (same
  // bits; the golden tests and `--backend counting` use it).
  DisparityEngine(int width, int height, const DisparityParameters& parameters, const MemoryBudget& memory = {},
                  int worker_threads = 0, KernelBackend backend = KernelBackend::native);
  ~DisparityEngine();
  DisparityEngine(const DisparityEngine&) = delete;
  DisparityEngine& operator=(const DisparityEngine&) = delete;

  // Left and right u8 views of the engine's size; returns the left-view disparity (s16 Q4), valid
  // until the next call.
  const Plane& compute(const Plane& left, const Plane& right);

  int16_t invalid_disparity_q4() const { return static_cast<int16_t>((parameters_.min_disparity - 1) * 16); }
  const DisparityParameters& parameters() const { return parameters_; }
  const Graph& graph() const { return *graph_; }

  // The graph spec the engine runs for these parameters (also what `lpstereo graph dot` draws).
  static GraphSpec graph_spec(const DisparityParameters& parameters);

 private:
  DisparityParameters parameters_;
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<FrameRunner> runner_;
};

}  // namespace lpstereo::arm
