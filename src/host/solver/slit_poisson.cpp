#include "host/solver/slit_poisson.hpp"

#include <fftw3.h>

#include <cmath>
#include <cstring>
#include <mutex>
#include <new>
#include <stdexcept>

#include "host/solver/slit_stokes_plan.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/mode_solve.hpp"

namespace capsflow {
namespace {

template <class T>
T* alloc_zeroed(std::size_t n) {
  void* p = fftw_malloc(sizeof(T) * n);
  if (!p) throw std::bad_alloc();
  std::memset(p, 0, sizeof(T) * n);
  return static_cast<T*>(p);
}

}  // namespace

SlitPoissonGradient::SlitPoissonGradient(const SlitGeometry& geo, int nx, int nz, int N, Backend backend)
    : geo_(geo), backend_(backend), nx_(nx), nz_(nz), N_(N), nzh_(nz / 2 + 1) {
  if (nx < 2 || nz < 2 || N < 2) throw std::invalid_argument("SlitPoissonGradient: grid too small");
  plane_ = static_cast<std::size_t>(nx_) * nz_;
  cplane_ = static_cast<std::size_t>(nx_) * nzh_;
  const std::size_t np = N_ + 1;
  src_ = alloc_zeroed<double>(np * plane_);
  for (auto& g : grad_) g = alloc_zeroed<double>(np * plane_);
  spec_ = alloc_zeroed<cplx>(np * cplane_);
  for (auto& g : gspec_) g = alloc_zeroed<cplx>(np * cplane_);
  // T_k(s_j) with s_j = -cos(pi j/N): (-1)^k cos(pi j k/N). Interpolation: a_k = (2/(N c_k)) sum''_j v_j T_k(s_j),
  // c_0 = c_N = 2, the end terms of the sum halved.
  to_cheb_.assign(np * np, 0.0);
  from_cheb_.assign(np * np, 0.0);
  for (int j = 0; j <= N_; ++j)
    for (int k = 0; k <= N_; ++k) {
      const double t = (k % 2 ? -1.0 : 1.0) * std::cos(kPi * static_cast<double>(j * k % (2 * N_)) / N_);
      from_cheb_[static_cast<std::size_t>(j) * np + k] = t;
      const double ck = (k == 0 || k == N_) ? 2.0 : 1.0;
      const double wj = (j == 0 || j == N_) ? 0.5 : 1.0;
      to_cheb_[static_cast<std::size_t>(k) * np + j] = 2.0 / (N_ * ck) * wj * t;
    }
  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    auto* cs = reinterpret_cast<fftw_complex*>(spec_);
    plan_fwd_ = fftw_plan_dft_r2c_2d(nx_, nz_, src_, cs, FFTW_ESTIMATE);
    plan_inv_ = fftw_plan_dft_c2r_2d(nx_, nz_, cs, grad_[0], FFTW_ESTIMATE | FFTW_DESTROY_INPUT);
  }
  if (!plan_fwd_ || !plan_inv_) throw std::runtime_error("FFTW planning failed (slit Poisson solve)");
}

SlitPoissonGradient::~SlitPoissonGradient() {
  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    for (void* p : {plan_fwd_, plan_inv_})
      if (p) fftw_destroy_plan(static_cast<fftw_plan>(p));
  }
  fftw_free(src_);
  for (auto* g : grad_) fftw_free(g);
  fftw_free(spec_);
  for (auto* g : gspec_) fftw_free(g);
}

void SlitPoissonGradient::zero_source() { std::memset(src_, 0, sizeof(double) * grid_size()); }

void SlitPoissonGradient::solve() {
  const int np = N_ + 1;
  const bool threads = backend_ != Backend::Serial;
  auto pf = static_cast<fftw_plan>(plan_fwd_);
#pragma omp parallel for schedule(static) if (threads)
  for (int j = 0; j < np; ++j)
    fftw_execute_dft_r2c(pf, src_ + j * plane_, reinterpret_cast<fftw_complex*>(spec_ + j * cplane_));

  const double ax = 2.0 * kPi / geo_.Lx, az = 2.0 * kPi / geo_.Lz;
  const double H = geo_.H;
  const double norm = 1.0 / static_cast<double>(plane_);  // FFTW's c2r(r2c(x)) = nx nz x
  const long long nmodes = static_cast<long long>(cplane_);
#pragma omp parallel if (threads)
  {
    std::vector<double> v(2 * np), c(2 * np), F(np), a(np), da(np), phi(2 * np), dphi(2 * np);
    TauWorkspace ws(N_);
#pragma omp for schedule(static)
    for (long long m = 0; m < nmodes; ++m) {
      const int ia = static_cast<int>(m / nzh_), kz = static_cast<int>(m % nzh_);
      const int sx = ia <= nx_ / 2 ? ia : ia - nx_;
      const double kxv = ax * sx, kzv = az * kz;
      const double k2 = kxv * kxv + kzv * kzv;
      // The Nyquist planes carry no derivative (their i k would not be the transform of a real field).
      const double dx = (nx_ % 2 == 0 && ia == nx_ / 2) ? 0.0 : kxv;
      const double dz = (nz_ % 2 == 0 && kz == nz_ / 2) ? 0.0 : kzv;
      for (int j = 0; j < np; ++j) {
        const cplx s = spec_[static_cast<std::size_t>(j) * cplane_ + m];
        v[j] = s.real();
        v[np + j] = s.imag();
      }
      for (int part = 0; part < 2; ++part) {
        for (int k = 0; k < np; ++k) {
          double acc = 0.0;
          const double* row = to_cheb_.data() + static_cast<std::size_t>(k) * np;
          for (int j = 0; j < np; ++j) acc += row[j] * v[part * np + j];
          F[k] = acc;
        }
        tau_helmholtz(N_, k2, H, F.data(), 0.0, 0.0, a.data(), ws);
        cheb_derivative<double>(N_, a.data(), H, da.data());
        for (int j = 0; j < np; ++j) {
          const double* row = from_cheb_.data() + static_cast<std::size_t>(j) * np;
          double p = 0.0, dp = 0.0;
          for (int k = 0; k < np; ++k) {
            p += row[k] * a[k];
            dp += row[k] * da[k];
          }
          phi[part * np + j] = p;
          dphi[part * np + j] = dp;
        }
      }
      for (int j = 0; j < np; ++j) {
        const std::size_t idx = static_cast<std::size_t>(j) * cplane_ + m;
        const cplx p(phi[j] * norm, phi[np + j] * norm);
        gspec_[0][idx] = cplx(0.0, dx) * p;
        gspec_[1][idx] = cplx(dphi[j] * norm, dphi[np + j] * norm);
        gspec_[2][idx] = cplx(0.0, dz) * p;
      }
    }
  }
  auto pi = static_cast<fftw_plan>(plan_inv_);
  for (int c = 0; c < 3; ++c) {
#pragma omp parallel for schedule(static) if (threads)
    for (int j = 0; j < np; ++j)
      fftw_execute_dft_c2r(pi, reinterpret_cast<fftw_complex*>(gspec_[c] + j * cplane_), grad_[c] + j * plane_);
  }
}

}  // namespace capsflow
