#pragma once
// Spreading of GGEM force clouds onto the Fourier x Chebyshev grid, and interpolation of grid velocities back
// to points (docs/method.md §1.2; docs/method.md "Global part").
//
// Grid layout: value (j, i, k) at index (j * nx + i) * nz + k, y_j Chebyshev-Gauss-Lobatto (increasing),
// x_i = i hx, z_k = k hz.
//
// Spreading: rho(x) = sum_m f_m g(x - x_m) at grid points within the cutoff sphere
// of each source, inside 0 <= y <= H only (the cloud outside the slit is dropped: the split stays exact, 4.3).
// serial: per source; threads: per y-plane, each plane owned by one thread, sources in the same order as the
// serial loop, so both give identical sums; device: per source with atomics.
#include <cstddef>
#include <vector>

#include "kernels/backend.hpp"

namespace capsflow {

struct SlitGridView {
  int nx = 0, nz = 0, N = 0;  // N: Chebyshev degree (N + 1 planes)
  double hx = 0.0, hz = 0.0, H = 0.0;
  const double* y = nullptr;  // N + 1 plane positions
};

// Per-source stencil data of the separable Gaussian (exp(-a^2 r^2) = ex * ey * ez): it depends on the source
// positions only, so prepare_spread makes it once per set of positions and spread_prepared deposits any number of
// force sets on it (the device makes its stencils on the device inside each spread instead).
struct SpreadWorkspace {
  int width = 0;  // max stencil points per direction
  std::vector<int> ix0, nxs, iz0, nzs, j0, j1;
  std::vector<double> ex, qx, ez, qz;
  std::vector<int> plane_start, plane_src;  // CSR: the sources touching each plane, ascending (serial and threads)
  // What the stencils were prepared for (spread_prepared refuses another count, backend, alpha or cutoff).
  std::size_t prepared_sources = 0;
  Backend prepared_backend = Backend::Serial;
  double prepared_alpha = 0.0, prepared_cutoff = 0.0;
};

// Adds the force clouds of ns sources, the forces divided by force_divisor (the viscosity mu for the global forcing
// f / mu; 1 leaves them as they are, bit for bit), to rho_x, rho_y, rho_z. Device: the sources, forces, plane
// positions and grids may be resident on the device (their map clauses then copy nothing; otherwise they are copied
// in and the grids back); the stencils are prepared there too.
void spread_forces(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                   const double* sx, const double* sy, const double* sz, const double* fx, const double* fy,
                   const double* fz, double* rho_x, double* rho_y, double* rho_z, SpreadWorkspace& ws,
                   double force_divisor = 1.0);

// The two halves of spread_forces: the stencils of ns sources (positions only), then the deposit of their forces.
// spread_prepared must see the positions prepare_spread saw (the caller's contract; the count, backend, alpha and
// cutoff are checked: std::logic_error). Same bits as spread_forces.
void prepare_spread(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                    const double* sx, const double* sy, const double* sz, SpreadWorkspace& ws);
void spread_prepared(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                     const double* sx, const double* sy, const double* sz, const double* fx, const double* fy,
                     const double* fz, double* rho_x, double* rho_y, double* rho_z, SpreadWorkspace& ws,
                     double force_divisor = 1.0);

// Tensor-product 9-point (degree 8) Lagrange interpolation of three grid fields at nt points; adds to (ux, uy, uz).
// Device: map clauses only (no-ops for arrays already resident, such as SlitStokesPlanDevice's velocity and nodes).
void interpolate_velocity(Backend backend, const SlitGridView& g, const double* gx, const double* gy,
                          const double* gz, std::size_t nt, const double* tx, const double* ty, const double* tz,
                          double* ux, double* uy, double* uz);

}  // namespace capsflow
