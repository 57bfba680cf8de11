// Google Benchmark of [ggem] tolerance (issue 34; docs/performance.md section 13): the velocity operator u = S[f]
// on set A's developed geometry (bench/data/set_a_strain205.checkpoint.h5: the X_f = 0.5 reproduction run at strain
// 205, 50 level-2 capsules, near contacts, membrane loads of a sheared suspension) at the parameters a tolerance
// picks, timed per application, with its error as counters:
//   err_max, err_rms   against the same alpha at alpha h_m 0.3, r_c 5 / alpha (the splitting's own error), as
//                      max over nodes |du| / max |u| and the root mean square of |du| / |u|
//   split_max, split_rms against alpha 1.5 at alpha h_m 0.3, r_c 5 / alpha (closer to the continuous integral: the
//                      global part's point forces at the nodes are the split's surface quadrature, exact as alpha -> 0)
// BM_SetATolerance/<k>/<threads>: k 0 the defaults (no tolerance), 1.. the tolerances of kTolerances (with the
// element rules a tolerance picks).
// BM_SetAAlpha/<10 alpha>/<threads>: alpha at the defaults' alpha h_m and r_c alpha, for the split's error.
// BM_SetAQuadrature/<k>/<threads>: the element rules of set k at the defaults' GGEM parameters (quadrature_set).
// Run: OMP_NUM_THREADS=2 build/release/bench/bench_ggem_tolerance
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/physics/config.hpp"
#include "host/physics/simulation.hpp"
#include "host/physics/velocity_model.hpp"
#include "host/run/checkpoint.hpp"
#include "host/solver/single_layer_plan.hpp"

using namespace capsflow;

namespace {

const double kTolerances[] = {2e-2, 1e-2, 5e-3, 1e-3, 1e-4};

// The developed set-A state, its configuration and its membrane load (one evaluate), made once per process.
struct Geometry {
  Config cfg;
  std::unique_ptr<Simulation> sim;
};
Geometry& geometry() {
  static Geometry g = [] {
    const std::string file = std::string(CAPSFLOW_BENCH_DATA) + "/set_a_strain205.checkpoint.h5";
    const Checkpoint ck = read_checkpoint(file);
    Geometry r;
    r.cfg = checkpoint_config(ck, file);
    r.cfg.run.backend = Backend::Serial;
    r.sim = std::make_unique<Simulation>(r.cfg, ck.state, file);
    r.sim->evaluate();
    return r;
  }();
  return g;
}

struct Velocity {
  std::vector<double> x, y, z;
};
Velocity apply_once(const GgemOptions& o, Backend b) {
  Geometry& g = geometry();
  SingleLayerPlan plan(g.cfg.domain, o, b);
  plan.set_geometry(g.sim->state());
  Velocity v;
  plan.apply(g.sim->state(), v.x, v.y, v.z);
  return v;
}
GgemOptions tight(double alpha) {
  GgemOptions o;
  o.alpha = alpha;
  o.alpha_hm = 0.3;
  o.cutoff = 5.0 / alpha;
  return o;
}
// One reference per alpha, made on first use (a map: the references it hands out stay valid as it grows).
const Velocity& reference(double alpha) {
  static std::map<double, Velocity> cache;
  auto it = cache.find(alpha);
  if (it == cache.end()) it = cache.emplace(alpha, apply_once(tight(alpha), Backend::Threads)).first;
  return it->second;
}
void errors(const Velocity& u, const Velocity& ref, double& max_rel, double& rms_rel) {
  double umax = 0.0, emax = 0.0, e2 = 0.0, u2 = 0.0;
  for (std::size_t i = 0; i < u.x.size(); ++i) {
    const double d = std::hypot(u.x[i] - ref.x[i], u.y[i] - ref.y[i], u.z[i] - ref.z[i]);
    umax = std::max(umax, std::hypot(ref.x[i], ref.y[i], ref.z[i]));
    emax = std::max(emax, d);
    e2 += d * d;
    u2 += ref.x[i] * ref.x[i] + ref.y[i] * ref.y[i] + ref.z[i] * ref.z[i];
  }
  max_rel = emax / umax;
  rms_rel = std::sqrt(e2 / u2);
}

void run_operator(benchmark::State& st, const GgemOptions& o, const QuadratureOrders& rules = {}) {
  Geometry& g = geometry();
  const Backend b = st.range(1) ? Backend::Threads : Backend::Serial;
  SingleLayerPlan plan(g.cfg.domain, o, b, rules);
  plan.set_geometry(g.sim->state());
  Velocity v;
  SingleLayerTimings sum;
  long k = 0;
  for (auto _ : st) {
    plan.apply(g.sim->state(), v.x, v.y, v.z);
    const SingleLayerTimings& t = plan.last_timings();
    sum.local_nodes += t.local_nodes;
    sum.local_walls += t.local_walls;
    sum.global += t.global;
    ++k;
  }
  double m = 0.0, r = 0.0;
  errors(v, reference(o.alpha), m, r);
  st.counters["err_max"] = m;
  st.counters["err_rms"] = r;
  errors(v, reference(1.5), m, r);
  st.counters["split_max"] = m;
  st.counters["split_rms"] = r;
  const double n = k > 0 ? static_cast<double>(k) : 1.0;
  st.counters["alpha"] = o.alpha;
  st.counters["alpha_hm"] = o.alpha_hm;
  st.counters["alpha_hx"] = plan.grid().hx * o.alpha;  // the grid's: nx rounded up to a fast FFT size
  st.counters["rc_alpha"] = plan.grid().cutoff * o.alpha;
  st.counters["grid_points"] = static_cast<double>(plan.grid().nx) * plan.grid().nz * (plan.grid().ny + 1);
  st.counters["local_nodes_s"] = sum.local_nodes / n;
  st.counters["local_walls_s"] = sum.local_walls / n;
  st.counters["global_s"] = sum.global / n;
}

void BM_SetATolerance(benchmark::State& st) {
  GgemOptions o;  // the defaults: alpha 4, alpha h_m 0.5, r_c 3.5 / alpha
  // What a run uses: the run's default element rules at every tolerance (issue 34; performance.md sections 16-17;
  // section 13's table had the kernels' finer rules).
  const QuadratureOrders rules = quadrature_orders(QuadratureOptions{});
  if (st.range(0) > 0) {
    o = with_ggem_tolerance(o, kTolerances[st.range(0) - 1]);
    st.SetLabel("tolerance " + std::to_string(o.tolerance));
  } else {
    st.SetLabel("defaults");
  }
  run_operator(st, o, rules);
}

void BM_SetAAlpha(benchmark::State& st) {
  GgemOptions o;
  o.alpha = 0.1 * static_cast<double>(st.range(0));
  o.cutoff = default_cutoff(o.alpha);
  run_operator(st, o);
}

// The element rules (docs/method_quadrature.md; the defaults sit ~1e-6 below the level-2 mesh's 2e-3): the operator
// at the defaults' GGEM parameters with rule set k, its error against the kernels' rules as counters. k 0: the
// kernels' rules (fine_quadrature, the run's defaults before issue 34); 1: the run's default rules (QuadratureOptions);
// 2-8: the sets measured on the way to them (performance.md 16).
QuadratureOrders quadrature_set(int k, std::string& label) {
  QuadratureOrders q;
  label = "kernels' rules";
  if (k == 1) {
    label = "run defaults";
    return quadrature_orders(QuadratureOptions{});
  }
  if (k >= 2) {  // the 7-point rule from 1.5, 5 x 5 from 0.75 to 1.5
    q.far_ratio = q.symmetric_ratio = q.outer_ratio = 1.5;
    q.regular_mid = 5;
    label = "D7 from 1.5, mid 5";
  }
  if (k >= 3) {
    q.regular_near = 7;
    q.singular = 5;
    label += ", near 7, singular 5";
  }
  if (k == 4) {
    q.near_angle = q.near_radial = 6;
    label += ", near-singular 6";
  }
  if (k == 5) {
    q.near_ratio = 0.35;
    label += ", near_ratio 0.35";
  }
  if (k == 6) {
    q.near_angle = q.near_radial = 5;
    q.near_ratio = 0.3;
    q.regular_near = 8;
    label = "D7 from 1.5, mid 5, near 8, singular 5, near_ratio 0.3, near-singular 5";
  }
  if (k == 7) {
    q.singular = 4;
    q.far_ratio = q.symmetric_ratio = q.outer_ratio = 1.0;
    q.mid_ratio = 0.6;
    q.regular_near = 6;
    q.near_ratio = 0.3;
    q.near_angle = q.near_radial = 5;
    label = "singular 4, D7 from 1.0, mid 5 from 0.6, near 6, near_ratio 0.3, near-singular 5";
  }
  return q;
}
void BM_SetAQuadrature(benchmark::State& st) {
  Geometry& g = geometry();
  const GgemOptions o;
  const Backend b = st.range(1) ? Backend::Threads : Backend::Serial;
  static const Velocity ref = [&] {
    SingleLayerPlan p(g.cfg.domain, o, Backend::Threads);
    p.set_geometry(g.sim->state());
    Velocity v;
    p.apply(g.sim->state(), v.x, v.y, v.z);
    return v;
  }();
  std::string label;
  SingleLayerPlan plan(g.cfg.domain, o, b, quadrature_set(static_cast<int>(st.range(0)), label));
  st.SetLabel(label);
  plan.set_geometry(g.sim->state());
  Velocity v;
  double nodes = 0.0;
  long k = 0;
  for (auto _ : st) {
    plan.apply(g.sim->state(), v.x, v.y, v.z);
    nodes += plan.last_timings().local_nodes;
    ++k;
  }
  double m = 0.0, r = 0.0;
  errors(v, ref, m, r);
  st.counters["quad_max"] = m;
  st.counters["quad_rms"] = r;
  st.counters["local_nodes_s"] = nodes / (k > 0 ? static_cast<double>(k) : 1.0);
}

}  // namespace

BENCHMARK(BM_SetAQuadrature)
    ->ArgsProduct({{0, 1, 2, 3, 4, 5, 6, 7}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->MinTime(1.0);
BENCHMARK(BM_SetATolerance)
    ->ArgsProduct({{0, 1, 2, 3, 4, 5}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->MinTime(2.0);
BENCHMARK(BM_SetAAlpha)
    ->ArgsProduct({{20, 30, 40, 50}, {1}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->MinTime(2.0);
