#include "host/slit_stokes_plan.hpp"
#include "host/stopwatch.hpp"

#include <fftw3.h>

#include <algorithm>
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

std::mutex& fftw_planner_mutex() {
  static std::mutex m;
  return m;
}

namespace {

template <class T>
T* fftw_alloc_array(std::size_t n) {
  void* p = fftw_malloc(sizeof(T) * n);
  if (!p) throw std::bad_alloc();
  std::memset(p, 0, sizeof(T) * n);
  return static_cast<T*>(p);
}

}  // namespace

void slit_homogeneous_solutions(const SlitGeometry& geo, int nx, int nz, int N, Backend backend,
                                std::vector<double>& hom_phi, std::vector<double>& hom_psi,
                                std::vector<double>& hom_minv) {
  const std::size_t np = N + 1;
  const int nzh = nz / 2 + 1;
  // Homogeneous solutions (D12): computed with the same tau solver, never from sinh/cosh (P13).
  const int nxh = nx / 2 + 1;
  const std::size_t nh = static_cast<std::size_t>(nxh) * nzh;
  hom_phi.assign(nh * np, 0.0);
  hom_psi.assign(nh * np, 0.0);
  hom_minv.assign(nh * 4, 0.0);
  const double ax = 2.0 * kPi / geo.Lx, az = 2.0 * kPi / geo.Lz;
#pragma omp parallel if (backend != Backend::Serial)
  {
    TauWorkspace<double> ws(N);
    std::vector<double> zero(np, 0.0), p(np), dp(np), dpsi(np);
#pragma omp for schedule(dynamic, 4)
    for (int ia = 0; ia < nxh; ++ia) {
      for (int jz = 0; jz < nzh; ++jz) {
        if (ia == 0 && jz == 0) continue;
        const double k2 = (ax * ia) * (ax * ia) + (az * jz) * (az * jz);
        const std::size_t h = static_cast<std::size_t>(ia) * nzh + jz;
        double* phi = &hom_phi[h * np];
        double* psi = &hom_psi[h * np];
        tau_helmholtz<double>(N, k2, geo.H, zero.data(), 1.0, 0.0, p.data(), ws);  // p = 1 at y = 0
        tau_helmholtz<double>(N, k2, geo.H, p.data(), 0.0, 0.0, phi, ws);
        cheb_derivative<double>(N, p.data(), geo.H, dp.data());
        tau_helmholtz<double>(N, k2, geo.H, dp.data(), 0.0, 0.0, psi, ws);
        cheb_derivative<double>(N, psi, geo.H, dpsi.data());
        // Wall divergences: theta_H1 = D psi_1 (phi vanishes on the walls); H2 is H1 reflected, so
        // theta_H2(0) = theta_H1(H) and theta_H2(H) = theta_H1(0).
        const double d0 = cheb_value_bottom<double>(N, dpsi.data());
        const double dH = cheb_value_top<double>(N, dpsi.data());
        const double det = d0 * d0 - dH * dH;
        double* mi = &hom_minv[h * 4];
        mi[0] = d0 / det;
        mi[1] = -dH / det;
        mi[2] = -dH / det;
        mi[3] = d0 / det;
      }
    }
  }
}

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
    // One 2D plan per plane shape, executed plane by plane (in parallel for 'threads'): the batched
    // plan_many variant made FFTW copy through temporary buffers on every call.
    auto* cs = reinterpret_cast<fftw_complex*>(spec_[0]);
    plan_fwd_ = fftw_plan_dft_r2c_2d(nx_, nz_, force_[0], cs, FFTW_ESTIMATE);
    plan_inv_ = fftw_plan_dft_c2r_2d(nx_, nz_, cs, vel_[0], FFTW_ESTIMATE | FFTW_DESTROY_INPUT);
    // DCT-I along y of a block of kBlock modes gathered from the planes into [j][mode] order (real and
    // imaginary parts as interleaved real sequences): cache-local, and FFTW vectorises across the block.
    const int ny1[1] = {N_ + 1};
    const fftw_r2r_kind kind[1] = {FFTW_REDFT00};
    const int seqs = 2 * kModeBlock;
    double* blockbuf = fftw_alloc_array<double>(static_cast<std::size_t>(seqs) * (N_ + 1));
    plan_dct_ = fftw_plan_many_r2r(1, ny1, seqs, blockbuf, nullptr, seqs, 1, blockbuf, nullptr, seqs, 1, kind,
                                   FFTW_ESTIMATE);
    fftw_free(blockbuf);
    plan_wall_ = fftw_plan_dft_r2c_2d(nx_, nz_, wall_[0][0], reinterpret_cast<fftw_complex*>(wspec_[0][0]),
                                      FFTW_ESTIMATE);
  }
  if (!plan_fwd_ || !plan_inv_ || !plan_dct_ || !plan_wall_) throw std::runtime_error("FFTW planning failed");

  slit_homogeneous_solutions(geo_, nx_, nz_, N_, backend_, hom_phi_, hom_psi_, hom_minv_);
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
  const int np = N_ + 1;
  for (int c = 0; c < 3; ++c) {
#pragma omp parallel for schedule(static) if (backend_ != Backend::Serial)
    for (int j = 0; j < np; ++j)
      fftw_execute_dft_r2c(pf, force_[c] + j * plane_, reinterpret_cast<fftw_complex*>(spec_[c] + j * cplane_));
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
#pragma omp parallel for schedule(static) if (backend_ != Backend::Serial)
    for (int j = 0; j < np; ++j)
      fftw_execute_dft_c2r(pi, reinterpret_cast<fftw_complex*>(spec_[c] + j * cplane_), vel_[c] + j * plane_);
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
  auto dct = static_cast<fftw_plan>(plan_dct_);
  // Modes are handled in blocks of consecutive kz of one kx row: the gather from the [j][mode] planes reads
  // whole cache lines, and one DCT call transforms the block.
  constexpr int kBlock = kModeBlock;
  const int blocks_per_row = (nzh_ + kBlock - 1) / kBlock;
  const int nblocks = nx_ * blocks_per_row;

#pragma omp parallel if (backend_ != Backend::Serial)
  {
    TauWorkspace<cplx> ws(N);
    std::vector<double> fac_storage(7 * 2 * static_cast<std::size_t>(tau_stride(N)));
    TauFactorsRef fac;  // one factorisation per mode, shared by its four solves
    tau_factors_bind(N, fac_storage.data(), fac);
    std::vector<cplx> rhs(np), p(np), dp(np), dv(np), cx(np), cy(np), cz(np), cd(np);
    // Block buffers [field][j][mode in block], FFTW-aligned.
    const std::size_t bsize = static_cast<std::size_t>(kBlock) * np;
    cplx* blockbuf = fftw_alloc_array<cplx>(3 * bsize);
    auto at = [&](int c, int j, int b) -> cplx& { return blockbuf[c * bsize + static_cast<std::size_t>(j) * kBlock + b]; };
#pragma omp for schedule(dynamic, 1)
    for (int blk = 0; blk < nblocks; ++blk) {
      const int i = blk / blocks_per_row;
      const int jz0 = (blk % blocks_per_row) * kBlock;
      const int nb = std::min(kBlock, nzh_ - jz0);
      const std::size_t col0 = static_cast<std::size_t>(i) * nzh_ + jz0;
      for (int c = 0; c < 3; ++c) {
        for (int j = 0; j <= N; ++j) {
          const cplx* src = spec_[c] + j * cplane_ + col0;
          for (int b = 0; b < nb; ++b) at(c, j, b) = src[b];
          for (int b = nb; b < kBlock; ++b) at(c, j, b) = cplx(0.0);
        }
        double* d = reinterpret_cast<double*>(blockbuf + c * bsize);
        fftw_execute_r2r(dct, d, d);
      }
      const int sx = i <= nx_ / 2 ? i : i - nx_;
      const int ia = sx < 0 ? -sx : sx;
      const bool unpaired_x = nyq_x && i == nx_ / 2;
      for (int b = 0; b < nb; ++b) {
        const int jz = jz0 + b;
        const std::size_t cidx = col0 + b;
        cplx* rx = cx.data();
        cplx* ry = cy.data();
        cplx* rz = cz.data();
        // Chebyshev coefficients in s from the DCT-I output (with the FFT normalisation).
        for (int k = 0; k <= N; ++k) {
          const double ck = (k == 0 || k == N) ? 2.0 : 1.0;
          const double sc = ((k % 2) ? -1.0 : 1.0) * inv_nxz / (N * ck);
          rx[k] = at(0, k, b) * sc;
          ry[k] = at(1, k, b) * sc;
          rz[k] = at(2, k, b) * sc;
        }
        const std::size_t h = static_cast<std::size_t>(ia) * nzh_ + jz;
        slit_mode_velocity<cplx>(N, H, sx == 0 && jz == 0, ax * sx, az * jz, unpaired_x, nyq_z && jz == nz_ / 2,
                                 wspec_[0][0][cidx] * inv_nxz, wspec_[1][0][cidx] * inv_nxz,
                                 wspec_[0][1][cidx] * inv_nxz, wspec_[1][1][cidx] * inv_nxz,
                                 wspec_[0][2][cidx] * inv_nxz, wspec_[1][2][cidx] * inv_nxz, &hom_phi_[h * np],
                                 &hom_psi_[h * np], &hom_minv_[h * 4], fac, rx, ry, rz, cd.data(), rhs.data(),
                                 p.data(), dp.data(), dv.data(), ws.g.data(), ws.P.data());
        // Back to DCT-I input: X_k = (-1)^k a_k, halved for interior k.
        for (int k = 0; k <= N; ++k) {
          const double sc = ((k % 2) ? -1.0 : 1.0) * ((k == 0 || k == N) ? 1.0 : 0.5);
          at(0, k, b) = rx[k] * sc;
          at(1, k, b) = ry[k] * sc;
          at(2, k, b) = rz[k] * sc;
        }
      }
      for (int c = 0; c < 3; ++c) {
        double* d = reinterpret_cast<double*>(blockbuf + c * bsize);
        fftw_execute_r2r(dct, d, d);
        for (int j = 0; j <= N; ++j) {
          cplx* dst = spec_[c] + j * cplane_ + col0;
          for (int b = 0; b < nb; ++b) dst[b] = at(c, j, b);
        }
      }
    }
    fftw_free(blockbuf);
  }
}

}  // namespace capsflow
