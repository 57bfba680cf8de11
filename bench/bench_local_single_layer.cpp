// Google Benchmark of the local single layer over capsule membranes (src/kernels/local_single_layer.hpp) in the
// paper's set A box: 50 capsules of level 2 (162 nodes, 320 elements) at volume fraction 0.2, H = 10.15,
// Lx = Lz = 10.2, alpha = 4, r_c = 1, default QuadratureOrders. Centres at random without overlap (centre distance
// >= 2.1, >= 1.05 from the walls), random nodal densities. Cases: targets = all 8100 nodes; targets = 84 x 84 grid
// points on each wall (y = 0 and y = H); the cell-list build. Serial (arg 0) and threads (arg 1).
// Run: OMP_NUM_THREADS=2 build/sl/bench/bench_local_single_layer
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/state/capsule_state.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/local_single_layer.hpp"

using namespace capsflow;

namespace {

constexpr double kH = 10.15, kL = 10.2, kAlpha = 4.0, kCutoff = 1.0;

struct SetA {
  CapsuleState s{2};
  std::vector<double> wx, wy, wz;  // wall grid points
  std::vector<int> node_ids;
  SetA() {
    std::mt19937_64 rng(2024u);
    std::uniform_real_distribution<double> ux(0.0, kL), uy(1.05, kH - 1.05);
    const int sp = s.add_species(0.3);
    std::vector<std::array<double, 3>> c;
    while (c.size() < 50) {
      const std::array<double, 3> p = {ux(rng), uy(rng), ux(rng)};
      bool ok = true;
      for (const auto& q : c) {
        const double dx = min_image(p[0] - q[0], kL), dy = p[1] - q[1], dz = min_image(p[2] - q[2], kL);
        ok = ok && dx * dx + dy * dy + dz * dz >= 2.1 * 2.1;
      }
      if (ok) c.push_back(p);
    }
    for (const auto& p : c) s.add_capsule(p, 1.0, sp);
    for (auto& v : s.x) v -= kL * std::floor(v / kL);
    for (auto& v : s.z) v -= kL * std::floor(v / kL);
    std::uniform_real_distribution<double> uf(-1.0, 1.0);
    const auto n = static_cast<std::size_t>(s.num_nodes());
    s.fx.resize(n);
    s.fy.resize(n);
    s.fz.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      s.fx[i] = uf(rng);
      s.fy[i] = uf(rng);
      s.fz[i] = uf(rng);
      node_ids.push_back(static_cast<int>(i));
    }
    for (double yw : {0.0, kH})
      for (int i = 0; i < 84; ++i)
        for (int j = 0; j < 84; ++j) {
          wx.push_back((i + 0.5) * kL / 84.0);
          wy.push_back(yw);
          wz.push_back((j + 0.5) * kL / 84.0);
        }
  }
};

const SetA& set_a() {
  static const SetA p;
  return p;
}

Backend backend_of(const benchmark::State& st) { return st.range(0) ? Backend::Threads : Backend::Serial; }

ElementCellList build(const CapsuleState& s) {
  ElementCellList cl;
  build_element_cell_list(cl, kL, kH, kL, kCutoff, s.num_capsules(), s.nodes_per_capsule(), s.triangles_per_capsule(),
                          s.mesh().tri.data(), s.x.data(), s.y.data(), s.z.data());
  return cl;
}

void run(benchmark::State& st, std::size_t n, const double* tx, const double* ty, const double* tz, const int* tn) {
  const SetA& p = set_a();
  const CapsuleState& s = p.s;
  const ElementCellList cl = build(s);
  std::vector<double> u(3 * n, 0.0);
  const QuadratureOrders q;
  for (auto _ : st) {
    local_single_layer_velocity(backend_of(st), cl, LocalSplit{kAlpha, kCutoff, 1.0 / (8.0 * kPi)},
                                SurfaceView{s.num_capsules(), s.nodes_per_capsule(), s.triangles_per_capsule(),
                                            s.mesh().tri.data(), s.x.data(), s.y.data(), s.z.data()},
                                Vec3In{s.fx.data(), s.fy.data(), s.fz.data()}, q, TargetView{n, tx, ty, tz, tn},
                                Vec3Out{u.data(), u.data() + n, u.data() + 2 * n});
    benchmark::DoNotOptimize(u.data());
  }
  st.counters["targets/s"] =
      benchmark::Counter(static_cast<double>(n), benchmark::Counter::kIsIterationInvariantRate);
  st.counters["targets"] = static_cast<double>(n);
  st.SetLabel(backend_name(backend_of(st)));
}

void BM_NodeTargets(benchmark::State& st) {
  const SetA& p = set_a();
  run(st, p.node_ids.size(), p.s.x.data(), p.s.y.data(), p.s.z.data(), p.node_ids.data());
}

void BM_WallTargets(benchmark::State& st) {
  const SetA& p = set_a();
  run(st, p.wx.size(), p.wx.data(), p.wy.data(), p.wz.data(), nullptr);
}

void BM_BuildCellList(benchmark::State& st) {
  const SetA& p = set_a();
  for (auto _ : st) {
    ElementCellList cl = build(p.s);
    benchmark::DoNotOptimize(cl.elem.data());
  }
}

}  // namespace

BENCHMARK(BM_NodeTargets)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_WallTargets)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_BuildCellList)->Unit(benchmark::kMillisecond);
