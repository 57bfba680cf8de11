// `capsflow demo` (demo.hpp): GGEM on point forces between the walls, its velocity profile and timings.
#include "host/cli/demo.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "host/base/atomic_file.hpp"
#include "host/base/backend_select.hpp"
#include "host/base/errors.hpp"
#include "host/solver/ggem_solver.hpp"
#include "host/solver/sample_problems.hpp"
#include "kernels/ggem_kernels.hpp"
#include "host/base/thread_limits.hpp"
#include <iostream>

namespace capsflow {
namespace fs = std::filesystem;
int run_demo(const std::string& out_dir, bool overwrite, int threads) {
  check_thread_count(threads, "--threads", std::cerr);
  const fs::path dir(out_dir);
  if (fs::exists(dir) && !fs::is_empty(dir) && !overwrite)
    throw InputError(out_dir + ": exists and is not empty (use --force to replace the demo's files in it)");
  fs::create_directories(dir);
  const Backend backend = backend_available(Backend::Threads) ? Backend::Threads : Backend::Serial;
  set_host_threads(threads);

  std::printf("capsflow demo: GGEM Stokes flow of point forces between two no-slip walls\n\n");

  // 1. One wall-parallel point force near the bottom wall: the velocity profile across the slit, 0.5 downstream,
  //    against the free-space Stokeslet (no walls). The walls bring the flow to rest at y = 0 and y = H.
  const SlitGeometry geo{4.0, 12.0, 12.0, 1.0};
  GgemSolver solver(geo, GgemOptions{}, backend);
  const double src[3] = {6.0, 1.0, 6.0}, F[3] = {1.0, 0.0, 0.0};
  const int n = 161;
  std::vector<double> tx(n, 6.5), ty(n), tz(n, 6.0), ux(n), uy(n), uz(n);
  for (int i = 0; i < n; ++i) ty[i] = geo.H * i / (n - 1);
  solver.apply(1, &src[0], &src[1], &src[2], &F[0], &F[1], &F[2], n, tx.data(), ty.data(), tz.data(), ux.data(),
               uy.data(), uz.data());
  std::vector<double> ufree(n);
  std::string csv = "y,ux_slit,ux_free_space\n";
  for (int i = 0; i < n; ++i) {
    double u[3] = {0, 0, 0};
    stokeslet_add(tx[i] - src[0], ty[i] - src[1], tz[i] - src[2], F[0], F[1], F[2], u[0], u[1], u[2]);
    ufree[i] = u[0] / (8.0 * kPi * geo.viscosity);
    char line[128];
    std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g\n", ty[i], ux[i], ufree[i]);
    csv += line;
  }
  write_file_atomically(dir / "profile.csv", csv);
  const auto& g = solver.grid();
  std::printf("1. Point force F = (1, 0, 0) at y = 1 in a slit H = 4, Lx = Lz = 12 (grid %d x %d x %d)\n", g.nx,
              g.ny + 1, g.nz);
  std::printf("   u_x on the walls: %.1e (y = 0), %.1e (y = H); peak %.4f at the force height\n", ux[0], ux[n - 1],
              ux[n / 4]);
  std::printf("   profile: %s (columns y, ux_slit, ux_free_space)\n\n", (dir / "profile.csv").c_str());

  // 2. The paper's set A box: 50 spheres x 162 nodes = 8100 point forces; velocity at every node.
  PointForceSet p = set_a_density(50, 2024u);
  GgemSolver box(p.geo, GgemOptions{}, backend);
  const std::size_t m = p.size();
  std::vector<double> u(3 * m);
  double best = 1e30;
  for (int rep = 0; rep < 3; ++rep) {
    box.apply(m, p.x.data(), p.y.data(), p.z.data(), p.fx.data(), p.fy.data(), p.fz.data(), m, p.x.data(),
              p.y.data(), p.z.data(), u.data(), u.data() + m, u.data() + 2 * m);
    best = std::min(best, box.last_timings().total);
  }
  const auto& t = box.last_timings();
  const auto& bg = box.grid();
  std::printf("2. Set A box (H = 10.15, Lx = Lz = 10.2, 8100 sources, grid %d x %d x %d), backend %s, %d thread(s)\n",
              bg.nx, bg.ny + 1, bg.nz, backend_name(backend), backend == Backend::Serial ? 1 : host_thread_count());
  std::printf("   full apply %.1f ms (best of 3): local %.1f, wall data %.1f, spread %.1f, global solve %.1f, "
              "interpolation %.1f ms\n\n",
              1e3 * best, 1e3 * t.local, 1e3 * t.wall_bc, 1e3 * t.spread, 1e3 * t.global_solve, 1e3 * t.interpolate);
  std::printf("Done. The profile is in %s.\n", (dir / "profile.csv").c_str());
  return 0;
}

}  // namespace capsflow
