#pragma once
// SlitStokesPlan: the global (smooth) part of GGEM. Solves
//     mu lap u - grad p = -rho,   div u = 0   in 0 < y < H, periodic in x and z,
//     u = prescribed Dirichlet data on y = 0 and y = H,
// on a Fourier (x, z) x Chebyshev-Gauss-Lobatto (y) grid, by per-mode Chebyshev-tau solves with a 2x2
// influence matrix that enforces div u = 0 on the walls (docs/method.md §1.2; Kleiser & Schumann).
//
// Life cycle: construct once per grid (FFTW plans made with FFTW_ESTIMATE so results are reproducible
// from run to run, homogeneous solutions cached per |k|, decision D12), then per solve:
//   1. fill forcing(0..2) = rho/mu on the grid (layout [j][i][k], z fastest); d(rho_y)/dy for the pressure is
//      taken spectrally (the analytic derivative of the clouds left an error floor near the walls),
//   2. fill wall(side, c): velocity component c at the wall grid points [i][k], side 0: y = 0, side 1: y = H,
//   3. solve(); velocity(c) then holds u_c on the grid.
// The k = 0 mode has no mean pressure gradient (fixed pressure drop, D2) and v0 = mean of its wall values.
#include <complex>
#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

#include "host/solver/slit_parameters.hpp"
#include "host/solver/slit_solve.hpp"
#include "kernels/backend.hpp"
#include "kernels/mode_solve.hpp"

namespace capsflow {

// FFTW's planner is not thread-safe; every FFTW plan in the process (both plans) is made under this lock.
std::mutex& fftw_planner_mutex();

// Homogeneous solutions per (|kx| index, kz index), (nx/2+1) (nz/2+1) of them (decision D12): phi_1 and psi_1
// Chebyshev coefficients (N + 1 each; phi_2, psi_2 follow by the reflection y -> H - y) and the inverse 2x2 influence
// matrix (4 each). Computed with the tau solver, never from sinh/cosh (P13). Shared by SlitStokesPlan and
// SlitStokesPlanDevice (which computes them here, on the host, and pushes them once).
void slit_homogeneous_solutions(const SlitGeometry& geo, int nx, int nz, int N, Backend backend,
                                std::vector<double>& hom_phi, std::vector<double>& hom_psi,
                                std::vector<double>& hom_minv);

// DCT-I of S real series of length N + 1 stored side by side ([j][s]), in place, with FFTW's REDFT00 convention
//   X_k = x_0 + (-1)^k x_N + 2 sum_{j=1}^{N-1} x_j cos(pi j k / N),
// by one complex FFT of length N per series: the even extension e (length 2N) packed as z_n = e_2n + i e_2n+1, then
// the real-FFT split. The same work as FFTW's own REDFT00 (a padded real FFT of length 2N), without its per-call
// buffers: those copies and allocations took a third of the mode stage. work: work_size() complex values from
// fftw_alloc (the alignment the plan was made with); one per thread.
class Dct1Lanes {
 public:
  Dct1Lanes(int N, int S);
  ~Dct1Lanes();
  Dct1Lanes(const Dct1Lanes&) = delete;
  Dct1Lanes& operator=(const Dct1Lanes&) = delete;
  std::size_t work_size() const { return static_cast<std::size_t>(N_) * S_; }
  void apply(double* x, std::complex<double>* work) const;

 private:
  int N_, S_;
  void* plan_ = nullptr;
  std::vector<double> half_cos_, half_sin_;  // cos(pi k/N)/2, sin(pi k/N)/2, k = 0..N
};

class SlitStokesPlan final : public SlitSolve {
 public:
  static constexpr int kModeBlock = 16;  // modes per block of solve_modes (vector lanes of the tau solves)

  SlitStokesPlan(const SlitGeometry& geo, const GgemGrid& grid, Backend backend);
  ~SlitStokesPlan();
  SlitStokesPlan(const SlitStokesPlan&) = delete;
  SlitStokesPlan& operator=(const SlitStokesPlan&) = delete;

  int nx() const { return nx_; }
  int ny() const { return N_; }  // Chebyshev degree; N + 1 planes
  int nz() const { return nz_; }
  std::size_t plane_size() const { return plane_; }
  std::size_t grid_size() const { return plane_ * static_cast<std::size_t>(N_ + 1); }
  const std::vector<double>& y_nodes() const { return y_; }  // increasing, y_0 = 0, y_N = H

  SlitGridView view() const override;
  double* forcing(int c) override { return force_[c]; }
  double* wall(int side, int c) { return wall_[side][c]; }
  const double* velocity(int c) const override { return vel_[c]; }
  double* velocity_mutable(int c) { return vel_[c]; }

  void zero_forcing_and_walls() override;
  // wall(side, c)[p] = -wall_local_u[c][side * nx * nz + p] (u_g = -u_l on the walls, 6.3).
  void set_walls_negated(const double* const wall_local_u[3]) override;
  void solve() override;
  const char* name() const override { return "FFTW"; }

  // The mode solves' instruction set: AVX-512 where the CPU has it (and CAPSFLOW_NO_AVX512 is unset), else portable
  // loops. Both give the same bits; the switch exists for the test that checks it.
  bool modes_use_avx512() const { return modes_avx512_; }
  void set_modes_avx512(bool on) { modes_avx512_ = on && modes_avx512_available(); }
  static bool modes_avx512_available();

  // Timings of the last solve() in seconds: transforms and per-mode solves.
  double last_transform_seconds() const override { return t_transform_; }
  double last_mode_seconds() const override { return t_modes_; }

 private:
  using cplx = std::complex<double>;
  void build_mode_lanes();
  void solve_modes();

  SlitGeometry geo_;
  Backend backend_;
  int nx_, nz_, N_, nzh_;
  std::size_t plane_, cplane_;
  std::vector<double> y_;
  double* force_[3] = {nullptr, nullptr, nullptr};
  double* vel_[3] = {nullptr, nullptr, nullptr};
  double* wall_[2][3] = {{nullptr, nullptr, nullptr}, {nullptr, nullptr, nullptr}};
  cplx* spec_[3] = {nullptr, nullptr, nullptr};
  cplx* wspec_[2][3] = {{nullptr, nullptr, nullptr}, {nullptr, nullptr, nullptr}};
  void* plan_fwd_ = nullptr;   // r2c over every y-plane
  void* plan_inv_ = nullptr;   // c2r over every y-plane
  std::unique_ptr<Dct1Lanes> dct_;  // DCT-I along y of a block of modes (re and im parts: 2 kModeBlock series)
  void* plan_wall_ = nullptr;  // r2c of one wall map
  // Per (|kx| index, block of kModeBlock kz) in lane order: the tau factors of each mode's k^2 (lane_tau_ points
  // into lane_fac_), the homogeneous solutions phi_1, psi_1 (phi_2, psi_2 follow by the reflection y -> H - y) and
  // the inverse influence matrices. Computed once per plan.
  std::vector<double> lane_fac_, lane_phi_, lane_psi_, lane_minv_;
  std::vector<TauLanes> lane_tau_;
  double t_transform_ = 0.0, t_modes_ = 0.0;
  bool modes_avx512_ = false;
};

}  // namespace capsflow
