// The slit Poisson solve of the double layer's potential flow (src/host/solver/slit_poisson.hpp) against a
// manufactured solution: phi = 0 on the walls, Fourier modes in x and z (the Nyquist-free ones), the k = 0 mode, and
// the serial and threads backends giving the same bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "host/solver/slit_poisson.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow::test {
namespace {

// phi = sin(pi y/H) cos(2 pi x/Lx) (1 + 0.5 sin(4 pi z/Lz)) + 0.3 y (H - y) sin(2 pi z/Lz) + 0.2 y (H - y)
struct Manufactured {
  double H, Lx, Lz;
  void eval(double x, double y, double z, double& lap, double g[3]) const {
    const double a = kPi / H, b = 2 * kPi / Lx, c = 4 * kPi / Lz, d = 2 * kPi / Lz;
    const double sy = std::sin(a * y), cy = std::cos(a * y), cx = std::cos(b * x), sx = std::sin(b * x);
    const double f = 1 + 0.5 * std::sin(c * z), fz = 0.5 * c * std::cos(c * z), fzz = -0.5 * c * c * std::sin(c * z);
    const double q = y * (H - y), qy = H - 2 * y;
    const double sz = std::sin(d * z), cz = std::cos(d * z);
    lap = -(a * a + b * b) * sy * cx * f + sy * cx * fzz + 0.3 * (-2.0 * sz - q * d * d * sz) + 0.2 * (-2.0);
    g[0] = -b * sy * sx * f;
    g[1] = a * cy * cx * f + 0.3 * qy * sz + 0.2 * qy;
    g[2] = sy * cx * fz + 0.3 * q * d * cz;
  }
};

TEST(SlitPoisson, GradientOfAManufacturedSolution) {
  const SlitGeometry geo{3.0, 4.0, 5.0, 1.0};
  const int nx = 16, nz = 20, N = 32;
  const Manufactured m{geo.H, geo.Lx, geo.Lz};
  std::vector<double> out[2][3];
  const Backend backends[2] = {Backend::Serial, Backend::Threads};
  for (int bi = 0; bi < 2; ++bi) {
    SlitPoissonGradient p(geo, nx, nz, N, backends[bi]);
    p.zero_source();
    double* s = p.source();
    double err = 0.0;
    for (int j = 0; j <= N; ++j)
      for (int i = 0; i < nx; ++i)
        for (int k = 0; k < nz; ++k) {
          const double y = 0.5 * geo.H * (1.0 - std::cos(kPi * j / N));
          double lap, g[3];
          m.eval(i * geo.Lx / nx, y, k * geo.Lz / nz, lap, g);
          s[(static_cast<std::size_t>(j) * nx + i) * nz + k] = lap;
        }
    p.solve();
    for (int j = 0; j <= N; ++j)
      for (int i = 0; i < nx; ++i)
        for (int k = 0; k < nz; ++k) {
          const double y = 0.5 * geo.H * (1.0 - std::cos(kPi * j / N));
          double lap, g[3];
          m.eval(i * geo.Lx / nx, y, k * geo.Lz / nz, lap, g);
          const std::size_t idx = (static_cast<std::size_t>(j) * nx + i) * nz + k;
          for (int c = 0; c < 3; ++c) err = std::max(err, std::abs(p.gradient(c)[idx] - g[c]));
        }
    EXPECT_LT(err, 1e-10) << (bi ? "threads" : "serial");
    for (int c = 0; c < 3; ++c) out[bi][c].assign(p.gradient(c), p.gradient(c) + p.grid_size());
  }
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(std::memcmp(out[0][c].data(), out[1][c].data(), out[0][c].size() * sizeof(double)), 0) << c;
}

}  // namespace
}  // namespace capsflow::test
