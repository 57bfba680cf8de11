// The spreading and interpolation stages of the GGEM global part (kernels/spread_interp), on every backend through
// the harness: spreading against a direct sum of the clouds over every grid point (minimum images in x and z),
// interpolation against a smooth field known in closed form; threads against serial bit for bit, the device within
// rounding (its spreading adds with atomics). Sources sit across both periodic seams and within the cutoff of both
// walls.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <vector>

#include "kernels/ggem_kernels.hpp"
#include "kernels/spread_interp.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

using namespace capsflow;

namespace {

struct Grid {
  int nx = 36, nz = 30, N = 40;
  double Lx = 4.5, Lz = 3.75, H = 5.0;
  std::vector<double> y;
  Grid() {
    for (int j = 0; j <= N; ++j) y.push_back(0.5 * H * (1.0 - std::cos(kPi * j / N)));
  }
  SlitGridView view() const { return {nx, nz, N, Lx / nx, Lz / nz, H, y.data()}; }
  std::size_t size() const { return static_cast<std::size_t>(N + 1) * nx * nz; }
};

struct Sources {
  std::vector<double> x, y, z, fx, fy, fz;
};

Sources random_sources(const Grid& g, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Sources s;
  for (int m = 0; m < n; ++m) {
    s.x.push_back(g.Lx * (1.4 * u(rng) - 0.2));  // some outside [0, Lx): wrapped by the stencil
    s.y.push_back(g.H * u(rng));
    s.z.push_back(g.Lz * (1.4 * u(rng) - 0.2));
    s.fx.push_back(u(rng) - 0.5);
    s.fy.push_back(u(rng) - 0.5);
    s.fz.push_back(u(rng) - 0.5);
  }
  return s;
}

std::vector<double> spread(Backend b, const Grid& g, const Sources& s, double alpha, double rc, int component) {
  std::vector<double> r[3];
  for (auto& v : r) v.assign(g.size(), 0.0);
  SpreadWorkspace ws;
  spread_forces(b, g.view(), alpha, rc, s.x.size(), s.x.data(), s.y.data(), s.z.data(), s.fx.data(), s.fy.data(),
                s.fz.data(), r[0].data(), r[1].data(), r[2].data(), ws);
  return r[component];
}

}  // namespace

class SpreadForces : public test::OnEachBackend {};

TEST_P(SpreadForces, MatchesDirectSumOfClouds) {
  const Grid g;
  const double alpha = 4.0, rc = 1.0;
  const Sources s = random_sources(g, 60, 3);
  std::vector<double> rho[3];
  for (int c = 0; c < 3; ++c) rho[c] = spread(backend(), g, s, alpha, rc, c);
  double worst = 0.0, scale = 0.0;
  for (int j = 0; j <= g.N; ++j)
    for (int i = 0; i < g.nx; ++i)
      for (int k = 0; k < g.nz; ++k) {
        double ref[3] = {0.0, 0.0, 0.0};
        for (std::size_t m = 0; m < s.x.size(); ++m) {
          const double dx = min_image(i * g.Lx / g.nx - s.x[m], g.Lx), dy = g.y[j] - s.y[m],
                       dz = min_image(k * g.Lz / g.nz - s.z[m], g.Lz);
          const double r2 = dx * dx + dy * dy + dz * dz;
          if (r2 > rc * rc) continue;
          const double w = ggem_screen(alpha, r2);
          ref[0] += w * s.fx[m];
          ref[1] += w * s.fy[m];
          ref[2] += w * s.fz[m];
        }
        const std::size_t idx = (static_cast<std::size_t>(j) * g.nx + i) * g.nz + k;
        for (int c = 0; c < 3; ++c) {
          worst = std::max(worst, std::fabs(rho[c][idx] - ref[c]));
          scale = std::max(scale, std::fabs(ref[c]));
        }
      }
  ASSERT_GT(scale, 0.0);
  // Only rounding (a grid point within rounding of r = rc could fall either way, at weight ~1e-6 of the peak; these
  // fixed sources have none).
  EXPECT_LT(worst / scale, 1e-12);
  std::printf("spread vs direct sum of clouds: max |diff| / max |rho| = %.2e\n", worst / scale);
}

CAPSFLOW_ON_EACH_BACKEND(SpreadForces);

class SpreadBackends : public test::OnEachBackend {};

TEST_P(SpreadBackends, MatchSerial) {
  const Grid g;
  const Sources s = random_sources(g, 200, 5);
  for (int c = 0; c < 3; ++c) {
    const auto a = spread(Backend::Serial, g, s, 4.0, 1.0, c), b = spread(backend(), g, s, 4.0, 1.0, c);
    EXPECT_LE(test::max_rel_error(b, a), oracle_tol(1e-13)) << "component " << c;
  }
}

CAPSFLOW_ON_PARALLEL_BACKENDS(SpreadBackends);

// The stencils made once (prepare_spread) serve two force sets with spread_forces' bits (device: its atomics add in
// a changing order, within rounding); a workspace prepared for another source count is refused.
TEST_P(SpreadForces, OnePreparationServesSeveralForceSets) {
  const Grid g;
  const Sources s = random_sources(g, 120, 8);
  Sources t = s;
  for (auto* v : {&t.fx, &t.fy, &t.fz})
    for (double& f : *v) f = 0.7 - f;
  SpreadWorkspace ws;
  prepare_spread(backend(), g.view(), 4.0, 1.0, s.x.size(), s.x.data(), s.y.data(), s.z.data(), ws);
  for (const Sources* f : {&s, static_cast<const Sources*>(&t)}) {
    std::vector<double> r[3];
    for (auto& v : r) v.assign(g.size(), 0.0);
    spread_prepared(backend(), g.view(), 4.0, 1.0, s.x.size(), s.x.data(), s.y.data(), s.z.data(), f->fx.data(),
                    f->fy.data(), f->fz.data(), r[0].data(), r[1].data(), r[2].data(), ws, 1.0);
    for (int c = 0; c < 3; ++c)
      EXPECT_LE(test::max_rel_error(r[c], spread(backend(), g, *f, 4.0, 1.0, c)), oracle_tol(1e-13)) << c;
  }
  std::vector<double> r(g.size(), 0.0);
  EXPECT_THROW(spread_prepared(backend(), g.view(), 4.0, 1.0, s.x.size() - 1, s.x.data(), s.y.data(), s.z.data(),
                               s.fx.data(), s.fy.data(), s.fz.data(), r.data(), r.data(), r.data(), ws, 1.0),
               std::logic_error);
}

namespace {

// A smooth field on the grid and in closed form: a degree-8 polynomial in y (the 9-point Lagrange rule on the
// Chebyshev planes is exact for it) times the lowest Fourier modes in x and z (Lagrange's remainder for 9 uniform
// points, (2 pi h / L)^9 max|prod (x - x_i)| / (h^9 9!), is about 1e-10 on this grid).
double smooth_field(const Grid& g, int c, double x, double y, double z) {
  const double t = y / g.H;
  const double p = 1.0 + t * (0.5 - t * (2.0 - t * (1.5 + t * (0.25 - t * t * t * (0.7 + 0.3 * t)))));
  const double fx = std::cos(2.0 * kPi * x / g.Lx + 0.3 * c), fz = std::sin(2.0 * kPi * z / g.Lz + 0.7);
  return p * (1.0 + 0.5 * fx + 0.25 * fz * fx);
}

struct Targets {
  std::vector<double> x, y, z;
};

Targets random_targets(const Grid& g, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Targets t;
  for (int m = 0; m < n; ++m) {
    t.x.push_back(g.Lx * u(rng));  // stencils across the seams near 0 and L
    t.y.push_back(g.H * u(rng));
    t.z.push_back(g.Lz * u(rng));
  }
  return t;
}

std::vector<double> interpolate(Backend b, const Grid& g, const Targets& t) {
  std::vector<double> f[3];
  for (int c = 0; c < 3; ++c) {
    f[c].resize(g.size());
    for (int j = 0; j <= g.N; ++j)
      for (int i = 0; i < g.nx; ++i)
        for (int k = 0; k < g.nz; ++k)
          f[c][(static_cast<std::size_t>(j) * g.nx + i) * g.nz + k] =
              smooth_field(g, c, i * g.Lx / g.nx, g.y[j], k * g.Lz / g.nz);
  }
  const std::size_t n = t.x.size();
  std::vector<double> u(3 * n, 0.0);
  interpolate_velocity(b, g.view(), f[0].data(), f[1].data(), f[2].data(), n, t.x.data(), t.y.data(), t.z.data(),
                       u.data(), u.data() + n, u.data() + 2 * n);
  return u;
}

}  // namespace

class InterpolateVelocity : public test::OnEachBackend {};

TEST_P(InterpolateVelocity, ReproducesASmoothFieldBetweenTheGridPoints) {
  const Grid g;
  const Targets t = random_targets(g, 300, 9);
  const std::vector<double> u = interpolate(backend(), g, t);
  const std::size_t n = t.x.size();
  double worst = 0.0;
  for (int c = 0; c < 3; ++c)
    for (std::size_t m = 0; m < n; ++m)
      worst = std::max(worst, std::fabs(u[c * n + m] - smooth_field(g, c, t.x[m], t.y[m], t.z[m])));
  std::printf("interpolation of a smooth field: max |error| = %.2e (field of order 1)\n", worst);
  EXPECT_LT(worst, 1e-9);
}

CAPSFLOW_ON_EACH_BACKEND(InterpolateVelocity);

class InterpolateBackends : public test::OnEachBackend {};

TEST_P(InterpolateBackends, MatchSerial) {
  const Grid g;
  const Targets t = random_targets(g, 300, 10);
  EXPECT_LE(test::max_rel_error(interpolate(backend(), g, t), interpolate(Backend::Serial, g, t)), oracle_tol(1e-13));
}

CAPSFLOW_ON_PARALLEL_BACKENDS(InterpolateBackends);
