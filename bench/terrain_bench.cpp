// terrain_bench: terrain estimation (arm/terrain, issue 9) against thesis 000 (Sabbatelli 2015,
// ../shared/theses/000_*.txt, §4.3.1 Figure 4.5 and §4.3.2).
//   (a) The deviation test of §4.3.1: a flat ground, an artificial box obstacle centred at
//       (11 m, 0) of width (square footprint) 0.8-12 m and height 0.5-3 m, area 22 m x 22 m, 0.5 m
//       cells, degree 3, with 5x5 and with 25x25 control points. The grid is built directly as a
//       HeightGrid from a dense sampling (5 cm lattice) of the ground and the box tops through the
//       cell rule (eq. 3.2), as the thesis does; the same without the box is the reference
//       surface. Printed: the maximum |S_box - S_reference| over the cell centres in % of the box
//       height. Acceptance (issue 9): at most 10 % with 25x25 for boxes up to 2 m wide. Two more
//       tables: every sample above the surface equalised (the thesis's rule, factor 0) and eq. 3.7
//       as printed in the text conversion (terrain_fit.cpp explains both).
//   (b) Speed: 25x25 control points, degree 3, 34 m x 22 m, 0.5 m cells (68 x 44), a rolling ground
//       (two hills and a ditch) with three boxes and 3 cm noise: fit_terrain and
//       compute_traversability on one host thread, median of 201 runs after 20 warm-up runs, wall
//       time and the thread's CPU time (the budgets are judged on the CPU time: on a shared host
//       the wall time also counts other processes' turns); printed beside the budgets
//       (3 ms, 1 ms) and the thesis's anchor (15 ms, 8 ms on an i7-3840QM); the counted ArmWork turned into cv1-class ARM time with the target's ARM
//       model (targets/cv1-class.json: cycles per scalar op and per DRAM byte, clock).
// Exits 1 when an acceptance figure is missed. Usage: terrain_bench
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <time.h>
#include <vector>

#include "arm/terrain/terrain_model.h"
#include "host_sim/target.h"
#include "bench/heap_setting.h"

namespace lpstereo {
namespace {

using namespace arm::terrain;

constexpr double kLatticeM = 0.05;  // the dense sampling of the deviation test

HeightGrid box_scene(double width_m, double height_m) {
  TerrainGridSpec spec;
  spec.forward_min_m = 0, spec.forward_max_m = 22, spec.lateral_min_m = -11, spec.lateral_max_m = 11, spec.cell_m = 0.5;
  HeightGridAccumulator accumulator(spec);
  for (double x = kLatticeM / 2; x < 22; x += kLatticeM) {
    for (double y = -11 + kLatticeM / 2; y < 11; y += kLatticeM) {
      const bool on_box = width_m > 0 && std::abs(x - 11.0) < width_m / 2 && std::abs(y) < width_m / 2;
      accumulator.add_point(Eigen::Vector3d(x, y, on_box ? height_m : 0.0));
    }
  }
  return accumulator.finish();
}

double max_deviation_percent(const TerrainFitParameters& parameters, double width_m, double height_m,
                             const Eigen::MatrixXd& reference) {
  const HeightGrid grid = box_scene(width_m, height_m);
  const TerrainEstimate estimate = fit_terrain(grid, parameters);
  if (!estimate.known) return std::nan("");
  const Eigen::MatrixXd surface = surface_heights_at_cells(estimate.surface, grid.spec);
  return 100.0 * (surface - reference).cwiseAbs().maxCoeff() / height_m;
}

const std::vector<double> kWidthsM = {0.8, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0};
const std::vector<double> kHeightsM = {0.5, 1.0, 1.5, 2.0, 2.5, 3.0};

// Prints the table; returns the worst deviation over widths <= 2 m.
double deviation_table(const char* title, const TerrainFitParameters& parameters) {
  const HeightGrid flat = box_scene(0, 0);
  const TerrainEstimate reference = fit_terrain(flat, parameters);
  const Eigen::MatrixXd reference_surface = surface_heights_at_cells(reference.surface, flat.spec);
  std::printf("\n%s: max surface deviation in %% of the box height\n  width \\ height", title);
  for (double height : kHeightsM) std::printf(" %6.1f m", height);
  std::printf("\n");
  double worst_small = 0;
  for (double width : kWidthsM) {
    std::printf("  %6.1f m      ", width);
    for (double height : kHeightsM) {
      const double deviation = max_deviation_percent(parameters, width, height, reference_surface);
      if (width <= 2.0) worst_small = std::max(worst_small, std::isnan(deviation) ? 1e9 : deviation);
      std::printf(" %7.1f%%", deviation);
    }
    std::printf("\n");
  }
  return worst_small;
}

HeightGrid speed_scene() {
  TerrainGridSpec spec;  // the defaults: 34 m x 22 m, 0.5 m cells
  HeightGridAccumulator accumulator(spec);
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 0.03);
  for (double x = 0.05; x < 34; x += 0.1) {
    for (double y = -10.95; y < 11; y += 0.1) {
      double z = 0.8 * std::exp(-((x - 20) * (x - 20) + (y - 5) * (y - 5)) / 30.0) +
                 0.5 * std::exp(-((x - 8) * (x - 8) + (y + 6) * (y + 6)) / 12.0) - 0.4 * std::exp(-(y + 2) * (y + 2) / 0.5);
      if ((std::abs(x - 12) < 0.4 && std::abs(y - 1) < 0.3) || (std::abs(x - 25) < 1.0 && std::abs(y + 4) < 1.0) ||
          (std::abs(x - 30) < 0.2 && std::abs(y - 8) < 0.2)) {
        z += 1.5;
      }
      accumulator.add_point(Eigen::Vector3d(x, y, z + noise(random)));
    }
  }
  return accumulator.finish();
}

struct Timing {
  double wall_ms = 0;  // steady clock
  double cpu_ms = 0;   // this thread's CPU time: what the code costs when the host is shared
};

double thread_cpu_ms() {
  timespec now{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return now.tv_sec * 1e3 + now.tv_nsec * 1e-6;
}

template <typename Function>
Timing median_ms(Function&& function, int runs) {
  for (int k = 0; k < 20; ++k) function();
  std::vector<double> wall, cpu;
  for (int k = 0; k < runs; ++k) {
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = thread_cpu_ms();
    function();
    cpu.push_back(thread_cpu_ms() - cpu_start);
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  std::nth_element(wall.begin(), wall.begin() + runs / 2, wall.end());
  std::nth_element(cpu.begin(), cpu.begin() + runs / 2, cpu.end());
  return {wall[static_cast<size_t>(runs / 2)], cpu[static_cast<size_t>(runs / 2)]};
}

void print_parameters(const TerrainFitParameters& p) {
  std::printf("fit: degree %dx%d, control %dx%d (initial %dx%d), max_iterations %d, threshold_factor %g, alpha %g + %g k, "
              "regularisation %g, maximum_weight %g, equalisation_tolerance_m %g, equalisation_threshold_factor %g, "
              "equalisation %s\n",
              p.degree_forward, p.degree_lateral, p.control_forward, p.control_lateral, p.initial_control_forward,
              p.initial_control_lateral, p.max_iterations, p.threshold_factor, p.alpha_initial, p.alpha_step, p.regularisation,
              p.maximum_weight, p.equalisation_tolerance_m, p.equalisation_threshold_factor,
              p.equalisation == TerrainFitParameters::Equalisation::never_overshoot ? "never_overshoot" : "as_printed");
}

int run() {
  std::printf("heap: %s\n", bench::keep_freed_heap_memory_setting().c_str());
  bool pass = true;
  // (a) the deviation test.
  TerrainFitParameters coarse;
  coarse.control_forward = coarse.control_lateral = 5;
  coarse.initial_control_forward = coarse.initial_control_lateral = 5;
  TerrainFitParameters fine;  // the defaults: 25 x 25 from 5 x 5
  std::printf("terrain_bench (a): thesis 000 §4.3.1 deviation test; area 22 m x 22 m, 0.5 m cells, box at (11 m, 0), "
              "grid from a %.0f cm lattice through eq. 3.2\n", kLatticeM * 100);
  print_parameters(coarse);
  deviation_table("5x5 control points", coarse);
  print_parameters(fine);
  const double worst_fine = deviation_table("25x25 control points", fine);
  std::printf("acceptance: boxes up to 2 m wide with 25x25, worst %.1f %% (limit 10 %%): %s\n", worst_fine,
              worst_fine <= 10.0 ? "pass" : "FAIL");
  pass = pass && worst_fine <= 10.0;
  // The settings bench/terrain_synth_eval measures with: the step rule (0.45 m within 4 cells) and
  // its patch limit (16 cells); off in the defaults, so the acceptance line above is on the defaults.
  TerrainFitParameters step_rule = fine;
  step_rule.equalisation_step_m = 0.45;
  step_rule.equalisation_patch_max_cells = 16;
  const double worst_step_rule =
      deviation_table("25x25 control points, step rule 0.45 m with the 16-cell patch limit (terrain_synth_eval's settings)", step_rule);
  std::printf("the same line with terrain_synth_eval's settings: worst %.1f %% (limit 10 %%): %s\n", worst_step_rule,
              worst_step_rule <= 10.0 ? "pass" : "FAIL");
  pass = pass && worst_step_rule <= 10.0;
  TerrainFitParameters every_sample = fine;
  every_sample.equalisation_threshold_factor = 0;
  deviation_table("25x25 control points, every sample above the surface equalised (the thesis; factor 0)", every_sample);
  TerrainFitParameters as_printed = fine;
  as_printed.equalisation = TerrainFitParameters::Equalisation::as_printed;
  deviation_table("25x25 control points, eq. 3.7 as printed (Z -= dz (1 + 1/W))", as_printed);

  // (b) speed.
  const HeightGrid grid = speed_scene();
  const TerrainFitParameters parameters;
  const TraversabilityParameters traversability_parameters;
  std::printf("\nterrain_bench (b): speed, %d x %d cells (34 m x 22 m, 0.5 m), 1 host thread, median of 201 runs\n",
              grid.spec.forward_cells(), grid.spec.lateral_cells());
  print_parameters(parameters);
  TerrainEstimate estimate = fit_terrain(grid, parameters);
  if (!estimate.known) {
    std::printf("terrain unknown: %s\n", estimate.reason.c_str());
    return 1;
  }
  std::printf("fit: %d iterations, %d cells equalised in the last, mean |error| %.4f m\n", estimate.iterations,
              estimate.equalised_cells_last, estimate.mean_abs_error_m);
  const Timing fit_ms = median_ms([&] { estimate = fit_terrain(grid, parameters); }, 201);
  TraversabilityMap map = compute_traversability(estimate, grid, traversability_parameters);
  const Timing cost_ms = median_ms([&] { map = compute_traversability(estimate, grid, traversability_parameters); }, 201);
  // The budgets are judged on the thread's CPU time: the wall time on a shared host also holds the
  // time other processes had the core (both printed; on an idle host they agree).
  std::printf("  median of 201 runs         wall ms   thread CPU ms   budget   thesis (i7-3840QM)\n");
  std::printf("  fit_terrain              %9.3f      %9.3f     3 ms     15 ms   %s\n", fit_ms.wall_ms, fit_ms.cpu_ms,
              fit_ms.cpu_ms <= 3.0 ? "pass" : "FAIL");
  std::printf("  compute_traversability   %9.3f      %9.3f     1 ms      8 ms   %s\n", cost_ms.wall_ms, cost_ms.cpu_ms,
              cost_ms.cpu_ms <= 1.0 ? "pass" : "FAIL");
  pass = pass && fit_ms.cpu_ms <= 3.0 && cost_ms.cpu_ms <= 1.0;
  // terrain_synth_eval's settings (the step rule with its patch limit) on the same scene.
  TerrainFitParameters eval_parameters = parameters;
  eval_parameters.equalisation_step_m = 0.45;
  eval_parameters.equalisation_patch_max_cells = 16;
  TerrainEstimate eval_estimate = fit_terrain(grid, eval_parameters);
  const Timing eval_fit_ms = median_ms([&] { eval_estimate = fit_terrain(grid, eval_parameters); }, 201);
  std::printf("  fit_terrain, step rule + patch limit %9.3f %9.3f     3 ms             %s (%d iterations, %llu ops)\n", eval_fit_ms.wall_ms,
              eval_fit_ms.cpu_ms, eval_fit_ms.cpu_ms <= 3.0 ? "pass" : "FAIL", eval_estimate.iterations,
              static_cast<unsigned long long>(eval_estimate.work.scalar_ops));
  pass = pass && eval_fit_ms.cpu_ms <= 3.0;
  const host_sim::Target target = host_sim::load_target("cv1-class");
  const auto arm_ms = [&](const ArmWork& work) {
    const double cycles = static_cast<double>(work.scalar_ops) * target.arm.cycles_per_scalar_op +
                          static_cast<double>(work.memory_bytes) * target.arm.cycles_per_dram_byte;
    return cycles / (target.arm.clock_mhz * 1e3);
  };
  std::printf("simulated on %s (one ARM core at %.0f MHz, %.2f cycles per op, %.2f per DRAM byte):\n", target.name.c_str(),
              target.arm.clock_mhz, target.arm.cycles_per_scalar_op, target.arm.cycles_per_dram_byte);
  std::printf("  fit_terrain              %12llu ops %10llu bytes  %7.3f ms\n",
              static_cast<unsigned long long>(estimate.work.scalar_ops), static_cast<unsigned long long>(estimate.work.memory_bytes),
              arm_ms(estimate.work));
  std::printf("  compute_traversability   %12llu ops %10llu bytes  %7.3f ms\n", static_cast<unsigned long long>(map.work.scalar_ops),
              static_cast<unsigned long long>(map.work.memory_bytes), arm_ms(map.work));
  return pass ? 0 : 1;
}

}  // namespace
}  // namespace lpstereo

int main() { return lpstereo::run(); }
