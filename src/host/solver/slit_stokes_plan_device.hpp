#pragma once
// SlitStokesPlanDevice: the device twin of SlitStokesPlan (which stays the CPU reference; HOOMD's X.cc / XGPU.cc
// pairs). Same problem, grid, layout and life cycle (slit_stokes_plan.hpp), but every grid array lives on the OpenMP
// default device for the plan's lifetime: forcing, wall data, spectra (and a coefficient work array of their size),
// velocity, the y nodes, the cached homogeneous
// solutions and influence matrices, and the DCT-I matrix are mapped once (DeviceMirror) when the plan is made, so a
// kernel that names them in a map clause finds them present and copies nothing. zero_forcing_and_walls(),
// set_walls_negated() and solve() run entirely on the device and leave the velocity there; push_*() / pull_*() copy
// for host callers and tests.
//
//   per y-plane FFTs in x-z: cuFFT (batched plans on the device addresses of the mapped arrays) when target regions
//       run on a GPU; FFTW on the same (host) arrays when they run on the OpenMP host fallback (tests without a GPU).
//       An offload build without cuFFT refuses to make a plan for a GPU (BackendUnavailable), never running the FFTs
//       on the host behind the caller's back. The choice is made once, in the constructor (fft_name()).
//   DCT-I along y (matrix products, one thread per coefficient) and the per-mode tau solves (one thread per mode):
//       three target regions (kernels/mode_solve_device).
//   homogeneous solutions: slit_homogeneous_solutions on the host (the CPU reference's numbers), pushed once.
//
// Usage (device arrays stay put between the steps):
//     SlitStokesPlanDevice plan(geo, grid);
//     plan.zero_forcing_and_walls();
//     spread_forces(Backend::Device, view, ..., plan.forcing(0), plan.forcing(1), plan.forcing(2), ws, mu);
//     plan.set_walls_negated(wall_local_u);
//     plan.solve();
//     interpolate_velocity(Backend::Device, view, plan.velocity(0), plan.velocity(1), plan.velocity(2), ...);
// The accessors return host addresses: the keys under which the device copies are mapped. On a GPU their host
// contents are stale until pull_velocity() / after push_forcing() and so on.
#include <cstddef>
#include <memory>
#include <vector>

#include "host/solver/slit_parameters.hpp"
#include "host/solver/slit_solve.hpp"
#include "kernels/device_mirror.hpp"

namespace capsflow {

class SlitStokesPlanDevice final : public SlitSolve {
 public:
  // Throws std::logic_error in a build without CAPSFLOW_OFFLOAD, BackendUnavailable when target regions run on a GPU
  // and the build has no cuFFT, libcufft cannot be loaded, or the CUDA runtime cannot see the mapped arrays.
  SlitStokesPlanDevice(const SlitGeometry& geo, const GgemGrid& grid);
  ~SlitStokesPlanDevice();
  SlitStokesPlanDevice(const SlitStokesPlanDevice&) = delete;
  SlitStokesPlanDevice& operator=(const SlitStokesPlanDevice&) = delete;

  int nx() const { return nx_; }
  int ny() const { return N_; }  // Chebyshev degree; N + 1 planes
  int nz() const { return nz_; }
  std::size_t plane_size() const { return plane_; }
  std::size_t grid_size() const { return plane_ * static_cast<std::size_t>(N_ + 1); }
  const std::vector<double>& y_nodes() const { return y_; }  // resident too (interpolation's map clause)

  SlitGridView view() const override;
  double* forcing(int c) override { return force_ + c * grid_size(); }
  double* wall(int side, int c) { return wall_ + (side * 3 + c) * plane_; }
  const double* velocity(int c) const override { return vel_ + c * grid_size(); }
  double* velocity_mutable(int c) { return vel_ + c * grid_size(); }

  // On the device: forcing and wall data to zero.
  void zero_forcing_and_walls() override;
  // On the device: wall(side, c)[p] = -wall_local_u[c][side * nx * nz + p] (u_g = -u_l on the walls, 6.3). The
  // three arrays (2 nx nz each) may be resident already (then nothing is copied) or host arrays (copied in).
  void set_walls_negated(const double* const wall_local_u[3]) override;
  // On the device: the global solve; the velocity stays there.
  void solve() override;

  // Host <-> device copies of whole blocks (all three components / all six wall maps).
  void push_forcing();
  void push_walls();
  void pull_forcing();
  void pull_velocity();

  // "cuFFT" (target regions on a GPU) or "FFTW, host fallback" (no GPU: the OpenMP runtime's host fallback).
  const char* fft_name() const;
  const char* name() const override { return fft_name(); }
  bool host_fallback() const { return host_fallback_; }
  // Arrays mapped for the plan's lifetime (for tests: forcing, velocity, spectra, coefficients, walls, wall spectra,
  // y nodes, homogeneous phi, psi, influence matrices, DCT matrix).
  std::size_t resident_arrays() const { return mirror_.attached_count(); }

  double last_transform_seconds() const override { return t_transform_; }
  double last_mode_seconds() const override { return t_modes_; }

 private:
  struct Fft;
  void setup();              // the constructor's work; on a throw the constructor releases what it made
  void release() noexcept;   // frees and unmaps everything (destructor, failed constructor)
  void fft_forward();
  void fft_inverse();

  SlitGeometry geo_;
  int nx_, nz_, N_, nzh_;
  std::size_t plane_, cplane_;
  bool host_fallback_ = true;
  DeviceMirror mirror_;
  std::vector<double> y_, hom_phi_, hom_psi_, hom_minv_, dct_;
  // Host blocks (FFTW-aligned), each mapped once: 3 fields of forcing / velocity / spectra (complex interleaved),
  // 6 wall maps (side * 3 + component) and their spectra.
  double* force_ = nullptr;
  double* vel_ = nullptr;
  double* spec_ = nullptr;
  double* coef_ = nullptr;     // Chebyshev coefficients between the DCT kernels (device work array)
  double* wall_ = nullptr;
  double* wspec_ = nullptr;
  double* scratch_ = nullptr;  // device memory (omp_target_alloc): per-mode work of one launch
  int scratch_device_ = 0;
  std::size_t chunk_ = 0;      // modes per launch
  std::unique_ptr<Fft> fft_;
  double t_transform_ = 0.0, t_modes_ = 0.0;
};

}  // namespace capsflow
