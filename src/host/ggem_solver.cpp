#include "host/ggem_solver.hpp"

#include <chrono>
#include <cmath>
#include <sstream>

#include "host/errors.hpp"
#include "host/slit_stokes_plan.hpp"
#include "host/slit_stokes_plan_device.hpp"
#include "host/stopwatch.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/local_sum.hpp"
#include "kernels/spread_interp.hpp"

namespace capsflow {
namespace {

// Smallest n' >= n whose prime factors are 2, 3, 5 and 7 (sizes FFTW transforms fast).
int next_fast_size(int n) {
  for (int m = std::max(n, 1);; ++m) {
    int r = m;
    for (int p : {2, 3, 5, 7})
      while (r % p == 0) r /= p;
    if (r == 1) return m;
  }
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}


}  // namespace

GgemGrid resolve_ggem_grid(const SlitGeometry& geo, const GgemOptions& opt) {
  auto require_positive = [](double v, const char* key) {
    if (!(v > 0.0) || !std::isfinite(v)) throw InputError(std::string(key) + ": expected a positive number, got " + num(v));
  };
  require_positive(geo.H, "[domain] H");
  require_positive(geo.Lx, "[domain] Lx");
  require_positive(geo.Lz, "[domain] Lz");
  require_positive(geo.viscosity, "[domain] viscosity");
  require_positive(opt.alpha, "[ggem] alpha");
  if (!(opt.alpha_hm > 0.0 && opt.alpha_hm <= 2.0))
    throw InputError("[ggem] alpha_hm: expected 0 < alpha_hm <= 2, got " + num(opt.alpha_hm));
  GgemGrid g;
  g.alpha = opt.alpha;
  g.cutoff = opt.cutoff > 0.0 ? opt.cutoff : default_cutoff(opt.alpha);
  g.spread_cutoff = default_spread_cutoff(opt.alpha);
  if (opt.cutoff < 0.0) throw InputError("[ggem] cutoff: expected a positive number, got " + num(opt.cutoff));
  for (auto [L, key] : {std::pair{geo.Lx, "Lx"}, std::pair{geo.Lz, "Lz"}})
    if (L < 2.0 * g.cutoff)
      throw InputError(std::string("[domain] ") + key + " = " + num(L) + " is too small for the cutoff " +
                       num(g.cutoff) + ": need " + key + " >= 2 * cutoff = " + num(2.0 * g.cutoff));
  if (const std::string e = ggem_grid_size_error(geo, opt); !e.empty()) throw InputError(e);
  const double hm = opt.alpha_hm / opt.alpha;
  auto fourier = [&](int given, double L, const char* key) {
    if (given != 0 && given < 8) throw InputError(std::string("[ggem] ") + key + ": expected >= 8, got " + std::to_string(given));
    return given > 0 ? given : next_fast_size(std::max(8, static_cast<int>(std::ceil(L / hm - 1e-9))));
  };
  g.nx = fourier(opt.nx, geo.Lx, "nx");
  g.nz = fourier(opt.nz, geo.Lz, "nz");
  if (opt.ny != 0 && opt.ny < 8) throw InputError("[ggem] ny: expected >= 8, got " + std::to_string(opt.ny));
  if (opt.ny > 0) {
    g.ny = opt.ny;
  } else if (opt.chebyshev_rule == "midchannel") {
    // Mid-channel Gauss-Lobatto spacing pi H / (2N) at most h_m (D9).
    g.ny = next_fast_size(std::max(8, static_cast<int>(std::ceil(kPi * geo.H / (2.0 * hm) - 1e-9))));
  } else if (opt.chebyshev_rule == "mean") {
    g.ny = next_fast_size(std::max(8, static_cast<int>(std::ceil(geo.H / hm - 1e-9))));
  } else {
    throw InputError("[ggem] chebyshev_rule: expected \"midchannel\" or \"mean\", got \"" + opt.chebyshev_rule + "\"");
  }
  g.hx = geo.Lx / g.nx;
  g.hz = geo.Lz / g.nz;
  return g;
}

std::string ggem_grid_size_error(const SlitGeometry& geo, const GgemOptions& opt) {
  const double hm = opt.alpha_hm / opt.alpha, max = kMaxGridPointsPerDirection;
  const bool mid = opt.chebyshev_rule != "mean";
  struct Dir {
    const char* axis;
    const char* length_key;
    double L;
    int given;
    double factor;  // points = factor * L / h_m
  };
  const Dir dirs[] = {{"x", "Lx", geo.Lx, opt.nx, 1.0},
                      {"z", "Lz", geo.Lz, opt.nz, 1.0},
                      {"y (Chebyshev N)", "H", geo.H, opt.ny, mid ? kPi / 2.0 : 1.0}};
  for (const Dir& d : dirs) {
    if (d.given > max)
      return std::string("[ggem] n") + (d.axis[0] == 'y' ? "y" : d.axis) + ": expected at most " + std::to_string(static_cast<long>(max)) +
             " grid points, got " + std::to_string(d.given);
    if (d.given > 0) continue;
    const double points = d.factor * d.L / hm;
    if (points <= max) continue;
    // Blame the length when even the default alpha (4, alpha_hm 0.5) would ask for too many points.
    const bool length = d.factor * d.L * 8.0 > max;
    return std::string(length ? "[domain] " : "[ggem] ") + (length ? d.length_key : "alpha") + ": " +
           d.length_key + " = " + num(d.L) + ", alpha = " + num(opt.alpha) + ", alpha_hm = " + num(opt.alpha_hm) +
           " ask for " + num(points) + " grid points along " + d.axis + " (" + (d.factor != 1.0 ? "pi/2 " : "") +
           d.length_key + " alpha / alpha_hm); expected at most " + std::to_string(static_cast<long>(max)) + " (lower alpha or " + d.length_key +
           ", or raise alpha_hm)";
  }
  return "";
}

GgemSolver::GgemSolver(const SlitGeometry& geo, const GgemOptions& opt, Backend backend)
    : geo_(geo), grid_(resolve_ggem_grid(geo, opt)), backend_(backend) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  // The device backend's global solve runs on the device, on grids resident for the solver's lifetime.
  if (backend_ == Backend::Device)
    device_plan_ = std::make_unique<SlitStokesPlanDevice>(geo_, grid_);
  else
#endif
    plan_ = std::make_unique<SlitStokesPlan>(geo_, grid_, backend_);
  const int nx = grid_.nx, nz = grid_.nz;
  const std::size_t nw = static_cast<std::size_t>(nx) * nz;
  for (auto& w : wall_pts_) w.resize(2 * nw);
  for (int side = 0; side < 2; ++side)
    for (int i = 0; i < nx; ++i)
      for (int k = 0; k < nz; ++k) {
        const std::size_t p = side * nw + static_cast<std::size_t>(i) * nz + k;
        wall_pts_[0][p] = i * grid_.hx;
        wall_pts_[1][p] = side == 0 ? 0.0 : geo_.H;
        wall_pts_[2][p] = k * grid_.hz;
      }
}

GgemSolver::~GgemSolver() = default;

void GgemSolver::apply(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx,
                       const double* fy, const double* fz, std::size_t nt, const double* tx, const double* ty,
                       const double* tz, double* ux, double* uy, double* uz) {
  // x and z may take any value (periodic): wrap them into [0, L) first, exactly (fmod), so that the kernels' cell and
  // grid indices stay in range; a coordinate of 1e9 would otherwise overflow an int index (zero or NaN velocities).
  auto wrapped = [](std::size_t n, const double* v, double L, std::vector<double>& buf) -> const double* {
    std::size_t i = 0;
    while (i < n && v[i] >= 0.0 && v[i] < L) ++i;
    if (i == n) return v;
    buf.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      double w = std::fmod(v[k], L);
      if (w < 0.0) w += L;
      buf[k] = w < L ? w : 0.0;  // -1e-300 + L rounds to L
    }
    return buf.data();
  };
  sx = wrapped(ns, sx, geo_.Lx, wrap_buf_[0]);
  sz = wrapped(ns, sz, geo_.Lz, wrap_buf_[1]);
  tx = wrapped(nt, tx, geo_.Lx, wrap_buf_[2]);
  tz = wrapped(nt, tz, geo_.Lz, wrap_buf_[3]);
  const auto t_start = std::chrono::steady_clock::now();
  const double scale = 1.0 / (8.0 * kPi * geo_.viscosity);
  const double alpha = grid_.alpha, rc = grid_.cutoff;

  // Local part at the targets.
  auto t0 = std::chrono::steady_clock::now();
  PointCellList cells;
  build_point_cell_list(cells, geo_.Lx, geo_.H, geo_.Lz, rc, ns, sx, sy, sz, fx, fy, fz);
  for (std::size_t i = 0; i < nt; ++i) ux[i] = uy[i] = uz[i] = 0.0;
  local_velocity_point_forces(backend_, cells, alpha, rc, scale, nt, tx, ty, tz, ux, uy, uz);
  timings_.local = seconds_since(t0);

  // The local velocity at the wall grid points: the global part's wall data is its negative (6.3).
  t0 = std::chrono::steady_clock::now();
  const std::size_t nwall = wall_pts_[0].size();
  for (auto& w : wall_u_) w.assign(nwall, 0.0);
  local_velocity_point_forces(backend_, cells, alpha, rc, scale, nwall, wall_pts_[0].data(), wall_pts_[1].data(),
                              wall_pts_[2].data(), wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data());
  timings_.wall_bc = seconds_since(t0);

  const double* wall_local[3] = {wall_u_[0].data(), wall_u_[1].data(), wall_u_[2].data()};
  apply_global(ns, sx, sy, sz, fx, fy, fz, wall_local, nt, tx, ty, tz, ux, uy, uz);
  timings_.total = seconds_since(t_start);
}

void GgemSolver::apply_global(std::size_t ns, const double* sx, const double* sy, const double* sz, const double* fx,
                              const double* fy, const double* fz, const double* const wall_local_u[3],
                              std::size_t nt, const double* tx, const double* ty, const double* tz, double* ux,
                              double* uy, double* uz) {
  const double mu = geo_.viscosity;
  const int nx = grid_.nx, nz = grid_.nz;
  if (device_plan_) {
    // Device: every stage a kernel on the resident grids; wall negation and f / mu inside the kernels. The inputs may
    // be resident already (their map clauses then copy nothing) or host arrays (copied in, u copied back).
    SlitStokesPlanDevice& dp = *device_plan_;
    SlitGridView view{nx, nz, grid_.ny, grid_.hx, grid_.hz, geo_.H, dp.y_nodes().data()};
    auto t0 = std::chrono::steady_clock::now();
    dp.zero_forcing_and_walls();
    dp.set_walls_negated(wall_local_u);
    spread_forces(backend_, view, grid_.alpha, grid_.spread_cutoff, ns, sx, sy, sz, fx, fy, fz, dp.forcing(0),
                  dp.forcing(1), dp.forcing(2), spread_ws_, mu);
    timings_.spread = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    dp.solve();
    timings_.global_solve = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    interpolate_velocity(backend_, view, dp.velocity(0), dp.velocity(1), dp.velocity(2), nt, tx, ty, tz, ux, uy, uz);
    timings_.interpolate = seconds_since(t0);
    return;
  }
  SlitStokesPlan& plan = *plan_;
  plan.zero_forcing_and_walls();
  const std::size_t nw = static_cast<std::size_t>(nx) * nz;
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c) {
      double* w = plan.wall(side, c);
      const double* ul = wall_local_u[c] + side * nw;
      for (std::size_t p = 0; p < nw; ++p) w[p] = -ul[p];
    }

  // Global forcing: clouds of f / mu.
  auto t0 = std::chrono::steady_clock::now();
  SlitGridView view{nx, nz, grid_.ny, grid_.hx, grid_.hz, geo_.H, plan.y_nodes().data()};
  spread_forces(backend_, view, grid_.alpha, grid_.spread_cutoff, ns, sx, sy, sz, fx, fy, fz, plan.forcing(0),
                plan.forcing(1), plan.forcing(2), spread_ws_, mu);
  timings_.spread = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  plan.solve();
  timings_.global_solve = seconds_since(t0);

  t0 = std::chrono::steady_clock::now();
  interpolate_velocity(backend_, view, plan.velocity(0), plan.velocity(1), plan.velocity(2), nt, tx, ty, tz, ux, uy,
                       uz);
  timings_.interpolate = seconds_since(t0);
}

}  // namespace capsflow
