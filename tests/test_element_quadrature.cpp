// Element integrals of the local single layer (docs/method_quadrature.md, D4, P6): accuracy against an independent
// reference, exactness of the tables, invariances, and the exact Stokeslet identities on a closed sphere mesh.
//
// The accuracy tables of docs/method_quadrature.md are printed by these tests:
//     ctest --test-dir build/q -R Quadrature -V      (or run build/q/tests/test_element_quadrature directly)
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <utility>
#include <vector>

#include "kernels/element_quadrature.hpp"
#include "support/test_util.hpp"

namespace capsflow::test {
namespace {

using Vec3 = std::array<double, 3>;
using Elem = std::array<double, 9>;

constexpr double kAlpha = 4.0;  // the defaults: a = 1, alpha = 4 (r_c = a)

// ---------------------------------------------------------------------------------------------------------------
// Independent reference: Gauss-Legendre by Newton iteration (not the library tables) and adaptive 4-way subdivision
// down to sub-elements with d/h_sub >= 3, each integrated by a 16 x 16 conical-product rule written here.

struct GaussRule {
  std::vector<double> x, w;
};

GaussRule newton_gauss(int n) {
  GaussRule g;
  for (int i = 0; i < n; ++i) {
    long double x = std::cos(3.14159265358979323846264338L * (i + 0.75L) / (n + 0.5L)), dp = 1.0L;
    for (int it = 0; it < 100; ++it) {
      long double p0 = 1.0L, p1 = x;
      for (int j = 2; j <= n; ++j) {
        const long double p2 = ((2 * j - 1) * x * p1 - (j - 1) * p0) / j;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1.0L, p1 = x;
      dp = n * (x * p1 - p0) / (x * x - 1.0L);
      const long double dx = p1 / dp;
      x -= dx;
      if (std::fabs(dx) < 1e-30L) break;
    }
    if (n == 1) x = 0.0L, dp = 1.0L;
    g.x.push_back(static_cast<double>(x));
    g.w.push_back(static_cast<double>(2.0L / ((1.0L - x * x) * dp * dp)));
  }
  return g;
}

using KernelFn = std::function<void(const Vec3& r, const Vec3& f, Vec3& u)>;

// G_l as Stokeslet minus G_g: exact down to r = 0, whereas ggem_local_add treats alpha r < 1e-9 as coincident (that
// cut-off drops the 1/r mass of a disc of radius 2.5e-10, ~3e-10 absolute, which the deep reference would feel).
KernelFn local_kernel(double alpha) {
  return [alpha](const Vec3& r, const Vec3& f, Vec3& u) {
    Vec3 g{0, 0, 0};
    ggem_global_free_add(alpha, r[0], r[1], r[2], f[0], f[1], f[2], g[0], g[1], g[2]);
    stokeslet_add(r[0], r[1], r[2], f[0], f[1], f[2], u[0], u[1], u[2]);
    for (int c = 0; c < 3; ++c) u[c] -= g[c];
  };
}
KernelFn stokeslet_kernel() {
  return [](const Vec3& r, const Vec3& f, Vec3& u) {
    stokeslet_add(r[0], r[1], r[2], f[0], f[1], f[2], u[0], u[1], u[2]);
  };
}
double dist_point_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  Vec3 ab{}, ap{};
  for (int c = 0; c < 3; ++c) ab[c] = b[c] - a[c], ap[c] = p[c] - a[c];
  double t = (ab[0] * ap[0] + ab[1] * ap[1] + ab[2] * ap[2]) / (ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]);
  t = std::clamp(t, 0.0, 1.0);
  double d2 = 0.0;
  for (int c = 0; c < 3; ++c) d2 += (ap[c] - t * ab[c]) * (ap[c] - t * ab[c]);
  return std::sqrt(d2);
}

// Distance point-triangle written independently of the library: plane projection if inside, else nearest edge.
double ref_distance(const Vec3& p, const Elem& v) {
  const Vec3 a{v[0], v[1], v[2]}, b{v[3], v[4], v[5]}, c{v[6], v[7], v[8]};
  Vec3 e1{}, e2{}, n{};
  for (int k = 0; k < 3; ++k) e1[k] = b[k] - a[k], e2[k] = c[k] - a[k];
  n = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (auto& x : n) x /= nn;
  const double h = (p[0] - a[0]) * n[0] + (p[1] - a[1]) * n[1] + (p[2] - a[2]) * n[2];
  Vec3 q{};
  for (int k = 0; k < 3; ++k) q[k] = p[k] - h * n[k];
  auto side = [&](const Vec3& s, const Vec3& t) {
    const Vec3 st{t[0] - s[0], t[1] - s[1], t[2] - s[2]}, sq{q[0] - s[0], q[1] - s[1], q[2] - s[2]};
    const Vec3 cr{st[1] * sq[2] - st[2] * sq[1], st[2] * sq[0] - st[0] * sq[2], st[0] * sq[1] - st[1] * sq[0]};
    return cr[0] * n[0] + cr[1] * n[1] + cr[2] * n[2];
  };
  if (side(a, b) >= 0 && side(b, c) >= 0 && side(c, a) >= 0) return std::fabs(h);
  return std::min({dist_point_segment(p, a, b), dist_point_segment(p, b, c), dist_point_segment(p, c, a)});
}

double ref_longest_edge(const Elem& v) {
  double m = 0.0;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    double d2 = 0.0;
    for (int c = 0; c < 3; ++c) d2 += (v[3 * j + c] - v[3 * i + c]) * (v[3 * j + c] - v[3 * i + c]);
    m = std::max(m, d2);
  }
  return std::sqrt(m);
}

// Conical-product rule on a (sub-)triangle; f given at the sub-triangle corners.
void ref_leaf(const KernelFn& k, const Vec3& x, const Elem& v, const Elem& f, const GaussRule& g, Vec3& u) {
  Vec3 e1{}, e2{};
  for (int c = 0; c < 3; ++c) e1[c] = v[3 + c] - v[c], e2[c] = v[6 + c] - v[c];
  const Vec3 cr{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double jac = std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
  const std::size_t n = g.x.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double s = 0.5 * (1.0 + g.x[i]);  // l1 + l2 = s
    for (std::size_t j = 0; j < n; ++j) {
      const double t = 0.5 * (1.0 + g.x[j]);
      const double l1 = s * (1.0 - t), l2 = s * t, l0 = 1.0 - s;
      const double w = 0.25 * g.w[i] * g.w[j] * s * jac;
      Vec3 r{}, fy{};
      for (int c = 0; c < 3; ++c) {
        r[c] = x[c] - (l0 * v[c] + l1 * v[3 + c] + l2 * v[6 + c]);
        fy[c] = w * (l0 * f[c] + l1 * f[3 + c] + l2 * f[6 + c]);
      }
      k(r, fy, u);
    }
  }
}

void ref_recurse(const KernelFn& k, const Vec3& x, const Elem& v, const Elem& f, const GaussRule& g, int depth,
                 Vec3& u) {
  const double h = ref_longest_edge(v), d = ref_distance(x, v);
  if (d >= 3.0 * h || depth >= 44) {
    ref_leaf(k, x, v, f, g, u);
    return;
  }
  auto mid = [](const Elem& a, int i, int j, int c) { return 0.5 * (a[3 * i + c] + a[3 * j + c]); };
  Elem mv{}, mf{};
  for (int c = 0; c < 3; ++c) {
    mv[c] = mid(v, 0, 1, c), mv[3 + c] = mid(v, 1, 2, c), mv[6 + c] = mid(v, 2, 0, c);
    mf[c] = mid(f, 0, 1, c), mf[3 + c] = mid(f, 1, 2, c), mf[6 + c] = mid(f, 2, 0, c);
  }
  // corners: (0, m01, m20), (m01, 1, m12), (m20, m12, 2), (m01, m12, m20)
  const int idx[4][3] = {{0, 3, 5}, {3, 1, 4}, {5, 4, 2}, {3, 4, 5}};
  for (const auto& t : idx) {
    Elem sv{}, sf{};
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 3; ++c) {
        const int q = t[i];
        sv[3 * i + c] = q < 3 ? v[3 * q + c] : mv[3 * (q - 3) + c];
        sf[3 * i + c] = q < 3 ? f[3 * q + c] : mf[3 * (q - 3) + c];
      }
    ref_recurse(k, x, sv, sf, g, depth + 1, u);
  }
}

Vec3 reference(const KernelFn& k, const Vec3& x, const Elem& v, const Elem& f) {
  static const GaussRule g = newton_gauss(16);
  Vec3 u{0, 0, 0};
  ref_recurse(k, x, v, f, g, 0, u);
  return u;
}

// ---------------------------------------------------------------------------------------------------------------
// Library calls and helpers.

Vec3 quad_local(const Vec3& x, const Elem& v, const Elem& f, int sv, const QuadratureOrders& q,
                double alpha = kAlpha) {
  Vec3 u{0, 0, 0};
  element_single_layer_add(alpha, x.data(), v.data(), f.data(), sv, q, u.data());
  return u;
}

// Counts kernel evaluations (cost column of the tables).
struct CountingKernel {
  double alpha;
  long* count;
  void add(double rx, double ry, double rz, double fx, double fy, double fz, double& ux, double& uy,
           double& uz) const {
    ++*count;
    ggem_local_add(alpha, rx, ry, rz, fx, fy, fz, ux, uy, uz);
  }
};

long count_evals(const Vec3& x, const Elem& v, const Elem& f, int sv, const QuadratureOrders& q) {
  long n = 0;
  Vec3 u{0, 0, 0};
  element_integral_add(CountingKernel{kAlpha, &n}, x.data(), v.data(), f.data(), sv, q, u.data());
  return n;
}

double rel_err(const Vec3& a, const Vec3& b) {
  double e = 0.0, m = 0.0;
  for (int c = 0; c < 3; ++c) e = std::max(e, std::fabs(a[c] - b[c])), m = std::max(m, std::fabs(b[c]));
  return e / m;
}

// The test element: scalene, longest edge 0.3 (a 0.3a element), tilted out of the coordinate planes.
Elem test_element() {
  const Elem flat{0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.11, 0.24, 0.0};
  // Rotate about the axis (1, 2, 3)/sqrt(14) by 0.7 rad and shift.
  const double ax[3] = {1 / std::sqrt(14.0), 2 / std::sqrt(14.0), 3 / std::sqrt(14.0)}, th = 0.7;
  const double cs = std::cos(th), sn = std::sin(th);
  Elem v{};
  for (int i = 0; i < 3; ++i) {
    const double* p = &flat[3 * i];
    const double d = ax[0] * p[0] + ax[1] * p[1] + ax[2] * p[2];
    const double cr[3] = {ax[1] * p[2] - ax[2] * p[1], ax[2] * p[0] - ax[0] * p[2], ax[0] * p[1] - ax[1] * p[0]};
    for (int c = 0; c < 3; ++c) v[3 * i + c] = p[c] * cs + cr[c] * sn + ax[c] * d * (1 - cs) + 0.2 * (c + 1);
  }
  return v;
}

Elem test_density() { return {1.0, -0.4, 0.7, 0.3, 1.2, -0.5, -0.6, 0.2, 1.1}; }

Vec3 elem_normal(const Elem& v) {
  const Vec3 e1{v[3] - v[0], v[4] - v[1], v[5] - v[2]}, e2{v[6] - v[0], v[7] - v[1], v[8] - v[2]};
  Vec3 n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double m = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  for (auto& x : n) x /= m;
  return n;
}

// Point with barycentric coordinates (l0, l1, l2) (may be outside the element) lifted by height h along the normal.
Vec3 lifted(const Elem& v, double l0, double l1, double l2, double h) {
  const Vec3 n = elem_normal(v);
  Vec3 x{};
  for (int c = 0; c < 3; ++c) x[c] = l0 * v[c] + l1 * v[3 + c] + l2 * v[6 + c] + h * n[c];
  return x;
}

// Targets at closest distance d from the element in assorted directions (bisection along rays from points of e).
std::vector<Vec3> targets_at_distance(const Elem& v, double d, int count, std::uint64_t seed) {
  const auto r = uniform_values(static_cast<std::size_t>(6 * count), 0.0, 1.0, seed);
  std::vector<Vec3> out;
  for (int i = 0; i < count; ++i) {
    const double* p = &r[6 * static_cast<std::size_t>(i)];
    double l1 = p[0], l2 = p[1];
    if (l1 + l2 > 1.0) l1 = 1.0 - l1, l2 = 1.0 - l2;
    const Vec3 c0 = lifted(v, 1.0 - l1 - l2, l1, l2, 0.0);
    Vec3 dir{2 * p[2] - 1, 2 * p[3] - 1, 2 * p[4] - 1};
    const double m = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    for (auto& x : dir) x /= m;
    double lo = 0.0, hi = 1.0;
    auto at = [&](double t) { return Vec3{c0[0] + t * dir[0], c0[1] + t * dir[1], c0[2] + t * dir[2]}; };
    while (ref_distance(at(hi), v) < d) hi *= 2.0;
    for (int it = 0; it < 80; ++it) {
      const double mid = 0.5 * (lo + hi);
      (ref_distance(at(mid), v) < d ? lo : hi) = mid;
    }
    out.push_back(at(0.5 * (lo + hi)));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------------------

TEST(ElementQuadrature, GaussTablesMatchNewtonAndIntegrateMonomials) {
  for (int n = 1; n <= kMaxGaussOrder; ++n) {
    const GaussRule g = newton_gauss(n);
    std::vector<double> x(static_cast<std::size_t>(n)), w(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) x[static_cast<std::size_t>(i)] = gauss_node(n, i), w[static_cast<std::size_t>(i)] = gauss_weight(n, i);
    std::sort(x.begin(), x.end());
    std::vector<double> gx = g.x;
    std::sort(gx.begin(), gx.end());
    for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(x[i], gx[i], 2e-16) << "n " << n;
    for (int k = 0; k <= 2 * n - 1; ++k) {
      double s = 0.0;
      for (int i = 0; i < n; ++i) s += gauss_weight(n, i) * std::pow(gauss_node(n, i), k);
      const double exact = (k % 2) ? 0.0 : 2.0 / (k + 1);
      EXPECT_NEAR(s, exact, 1e-14) << "n " << n << " k " << k;
    }
  }
}

// Kernel returning y-monomials: u_x += f_x * (-r_x)^a (-r_y)^b with the target at the origin.
struct MonomialKernel {
  int a, b;
  void add(double rx, double ry, double, double fx, double, double, double& ux, double&, double&) const {
    ux += fx * std::pow(-rx, a) * std::pow(-ry, b);
  }
};

TEST(ElementQuadrature, TriangleRulesAreExactForPolynomials) {
  // Reference triangle (0,0),(1,0),(0,1): int x^a y^b = a! b! / (a + b + 2)!.
  const Elem v{0, 0, 0, 1, 0, 0, 0, 1, 0};
  const Elem f{1, 0, 0, 1, 0, 0, 1, 0, 0};
  const double x0[3] = {0, 0, 0};
  auto fact = [](int n) { return std::tgamma(n + 1.0); };
  for (int rule = 0; rule < 4; ++rule) {
    QuadratureOrders q;
    q.near_ratio = -1.0;  // everything regular
    q.far_ratio = 0.0;    // and "far"
    q.far_dunavant = rule == 0;
    q.regular_far = rule == 1 ? 3 : 6;
    if (rule == 3) {  // the 16-point symmetric rule everywhere
      q.mid_ratio = q.outer_ratio = q.symmetric_ratio = 0.0;
      q.far_ratio = 1e300;
    }
    const int degree = rule == 0 ? 5 : (rule == 1 ? 4 : (rule == 2 ? 10 : 8));
    for (int a = 0; a <= degree; ++a)
      for (int b = 0; a + b <= degree; ++b) {
        double u[3] = {0, 0, 0};
        element_integral_add(MonomialKernel{a, b}, x0, v.data(), f.data(), -1, q, u);
        EXPECT_NEAR(u[0], fact(a) * fact(b) / fact(a + b + 2), 1e-15) << "rule " << rule << " a " << a << " b " << b;
      }
    if (rule == 3) {  // and not degree 9: the rule is what its name says
      double worst = 0.0;
      for (int a = 0; a <= 9; ++a) {
        double u[3] = {0, 0, 0};
        element_integral_add(MonomialKernel{a, 9 - a}, x0, v.data(), f.data(), -1, q, u);
        const double exact = fact(a) * fact(9 - a) / fact(11);
        worst = std::max(worst, std::fabs(u[0] - exact) / exact);
      }
      EXPECT_GT(worst, 1e-6);
    }
  }
}

TEST(ElementQuadrature, ReferenceIsSelfConsistentAndMatchesClosedForm) {
  // int over a flat triangle of 1/|x - y| from a vertex: int_0^beta R(theta) dtheta, R = p / cos(theta - theta_p),
  // giving p [atanh(sin(t))] between the limits. Right triangle legs p (from x) and L: p * asinh(L / p).
  const double p = 0.2, L = 0.3;
  const Elem v{0, 0, 0, p, 0, 0, p, L, 0};
  const Elem f{1, 0, 0, 1, 0, 0, 1, 0, 0};
  const KernelFn one_over_r = [](const Vec3& r, const Vec3& fy, Vec3& u) {
    u[0] += fy[0] / std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  };
  const Vec3 ref = reference(one_over_r, {0, 0, 0}, v, f);
  EXPECT_NEAR(ref[0], p * std::asinh(L / p), 1e-11);
  std::printf("closed form 1/r from a vertex: reference error %.2e\n", std::fabs(ref[0] - p * std::asinh(L / p)));
}

TEST(ElementQuadrature, RegularRuleAccuracyByDistance) {
  const Elem v = test_element(), f = test_density();
  const double h = ref_longest_edge(v);
  std::printf("\nRegular rules, element h_e = %.2f, alpha = %.0f: max error over 24 targets at distance d, relative to\n"
              "|I_l| (rel) and to the unscreened Stokeslet integral |I_S| (stk)\n", h, kAlpha);
  const std::vector<int> orders{0, -1, 4, 5, 6, 7, 8, 10, 12};  // 0: 7-point Dunavant, -1: 16-point symmetric
  std::printf("  d/h_e      |");
  for (int n : orders) n > 0 ? std::printf("  %2dx%-2d   |", n, n) : std::printf(n ? "   S16    |" : "   D7     |");
  std::printf(" default [evals]\n");
  QuadratureOrders def;
  for (double ratio : {3.0, 2.5, 2.0, 1.75, 1.5, 1.0, 0.75, 0.5, 1.0 / 3.0}) {  // < 0.5: near-singular path
    const auto xs = targets_at_distance(v, ratio * h, 24, 11);
    const std::size_t m = orders.size() + 1;
    std::vector<double> rel(m, 0.0), stk(m, 0.0);
    long evals = 0;
    for (const auto& x : xs) {
      const Vec3 ref = reference(local_kernel(kAlpha), x, v, f);
      const Vec3 refs = reference(stokeslet_kernel(), x, v, f);
      const double scale = std::sqrt(refs[0] * refs[0] + refs[1] * refs[1] + refs[2] * refs[2]);
      for (std::size_t r = 0; r < m; ++r) {
        QuadratureOrders q;
        if (r < orders.size() && orders[r] < 0) {  // the symmetric band everywhere
          q.near_ratio = -1.0;
          q.mid_ratio = q.outer_ratio = q.symmetric_ratio = 0.0;
          q.far_ratio = 1e300;
        } else if (r < orders.size()) {
          q.near_ratio = -1.0;
          q.far_ratio = 0.0;
          q.far_dunavant = orders[r] == 0;
          q.regular_far = orders[r];
        } else {
          q = def;
          evals = std::max(evals, count_evals(x, v, f, -1, q));
        }
        const Vec3 u = quad_local(x, v, f, -1, q);
        rel[r] = std::max(rel[r], rel_err(u, ref));
        double e = 0.0;
        for (int c = 0; c < 3; ++c) e = std::max(e, std::fabs(u[c] - ref[c]));
        stk[r] = std::max(stk[r], e / scale);
      }
    }
    std::printf("  %5.2f rel  |", ratio);
    for (double e : rel) std::printf(" %8.1e |", e);
    std::printf(" [%ld]\n        stk  |", evals);
    for (double e : stk) std::printf(" %8.1e |", e);
    std::printf("\n");
    // The requirement behind both bounds: each element's error at most 1e-6 of the velocity scale |I_S|, so the ~150
    // element terms of a target cannot add up to more than ~1e-5 of its velocity, 10x inside the 1e-4 that
    // DefaultOrdersAccurateOnCloseCapsules asserts for the assembly.
    EXPECT_LT(stk.back(), 1e-6) << "default rules at d/h_e = " << ratio;
    // From outer_ratio on the rules are judged by the unscreened scale only: there alpha r > 1.8 and the screened
    // element value is ~1e-2 of |I_S| (1e-4 beyond far_ratio, alpha r > 2.4), so an error of 2e-5 of it (S16,
    // d/h_e 1.5-2.5) or of a few per cent (7-point rule) is still below 1e-6 of the velocity scale. Closer in,
    // |I_l| ~ |I_S| and the relative error is the one that matters.
    if (ratio < def.outer_ratio) {
      EXPECT_LT(rel.back(), 2e-6) << "default rules at d/h_e = " << ratio;
    }
  }
  // Method-spec 5.2 setting: target above the centroid at d = 0.3 and 0.1 (one and a third of the element size).
  for (double d : {0.3, 0.1}) {
    const Vec3 x = lifted(v, 1.0 / 3, 1.0 / 3, 1.0 / 3, d);
    const Vec3 ref = reference(local_kernel(kAlpha), x, v, f);
    std::printf("  above centroid d = %.1f:", d);
    for (int n : {4, 6, 8, 12}) {
      QuadratureOrders q;
      q.near_ratio = -1.0;
      q.far_ratio = 0.0;
      q.far_dunavant = false;
      q.regular_far = n;
      std::printf("  %dx%d %.1e", n, n, rel_err(quad_local(x, v, f, -1, q), ref));
    }
    const double e = rel_err(quad_local(x, v, f, -1, def), ref);
    std::printf("  default %.1e (%ld evaluations)\n", e, count_evals(x, v, f, -1, def));
    EXPECT_LT(e, 1e-6);
  }
}

TEST(ElementQuadrature, SingularRuleConvergesWithOrder) {
  const Elem v = test_element(), f = test_density();
  std::printf("\nSingular (polar about the vertex) rule, element h_e = 0.3, relative error:\n  vertex |");
  const std::vector<int> orders{2, 3, 4, 6, 8, 10, 14, 20};
  for (int n : orders) std::printf("  %2dx%-2d  |", n, n);
  std::printf("\n");
  for (int k = 0; k < 3; ++k) {
    const Vec3 x{v[3 * k], v[3 * k + 1], v[3 * k + 2]};
    const Vec3 ref = reference(local_kernel(kAlpha), x, v, f);
    std::printf("  %6d |", k);
    double prev = 1.0;
    for (int n : orders) {
      QuadratureOrders q;
      q.singular = n;
      const double e = rel_err(quad_local(x, v, f, k, q), ref);
      std::printf(" %8.1e |", e);
      if (n <= 6) {
        EXPECT_LT(e, prev) << "vertex " << k << " order " << n;
      }
      prev = e;
      if (n == 6) {
        EXPECT_LT(e, 3e-6) << "vertex " << k;
      }
      if (n == 10) {
        EXPECT_LT(e, 1e-9) << "vertex " << k;
      }
    }
    std::printf("\n");
  }
  std::printf("  vertex-polar (singular_method = VertexPolar), same orders:\n");
  for (int k = 0; k < 3; ++k) {
    const Vec3 x{v[3 * k], v[3 * k + 1], v[3 * k + 2]};
    const Vec3 ref = reference(local_kernel(kAlpha), x, v, f);
    std::printf("  %6d |", k);
    for (int n : orders) {
      QuadratureOrders q;
      q.singular = n;
      q.singular_method = SingularMethod::VertexPolar;
      std::printf(" %8.1e |", rel_err(quad_local(x, v, f, k, q), ref));
    }
    QuadratureOrders q6;
    q6.singular_method = SingularMethod::VertexPolar;
    std::printf("  [6: %ld evaluations]\n", count_evals(x, v, f, k, q6));
  }
  // Unflagged vertex target (singular_vertex = -1) goes through the near-singular path and stays accurate.
  const Vec3 x0{v[0], v[1], v[2]};
  EXPECT_LT(rel_err(quad_local(x0, v, f, -1, QuadratureOrders{}), reference(local_kernel(kAlpha), x0, v, f)), 1e-6);
}

struct NearCase {
  const char* name;
  double l0, l1, l2;  // barycentric coordinates of the projection (may be outside)
};

const std::vector<NearCase> kNearCases{
    {"centroid", 1.0 / 3, 1.0 / 3, 1.0 / 3}, {"interior", 0.15, 0.6, 0.25},
    {"edge midpoint", 0.5, 0.5, 0.0},        {"on edge near vertex", 0.97, 0.03, 0.0},
    {"near vertex", 0.99, 0.006, 0.004},     {"above vertex", 1.0, 0.0, 0.0},
    {"outside edge", 0.5, 0.51, -0.01},      {"outside vertex", 1.01, -0.005, -0.005},
};

TEST(ElementQuadrature, NearSingularTargets) {
  const Elem v = test_element(), f = test_density();
  const double h = ref_longest_edge(v);
  QuadratureOrders proj, sub;
  sub.near_method = NearSingularMethod::Subdivision;
  std::printf("\nNear-singular targets at height eta*h_e above points of the element plane; relative error "
              "[kernel evaluations]\n");
  std::printf("  %-20s | eta   | projection (default) | subdivision\n", "projection point");
  double worst_proj = 0.0;
  for (const auto& c : kNearCases)
    for (double eta : {0.02, 0.01, 0.005, 0.0}) {
      const Vec3 x = lifted(v, c.l0, c.l1, c.l2, eta * h);
      if (ref_distance(x, v) >= 0.5 * h) continue;
      const Vec3 ref = reference(local_kernel(kAlpha), x, v, f);
      const double ep = rel_err(quad_local(x, v, f, -1, proj), ref);
      const double es = rel_err(quad_local(x, v, f, -1, sub), ref);
      std::printf("  %-20s | %5.3f | %8.1e [%5ld]     | %8.1e [%5ld]\n", c.name, eta, ep,
                  count_evals(x, v, f, -1, proj), es, count_evals(x, v, f, -1, sub));
      worst_proj = std::max(worst_proj, ep);
      EXPECT_LT(ep, 1e-6) << c.name << " eta " << eta;
      EXPECT_LT(es, 1e-4) << c.name << " eta " << eta;
    }
  std::printf("  worst projection error %.1e\n", worst_proj);
}

TEST(ElementQuadrature, NearSingularRandomTargets) {
  // Targets at d/h_e in (0, 0.5) in assorted directions, both sides of the plane; default settings.
  const Elem v = test_element(), f = test_density();
  const double h = ref_longest_edge(v);
  double worst = 0.0;
  for (double ratio : {0.45, 0.3, 0.15, 0.05, 0.01}) {
    for (const auto& x : targets_at_distance(v, ratio * h, 12, 5)) {
      const double e = rel_err(quad_local(x, v, f, -1, QuadratureOrders{}), reference(local_kernel(kAlpha), x, v, f));
      worst = std::max(worst, e);
      EXPECT_LT(e, 1e-6) << "d/h_e " << ratio;
    }
  }
  std::printf("near-singular random targets (d/h_e 0.01..0.45): worst relative error %.1e\n", worst);
}

TEST(ElementQuadrature, NearSingularSettingsSweep) {
  // Accuracy/cost of the projection rule's settings over the fixed and random near-singular targets.
  const Elem v = test_element(), f = test_density();
  const double h = ref_longest_edge(v);
  std::vector<Vec3> xs;
  for (const auto& c : kNearCases)
    for (double eta : {0.02, 0.005, 0.001}) xs.push_back(lifted(v, c.l0, c.l1, c.l2, eta * h));
  for (double ratio : {0.45, 0.3, 0.15, 0.05, 0.01})
    for (const auto& x : targets_at_distance(v, ratio * h, 8, 9)) xs.push_back(x);
  std::vector<Vec3> refs;
  for (const auto& x : xs) refs.push_back(reference(local_kernel(kAlpha), x, v, f));
  std::printf("\nProjection rule settings over %zu near-singular targets: worst relative error, mean/max evaluations\n",
              xs.size());
  struct Setting {
    int na, nr;
    double panel;
  };
  for (const Setting& st : {Setting{4, 4, 2.0}, Setting{6, 6, 2.0}, Setting{6, 6, 1.5}, Setting{7, 7, 2.0},
                            Setting{6, 8, 2.0}, Setting{8, 6, 2.0}, Setting{8, 8, 2.5}, Setting{8, 8, 2.0},
                            Setting{10, 10, 3.0}}) {
    QuadratureOrders q;
    q.near_angle = st.na, q.near_radial = st.nr, q.near_panel = st.panel;
    double worst = 0.0, mean = 0.0;
    long most = 0;
    for (std::size_t i = 0; i < xs.size(); ++i) {
      worst = std::max(worst, rel_err(quad_local(xs[i], v, f, -1, q), refs[i]));
      const long n = count_evals(xs[i], v, f, -1, q);
      mean += static_cast<double>(n) / static_cast<double>(xs.size());
      most = std::max(most, n);
    }
    std::printf("  angle %2d radial %2d panel %.1f: worst %.1e, evaluations mean %.0f max %ld\n", st.na, st.nr,
                st.panel, worst, mean, most);
  }
}

TEST(ElementQuadrature, DegenerateElementAddsNothing) {
  const Elem v{0, 0, 0, 0.3, 0, 0, 0.6, 0, 0}, f = test_density();
  const Vec3 u = quad_local({0.1, 0.01, 0.0}, v, f, -1, QuadratureOrders{});
  for (double c : u) EXPECT_EQ(c, 0.0);
}

TEST(ElementQuadrature, SkinnyAndObtuseElements) {
  // Deformed capsules have distorted elements: a sliver (aspect ratio ~8) and an obtuse triangle.
  const Elem f = test_density();
  const std::vector<std::pair<const char*, Elem>> elems{{"sliver", {0, 0, 0, 0.3, 0, 0, 0.15, 0.035, 0.01}},
                                                         {"obtuse", {0, 0, 0, 0.3, 0, 0, 0.12, 0.04, -0.02}}};
  std::printf("\nDistorted elements, singular rules: relative error [evaluations]\n");
  std::printf("  element vertex angle | parametric 6x6 | parametric 8x8 | vertex-polar 6     | vertex-polar 8\n");
  for (const auto& [name, v] : elems) {
    const double h = ref_longest_edge(v);
    for (int k = 0; k < 3; ++k) {
      const Vec3 x{v[3 * k], v[3 * k + 1], v[3 * k + 2]};
      const double* a = &v[3 * ((k + 1) % 3)];
      const double* b = &v[3 * ((k + 2) % 3)];
      double ea[3], eb[3];
      for (int c = 0; c < 3; ++c) ea[c] = a[c] - x[c], eb[c] = b[c] - x[c];
      const double angle = std::acos((ea[0] * eb[0] + ea[1] * eb[1] + ea[2] * eb[2]) /
                                     std::sqrt((ea[0] * ea[0] + ea[1] * ea[1] + ea[2] * ea[2]) *
                                               (eb[0] * eb[0] + eb[1] * eb[1] + eb[2] * eb[2]))) *
                           180.0 / kPi;
      const Vec3 ref = reference(local_kernel(kAlpha), x, v, f);
      double e[4];
      long n[4];
      for (int r = 0; r < 4; ++r) {
        QuadratureOrders q;
        q.singular = r % 2 ? 8 : 6;
        q.singular_method = r < 2 ? SingularMethod::Parametric : SingularMethod::VertexPolar;
        e[r] = rel_err(quad_local(x, v, f, k, q), ref);
        n[r] = count_evals(x, v, f, k, q);
      }
      std::printf("  %-7s %6d %5.1f | %8.1e [%2ld] | %8.1e [%2ld] | %8.1e [%3ld] | %8.1e [%3ld]\n", name, k, angle,
                  e[0], n[0], e[1], n[1], e[2], n[2], e[3], n[3]);
      EXPECT_LT(e[2], 1e-5) << name << " vertex " << k;
      EXPECT_LT(e[3], 1e-7) << name << " vertex " << k;
    }
    double worst_near = 0.0, worst_reg = 0.0;
    for (double ratio : {0.3, 0.05, 0.005})
      for (const auto& x : targets_at_distance(v, ratio * h, 8, 21))
        worst_near = std::max(worst_near, rel_err(quad_local(x, v, f, -1, QuadratureOrders{}),
                                                  reference(local_kernel(kAlpha), x, v, f)));
    for (double ratio : {0.5, 1.0})
      for (const auto& x : targets_at_distance(v, ratio * h, 8, 23))
        worst_reg = std::max(worst_reg, rel_err(quad_local(x, v, f, -1, QuadratureOrders{}),
                                                reference(local_kernel(kAlpha), x, v, f)));
    // d/h_e = 2 (outer band, screened): judged on the velocity scale |I_S| as in RegularRuleAccuracyByDistance.
    double worst_outer = 0.0, worst_outer_rel = 0.0;
    for (const auto& x : targets_at_distance(v, 2.0 * h, 8, 23)) {
      const Vec3 u = quad_local(x, v, f, -1, QuadratureOrders{}), ref = reference(local_kernel(kAlpha), x, v, f);
      const Vec3 refs = reference(stokeslet_kernel(), x, v, f);
      double e = 0.0;
      for (int c = 0; c < 3; ++c) e = std::max(e, std::fabs(u[c] - ref[c]));
      worst_outer = std::max(worst_outer, e / std::sqrt(refs[0] * refs[0] + refs[1] * refs[1] + refs[2] * refs[2]));
      worst_outer_rel = std::max(worst_outer_rel, rel_err(u, ref));
    }
    std::printf("  %-7s default rules: near-singular (d/h_e 0.005-0.3) worst %.1e, regular (0.5-1) worst %.1e, "
                "d/h_e 2 %.1e of |I_S| (%.1e of |I_l|)\n",
                name, worst_near, worst_reg, worst_outer, worst_outer_rel);
    EXPECT_LT(worst_near, 1e-6) << name;
    EXPECT_LT(worst_reg, 1e-6) << name;
    EXPECT_LT(worst_outer, 1e-6) << name;
  }
}

TEST(ElementQuadrature, LinearInDensity) {
  const Elem v = test_element();
  const auto r = uniform_values(18, -1.0, 1.0, 3);
  Elem f1{}, f2{}, fc{};
  for (int i = 0; i < 9; ++i) f1[static_cast<std::size_t>(i)] = r[static_cast<std::size_t>(i)], f2[static_cast<std::size_t>(i)] = r[static_cast<std::size_t>(9 + i)];
  for (int i = 0; i < 9; ++i) fc[static_cast<std::size_t>(i)] = 2.5 * f1[static_cast<std::size_t>(i)] - 0.75 * f2[static_cast<std::size_t>(i)];
  const std::vector<std::pair<Vec3, int>> cases{{lifted(v, 0.2, 0.3, 0.5, 1.0), -1},
                                                 {lifted(v, 0.2, 0.3, 0.5, 0.2), -1},
                                                 {lifted(v, 0.2, 0.3, 0.5, 0.003), -1},
                                                 {lifted(v, 0.0, 1.0, 0.0, 0.0), 1}};
  for (const auto& [x, sv] : cases) {
    const QuadratureOrders q;
    const Vec3 a = quad_local(x, v, f1, sv, q), b = quad_local(x, v, f2, sv, q), c = quad_local(x, v, fc, sv, q);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(c[k], 2.5 * a[k] - 0.75 * b[k], 1e-13 * (1 + std::fabs(c[k])));
  }
}

TEST(ElementQuadrature, TranslationInvariantAndRotationCovariant) {
  const Elem v = test_element(), f = test_density();
  const Vec3 shift{0.37, -1.2, 0.81};
  // Rotation: about (0.3, -0.5, 0.8) by 1.1 rad (Rodrigues).
  Vec3 ax{0.3, -0.5, 0.8};
  const double m = std::sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
  for (auto& x : ax) x /= m;
  const double th = 1.1, cs = std::cos(th), sn = std::sin(th);
  auto rot = [&](const double* p) {
    const double d = ax[0] * p[0] + ax[1] * p[1] + ax[2] * p[2];
    const double cr[3] = {ax[1] * p[2] - ax[2] * p[1], ax[2] * p[0] - ax[0] * p[2], ax[0] * p[1] - ax[1] * p[0]};
    Vec3 o{};
    for (int c = 0; c < 3; ++c) o[c] = p[c] * cs + cr[c] * sn + ax[c] * d * (1 - cs);
    return o;
  };
  const std::vector<std::pair<Vec3, int>> cases{{lifted(v, 0.2, 0.3, 0.5, 0.9), -1},
                                                 {lifted(v, 0.2, 0.3, 0.5, 0.25), -1},
                                                 {lifted(v, 0.6, 0.5, -0.1, 0.004), -1},
                                                 {lifted(v, 0.0, 0.0, 1.0, 0.0), 2}};
  const QuadratureOrders q;
  for (const auto& [x, sv] : cases) {
    const Vec3 u0 = quad_local(x, v, f, sv, q);
    Elem vt{}, vr{}, fr{};
    Vec3 xt{}, xr = rot(x.data());
    for (int i = 0; i < 3; ++i) {
      const Vec3 a = rot(&v[3 * static_cast<std::size_t>(i)]), b = rot(&f[3 * static_cast<std::size_t>(i)]);
      for (int c = 0; c < 3; ++c) {
        vt[static_cast<std::size_t>(3 * i + c)] = v[static_cast<std::size_t>(3 * i + c)] + shift[static_cast<std::size_t>(c)];
        vr[static_cast<std::size_t>(3 * i + c)] = a[static_cast<std::size_t>(c)];
        fr[static_cast<std::size_t>(3 * i + c)] = b[static_cast<std::size_t>(c)];
      }
    }
    for (int c = 0; c < 3; ++c) xt[static_cast<std::size_t>(c)] = x[static_cast<std::size_t>(c)] + shift[static_cast<std::size_t>(c)];
    const Vec3 ut = quad_local(xt, vt, f, sv, q), ur = quad_local(xr, vr, fr, sv, q), u0r = rot(u0.data());
    const double scale = std::sqrt(u0[0] * u0[0] + u0[1] * u0[1] + u0[2] * u0[2]);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(ut[static_cast<std::size_t>(c)], u0[static_cast<std::size_t>(c)], 1e-12 * scale);
      EXPECT_NEAR(ur[static_cast<std::size_t>(c)], u0r[static_cast<std::size_t>(c)], 1e-12 * scale);
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Closed sphere mesh (icosahedron refined and projected to radius a).

struct Mesh {
  std::vector<Vec3> x;
  std::vector<std::array<int, 3>> tri;
};

Mesh icosphere(int levels, double a) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  Mesh m;
  m.x = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  m.tri = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
           {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
           {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  auto project = [a](Vec3 p) {
    const double r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    for (auto& c : p) c *= a / r;
    return p;
  };
  for (auto& p : m.x) p = project(p);
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int i, int j) {
      const auto key = std::minmax(i, j);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      Vec3 p{};
      for (int c = 0; c < 3; ++c) p[static_cast<std::size_t>(c)] = 0.5 * (m.x[static_cast<std::size_t>(i)][static_cast<std::size_t>(c)] + m.x[static_cast<std::size_t>(j)][static_cast<std::size_t>(c)]);
      m.x.push_back(project(p));
      const int id = static_cast<int>(m.x.size()) - 1;
      mid[key] = id;
      return id;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& tr : m.tri) {
      const int a01 = midpoint(tr[0], tr[1]), a12 = midpoint(tr[1], tr[2]), a20 = midpoint(tr[2], tr[0]);
      next.push_back({tr[0], a01, a20});
      next.push_back({a01, tr[1], a12});
      next.push_back({a20, a12, tr[2]});
      next.push_back({a01, a12, a20});
    }
    m.tri = next;
  }
  return m;
}

Elem element_of(const Mesh& m, const std::array<int, 3>& tr) {
  Elem v{};
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) v[static_cast<std::size_t>(3 * i + c)] = m.x[static_cast<std::size_t>(tr[static_cast<std::size_t>(i)])][static_cast<std::size_t>(c)];
  return v;
}

// Stokeslet single layer of the whole mesh at x; density per element from fn(element, node index).
template <class DensityFn>
Vec3 mesh_stokeslet(const Mesh& m, const Vec3& x, int target_node, DensityFn density) {
  const QuadratureOrders q;
  Vec3 u{0, 0, 0};
  for (const auto& tr : m.tri) {
    const Elem v = element_of(m, tr);
    int sv = -1;
    for (int i = 0; i < 3; ++i)
      if (tr[static_cast<std::size_t>(i)] == target_node) sv = i;
    const Elem f = density(v, tr);
    element_stokeslet_add(x.data(), v.data(), f.data(), sv, q, u.data());
  }
  return u;
}

TEST(ElementQuadrature, StokesletNormalIdentityOnClosedMeshIsExact) {
  // \oint S . n dS = 0 for any target, for the closed polyhedron with its exact (element-wise constant) normals.
  const Mesh m = icosphere(2, 1.0);
  auto normal_density = [](const Elem& v, const std::array<int, 3>&) {
    const Vec3 n = elem_normal(v);
    return Elem{n[0], n[1], n[2], n[0], n[1], n[2], n[0], n[1], n[2]};
  };
  // Scale: the single layer of a unit uniform traction, 16 pi a / 3.
  const double scale = 16.0 * kPi / 3.0;
  double worst = 0.0;
  // On nodes (singular + regular + the neighbours of the node), near the surface (near-singular), off the surface.
  std::vector<std::pair<Vec3, int>> targets;
  for (int i = 0; i < 162; i += 7) targets.push_back({m.x[static_cast<std::size_t>(i)], i});
  const Elem e0 = element_of(m, m.tri[5]);
  for (double hgt : {0.02, 0.005, -0.005, -0.02, 0.3, -0.3})
    for (const auto& c : kNearCases) targets.push_back({lifted(e0, c.l0, c.l1, c.l2, hgt * 0.3), -1});
  for (const auto& [x, node] : targets) {
    const Vec3 u = mesh_stokeslet(m, x, node, normal_density);
    worst = std::max(worst, std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) / scale);
  }
  std::printf("closed-mesh identity |oint S.n dS| / (16 pi a/3): worst %.1e over %zu targets (320 elements)\n", worst,
              targets.size());
  EXPECT_LT(worst, 1e-6);
}

TEST(ElementQuadrature, StokesletUniformTractionOnSphereIsRigidTranslation) {
  // (1/8 pi mu) \int S . f dS = (2a/(3 mu)) f on the sphere: \int S . f dS = (16 pi a / 3) f. Flat elements make an
  // O(h^2) geometric error; the quadrature must not spoil the convergence.
  auto uniform = [](const Elem&, const std::array<int, 3>&) { return Elem{0, 0, 1, 0, 0, 1, 0, 0, 1}; };
  const double exact = 16.0 * kPi / 3.0;
  double prev = 1.0;
  for (int level = 1; level <= 3; ++level) {
    const Mesh m = icosphere(level, 1.0);
    double worst = 0.0;
    const int stride = static_cast<int>(m.x.size()) / 12;
    for (int i = 0; i < static_cast<int>(m.x.size()); i += stride) {
      const Vec3 u = mesh_stokeslet(m, m.x[static_cast<std::size_t>(i)], i, uniform);
      worst = std::max({worst, std::fabs(u[2] - exact) / exact, std::fabs(u[0]) / exact, std::fabs(u[1]) / exact});
    }
    std::printf("sphere uniform traction, %zu nodes: max relative error %.2e (ratio to previous %.2f)\n", m.x.size(),
                worst, prev / worst);
    if (level > 1) {
      EXPECT_GT(prev / worst, 3.0);
    }
    prev = worst;
  }
  EXPECT_LT(prev, 5e-3);
}

TEST(ElementQuadrature, CostPerNodeOnCapsule) {
  // Own-capsule local sum for every node of a 162-node capsule (a = 1, alpha = 4, r_c = 4/alpha): elements whose
  // centroid is within r_c + circumradius (docs/method_quadrature.md), evaluations of G_l by class.
  const Mesh m = icosphere(2, 1.0);
  const double rc = 4.0 / kAlpha;
  const QuadratureOrders q;
  // singular, far, symmetric, outer mid, mid, near-regular, near-singular
  long evals[7] = {0, 0, 0, 0, 0, 0, 0}, elems[7] = {0, 0, 0, 0, 0, 0, 0};
  const auto t0 = std::chrono::steady_clock::now();
  Vec3 sink{0, 0, 0};
  for (std::size_t i = 0; i < m.x.size(); ++i) {
    const Vec3& x = m.x[i];
    for (const auto& tr : m.tri) {
      const Elem v = element_of(m, tr);
      Vec3 c{(v[0] + v[3] + v[6]) / 3, (v[1] + v[4] + v[7]) / 3, (v[2] + v[5] + v[8]) / 3};
      double circ = 0.0, dc = 0.0;
      for (int k = 0; k < 3; ++k) {
        double d2 = 0.0;
        for (int j = 0; j < 3; ++j) d2 += (v[3 * k + j] - c[j]) * (v[3 * k + j] - c[j]);
        circ = std::max(circ, std::sqrt(d2));
      }
      for (int j = 0; j < 3; ++j) dc += (x[j] - c[j]) * (x[j] - c[j]);
      if (std::sqrt(dc) >= rc + circ) continue;
      int sv = -1;
      for (int k = 0; k < 3; ++k)
        if (tr[k] == static_cast<int>(i)) sv = k;
      const double ratio = ref_distance(x, v) / ref_longest_edge(v);
      const int cls = sv >= 0                      ? 0
                      : ratio >= q.far_ratio       ? 1
                      : ratio >= q.symmetric_ratio ? 2
                      : ratio >= q.outer_ratio     ? 3
                      : ratio >= q.mid_ratio       ? 4
                      : ratio >= q.near_ratio      ? 5
                                                   : 6;
      const Elem f = test_density();
      evals[cls] += count_evals(x, v, f, sv, q);
      elems[cls] += 1;
      element_single_layer_add(kAlpha, x.data(), v.data(), f.data(), sv, q, sink.data());
    }
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double nn = static_cast<double>(m.x.size());
  const char* names[7] = {"singular",  "far (D7)",  "symmetric (S16)", "outer mid (5x5)", "mid (7x7)",
                          "near-regular (10x10)", "near-singular"};
  std::printf("\nOwn-capsule local sum, 162-node capsule, r_c = a: per node, elements [evaluations of G_l]\n");
  long total = 0;
  for (int c = 0; c < 7; ++c) {
    std::printf("  %-22s %6.1f [%7.1f]\n", names[c], static_cast<double>(elems[c]) / nn,
                static_cast<double>(evals[c]) / nn);
    total += evals[c];
  }
  std::printf("  total %.0f evaluations per node; %.1f us per node (serial, counting pass included)\n",
              static_cast<double>(total) / nn, 1e6 * secs / nn);
  EXPECT_TRUE(std::isfinite(sink[0] + sink[1] + sink[2]));
}

}  // namespace
}  // namespace capsflow::test
