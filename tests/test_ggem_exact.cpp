// The full GGEM solver against the independent exact slit Green's function (tests/support/slit_green_reference,
// a Fourier-mode sum with closed-form per-mode solutions): forces parallel and normal to the walls, near a wall
// and at mid-channel, at the default resolution alpha h_m = 0.5 and on refined grids.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "host/solver/ggem_solver.hpp"
#include "support/backends.hpp"
#include "support/slit_green_reference.hpp"

using namespace capsflow;

namespace {

struct Case {
  const char* name;
  double y0;
  double F[3];
};

using Offsets = std::vector<std::array<double, 3>>;

// Targets off the source plane (the reference converges exponentially in |y - y0|), near and far: the cases the
// [ggem] tolerance fits were made on.
const Offsets kFittedOffsets = {{0.4, 0.3, 0.2},  {-0.7, 0.5, 0.3}, {0.2, -0.35, -0.6}, {1.5, 0.8, -1.0},
                                {-2.0, 1.2, 1.7}, {0.1, 0.45, 0.0}, {2.4, -0.3, 2.5}};

// Max over targets of |u - u_exact| / |u_exact| (per target), for one point force.
double error_vs_exact(const SlitGeometry& geo, const GgemOptions& opt, const Case& c,
                      Backend backend = Backend::Threads, const Offsets& offs = kFittedOffsets) {
  const double src[3] = {0.5 * geo.Lx, c.y0, 0.5 * geo.Lz};
  std::vector<double> tx, ty, tz;
  for (const auto& o : offs) {
    tx.push_back(src[0] + o[0]);
    ty.push_back(src[1] + o[1]);
    tz.push_back(src[2] + o[2]);
  }
  const std::size_t n = tx.size();
  std::vector<double> ux(n), uy(n), uz(n);
  GgemSolver s(geo, opt, backend);
  const double sx[1] = {src[0]}, sy[1] = {src[1]}, sz[1] = {src[2]};
  const double fx[1] = {c.F[0]}, fy[1] = {c.F[1]}, fz[1] = {c.F[2]};
  s.apply(1, sx, sy, sz, fx, fy, fz, n, tx.data(), ty.data(), tz.data(), ux.data(), uy.data(), uz.data());
  const test::SlitRefGeometry rg{geo.H, geo.Lx, geo.Lz, geo.viscosity};
  double worst = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double tgt[3] = {tx[i], ty[i], tz[i]};
    double ue[3];
    test::slit_green_velocity(rg, src, c.F, tgt, ue, 1e-10);
    const double err = std::hypot(ux[i] - ue[0], uy[i] - ue[1], uz[i] - ue[2]);
    worst = std::max(worst, err / std::hypot(ue[0], ue[1], ue[2]));
    if (std::getenv("CAPSFLOW_VERBOSE"))
      std::printf("   target %zu |u| %.3e err %.3e\n", i, std::hypot(ue[0], ue[1], ue[2]), err);
  }
  return worst;
}

const Case kCases[] = {{"parallel, mid-channel", 2.0, {1.0, 0.0, 0.0}},
                       {"normal, mid-channel", 2.0, {0.0, 1.0, 0.0}},
                       {"parallel, near a wall", 0.6, {0.0, 0.0, 1.0}},
                       {"normal, near a wall", 0.6, {0.0, 1.0, 0.0}}};

}  // namespace

// Physics on every backend (the backends harness): the exact Green's function is the oracle.
class GgemExactBackends : public test::OnEachBackend {};

TEST_P(GgemExactBackends, DefaultResolutionWithinOnePerMille) {
  const SlitGeometry geo{4.0, 6.0, 6.0, 1.0};
  for (const Case& c : kCases) {
    const double e = error_vs_exact(geo, GgemOptions{}, c, backend());
    std::printf("%-24s alpha_hm 0.5: max relative error %.2e\n", c.name, e);
    EXPECT_LT(e, 1e-3) << c.name;
  }
}

CAPSFLOW_ON_EACH_BACKEND(GgemExactBackends);

// The smallest period the local cutoff allows (Lx = Lz = 2 r_c = 7/alpha): the clouds, truncated at 4/alpha, are
// wider than half the period and overlap their own periodic images on the grid; the result still meets the bound.
TEST_P(GgemExactBackends, CloudsWiderThanHalfThePeriod) {
  const GgemGrid g = resolve_ggem_grid(SlitGeometry{4.0, 1.75, 1.75, 1.0}, GgemOptions{});
  ASSERT_EQ(g.cutoff, 0.875);
  ASSERT_EQ(g.spread_cutoff, 1.0);
  const SlitGeometry geo{4.0, 2.0 * g.cutoff, 2.0 * g.cutoff, 1.0};
  for (const Case& c : kCases) {
    const double e = error_vs_exact(geo, GgemOptions{}, c, backend());
    std::printf("%-24s Lx = Lz = 2 r_c: max relative error %.2e\n", c.name, e);
    EXPECT_LT(e, 1e-3) << c.name;
  }
}

TEST(GgemExact, ErrorFallsAsTheGridIsRefined) {
  const SlitGeometry geo{4.0, 6.0, 6.0, 1.3};
  for (const Case& c : {kCases[0], kCases[3]}) {
    std::vector<double> e;
    for (double ahm : {0.7, 0.5, 0.35}) {
      GgemOptions opt;
      opt.alpha_hm = ahm;
      e.push_back(error_vs_exact(geo, opt, c));
      std::printf("%-24s alpha_hm %.2f: max relative error %.2e\n", c.name, ahm, e.back());
    }
    EXPECT_LT(e[1], 0.5 * e[0]) << c.name;
    EXPECT_LT(e[2], 0.5 * e[1]) << c.name;
  }
  EXPECT_LT(error_vs_exact(geo, [] { GgemOptions o; o.alpha_hm = 0.35; return o; }(), kCases[0]), 1e-4);
}

// [ggem] tolerance's promise (slit_parameters.hpp): the parameters it picks put every case within the tolerance of
// the exact Green's function, here and in set A's box (H = L = 10.155), forces parallel and normal to the walls at
// 0.4 from a wall and at mid-channel (the fits were made on these cases; the margins are 1.3-2.5).
TEST(GgemExact, ToleranceIsMetAgainstTheExactGreensFunction) {
  const Case near_wall[] = {{"parallel, 0.4 from a wall", 0.4, {1.0, 0.0, 0.0}},
                            {"normal, 0.4 from a wall", 0.4, {0.0, 1.0, 0.0}}};
  for (const SlitGeometry geo : {SlitGeometry{4.0, 6.0, 6.0, 1.3}, SlitGeometry{10.155, 10.155, 10.155, 1.0}}) {
    for (double tol : {2e-2, 1e-2, 5e-3, 1e-3, 1e-4}) {  // 1e-2: the study presets' (docs/presets.md)
      const GgemOptions opt = with_ggem_tolerance(GgemOptions{}, tol);
      double worst = 0.0;
      for (Case c : kCases) {
        if (c.y0 == 2.0) c.y0 = 0.5 * geo.H;
        worst = std::max(worst, error_vs_exact(geo, opt, c));
      }
      for (const Case& c : near_wall) worst = std::max(worst, error_vs_exact(geo, opt, c));
      std::printf("H %-6g tolerance %.0e: alpha_hm %.3f, cutoff %.3f / alpha: max relative error %.2e\n", geo.H,
                  tol, opt.alpha_hm, opt.cutoff * opt.alpha, worst);
      EXPECT_LE(worst, tol) << "H " << geo.H << ", tolerance " << tol;
    }
  }
}

// The promise on cases the fits never saw: another box (H 6, Lx 8, Lz 5, viscosity 0.7), oblique forces 1.0 and 0.25
// from a wall (the fits': 0.4 and more) and at mid-channel, and targets near the source plane (|y - y0| = 0.05-0.15;
// the fits' targets are 0.3 or more off it), at the distances the promise names (0.45 to 3.6 from the force:
// docs/usage.md [ggem]). Measured 2026-12-07: 2e-2 to 1e-3 met with 2-3x to spare (0.47, 0.39, 0.36 of it);
// 1e-4 missed by up to 1.94x (the grid term: 0.85 alpha_hm meets it), which docs/method.md 1.5 and usage.md state.
// The 1e-4 check fails the day that changes either way, so the docs are mended with it.
TEST(GgemExact, ToleranceOnCasesTheFitsNeverSaw) {
  const SlitGeometry geo{6.0, 8.0, 5.0, 0.7};
  const Case held_out[] = {{"oblique, 0.25 from a wall", 0.25, {-0.3, 0.8, 0.52}},
                           {"oblique, 1.0 from a wall", 1.0, {0.6, -0.5, 0.62}},
                           {"oblique, mid-channel", 3.0, {0.7, 0.7, -0.14}}};
  const Offsets near_plane = {{0.45, 0.08, 0.1}, {-0.3, -0.1, 0.4}, {0.6, 0.12, -0.4},    {-1.1, -0.15, 0.9},
                              {0.05, 0.05, -0.6}, {2.2, 0.09, 1.3}, {-2.8, -0.12, -1.9}};
  for (double tol : {1e-2, 1e-3, 1e-4}) {  // 1e-2: the study presets'
    const GgemOptions opt = with_ggem_tolerance(GgemOptions{}, tol);
    double worst = 0.0;
    for (const Case& c : held_out) worst = std::max(worst, error_vs_exact(geo, opt, c, Backend::Threads, near_plane));
    std::printf("held-out cases, tolerance %.0e: max relative error %.2e (%.2f of it)\n", tol, worst, worst / tol);
    if (tol >= 1e-3) {
      EXPECT_LE(worst, tol) << "tolerance " << tol;
    } else {
      EXPECT_GT(worst, tol) << "1e-4 is now met off the fitted cases: say so in docs/method.md 1.5 and usage.md";
      EXPECT_LT(worst, 2.5 * tol) << "the shortfall at 1e-4 grew beyond the documented 1.94x";
    }
  }
}

TEST(GgemExact, MeanModeChebyshevRuleIsReportedAndCoarser) {
  // Decision D9: the paper's equal mean spacing (N ~ H/h_m) under-resolves the clouds at mid-channel.
  const SlitGeometry geo{4.0, 6.0, 6.0, 1.0};
  GgemOptions mean;
  mean.chebyshev_rule = "mean";
  const double e_mean = error_vs_exact(geo, mean, kCases[1]);
  const double e_mid = error_vs_exact(geo, GgemOptions{}, kCases[1]);
  std::printf("normal force, mid-channel: chebyshev_rule mean %.2e, midchannel %.2e\n", e_mean, e_mid);
  EXPECT_GT(e_mean, e_mid);
}
