#pragma once
// SlitPoissonGradient: grad(phi) on the GGEM grid for lap(phi) = s in 0 < y < H, periodic in x and z, phi = 0 on
// y = 0 and y = H. The potential-flow part of the double layer's global field (docs/method.md "Double layer"): the
// smoothed mass sources s of the density elements give the velocity grad(phi); the Dirichlet condition makes its
// tangential components vanish on the walls, so only the normal component enters the Stokes solve's wall data.
//
// Fourier (FFTW r2c per plane) x Chebyshev-tau per mode (the Helmholtz solver of kernels/mode_solve.hpp with
// lambda = k^2; k = 0 included: phi'' = s with phi = 0 on both walls always has a solution). The Chebyshev
// transforms are the Stokes plan's DCT-I (Dct1Lanes) over blocks of kBlock modes. CPU only (on the device backend the
// double layer brings its source to the host for it; backend Serial or Threads here).
//
// Layout as the Stokes plan: value (j, i, k) at (j * nx + i) * nz + k. Serial and threads give the same bits (modes
// are independent; FFTs plane by plane).
#include <complex>
#include <cstddef>
#include <memory>
#include <vector>

#include "host/solver/slit_parameters.hpp"
#include "kernels/backend.hpp"

namespace capsflow {

class Dct1Lanes;

class SlitPoissonGradient {
 public:
  static constexpr int kBlock = 16;  // modes per block of the Chebyshev transforms
  SlitPoissonGradient(const SlitGeometry& geo, int nx, int nz, int N, Backend backend);
  ~SlitPoissonGradient();
  SlitPoissonGradient(const SlitPoissonGradient&) = delete;
  SlitPoissonGradient& operator=(const SlitPoissonGradient&) = delete;

  double* source() { return src_; }  // s on the grid, to be filled (zero_source first)
  void zero_source();
  void solve();                                          // fills gradient(c), c = 0, 1, 2
  const double* gradient(int c) const { return grad_[c]; }
  std::size_t grid_size() const { return plane_ * static_cast<std::size_t>(N_ + 1); }

 private:
  using cplx = std::complex<double>;
  SlitGeometry geo_;
  Backend backend_;
  int nx_, nz_, N_, nzh_;
  std::size_t plane_, cplane_;
  double* src_ = nullptr;
  double* grad_[3] = {nullptr, nullptr, nullptr};
  cplx* spec_ = nullptr;      // transform of the source, then of phi
  cplx* gspec_[3] = {nullptr, nullptr, nullptr};
  std::unique_ptr<Dct1Lanes> dct_;  // DCT-I along y of 2 kBlock series (real and imaginary parts of kBlock modes)
  void* plan_fwd_ = nullptr;
  void* plan_inv_ = nullptr;
};

}  // namespace capsflow
