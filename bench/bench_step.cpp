// Google Benchmark of one full time step of `capsflow run` (Simulation::advance: membrane forces, local integrals
// at the nodes, local integrals at the wall grid points, GGEM global solve and interpolation, dt, AB2 update,
// contact control) for the paper's set A: 50 level-2 capsules, phi = 0.2, 2a/H = 0.197 (H = 10.15, Lx = Lz = 10.2),
// alpha = 4, alpha_hm = 0.5, half stiff (Ca 0.2) and half floppy (Ca 1), Poiseuille flow, random placement (seed 1).
// The counters give each stage's mean seconds per step; their shares are in docs/performance.md.
// Run: OMP_NUM_THREADS=2 build/release/bench/bench_step
// Args: 0 serial, 1 threads, 2 device (offload builds only; tools/device-check.sh runs it on a GPU).
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/physics/config.hpp"
#include "host/solver/sample_problems.hpp"
#include "host/physics/simulation.hpp"
#include "host/physics/velocity_model.hpp"
#include "host/solver/double_layer_plan.hpp"
#include "host/solver/single_layer_plan.hpp"

using namespace capsflow;

namespace {

void BM_SetAStep(benchmark::State& st) {
  Config c = parse_config(set_a_step_problem_toml(), "set A");
  c.run.backend = st.range(0) == 2 ? Backend::Device : st.range(0) ? Backend::Threads : Backend::Serial;
  if (!backend_available(c.run.backend)) {
    st.SkipWithError("backend not available here");
    return;
  }
  Simulation sim(c);
  sim.advance();  // the Euler start: later steps are AB2, as in a run
  SimulationTimings sum;
  long steps = 0, corrections = 0;
  const TransferCounts before = sim.workspace().transfers();
  for (auto _ : st) {
    const StepInfo info = sim.advance();
    if (info.stop != StopReason::None) {
      st.SkipWithError(info.message.c_str());
      break;
    }
    sum += sim.last_timings();
    corrections += info.contact.pair_corrections + info.contact.wall_corrections;
    ++steps;
  }
  const double n = steps > 0 ? static_cast<double>(steps) : 1.0;
  st.counters["forces_s"] = sum.forces / n;
  st.counters["local_nodes_s"] = sum.local_nodes / n;
  st.counters["local_walls_s"] = sum.local_walls / n;
  st.counters["global_s"] = sum.global / n;
  st.counters["dt_s"] = sum.step_size / n;
  st.counters["ab2_s"] = sum.update / n;
  st.counters["contact_s"] = sum.contact / n;
  st.counters["corrections"] = static_cast<double>(corrections);
  // The device step's transfers of resident arrays (StepWorkspace; 0 on the host backends, docs/device.md).
  const TransferCounts moved = sim.workspace().transfers() - before;
  st.counters["resident_MB_per_step"] = static_cast<double>(moved.pull_bytes + moved.push_bytes) / 1e6 / n;
  st.counters["resident_copies_per_step"] = static_cast<double>(moved.calls()) / n;
  st.counters["nodes"] = static_cast<double>(sim.state().num_nodes());
  st.SetLabel(backend_name(c.run.backend));
}

// Scaling (issue 11): set A's density, mesh and species with N capsules in a box widened in x and z
// (Lx = Lz = 10.2 sqrt(N / 50), same H and phi), threads backend. Run each size in its own process for its peak
// memory: --benchmark_filter='BM_SetAScaling/800'.
void BM_SetAScaling(benchmark::State& st) {
  const int n = static_cast<int>(st.range(0));
  Config c = parse_config(set_a_step_problem_toml(), "set A");
  c.domain.Lx = c.domain.Lz = 10.2 * std::sqrt(n / 50.0);
  c.run.backend = Backend::Threads;
  Simulation sim(c);
  sim.advance();
  SimulationTimings sum;
  long steps = 0;
  for (auto _ : st) {
    const StepInfo info = sim.advance();
    if (info.stop != StopReason::None) {
      st.SkipWithError(info.message.c_str());
      break;
    }
    sum += sim.last_timings();
    ++steps;
  }
  const double k = steps > 0 ? static_cast<double>(steps) : 1.0;
  st.counters["capsules"] = static_cast<double>(sim.state().num_capsules());
  st.counters["local_nodes_s"] = sum.local_nodes / k;
  st.counters["local_walls_s"] = sum.local_walls / k;
  st.counters["global_s"] = sum.global / k;
  st.counters["dt_s"] = sum.step_size / k;
  st.counters["contact_s"] = sum.contact / k;
}

// The velocity operator alone on set A's geometry after one evaluate (issue 19): set_geometry (element cell list,
// packed element geometry) and apply (u = S[f]: local sums at the nodes and the wall points, spread, solve,
// interpolate), the cost an iterative solve (viscosity ratio != 1) pays per iteration. Host backends (the device
// plan needs the run's workspace: BM_SetAStep covers it).
void BM_SetAOperator(benchmark::State& st, bool geometry_too) {
  Config c = parse_config(set_a_step_problem_toml(), "set A");
  c.run.backend = st.range(0) ? Backend::Threads : Backend::Serial;
  Simulation sim(c);
  sim.evaluate();
  const CapsuleState& s = sim.state();
  // The run's element rules (the configuration's [quadrature], as Simulation takes them), not the plan's finer default.
  SingleLayerPlan plan(c.domain, c.ggem, c.run.backend, quadrature_orders(c.quadrature));
  plan.set_geometry(s);
  std::vector<double> ux, uy, uz;
  SingleLayerTimings sum;
  // The global part's stages: spreading, the 2D FFTs (forward and inverse), the mode solves with their DCTs along y,
  // and the interpolation (the rest of global_s: the wall values and the sources' stencils).
  double spread = 0.0, fft = 0.0, modes = 0.0, interp = 0.0;
  long k = 0;
  for (auto _ : st) {
    if (geometry_too) plan.set_geometry(s);
    plan.apply(s, ux, uy, uz);
    const SingleLayerTimings& t = plan.last_timings();
    sum.set_geometry += t.set_geometry;
    sum.local_nodes += t.local_nodes;
    sum.local_walls += t.local_walls;
    sum.global += t.global;
    const GgemGlobalTimings& g = plan.global_part().last_timings();
    spread += g.spread;
    interp += g.interpolate;
    fft += plan.global_part().slit_solve().last_transform_seconds();
    modes += plan.global_part().slit_solve().last_mode_seconds();
    ++k;
  }
  const double n = k > 0 ? static_cast<double>(k) : 1.0;
  if (geometry_too) st.counters["set_geometry_s"] = sum.set_geometry / n;
  st.counters["local_nodes_s"] = sum.local_nodes / n;
  st.counters["local_walls_s"] = sum.local_walls / n;
  st.counters["global_s"] = sum.global / n;
  st.counters["spread_s"] = spread / n;
  st.counters["fft_s"] = fft / n;
  st.counters["modes_s"] = modes / n;
  st.counters["interp_s"] = interp / n;
  st.SetLabel(backend_name(c.run.backend));
}
void BM_SetAApply(benchmark::State& st) { BM_SetAOperator(st, false); }
void BM_SetASetGeometryAndApply(benchmark::State& st) { BM_SetAOperator(st, true); }

// Issue 22: one step of set A with every capsule at viscosity ratio lambda = arg / 10 (10: the lambda = 1 path, no
// double layer; 50: lambda = 5, GMRES on the interface-velocity equation), threads backend, in the same process so
// the two are compared on the same machine state. Counters: GMRES applications per step and the interface solve's
// seconds (the double layer's set_geometry and applications). BM_SetAStepViscosityRatioDevice: the same on the
// device backend (registered in offload builds only; issue 34: the GPU check measures lambda 5 against lambda 1).
void set_a_step_viscosity_ratio(benchmark::State& st, Backend backend, const char* ggem_tolerance = nullptr) {
  Config c = parse_config(
      ggem_tolerance ? set_a_step_problem_toml_at_tolerance(ggem_tolerance) : set_a_step_problem_toml(), "set A");
  c.run.backend = backend;
  for (SpeciesSpec& sp : c.species) sp.viscosity_ratio = static_cast<double>(st.range(0)) / 10.0;
  Simulation sim(c);
  sim.advance();
  SimulationTimings sum;
  long steps = 0, applications = 0;
  for (auto _ : st) {
    const StepInfo info = sim.advance();
    if (info.stop != StopReason::None) {
      st.SkipWithError(info.message.c_str());
      break;
    }
    sum += sim.last_timings();
    if (sim.solves_interface_velocity()) applications += sim.last_gmres().iterations;
    ++steps;
  }
  const double n = steps > 0 ? static_cast<double>(steps) : 1.0;
  st.counters["gmres_applications"] = static_cast<double>(applications) / n;
  st.counters["interface_solve_s"] = sum.interface_solve / n;
  st.counters["velocity_s"] = sum.velocity_total / n;
  st.SetLabel("lambda " + std::to_string(static_cast<double>(st.range(0)) / 10.0).substr(0, 3) + ", " +
              backend_name(backend));
}
void BM_SetAStepViscosityRatio(benchmark::State& st) { set_a_step_viscosity_ratio(st, Backend::Threads); }
// The same at the study presets' numerics (issue 34): [ggem] tolerance = 1e-2 instead of alpha_hm 0.5, and with it
// the interface solve's tolerance 1e-5 (a thousandth; the reader derives it).
void BM_SetAStepViscosityRatioPreset(benchmark::State& st) {
  set_a_step_viscosity_ratio(st, Backend::Threads, "1e-2");
}

// The double layer's application alone on set A's geometry (DoubleLayerPlan::apply: local at the nodes and the wall
// points, dipole spreading, Poisson and Stokes solves, interpolation): one GMRES iteration's cost, beside the single
// layer's (BM_SetAApply).
void BM_SetADoubleLayerApply(benchmark::State& st) {
  Config c = parse_config(set_a_step_problem_toml(), "set A");
  c.run.backend = st.range(0) ? Backend::Threads : Backend::Serial;
  Simulation sim(c);
  sim.evaluate();
  const CapsuleState& s = sim.state();
  SingleLayerPlan plan(c.domain, c.ggem, c.run.backend, quadrature_orders(c.quadrature));
  plan.set_geometry(s);
  DoubleLayerPlan dl(plan);
  dl.set_geometry();
  std::vector<double> kx, ky, kz;
  DoubleLayerTimings sum;
  long k = 0;
  for (auto _ : st) {
    dl.apply(NodeField{s.fx, s.fy, s.fz}, NodeFieldOut{kx, ky, kz});
    const DoubleLayerTimings& t = dl.last_timings();
    sum.local_nodes += t.local_nodes;
    sum.local_walls += t.local_walls;
    sum.global += t.global;
    ++k;
  }
  const double n = k > 0 ? static_cast<double>(k) : 1.0;
  st.counters["local_nodes_s"] = sum.local_nodes / n;
  st.counters["local_walls_s"] = sum.local_walls / n;
  st.counters["global_s"] = sum.global / n;
  st.counters["set_geometry_s"] = dl.last_timings().set_geometry;
  st.SetLabel(backend_name(c.run.backend));
}

void step_args(benchmark::internal::Benchmark* b) {
  b->Arg(0)->Arg(1);
  if (device_backend_built()) b->Arg(2);
}

}  // namespace

BENCHMARK(BM_SetAScaling)->Arg(50)->Arg(200)->Arg(800)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_SetAStep)->Apply(step_args)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(5.0);
BENCHMARK(BM_SetAApply)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_SetAStepViscosityRatio)->Arg(10)->Arg(50)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(5.0);
BENCHMARK(BM_SetAStepViscosityRatioPreset)->Arg(10)->Arg(50)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(5.0);
// Registered where the device backend is built (a benchmark without arguments would run once with none).
[[maybe_unused]] const bool device_viscosity_ratio_registered = [] {
  if (!device_backend_built()) return false;
  benchmark::RegisterBenchmark("BM_SetAStepViscosityRatioDevice",
                               [](benchmark::State& st) { set_a_step_viscosity_ratio(st, Backend::Device); })
      ->Arg(10)->Arg(50)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(5.0);
  return true;
}();
BENCHMARK(BM_SetADoubleLayerApply)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
BENCHMARK(BM_SetASetGeometryAndApply)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);
