// The implementation of slit_stokes_plan.hpp: SlitStokesPlan, the Fourier x Chebyshev-tau solve of GGEM's global part.
#include "host/solver/slit_stokes_plan.hpp"
#include "host/base/stopwatch.hpp"
#include "host/solver/fftw_alloc.hpp"
#include "kernels/simd_path.hpp"

#include <fftw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
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

Dct1Lanes::Dct1Lanes(int N, int S) : N_(N), S_(S), half_cos_(N + 1), half_sin_(N + 1) {
  for (int k = 0; k <= N; ++k) {
    half_cos_[k] = 0.5 * std::cos(kPi * k / N);
    half_sin_[k] = 0.5 * std::sin(kPi * k / N);
  }
  std::lock_guard<std::mutex> lock(fftw_planner_mutex());
  auto* z = reinterpret_cast<fftw_complex*>(fftw_alloc_array<std::complex<double>>(work_size()));
  plan_ = fftw_plan_many_dft(1, &N_, S_, z, nullptr, S_, 1, z, nullptr, S_, 1, FFTW_FORWARD, FFTW_ESTIMATE);
  fftw_free(z);
  if (!plan_) throw std::runtime_error("FFTW planning failed (Chebyshev transform)");
}

Dct1Lanes::~Dct1Lanes() {
  std::lock_guard<std::mutex> lock(fftw_planner_mutex());
  fftw_destroy_plan(static_cast<fftw_plan>(plan_));
}

void Dct1Lanes::apply(double* x, std::complex<double>* work) const {
  const int N = N_, S = S_;
  // z_n = e_2n + i e_2n+1 with e_m = x_m for m <= N and x_{2N-m} beyond (the even extension).
  for (int n = 0; n < N; ++n) {
    const int m0 = 2 * n, m1 = 2 * n + 1;
    const double* x0 = x + static_cast<std::size_t>(m0 <= N ? m0 : 2 * N - m0) * S;
    const double* x1 = x + static_cast<std::size_t>(m1 <= N ? m1 : 2 * N - m1) * S;
    double* z = reinterpret_cast<double*>(work + static_cast<std::size_t>(n) * S);
    for (int s = 0; s < S; ++s) {
      z[2 * s] = x0[s];
      z[2 * s + 1] = x1[s];
    }
  }
  fftw_execute_dft(static_cast<fftw_plan>(plan_), reinterpret_cast<fftw_complex*>(work),
                   reinterpret_cast<fftw_complex*>(work));
  // E_k = F_k + e^{-i pi k/N} G_k with F, G the transforms of the even and odd samples,
  // F_k = (Z_k + conj Z_{N-k})/2, G_k = (Z_k - conj Z_{N-k})/(2i); X_k = Re E_k (E is real for even e).
  for (int k = 0; k <= N; ++k) {
    const double* a = reinterpret_cast<const double*>(work + static_cast<std::size_t>(k % N) * S);
    const double* b = reinterpret_cast<const double*>(work + static_cast<std::size_t>((N - k) % N) * S);
    const double hc = half_cos_[k], hs = half_sin_[k];
    double* X = x + static_cast<std::size_t>(k) * S;
    for (int s = 0; s < S; ++s) {
      const double ar = a[2 * s], ai = a[2 * s + 1], br = b[2 * s], bi = b[2 * s + 1];
      X[s] = 0.5 * (ar + br) + hc * (ai + bi) - hs * (ar - br);
    }
  }
}

namespace {

// One mode's homogeneous solutions (D12), with the same tau solver, never from sinh/cosh (P13): phi_1 and psi_1
// coefficients and the inverse 2x2 influence matrix, into the workspace's arrays.
struct HomogeneousMode {
  TauWorkspace ws;
  std::vector<double> zero, p, dp, dpsi, phi, psi;
  double minv[4] = {0.0, 0.0, 0.0, 0.0};
  explicit HomogeneousMode(int N)
      : ws(N), zero(N + 1, 0.0), p(N + 1), dp(N + 1), dpsi(N + 1), phi(N + 1), psi(N + 1) {}
  void solve(int N, double H, double k2) {
    tau_helmholtz(N, k2, H, zero.data(), 1.0, 0.0, p.data(), ws);  // p = 1 at y = 0
    tau_helmholtz(N, k2, H, p.data(), 0.0, 0.0, phi.data(), ws);
    cheb_derivative<double>(N, p.data(), H, dp.data());
    tau_helmholtz(N, k2, H, dp.data(), 0.0, 0.0, psi.data(), ws);
    cheb_derivative<double>(N, psi.data(), H, dpsi.data());
    // Wall divergences: theta_H1 = D psi_1 (phi vanishes on the walls); H2 is H1 reflected, so
    // theta_H2(0) = theta_H1(H) and theta_H2(H) = theta_H1(0).
    const double d0 = cheb_value_bottom<double>(N, dpsi.data());
    const double dH = cheb_value_top<double>(N, dpsi.data());
    const double det = d0 * d0 - dH * dH;
    minv[0] = d0 / det;
    minv[1] = -dH / det;
    minv[2] = -dH / det;
    minv[3] = d0 / det;
  }
};

}  // namespace

void slit_homogeneous_solutions(const SlitGeometry& geo, int nx, int nz, int N, Backend backend,
                                std::vector<double>& hom_phi, std::vector<double>& hom_psi,
                                std::vector<double>& hom_minv) {
  const std::size_t np = N + 1;
  const int nzh = nz / 2 + 1;
  const int nxh = nx / 2 + 1;
  const std::size_t nh = static_cast<std::size_t>(nxh) * nzh;
  hom_phi.assign(nh * np, 0.0);
  hom_psi.assign(nh * np, 0.0);
  hom_minv.assign(nh * 4, 0.0);
  const double ax = 2.0 * kPi / geo.Lx, az = 2.0 * kPi / geo.Lz;
#pragma omp parallel if (backend != Backend::Serial)
  {
    HomogeneousMode m(N);
#pragma omp for schedule(dynamic, 4)
    for (int ia = 0; ia < nxh; ++ia) {
      for (int jz = 0; jz < nzh; ++jz) {
        if (ia == 0 && jz == 0) continue;
        m.solve(N, geo.H, (ax * ia) * (ax * ia) + (az * jz) * (az * jz));
        const std::size_t h = static_cast<std::size_t>(ia) * nzh + jz;
        std::copy(m.phi.begin(), m.phi.end(), hom_phi.begin() + static_cast<std::ptrdiff_t>(h * np));
        std::copy(m.psi.begin(), m.psi.end(), hom_psi.begin() + static_cast<std::ptrdiff_t>(h * np));
        std::copy(m.minv, m.minv + 4, hom_minv.begin() + static_cast<std::ptrdiff_t>(h * 4));
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
    plan_wall_ = fftw_plan_dft_r2c_2d(nx_, nz_, wall_[0][0], reinterpret_cast<fftw_complex*>(wspec_[0][0]),
                                      FFTW_ESTIMATE);
  }
  if (!plan_fwd_ || !plan_inv_ || !plan_wall_) throw std::runtime_error("FFTW planning failed");
  // DCT-I along y of a block of kModeBlock modes gathered from the planes into [j][lane] order: cache-local, and the
  // FFTs run across the block's lanes.
  dct_ = std::make_unique<Dct1Lanes>(N_, 2 * kModeBlock);

  build_mode_lanes();
  modes_avx512_ = modes_avx512_available() && host_simd_path() == SimdPath::Avx512;
}

SlitStokesPlan::~SlitStokesPlan() {
  {
    std::lock_guard<std::mutex> lock(fftw_planner_mutex());
    for (void* p : {plan_fwd_, plan_inv_, plan_wall_})
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

SlitGridView SlitStokesPlan::view() const {
  return slit_grid_view(geo_, nx_, nz_, N_, y_.data());
}

void SlitStokesPlan::set_walls_negated(const double* const wall_local_u[3]) {
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c) {
      double* w = wall_[side][c];
      const double* ul = wall_local_u[c] + side * plane_;
      for (std::size_t p = 0; p < plane_; ++p) w[p] = -ul[p];
    }
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

void SlitStokesPlan::build_mode_lanes() {
  // Per (|kx| index, block of kModeBlock consecutive kz): the tau factors of each lane's k^2 (lambda = 0 for the
  // mean mode, which its solves need) and the homogeneous solutions in lane order ([k][lane]), written there directly
  // (no second copy in mode order: the memory estimate counts these arrays once). Lanes past the last kz of a row get
  // a valid k^2 and zero homogeneous solutions, so they solve zeros to zeros.
  constexpr int B = kModeBlock;
  const std::size_t np = N_ + 1;
  const int nxh = nx_ / 2 + 1;
  const int bpr = (nzh_ + B - 1) / B;
  const int nlb = nxh * bpr;
  const double ax = 2.0 * kPi / geo_.Lx, az = 2.0 * kPi / geo_.Lz;
  const std::size_t fac_size = tau_lanes_doubles(N_, B);
  lane_fac_.assign(static_cast<std::size_t>(nlb) * fac_size, 0.0);
  lane_tau_.assign(static_cast<std::size_t>(nlb), TauLanes{});
  lane_phi_.assign(static_cast<std::size_t>(nlb) * np * B, 0.0);
  lane_psi_.assign(static_cast<std::size_t>(nlb) * np * B, 0.0);
  lane_minv_.assign(static_cast<std::size_t>(nlb) * 4 * B, 0.0);
#pragma omp parallel if (backend_ != Backend::Serial)
  {
    HomogeneousMode m(N_);
#pragma omp for schedule(dynamic, 1)
    for (int lbi = 0; lbi < nlb; ++lbi) {
      const std::size_t lb = static_cast<std::size_t>(lbi);
      const int ia = lbi / bpr, blk = lbi % bpr;
      double lambda[B];
      for (int b = 0; b < B; ++b) {
        const int jz = blk * B + b;
        lambda[b] = (ax * ia) * (ax * ia) + (az * jz) * (az * jz);
        if (jz >= nzh_ || (ia == 0 && jz == 0)) continue;
        m.solve(N_, geo_.H, lambda[b]);
        for (std::size_t k = 0; k < np; ++k) {
          lane_phi_[(lb * np + k) * B + b] = m.phi[k];
          lane_psi_[(lb * np + k) * B + b] = m.psi[k];
        }
        for (int e = 0; e < 4; ++e) lane_minv_[(lb * 4 + e) * B + b] = m.minv[e];
      }
      TauLanes& f = lane_tau_[lb];
      tau_lanes_bind(N_, B, &lane_fac_[lb * fac_size], f);
      tau_lanes_factor(lambda, geo_.H, f);
    }
  }
}

namespace {

// What one block of modes needs from the plan (solve_modes' block loop).
struct ModeBlockArgs {
  int nx, nzh, N, blocks_per_row;
  double H, ax, az, inv_nxz;
  bool nyq_x, nyq_z;
  std::size_t cplane;
  std::complex<double>* const* spec;               // [3]
  const std::complex<double>* const (*wspec)[3];  // [2][3]
  const TauLanes* lane_tau;
  const double *lane_phi, *lane_psi, *lane_minv;
  const Dct1Lanes* dct;
};

// Block blk: kModeBlock consecutive kz of one kx row. The gather from the [j][mode] planes reads whole cache lines,
// one DCT per field transforms the block, and slit_modes_velocity solves its modes as vector lanes. Block layout
// per field: [j][re, im][lane] (2B real series).
template <int B>
inline void solve_mode_block(const ModeBlockArgs& a, int blk, double* blockbuf, std::complex<double>* dct_work,
                             double* work) {
  using cplx = std::complex<double>;
  constexpr int L = 2 * B;
  const int N = a.N;
  const std::size_t np = N + 1;
  const std::size_t bsize = static_cast<std::size_t>(L) * np;
  const int i = blk / a.blocks_per_row;
  const int jz0 = (blk % a.blocks_per_row) * B;
  const int nb = std::min(B, a.nzh - jz0);
  const std::size_t col0 = static_cast<std::size_t>(i) * a.nzh + jz0;
  for (int c = 0; c < 3; ++c) {
    double* d = blockbuf + c * bsize;
    for (std::size_t j = 0; j < np; ++j) {
      const cplx* src = a.spec[c] + j * a.cplane + col0;
      double* row = d + j * L;
      for (int b = 0; b < nb; ++b) {
        row[b] = src[b].real();
        row[B + b] = src[b].imag();
      }
      for (int b = nb; b < B; ++b) row[b] = row[B + b] = 0.0;
    }
    a.dct->apply(d, dct_work);
    // Chebyshev coefficients in s from the DCT-I output (with the FFT normalisation).
    for (int k = 0; k <= N; ++k) {
      const double ck = (k == 0 || k == N) ? 2.0 : 1.0;
      const double sc = ((k % 2) ? -1.0 : 1.0) * a.inv_nxz / (N * ck);
      for (int l = 0; l < L; ++l) d[k * L + l] *= sc;
    }
  }
  const int sx = i <= a.nx / 2 ? i : i - a.nx;
  const int ia = sx < 0 ? -sx : sx;
  const bool unpaired_x = a.nyq_x && i == a.nx / 2;
  double kx[B], kz[B], wall[6][L];
  int mean[B];
  for (int b = 0; b < B; ++b) {
    const int jz = jz0 + b;
    const bool live = b < nb;
    kx[b] = unpaired_x ? 0.0 : a.ax * sx;
    kz[b] = a.nyq_z && jz == a.nzh - 1 ? 0.0 : a.az * jz;  // jz = nz/2 for even nz
    mean[b] = live && sx == 0 && jz == 0;
    for (int side = 0; side < 2; ++side)
      for (int c = 0; c < 3; ++c) {
        const cplx v = live ? a.wspec[side][c][col0 + b] * a.inv_nxz : cplx(0.0);
        wall[2 * c + side][b] = v.real();
        wall[2 * c + side][B + b] = v.imag();
      }
  }
  const std::size_t lb = static_cast<std::size_t>(ia) * a.blocks_per_row + blk % a.blocks_per_row;
  const ModeLanes in = mode_lanes(B, kx, kz, mean, &wall[0][0], a.lane_phi + lb * np * B, a.lane_psi + lb * np * B,
                                  a.lane_minv + lb * 4 * B);
  slit_modes_velocity<B>(N, a.H, in, a.lane_tau[lb], blockbuf, blockbuf + bsize, blockbuf + 2 * bsize, work);
  for (int c = 0; c < 3; ++c) {
    double* d = blockbuf + c * bsize;
    // Back to DCT-I input: X_k = (-1)^k a_k, halved for interior k.
    for (int k = 0; k <= N; ++k) {
      const double sc = ((k % 2) ? -1.0 : 1.0) * ((k == 0 || k == N) ? 1.0 : 0.5);
      for (int l = 0; l < L; ++l) d[k * L + l] *= sc;
    }
    a.dct->apply(d, dct_work);
    for (std::size_t j = 0; j < np; ++j) {
      cplx* dst = a.spec[c] + j * a.cplane + col0;
      const double* row = d + j * L;
      for (int b = 0; b < nb; ++b) dst[b] = cplx(row[b], row[B + b]);
    }
  }
}

// The same code compiled for AVX-512 where the CPU has it (checked once): the lanes of every recurrence are vector
// operations 8 wide. This file is compiled with -ffp-contract=off (CMakeLists.txt): GCC would otherwise fuse a*b+c
// into FMAs here and not in the portable copy. So both variants give the same bits.
#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD) && defined(__GNUC__)
#define CAPSFLOW_MODES_AVX512 1
__attribute__((target("avx512f"), flatten)) void solve_mode_block_avx512(const ModeBlockArgs& a, int blk,
                                                                       double* blockbuf,
                                                                       std::complex<double>* dct_work, double* work) {
  solve_mode_block<SlitStokesPlan::kModeBlock>(a, blk, blockbuf, dct_work, work);
}
#endif

}  // namespace

bool SlitStokesPlan::modes_avx512_available() {
#ifdef CAPSFLOW_MODES_AVX512
  static const bool yes = __builtin_cpu_supports("avx512f");
  return yes;
#else
  return false;
#endif
}

void SlitStokesPlan::solve_modes() {
  ModeBlockArgs a;
  a.nx = nx_;
  a.nzh = nzh_;
  a.N = N_;
  a.blocks_per_row = (nzh_ + kModeBlock - 1) / kModeBlock;
  a.H = geo_.H;
  a.ax = 2.0 * kPi / geo_.Lx;
  a.az = 2.0 * kPi / geo_.Lz;
  a.inv_nxz = 1.0 / static_cast<double>(plane_);
  a.nyq_x = nx_ % 2 == 0;
  a.nyq_z = nz_ % 2 == 0;
  a.cplane = cplane_;
  a.spec = spec_;
  a.wspec = wspec_;
  a.lane_tau = lane_tau_.data();
  a.lane_phi = lane_phi_.data();
  a.lane_psi = lane_psi_.data();
  a.lane_minv = lane_minv_.data();
  a.dct = dct_.get();
  const int nblocks = nx_ * a.blocks_per_row;
#pragma omp parallel if (backend_ != Backend::Serial)
  {
    std::vector<double> work(slit_modes_work_doubles(N_, kModeBlock));
    double* blockbuf = fftw_alloc_array<double>(3 * 2 * kModeBlock * static_cast<std::size_t>(N_ + 1));
    cplx* dct_work = fftw_alloc_array<cplx>(dct_->work_size());
#pragma omp for schedule(dynamic, 1)
    for (int blk = 0; blk < nblocks; ++blk) {
#ifdef CAPSFLOW_MODES_AVX512
      if (modes_avx512_) {
        solve_mode_block_avx512(a, blk, blockbuf, dct_work, work.data());
        continue;
      }
#endif
      solve_mode_block<kModeBlock>(a, blk, blockbuf, dct_work, work.data());
    }
    fftw_free(dct_work);
    fftw_free(blockbuf);
  }
}

}  // namespace capsflow
