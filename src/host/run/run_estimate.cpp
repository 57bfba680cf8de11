// The implementation of run_estimate.hpp: what a run will need, before it runs.
#include "host/run/run_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <cstdio>
#include <limits>

#include "host/base/errors.hpp"
#include "host/physics/contact.hpp"
#include "host/physics/initial_conditions.hpp"
#include "host/physics/step_rule.hpp"
#include "host/physics/step_watch.hpp"
#include "host/state/capsule_state.hpp"
#include "host/solver/slit_stokes_plan.hpp"
#include "kernels/mode_solve.hpp"

namespace capsflow {
namespace {

// Calibration of the memory estimate (docs/performance.md section 5): the peak resident size of `capsflow run`
// (GNU time's maxrss) less the grid term, which is exact, fitted over an isolated capsule, set A, set A at 4x the
// area and the pair box at alpha 4 (162 to 32400 nodes, 0.9 to 22 million grid points): within 1 % of each
// (refitted 2026-11-28 after the mode stage's lane arrays).
constexpr double kBaseBytes = 24.0 * (1 << 20);  // the program, HDF5, FFTW plans, OpenMP runtime and thread stacks
constexpr double kBytesPerNode = 1550.0;         // mesh, forces, velocities, AB2 history, geometry, spreading stencils
constexpr double kBytesPerWallPoint = 110.0;     // wall targets, their local velocities and cell lists

// Calibration of the cost estimate: stage times of one set-A step with 2 threads on the development machine, idle,
// after the speed work of issue 11 (a 2-strain run of examples/presets/set_a.toml, docs/performance.md section 5:
// 50 level-2 capsules, 8100 nodes, grid 84 x 84 x 129, 14112 wall points: local at the nodes 49.7 ms, local at the
// walls 13.7 ms, global 44.9 ms), per unit of work.
constexpr double kSecondsPerNode2T = 0.0497 / 8100.0;
constexpr double kSecondsPerWallPoint2T = 0.0137 / 14112.0;
constexpr double kSecondsPerGridPoint2T = 0.0449 / (84.0 * 84.0 * 129.0);
constexpr double kSerialOver2Threads = 1.9;  // serial 198.9 ms vs 104.2 ms with 2 threads (section 6, bench_step)

// Calibration of the interface-velocity solve at a viscosity ratio != 1 (docs/method.md 3.1), in applications of the
// single layer (about a lambda = 1 step's cost: BM_SetAStepViscosityRatio/10 330 ms per step against BM_SetAApply/1
// 315 ms, docs/performance.md section 11). Per step, on top of the lambda = 1 step:
// - the double layer's set_geometry (the subtraction's C_i: one matrix traversal and three global solves): 1.04-1.19 s
//   serial on set A against 269-277 ms CPU per single-layer application (section 12): about 4 applications;
// - the GMRES applications, each of the double layer: 385 ms CPU serial against the single layer's 269-277 ms
//   (section 12, BM_SetADoubleLayerApply/0): 1.43 applications; 6 of them per step (section 15: 5.67 per step in set
//   A's lambda-5 run with the quadratic guess and the rigid-motion preconditioner, the first solve from rest
//   included; 7.38 before, section 12; 3.6 for the drop at lambda 0.1, so an upper estimate below 1).
// One step: 1 + 4 + 6 x 1.43 = 13.6 single-layer applications; with the rule's third of the steps at lambda 5, 4.5x
// per strain unit against 3.8x measured in wall time on the idle machine (32.6 s against 8.6 s for 1.5 strain units,
// section 15).
constexpr double kSetGeometryApplications = 4.0;
constexpr double kDoubleOverSingleLayer = 1.43;
constexpr double kGmresApplicationsPerStep = 6.0;
// Per decade of [gmres] tolerance below (above) 1e-6, applications more (fewer): set A at lambda 5 and [ggem]
// tolerance 1e-2 took 3.18 / 4.65 / 10.6 per step at 1e-4 / 1e-5 / 1e-8 (section 20; 6.12 at the defaults' 1e-6).
constexpr double kGmresApplicationsPerDecade = 1.5;

// Strain units costed at the step rule's fresh rate before the developed one (the rates: step_rule.hpp's
// estimate_step_rates).
constexpr double kStartStrain = 2.0;

}  // namespace

RunSize run_size(const Config& c) {
  RunSize s;
  s.capsules = c.suspension ? suspension_count(c) : static_cast<long>(c.capsule_list.size());
  const long per_capsule = 10L * (1L << (2 * c.capsules.mesh_level)) + 2;
  s.nodes = s.capsules * per_capsule;
  s.grid = resolve_ggem_grid(c.domain, c.ggem);
  s.grid_points = static_cast<std::uint64_t>(s.grid.nx) * static_cast<std::uint64_t>(s.grid.nz) *
                  static_cast<std::uint64_t>(s.grid.ny + 1);
  s.wall_points = 2ULL * static_cast<std::uint64_t>(s.grid.nx) * static_cast<std::uint64_t>(s.grid.nz);
  return s;
}

std::uint64_t grid_bytes(int nx, int nz, int N) {
  // SlitStokesPlan: forcing and velocity (3 real fields each), spectra (3 complex fields on nx (nz/2 + 1) modes per
  // plane), wall maps and their spectra (2 walls x 3), the Chebyshev points, and per block of kModeBlock kz modes of
  // each |kx| (the last block of a row padded): the homogeneous solutions phi, psi (N + 1 per lane each), the 2x2
  // inverses, the tau factors and their TauLanes view.
  const std::uint64_t np = static_cast<std::uint64_t>(N) + 1;
  const std::uint64_t plane = static_cast<std::uint64_t>(nx) * static_cast<std::uint64_t>(nz);
  const std::uint64_t cplane = static_cast<std::uint64_t>(nx) * static_cast<std::uint64_t>(nz / 2 + 1);
  const std::uint64_t B = SlitStokesPlan::kModeBlock;
  const std::uint64_t blocks =
      static_cast<std::uint64_t>(nx / 2 + 1) * ((static_cast<std::uint64_t>(nz / 2 + 1) + B - 1) / B);
  const std::uint64_t lanes = blocks * ((2 * np + 4) * B + tau_lanes_doubles(N, static_cast<int>(B))) * 8 +
                              blocks * sizeof(TauLanes);
  return 6 * np * plane * 8 + 3 * np * cplane * 16 + 6 * plane * 8 + 6 * cplane * 16 + np * 8 + lanes;
}

MemoryEstimate estimate_memory(const RunSize& s) {
  MemoryEstimate m;
  m.grid = grid_bytes(s.grid.nx, s.grid.nz, s.grid.ny);
  m.capsules = static_cast<std::uint64_t>(kBytesPerNode * static_cast<double>(s.nodes) +
                                          kBytesPerWallPoint * static_cast<double>(s.wall_points));
  m.base = static_cast<std::uint64_t>(kBaseBytes);
  return m;
}

std::string bytes_text(std::uint64_t bytes) {
  char buf[32];
  const double b = static_cast<double>(bytes);
  if (b >= 1024.0 * 1024.0 * 1024.0)
    std::snprintf(buf, sizeof buf, "%.1f GiB", b / (1024.0 * 1024.0 * 1024.0));
  else
    std::snprintf(buf, sizeof buf, "%.0f MiB", std::ceil(b / (1024.0 * 1024.0)));
  return buf;
}

void check_memory_fits(const Config& c, const RunSize& s, const MemoryEstimate& need, const MemoryLimit& avail) {
  if (avail.bytes == 0 || need.total() <= avail.bytes) return;
  char grid[96];
  std::snprintf(grid, sizeof grid, "%d x %d x %d", s.grid.nx, s.grid.nz, s.grid.ny + 1);
  // Name the key that asked for the memory: the capsules' arrays, an explicit grid size, or alpha's grid.
  std::string key = "[ggem] alpha";
  if (need.capsules > need.grid) {
    key = c.suspension && c.suspension->count ? "[suspension] count"
          : c.suspension                      ? "[suspension] volume_fraction"
                                              : "[capsules] mesh_level";
  } else {
    int largest = 0;
    for (const auto& [n, k] : {std::pair<int, const char*>{c.ggem.nx, "[ggem] nx"},
                               {c.ggem.nz, "[ggem] nz"},
                               {c.ggem.ny, "[ggem] ny"}})
      if (n > largest) {
        largest = n;
        key = k;
      }
  }
  throw InputError(c.origin(key) + ": the run needs about " + bytes_text(need.total()) +
                   " of memory (grid " + grid + " = " + std::to_string(s.grid_points) + " points: " +
                   bytes_text(need.grid) + "; " +
                   std::to_string(s.nodes) + " nodes: " + bytes_text(need.capsules) + "), but this process may use " +
                   bytes_text(avail.bytes) + " (" + avail.what +
                   "): coarsen the grid ([ggem] alpha, alpha_hm, nx, nz, ny), use fewer capsules or a coarser mesh, shrink "
                   "the box or use a machine with more memory");
}

bool StartStepEstimate::far_below() const { return dt < dt_rule / StepWatch::kFarBelow; }

StartStepEstimate start_step_estimate(const Config& c) {
  StartStepEstimate st;
  st.dt = st.dt_rule = 1.0 / estimate_step_rates(c).start;
  if (c.time.step_rule != StepRule::Membrane || c.suspension || c.capsule_list.empty()) return st;
  CapsuleState s(c.capsules.mesh_level, c.capsules.membrane);
  for (std::size_t i = 0; i < c.species.size(); ++i)
    s.add_species(SpeciesProperties{c.species[i].ca, c.species[i].bending_modulus, c.species_membrane(i),
                                    c.species[i].shape});
  try {
    for (const CapsulePlacement& p : place_capsules(c))
      s.add_capsule(p.center, c.species_radius(static_cast<std::size_t>(p.species)), p.species, p.orientation);
  } catch (const InputError&) {
    return st;  // the run refuses it, naming the key
  }
  const CapsuleGeometry g = compute_geometry(s, Backend::Serial);
  const double h_near = near_contact_range(s);  // h_e as the run takes it (TimeStepRule)
  // The imposed flow at the nodes (docs/method.md 3): shear gammadot (y - H/2), Poiseuille gammadot_w y (1 - y/H).
  const std::size_t n = s.x.size();
  std::vector<double> ux(n, 0.0), uy(n, 0.0), uz(n, 0.0);
  const double gd = c.flow.shear_rate, H = c.domain.H;
  for (std::size_t i = 0; i < n; ++i)
    ux[i] = c.flow.type == FlowType::Shear        ? gd * (s.y[i] - 0.5 * H)
            : c.flow.type == FlowType::Poiseuille ? gd * s.y[i] * (1.0 - s.y[i] / H)
                                                  : 0.0;
  const ClosingLimits cl = closing_limits(s, g.centroid, ux.data(), uy.data(), uz.data(), c.domain.Lx, c.domain.Lz,
                                          H, h_near, c.time.min_gap, Backend::Serial);
  const StepInfo info = estimate_first_step(c, st.dt_rule, h_near, cl);  // the run's rule, at the first step
  st.dt = info.dt;
  st.limit = info.limit;
  st.keys = step_limit_keys(c, info, h_near);
  return st;
}

CostEstimate estimate_cost(const Config& c, const RunSize& s, int threads) {
  CostEstimate e;
  e.threads = std::max(1, threads);
  const double t2 = kSecondsPerNode2T * static_cast<double>(s.nodes) +
                    kSecondsPerWallPoint2T * static_cast<double>(s.wall_points) +
                    kSecondsPerGridPoint2T * static_cast<double>(s.grid_points);
  // Serial from the measured ratio; T threads as 2 threads' parallel efficiency held (an optimistic idealisation).
  const double serial = t2 * kSerialOver2Threads;
  e.seconds_per_step = e.threads == 1 ? serial : serial / (kSerialOver2Threads / 2.0 * e.threads);
  // A viscosity ratio != 1: the interface-velocity solve each step (the calibration above; it was left out, which put
  // a lambda-5 estimate 13x below the run, issue 37).
  if (c.has_viscosity_contrast()) {
    // kGmresApplicationsPerStep was measured at the default tolerance (1e-6).
    const double gmres =
        std::max(1.0, kGmresApplicationsPerStep +
                          kGmresApplicationsPerDecade * std::log10(GmresConfig{}.tolerance / c.gmres.tolerance));
    e.interface_solve_applications = kSetGeometryApplications + gmres * kDoubleOverSingleLayer;
    e.seconds_per_step *= 1.0 + e.interface_solve_applications;
  }

  const StepRateEstimate r = estimate_step_rates(c);
  e.ca_ref = r.ca_ref;
  e.dilute = !c.suspension;
  e.steps_per_strain_start = e.steps_per_strain_rule = r.start;
  e.steps_per_strain_developed = r.developed;
  // Explicit capsules: a close pair can hold the first steps below the rule (near_contact_factor, c_gap, min_gap).
  // Costed at that rate for the first strain units, then at the rule's.
  if (e.dilute) {
    const StartStepEstimate st = start_step_estimate(c);
    e.steps_per_strain_start = std::max(r.start, 1.0 / st.dt);
  }
  const double end = c.time.end.value_or(0.0);
  const double start = std::min(end, kStartStrain);
  e.total_seconds = e.seconds_per_strain_start() * start + e.seconds_per_strain_developed() * (end - start);
  return e;
}

}  // namespace capsflow
