// The implementation of slit_parameters.hpp: the slit and its GGEM grid as values, with their checks.
#include "host/solver/slit_parameters.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "host/base/errors.hpp"
#include "kernels/ggem_kernels.hpp"

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

double ggem_alpha_hm_for(double tolerance) {
  const double t = std::clamp(tolerance, kMinGgemTolerance, kMaxGgemTolerance);
  return std::sqrt(1.15 / std::log(0.12 / (0.5 * t)));
}

double ggem_cutoff_alpha_for(double tolerance) {
  const double t = std::clamp(tolerance, kMinGgemTolerance, kMaxGgemTolerance);
  return std::max(kMinCutoffAlpha, std::sqrt(std::log(6.2 / (0.5 * t)) / 0.91));
}

GgemOptions with_ggem_tolerance(GgemOptions o, double tolerance) {
  o.tolerance = tolerance;
  o.alpha_hm = ggem_alpha_hm_for(tolerance);
  o.cutoff = ggem_cutoff_alpha_for(tolerance) / o.alpha;
  return o;
}

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
  // Below 2 / alpha the local sum drops erfc(2) ~ 0.5 % of the screened kernel and more: wrong physics, silently.
  if (opt.cutoff > 0.0 && opt.cutoff * opt.alpha < kMinCutoffAlpha)
    throw InputError("[ggem] cutoff: expected at least " + num(kMinCutoffAlpha) + " / alpha = " +
                     num(kMinCutoffAlpha / opt.alpha) + " (the local kernel is not yet screened below it; default " +
                     "3.5 / alpha = " + num(default_cutoff(opt.alpha)) + "), got " + num(opt.cutoff));
  for (auto [L, key] : {std::pair{geo.Lx, "Lx"}, std::pair{geo.Lz, "Lz"}})
    if (L < 2.0 * g.cutoff) {
      // A cutoff from alpha's default is alpha's doing: name the key the user would change.
      if (opt.cutoff == 0.0)
        throw InputError("[ggem] alpha: alpha = " + num(opt.alpha) + " gives the local cutoff 3.5 / alpha = " +
                         num(g.cutoff) + ", which needs [domain] " + key + " >= 2 * cutoff = " +
                         num(2.0 * g.cutoff) + " (" + key + " = " + num(L) + "); expected a larger alpha (or " +
                         key + ")");
      throw InputError(std::string("[domain] ") + key + " = " + num(L) + " is too small for the cutoff " +
                       num(g.cutoff) + ": need " + key + " >= 2 * cutoff = " + num(2.0 * g.cutoff));
    }
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

}  // namespace capsflow
