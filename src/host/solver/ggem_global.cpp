// The implementation of ggem_global.hpp: GgemGlobalPart, GGEM's global part as named stages over one SlitSolve.
#include "host/solver/ggem_global.hpp"

#include <chrono>

#include "host/base/stopwatch.hpp"

namespace capsflow {

GgemGlobalPart::GgemGlobalPart(const SlitGeometry& geo, const GgemGrid& grid, Backend backend)
    : geo_(geo), grid_(grid), backend_(backend), solve_(make_slit_solve(backend, geo, grid)), view_(solve_->view()) {
  const int nx = grid_.nx, nz = grid_.nz;
  const std::size_t nw = static_cast<std::size_t>(nx) * nz;
  for (auto& w : wall_pts_) w.resize(2 * nw);
  for (int side = 0; side < 2; ++side)
    for (int i = 0; i < nx; ++i)
      for (int k = 0; k < nz; ++k) {
        const std::size_t p = side * nw + static_cast<std::size_t>(i) * nz + k;
        wall_pts_[0][p] = i * grid_.hx;
        wall_pts_[1][p] = side == 0 ? 0.0 : geo_.H;
        wall_pts_[2][p] = k * grid_.hz;
      }
}

void GgemGlobalPart::set_walls(const double* const wall_local_u[3]) {
  const auto t0 = std::chrono::steady_clock::now();
  solve_->zero_forcing_and_walls();
  solve_->set_walls_negated(wall_local_u);
  timings_.walls = seconds_since(t0);
}

void GgemGlobalPart::set_sources(std::size_t ns, const double* sx, const double* sy, const double* sz) {
  const auto t0 = std::chrono::steady_clock::now();
  prepare_spread(backend_, view_, grid_.alpha, grid_.spread_cutoff, ns, sx, sy, sz, spread_ws_);
  ns_ = ns;
  src_[0] = sx, src_[1] = sy, src_[2] = sz;
  timings_.sources = seconds_since(t0);
}

void GgemGlobalPart::spread(const double* fx, const double* fy, const double* fz) {
  const auto t0 = std::chrono::steady_clock::now();
  spread_prepared(backend_, view_, grid_.alpha, grid_.spread_cutoff, ns_, src_[0], src_[1], src_[2], fx, fy, fz,
                  solve_->forcing(0), solve_->forcing(1), solve_->forcing(2), spread_ws_, geo_.viscosity);
  timings_.spread = seconds_since(t0);
}

void GgemGlobalPart::spread(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx,
                            const double* fy, const double* fz) {
  set_sources(ns, sx, sy, sz);
  spread(fx, fy, fz);
}

void GgemGlobalPart::solve() {
  const auto t0 = std::chrono::steady_clock::now();
  solve_->solve();
  timings_.solve = seconds_since(t0);
}

void GgemGlobalPart::interpolate(std::size_t nt, const double* tx, const double* ty, const double* tz, double* ux,
                                 double* uy, double* uz) {
  const auto t0 = std::chrono::steady_clock::now();
  interpolate_velocity(backend_, view_, solve_->velocity(0), solve_->velocity(1), solve_->velocity(2), nt, tx, ty, tz,
                       ux, uy, uz);
  timings_.interpolate = seconds_since(t0);
}

}  // namespace capsflow
