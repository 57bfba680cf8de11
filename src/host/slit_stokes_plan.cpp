#include "host/slit_stokes_plan.hpp"

#include <fftw3.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <stdexcept>

#include "kernels/ggem_kernels.hpp"
#include "kernels/mode_solve.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif

namespace capsflow {
namespace {

// FFTW's planner is not thread-safe; every plan in the process is made under this lock.
std::mutex& fftw_planner_mutex() {
  static std::mutex m;
  return m;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

template <class T>
T* fftw_alloc_array(std::size_t n) {
  void* p = fftw_malloc(sizeof(T) * n);
  if (!p) throw std::bad_alloc();
  std::memset(p, 0, sizeof(T) * n);
  return static_cast<T*>(p);
}

int fft_threads_for(Backend b) {
#if defined(CAPSFLOW_HAVE_FFTW_OMP) && defined(CAPSFLOW_HAVE_OPENMP)
  if (b == Backend::Threads || b == Backend::Device) {
    static const bool ok = fftw_init_threads() != 0;
    if (ok) return omp_get_max_threads();
  }
#else
  (void)b;
#endif
  return 1;
}

}  // namespace

SlitStokesPlan::SlitStokesPlan(const SlitGeometry& geo, const GgemGrid& grid, Backend backend)
    : geo_(geo), backend_(backend), nx_(grid.nx), nz_(grid.nz), N_(grid.ny), nzh_(grid.nz / 2 + 1) {
  plane_ = static_cast<std::size_t>(nx_) * nz_;
  cplane_ = static_cast<std::size_t>(nx_) * nzh_;
  const std::size_t np = N_ + 1;
  y_.resize(np);
  for (int j = 0; j <= N_; ++j) y_[j] = 0.5 * geo_.H * (1.0 - std::cos(kPi * j / N_));
  y_[0] = 0.0;
  y_[N_] = geo_.H;

  for (auto& f : force_) f = fftw_alloc_array<double>(np * plane_);
  for (auto& v : vel_) v = fftw_alloc_array<double>(np * plane_);
  for (auto& s : spec_) s = fftw_alloc_array<cplx>(np * cplane_);
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c) {
      wall_[side][c] = fftw_alloc_array<double>(plane_);
      wspec_[side][c] = fftw_alloc_array<cplx>(cplane_);
    }

  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
#if defined(CAPSFLOW_HAVE_FFTW_OMP) && defined(CAPSFLOW_HAVE_OPENMP)
    const int nthreads = fft_threads_for(backend_);
    fftw_plan_with_nthreads(nthreads);
#endif
    const int n2[2] = {nx_, nz_};
    const int pl = static_cast<int>(plane_), cpl = static_cast<int>(cplane_);
    auto* cs = reinterpret_cast<fftw_complex*>(spec_[0]);
    plan_fwd_ = fftw_plan_many_dft_r2c(2, n2, N_ + 1, force_[0], nullptr, 1, pl, cs, nullptr, 1, cpl,
                                       FFTW_ESTIMATE);
    plan_inv_ = fftw_plan_many_dft_c2r(2, n2, N_ + 1, cs, nullptr, 1, cpl, vel_[0], nullptr, 1, pl,
                                       FFTW_ESTIMATE | FFTW_DESTROY_INPUT);
    const int ny1[1] = {N_ + 1};
    const fftw_r2r_kind kind[1] = {FFTW_REDFT00};
    double* sd = reinterpret_cast<double*>(spec_[0]);
    plan_dct_ = fftw_plan_many_r2r(1, ny1, 2 * cpl, sd, nullptr, 2 * cpl, 1, sd, nullptr, 2 * cpl, 1, kind,
                                   FFTW_ESTIMATE);
#if defined(CAPSFLOW_HAVE_FFTW_OMP) && defined(CAPSFLOW_HAVE_OPENMP)
    fftw_plan_with_nthreads(1);
#endif
    plan_wall_ = fftw_plan_dft_r2c_2d(nx_, nz_, wall_[0][0], reinterpret_cast<fftw_complex*>(wspec_[0][0]),
                                      FFTW_ESTIMATE);
  }
  if (!plan_fwd_ || !plan_inv_ || !plan_dct_ || !plan_wall_) throw std::runtime_error("FFTW planning failed");

  // Homogeneous solutions (D12): computed with the same tau solver, never from sinh/cosh (P13).
  const int nxh = nx_ / 2 + 1;
  const std::size_t nh = static_cast<std::size_t>(nxh) * nzh_;
  hom_phi_.assign(nh * np, 0.0);
  hom_psi_.assign(nh * np, 0.0);
  hom_minv_.assign(nh * 4, 0.0);
  const double ax = 2.0 * kPi / geo_.Lx, az = 2.0 * kPi / geo_.Lz;
#pragma omp parallel if (backend_ != Backend::Serial)
  {
    TauWorkspace<double> ws(N_);
    std::vector<double> zero(np, 0.0), p(np), dp(np), dpsi(np);
#pragma omp for schedule(dynamic, 4)
    for (int ia = 0; ia < nxh; ++ia) {
      for (int jz = 0; jz < nzh_; ++jz) {
        if (ia == 0 && jz == 0) continue;
        const double k2 = (ax * ia) * (ax * ia) + (az * jz) * (az * jz);
        const std::size_t h = static_cast<std::size_t>(ia) * nzh_ + jz;
        double* phi = &hom_phi_[h * np];
        double* psi = &hom_psi_[h * np];
        tau_helmholtz<double>(N_, k2, geo_.H, zero.data(), 1.0, 0.0, p.data(), ws);  // p = 1 at y = 0
        tau_helmholtz<double>(N_, k2, geo_.H, p.data(), 0.0, 0.0, phi, ws);
        cheb_derivative<double>(N_, p.data(), geo_.H, dp.data());
        tau_helmholtz<double>(N_, k2, geo_.H, dp.data(), 0.0, 0.0, psi, ws);
        cheb_derivative<double>(N_, psi, geo_.H, dpsi.data());
        // Wall divergences: theta_H1 = D psi_1 (phi vanishes on the walls); H2 is H1 reflected, so
        // theta_H2(0) = theta_H1(H) and theta_H2(H) = theta_H1(0).
        const double d0 = cheb_value_bottom<double>(N_, dpsi.data());
        const double dH = cheb_value_top<double>(N_, dpsi.data());
        const double det = d0 * d0 - dH * dH;
        double* mi = &hom_minv_[h * 4];
        mi[0] = d0 / det;
        mi[1] = -dH / det;
        mi[2] = -dH / det;
        mi[3] = d0 / det;
      }
    }
  }
}

SlitStokesPlan::~SlitStokesPlan() {
  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    for (void* p : {plan_fwd_, plan_inv_, plan_dct_, plan_wall_})
      if (p) fftw_destroy_plan(static_cast<fftw_plan>(p));
  }
  for (auto* f : force_) fftw_free(f);
  for (auto* v : vel_) fftw_free(v);
  for (auto* s : spec_) fftw_free(s);
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c) {
      fftw_free(wall_[side][c]);
      fftw_free(wspec_[side][c]);
    }
}

void SlitStokesPlan::zero_forcing_and_walls() {
  const std::size_t n = grid_size();
  for (auto* f : force_) std::memset(f, 0, sizeof(double) * n);
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c) std::memset(wall_[side][c], 0, sizeof(double) * plane_);
}

void SlitStokesPlan::solve() {
  auto t0 = std::chrono::steady_clock::now();
  auto pf = static_cast<fftw_plan>(plan_fwd_);
  auto pd = static_cast<fftw_plan>(plan_dct_);
  for (int c = 0; c < 4; ++c) {
    fftw_execute_dft_r2c(pf, force_[c], reinterpret_cast<fftw_complex*>(spec_[c]));
    double* sd = reinterpret_cast<double*>(spec_[c]);
    fftw_execute_r2r(pd, sd, sd);
  }
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c)
      fftw_execute_dft_r2c(static_cast<fftw_plan>(plan_wall_), wall_[side][c],
                           reinterpret_cast<fftw_complex*>(wspec_[side][c]));
  t_transform_ = seconds_since(t0);

  auto t1 = std::chrono::steady_clock::now();
  solve_modes();
  t_modes_ = seconds_since(t1);

  auto t2 = std::chrono::steady_clock::now();
  auto pi = static_cast<fftw_plan>(plan_inv_);
  for (int c = 0; c < 3; ++c) {
    double* sd = reinterpret_cast<double*>(spec_[c]);
    fftw_execute_r2r(pd, sd, sd);
    fftw_execute_dft_c2r(pi, reinterpret_cast<fftw_complex*>(spec_[c]), vel_[c]);
  }
  t_transform_ += seconds_since(t2);
}

void SlitStokesPlan::solve_modes() {
  const int N = N_;
  const std::size_t np = N + 1;
  const double H = geo_.H;
  const double ax = 2.0 * kPi / geo_.Lx, az = 2.0 * kPi / geo_.Lz;
  const double inv_nxz = 1.0 / static_cast<double>(plane_);
  const bool nyq_x = nx_ % 2 == 0, nyq_z = nz_ % 2 == 0;
  const cplx I(0.0, 1.0);

#pragma omp parallel if (backend_ != Backend::Serial)
  {
    TauWorkspace<cplx> ws(N);
    std::vector<cplx> rx(np), ry(np), rz(np), dry(np), rhs(np), p(np), dp(np), u(np), v(np), w(np), dv(np);
#pragma omp for schedule(dynamic, 2)
    for (int i = 0; i < nx_; ++i) {
      const int sx = i <= nx_ / 2 ? i : i - nx_;
      const int ia = sx < 0 ? -sx : sx;
      const double kx = ax * sx;
      const bool unpaired_x = nyq_x && i == nx_ / 2;
      for (int jz = 0; jz < nzh_; ++jz) {
        const double kz = az * jz;
        const bool unpaired_z = nyq_z && jz == nz_ / 2;
        // Unpaired Nyquist modes keep k^2 but drop the odd first-derivative factors (6.7).
        const cplx ikx = unpaired_x ? cplx(0.0) : I * kx;
        const cplx ikz = unpaired_z ? cplx(0.0) : I * kz;
        const double k2 = kx * kx + kz * kz;
        const std::size_t col = static_cast<std::size_t>(i) * nzh_ + jz;
        // Gather the column and turn DCT-I output into Chebyshev coefficients in s (with the FFT scaling).
        for (int k = 0; k <= N; ++k) {
          const double ck = (k == 0 || k == N) ? 2.0 : 1.0;
          const double sc = ((k % 2) ? -1.0 : 1.0) * inv_nxz / (N * ck);
          const std::size_t idx = k * cplane_ + col;
          rx[k] = spec_[0][idx] * sc;
          ry[k] = spec_[1][idx] * sc;
          rz[k] = spec_[2][idx] * sc;
          dry[k] = spec_[3][idx] * sc;
        }
        const cplx ub0 = wspec_[0][0][col] * inv_nxz, ubH = wspec_[1][0][col] * inv_nxz;
        const cplx vb0 = wspec_[0][1][col] * inv_nxz, vbH = wspec_[1][1][col] * inv_nxz;
        const cplx wb0 = wspec_[0][2][col] * inv_nxz, wbH = wspec_[1][2][col] * inv_nxz;

        if (sx == 0 && jz == 0) {
          // Mean mode (6.6): u0'' = -rho_x0/mu, w0'' = -rho_z0/mu, v0 = mean of its wall values.
          for (int k = 0; k <= N; ++k) rhs[k] = -rx[k];
          tau_helmholtz<cplx>(N, 0.0, H, rhs.data(), ub0, ubH, u.data(), ws);
          for (int k = 0; k <= N; ++k) rhs[k] = -rz[k];
          tau_helmholtz<cplx>(N, 0.0, H, rhs.data(), wb0, wbH, w.data(), ws);
          for (int k = 0; k <= N; ++k) v[k] = cplx(0.0);
          v[0] = 0.5 * (vb0 + vbH);
        } else {
          // Particular solution: pressure with p = 0 on the walls, then the three velocity components.
          for (int k = 0; k <= N; ++k) rhs[k] = ikx * rx[k] + dry[k] + ikz * rz[k];
          tau_helmholtz<cplx>(N, k2, H, rhs.data(), cplx(0.0), cplx(0.0), p.data(), ws);
          cheb_derivative<cplx>(N, p.data(), H, dp.data());
          for (int k = 0; k <= N; ++k) rhs[k] = ikx * p[k] - rx[k];
          tau_helmholtz<cplx>(N, k2, H, rhs.data(), ub0, ubH, u.data(), ws);
          for (int k = 0; k <= N; ++k) rhs[k] = dp[k] - ry[k];
          tau_helmholtz<cplx>(N, k2, H, rhs.data(), vb0, vbH, v.data(), ws);
          for (int k = 0; k <= N; ++k) rhs[k] = ikz * p[k] - rz[k];
          tau_helmholtz<cplx>(N, k2, H, rhs.data(), wb0, wbH, w.data(), ws);
          cheb_derivative<cplx>(N, v.data(), H, dv.data());
          const cplx th0 = ikx * ub0 + cheb_value_bottom<cplx>(N, dv.data()) + ikz * wb0;
          const cplx thH = ikx * ubH + cheb_value_top<cplx>(N, dv.data()) + ikz * wbH;
          // Influence matrix: add c1 H1 + c2 H2 so that div u = 0 on both walls.
          const std::size_t h = static_cast<std::size_t>(ia) * nzh_ + jz;
          const double* mi = &hom_minv_[h * 4];
          const cplx c1 = -(mi[0] * th0 + mi[1] * thH);
          const cplx c2 = -(mi[2] * th0 + mi[3] * thH);
          const double* phi = &hom_phi_[h * np];
          const double* psi = &hom_psi_[h * np];
          for (int k = 0; k <= N; ++k) {
            const double sgn = (k % 2) ? -1.0 : 1.0;  // phi_2 = phi_1 reflected, psi_2 = -psi_1 reflected
            const cplx phic = c1 * phi[k] + c2 * (sgn * phi[k]);
            const cplx psic = c1 * psi[k] - c2 * (sgn * psi[k]);
            u[k] += ikx * phic;
            v[k] += psic;
            w[k] += ikz * phic;
          }
        }
        // Scatter back as DCT-I input: X_k = (-1)^k a_k, halved for interior k.
        for (int k = 0; k <= N; ++k) {
          const double sc = ((k % 2) ? -1.0 : 1.0) * ((k == 0 || k == N) ? 1.0 : 0.5);
          const std::size_t idx = k * cplane_ + col;
          spec_[0][idx] = u[k] * sc;
          spec_[1][idx] = v[k] * sc;
          spec_[2][idx] = w[k] * sc;
        }
      }
    }
  }
}

}  // namespace capsflow
