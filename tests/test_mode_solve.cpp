// The 1D Chebyshev-tau Helmholtz solver on exact solutions (docs/method.md §1.2, tests 2-3 of section 11).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include "kernels/ggem_kernels.hpp"
#include "kernels/mode_solve.hpp"

using namespace capsflow;

namespace {

// Chebyshev coefficients in s = 2y/H - 1 by direct O(N^2) quadrature at s_j = -cos(pi j/N) (independent of FFTW).
std::vector<double> cheb_coeffs(const std::function<double(double)>& f, int N, double H) {
  std::vector<double> a(N + 1, 0.0);
  for (int k = 0; k <= N; ++k) {
    double s = 0.0;
    for (int j = 0; j <= N; ++j) {
      const double sj = -std::cos(kPi * j / N);
      const double cj = (j == 0 || j == N) ? 2.0 : 1.0;
      s += f(0.5 * H * (1.0 + sj)) * std::cos(k * std::acos(sj)) / cj;
    }
    a[k] = 2.0 * s / (N * ((k == 0 || k == N) ? 2.0 : 1.0));
  }
  return a;
}

double cheb_eval(const std::vector<double>& a, double y, double H) {
  const double s = 2.0 * y / H - 1.0;
  double v = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) v += a[k] * std::cos(static_cast<double>(k) * std::acos(s));
  return v;
}

double max_error(const std::vector<double>& a, const std::function<double(double)>& exact, double H) {
  double e = 0.0;
  for (int i = 0; i <= 200; ++i) {
    const double y = H * i / 200.0;
    e = std::max(e, std::abs(cheb_eval(a, y, H) - exact(y)));
  }
  return e;
}

}  // namespace

TEST(TauSolver, ExactSmoothSolutionToMachinePrecision) {
  const double H = 3.0;
  for (double lam : {0.0, 1.0, 25.0, 400.0}) {
    auto u = [](double y) { return std::sin(2.0 * y) + y * y - 0.5 * y; };
    auto F = [lam, &u](double y) { return -4.0 * std::sin(2.0 * y) + 2.0 - lam * u(y); };
    const int N = 40;
    auto Fc = cheb_coeffs(F, N, H);
    std::vector<double> a(N + 1);
    TauWorkspace ws(N);
    tau_helmholtz(N, lam, H, Fc.data(), u(0.0), u(H), a.data(), ws);
    EXPECT_LT(max_error(a, u, H), 1e-11) << "lambda " << lam;
  }
}

TEST(TauSolver, SpectralConvergence) {
  const double H = 2.0, lam = 9.0;
  auto u = [](double y) { return std::exp(std::sin(3.0 * y)); };
  auto F = [&](double y) {
    const double s = std::sin(3.0 * y), c = std::cos(3.0 * y);
    return (9.0 * c * c - 9.0 * s) * std::exp(s) - lam * u(y);
  };
  double prev = 1.0;
  for (int N : {8, 16, 24, 32}) {
    auto Fc = cheb_coeffs(F, N, H);
    std::vector<double> a(N + 1);
    TauWorkspace ws(N);
    tau_helmholtz(N, lam, H, Fc.data(), u(0.0), u(H), a.data(), ws);
    const double e = max_error(a, u, H);
    EXPECT_LT(e, 0.1 * prev) << "N " << N;
    prev = e;
  }
  EXPECT_LT(prev, 1e-9);
}

TEST(TauSolver, OneSidedWallConditionHasTheRightOrientation) {
  // u = 1 on y = H only: u = sinh(k y) / sinh(k H) (pitfall P7).
  const double H = 2.0, k = 1.7;
  const int N = 32;
  std::vector<double> zero(N + 1, 0.0), a(N + 1);
  TauWorkspace ws(N);
  tau_helmholtz(N, k * k, H, zero.data(), 0.0, 1.0, a.data(), ws);
  EXPECT_LT(max_error(a, [&](double y) { return std::sinh(k * y) / std::sinh(k * H); }, H), 1e-12);
  EXPECT_NEAR(cheb_value_top<double>(N, a.data()), 1.0, 1e-14);
  EXPECT_NEAR(cheb_value_bottom<double>(N, a.data()), 0.0, 1e-14);
}

TEST(TauSolver, LargeWavenumberDoesNotOverflow) {
  // kH = 250 (pitfall P13): the boundary layer exp(-k y) at y = 0 only.
  const double H = 10.0, k = 25.0;
  const int N = 256;
  std::vector<double> zero(N + 1, 0.0), a(N + 1);
  TauWorkspace ws(N);
  tau_helmholtz(N, k * k, H, zero.data(), 1.0, 0.0, a.data(), ws);
  for (double v : a) ASSERT_TRUE(std::isfinite(v));
  EXPECT_LT(max_error(a, [&](double y) { return std::exp(-k * y); }, H), 1e-8);
}

TEST(TauSolver, MeanModeCouetteAndForceLayer) {
  const double H = 5.0, U = 2.0, c = 0.3;
  const int N = 16;
  std::vector<double> zero(N + 1, 0.0), a(N + 1);
  TauWorkspace ws(N);
  // Couette: moving top wall, no force.
  tau_helmholtz(N, 0.0, H, zero.data(), 0.0, U, a.data(), ws);
  EXPECT_LT(max_error(a, [&](double y) { return U * y / H; }, H), 1e-13);
  // Uniform force layer: u'' = -c between fixed walls gives c y (H - y) / 2.
  std::vector<double> Fc(N + 1, 0.0);
  Fc[0] = -c;
  tau_helmholtz(N, 0.0, H, Fc.data(), 0.0, 0.0, a.data(), ws);
  EXPECT_LT(max_error(a, [&](double y) { return 0.5 * c * y * (H - y); }, H), 1e-13);
}

TEST(TauSolver, DerivativeRecurrence) {
  const double H = 1.5;
  const int N = 30;
  auto a = cheb_coeffs([](double y) { return std::cos(2.0 * y) * y; }, N, H);
  std::vector<double> b(N + 1);
  cheb_derivative<double>(N, a.data(), H, b.data());
  EXPECT_LT(max_error(b, [](double y) { return std::cos(2.0 * y) - 2.0 * y * std::sin(2.0 * y); }, H), 1e-10);
}

// The CPU plan solves 16 modes as vector lanes, the device kernel one mode per thread: the same body with B = 16 and
// B = 1 gives the same bits for every mode of a batch, including the mean mode, unpaired Nyquist directions and
// a lane past the end of a row (zero data).
TEST(ModeLanes, SixteenLanesEqualOneLaneModeByMode) {
  constexpr int B = 16, N = 24, np = N + 1;
  const double H = 2.5;
  auto rnd = [](std::size_t n, std::uint64_t seed) {
    std::vector<double> v(n);
    std::uint64_t s = seed;
    for (auto& x : v) {
      s = s * 6364136223846793005ull + 1442695040888963407ull;
      x = static_cast<double>(s >> 11) / 9007199254740992.0 - 0.5;
    }
    return v;
  };
  double kx[B], kz[B], lambda[B];
  int mean[B];
  for (int b = 0; b < B; ++b) {
    kx[b] = b == 5 ? 0.0 : 0.7 * (b % 3);  // lane 5: an unpaired Nyquist x direction
    kz[b] = 0.45 * b;
    mean[b] = b == 0;
    lambda[b] = b == 5 ? 1.96 + kz[b] * kz[b] : kx[b] * kx[b] + kz[b] * kz[b];
  }
  const auto rx0 = rnd(np * 2 * B, 1), ry0 = rnd(np * 2 * B, 2), rz0 = rnd(np * 2 * B, 3);
  auto walls = rnd(6 * 2 * B, 4);
  auto phi = rnd(np * B, 5), psi = rnd(np * B, 6), minv = rnd(4 * B, 7);
  // The mean mode (lane 0) has no homogeneous solutions; lane 15 (past the end of a row) has nothing at all.
  for (int b : {0, 15}) {
    for (int k = 0; k < np; ++k) phi[k * B + b] = psi[k * B + b] = 0.0;
    for (int e = 0; e < 4; ++e) minv[e * B + b] = 0.0;
  }
  for (int q = 0; q < 12; ++q) walls[q * B + 15] = 0.0;
  std::vector<double> rx = rx0, ry = ry0, rz = rz0;
  for (int k = 0; k < np; ++k)  // lane 15: past the end of a row
    for (int pt = 0; pt < 2; ++pt) {
      const std::size_t l = static_cast<std::size_t>(k * 2 + pt) * B + 15;
      rx[l] = ry[l] = rz[l] = 0.0;
    }

  std::vector<double> fac(tau_lanes_doubles(N, B)), work(slit_modes_work_doubles(N, B));
  TauLanes f;
  tau_lanes_bind(N, B, fac.data(), f);
  tau_lanes_factor(lambda, H, f);
  const ModeLanes in = mode_lanes(B, kx, kz, mean, walls.data(), phi.data(), psi.data(), minv.data());
  std::vector<double> bx = rx, by = ry, bz = rz;
  slit_modes_velocity<B>(N, H, in, f, bx.data(), by.data(), bz.data(), work.data());

  for (int b = 0; b < B; ++b) {
    std::vector<double> f1(tau_lanes_doubles(N, 1)), w1(slit_modes_work_doubles(N, 1));
    TauLanes g;
    tau_lanes_bind(N, 1, f1.data(), g);
    tau_lanes_factor(&lambda[b], H, g);
    std::vector<double> x(2 * np), y(2 * np), z(2 * np), ph(np), ps(np), mi(4), wl(12);
    for (int k = 0; k < np; ++k) {
      for (int pt = 0; pt < 2; ++pt) {
        x[2 * k + pt] = rx[(k * 2 + pt) * B + b];
        y[2 * k + pt] = ry[(k * 2 + pt) * B + b];
        z[2 * k + pt] = rz[(k * 2 + pt) * B + b];
      }
      ph[k] = phi[k * B + b];
      ps[k] = psi[k * B + b];
    }
    for (int e = 0; e < 4; ++e) mi[e] = minv[e * B + b];
    for (int q = 0; q < 6; ++q)
      for (int pt = 0; pt < 2; ++pt) wl[2 * q + pt] = walls[(2 * q + pt) * B + b];
    const ModeLanes one = mode_lanes(1, &kx[b], &kz[b], &mean[b], wl.data(), ph.data(), ps.data(), mi.data());
    slit_modes_velocity<1>(N, H, one, g, x.data(), y.data(), z.data(), w1.data());
    for (int k = 0; k < np; ++k)
      for (int pt = 0; pt < 2; ++pt) {
        const std::size_t l = static_cast<std::size_t>(k * 2 + pt) * B + b;
        ASSERT_EQ(bx[l], x[2 * k + pt]) << "lane " << b << ", k " << k;
        ASSERT_EQ(by[l], y[2 * k + pt]) << "lane " << b << ", k " << k;
        ASSERT_EQ(bz[l], z[2 * k + pt]) << "lane " << b << ", k " << k;
      }
    if (b == 15) {
      for (int k = 0; k < 2 * np; ++k) EXPECT_EQ(x[k], 0.0);
    }
  }
}
