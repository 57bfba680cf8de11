// The implementation of ggem_solver.hpp: GgemSolver, the Stokes velocity of point forces in the slit by GGEM.
#include "host/solver/ggem_solver.hpp"

#include <chrono>
#include <cmath>

#include "host/base/stopwatch.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/local_sum.hpp"
#include "kernels/spread_interp.hpp"

namespace capsflow {

GgemSolver::GgemSolver(const SlitGeometry& geo, const GgemOptions& opt, Backend backend)
    : global_(geo, resolve_ggem_grid(geo, opt), backend) {}

void GgemSolver::apply(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx,
                       const double* fy, const double* fz, std::size_t nt, const double* tx, const double* ty,
                       const double* tz, double* ux, double* uy, double* uz) {
  // x and z may take any value (periodic): wrap them into [0, L) first, exactly (fmod), so that the kernels' cell and
  // grid indices stay in range; a coordinate of 1e9 would otherwise overflow an int index (zero or NaN velocities).
  auto wrapped = [](std::size_t n, const double* v, double L, std::vector<double>& buf) -> const double* {
    std::size_t i = 0;
    while (i < n && v[i] >= 0.0 && v[i] < L) ++i;
    if (i == n) return v;
    buf.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      double w = std::fmod(v[k], L);
      if (w < 0.0) w += L;
      buf[k] = w < L ? w : 0.0;  // -1e-300 + L rounds to L
    }
    return buf.data();
  };
  const SlitGeometry& geo = global_.geometry();
  const GgemGrid& grid = global_.grid();
  const Backend backend = global_.backend();
  sx = wrapped(ns, sx, geo.Lx, wrap_buf_[0]);
  sz = wrapped(ns, sz, geo.Lz, wrap_buf_[1]);
  tx = wrapped(nt, tx, geo.Lx, wrap_buf_[2]);
  tz = wrapped(nt, tz, geo.Lz, wrap_buf_[3]);
  const auto t_start = std::chrono::steady_clock::now();
  const double scale = 1.0 / (8.0 * kPi * geo.viscosity);
  const double alpha = grid.alpha, rc = grid.cutoff;

  // Local part at the targets.
  auto t0 = std::chrono::steady_clock::now();
  PointCellList cells;
  build_point_cell_list(cells, geo.Lx, geo.H, geo.Lz, rc, ns, sx, sy, sz, fx, fy, fz);
  for (std::size_t i = 0; i < nt; ++i) ux[i] = uy[i] = uz[i] = 0.0;
  local_velocity_point_forces(backend, cells, alpha, rc, scale, nt, tx, ty, tz, ux, uy, uz);
  timings_.local = seconds_since(t0);

  // The local velocity at the wall grid points: the global part's wall data is its negative (6.3).
  t0 = std::chrono::steady_clock::now();
  const std::size_t nwall = global_.num_wall_points();
  for (auto& w : wall_u_) w.assign(nwall, 0.0);
  local_velocity_point_forces(backend, cells, alpha, rc, scale, nwall, global_.wall_points(0).data(),
                              global_.wall_points(1).data(), global_.wall_points(2).data(), wall_u_[0].data(),
                              wall_u_[1].data(), wall_u_[2].data());
  timings_.wall_bc = seconds_since(t0);

  const double* wall_local[3] = {wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data()};
  global_.set_walls(wall_local);
  global_.spread(ns, sx, sy, sz, fx, fy, fz);
  global_.solve();
  global_.interpolate(nt, tx, ty, tz, ux, uy, uz);
  const GgemGlobalTimings& g = global_.last_timings();
  timings_.spread = g.walls + g.spread;
  timings_.global_solve = g.solve;
  timings_.interpolate = g.interpolate;
  timings_.total = seconds_since(t_start);
}

}  // namespace capsflow
