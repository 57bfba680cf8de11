// Kernel identities of the GGEM splitting (docs/method.md §1.1).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "kernels/ggem_kernels.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

TEST(GgemKernels, LocalPlusGlobalIsStokeslet) {
  const double alpha = 4.0;
  auto v = test::uniform_values(6 * 200, -1.5, 1.5, 7);
  for (int i = 0; i < 200; ++i) {
    const double* p = &v[6 * i];
    double ul[3] = {0, 0, 0}, us[3] = {0, 0, 0};
    ggem_local_add(alpha, p[0], p[1], p[2], p[3], p[4], p[5], ul[0], ul[1], ul[2]);
    ggem_global_free_add(alpha, p[0], p[1], p[2], p[3], p[4], p[5], ul[0], ul[1], ul[2]);
    stokeslet_add(p[0], p[1], p[2], p[3], p[4], p[5], us[0], us[1], us[2]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(ul[c], us[c], 1e-12 * (1.0 + std::abs(us[c])));
  }
}

TEST(GgemKernels, ScreeningHasUnitMassAndZeroSecondMoment) {
  // Radial integrals 4 pi int r^2 g dr and 4 pi int r^4 g dr by composite Simpson on [0, 10/alpha].
  for (double alpha : {2.0, 4.0, 6.0}) {
    const int n = 20000;
    const double R = 10.0 / alpha, h = R / n;
    double m0 = 0.0, m2 = 0.0;
    for (int i = 0; i <= n; ++i) {
      const double r = i * h, w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
      const double g = ggem_screen(alpha, r * r);
      m0 += w * 4.0 * kPi * r * r * g;
      m2 += w * 4.0 * kPi * r * r * r * r * g;
    }
    m0 *= h / 3.0;
    m2 *= h / 3.0;
    EXPECT_NEAR(m0, 1.0, 1e-12) << "alpha " << alpha;
    EXPECT_NEAR(m2 * alpha * alpha, 0.0, 1e-12) << "alpha " << alpha;
  }
}

TEST(GgemKernels, GlobalSelfTermAndContinuityAtOrigin) {
  const double alpha = 4.0;
  double u[3] = {0, 0, 0};
  ggem_global_free_add(alpha, 0.0, 0.0, 0.0, 1.0, 2.0, -3.0, u[0], u[1], u[2]);
  const double g0 = 4.0 * alpha / kSqrtPi;
  EXPECT_DOUBLE_EQ(u[0], g0);
  EXPECT_DOUBLE_EQ(u[1], 2.0 * g0);
  EXPECT_DOUBLE_EQ(u[2], -3.0 * g0);
  // The series branch (alpha r < 1e-4) and the closed form agree across the switch.
  for (double r : {0.99e-4 / alpha, 1.01e-4 / alpha}) {
    double a[3] = {0, 0, 0};
    ggem_global_free_add(alpha, r * 0.6, r * 0.8, 0.0, 1.0, 0.5, 0.25, a[0], a[1], a[2]);
    EXPECT_NEAR(a[0], g0, 1e-6 * g0);
  }
}

TEST(GgemKernels, CoincidentTargetGetsRegularPart) {
  // At r = 0 the local kernel returns -G_g(0): the Stokeslet of the source itself removed.
  const double alpha = 3.0;
  double u[3] = {0, 0, 0};
  ggem_local_add(alpha, 0.0, 0.0, 0.0, 1.0, -1.0, 2.0, u[0], u[1], u[2]);
  const double g0 = 4.0 * alpha / kSqrtPi;
  EXPECT_DOUBLE_EQ(u[0], -g0);
  EXPECT_DOUBLE_EQ(u[2], -2.0 * g0);
  // and the local kernel near r -> 0 minus the Stokeslet tends to the same limit.
  const double r = 1e-5;
  double a[3] = {0, 0, 0};
  ggem_local_add(alpha, r, 0.0, 0.0, 0.0, 1.0, 0.0, a[0], a[1], a[2]);
  stokeslet_add(-r, 0.0, 0.0, 0.0, -1.0, 0.0, a[0], a[1], a[2]);  // subtract S(r).f
  EXPECT_NEAR(a[1], -g0, 1e-6 * g0);
}

TEST(GgemKernels, LocalKernelNegligibleAtCutoff) {
  // At alpha r = 4 the local kernel is about 5e-7 of the Stokeslet (docs/method.md §1.1).
  const double alpha = 4.0, r = 4.0 / alpha;
  double ul[3] = {0, 0, 0}, us[3] = {0, 0, 0};
  ggem_local_add(alpha, r, 0, 0, 0, 1, 0, ul[0], ul[1], ul[2]);
  stokeslet_add(r, 0, 0, 0, 1, 0, us[0], us[1], us[2]);
  EXPECT_LT(std::abs(ul[1] / us[1]), 1e-6);
  EXPECT_GT(std::abs(ul[1] / us[1]), 1e-8);
}

TEST(GgemKernels, TabulatedLocalKernelMatchesClosedForm) {
  // ggem_local_add_tabulated (the element integrals' kernel) against ggem_local_add (erfc, exp) for alpha r in
  // [1e-6, 7] (table, both interval kinds, and the closed-form fallback beyond alpha r = 6), several alpha. Errors
  // relative to the Stokeslet term |f|/r and to the screened value itself.
  double worst_stk = 0.0, worst_rel = 0.0;
  for (double alpha : {1.0, 4.0, 9.5}) {
    const auto v = test::uniform_values(5 * 4000, 0.0, 1.0, 31);
    for (int i = 0; i < 4000; ++i) {
      const double* p = &v[5 * static_cast<std::size_t>(i)];
      const double x = i < 200 ? std::pow(10.0, -6.0 + 6.0 * p[0]) : 7.0 * p[0];  // alpha r
      const double ct = 2.0 * p[1] - 1.0, ph = 2.0 * kPi * p[2], st = std::sqrt(1.0 - ct * ct);
      const double r = x / alpha, rx = r * st * std::cos(ph), ry = r * st * std::sin(ph), rz = r * ct;
      const double fx = p[3] - 0.5, fy = p[4] - 0.5, fz = 0.3;
      double a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
      ggem_local_add(alpha, rx, ry, rz, fx, fy, fz, a[0], a[1], a[2]);
      ggem_local_add_tabulated(alpha, rx, ry, rz, fx, fy, fz, b[0], b[1], b[2]);
      const double fn = std::sqrt(fx * fx + fy * fy + fz * fz);
      const double an = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
      for (int c = 0; c < 3; ++c) {
        worst_stk = std::max(worst_stk, std::fabs(a[c] - b[c]) * r / fn);
        if (x < 5.5) worst_rel = std::max(worst_rel, std::fabs(a[c] - b[c]) / an);  // screened value > 1e-14 of |f|/r
      }
    }
  }
  std::printf("  tabulated G_l vs erfc/exp: %.1e relative to |f|/r, %.1e relative to |G_l f|\n", worst_stk, worst_rel);
  EXPECT_LT(worst_stk, 4e-15);
  EXPECT_LT(worst_rel, 1e-12);
}
