// The implementation of slit_poisson.hpp: the potential-flow part of the double layer's global field.
#include "host/solver/slit_poisson.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <new>
#include <stdexcept>

#include "host/solver/fftw_alloc.hpp"
#include "host/solver/slit_stokes_plan.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/mode_solve.hpp"

namespace capsflow {

SlitPoissonGradient::SlitPoissonGradient(const SlitGeometry& geo, int nx, int nz, int N, Backend backend)
    : geo_(geo), backend_(backend), nx_(nx), nz_(nz), N_(N), nzh_(nz / 2 + 1) {
  if (nx < 2 || nz < 2 || N < 2) throw std::invalid_argument("SlitPoissonGradient: grid too small");
  plane_ = static_cast<std::size_t>(nx_) * nz_;
  cplane_ = static_cast<std::size_t>(nx_) * nzh_;
  const std::size_t np = N_ + 1;
  src_ = fftw_alloc_array<double>(np * plane_);
  for (auto& g : grad_) g = fftw_alloc_array<double>(np * plane_);
  spec_ = fftw_alloc_array<cplx>(np * cplane_);
  for (auto& g : gspec_) g = fftw_alloc_array<cplx>(np * cplane_);
  dct_ = std::make_unique<Dct1Lanes>(N_, 2 * kBlock);
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
  constexpr int B = kBlock, L = 2 * kBlock;  // lanes: real parts of B modes, then their imaginary parts
  const long long nblocks = (nmodes + B - 1) / B;
  const int N = N_;
#pragma omp parallel if (threads)
  {
    std::vector<double> buf(static_cast<std::size_t>(np) * L), dbuf(static_cast<std::size_t>(np) * L);
    std::vector<double> F(np), a(np), da(np), b0(L), bN(L), d0(L), dN(L);
    auto* work = static_cast<cplx*>(fftw_malloc(sizeof(cplx) * dct_->work_size()));
    TauWorkspace ws(N_);
#pragma omp for schedule(static)
    for (long long blk = 0; blk < nblocks; ++blk) {
      const long long m0 = blk * B;
      const int nb = static_cast<int>(std::min<long long>(B, nmodes - m0));
      std::fill(buf.begin(), buf.end(), 0.0);
      for (int l = 0; l < nb; ++l)
        for (int j = 0; j < np; ++j) {
          const cplx v = spec_[static_cast<std::size_t>(j) * cplane_ + static_cast<std::size_t>(m0 + l)];
          buf[static_cast<std::size_t>(j) * L + l] = v.real();
          buf[static_cast<std::size_t>(j) * L + B + l] = v.imag();
        }
      // Values at s_j = -cos(pi j/N) -> Chebyshev coefficients: a_k = (-1)^k X_k / (N c_k), X = DCT-I.
      dct_->apply(buf.data(), work);
      for (int lane = 0; lane < L; ++lane) {
        const int l = lane % B;
        if (l >= nb) continue;
        const long long m = m0 + l;
        const int ia = static_cast<int>(m / nzh_), kz = static_cast<int>(m % nzh_);
        const int sx = ia <= nx_ / 2 ? ia : ia - nx_;
        const double k2 = (ax * sx) * (ax * sx) + (az * kz) * (az * kz);
        for (int k = 0; k <= N; ++k) {
          const double ck = (k == 0 || k == N) ? 2.0 : 1.0;
          F[k] = (k % 2 ? -1.0 : 1.0) * buf[static_cast<std::size_t>(k) * L + lane] / (N * ck);
        }
        tau_helmholtz(N, k2, H, F.data(), 0.0, 0.0, a.data(), ws);
        cheb_derivative<double>(N, a.data(), H, da.data());
        // Back to values: u_j = sum_k b_k cos(pi j k/N), b_k = (-1)^k a_k, = (DCT-I(b)_j + b_0 + (-1)^j b_N) / 2.
        for (int k = 0; k <= N; ++k) {
          const double sgn = k % 2 ? -1.0 : 1.0;
          buf[static_cast<std::size_t>(k) * L + lane] = sgn * a[k];
          dbuf[static_cast<std::size_t>(k) * L + lane] = sgn * da[k];
        }
      }
      for (int lane = 0; lane < L; ++lane) {
        b0[lane] = buf[lane];
        bN[lane] = buf[static_cast<std::size_t>(N) * L + lane];
        d0[lane] = dbuf[lane];
        dN[lane] = dbuf[static_cast<std::size_t>(N) * L + lane];
      }
      dct_->apply(buf.data(), work);
      dct_->apply(dbuf.data(), work);
      for (int l = 0; l < nb; ++l) {
        const long long m = m0 + l;
        const int ia = static_cast<int>(m / nzh_), kz = static_cast<int>(m % nzh_);
        const int sx = ia <= nx_ / 2 ? ia : ia - nx_;
        // The Nyquist planes carry no derivative (their i k would not be the transform of a real field).
        const double dx = (nx_ % 2 == 0 && ia == nx_ / 2) ? 0.0 : ax * sx;
        const double dz = (nz_ % 2 == 0 && kz == nz_ / 2) ? 0.0 : az * kz;
        for (int j = 0; j <= N; ++j) {
          const double sj = j % 2 ? -1.0 : 1.0;
          const std::size_t row = static_cast<std::size_t>(j) * L;
          const double pr = 0.5 * (buf[row + l] + b0[l] + sj * bN[l]) * norm;
          const double pim = 0.5 * (buf[row + B + l] + b0[B + l] + sj * bN[B + l]) * norm;
          const double dr = 0.5 * (dbuf[row + l] + d0[l] + sj * dN[l]) * norm;
          const double dim = 0.5 * (dbuf[row + B + l] + d0[B + l] + sj * dN[B + l]) * norm;
          const std::size_t idx = static_cast<std::size_t>(j) * cplane_ + static_cast<std::size_t>(m);
          gspec_[0][idx] = cplx(-dx * pim, dx * pr);
          gspec_[1][idx] = cplx(dr, dim);
          gspec_[2][idx] = cplx(-dz * pim, dz * pr);
        }
      }
    }
    fftw_free(work);
  }
  auto pi = static_cast<fftw_plan>(plan_inv_);
  for (int c = 0; c < 3; ++c) {
#pragma omp parallel for schedule(static) if (threads)
    for (int j = 0; j < np; ++j)
      fftw_execute_dft_c2r(pi, reinterpret_cast<fftw_complex*>(gspec_[c] + j * cplane_), grad_[c] + j * plane_);
  }
}

}  // namespace capsflow
