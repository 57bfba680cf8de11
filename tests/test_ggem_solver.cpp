// Properties of the full GGEM point-force solver that need no external reference: independence of the
// splitting parameter, no slip at off-grid wall points, far-field decay, and backend equivalence.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "host/solver/ggem_solver.hpp"
#include "host/solver/slit_stokes_plan_device.hpp"
#include "kernels/ggem_kernels.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

namespace {

struct Points {
  std::vector<double> x, y, z, fx, fy, fz;
  void add(double px, double py, double pz, double f0 = 0, double f1 = 0, double f2 = 0) {
    x.push_back(px);
    y.push_back(py);
    z.push_back(pz);
    fx.push_back(f0);
    fy.push_back(f1);
    fz.push_back(f2);
  }
  std::size_t size() const { return x.size(); }
};

std::vector<double> solve(GgemSolver& s, const Points& src, const Points& tgt) {
  const std::size_t n = tgt.size();
  std::vector<double> u(3 * n);
  s.apply(src.size(), src.x.data(), src.y.data(), src.z.data(), src.fx.data(), src.fy.data(), src.fz.data(), n,
          tgt.x.data(), tgt.y.data(), tgt.z.data(), u.data(), u.data() + n, u.data() + 2 * n);
  return u;
}

// A small rigid-looking cluster of forces plus one isolated force; probes off the sources.
void cluster(Points& src, Points& tgt, double H, double L) {
  src.add(0.5 * L, 0.5 * H, 0.5 * L, 1.0, 0.3, -0.2);
  src.add(0.5 * L + 0.3, 0.5 * H - 0.2, 0.5 * L + 0.1, -0.4, 0.8, 0.1);
  src.add(0.2 * L, 0.4, 0.7 * L, 0.2, -1.0, 0.5);  // near the bottom wall
  auto p = test::uniform_values(3 * 12, 0.0, 1.0, 11);
  for (int i = 0; i < 12; ++i) tgt.add(p[3 * i] * L, 0.1 + p[3 * i + 1] * (H - 0.2), p[3 * i + 2] * L);
}

}  // namespace

// Physics of the point-force solver on every backend (the harness), against exact properties.
class GgemSolverPhysics : public test::OnEachBackend {};

TEST_P(GgemSolverPhysics, IndependentOfAlphaAtFixedAlphaHm) {
  const SlitGeometry geo{4.0, 6.0, 6.0, 1.0};
  Points src, tgt;
  cluster(src, tgt, geo.H, geo.Lx);
  std::vector<std::vector<double>> u;
  for (double alpha : {3.0, 4.0, 6.0}) {
    GgemOptions opt;
    opt.alpha = alpha;
    GgemSolver s(geo, opt, backend());
    u.push_back(solve(s, src, tgt));
  }
  const double e34 = test::max_rel_error(u[0], u[1]);
  const double e64 = test::max_rel_error(u[2], u[1]);
  std::printf("alpha 3 vs 4: %.2e, alpha 6 vs 4: %.2e\n", e34, e64);
  EXPECT_LT(e34, 1e-3);
  EXPECT_LT(e64, 1e-3);
}

TEST_P(GgemSolverPhysics, NoSlipAtOffGridWallPoints) {
  // u_l + u_g vanishes on the walls up to the grid's resolution of the wall data -u_l, which is excellent once
  // the source sits a couple of cloud widths (1/alpha) from the wall; closer than h_m it degrades (pitfall P10,
  // docs/method.md reports the numbers).
  const SlitGeometry geo{4.0, 6.0, 6.0, 1.0};
  GgemSolver s(geo, GgemOptions{}, backend());
  Points wall;
  auto p = test::uniform_values(2 * 60, 0.0, geo.Lx, 5);
  for (int i = 0; i < 60; ++i) wall.add(p[2 * i], (i % 2) ? geo.H : 0.0, p[2 * i + 1]);
  double prev = 1.0;
  for (double h : {0.5, 0.8, 1.2}) {
    Points src, near;
    src.add(1.0, h, 4.0, 0.2, -1.0, 0.5);
    src.add(4.0, geo.H - h, 2.0, -0.6, 0.3, 0.2);
    near.add(1.0, h + 0.3, 4.0);
    const auto uw = solve(s, src, wall);
    const auto un = solve(s, src, near);
    double wmax = 0.0;
    for (double v : uw) wmax = std::max(wmax, std::abs(v));
    const double unear = std::sqrt(un[0] * un[0] + un[1] * un[1] + un[2] * un[2]);
    std::printf("source %.1f from the walls: max |u| on the walls / |u| near the source = %.2e\n", h, wmax / unear);
    EXPECT_LT(wmax / unear, h < 0.6 ? 1e-3 : 1e-5) << "h " << h;
    EXPECT_LT(wmax / unear, prev) << "h " << h;
    prev = wmax / unear;
  }
}

TEST_P(GgemSolverPhysics, WallParallelForceDecaysAsInverseSquare) {
  // For rho >> H a wall-parallel force looks like a Hele-Shaw source dipole: u ~ cos(2 phi)/rho^2, pushing fluid
  // ahead (phi = 0) and drawing it back beside (phi = 90 deg) with equal magnitude. The periodic images and the
  // net-force mean flow add a nearly uniform field; half the difference along - across cancels it.
  const double H = 2.0, L = 48.0, h = 1.0, y = 0.8;
  const SlitGeometry geo{H, L, L, 1.0};
  GgemOptions opt;
  opt.alpha = 1.5;
  GgemSolver s(geo, opt, backend());
  Points src, tgt;
  src.add(0.5 * L, h, 0.5 * L, 1.0, 0.0, 0.0);
  for (double rho : {6.0, 12.0}) {
    tgt.add(0.5 * L + rho, y, 0.5 * L);  // along the force
    tgt.add(0.5 * L, y, 0.5 * L + rho);  // beside it
  }
  auto u = solve(s, src, tgt);
  EXPECT_GT(u[0], 0.0);
  EXPECT_LT(u[1], 0.0);
  const double d6 = 0.5 * (u[0] - u[1]), d12 = 0.5 * (u[2] - u[3]);
  const double p = std::log2(d6 / d12);
  std::printf("decay exponent between rho = 3H and 6H: %.3f\n", p);
  EXPECT_NEAR(p, 2.0, 0.1);
}

TEST_P(GgemSolverPhysics, WallNormalForceDecaysExponentially) {
  // Between two walls a wall-normal force has no algebraic far field: the disturbance decays exponentially
  // (with oscillation: Papkovich-Fadle eigenvalues are complex). A 1/rho^2 law would fall by only 1/25
  // from rho = H/2 to rho = 2.5 H.
  const double H = 2.0, L = 24.0;
  const SlitGeometry geo{H, L, L, 1.0};
  GgemOptions opt;
  opt.alpha = 2.0;
  GgemSolver s(geo, opt, backend());
  Points src, tgt;
  src.add(0.5 * L, 0.5 * H, 0.5 * L, 0.0, 1.0, 0.0);
  for (int i = 0; i <= 20; ++i) tgt.add(0.5 * L + 0.5 * H + 0.1 * H * i, 0.3 * H, 0.5 * L);
  auto u = solve(s, src, tgt);
  const std::size_t n = tgt.size();
  auto mag = [&](std::size_t i) { return std::hypot(u[i], u[n + i], u[2 * n + i]); };
  const double first = mag(0);
  double tail = 0.0;  // envelope over 2 H <= rho <= 2.5 H
  for (std::size_t i = 15; i < n; ++i) tail = std::max(tail, mag(i));
  std::printf("|u| at rho = H/2: %.3e, max over [2H, 2.5H]: %.3e\n", first, tail);
  EXPECT_LT(tail, 2e-3 * first);
}

CAPSFLOW_ON_EACH_BACKEND(GgemSolverPhysics);

class GgemBackends : public test::OnEachBackend {};

TEST_P(GgemBackends, MatchSerialOnRandomConfigurations) {
  const SlitGeometry geo{5.0, 7.0, 6.5, 0.8};
  for (std::uint64_t seed : {1u, 2u}) {
    Points src, tgt;
    const int n = 400;
    auto p = test::uniform_values(6 * n, 0.0, 1.0, seed);
    for (int i = 0; i < n; ++i)
      src.add(p[6 * i] * geo.Lx, p[6 * i + 1] * geo.H, p[6 * i + 2] * geo.Lz, p[6 * i + 3] - 0.5,
              p[6 * i + 4] - 0.5, p[6 * i + 5] - 0.5);
    for (int i = 0; i < 100; ++i) tgt.add(src.x[i], src.y[i], src.z[i]);  // coincident: regular part
    for (int i = 0; i < 100; ++i) tgt.add(p[6 * i + 3] * geo.Lx, p[6 * i + 4] * geo.H, p[6 * i + 5] * geo.Lz);
    GgemSolver ref(geo, GgemOptions{}, Backend::Serial);
    GgemSolver other(geo, GgemOptions{}, GetParam());
    // The device instance runs the device global solve (SlitStokesPlanDevice), not the CPU one.
    EXPECT_EQ(dynamic_cast<const SlitStokesPlanDevice*>(&other.global().slit_solve()) != nullptr,
              GetParam() == Backend::Device);
    const auto ur = solve(ref, src, tgt);
    const auto uo = solve(other, src, tgt);
    EXPECT_LT(test::max_rel_error(uo, ur), 1e-12) << "seed " << seed;
  }
}

CAPSFLOW_ON_PARALLEL_BACKENDS(GgemBackends);
