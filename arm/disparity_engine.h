// The dense-disparity engine as a small API (after libSGM): one class, a Parameters struct, a
// documented output format. It builds the processing graph for the parameters (vector kernels for
// census, matching and refinement; see graphs/ for the same graphs as files), verifies it against a
// target's memory, and runs it frame after frame with the ARM-side scheduler.
//
// The default is semi-global matching on census Hamming costs: census of both views, then, in the
// host's schedule (SgmSchedule::side_by_side), two passes of paths side by side that each write
// their path sums, then sgm_sums_select:
//   paths = 8: sgm_8path_forward (left, top-left, top, top-right) beside sgm_8path_backward_sums
//              (right, bottom-right, bottom, bottom-left, rows bottom up);
//   paths = 4: sgm_4path_row_pair_sums (left, top-left) beside sgm_4path_column_pair_sums (top,
//              top-right);
// or, in the chip's schedule (SgmSchedule::sequential; the same bits): sgm_4path, one row-streaming
// pass, or sgm_8path_forward then sgm_8path_backward fused with the selection. SgmSchedule::automatic
// (the default) is side_by_side with two or more worker threads and sequential with one;
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

// How the SGM passes run (the same bits every way; tests/kernels/golden_test.cpp checks each).
enum class SgmSchedule {
  // side_by_side with two or more worker threads, sequential with one: one worker cannot run two
  // passes side by side, and there the schedule with fewer volumes is the faster one
  // (disparity_bench, BM_lpstereo_one_worker: 5-7 % for 8 paths, a third for 4 paths, on a
  // 2-core AVX-512 host).
  automatic,
  // The paths as two passes side by side, each writing its path sums, then the selection
  // (sgm_sums_select, row bands in parallel): 8 paths as sgm_8path_forward + sgm_8path_backward_sums,
  // 4 paths as sgm_4path_row_pair_sums + sgm_4path_column_pair_sums. What two host cores run fastest;
  // two W x H x D u16 volumes in DRAM.
  side_by_side,
  // The chip's schedule, fewer volumes in DRAM: sgm_4path in one row-streaming pass (none), or
  // sgm_8path_forward then sgm_8path_backward fused with the selection (one).
  sequential,
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
  SgmSchedule schedule = SgmSchedule::automatic;  // SGM only: the order of the passes, the same bits (see SgmSchedule)
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
  // The graph it runs: graph_spec of its parameters with SgmSchedule::automatic resolved for its
  // worker threads.
  const Graph& graph() const { return *graph_; }

  // The graph spec the engine runs for these parameters (also what `lpstereo graph dot` draws);
  // SgmSchedule::automatic is drawn as side_by_side, what an engine with two or more workers runs.
  static GraphSpec graph_spec(const DisparityParameters& parameters);

 private:
  DisparityParameters parameters_;
  std::unique_ptr<Graph> graph_;
  std::unique_ptr<FrameRunner> runner_;
  Plane mirrored_left_, mirrored_right_, right_view_;  // compute_right_view's frames, kept between calls
};

}  // namespace lpstereo::arm
