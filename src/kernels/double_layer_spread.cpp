// The implementation of double_layer_spread.hpp: the spreading of the double layer's global forcing onto the grid.
#include "kernels/double_layer_spread.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD) && (defined(__GNUC__) || defined(__clang__))
#define CAPSFLOW_DL_DEPOSIT_AVX512 1
#include <immintrin.h>
#endif

#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/simd_path.hpp"
#include "kernels/slit_cells.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

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
          const std::size_t idx =
              (static_cast<std::size_t>(j) * nx + slit_wrap_index(i0 + a, nx)) * nz + slit_wrap_index(k0 + b, nz);
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

// ---- Host: the single layer's prepared stencils (spread_interp.hpp's SpreadWorkspace) -------------------------------
// Same sources (the nodes), alpha and cutoff as the single layer's clouds: the x and z factors exp(-alpha^2 d^2) and
// (alpha d)^2 per stencil point, and the plane-major lists, made once per geometry, serve every application. Per
// (plane, row) the cloud is a contiguous run of z points (at most two pieces across the seam), deposited by a run
// body: portable, or 8 points per AVX-512 operation with masks.

// One row's constants: the x-y part of the cloud and of the two projections a.r, q.r.
struct DlRow {
  double exy, pxy;  // exp(-alpha^2 (dx^2 + dy^2)), alpha^2 (dx^2 + dy^2)
  double arxy, qrxy;
  double q[3], av[3], qa, Ch, Cg;
};

// Points t = 0..len-1 of a run: z offset dz0 + t hz, factors e[t] = exp(-alpha^2 dz^2) and qz[t] = alpha^2 dz^2.
struct PortableDlRun {
  void operator()(const DlRow& w, int len, double dz0, double hz, const double* __restrict e,
                  const double* __restrict qz, double* __restrict bx, double* __restrict by, double* __restrict bz,
                  double* __restrict s) const {
    for (int t = 0; t < len; ++t) {
      const double dz = dz0 + t * hz;
      const double ee = w.exy * e[t], p = w.pxy + qz[t];
      const double h = w.Ch * ee * (3.5 - p);
      const double ar = w.arxy + w.av[2] * dz, qr = w.qrxy + w.q[2] * dz;
      bx[t] += h * (w.q[0] * ar + w.av[0] * qr);
      by[t] += h * (w.q[1] * ar + w.av[1] * qr);
      bz[t] += h * (w.q[2] * ar + w.av[2] * qr);
      s[t] += w.Cg * ee * (2.5 - p) * w.qa;
    }
  }
};

#ifdef CAPSFLOW_DL_DEPOSIT_AVX512
struct Avx512DlRun {
  __attribute__((target("avx512f"))) inline void operator()(const DlRow& w, int len, double dz0, double hz,
                                                            const double* e, const double* qz, double* bx, double* by,
                                                            double* bz, double* s) const {
    const __m512d lane = _mm512_set_pd(7, 6, 5, 4, 3, 2, 1, 0);
    const __m512d vexy = _mm512_set1_pd(w.exy), vpxy = _mm512_set1_pd(w.pxy);
    const __m512d c35 = _mm512_set1_pd(3.5), c25 = _mm512_set1_pd(2.5), vCh = _mm512_set1_pd(w.Ch);
    const __m512d vCgqa = _mm512_set1_pd(w.Cg * w.qa);
    const __m512d q0 = _mm512_set1_pd(w.q[0]), q1 = _mm512_set1_pd(w.q[1]), q2 = _mm512_set1_pd(w.q[2]);
    const __m512d a0 = _mm512_set1_pd(w.av[0]), a1 = _mm512_set1_pd(w.av[1]), a2 = _mm512_set1_pd(w.av[2]);
    const __m512d varxy = _mm512_set1_pd(w.arxy), vqrxy = _mm512_set1_pd(w.qrxy), vhz = _mm512_set1_pd(hz);
    for (int t = 0; t < len; t += 8) {
      const int m = len - t < 8 ? len - t : 8;
      const __mmask8 k = static_cast<__mmask8>((1u << m) - 1u);
      const __m512d dz = _mm512_fmadd_pd(_mm512_add_pd(lane, _mm512_set1_pd(t)), vhz, _mm512_set1_pd(dz0));
      const __m512d ee = _mm512_mul_pd(vexy, _mm512_maskz_loadu_pd(k, e + t));
      const __m512d p = _mm512_add_pd(vpxy, _mm512_maskz_loadu_pd(k, qz + t));
      const __m512d h = _mm512_mul_pd(_mm512_mul_pd(vCh, ee), _mm512_sub_pd(c35, p));
      const __m512d ar = _mm512_fmadd_pd(a2, dz, varxy), qr = _mm512_fmadd_pd(q2, dz, vqrxy);
      const __m512d hx = _mm512_mul_pd(h, _mm512_fmadd_pd(q0, ar, _mm512_mul_pd(a0, qr)));
      const __m512d hy = _mm512_mul_pd(h, _mm512_fmadd_pd(q1, ar, _mm512_mul_pd(a1, qr)));
      const __m512d hzv = _mm512_mul_pd(h, _mm512_fmadd_pd(q2, ar, _mm512_mul_pd(a2, qr)));
      const __m512d sv = _mm512_mul_pd(_mm512_mul_pd(vCgqa, ee), _mm512_sub_pd(c25, p));
      _mm512_mask_storeu_pd(bx + t, k, _mm512_add_pd(_mm512_maskz_loadu_pd(k, bx + t), hx));
      _mm512_mask_storeu_pd(by + t, k, _mm512_add_pd(_mm512_maskz_loadu_pd(k, by + t), hy));
      _mm512_mask_storeu_pd(bz + t, k, _mm512_add_pd(_mm512_maskz_loadu_pd(k, bz + t), hzv));
      _mm512_mask_storeu_pd(s + t, k, _mm512_add_pd(_mm512_maskz_loadu_pd(k, s + t), sv));
    }
  }
};
#endif

// Plane j: its sources (the plane-major list, ascending) and each one's rows.
template <class Run>
inline void dl_deposit_plane(const SpreadWorkspace& ws, int j, const SlitGridView& g, double alpha, double rc,
                             const double* sx, const double* sy, const double* sz, const double* qx,
                             const double* qy, const double* qz, const double* ax, const double* ay,
                             const double* az, double* bx, double* by, double* bz, double* s, const Run& run) {
  const int nx = g.nx, nz = g.nz, W = ws.width;
  const double hx = g.hx, hz = g.hz, inv_hz = 1.0 / hz;
  const double a2 = alpha * alpha, inv_a2 = 1.0 / a2;
  DlRow w;
  w.Ch = 2.0 * a2 * a2 * alpha / (kPi * kSqrtPi);
  w.Cg = alpha * a2 / (kPi * kSqrtPi);
  for (int kk = ws.plane_start[j]; kk < ws.plane_start[j + 1]; ++kk) {
    const int m = ws.plane_src[kk];
    const double dy = g.y[j] - sy[m];
    const double rem_y = rc * rc - dy * dy;
    if (rem_y < 0.0) continue;
    const double qyy = a2 * dy * dy, ey = std::exp(-qyy);
    w.q[0] = qx[m], w.q[1] = qy[m], w.q[2] = qz[m];
    w.av[0] = ax[m], w.av[1] = ay[m], w.av[2] = az[m];
    w.qa = w.q[0] * w.av[0] + w.q[1] * w.av[1] + w.q[2] * w.av[2];
    const std::size_t o = static_cast<std::size_t>(m) * W;
    const double *exm = ws.ex.data() + o, *qxm = ws.qx.data() + o, *ezm = ws.ez.data() + o, *qzm = ws.qz.data() + o;
    const int nzm = ws.nzs[m], iz0 = ws.iz0[m];
    for (int a = 0; a < ws.nxs[m]; ++a) {
      const double rem = rem_y - qxm[a] * inv_a2;
      if (rem < 0.0) continue;
      const double half = std::sqrt(rem);
      int blo = static_cast<int>(std::ceil((sz[m] - half) * inv_hz)) - iz0;
      int bhi = static_cast<int>(std::floor((sz[m] + half) * inv_hz)) - iz0;
      if (blo < 0) blo = 0;
      if (bhi > nzm - 1) bhi = nzm - 1;
      if (blo > bhi) continue;
      const double dx = (ws.ix0[m] + a) * hx - sx[m];
      w.exy = ey * exm[a];
      w.pxy = qyy + qxm[a];
      w.arxy = w.av[0] * dx + w.av[1] * dy;
      w.qrxy = w.q[0] * dx + w.q[1] * dy;
      const std::size_t row = (static_cast<std::size_t>(j) * nx + slit_wrap_index(ws.ix0[m] + a, nx)) * nz;
      int b = blo, k = slit_wrap_index(iz0 + blo, nz);
      while (b <= bhi) {
        const int len = std::min(bhi - b + 1, nz - k);
        run(w, len, (iz0 + b) * hz - sz[m], hz, ezm + b, qzm + b, bx + row + k, by + row + k, bz + row + k,
            s + row + k);
        b += len;
        k = 0;
      }
    }
  }
}

#ifdef CAPSFLOW_DL_DEPOSIT_AVX512
bool dl_deposit_with_avx512() { return host_simd_path() == SimdPath::Avx512; }
__attribute__((target("avx512f"))) void dl_deposit_plane_avx512(const SpreadWorkspace& ws, int j,
                                                               const SlitGridView& g, double alpha, double rc,
                                                               const double* sx, const double* sy, const double* sz,
                                                               const double* qx, const double* qy, const double* qz,
                                                               const double* ax, const double* ay, const double* az,
                                                               double* bx, double* by, double* bz, double* s) {
  dl_deposit_plane(ws, j, g, alpha, rc, sx, sy, sz, qx, qy, qz, ax, ay, az, bx, by, bz, s, Avx512DlRun());
}
#endif

}  // namespace

void spread_double_layer_prepared(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                                  const double* sx, const double* sy, const double* sz, const double* qx,
                                  const double* qy, const double* qz, const double* ax, const double* ay,
                                  const double* az, double* bx, double* by, double* bz, double* s,
                                  const SpreadWorkspace& ws) {
  require_built(backend, "spread_double_layer_prepared");
  if (backend == Backend::Device)
    throw std::logic_error("spread_double_layer_prepared: host backends only (the device spreads per call)");
  if (ws.prepared_sources != ns || ws.prepared_backend != backend || ws.prepared_alpha != alpha ||
      ws.prepared_cutoff != cutoff || ws.plane_start.size() != static_cast<std::size_t>(g.N) + 2)
    throw std::logic_error("spread_double_layer_prepared: the workspace was not prepared for these sources");
  const int np = g.N + 1;
#ifdef CAPSFLOW_DL_DEPOSIT_AVX512
  if (dl_deposit_with_avx512()) {
#pragma omp parallel for schedule(dynamic, 1) if (backend == Backend::Threads)
    for (int j = 0; j < np; ++j)
      dl_deposit_plane_avx512(ws, j, g, alpha, cutoff, sx, sy, sz, qx, qy, qz, ax, ay, az, bx, by, bz, s);
    return;
  }
#endif
#pragma omp parallel for schedule(dynamic, 1) if (backend == Backend::Threads)
  for (int j = 0; j < np; ++j)
    dl_deposit_plane(ws, j, g, alpha, cutoff, sx, sy, sz, qx, qy, qz, ax, ay, az, bx, by, bz, s, PortableDlRun());
}

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
          const std::size_t row = (static_cast<std::size_t>(j) * nx + slit_wrap_index(i0 + a, nx)) * nz;
          const double exy = ey * ex[a];
          for (int b = 0; b < niz; ++b) {
            const double rz = dzs[b];
            const double r2 = rxy2 + rz * rz;
            if (r2 > rc2) continue;
            const CloudShare c = dl_cloud_share(Ch, Cg, exy * ez[b], a2 * r2, q, av, qa, rx, dy, rz);
            const std::size_t idx = row + slit_wrap_index(k0 + b, nz);
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
