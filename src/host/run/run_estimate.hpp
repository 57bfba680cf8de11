#pragma once
// What a run will need, before it runs: its size (capsules, nodes, grid), the memory it needs (one estimator, used
// by `capsflow run --dry-run` and by the input check that refuses a grid which cannot fit), and an estimate of its
// cost per strain unit.
//
//   const RunSize size = run_size(cfg);                        // resolves the grid, counts the capsules
//   const MemoryEstimate mem = estimate_memory(size);
//   check_memory_fits(cfg, size, mem, available_memory());     // InputError with both sizes when it cannot fit
//   const CostEstimate cost = estimate_cost(cfg, size, threads);
//
// The memory is an estimate of the peak resident size: the grid arrays exactly (they dominate large boxes), the
// per-node and per-wall-point arrays and the program from calibration constants (docs/performance.md section 5).
// The cost is an estimate from calibrated constants too: seconds per step from bench_step's stage times, steps per
// strain unit from the time-step rule dt = cfl Ca_ref h with the h measured in real runs (a fresh random placement
// steps ~3x faster than a developed suspension, whose closest node pairs sit near min_gap).
#include <cstdint>
#include <string>

#include "host/physics/config.hpp"
#include "host/physics/simulation.hpp"
#include "host/solver/ggem_solver.hpp"
#include "host/base/machine_limits.hpp"

namespace capsflow {

struct RunSize {
  long capsules = 0;             // N_p ([suspension] count or from volume_fraction, or the [[capsule]] entries)
  long nodes = 0;                // N_p (10 4^level + 2)
  GgemGrid grid;                 // the resolved GGEM grid
  std::uint64_t grid_points = 0; // nx nz (N + 1)
  std::uint64_t wall_points = 0; // 2 nx nz: targets of the local part on the walls
};

// Throws InputError for a configuration whose grid cannot be resolved (as GgemSolver would).
RunSize run_size(const Config& c);

struct MemoryEstimate {
  std::uint64_t grid = 0;      // GGEM grid arrays: forcing, velocity, spectra (3 components), homogeneous solutions
  std::uint64_t capsules = 0;  // per node and per wall point: meshes, forces, velocities, AB2 history, stencils, cells
  std::uint64_t base = 0;      // the program, its libraries and thread stacks
  std::uint64_t total() const { return grid + capsules + base; }
};

// The GGEM grid arrays of SlitStokesPlan, in bytes, for nx x nz Fourier points and Chebyshev degree N.
std::uint64_t grid_bytes(int nx, int nz, int N);
MemoryEstimate estimate_memory(const RunSize& size);

// Refuses (InputError naming the grid keys, the needed and the available sizes) a run that cannot fit.
void check_memory_fits(const Config& c, const RunSize& size, const MemoryEstimate& need, const MemoryLimit& avail);

struct CostEstimate {
  int threads = 1;                         // threads the estimate assumes (1 for serial)
  double seconds_per_step = 0.0;           // at the start (the grid and node terms do not change during a run)
  // At a viscosity ratio != 1: single-layer applications per step the interface-velocity solve adds (set_geometry and
  // the GMRES applications of the double layer; included in seconds_per_step). 0 at lambda = 1.
  double interface_solve_applications = 0.0;
  double ca_ref = 0.0;                     // Ca of the step rule
  double steps_per_strain_start = 0.0;     // fresh placement (or a dilute run throughout)
  double steps_per_strain_developed = 0.0; // developed suspension (equal to the start for dilute runs)
  bool dilute = false;                     // explicit capsules (isolated, pair): no developed suspension
  double seconds_per_strain_start() const { return seconds_per_step * steps_per_strain_start; }
  double seconds_per_strain_developed() const { return seconds_per_step * steps_per_strain_developed; }
  double total_seconds = 0.0;              // to [time] end: the start rate for the first 2 strain units, then developed
  // Explicit capsules under the membrane rule: the steps per strain unit of the rule alone (cfl, Ca, mesh) when the
  // first steps are held below it (start_step_estimate), else equal to steps_per_strain_start.
  double steps_per_strain_rule = 0.0;
};

// The first steps of explicit capsules under the membrane rule, from the placed meshes and the imposed flow (issue
// 37): a close pair makes the near-contact factor and the collision cap act from the first step, which the
// calibrated rates of estimate_cost do not see. The closing speeds are the imposed flow's (no disturbance: the
// hydrodynamic interaction slows an approach, so the estimate errs towards more steps).
struct StartStepEstimate {
  double dt_rule = 0.0;         // the membrane rule's step (strain units; the calibrated shortest edge)
  double dt = 0.0;              // the first step with the near-contact factor and the collision cap
  StepLimit limit = StepLimit::Membrane;  // what sets dt
  std::string keys;             // step_limit_keys of that limit ("" for the rule itself)
  bool far_below() const;       // dt below dt_rule / StepWatch::kFarBelow: the dry run warns
};
// Empty (dt = dt_rule, limit Membrane) for a suspension, the paper rule, or a placement that fails (the run says why).
StartStepEstimate start_step_estimate(const Config& c);

// `threads`: the threads the run will use (1 for serial).
CostEstimate estimate_cost(const Config& c, const RunSize& size, int threads);

// "1.2 GiB", "340 MiB"
std::string bytes_text(std::uint64_t bytes);

}  // namespace capsflow
