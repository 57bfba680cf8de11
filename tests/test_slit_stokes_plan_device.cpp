// SlitStokesPlanDevice, the device global solve, against SlitStokesPlan, its CPU reference (HOOMD-style compare
// tests): random forcing and random wall data on odd and even grids, small N and N ~ 40; a plan reused for several
// solves; the arrays resident for the plan's lifetime; GgemSolver's device backend running it.
//
// Device-only instances (names end in /device): without a GPU they run on the OpenMP host fallback (ctest sets the
// test switch), where FFTW stands in for cuFFT and host and device arrays are the same memory, so the arithmetic of
// every device kernel is checked and the data movement is not. Checks that only a GPU can make say so and are skipped
// here with that reason. Host builds skip them all (backend 'device' not built).
#include <fftw3.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/base/backend_select.hpp"
#include "host/solver/ggem_solver.hpp"
#include "host/solver/slit_stokes_plan.hpp"
#include "host/solver/slit_stokes_plan_device.hpp"
#include "kernels/mode_solve_device.hpp"
#include "support/backends.hpp"
#include "support/test_util.hpp"

#ifdef CAPSFLOW_HAVE_OPENMP
#include <omp.h>
#endif

using namespace capsflow;

namespace {

const SlitGeometry kGeo{2.3, 5.1, 3.7, 1.0};

GgemGrid make_grid(int nx, int nz, int N) {
  GgemGrid g;
  g.nx = nx;
  g.nz = nz;
  g.ny = N;
  g.hx = kGeo.Lx / nx;
  g.hz = kGeo.Lz / nz;
  g.alpha = 4.0;
  g.cutoff = 1.0;
  return g;
}

// Random forcing in every grid cell and random wall data on both walls, the same values into both plans.
template <class Plan>
void fill_random(Plan& plan, std::uint64_t seed) {
  const std::size_t ng = plan.grid_size(), nw = plan.plane_size();
  for (int c = 0; c < 3; ++c) {
    const auto f = test::uniform_values(ng, -1.0, 1.0, seed + 10 * c);
    std::copy(f.begin(), f.end(), plan.forcing(c));
    for (int side = 0; side < 2; ++side) {
      const auto w = test::uniform_values(nw, -0.5, 0.5, seed + 100 + 10 * c + side);
      std::copy(w.begin(), w.end(), plan.wall(side, c));
    }
  }
}

// max |a - b| / max |b| over the three velocity components.
double velocity_rel_diff(const SlitStokesPlanDevice& d, const SlitStokesPlan& r) {
  double diff = 0.0, ref = 0.0;
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < r.grid_size(); ++i) {
      diff = std::max(diff, std::abs(d.velocity(c)[i] - r.velocity(c)[i]));
      ref = std::max(ref, std::abs(r.velocity(c)[i]));
    }
  return diff / ref;
}

double solve_and_compare(SlitStokesPlanDevice& dev, SlitStokesPlan& ref, std::uint64_t seed) {
  fill_random(ref, seed);
  fill_random(dev, seed);
  dev.push_forcing();
  dev.push_walls();
  ref.solve();
  dev.solve();
  dev.pull_velocity();
  return velocity_rel_diff(dev, ref);
}

class SlitStokesPlanDeviceTest : public test::OnEachBackend {};

TEST_P(SlitStokesPlanDeviceTest, MatchesTheCpuReferenceOnRandomData) {
  struct Size {
    int nx, nz, N;
  };
  // Odd and even Fourier sizes (even ones have unpaired Nyquist modes), small N, N ~ 40, and set A's N = 128.
  for (const Size s :
       {Size{8, 8, 8}, Size{9, 15, 11}, Size{12, 10, 17}, Size{15, 16, 40}, Size{10, 9, 42}, Size{9, 8, 128}}) {
    const GgemGrid g = make_grid(s.nx, s.nz, s.N);
    SlitStokesPlan ref(kGeo, g, Backend::Serial);
    SlitStokesPlanDevice dev(kGeo, g);
    const double e = solve_and_compare(dev, ref, 7u + static_cast<std::uint64_t>(s.N));
    std::printf("nx %2d nz %2d N %2d (%s): max relative difference %.2e\n", s.nx, s.nz, s.N, dev.fft_name(), e);
    EXPECT_LT(e, 1e-12) << "nx " << s.nx << " nz " << s.nz << " N " << s.N;
  }
}

TEST_P(SlitStokesPlanDeviceTest, OnePlanServesSeveralSolves) {
  const GgemGrid g = make_grid(12, 9, 20);
  SlitStokesPlan ref(kGeo, g, Backend::Serial);
  SlitStokesPlanDevice dev(kGeo, g);
  for (std::uint64_t seed : {1u, 2u, 3u}) EXPECT_LT(solve_and_compare(dev, ref, seed), 1e-12) << "solve " << seed;
  // Zeroing on the device: a solve with no forcing and no wall data gives zero velocity.
  dev.zero_forcing_and_walls();
  dev.solve();
  dev.pull_velocity();
  dev.pull_forcing();
  for (int c = 0; c < 3; ++c)
    for (std::size_t i = 0; i < dev.grid_size(); ++i) {
      ASSERT_EQ(dev.forcing(c)[i], 0.0);
      ASSERT_EQ(dev.velocity(c)[i], 0.0);
    }
}

TEST_P(SlitStokesPlanDeviceTest, WallDataAreTheNegatedLocalVelocity) {
  const GgemGrid g = make_grid(9, 8, 12);
  SlitStokesPlan ref(kGeo, g, Backend::Serial);
  SlitStokesPlanDevice dev(kGeo, g);
  const std::size_t nw = dev.plane_size();
  std::vector<double> ul[3];
  for (int c = 0; c < 3; ++c) ul[c] = test::uniform_values(2 * nw, -1.0, 1.0, 40u + c);
  const double* ulp[3] = {ul[0].data(), ul[1].data(), ul[2].data()};
  dev.zero_forcing_and_walls();
  dev.set_walls_negated(ulp);
  ref.zero_forcing_and_walls();
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c)
      for (std::size_t p = 0; p < nw; ++p) ref.wall(side, c)[p] = -ul[c][side * nw + p];
  ref.solve();
  dev.solve();
  dev.pull_velocity();
  EXPECT_LT(velocity_rel_diff(dev, ref), 1e-12);
}

TEST_P(SlitStokesPlanDeviceTest, ArraysStayResidentForThePlansLifetime) {
  const GgemGrid g = make_grid(8, 10, 9);
  SlitStokesPlanDevice dev(kGeo, g);
  // forcing, velocity, spectra, coefficients, walls, wall spectra, y nodes, phi, psi, influence matrices, DCT matrix.
  EXPECT_EQ(dev.resident_arrays(), 11u);
  if (dev.host_fallback()) {
    EXPECT_STREQ(dev.fft_name(), "FFTW, host fallback");
    GTEST_SKIP() << "presence on the device and the velocity staying there need a GPU: on the host fallback host and "
                    "device arrays are the same memory (the bookkeeping above is what is checked here)";
  }
#ifdef CAPSFLOW_HAVE_OPENMP
  // A GPU runs cuFFT; the host-memory test device (LLVM's host offload plugin) FFTW on the same device arrays.
  EXPECT_STREQ(dev.fft_name(), device_memory_host_addressable_for_tests()
                                   ? "FFTW on the device's arrays (host-memory test device)"
                                   : "cuFFT");
  const int d = omp_get_default_device();
  for (int c = 0; c < 3; ++c) {
    EXPECT_TRUE(omp_target_is_present(dev.forcing(c), d)) << "forcing " << c;
    EXPECT_TRUE(omp_target_is_present(dev.velocity(c), d)) << "velocity " << c;
    EXPECT_TRUE(omp_target_is_present(dev.wall(1, c), d)) << "wall " << c;
  }
  EXPECT_TRUE(omp_target_is_present(dev.y_nodes().data(), d));
  // The solve leaves the velocity on the device: the host copy keeps its sentinel until pulled.
  fill_random(dev, 5u);
  dev.push_forcing();
  dev.push_walls();
  for (int c = 0; c < 3; ++c) std::fill(dev.velocity_mutable(c), dev.velocity_mutable(c) + dev.grid_size(), -7.0);
  dev.solve();
  EXPECT_EQ(dev.velocity(0)[dev.grid_size() / 2], -7.0) << "the solve copied the velocity to the host";
  dev.pull_velocity();
  EXPECT_NE(dev.velocity(0)[dev.grid_size() / 2], -7.0) << "pull_velocity brought nothing back";
  // A host edit of the forcing without push does not reach the device.
  SlitStokesPlan ref(kGeo, g, Backend::Serial);
  EXPECT_LT(solve_and_compare(dev, ref, 6u), 1e-12);
  for (int c = 0; c < 3; ++c) std::fill(dev.forcing(c), dev.forcing(c) + dev.grid_size(), 1e3);
  dev.solve();
  dev.pull_velocity();
  EXPECT_LT(velocity_rel_diff(dev, ref), 1e-12) << "an unpushed host edit reached the device";
#endif
}

INSTANTIATE_TEST_SUITE_P(Backends, SlitStokesPlanDeviceTest, ::testing::Values(Backend::Device),
                         test::backend_param_name);

// GgemSolver's device backend gets the device plan from make_slit_solve and matches the serial solver (apply, and the
// global part's stages alone).
class GgemDeviceGlobalSolve : public test::OnEachBackend {};

TEST_P(GgemDeviceGlobalSolve, RunsOnTheDeviceAndMatchesSerial) {
  const SlitGeometry geo{4.0, 6.0, 5.5, 0.7};
  const int n = 300;
  const auto p = test::uniform_values(6 * n, 0.0, 1.0, 11u);
  std::vector<double> x(n), y(n), z(n), fx(n), fy(n), fz(n);
  for (int i = 0; i < n; ++i) {
    x[i] = p[6 * i] * geo.Lx;
    y[i] = p[6 * i + 1] * geo.H;
    z[i] = p[6 * i + 2] * geo.Lz;
    fx[i] = p[6 * i + 3] - 0.5;
    fy[i] = p[6 * i + 4] - 0.5;
    fz[i] = p[6 * i + 5] - 0.5;
  }
  GgemSolver ref(geo, GgemOptions{}, Backend::Serial);
  GgemSolver dev(geo, GgemOptions{}, Backend::Device);
  ASSERT_NE(dynamic_cast<const SlitStokesPlanDevice*>(&dev.global().slit_solve()), nullptr)
      << "the device backend must own the device global solve";
  EXPECT_NE(dynamic_cast<const SlitStokesPlan*>(&ref.global().slit_solve()), nullptr);
  std::vector<double> ur(3 * n, 0.0), ud(3 * n, 0.0);
  for (int rep = 0; rep < 2; ++rep) {  // the second apply reuses the resident grids
    std::fill(ur.begin(), ur.end(), 0.0);
    std::fill(ud.begin(), ud.end(), 0.0);
    ref.apply(n, x.data(), y.data(), z.data(), fx.data(), fy.data(), fz.data(), n, x.data(), y.data(), z.data(),
              ur.data(), ur.data() + n, ur.data() + 2 * n);
    dev.apply(n, x.data(), y.data(), z.data(), fx.data(), fy.data(), fz.data(), n, x.data(), y.data(), z.data(),
              ud.data(), ud.data() + n, ud.data() + 2 * n);
    EXPECT_LT(test::max_rel_error(ud, ur), 1e-12) << "apply " << rep;
  }
  // The global part alone, with wall data from a given local velocity.
  const std::size_t nw = dev.wall_points(0).size();
  std::vector<double> wl[3];
  for (int c = 0; c < 3; ++c) wl[c] = test::uniform_values(nw, -0.1, 0.1, 70u + c);
  const double* wlp[3] = {wl[0].data(), wl[1].data(), wl[2].data()};
  std::fill(ur.begin(), ur.end(), 0.0);
  std::fill(ud.begin(), ud.end(), 0.0);
  auto global_part = [&](GgemGlobalPart& g, std::vector<double>& u) {
    g.set_walls(wlp);
    g.spread(n, x.data(), y.data(), z.data(), fx.data(), fy.data(), fz.data());
    g.solve();
    g.interpolate(n, x.data(), y.data(), z.data(), u.data(), u.data() + n, u.data() + 2 * n);
  };
  global_part(ref.global(), ur);
  global_part(dev.global(), ud);
  EXPECT_LT(test::max_rel_error(ud, ur), 1e-12);
  EXPECT_GT(dev.global().last_timings().solve, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Backends, GgemDeviceGlobalSolve, ::testing::Values(Backend::Device),
                         test::backend_param_name);

// The device's DCT-I matrix is FFTW's REDFT00 (checked in every build: the matrix is made on the host).
TEST(DctMatrix, IsFftwRedft00) {
  for (int N : {8, 17, 128}) {
    const int np = N + 1;
    std::vector<double> D(static_cast<std::size_t>(np) * np);
    dct1_matrix(N, D.data());
    auto x = test::uniform_values(np, -1.0, 1.0, 3u + static_cast<std::uint64_t>(N));
    std::vector<double> in = x, out(np);
    fftw_plan p = fftw_plan_r2r_1d(np, in.data(), out.data(), FFTW_REDFT00, FFTW_ESTIMATE);
    fftw_execute(p);
    fftw_destroy_plan(p);
    double diff = 0.0, ref = 0.0;
    for (int k = 0; k < np; ++k) {
      double s = 0.0;
      for (int j = 0; j < np; ++j) s += D[static_cast<std::size_t>(k) * np + j] * x[j];
      diff = std::max(diff, std::abs(s - out[k]));
      ref = std::max(ref, std::abs(out[k]));
    }
    EXPECT_LT(diff / ref, 1e-14) << "N = " << N;
  }
}

// A host-only build refuses the device global solve with an error naming it, never a silent host run (R6).
TEST(SlitStokesPlanDeviceBuild, HostBuildRefusesTheDevicePlan) {
  if (device_backend_built()) GTEST_SKIP() << "an offload build: the device instances above run instead";
  const GgemGrid g = make_grid(8, 8, 8);
  try {
    SlitStokesPlanDevice dev(kGeo, g);
    FAIL() << "SlitStokesPlanDevice was made in a host-only build";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("SlitStokesPlanDevice"), std::string::npos) << e.what();
  }
  SlitModeGrid mg{8, 8, 8, kGeo.H, kGeo.Lx, kGeo.Lz};
  try {
    slit_solve_modes_device(mg, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, 1);
    FAIL() << "slit_solve_modes_device ran in a host-only build";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("slit_solve_modes_device"), std::string::npos) << e.what();
  }
}

}  // namespace
