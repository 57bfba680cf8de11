// Validation of the independent slit Green's function reference (tests/support/slit_green_reference.*)
// by properties that a wrong reference would fail: no slip, reciprocity, incompressibility, the
// plane-averaged flow (docs/validation.md, VD 5), Blake's single-wall solution for a wide slit,
// Faxen's two-wall mid-plane mobility (which plain superposition of two single walls misses), and
// the truncation contract (tolerance honoured, domain_error in the source plane).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "support/slit_green_reference.hpp"
#include "support/test_util.hpp"

using capsflow::test::SlitRefGeometry;
using capsflow::test::slit_green_tensor;
using capsflow::test::slit_green_velocity;
using capsflow::test::slit_green_wall_tensor;

namespace {

constexpr double kPi = 3.14159265358979323846;

using Mat = double[3][3];

double max_abs(const Mat& G) {
  double m = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m = std::max(m, std::abs(G[i][j]));
  return m;
}

double max_abs_diff(const Mat& A, const Mat& B) {
  double m = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m = std::max(m, std::abs(A[i][j] - B[i][j]));
  return m;
}

// Oseen tensor (I + rr/r^2)/(8 pi mu r).
void oseen(const double r[3], double mu, Mat& G) {
  const double rr = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) G[i][j] = ((i == j ? 1.0 : 0.0) / rr + r[i] * r[j] / (rr * rr * rr)) / (8 * kPi * mu);
}

// Blake (1971): Stokeslet at x0 (height h = x0[1] above a no-slip wall y = 0) plus its image system:
//   8 pi mu G_ij = (d_ij/r + r_i r_j/r^3) - (d_ij/R + R_i R_j/R^3)
//                  + 2h M_jk d/dR_k [ h R_i/R^3 - (d_in/R + R_i R_n/R^3) ],
// r = x - x0, R = x - x0* (x0* mirrored in the wall), n the wall normal (index 1), M = diag(1, -1, 1).
void blake(const double x0[3], const double x[3], double mu, Mat& G) {
  constexpr int n = 1;
  const double h = x0[1];
  double r[3], R[3];
  for (int i = 0; i < 3; ++i) {
    r[i] = x[i] - x0[i];
    R[i] = x[i] - (i == n ? -x0[i] : x0[i]);
  }
  const double rn = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  const double Rn = std::sqrt(R[0] * R[0] + R[1] * R[1] + R[2] * R[2]);
  const double R3 = Rn * Rn * Rn, R5 = R3 * Rn * Rn;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double dij = i == j ? 1.0 : 0.0, din = i == n ? 1.0 : 0.0;
      double g = dij / rn + r[i] * r[j] / (rn * rn * rn) - dij / Rn - R[i] * R[j] / R3;
      // d/dR_k of phi_i for k = j (M is diagonal).
      const int k = j;
      const double dik = i == k ? 1.0 : 0.0, dnk = n == k ? 1.0 : 0.0;
      const double dphi = h * (dik / R3 - 3 * R[i] * R[k] / R5) + din * R[k] / R3 -
                          ((dik * R[n] + R[i] * dnk) / R3 - 3 * R[i] * R[n] * R[k] / R5);
      g += 2 * h * (j == n ? -1.0 : 1.0) * dphi;
      G[i][j] = g / (8 * kPi * mu);
    }
  }
}

// Blake tensor for a wall at y = H (mirror y -> H - y; the tensor transforms with P = diag(1,-1,1)).
void blake_top(const double x0[3], const double x[3], double H, double mu, Mat& G) {
  const double m0[3] = {x0[0], H - x0[1], x0[2]}, m[3] = {x[0], H - x[1], x[2]};
  Mat B;
  blake(m0, m, mu, B);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) G[i][j] = ((i == 1) != (j == 1) ? -1.0 : 1.0) * B[i][j];
}

double dist(const double a[3], const double b[3]) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

}  // namespace

TEST(SlitGreenReference, BlakeImplementationIsSelfConsistent) {
  // The test's own Blake tensor: no slip on the wall and the Lorentz self terms of docs/validation.md, VD 5.
  const double mu = 0.7, h = 1.3, x0[3] = {0.2, h, -0.1};
  Mat G;
  for (double px : {-1.0, 0.3, 2.0}) {
    const double x[3] = {px, 0.0, 0.5 * px + 0.1};
    blake(x0, x, mu, G);
    EXPECT_LT(max_abs(G), 1e-15);
  }
  // Wall part at the source: Blake minus Oseen, evaluated just off the source.
  const double eps = 1e-5, x[3] = {x0[0] + eps, h, x0[2]};
  Mat O;
  const double r[3] = {x[0] - x0[0], 0, 0};  // the separation exactly as blake() sees it
  blake(x0, x, mu, G);
  oseen(r, mu, O);
  EXPECT_NEAR(G[0][0] - O[0][0], -3.0 / (32 * kPi * mu * h), 1e-8);
  EXPECT_NEAR(G[2][2] - O[2][2], -3.0 / (32 * kPi * mu * h), 1e-8);
  EXPECT_NEAR(G[1][1] - O[1][1], -3.0 / (16 * kPi * mu * h), 1e-8);
}

TEST(SlitGreenReference, NoSlipOnBothWalls) {
  const SlitRefGeometry g{4.0, 10.0, 8.0, 1.3};
  auto v = capsflow::test::uniform_values(4 * 12, 0.0, 1.0, 11);
  for (int t = 0; t < 12; ++t) {
    const double* p = &v[4 * t];
    const double src[3] = {10.0 * p[0], 0.3 + 3.4 * p[1], 8.0 * p[2]};
    const double wall = t % 2 == 0 ? 0.0 : g.H;
    const double tgt[3] = {src[0] + 2.0 * (p[3] - 0.5), wall, src[2] + 1.5 * (p[3] - 0.3)};
    Mat G;
    slit_green_tensor(g, src, tgt, G, 1e-13);
    const double scale = 1.0 / (8 * kPi * g.mu * dist(src, tgt));
    EXPECT_LT(max_abs(G), 1e-12 * scale) << "target on wall y = " << wall;
    // And the result is not trivially zero just inside the slit.
    const double tin[3] = {tgt[0], wall == 0.0 ? 0.05 : g.H - 0.05, tgt[2]};
    slit_green_tensor(g, src, tin, G, 1e-13);
    EXPECT_GT(max_abs(G), 1e-3 * scale);
  }
}

TEST(SlitGreenReference, Reciprocity) {
  const SlitRefGeometry g{5.0, 10.0, 7.0, 0.8};
  auto v = capsflow::test::uniform_values(6 * 20, 0.0, 1.0, 5);
  for (int t = 0; t < 20; ++t) {
    const double* p = &v[6 * t];
    const double a[3] = {10.0 * p[0], 0.2 + 4.6 * p[1], 7.0 * p[2]};
    double b[3] = {a[0] + 3.0 * (p[3] - 0.5), 0.2 + 4.6 * p[4], a[2] + 3.0 * (p[5] - 0.5)};
    if (std::abs(b[1] - a[1]) < 0.2) b[1] = a[1] + (a[1] < 2.5 ? 0.3 : -0.3);
    Mat Gab, Gba;
    slit_green_tensor(g, a, b, Gab, 1e-13);
    slit_green_tensor(g, b, a, Gba, 1e-13);
    const double scale = 1.0 / (8 * kPi * g.mu * dist(a, b));
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(Gab[i][j], Gba[j][i], 1e-11 * scale) << i << j;
    // The wall part is reciprocal too, including in the source plane.
    const double c[3] = {b[0], a[1], b[2]};
    slit_green_wall_tensor(g, a, c, Gab, 1e-13);
    slit_green_wall_tensor(g, c, a, Gba, 1e-13);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(Gab[i][j], Gba[j][i], 1e-11 * scale) << i << j;
  }
}

TEST(SlitGreenReference, Incompressible) {
  // Fourth-order central differences of u = G F; |div u| relative to |grad u| ~ |u| / r.
  const SlitRefGeometry g{4.0, 10.0, 10.0, 1.0};
  const double src[3] = {1.0, 1.5, 2.0};
  const double F[3] = {0.7, -1.1, 0.4};
  const double tgts[4][3] = {{1.3, 2.1, 2.2}, {0.2, 0.9, 3.5}, {6.0, 3.7, 7.0}, {1.1, 0.2, 1.8}};
  for (const auto& x : tgts) {
    const double r = dist(src, x), hs = 3e-3 * r;
    double div = 0.0, dmax = 0.0;
    for (int c = 0; c < 3; ++c) {
      double acc = 0.0;
      const double w[4] = {1.0 / 12, -8.0 / 12, 8.0 / 12, -1.0 / 12};
      const double off[4] = {-2, -1, 1, 2};
      for (int s = 0; s < 4; ++s) {
        double y[3] = {x[0], x[1], x[2]}, u[3];
        y[c] += off[s] * hs;
        slit_green_velocity(g, src, F, y, u, 1e-13);
        acc += w[s] * u[c];
      }
      div += acc / hs;
      dmax = std::max(dmax, std::abs(acc / hs));
    }
    const double grad_scale = 1.0 / (8 * kPi * g.mu * r * r);  // |F| ~ 1.4
    std::printf("r = %.3f: div u = %.3e, max |du_i/dx_i| = %.3e, 1/(8 pi mu r^2) = %.3e\n", r, div, dmax,
                grad_scale);
    EXPECT_LT(std::abs(div), 1e-8 * grad_scale);
    EXPECT_GT(dmax, 1e-2 * grad_scale);  // the cancellation is not trivial
  }
}

TEST(SlitGreenReference, PlaneAverageIsTheShearFlowOfValidationData) {
  // Trapezoid rule on an N x N grid of a plane y = const integrates every Fourier mode with
  // |nx|, |nz| < N exactly; aliased modes are ~exp(-2 pi N |y - y0| / L) ~ 1e-9 here.
  const SlitRefGeometry g{4.0, 10.0, 9.0, 1.7};
  const double h = 1.3, src[3] = {2.0, h, 3.0};
  const double A = g.Lx * g.Lz;
  const int N = 32;
  for (double y : {0.3, 2.5, 3.6}) {
    double mean[3][3] = {{0}};
    for (int a = 0; a < N; ++a)
      for (int b = 0; b < N; ++b) {
        const double tgt[3] = {g.Lx * a / N, y, g.Lz * b / N};
        Mat G;
        slit_green_tensor(g, src, tgt, G, 1e-8);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) mean[i][j] += G[i][j] / (N * N);
      }
    // VD 5 (docs/validation.md): F/(mu A) y (H - h)/H below the force, F/(mu A) h (H - y)/H above; no mean
    // flow from a wall-normal force and no net wall-normal flux.
    const double expect = (y < h ? y * (g.H - h) : h * (g.H - y)) / (g.mu * A * g.H);
    const double tolabs = 1e-7 * expect;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        EXPECT_NEAR(mean[i][j], (i == j && i != 1) ? expect : 0.0, tolabs) << "y = " << y << " ij " << i << j;
  }
}

TEST(SlitGreenReference, WideSlitApproachesBlake) {
  // Force at h = 1 above the bottom wall; target off the source plane. The top wall and the periodic
  // images are finite-size corrections that must shrink as H and the periods grow.
  const double mu = 1.0, h = 1.0;
  const double off[2][3] = {{0.3, 0.4, -0.2}, {-0.5, -0.6, 0.8}};
  for (const auto& o : off) {
    double prev = 1e300;
    for (double H : {8.0, 16.0, 32.0}) {
      const SlitRefGeometry g{H, 2 * H, 2 * H, mu};
      const double src[3] = {0.1 * H, h, 0.2 * H};
      const double tgt[3] = {src[0] + o[0], src[1] + o[1], src[2] + o[2]};
      Mat S, B, O;
      slit_green_tensor(g, src, tgt, S, 1e-9);
      blake(src, tgt, mu, B);
      const double r[3] = {o[0], o[1], o[2]};
      oseen(r, mu, O);
      double wall_blake[3][3];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) wall_blake[i][j] = B[i][j] - O[i][j];
      const double err = max_abs_diff(S, B) / max_abs(wall_blake);
      std::printf("H = L/2 = %4.0f: max |G_slit - G_Blake| / max |G_Blake - G_Oseen| = %.3e\n", H, err);
      EXPECT_LT(err, 0.6 * prev);
      prev = err;
    }
    EXPECT_LT(prev, 0.01);
  }
}

TEST(SlitGreenReference, MidplaneMobilityIsFaxenNotSuperposition) {
  // Point force at the mid-plane of a slit of half-width l = 1: the wall correction to the parallel
  // mobility is -c F/(6 pi mu l) with Faxen's c = 1.004; superposing two single walls (two Lorentz
  // images) gives c = 2 * 9/16 = 1.125. The periodic lattice adds an exact 1/L term, removed by
  // Richardson extrapolation from L and 2L.
  const double mu = 1.0, l = 1.0, H = 2 * l;
  auto coef = [&](double L) {
    const SlitRefGeometry g{H, L, L, mu};
    const double src[3] = {0.3, l, 0.7};
    Mat W;
    slit_green_wall_tensor(g, src, src, W, 1e-12);
    EXPECT_NEAR(W[0][0], W[2][2], 1e-12);
    EXPECT_NEAR(W[0][1], 0.0, 1e-12);
    return -6 * kPi * mu * l * W[0][0];
  };
  const double c40 = coef(40.0), c80 = coef(80.0), c160 = coef(160.0);
  // c(L) = c + a/L + b/L^2 + ...: eliminate a and b from L = 40, 80, 160.
  const double ext1 = 2 * c80 - c40, ext2 = 2 * c160 - c80, ext = (4 * ext2 - ext1) / 3;
  std::printf("Faxen coefficient: L=40 %.6f, L=80 %.6f, L=160 %.6f, extrapolated %.6f\n", c40, c80, c160, ext);
  EXPECT_NEAR(ext, 1.004, 5e-4);
  EXPECT_NEAR(ext1, ext2, 2e-3);
  EXPECT_GT(std::abs(ext - 1.125), 0.1);

  // Off the source plane the two-wall velocity differs from superposition of two Blake solutions
  // by an O(1) fraction of the wall-induced flow.
  const SlitRefGeometry g{H, 40.0, 40.0, mu};
  const double src[3] = {0.0, l, 0.0}, tgt[3] = {0.4, l + 0.5, -0.3};
  Mat S, Bb, Bt, O, sup;
  slit_green_tensor(g, src, tgt, S, 1e-11);
  blake(src, tgt, mu, Bb);
  blake_top(src, tgt, H, mu, Bt);
  const double r[3] = {tgt[0] - src[0], tgt[1] - src[1], tgt[2] - src[2]};
  oseen(r, mu, O);
  double wall[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      sup[i][j] = Bb[i][j] + Bt[i][j] - O[i][j];
      wall[i][j] = S[i][j] - O[i][j];
    }
  const double rel = max_abs_diff(S, sup) / max_abs(wall);
  std::printf("two walls vs superposition: max diff / max wall-induced = %.3f\n", rel);
  EXPECT_GT(rel, 0.1);
}

TEST(SlitGreenReference, FreeSpacePartDependsOnlyOnSeparation) {
  // G - G_wall is the doubly periodic free-space Stokeslet (k = 0 mode removed): it must not depend
  // on H or on the source height, only on the separation. As L grows it tends to the Oseen tensor
  // plus an O(1/L) lattice term.
  const double d[3] = {0.35, 0.45, -0.25};
  Mat ref{};
  bool first = true;
  for (double H : {3.0, 6.0})
    for (double y0 : {1.0, 1.7}) {
      const SlitRefGeometry g{H, 12.0, 9.0, 1.2};
      const double src[3] = {0.5, y0, 0.2}, tgt[3] = {src[0] + d[0], src[1] + d[1], src[2] + d[2]};
      Mat G, W, D;
      slit_green_tensor(g, src, tgt, G, 1e-12);
      slit_green_wall_tensor(g, src, tgt, W, 1e-12);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) D[i][j] = G[i][j] - W[i][j];
      if (first) {
        std::copy(&D[0][0], &D[0][0] + 9, &ref[0][0]);
        first = false;
      } else {
        EXPECT_LT(max_abs_diff(D, ref), 1e-10 * max_abs(ref));
      }
    }
  // Near the source the lattice term is a smooth O(1/L) field: L (G - G_wall - G_Oseen) converges.
  Mat prevD{};
  for (double L : {10.0, 20.0, 40.0}) {
    const SlitRefGeometry g{3.0, L, L, 1.0};
    const double src[3] = {0.0, 1.0, 0.0}, tgt[3] = {d[0], 1.0 + d[1], d[2]};
    Mat G, W, O, D;
    slit_green_tensor(g, src, tgt, G, 1e-10);
    slit_green_wall_tensor(g, src, tgt, W, 1e-10);
    oseen(d, 1.0, O);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) D[i][j] = L * (G[i][j] - W[i][j] - O[i][j]);
    const double e = max_abs(D) / L / max_abs(O), change = max_abs_diff(D, prevD) / max_abs(D);
    std::printf("L = %4.0f: max |G - G_wall - G_Oseen| / max |G_Oseen| = %.3e, change of L x it: %.3e\n", L, e,
                change);
    if (L == 40.0) {
      EXPECT_LT(change, 0.05);
    }
    EXPECT_LT(e, 2.5 / L);
    std::copy(&D[0][0], &D[0][0] + 9, &prevD[0][0]);
  }
}

TEST(SlitGreenReference, ToleranceIsHonouredAndSourcePlaneThrows) {
  const SlitRefGeometry g{6.0, 10.0, 10.0, 1.0};
  const double src[3] = {1.0, 2.0, 3.0};
  for (double dy : {0.1, 0.5, 2.0}) {
    const double tgt[3] = {1.4, 2.0 + dy, 2.7};
    Mat lo, hi;
    slit_green_tensor(g, src, tgt, hi, 1e-13);
    const double scale = 1.0 / (8 * kPi * g.mu * dist(src, tgt));
    for (double tol : {1e-4, 1e-7, 1e-10}) {
      slit_green_tensor(g, src, tgt, lo, tol);
      const double err = max_abs_diff(lo, hi);
      EXPECT_LT(err, tol * scale) << "dy " << dy << " tol " << tol;
      // The truncation is not wildly conservative either (the error is not far below tol).
      if (tol >= 1e-7) {
        EXPECT_GT(err, 1e-7 * tol * scale) << "dy " << dy << " tol " << tol;
      }
    }
    slit_green_wall_tensor(g, src, tgt, lo, 1e-6);
    slit_green_wall_tensor(g, src, tgt, hi, 1e-13);
    EXPECT_LT(max_abs_diff(lo, hi), 1e-6 / (8 * kPi * g.mu * 2.0 * src[1]));
  }
  Mat G;
  const double inplane[3] = {1.5, 2.0, 3.0};
  EXPECT_THROW(slit_green_tensor(g, src, inplane, G), std::domain_error);
  const double near[3] = {1.5, 2.0 + 1e-7, 3.0};
  EXPECT_THROW(slit_green_tensor(g, src, near, G, 1e-10), std::domain_error);
  EXPECT_NO_THROW(slit_green_wall_tensor(g, src, inplane, G));
  EXPECT_NO_THROW(slit_green_wall_tensor(g, src, src, G));
  const double outside[3] = {0.0, 6.5, 0.0}, onwall[3] = {0.0, 0.0, 0.0};
  EXPECT_THROW(slit_green_tensor(g, src, outside, G), std::invalid_argument);
  EXPECT_THROW(slit_green_tensor(g, onwall, src, G), std::invalid_argument);
}

TEST(SlitGreenReference, CostOfTypicalEvaluations) {
  // The cost is the number of Fourier modes summed (the time per tensor is printed, not judged: timing belongs to
  // bench/). Each mode's term decays like exp(-k |y - y0|), so a closer target needs more modes to reach the same
  // tolerance: the count must fall as |y - y0| grows.
  for (double H : {4.0, 10.0}) {
    std::size_t previous = 0;
    for (double dy : {0.1, 0.3, 1.0}) {
      const SlitRefGeometry g{H, 10.0, 10.0, 1.0};
      const double src[3] = {3.0, 0.5 * H, 4.0}, tgt[3] = {3.2, 0.5 * H + dy, 4.1};
      Mat G;
      const auto t0 = std::chrono::steady_clock::now();
      slit_green_tensor(g, src, tgt, G, 1e-10);
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const std::size_t nm = capsflow::test::slit_green_mode_count(g, src, tgt, 1e-10);
      std::printf("H = %4.1f, L = 10, |y - y0| = %.1f: %zu modes, %.2e s per tensor\n", H, dy, nm, sec);
      EXPECT_GT(nm, 0u);
      if (previous > 0) {
        EXPECT_LT(nm, previous) << "H = " << H << ", |y - y0| = " << dy;
      }
      previous = nm;
    }
  }
}
