#pragma once
// GgemSolver: Stokes velocity of point forces in the periodic slit 0 <= y <= H (no slip on both walls),
// periodic in x (Lx) and z (Lz), by GGEM (method-spec sections 4 and 6; docs/method.md).
//
//   u(x) = sum_m G_l(x - x_m) f_m / (8 pi mu)            local part: screened Stokeslet, cell list, cutoff r_c
//        + u_g(x)                                         global part: Stokes in the slit forced by sum_m f_m g_m,
//                                                         with u_g = -u_l on the walls (SlitStokesPlan)
//
// Plan/execute: the constructor resolves the grid, plans the FFTs and caches the homogeneous solutions;
// apply() may then be called any number of times with new sources and targets.
//
// A target that coincides with a source (|r| < 1e-9/alpha) receives the regular part there: the velocity
// with that source's own free-space Stokeslet removed.
#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "kernels/backend.hpp"
#include "kernels/spread_interp.hpp"

namespace capsflow {

struct SlitGeometry {
  double H = 0.0;          // wall-to-wall distance (walls at y = 0 and y = H)
  double Lx = 0.0;         // period in x
  double Lz = 0.0;         // period in z
  double viscosity = 1.0;  // mu
};

struct GgemOptions {
  double alpha = 4.0;      // splitting parameter (1/length)
  double alpha_hm = 0.5;   // alpha * h_m: grid spacing h_m = alpha_hm / alpha in x and z
  int nx = 0;              // Fourier points in x (0: from h_m, rounded up to a fast FFT size)
  int nz = 0;              // Fourier points in z (0: likewise)
  int ny = 0;              // Chebyshev degree N (N + 1 Gauss-Lobatto points); 0: from chebyshev_rule
  double cutoff = 0.0;     // local cutoff r_c of the G_l sum (0: default_cutoff(alpha)); not the clouds' truncation
  // How N follows when ny = 0 (decision D9): "midchannel" (default) N >= pi alpha H, so the mid-channel
  // spacing is at most h_m; "mean" N >= H / h_m, equal mean spacing in all directions (the paper's choice).
  std::string chebyshev_rule = "midchannel";
};

// The local cutoff when none is given: 3.5 / alpha, where G_l is 2e-5 of the Stokeslet; the sum over the sources
// beyond it moves the velocity by < 1e-6 of its scale (docs/method.md, figures in docs/performance.md section 6).
inline double default_cutoff(double alpha) { return 3.5 / alpha; }

// The truncation radius of the Gaussian clouds (spreading), independent of the local cutoff: 4 / alpha, where the
// cloud is 6e-7 of its peak. Truncating the clouds at 3.5 / alpha costs accuracy (docs/performance.md section 6).
inline double default_spread_cutoff(double alpha) { return 4.0 / alpha; }

// The grid a GgemOptions resolves to for a geometry.
struct GgemGrid {
  int nx = 0, nz = 0;  // Fourier points
  int ny = 0;          // Chebyshev degree N; points j = 0..N at y_j = (H/2)(1 - cos(pi j / N)) (y_0 = 0)
  double hx = 0.0, hz = 0.0;
  double alpha = 0.0;
  double cutoff = 0.0;         // local cutoff r_c (the G_l sums, cell lists, box checks)
  double spread_cutoff = 0.0;  // truncation radius of the Gaussian clouds (default_spread_cutoff(alpha))
};

// Resolves and validates (throws InputError naming the [domain]/[ggem] key and what was expected).
GgemGrid resolve_ggem_grid(const SlitGeometry& geo, const GgemOptions& opt);

// The most grid points along one direction (nx, nz, or the Chebyshev N). Far beyond any grid that fits in memory
// (the memory check refuses those), low enough that the sizes and their products stay exact in int / size_t.
inline constexpr double kMaxGridPointsPerDirection = 1 << 20;

// Empty when the grid that `geo` and `opt` ask for has at most kMaxGridPointsPerDirection points along each
// direction; otherwise "<key>: <why>, expected ..." naming the key to change ("[ggem] alpha", "[domain] Lx", ...).
// resolve_ggem_grid throws it as an InputError; parse_config prefixes the file name.
std::string ggem_grid_size_error(const SlitGeometry& geo, const GgemOptions& opt);

// Wall-clock seconds of the stages of the last apply().
struct GgemTimings {
  double local = 0.0, wall_bc = 0.0, spread = 0.0, global_solve = 0.0, interpolate = 0.0, total = 0.0;
};

class SlitStokesPlan;
class SlitStokesPlanDevice;

class GgemSolver {
 public:
  GgemSolver(const SlitGeometry& geo, const GgemOptions& opt, Backend backend);
  ~GgemSolver();
  GgemSolver(const GgemSolver&) = delete;
  GgemSolver& operator=(const GgemSolver&) = delete;

  // Velocities (ux, uy, uz) at nt targets from ns point forces. All arrays are structure-of-arrays.
  // Sources and targets must lie in 0 <= y <= H (checked by the callers that read user input).
  void apply(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx,
             const double* fy, const double* fz, std::size_t nt, const double* tx, const double* ty,
             const double* tz, double* ux, double* uy, double* uz);

  // The global part alone, for callers that compute the local part themselves (capsule membranes, where u_l comes
  // from element integrals): adds u_g at the targets, forced by the clouds of the point forces, with wall data
  // u_g = -wall_local_u on the wall grid points (wall_points(); bottom wall first). Timings: spread, global_solve,
  // interpolate.
  void apply_global(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx,
                     const double* fy, const double* fz, const double* const wall_local_u[3], std::size_t nt,
                     const double* tx, const double* ty, const double* tz, double* ux, double* uy, double* uz);

  // Wall grid points (x_i, 0 or H, z_k), bottom wall then top, i major: 2 * nx * nz points per array.
  const std::vector<double>& wall_points(int c) const { return wall_pts_[c]; }

  const GgemGrid& grid() const { return grid_; }
  const SlitGeometry& geometry() const { return geo_; }
  Backend backend() const { return backend_; }
  const GgemTimings& last_timings() const { return timings_; }
  // The CPU global solve (serial, threads; and device in a build without offload, whose kernels refuse it).
  SlitStokesPlan& plan() { return *plan_; }
  // The device global solve (Backend::Device in an offload build), else nullptr.
  SlitStokesPlanDevice* device_plan() { return device_plan_.get(); }

 private:
  SlitGeometry geo_;
  GgemGrid grid_;
  Backend backend_;
  std::unique_ptr<SlitStokesPlan> plan_;
  std::unique_ptr<SlitStokesPlanDevice> device_plan_;
  GgemTimings timings_;
  // Scratch reused across apply() calls.
  std::vector<double> wall_pts_[3];  // wall grid points, bottom then top
  std::vector<double> wall_u_[3];    // local velocity there
  std::array<std::vector<double>, 4> wrap_buf_;  // x, z of sources and targets wrapped into the box (apply)
  SpreadWorkspace spread_ws_;
};

}  // namespace capsflow
