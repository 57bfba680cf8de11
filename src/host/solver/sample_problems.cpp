// The implementation of sample_problems.hpp: reproducible problems shared by the benchmarks, the tests and the demo.
#include "host/solver/sample_problems.hpp"

#include <cmath>
#include <random>

#include "host/base/errors.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {

PointForceSet clustered_spheres(int n_spheres, double H, double L, std::uint64_t seed) {
  if (H < 2.2) throw InputError("clustered_spheres: H must exceed 2.2 for spheres of radius 1");
  PointForceSet p;
  p.geo = SlitGeometry{H, L, L, 1.0};
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(0.0, L), uy(1.05, H - 1.05), uf(-1.0, 1.0);
  std::vector<double> cx, cy, cz;
  long attempts = 0;
  while (static_cast<int>(cx.size()) < n_spheres) {
    if (++attempts > 1000000L * (n_spheres + 1))
      throw InputError("clustered_spheres: cannot place " + std::to_string(n_spheres) + " spheres in the box");
    const double x = ux(rng), y = uy(rng), z = ux(rng);
    bool ok = true;
    for (std::size_t k = 0; k < cx.size() && ok; ++k) {
      const double dx = min_image(x - cx[k], L), dz = min_image(z - cz[k], L), dy = y - cy[k];
      ok = dx * dx + dy * dy + dz * dz >= 2.1 * 2.1;
    }
    if (ok) {
      cx.push_back(x);
      cy.push_back(y);
      cz.push_back(z);
    }
  }
  const int nv = 162;
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n_spheres; ++k) {
    double sum[3] = {0, 0, 0};
    const std::size_t first = p.size();
    for (int i = 0; i < nv; ++i) {
      const double zz = 1.0 - 2.0 * (i + 0.5) / nv, r = std::sqrt(1.0 - zz * zz), ph = golden * i;
      p.x.push_back(std::fmod(cx[k] + r * std::cos(ph) + L, L));
      p.y.push_back(cy[k] + zz);
      p.z.push_back(std::fmod(cz[k] + r * std::sin(ph) + L, L));
      const double f[3] = {uf(rng), uf(rng), uf(rng)};
      p.fx.push_back(f[0]);
      p.fy.push_back(f[1]);
      p.fz.push_back(f[2]);
      for (int c = 0; c < 3; ++c) sum[c] += f[c];
    }
    for (std::size_t i = first; i < p.size(); ++i) {
      p.fx[i] -= sum[0] / nv;
      p.fy[i] -= sum[1] / nv;
      p.fz[i] -= sum[2] / nv;
    }
  }
  return p;
}

PointForceSet set_a_density(int n_spheres, std::uint64_t seed) {
  return clustered_spheres(n_spheres, 10.15, 10.2 * std::sqrt(n_spheres / 50.0), seed);
}

const char* set_a_step_problem_toml() {
  return R"(
[domain]
H = 10.15
Lx = 10.2
Lz = 10.2
[ggem]
alpha = 4.0
alpha_hm = 0.5
[flow]
type = "poiseuille"
[capsules]
mesh_level = 2
inflation = 0.1
[[species]]
name = "stiff"
ca = 0.2
[[species]]
name = "floppy"
ca = 1.0
[suspension]
volume_fraction = 0.2
fractions = [0.5, 0.5]
seed = 1
[time]
end = 100.0
)";
}

std::string set_a_step_problem_toml_at_tolerance(const std::string& tolerance) {
  std::string text = set_a_step_problem_toml();
  const std::string key = "alpha_hm = 0.5";
  text.replace(text.find(key), key.size(), "tolerance = " + tolerance);
  return text;
}

}  // namespace capsflow
