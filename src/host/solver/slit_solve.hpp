#pragma once
// SlitSolve: the global solve of GGEM behind one interface (docs/method.md §1.2): forcing and wall data in, the grid
// velocity out, all on the side that executes it (host memory for the CPU plan, resident device arrays for the device
// plan). One stage of UAMMD's spread -> solve -> interpolate pipeline, so the callers (GgemGlobalPart, and through it
// GgemSolver and SingleLayerPlan) write the pipeline once instead of once per plan.
//
// make_slit_solve is the only place that chooses between the CPU reference (SlitStokesPlan: FFTW, serial or threads)
// and its device twin (SlitStokesPlanDevice: cuFFT or the host fallback, grids resident). A virtual call per stage is
// nothing against a solve (milliseconds); the kernels below the interface stay plain loops.
#include <memory>

#include "host/solver/slit_parameters.hpp"
#include "kernels/backend.hpp"
#include "kernels/spread_interp.hpp"

namespace capsflow {

class SlitSolve {
 public:
  virtual ~SlitSolve() = default;
  // The grid as spreading and interpolation see it (the y nodes are the plan's own array, resident on the device).
  virtual SlitGridView view() const = 0;
  // Forcing and wall data to zero.
  virtual void zero_forcing_and_walls() = 0;
  // Forcing component c (rho_c / mu on the grid, layout of spread_interp.hpp), to be filled by spreading.
  virtual double* forcing(int c) = 0;
  // Wall data u_g = -u_l on the wall grid points: wall_local_u[c] holds 2 nx nz values, bottom wall first, i major.
  virtual void set_walls_negated(const double* const wall_local_u[3]) = 0;
  virtual void solve() = 0;
  // Velocity component c on the grid after solve().
  virtual const double* velocity(int c) const = 0;
  // Seconds of the last solve(): x-z transforms (and the DCT for the CPU plan's timing), per-mode solves.
  virtual double last_transform_seconds() const = 0;
  virtual double last_mode_seconds() const = 0;
  // "FFTW" for the CPU plan; the device plan's fft_name().
  virtual const char* name() const = 0;
};

// The grid view of a plan with nx x nz Fourier points, Chebyshev degree N and plane positions y (both plans).
inline SlitGridView slit_grid_view(const SlitGeometry& geo, int nx, int nz, int N, const double* y) {
  return SlitGridView{nx, nz, N, geo.Lx / nx, geo.Lz / nz, geo.H, y};
}

// The CPU plan for Backend::Serial and Threads (and for Device in a build without offload, whose kernels refuse it
// with the usual BackendUnavailable); the device plan for Backend::Device in an offload build.
std::unique_ptr<SlitSolve> make_slit_solve(Backend backend, const SlitGeometry& geo, const GgemGrid& grid);

}  // namespace capsflow
