#include "kernels/double_layer_spread.hpp"

#include <cmath>
#include <vector>

#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

inline int wrap(int i, int n) {
  const int r = i % n;
  return r < 0 ? r + n : r;
}

// One grid point's share of a density element's cloud, r from the element: the body force h(r) [q (a.r) + a (q.r)]
// and the source's g(r) (q.a), from e = exp(-alpha^2 r^2) and p = alpha^2 r^2 (h = Ch e (7/2 - p), g = Cg e (5/2 - p)).
// Every backend deposits these same terms.
struct CloudShare {
  double bx, by, bz, s;
};
inline CloudShare dl_cloud_share(double Ch, double Cg, double e, double p, const double* q, const double* av, double qa,
                                 double rx, double ry, double rz) {
  const double h = Ch * e * (3.5 - p);
  const double ar = av[0] * rx + av[1] * ry + av[2] * rz;
  const double qr = q[0] * rx + q[1] * ry + q[2] * rz;
  return {h * (q[0] * ar + av[0] * qr), h * (q[1] * ar + av[1] * qr), h * (q[2] * ar + av[2] * qr),
          Cg * e * (2.5 - p) * qa};
}

CAPSFLOW_DEVICE_END

#ifdef CAPSFLOW_HAVE_OFFLOAD
// The device: a team per source, a thread per grid point of its cutoff box, atomic deposits (sources overlap), as
// the single layer's device spreading. The same terms as the host loop, the Gaussian as one exp instead of the
// product of three: round-off apart from serial, like every atomic sum.
void spread_double_layer_device(const SlitGridView& g, double alpha, double cutoff, std::size_t ns, const double* sx,
                                const double* sy, const double* sz, const double* qx, const double* qy,
                                const double* qz, const double* ax, const double* ay, const double* az, double* bx,
                                double* by, double* bz, double* s) {
  const int nx = g.nx, nz = g.nz, np = g.N + 1;
  const double hx = g.hx, hz = g.hz;
  const double* yv = g.y;
  const std::size_t ng = static_cast<std::size_t>(np) * nx * nz;
  const double a2 = alpha * alpha, rc2 = cutoff * cutoff;
  const double Ch = 2.0 * a2 * a2 * alpha / (kPi * kSqrtPi), Cg = alpha * a2 / (kPi * kSqrtPi);
  const int nsi = static_cast<int>(ns);
#pragma omp target teams distribute map(to : sx[0:ns], sy[0:ns], sz[0:ns], qx[0:ns], qy[0:ns], qz[0:ns], ax[0:ns], \
                                            ay[0:ns], az[0:ns], yv[0:np])                                        \
    map(tofrom : bx[0:ng], by[0:ng], bz[0:ng], s[0:ng])
  for (int m = 0; m < nsi; ++m) {
    int jlo = np, jhi = -1;  // the planes within the cutoff (the Chebyshev planes are not evenly spaced)
    for (int j = 0; j < np; ++j) {
      const double dy = yv[j] - sy[m];
      if (dy * dy <= rc2) {
        jlo = j < jlo ? j : jlo;
        jhi = j > jhi ? j : jhi;
      }
    }
    const int i0 = static_cast<int>(std::ceil((sx[m] - cutoff) / hx));
    const int i1 = static_cast<int>(std::floor((sx[m] + cutoff) / hx));
    const int k0 = static_cast<int>(std::ceil((sz[m] - cutoff) / hz));
    const int k1 = static_cast<int>(std::floor((sz[m] + cutoff) / hz));
    const int nj = jhi - jlo + 1, nix = i1 - i0 + 1, niz = k1 - k0 + 1;
    const double q[3] = {qx[m], qy[m], qz[m]}, av[3] = {ax[m], ay[m], az[m]};
    const double qa = q[0] * av[0] + q[1] * av[1] + q[2] * av[2];
#pragma omp parallel for collapse(3)
    for (int jj = 0; jj < nj; ++jj)
      for (int a = 0; a < nix; ++a)
        for (int b = 0; b < niz; ++b) {
          const int j = jlo + jj;
          const double dy = yv[j] - sy[m];
          const double rx = (i0 + a) * hx - sx[m], rz = (k0 + b) * hz - sz[m];
          const double r2 = rx * rx + dy * dy + rz * rz;
          if (r2 > rc2) continue;
          const double p = a2 * r2;
          const CloudShare c = dl_cloud_share(Ch, Cg, std::exp(-p), p, q, av, qa, rx, dy, rz);
          const std::size_t idx = (static_cast<std::size_t>(j) * nx + wrap(i0 + a, nx)) * nz + wrap(k0 + b, nz);
#pragma omp atomic update
          bx[idx] += c.bx;
#pragma omp atomic update
          by[idx] += c.by;
#pragma omp atomic update
          bz[idx] += c.bz;
#pragma omp atomic update
          s[idx] += c.s;
        }
  }
}
#endif

}  // namespace

void spread_double_layer(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                         const double* sx, const double* sy, const double* sz, const double* qx, const double* qy,
                         const double* qz, const double* ax, const double* ay, const double* az, double* bx,
                         double* by, double* bz, double* s) {
  require_built(backend, "spread_double_layer");
  if (backend == Backend::Device) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
    spread_double_layer_device(g, alpha, cutoff, ns, sx, sy, sz, qx, qy, qz, ax, ay, az, bx, by, bz, s);
#endif
    return;
  }
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
            const CloudShare c = dl_cloud_share(Ch, Cg, exy * ez[b], a2 * r2, q, av, qa, rx, dy, rz);
            const std::size_t idx = row + wrap(k0 + b, nz);
            bx[idx] += c.bx;
            by[idx] += c.by;
            bz[idx] += c.bz;
            s[idx] += c.s;
          }
        }
      }
    }
  }
}

}  // namespace capsflow
