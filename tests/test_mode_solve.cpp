// The 1D Chebyshev-tau Helmholtz solver on exact solutions (method-spec 6.5, tests 2-3 of section 11).
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
    TauWorkspace<double> ws(N);
    tau_helmholtz<double>(N, lam, H, Fc.data(), u(0.0), u(H), a.data(), ws);
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
    TauWorkspace<double> ws(N);
    tau_helmholtz<double>(N, lam, H, Fc.data(), u(0.0), u(H), a.data(), ws);
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
  TauWorkspace<double> ws(N);
  tau_helmholtz<double>(N, k * k, H, zero.data(), 0.0, 1.0, a.data(), ws);
  EXPECT_LT(max_error(a, [&](double y) { return std::sinh(k * y) / std::sinh(k * H); }, H), 1e-12);
  EXPECT_NEAR(cheb_value_top<double>(N, a.data()), 1.0, 1e-14);
  EXPECT_NEAR(cheb_value_bottom<double>(N, a.data()), 0.0, 1e-14);
}

TEST(TauSolver, LargeWavenumberDoesNotOverflow) {
  // kH = 250 (pitfall P13): the boundary layer exp(-k y) at y = 0 only.
  const double H = 10.0, k = 25.0;
  const int N = 256;
  std::vector<double> zero(N + 1, 0.0), a(N + 1);
  TauWorkspace<double> ws(N);
  tau_helmholtz<double>(N, k * k, H, zero.data(), 1.0, 0.0, a.data(), ws);
  for (double v : a) ASSERT_TRUE(std::isfinite(v));
  EXPECT_LT(max_error(a, [&](double y) { return std::exp(-k * y); }, H), 1e-8);
}

TEST(TauSolver, MeanModeCouetteAndForceLayer) {
  const double H = 5.0, U = 2.0, c = 0.3;
  const int N = 16;
  std::vector<double> zero(N + 1, 0.0), a(N + 1);
  TauWorkspace<double> ws(N);
  // Couette: moving top wall, no force.
  tau_helmholtz<double>(N, 0.0, H, zero.data(), 0.0, U, a.data(), ws);
  EXPECT_LT(max_error(a, [&](double y) { return U * y / H; }, H), 1e-13);
  // Uniform force layer: u'' = -c between fixed walls gives c y (H - y) / 2.
  std::vector<double> Fc(N + 1, 0.0);
  Fc[0] = -c;
  tau_helmholtz<double>(N, 0.0, H, Fc.data(), 0.0, 0.0, a.data(), ws);
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
