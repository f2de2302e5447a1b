// The dense-disparity engine as a small API (after libSGM): one class, a Parameters struct, a
// documented output format. It builds the processing graph for the parameters (vector kernels for
// census, matching and refinement; see graphs/ for the same graphs as files), verifies it against a
// target's memory, and runs it frame after frame with the ARM-side scheduler.
//
// The default is semi-global matching on census Hamming costs: census of both views, then
//   paths = 8: by bands of 64 rows, no W x H x D volume (kernels/sgm_8path_bands.cpp):
//              sgm_8path_forward_checkpoints beside sgm_8path_backward_checkpoints (each pass's row
//              state at every band), then sgm_8path_bands, the bands in parallel, each running the
//              forward paths from its checkpoint into one band of sums and the backward paths with
//              the selection; bit for bit sgm_8path_forward + sgm_8path_backward over the frame;
//   paths = 4: sgm_4path, one row-streaming pass (the chip's; no volume either);
//   paths = 0: census_wta_disparity, no aggregation (the baseline; census 5x5 only).
// Every SGM graph ends in winner takes all with the uniqueness ratio, the parabola sub-pixel step
// and the left-right check (kernels/sgm_core.h, kernels/sgm_reference.h), then the 3x3 median and
// the speckle filter unless they are switched off.
//
// multires = true: two matching passes with the same paths, census and penalties, fused by
// disparity_fuse_multires (graphs/disparity-multires-wta.json is the same shape with WTA matchers):
//   far  (full resolution)  [min_disparity, min_disparity + num_far) px,
//                           num_far = min(num_disparities, multires_far_disparities), the cap 128 by
//                           default (kMultiresFarDisparities, the budgeted 4K search);
//   near (half resolution)  downsample2x of both views, census, matching over the WHOLE range in
//                           half px: [floor(min / 2), ceil((min + num - 1) / 2)], which covers every
//                           full-resolution disparity of [min, min + num);
//   fuse                    top = min + num_far - 1 - margin (margin = min(2, num_far - 1) px):
//                           the near value x 2 where it is valid and above top, else the far value
//                           where it is valid and <= top (but not where the near value is invalid in
//                           the left band, x / 2 < the near range's top, whose searches the image's
//                           edge cuts short), else invalid (nearest upsampling).
// The near pass searches the far range too because it is the pass that decides "near or far": a
// matcher whose true disparity lies beyond its range returns a plausible value inside it, so the far
// pass cannot say "not mine" (measured: kernels/disparity_fuse_multires.cpp). Near pixels thus have
// half-resolution detail (1/8 px steps after the x 2, edges on the 2x2 grid). The LR check and
// uniqueness run inside each pass (the near tolerance is in half px). No post-processing beyond the
// single-resolution engine's (none): the output is the fused map.
//
// The right-view disparity (compute_right_view) is the same engine run on the mirrored pair:
// mirror(right) as the left view, mirror(left) as the right view, result mirrored back. A right pixel
// x with value d matches left pixel x + d; same range, same invalid value, same options. It costs a
// second run; the kernels' own right-view keys are whole-pixel minima with no sub-pixel step,
// uniqueness or LR check, so they are not exposed.
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

// How graph_spec lays out 8-path SGM (4 paths are always sgm_4path, one row-streaming pass). The
// same bits either way (tests/kernels/golden_test.cpp).
enum class EightPathLayout {
  // What the engine runs on the host and the board: by bands, no W x H x D volume.
  bands,
  // sgm_8path_forward, then sgm_8path_backward fused with the selection, the forward sums in DRAM
  // (2 W H D bytes): what a target profile costs, since a vector engine's tiles go through its SRAM,
  // which cannot hold the bands' sums.
  forward_backward,
};

struct DisparityParameters {
  int min_disparity = 0;       // pixels; may be negative
  int num_disparities = 64;    // pixels searched: [min_disparity, min_disparity + num_disparities), 1..512 with SGM
  int census_width = 5;        // census window: 5 (5x5, census32 signatures) or 9 (9x7, census64)
  int paths = 8;               // SGM paths: 8 (two passes, the default: the accurate one, libSGM's default too),
                               // 4 (one row-streaming pass, what the chip graphs run); 0 = census winner takes all
  int p1 = -1;                 // SGM penalty for a 1 px disparity change, Hamming bits; -1 = 5 (5x5) or 7 (9x7)
  int p2 = -1;                 // SGM penalty for larger changes, Hamming bits (>= p1, <= 4000); -1 = 45 (5x5) or 50 (9x7)
                               // (the defaults: lowest mean bad-2 over the 8 Middlebury pairs of ../shared/data)
  int uniqueness_percent = 5;  // SGM: the best cost must beat the others (|d - best| > 1) by this %; 0 = off, <= 50
  bool subpixel = true;        // SGM: parabola sub-pixel step (Q4); false = whole pixels
  int lr_max_diff = 2;         // SGM: left-right check tolerance in px; -1 = off
  // Post-processing of the SGM map (not with paths = 0), OpenCV StereoSGBM's order and semantics:
  bool median = true;          // 3x3 median that keeps invalid pixels invalid (kernels/median3x3_s16.cpp)
  int speckle_max_size_px = 100;  // regions of at most this many pixels become invalid; 0 = off
                                  // (arm/tasks/speckle_filter.cpp, cv::filterSpeckles bit for bit)
  int speckle_max_difference_px = 2;  // neighbours within this many px belong to one region (speckleRange)
  // The defaults (8 paths, LR 2 px, median, speckles of <= 100 px within 2 px) are the setting with
  // the lowest errors over the 8 Middlebury pairs and KITTI 2015 000046 of ../shared/data at a density
  // no lower than OpenCV's: docs/evaluation.md has the table.
  int max_cost_bits = 6;       // paths = 0 only: a best Hamming cost above this is invalid
  bool multires = false;       // full-resolution far pass + half-resolution pass, fused (see above)
  // multires only: the full-resolution pass's cap, [1, 512]. Below num_disparities / 2 the half-resolution
  // pass does most of the matching. 64 with num_disparities 128 at 640 px is a near guard: the far pass
  // is the single 64-disparity engine's, and surfaces 1.3-2.6 m ahead (f B / 128 .. f B / 64 at f
  // 554 px, B 0.3 m) get their half-resolution disparity instead of the wrong value a 64-disparity
  // matcher returns for them; in the obstacle chain the engine then takes 14.5 ms instead of 9.7
  // (docs/obstacles3d.md, "The near guard").
  int multires_far_disparities = 128;
};

// The chip configuration: what a stereo unit of the target model runs, graphs/disparity.json's
// matcher: single-pass 4-path SGM on census 5x5 with the default penalties, uniqueness 5 %, sub-pixel,
// LR check 1 px, the 3x3 median, no speckle filter (an ARM task the 4K frame budget does not hold),
// over the smallest search range the unit offers that covers the requested one (the largest it
// offers when none does: the unit searches no further). min_disparity is the requested one.
// offered_search_ranges: the unit's (UnitLimits::search_ranges), not empty.
DisparityParameters chip_configuration(const DisparityParameters& requested, const std::vector<int>& offered_search_ranges);

// One line naming every setting, for reports and benchmarks ("8-path SGM, census 5x5, P1 5, P2 45, ...").
std::string settings_text(const DisparityParameters& parameters);

// The multi-resolution split for a range (see the header comment). Disparities in px of each pass.
struct MultiresSplit {
  int min_far = 0, num_far = 0;    // full-resolution px
  int min_near = 0, num_near = 0;  // half-resolution px
  int margin_px = 0;               // top steps of the far range not trusted (full-resolution px)
};
inline constexpr int kMultiresFarDisparities = 128;  // the far pass's default cap: the budgeted 4K search (issue 4)
// far_cap: DisparityParameters::multires_far_disparities (>= 1).
MultiresSplit multires_split(int min_disparity, int num_disparities, int far_cap = kMultiresFarDisparities);

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
  // The right-view disparity of the same pair (see the header comment: the mirrored pair), s16 Q4,
  // same invalid value; valid until the next call of either function (it reuses the graph's buffers).
  const Plane& compute_right_view(const Plane& left, const Plane& right);

  int16_t invalid_disparity_q4() const { return static_cast<int16_t>((parameters_.min_disparity - 1) * 16); }
  const DisparityParameters& parameters() const { return parameters_; }
  // The graph it runs: graph_spec of its parameters.
  const Graph& graph() const { return *graph_; }

  // The working memory an engine of these arguments will take, in bytes, computed before
  // allocating anything (the graph is built and verified, no frame buffer is made): the
  // FrameRunner's buffers, row state and per-worker scratch (FrameRunner::planned_bytes) plus the
  // speckle filter's per-pixel marks (W H bytes) when it is on. Throws as the constructor does for
  // bad parameters.
  static size_t working_set_bytes(int width, int height, const DisparityParameters& parameters, int worker_threads = 0);

  // The graph spec the engine runs for these parameters (also what `lpstereo graph dot` draws).
  static GraphSpec graph_spec(const DisparityParameters& parameters, EightPathLayout layout = EightPathLayout::bands);

 private:
  DisparityParameters parameters_;
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<FrameRunner> runner_;
  Plane mirrored_left_, mirrored_right_, right_view_;  // compute_right_view's frames, kept between calls
};

}  // namespace lpstereo::arm
