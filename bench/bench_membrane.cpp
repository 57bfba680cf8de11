// Membrane forces (in-plane alone, and with bending) and capsule geometry: 50 and 800 capsules at mesh level 2, 50 at
// level 3; serial and threads.
// Run (release build):  OMP_NUM_THREADS=2 build/mr/bench/bench_membrane
// Figures and machine: docs/performance.md.
#include <benchmark/benchmark.h>

#include <vector>

#include "host/base/backend_select.hpp"
#include "host/state/capsule_state.hpp"
#include "kernels/capsule_geometry.hpp"

using namespace capsflow;

namespace {

// ncap capsules on a lattice, each slightly sheared so the forces are not trivial.
CapsuleState make_state(int ncap, int level, double bending_modulus = 0.0) {
  CapsuleState s(level);
  const int sp = s.add_species(0.3, bending_modulus);
  for (int k = 0; k < ncap; ++k) s.add_capsule({2.5 * (k % 10), 2.5 * ((k / 10) % 10), 2.5 * (k / 100)}, 1.0, sp);
  for (std::size_t i = 0; i < s.x.size(); ++i) s.x[i] += 0.2 * s.y[i];
  return s;
}

Backend backend_arg(const benchmark::State& st) { return st.range(2) ? Backend::Threads : Backend::Serial; }

// In-plane forces, and with bending modulus kb the four bending passes on top (kernels/bending_forces).
void membrane_forces_body(benchmark::State& st, double kb) {
  const Backend b = backend_arg(st);
  CapsuleState s = make_state(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)), kb);
  s.compute_membrane_forces(b);  // sizes the outputs and checks the backend
  for (auto _ : st) {
    s.compute_membrane_forces(b);
    benchmark::DoNotOptimize(s.fx.data());
    benchmark::ClobberMemory();
  }
  st.counters["nodes/s"] =
      benchmark::Counter(static_cast<double>(s.num_nodes()) * static_cast<double>(st.iterations()),
                         benchmark::Counter::kIsRate);
  st.SetLabel(backend_name(b));
}

void BM_MembraneForces(benchmark::State& st) { membrane_forces_body(st, 0.0); }
void BM_MembraneForcesWithBending(benchmark::State& st) { membrane_forces_body(st, 0.05); }

// The per-step geometry kernels: volume/area/centroid/moments, mean velocity, node normals, minimum edge.
void BM_Geometry(benchmark::State& st) {
  const Backend b = backend_arg(st);
  require_backend(b);
  CapsuleState s = make_state(static_cast<int>(st.range(0)), static_cast<int>(st.range(1)));
  const int nc = s.num_capsules(), nv = s.nodes_per_capsule(), nt = s.triangles_per_capsule();
  const TriMesh& m = s.mesh();
  const std::size_t n = s.x.size();
  std::vector<double> vol(nc), area(nc), cen(3 * nc), mom(6 * nc), U(3 * nc), om(3 * nc), h(nc);
  std::vector<double> u(n, 0.1), nx(n), ny(n), nz(n);
  for (auto _ : st) {
    capsule_shape(b, nc, nv, nt, m.tri.data(), s.x.data(), s.y.data(), s.z.data(), vol.data(), area.data(),
                  cen.data(), mom.data());
    capsule_mean_velocity(b, nc, nv, nt, m.tri.data(), s.x.data(), s.y.data(), s.z.data(), u.data(), s.y.data(),
                          u.data(), U.data(), om.data());
    node_normals(b, nc, nv, m.tri.data(), m.inc_offsets.data(), m.inc_tri.data(), s.x.data(), s.y.data(), s.z.data(),
                 nx.data(), ny.data(), nz.data());
    min_edge_length(b, nc, nv, m.num_edges(), m.edges.data(), s.x.data(), s.y.data(), s.z.data(), h.data());
    benchmark::DoNotOptimize(vol.data());
    benchmark::DoNotOptimize(nx.data());
    benchmark::ClobberMemory();
  }
  st.counters["nodes/s"] = benchmark::Counter(static_cast<double>(n) * static_cast<double>(st.iterations()),
                                              benchmark::Counter::kIsRate);
  st.SetLabel(backend_name(b));
}

void sizes(benchmark::internal::Benchmark* bm) {
  bm->ArgNames({"ncap", "level", "threads"});
  for (int threads : {0, 1}) {
    bm->Args({50, 2, threads});
    bm->Args({800, 2, threads});
    bm->Args({50, 3, threads});
  }
  bm->Unit(benchmark::kMicrosecond)->UseRealTime();  // wall clock: CPU time would count one thread only
}

}  // namespace

BENCHMARK(BM_MembraneForces)->Apply(sizes);
BENCHMARK(BM_MembraneForcesWithBending)->Apply(sizes);
BENCHMARK(BM_Geometry)->Apply(sizes);
