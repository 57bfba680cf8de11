#pragma once
// GgemSolver: Stokes velocity of point forces in the periodic slit 0 <= y <= H (no slip on both walls),
// periodic in x (Lx) and z (Lz), by GGEM (docs/method.md §1.1, §1.2; docs/method.md).
//
//   u(x) = sum_m G_l(x - x_m) f_m / (8 pi mu)            local part: screened Stokeslet, cell list, cutoff r_c
//        + u_g(x)                                         global part: Stokes in the slit forced by sum_m f_m g_m,
//                                                         with u_g = -u_l on the walls (SlitStokesPlan)
//
// Plan/execute: the constructor resolves the grid and makes the global part (ggem_global.hpp: FFT plans, cached
// homogeneous solutions, wall points); apply() may then be called any number of times with new sources and targets.
//
// A target that coincides with a source (|r| < 1e-9/alpha) receives the regular part there: the velocity
// with that source's own free-space Stokeslet removed.
#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "host/solver/ggem_global.hpp"
#include "host/solver/slit_parameters.hpp"
#include "kernels/backend.hpp"

namespace capsflow {

// Wall-clock seconds of the stages of the last apply().
struct GgemTimings {
  double local = 0.0, wall_bc = 0.0, spread = 0.0, global_solve = 0.0, interpolate = 0.0, total = 0.0;
};

// The point-force client of GgemGlobalPart: the local part by the point-force cell list, the global part by the
// shared stages. Chooses no plan of its own (make_slit_solve does, once).
class GgemSolver {
 public:
  GgemSolver(const SlitGeometry& geo, const GgemOptions& opt, Backend backend);
  GgemSolver(const GgemSolver&) = delete;
  GgemSolver& operator=(const GgemSolver&) = delete;

  // Velocities (ux, uy, uz) at nt targets from ns point forces. All arrays are structure-of-arrays.
  // Sources and targets must lie in 0 <= y <= H (checked by the callers that read user input).
  void apply(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx,
             const double* fy, const double* fz, std::size_t nt, const double* tx, const double* ty,
             const double* tz, double* ux, double* uy, double* uz);

  // Wall grid points (x_i, 0 or H, z_k), bottom wall then top, i major: 2 * nx * nz points per array.
  const std::vector<double>& wall_points(int c) const { return global_.wall_points(c); }

  const GgemGrid& grid() const { return global_.grid(); }
  const SlitGeometry& geometry() const { return global_.geometry(); }
  Backend backend() const { return global_.backend(); }
  const GgemTimings& last_timings() const { return timings_; }
  // The global part's stages (tests, and callers that compute the local part themselves).
  GgemGlobalPart& global() { return global_; }
  const GgemGlobalPart& global() const { return global_; }

 private:
  GgemGlobalPart global_;
  GgemTimings timings_;
  // Scratch reused across apply() calls.
  std::vector<double> wall_u_[3];                // local velocity at the wall points
  std::array<std::vector<double>, 4> wrap_buf_;  // x, z of sources and targets wrapped into the box (apply)
};

}  // namespace capsflow
