#include "host/run/run_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <cstdio>
#include <limits>

#include "host/base/errors.hpp"
#include "host/physics/initial_conditions.hpp"
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

// Calibration of the steps per strain unit: h of dt = cfl Ca_ref h / a (Config::rule_step), measured on the set C runs of
// docs/reproduction.md (level 2, cfl 0.5, Ca_ref 0.2): 68 steps per strain unit over the first strain unit (a fresh
// random placement: h = 0.147 a) and 190-220 after strain 10 (X_f = 0: h = 0.05 a, set by the closest node pairs of
// neighbouring capsules near min_gap). A pure floppy suspension steps ~2x faster than the stiff one.
constexpr double kFreshH = 0.147;      // level 2; scales with the mesh spacing 2^-level
constexpr double kDevelopedH = 0.050;  // gap-limited: the same at every level (capped by the fresh h)
constexpr double kStartStrain = 2.0;   // strain units costed at the fresh rate before the developed one
// The membrane rule ([time] step_rule = "membrane"): h is the shortest edge of the deformed capsules, 0.227 a at
// level 2 in set A and C alike (44 steps per strain unit at cfl 0.5, Ca_ref 0.2: set A over [0, 20] with the gap
// term removed, set C over [0, 3], docs/performance.md section 7), fresh or developed. A developed suspension
// always has pairs within h_e, so its steps carry the near-contact factor.
constexpr double kMembraneH = 0.227;   // level 2; scales with the mesh spacing 2^-level

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

CostEstimate estimate_cost(const Config& c, const RunSize& s, int threads) {
  CostEstimate e;
  e.threads = std::max(1, threads);
  const double t2 = kSecondsPerNode2T * static_cast<double>(s.nodes) +
                    kSecondsPerWallPoint2T * static_cast<double>(s.wall_points) +
                    kSecondsPerGridPoint2T * static_cast<double>(s.grid_points);
  // Serial from the measured ratio; T threads as 2 threads' parallel efficiency held (an optimistic idealisation).
  const double serial = t2 * kSerialOver2Threads;
  e.seconds_per_step = e.threads == 1 ? serial : serial / (kSerialOver2Threads / 2.0 * e.threads);

  // Ca_ref as the run takes it (Simulation::build_state): Ca (a_ref / a) / f over the species, with the law's
  // stiffness factor f and the viscosity ratio's factor; the shortest edge scales with the smallest species' radius
  // (shapes' distortion not counted).
  // The smallest radius of the species (the [capsules] radius only when no species gives one: it is a default).
  double ca_min = c.species.empty() ? 1.0 : c.species[0].ca;
  double a_min = c.species.empty() ? c.capsules.radius : std::numeric_limits<double>::infinity();
  double ca_rule = c.species.empty() ? 1.0 : std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < c.species.size(); ++i) {
    const double a = c.species_radius(i);
    ca_min = std::min(ca_min, c.species[i].ca);
    ca_rule = std::min(ca_rule, c.species_step_ca(i));
    a_min = std::min(a_min, a);
  }
  e.ca_ref = c.time.reference_ca ? *c.time.reference_ca * (ca_rule / ca_min) : ca_rule;
  const double level_scale = std::pow(2.0, 2 - c.capsules.mesh_level);
  e.dilute = !c.suspension;
  if (c.time.step_rule == StepRule::Membrane) {
    const double h = kMembraneH * level_scale * a_min;  // the smallest species' shortest edge
    e.steps_per_strain_start = 1.0 / c.rule_step(e.ca_ref, h);
    e.steps_per_strain_developed =
        e.dilute ? e.steps_per_strain_start : 1.0 / (c.time.near_contact_factor * c.rule_step(e.ca_ref, h));
    // Bending adds its rate (1/dt_B, dt_B = bending_cfl mu gammadot h^3 / kappa, kappa = kb Gs a^2, Gs = mu gammadot
    // a / Ca), each species with its own edge.
    double bending_rate = 0.0;
    for (std::size_t i = 0; i < c.species.size(); ++i) {
      const SpeciesSpec& sp = c.species[i];
      if (!(sp.bending_modulus > 0.0)) continue;
      const double a = c.species_radius(i), hb = kMembraneH * level_scale * a;  // this species' shortest edge
      const double kappa = sp.bending_modulus * (a / sp.ca) * a * a;
      bending_rate = std::max(bending_rate, kappa / (c.time.bending_cfl * hb * hb * hb));
    }
    e.steps_per_strain_start += bending_rate;
    e.steps_per_strain_developed += bending_rate;
  } else {
    const double a = c.capsules.radius;  // the calibration's h are in units of a
    const double h_fresh = kFreshH * level_scale * a;
    const double h_dev = std::min(h_fresh, kDevelopedH * a);
    e.steps_per_strain_start = 1.0 / c.rule_step(e.ca_ref, h_fresh);
    e.steps_per_strain_developed = e.dilute ? e.steps_per_strain_start : 1.0 / c.rule_step(e.ca_ref, h_dev);
  }
  const double end = c.time.end.value_or(0.0);
  const double start = std::min(end, kStartStrain);
  e.total_seconds = e.seconds_per_strain_start() * start + e.seconds_per_strain_developed() * (end - start);
  return e;
}

}  // namespace capsflow
