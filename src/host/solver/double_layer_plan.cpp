// The implementation of double_layer_plan.hpp: DoubleLayerPlan, the membranes' double layer in the slit by GGEM.
#include "host/solver/double_layer_plan.hpp"

#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "host/base/stopwatch.hpp"
#include "kernels/double_layer_spread.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/local_double_layer.hpp"

namespace capsflow {
namespace {

// The capsules' surface as the local layer sums read it (host positions).
SurfaceView surface_view(const CapsuleState& s) {
  return {s.num_capsules(), s.nodes_per_capsule(), s.triangles_per_capsule(), s.mesh().tri.data(), s.x.data(),
          s.y.data(), s.z.data()};
}

}  // namespace

DoubleLayerPlan::DoubleLayerPlan(SingleLayerPlan& single_layer) : sl_(single_layer), scale_(1.0 / (8.0 * kPi)) {
  const GgemGrid& g = sl_.grid();
  // The Poisson solve is host code: on the device backend it runs multithreaded on the host.
  const Backend pb = sl_.backend() == Backend::Device ? Backend::Threads : sl_.backend();
  poisson_ = std::make_unique<SlitPoissonGradient>(sl_.geometry(), g.nx, g.nz, g.ny, pb);
  for (auto& w : wall_) w.resize(sl_.global_part().num_wall_points());
}

void DoubleLayerPlan::set_geometry() {
  const auto t0 = std::chrono::steady_clock::now();
  const CapsuleState& s = sl_.state();
  const std::size_t n = static_cast<std::size_t>(s.num_nodes());
  const int ncap = s.num_capsules(), nv = s.nodes_per_capsule(), ntri = s.triangles_per_capsule();
  const int* tri = s.mesh().tri.data();
  for (int c = 0; c < 3; ++c) {
    area_[c].assign(n, 0.0);
    unit_[c].assign(n, 0.0);
    for (auto* v : {&pq_[c], &kd_[c], &tmp_[c]}) v->assign(n, 0.0);
  }
  if (node_ids_.size() != n) {
    node_ids_.resize(n);
    std::iota(node_ids_.begin(), node_ids_.end(), 0);
  }
  for (int k = 0; k < ncap; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    for (int t = 0; t < ntri; ++t) {
      const std::size_t i0 = o + tri[3 * t], i1 = o + tri[3 * t + 1], i2 = o + tri[3 * t + 2];
      const double a[3] = {s.x[i1] - s.x[i0], s.y[i1] - s.y[i0], s.z[i1] - s.z[i0]};
      const double b[3] = {s.x[i2] - s.x[i0], s.y[i2] - s.y[i0], s.z[i2] - s.z[i0]};
      // (1/3) of A_e n_e = (1/6) a x b to each vertex
      const double N[3] = {(a[1] * b[2] - a[2] * b[1]) / 6.0, (a[2] * b[0] - a[0] * b[2]) / 6.0,
                           (a[0] * b[1] - a[1] * b[0]) / 6.0};
      for (std::size_t i : {i0, i1, i2})
        for (int c = 0; c < 3; ++c) area_[c][i] += N[c];
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double len = std::sqrt(area_[0][i] * area_[0][i] + area_[1][i] * area_[1][i] + area_[2][i] * area_[2][i]);
    for (int c = 0; c < 3; ++c) unit_[c][i] = len > 0.0 ? area_[c][i] / len : 0.0;
  }
  have_geometry_ = true;
  // C_i = K_d[e_d](x_i): a constant density has zero net flux through each closed capsule (sum_m a_m = 0), so P
  // leaves it as it is. The local part of the three in one traversal; the global part per density.
  cmat_.assign(9 * n, 0.0);
  const GgemGrid& g = sl_.grid();
  const Backend b = sl_.backend();
  // The host traversal's element pack (geometry once here; densities per application). Never on the device.
  const bool packed = b != Backend::Device && element_pack_used();
  if (packed) pack_element_geometry(b, sl_.cell_list(), nv, ntri, tri, s.x.data(), s.y.data(), s.z.data(), pack_);
  const SurfaceView surface = surface_view(s);
  local_double_layer_matrix(b, sl_.cell_list(), pack_, LocalSplit{g.alpha, g.cutoff, scale_}, surface, sl_.orders(),
                            TargetView{n, s.x.data(), s.y.data(), s.z.data(), node_ids_.data()}, cmat_.data());
  // The wall points' local part of the three unit densities: one matrix traversal on the host (the device's matrix
  // pass takes membrane nodes only: there, one sum per density).
  GgemGlobalPart& gp = sl_.global_part_mutable();
  const std::size_t nw = gp.num_wall_points();
  if (packed) {
    wall_matrix_.assign(9 * nw, 0.0);
    local_double_layer_matrix(
        b, sl_.cell_list(), pack_, LocalSplit{g.alpha, g.cutoff, scale_}, surface, sl_.orders(),
        TargetView{nw, gp.wall_points(0).data(), gp.wall_points(1).data(), gp.wall_points(2).data(), nullptr},
        wall_matrix_.data());
  }
  std::vector<double> one(n, 1.0), zero(n, 0.0);
  for (int d = 0; d < 3; ++d) {
    const NodeField e{d == 0 ? one : zero, d == 1 ? one : zero, d == 2 ? one : zero};
    if (packed) {
      for (int c = 0; c < 3; ++c)
        for (std::size_t p = 0; p < nw; ++p) wall_[c][p] = wall_matrix_[9 * p + 3 * c + d];
    } else {
      local_walls(e);
    }
    for (auto& k : kd_) std::fill(k.begin(), k.end(), 0.0);
    global_from_walls(e, n, s.x.data(), s.y.data(), s.z.data(), kd_[0].data(), kd_[1].data(), kd_[2].data());
    for (std::size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) cmat_[9 * i + 3 * c + d] += kd_[c][i];
  }
  timings_.set_geometry = seconds_since(t0);
}

void DoubleLayerPlan::deflate(NodeField q) {
  const CapsuleState& s = sl_.state();
  const int ncap = s.num_capsules(), nv = s.nodes_per_capsule();
  for (int k = 0; k < ncap; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * nv;
    double flux = 0.0, norm = 0.0;
    for (std::size_t i = o; i < o + nv; ++i) {
      flux += q.x[i] * area_[0][i] + q.y[i] * area_[1][i] + q.z[i] * area_[2][i];
      norm += unit_[0][i] * area_[0][i] + unit_[1][i] * area_[1][i] + unit_[2][i] * area_[2][i];
    }
    const double c = norm > 0.0 ? flux / norm : 0.0;
    for (std::size_t i = o; i < o + nv; ++i) {
      pq_[0][i] = q.x[i] - c * unit_[0][i];
      pq_[1][i] = q.y[i] - c * unit_[1][i];
      pq_[2][i] = q.z[i] - c * unit_[2][i];
    }
  }
}

void DoubleLayerPlan::apply_deflated(NodeField q, std::size_t nt, const double* tx, const double* ty,
                                     const double* tz, const int* target_node, double* kx, double* ky, double* kz) {
  if (!have_geometry_) throw std::logic_error("DoubleLayerPlan::apply before set_geometry");
  deflate(q);
  apply_discrete(NodeField{pq_[0], pq_[1], pq_[2]}, nt, tx, ty, tz, target_node, kx, ky, kz);
}

void DoubleLayerPlan::apply_discrete(NodeField q, std::size_t nt, const double* tx, const double* ty,
                                     const double* tz, const int* target_node, double* kx, double* ky, double* kz) {
  if (!have_geometry_) throw std::logic_error("DoubleLayerPlan::apply before set_geometry");
  const auto t0 = std::chrono::steady_clock::now();
  const CapsuleState& s = sl_.state();
  const GgemGrid& g = sl_.grid();
  for (std::size_t p = 0; p < nt; ++p) kx[p] = ky[p] = kz[p] = 0.0;
  if (sl_.backend() != Backend::Device && element_pack_used())
    pack_element_density(sl_.backend(), sl_.cell_list(), q.x.data(), q.y.data(), q.z.data(), pack_);
  local_double_layer_velocity(sl_.backend(), sl_.cell_list(), pack_, LocalSplit{g.alpha, g.cutoff, scale_},
                              surface_view(s), Vec3In{q.x.data(), q.y.data(), q.z.data()}, sl_.orders(),
                              TargetView{nt, tx, ty, tz, target_node}, Vec3Out{kx, ky, kz});
  timings_.local_nodes = seconds_since(t0);
  local_walls(q);
  global_from_walls(q, nt, tx, ty, tz, kx, ky, kz);
  timings_.apply = seconds_since(t0);
}

void DoubleLayerPlan::local_walls(NodeField q) {
  const auto t1 = std::chrono::steady_clock::now();
  const CapsuleState& s = sl_.state();
  const GgemGrid& g = sl_.grid();
  // The local part at the wall grid points: the wall data that makes K vanish on the walls.
  GgemGlobalPart& gp = sl_.global_part_mutable();
  const std::size_t nw = gp.num_wall_points();
  for (auto& w : wall_) std::fill(w.begin(), w.end(), 0.0);
  local_double_layer_velocity(
      sl_.backend(), sl_.cell_list(), pack_, LocalSplit{g.alpha, g.cutoff, scale_}, surface_view(s),
      Vec3In{q.x.data(), q.y.data(), q.z.data()}, sl_.orders(),
      TargetView{nw, gp.wall_points(0).data(), gp.wall_points(1).data(), gp.wall_points(2).data(), nullptr},
      Vec3Out{wall_[0].data(), wall_[1].data(), wall_[2].data()});
  timings_.local_walls = seconds_since(t1);
}

void DoubleLayerPlan::global_from_walls(NodeField q, std::size_t nt, const double* tx, const double* ty,
                                        const double* tz, double* kx, double* ky, double* kz) {
  const auto t2 = std::chrono::steady_clock::now();
  const CapsuleState& s = sl_.state();
  const Backend b = sl_.backend();
  const GgemGrid& g = sl_.grid();
  const std::size_t n = static_cast<std::size_t>(s.num_nodes());
  GgemGlobalPart& gp = sl_.global_part_mutable();
  // Dipole clouds and their sources, the potential flow, then Stokes with the wall data. On the device the forcing
  // and the grid velocity are the single layer's resident arrays; the Poisson source comes back for the host solve.
  SlitSolve& solve = gp.slit_solve_mutable();
  const SlitGridView view = solve.view();
  solve.zero_forcing_and_walls();
  poisson_->zero_source();
  // Host backends: the single layer's stencils of these nodes (its set_geometry prepared them); the device spreads
  // per call.
  if (b != Backend::Device && gp.num_sources() == n)
    spread_double_layer_prepared(b, view, g.alpha, g.spread_cutoff, n, s.x.data(), s.y.data(), s.z.data(), q.x.data(),
                                 q.y.data(), q.z.data(), area_[0].data(), area_[1].data(), area_[2].data(),
                                 solve.forcing(0), solve.forcing(1), solve.forcing(2), poisson_->source(),
                                 gp.spread_workspace());
  else
    spread_double_layer(b, view, g.alpha, g.spread_cutoff, n, s.x.data(), s.y.data(), s.z.data(), q.x.data(),
                        q.y.data(), q.z.data(), area_[0].data(), area_[1].data(), area_[2].data(), solve.forcing(0),
                        solve.forcing(1), solve.forcing(2), poisson_->source());
  poisson_->solve();
  // Wall grid points are the grid's planes j = 0 and j = N ([i][k] order, bottom then top): add grad(phi) there.
  const std::size_t plane = static_cast<std::size_t>(view.nx) * view.nz;
  for (int c = 0; c < 3; ++c) {
    const double* gr = poisson_->gradient(c);
    for (std::size_t p = 0; p < plane; ++p) {
      wall_[c][p] += gr[p];
      wall_[c][plane + p] += gr[static_cast<std::size_t>(view.N) * plane + p];
    }
  }
  const double* wl[3] = {wall_[0].data(), wall_[1].data(), wall_[2].data()};
  solve.set_walls_negated(wl);
  solve.solve();
  interpolate_velocity(b, view, solve.velocity(0), solve.velocity(1), solve.velocity(2), nt, tx, ty, tz, kx, ky, kz);
  interpolate_velocity(b, view, poisson_->gradient(0), poisson_->gradient(1), poisson_->gradient(2), nt, tx, ty, tz,
                       kx, ky, kz);
  timings_.global = seconds_since(t2);
}

void DoubleLayerPlan::apply(NodeField q, NodeFieldOut k) {
  if (!have_geometry_) throw std::logic_error("DoubleLayerPlan::apply before set_geometry");
  const CapsuleState& s = sl_.state();
  const std::size_t n = static_cast<std::size_t>(s.num_nodes());
  deflate(q);
  k.x.resize(n);
  k.y.resize(n);
  k.z.resize(n);
  apply_discrete(NodeField{pq_[0], pq_[1], pq_[2]}, n, s.x.data(), s.y.data(), s.z.data(), node_ids_.data(),
                 k.x.data(), k.y.data(), k.z.data());
  for (std::size_t i = 0; i < n; ++i) {
    const double p[3] = {pq_[0][i], pq_[1][i], pq_[2][i]};
    const double* C = &cmat_[9 * i];
    k.x[i] -= C[0] * p[0] + C[1] * p[1] + C[2] * p[2] + 0.5 * p[0];
    k.y[i] -= C[3] * p[0] + C[4] * p[1] + C[5] * p[2] + 0.5 * p[1];
    k.z[i] -= C[6] * p[0] + C[7] * p[1] + C[8] * p[2] + 0.5 * p[2];
  }
}

}  // namespace capsflow
