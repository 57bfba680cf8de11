#include "kernels/double_layer_spread.hpp"

#include <cmath>
#include <vector>

#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

inline int wrap(int i, int n) {
  const int r = i % n;
  return r < 0 ? r + n : r;
}

}  // namespace

void spread_double_layer(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                         const double* sx, const double* sy, const double* sz, const double* qx, const double* qy,
                         const double* qz, const double* ax, const double* ay, const double* az, double* bx,
                         double* by, double* bz, double* s) {
  require_built(backend, "spread_double_layer");
  if (backend == Backend::Device) device_not_built("spread_double_layer (device)");
  const int nx = g.nx, nz = g.nz, np = g.N + 1;
  const double hx = g.hx, hz = g.hz;
  const double a2 = alpha * alpha, rc2 = cutoff * cutoff;
  const double Ch = 2.0 * a2 * a2 * alpha / (kPi * kSqrtPi), Cg = alpha * a2 / (kPi * kSqrtPi);
  const int wmax = static_cast<int>(std::ceil(2.0 * cutoff / std::min(hx, hz))) + 2;
  const long long nm = static_cast<long long>(ns);
#pragma omp parallel if (backend == Backend::Threads)
  {
    std::vector<double> ex(wmax), ez(wmax), dxs(wmax), dzs(wmax);
#pragma omp for schedule(dynamic, 1)
    for (int j = 0; j < np; ++j) {
      const double yj = g.y[j];
      for (long long m = 0; m < nm; ++m) {
        const double dy = yj - sy[m];
        const double rem = rc2 - dy * dy;
        if (rem < 0.0) continue;
        const double half = std::sqrt(rem);
        const int i0 = static_cast<int>(std::ceil((sx[m] - half) / hx));
        const int i1 = static_cast<int>(std::floor((sx[m] + half) / hx));
        const int k0 = static_cast<int>(std::ceil((sz[m] - half) / hz));
        const int k1 = static_cast<int>(std::floor((sz[m] + half) / hz));
        const int nix = i1 - i0 + 1, niz = k1 - k0 + 1;
        if (nix <= 0 || niz <= 0 || nix > wmax || niz > wmax) continue;
        for (int a = 0; a < nix; ++a) {
          dxs[a] = (i0 + a) * hx - sx[m];
          ex[a] = std::exp(-a2 * dxs[a] * dxs[a]);
        }
        for (int b = 0; b < niz; ++b) {
          dzs[b] = (k0 + b) * hz - sz[m];
          ez[b] = std::exp(-a2 * dzs[b] * dzs[b]);
        }
        const double ey = std::exp(-a2 * dy * dy);
        const double q[3] = {qx[m], qy[m], qz[m]}, av[3] = {ax[m], ay[m], az[m]};
        const double qa = q[0] * av[0] + q[1] * av[1] + q[2] * av[2];
        for (int a = 0; a < nix; ++a) {
          const double rx = dxs[a];
          const double rxy2 = rx * rx + dy * dy;
          if (rxy2 > rc2) continue;
          const std::size_t row = (static_cast<std::size_t>(j) * nx + wrap(i0 + a, nx)) * nz;
          const double exy = ey * ex[a];
          for (int b = 0; b < niz; ++b) {
            const double rz = dzs[b];
            const double r2 = rxy2 + rz * rz;
            if (r2 > rc2) continue;
            const double e = exy * ez[b];
            const double p = a2 * r2;
            const double h = Ch * e * (3.5 - p);
            const double ar = av[0] * rx + av[1] * dy + av[2] * rz;
            const double qr = q[0] * rx + q[1] * dy + q[2] * rz;
            const std::size_t idx = row + wrap(k0 + b, nz);
            bx[idx] += h * (q[0] * ar + av[0] * qr);
            by[idx] += h * (q[1] * ar + av[1] * qr);
            bz[idx] += h * (q[2] * ar + av[2] * qr);
            s[idx] += Cg * e * (2.5 - p) * qa;
          }
        }
      }
    }
  }
}

}  // namespace capsflow
