// Google Benchmark of the GGEM point-force solver: local sum, spreading, global solve, interpolation and the
// full apply, serial, threads and (offload builds) device, at several sizes. The "SetA" cases are the paper's set A box
// (H = 10.15, Lx = Lz = 10.2, a = 1, alpha = 4): 50 spheres of 162 nodes at volume fraction 0.2.
// Larger sizes keep that number density and H, and widen Lx = Lz. Run: build/release/bench/bench_ggem
#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/solver/ggem_solver.hpp"
#include "host/solver/sample_problems.hpp"
#include "host/solver/slit_stokes_plan.hpp"
#include "host/solver/slit_stokes_plan_device.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/local_sum.hpp"
#include "kernels/spread_interp.hpp"

using namespace capsflow;

namespace {

using Problem = PointForceSet;

// Problems by sphere count; 50 is set A, the others keep its number density in wider boxes.
const Problem& problem(int n_spheres) {
  static std::vector<std::pair<int, Problem>> cache;
  for (auto& [n, p] : cache)
    if (n == n_spheres) return p;
  cache.emplace_back(n_spheres, set_a_density(n_spheres, 2024u + static_cast<unsigned>(n_spheres)));
  return cache.back().second;
}

// The "threads" argument: 0 serial, 1 threads, 2 device (offload builds only; the global solve on the device,
// SlitStokesPlanDevice, its grids resident).
Backend backend_of(const benchmark::State& st) {
  return st.range(1) == 2 ? Backend::Device : st.range(1) ? Backend::Threads : Backend::Serial;
}

// Device cases without a device (or the test switch) are skipped, never timed on the host fallback.
bool usable(benchmark::State& st) {
  if (backend_available(backend_of(st))) return true;
  st.SkipWithError("backend not available here");
  return false;
}

// The grids of a case: the device plan's resident arrays for 'device' (spreading and interpolation then copy no grid
// per call), the CPU plan's otherwise.
struct Grids {
  std::unique_ptr<SlitStokesPlan> cpu;
  std::unique_ptr<SlitStokesPlanDevice> dev;
  Grids(const Problem& p, const GgemGrid& g, Backend b) {
    if (b == Backend::Device)
      dev = std::make_unique<SlitStokesPlanDevice>(p.geo, g);
    else
      cpu = std::make_unique<SlitStokesPlan>(p.geo, g, b);
  }
  double* forcing(int c) { return dev ? dev->forcing(c) : cpu->forcing(c); }
  const double* velocity(int c) const { return dev ? dev->velocity(c) : cpu->velocity(c); }
  const double* y() const { return dev ? dev->y_nodes().data() : cpu->y_nodes().data(); }
  std::size_t grid_size() const { return dev ? dev->grid_size() : cpu->grid_size(); }
  void solve() { dev ? dev->solve() : cpu->solve(); }
  double transform_seconds() const { return dev ? dev->last_transform_seconds() : cpu->last_transform_seconds(); }
  double mode_seconds() const { return dev ? dev->last_mode_seconds() : cpu->last_mode_seconds(); }
};

void set_rate(benchmark::State& st, std::size_t n) {
  st.counters["sources/s"] = benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate);
  st.SetLabel(backend_name(backend_of(st)));
}

void BM_FullApply(benchmark::State& st) {
  if (!usable(st)) return;
  const Problem& p = problem(static_cast<int>(st.range(0)));
  GgemSolver s(p.geo, GgemOptions{}, backend_of(st));
  const std::size_t n = p.size();
  std::vector<double> u(3 * n);
  GgemTimings sum;
  for (auto _ : st) {
    s.apply(n, p.x.data(), p.y.data(), p.z.data(), p.fx.data(), p.fy.data(), p.fz.data(), n, p.x.data(), p.y.data(),
            p.z.data(), u.data(), u.data() + n, u.data() + 2 * n);
    const auto& t = s.last_timings();
    sum.local += t.local;
    sum.wall_bc += t.wall_bc;
    sum.spread += t.spread;
    sum.global_solve += t.global_solve;
    sum.interpolate += t.interpolate;
  }
  const double it = static_cast<double>(st.iterations());
  st.counters["local_ms"] = 1e3 * sum.local / it;
  st.counters["wall_bc_ms"] = 1e3 * sum.wall_bc / it;
  st.counters["spread_ms"] = 1e3 * sum.spread / it;
  st.counters["solve_ms"] = 1e3 * sum.global_solve / it;
  st.counters["interp_ms"] = 1e3 * sum.interpolate / it;
  st.counters["grid"] = static_cast<double>(s.grid().nx) * (s.grid().ny + 1) * s.grid().nz;
  set_rate(st, n);
}

void BM_LocalSum(benchmark::State& st) {
  if (!usable(st)) return;
  const Problem& p = problem(static_cast<int>(st.range(0)));
  const GgemGrid g = resolve_ggem_grid(p.geo, GgemOptions{});
  const std::size_t n = p.size();
  std::vector<double> u(3 * n, 0.0);
  const double scale = 1.0 / (8.0 * kPi);
  for (auto _ : st) {
    PointCellList cl;
    build_point_cell_list(cl, p.geo.Lx, p.geo.H, p.geo.Lz, g.cutoff, n, p.x.data(), p.y.data(), p.z.data(),
                          p.fx.data(), p.fy.data(), p.fz.data());
    local_velocity_point_forces(backend_of(st), cl, g.alpha, g.cutoff, scale, n, p.x.data(), p.y.data(), p.z.data(),
                                u.data(), u.data() + n, u.data() + 2 * n);
    benchmark::DoNotOptimize(u.data());
  }
  set_rate(st, n);
}

void BM_Spread(benchmark::State& st) {
  if (!usable(st)) return;
  const Problem& p = problem(static_cast<int>(st.range(0)));
  const GgemGrid g = resolve_ggem_grid(p.geo, GgemOptions{});
  Grids plan(p, g, backend_of(st));
  SlitGridView view{g.nx, g.nz, g.ny, g.hx, g.hz, p.geo.H, plan.y()};
  SpreadWorkspace ws;
  const std::size_t n = p.size();
  for (auto _ : st) {
    spread_forces(backend_of(st), view, g.alpha, g.spread_cutoff, n, p.x.data(), p.y.data(), p.z.data(), p.fx.data(),
                  p.fy.data(), p.fz.data(), plan.forcing(0), plan.forcing(1), plan.forcing(2), ws);
    benchmark::DoNotOptimize(plan.forcing(0));
  }
  set_rate(st, n);
}

void BM_GlobalSolve(benchmark::State& st) {
  if (!usable(st)) return;
  const Problem& p = problem(static_cast<int>(st.range(0)));
  const GgemGrid g = resolve_ggem_grid(p.geo, GgemOptions{});
  Grids plan(p, g, backend_of(st));
  double transform = 0.0, modes = 0.0;
  for (auto _ : st) {
    plan.solve();
    transform += plan.transform_seconds();
    modes += plan.mode_seconds();
  }
  const double it = static_cast<double>(st.iterations());
  st.counters["fft_ms"] = 1e3 * transform / it;
  st.counters["modes_ms"] = 1e3 * modes / it;
  set_rate(st, p.size());
  st.counters["grid"] = static_cast<double>(plan.grid_size());
}

void BM_Interpolate(benchmark::State& st) {
  if (!usable(st)) return;
  const Problem& p = problem(static_cast<int>(st.range(0)));
  const GgemGrid g = resolve_ggem_grid(p.geo, GgemOptions{});
  Grids plan(p, g, backend_of(st));
  SlitGridView view{g.nx, g.nz, g.ny, g.hx, g.hz, p.geo.H, plan.y()};
  const std::size_t n = p.size();
  std::vector<double> u(3 * n, 0.0);
  for (auto _ : st) {
    interpolate_velocity(backend_of(st), view, plan.velocity(0), plan.velocity(1), plan.velocity(2), n, p.x.data(),
                         p.y.data(), p.z.data(), u.data(), u.data() + n, u.data() + 2 * n);
    benchmark::DoNotOptimize(u.data());
  }
  set_rate(st, n);
}

// Sphere counts: 12 (~2k sources), 50 (set A, 8100), 200 (32k), 618 (~100k sources).
void sizes(benchmark::internal::Benchmark* b) {
  for (int n : {12, 50, 200, 618})
    for (int threads : {0, 1, 2})
      if (threads < 2 || device_backend_built()) b->Args({n, threads});
  b->ArgNames({"spheres", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

}  // namespace

BENCHMARK(BM_FullApply)->Apply(sizes);
BENCHMARK(BM_LocalSum)->Apply(sizes);
BENCHMARK(BM_Spread)->Apply(sizes);
BENCHMARK(BM_GlobalSolve)->Apply(sizes);
BENCHMARK(BM_Interpolate)->Apply(sizes);
