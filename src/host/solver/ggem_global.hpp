#pragma once
// GgemGlobalPart: the global (smooth) part of GGEM as named stages over one SlitSolve (docs/method.md §1.2):
//
//     set_walls(u_l at the wall points)   forcing to zero, wall data u_g = -u_l (the split stays exact on the walls)
//     set_sources(positions)              the clouds' stencils, once per positions
//     spread(point forces)                adds the Gaussian clouds of f / mu to the forcing
//     solve()                             Stokes in the slit on the Fourier x Chebyshev grid
//     interpolate(targets)                adds u_g at the targets
//
// The one owner of the grid-side pieces that both velocity operators share: the SlitSolve chosen once by
// make_slit_solve, the wall grid points and the spreading stencils' scratch. GgemSolver (point forces: `capsflow
// green`, the benches) and SingleLayerPlan (capsule membranes) are its two clients; each computes its own local part,
// including u_l at wall_points(), and calls the stages in this order. Each stage is timed (last_timings()).
//
// On the device backend every stage is a kernel on the plan's resident grids; the point arrays handed in may be
// resident already (their map clauses then copy nothing) or host arrays (copied in, velocities copied back).
#include <cstddef>
#include <memory>
#include <vector>

#include "host/solver/slit_parameters.hpp"
#include "host/solver/slit_solve.hpp"
#include "kernels/backend.hpp"
#include "kernels/spread_interp.hpp"

namespace capsflow {

struct GgemGlobalTimings {
  double sources = 0.0, walls = 0.0, spread = 0.0, solve = 0.0, interpolate = 0.0;
};

class GgemGlobalPart {
 public:
  GgemGlobalPart(const SlitGeometry& geo, const GgemGrid& grid, Backend backend);

  // Wall grid points (x_i, 0 or H, z_k), bottom wall then top, i major: 2 nx nz points per array. The local part's
  // velocity there is what set_walls() takes.
  const std::vector<double>& wall_points(int c) const { return wall_pts_[c]; }
  std::size_t num_wall_points() const { return wall_pts_[0].size(); }

  void set_walls(const double* const wall_local_u[3]);
  // The point forces' positions: their spreading stencils, made once per positions (host backends; the device makes
  // them inside each spread). The arrays must stay unchanged until the next set_sources.
  void set_sources(std::size_t ns, const double* sx, const double* sy, const double* sz);
  // Spreads forces at the positions of the last set_sources; the second form sets the sources first.
  void spread(const double* fx, const double* fy, const double* fz);
  void spread(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx, const double* fy,
              const double* fz);
  void solve();
  void interpolate(std::size_t nt, const double* tx, const double* ty, const double* tz, double* ux, double* uy,
                   double* uz);

  const SlitSolve& slit_solve() const { return *solve_; }
  // The solve itself, for a second operator on the same grid (DoubleLayerPlan fills its forcing and walls directly).
  SlitSolve& slit_solve_mutable() { return *solve_; }
  // The stencils of the last set_sources and their count (host backends; the double layer's clouds reuse them).
  const SpreadWorkspace& spread_workspace() const { return spread_ws_; }
  std::size_t num_sources() const { return ns_; }
  const GgemGrid& grid() const { return grid_; }
  const SlitGeometry& geometry() const { return geo_; }
  Backend backend() const { return backend_; }
  const GgemGlobalTimings& last_timings() const { return timings_; }

 private:
  SlitGeometry geo_;
  GgemGrid grid_;
  Backend backend_;
  std::unique_ptr<SlitSolve> solve_;
  SlitGridView view_;
  std::vector<double> wall_pts_[3];
  SpreadWorkspace spread_ws_;
  std::size_t ns_ = 0;
  const double* src_[3] = {nullptr, nullptr, nullptr};
  GgemGlobalTimings timings_;
};

}  // namespace capsflow
