// The global Fourier-Chebyshev Stokes solve on a manufactured 3D solution (docs/method.md §1.3):
// a divergence-free, periodic field with non-zero wall values, its forcing rho = -mu lap u + grad p computed
// analytically, and spectral convergence of the solve in the Fourier and Chebyshev resolutions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
#include <cstdio>
#include <vector>

#include <fftw3.h>

#include "host/base/backend_select.hpp"
#include "host/solver/slit_solve.hpp"
#include "host/solver/slit_stokes_plan.hpp"
#include "host/solver/slit_stokes_plan_device.hpp"
#include "kernels/backend.hpp"
#include "kernels/ggem_kernels.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

namespace {

struct Manufactured {
  // u = curl(0, 0, phi(y) S(theta)) + (U(y), 0, 0), theta = kx x + kz z, S = exp(beta sin theta),
  // p = q(y) S'(theta). Divergence-free by construction; zero mean pressure gradient.
  double mu = 1.3, kx = 1.0, kz = 2.0, beta = 0.8;
  double H = 2.0;
  double phi(double y, int d) const {  // d-th derivative of sin(1.3 y + 0.4)
    const double a = 1.3, arg = a * y + 0.4;
    const double s = std::sin(arg), c = std::cos(arg);
    const double v[5] = {s, a * c, -a * a * s, -a * a * a * c, a * a * a * a * s};
    return v[d];
  }
  double q(double y, int d) const {  // cos(0.7 y)
    const double a = 0.7;
    const double v[3] = {std::cos(a * y), -a * std::sin(a * y), -a * a * std::cos(a * y)};
    return v[d];
  }
  double U(double y, int d) const {  // cos(1.1 y)
    const double a = 1.1;
    return d == 0 ? std::cos(a * y) : -a * a * std::cos(a * y);
  }
  void S(double th, double* s) const {  // S, S', S'', S'''
    const double sn = std::sin(th), cs = std::cos(th), e = std::exp(beta * sn);
    s[0] = e;
    s[1] = beta * cs * e;
    s[2] = (-beta * sn + beta * beta * cs * cs) * e;
    s[3] = beta * cs * e * (beta * beta * cs * cs - 3.0 * beta * sn - 1.0);
  }
  void velocity(double x, double y, double z, double* u) const {
    double s[4];
    S(kx * x + kz * z, s);
    u[0] = phi(y, 1) * s[0] + U(y, 0);
    u[1] = -kx * phi(y, 0) * s[1];
    u[2] = 0.0;
  }
  void forcing(double x, double y, double z, double* r) const {
    double s[4];
    S(kx * x + kz * z, s);
    const double K2 = kx * kx + kz * kz;
    r[0] = -mu * (phi(y, 3) * s[0] + K2 * phi(y, 1) * s[2]) + kx * q(y, 0) * s[2] - mu * U(y, 2);
    r[1] = mu * kx * (phi(y, 2) * s[1] + K2 * phi(y, 0) * s[3]) + q(y, 1) * s[1];
    r[2] = kz * q(y, 0) * s[2];
  }
};

struct SolveResult {
  double error = 0.0;          // max |u - exact| / max |exact| over the grid
  std::vector<double> u[3];    // the plan's velocity field, component by component
};

SolveResult solve_manufactured(const Manufactured& m, int nxz, int N, Backend backend) {
  SlitGeometry geo{m.H, 2.0 * kPi / m.kx, 2.0 * kPi / (m.kz / 2.0), m.mu};
  GgemGrid grid;
  grid.nx = nxz;
  grid.nz = nxz;
  grid.ny = N;
  grid.hx = geo.Lx / nxz;
  grid.hz = geo.Lz / nxz;
  // Through the one factory: the CPU plan, or the device plan (filled on the host and pushed, read back after).
  std::unique_ptr<SlitSolve> made = make_slit_solve(backend, geo, grid);
  SlitSolve& plan = *made;
  auto* device = dynamic_cast<SlitStokesPlanDevice*>(made.get());
  plan.zero_forcing_and_walls();
  const SlitGridView view = plan.view();
  const double* yv = view.y;
  for (int j = 0; j <= N; ++j)
    for (int i = 0; i < nxz; ++i)
      for (int k = 0; k < nxz; ++k) {
        double r[3];
        m.forcing(i * grid.hx, yv[j], k * grid.hz, r);
        const std::size_t idx = (static_cast<std::size_t>(j) * nxz + i) * nxz + k;
        for (int c = 0; c < 3; ++c) plan.forcing(c)[idx] = r[c] / m.mu;
      }
  if (device != nullptr) device->push_forcing();
  // Wall data through the interface's negation (u_g = -u_l): hand it -u.
  const std::size_t nw = static_cast<std::size_t>(nxz) * nxz;
  std::vector<double> neg[3];
  for (auto& v : neg) v.assign(2 * nw, 0.0);
  for (int side = 0; side < 2; ++side)
    for (int i = 0; i < nxz; ++i)
      for (int k = 0; k < nxz; ++k) {
        double u[3];
        m.velocity(i * grid.hx, side ? m.H : 0.0, k * grid.hz, u);
        for (int c = 0; c < 3; ++c) neg[c][side * nw + static_cast<std::size_t>(i) * nxz + k] = -u[c];
      }
  const double* negp[3] = {neg[0].data(), neg[1].data(), neg[2].data()};
  plan.set_walls_negated(negp);
  plan.solve();
  if (device != nullptr) device->pull_velocity();
  SolveResult res;
  const std::size_t points = static_cast<std::size_t>(N + 1) * nxz * nxz;
  for (int c = 0; c < 3; ++c) res.u[c].assign(plan.velocity(c), plan.velocity(c) + points);
  double err = 0.0, ref = 0.0;
  for (int j = 0; j <= N; ++j)
    for (int i = 0; i < nxz; ++i)
      for (int k = 0; k < nxz; ++k) {
        double u[3];
        m.velocity(i * grid.hx, yv[j], k * grid.hz, u);
        const std::size_t idx = (static_cast<std::size_t>(j) * nxz + i) * nxz + k;
        for (int c = 0; c < 3; ++c) {
          err = std::max(err, std::abs(plan.velocity(c)[idx] - u[c]));
          ref = std::max(ref, std::abs(u[c]));
        }
      }
  res.error = err / ref;
  return res;
}

double solve_error(const Manufactured& m, int nxz, int N, Backend backend) {
  return solve_manufactured(m, nxz, N, backend).error;
}

}  // namespace

class SlitSolvePhysics : public test::OnEachBackend {};

TEST_P(SlitSolvePhysics, ManufacturedSolutionConvergesSpectrally) {
  Manufactured m;
  double prev = 1.0;
  for (int n : {8, 16, 24, 32}) {
    const double e = solve_error(m, n, n, backend());
    std::printf("n = %d: max relative error %.3e\n", n, e);
    EXPECT_LT(e, 0.05 * prev) << "n = " << n;
    prev = e;
  }
  EXPECT_LT(prev, 1e-8);
}

TEST_P(SlitSolvePhysics, ManufacturedSolutionConvergesInChebyshevAlone) {
  Manufactured m;
  double prev = 1.0;
  for (int N : {6, 8, 10, 12}) {
    const double e = solve_error(m, 48, N, backend());
    std::printf("N = %d: max relative error %.3e\n", N, e);
    EXPECT_LT(e, 0.05 * prev) << "N = " << N;
    prev = e;
  }
  EXPECT_LT(prev, 1e-11);
}

CAPSFLOW_ON_EACH_BACKEND(SlitSolvePhysics);

class SlitSolveBackends : public test::OnEachBackend {};

// The three velocity fields, point by point: threads give the serial bits (planes split among threads, each summed
// in the serial order); the device within 1e-12 of the flow's largest value (its FFTs and mode solves round
// differently). The manufactured flow has w = 0: that component is compared at the same scale.
TEST_P(SlitSolveBackends, MatchSerial) {
  Manufactured m;
  const SolveResult s = solve_manufactured(m, 16, 16, Backend::Serial);
  const SolveResult t = solve_manufactured(m, 16, 16, backend());
  double scale = 0.0;
  for (int c = 0; c < 2; ++c) {
    double largest = 0.0;
    for (double v : s.u[c]) largest = std::max(largest, std::abs(v));
    ASSERT_GT(largest, 0.1) << "component " << c << " carries no flow: a compare of zeros proves nothing";
    scale = std::max(scale, largest);
  }
  for (int c = 0; c < 3; ++c) {
    ASSERT_EQ(s.u[c].size(), t.u[c].size());
    double worst = 0.0;
    for (std::size_t i = 0; i < s.u[c].size(); ++i) worst = std::max(worst, std::abs(s.u[c][i] - t.u[c][i]));
    if (backend() == Backend::Device)
      EXPECT_LE(worst, 1e-12 * scale) << "component " << c;
    else
      EXPECT_EQ(worst, 0.0) << "component " << c;
  }
}

CAPSFLOW_ON_PARALLEL_BACKENDS(SlitSolveBackends);

// The plan's Chebyshev transform (a complex FFT of length N per series plus the real-FFT split) is FFTW's REDFT00,
// series by series, for even, odd and non-power-of-two N.
TEST(Dct1Lanes, IsFftwRedft00OnEverySeries) {
  for (int N : {8, 17, 90, 128}) {
    const int np = N + 1, S = 6;
    Dct1Lanes dct(N, S);
    auto x = test::uniform_values(static_cast<std::size_t>(np) * S, -1.0, 1.0, 11u + static_cast<std::uint64_t>(N));
    std::vector<double> lanes = x;
    auto* work = static_cast<std::complex<double>*>(fftw_malloc(sizeof(std::complex<double>) * dct.work_size()));
    dct.apply(lanes.data(), work);
    fftw_free(work);
    for (int s = 0; s < S; ++s) {
      std::vector<double> in(np), out(np);
      for (int j = 0; j < np; ++j) in[j] = x[static_cast<std::size_t>(j) * S + s];
      fftw_plan p = fftw_plan_r2r_1d(np, in.data(), out.data(), FFTW_REDFT00, FFTW_ESTIMATE);
      fftw_execute(p);
      fftw_destroy_plan(p);
      double diff = 0.0, ref = 0.0;
      for (int k = 0; k < np; ++k) {
        diff = std::max(diff, std::abs(lanes[static_cast<std::size_t>(k) * S + s] - out[k]));
        ref = std::max(ref, std::abs(out[k]));
      }
      EXPECT_LT(diff / ref, 1e-14) << "N = " << N << ", series " << s;
    }
  }
}

// The mode solves' AVX-512 copy and their portable loops give the same bits (the plan's file is compiled without
// FMA contraction), serial and threads alike: a run may move between CPUs of different vector widths in this stage.
TEST(SlitStokesPlanModes, Avx512AndPortableGiveTheSameBits) {
  if (!SlitStokesPlan::modes_avx512_available()) GTEST_SKIP() << "this CPU has no AVX-512";
  SlitGeometry geo;
  geo.H = 3.0;
  geo.Lx = 4.0;
  geo.Lz = 5.0;
  GgemGrid g;
  g.nx = 24;
  g.nz = 36;  // 19 kz modes: a full block of 16 and a partial one
  g.ny = 40;
  g.hx = geo.Lx / g.nx;
  g.hz = geo.Lz / g.nz;
  for (Backend b : {Backend::Serial, Backend::Threads}) {
    if (!backend_available(b)) continue;
    std::vector<double> out[2];
    for (int simd = 0; simd < 2; ++simd) {
      SlitStokesPlan plan(geo, g, b);
      plan.set_modes_avx512(simd == 1);
      ASSERT_EQ(plan.modes_use_avx512(), simd == 1);
      plan.zero_forcing_and_walls();
      for (int c = 0; c < 3; ++c) {
        const auto f = test::uniform_values(plan.grid_size(), -1.0, 1.0, 7u + static_cast<std::uint64_t>(c));
        std::copy(f.begin(), f.end(), plan.forcing(c));
        const auto w0 = test::uniform_values(plan.plane_size(), -0.1, 0.1, 17u + static_cast<std::uint64_t>(c));
        const auto w1 = test::uniform_values(plan.plane_size(), -0.1, 0.1, 27u + static_cast<std::uint64_t>(c));
        std::copy(w0.begin(), w0.end(), plan.wall(0, c));
        std::copy(w1.begin(), w1.end(), plan.wall(1, c));
      }
      plan.solve();
      for (int c = 0; c < 3; ++c)
        out[simd].insert(out[simd].end(), plan.velocity(c), plan.velocity(c) + plan.grid_size());
    }
    ASSERT_EQ(out[0].size(), out[1].size());
    std::size_t differ = 0;
    for (std::size_t i = 0; i < out[0].size(); ++i) differ += out[0][i] != out[1][i];
    EXPECT_EQ(differ, 0u) << backend_name(b);
  }
}
