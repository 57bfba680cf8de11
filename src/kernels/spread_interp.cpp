// The implementation of spread_interp.hpp: the spreading of GGEM clouds onto the grid and interpolation back.
#include "kernels/spread_interp.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD)
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

// One contiguous run of a row, portable: p += cf g with g = (2.5 - q) e the cloud's values (e = exp(-q) factors).
// Atomic: the device, where sources deposit concurrently; the host backends order their sources so that no two
// threads write one point (race-free, and the serial sums' order).
template <bool Atomic>
struct PortableRunDeposit {
  void operator()(int len, const double* __restrict e, const double* __restrict q, double exy, double qxy, double cfx,
                  double cfy, double cfz, double* __restrict px, double* __restrict py, double* __restrict pz) const {
    for (int t = 0; t < len; ++t) {
      const double ee = exy * e[t];
      const double qq = qxy + q[t];
      const double g = (2.5 - qq) * ee;
      if constexpr (Atomic) {
#pragma omp atomic update
        px[t] += cfx * g;
#pragma omp atomic update
        py[t] += cfy * g;
#pragma omp atomic update
        pz[t] += cfz * g;
      } else {
        px[t] += cfx * g;
        py[t] += cfy * g;
        pz[t] += cfz * g;
      }
    }
  }
};

// Source m's cloud on plane j: the y factor and the squared radius left for x and z.
struct PlaneCloud {
  double rem_y, qy, cfx, cfy, cfz;
};

// False when plane j lies outside source m's cutoff sphere.
// The forces are divided by `div` here (the viscosity: the clouds of f / mu), so no caller keeps a scaled copy; for
// div = 1 the quotient is exact and the sums are those of pre-divided forces bit for bit.
inline bool plane_cloud(int m, int j, const double* yv, double alpha, double rc, const double* sy, const double* fx,
                        const double* fy, const double* fz, double div, PlaneCloud& p) {
  const double a2 = alpha * alpha;
  const double C = alpha * a2 / (kPi * kSqrtPi);
  const double dy = yv[j] - sy[m];
  p.rem_y = rc * rc - dy * dy;
  if (p.rem_y < 0.0) return false;
  p.qy = a2 * dy * dy;
  const double ey = std::exp(-p.qy);
  p.cfx = C * (fx[m] / div) * ey;
  p.cfy = C * (fy[m] / div) * ey;
  p.cfz = C * (fz[m] / div) * ey;
  return true;
}

// The one deposit body of every backend: source m's cloud on the (plane j, stencil column a) row. The sphere
// |r| <= cutoff makes the row a contiguous run of z points, walked in at most two pieces across the periodic seam;
// each piece goes to the run functor (portable, atomic on the device, or the host's AVX-512 run).
template <class Run>
inline void deposit_row(const PlaneCloud& p, int m, int j, int a, int nx, int nz, double hz, double alpha,
                        const double* sz, int width, const int* ix0, const double* ex, const double* qx,
                        const int* iz0, const int* nzs, const double* ez, const double* qz, double* rx, double* ry,
                        double* rz, const Run& run) {
  const double inv_a2 = 1.0 / (alpha * alpha), inv_hz = 1.0 / hz;
  const double* exm = ex + static_cast<std::size_t>(m) * width;
  const double* qxm = qx + static_cast<std::size_t>(m) * width;
  const double* ezm = ez + static_cast<std::size_t>(m) * width;
  const double* qzm = qz + static_cast<std::size_t>(m) * width;
  const int nzm = nzs[m];
  const double dx2 = qxm[a] * inv_a2;
  const double rem = p.rem_y - dx2;
  if (rem < 0.0) return;
  // z stencil points with dz^2 <= rem: a contiguous range [blo, bhi] of the source's z stencil.
  const double half = std::sqrt(rem);
  const double zc = sz[m];
  int blo = static_cast<int>(std::ceil((zc - half) * inv_hz)) - iz0[m];
  int bhi = static_cast<int>(std::floor((zc + half) * inv_hz)) - iz0[m];
  if (blo < 0) blo = 0;
  if (bhi > nzm - 1) bhi = nzm - 1;
  if (blo > bhi) return;
  const int i = slit_wrap_index(ix0[m] + a, nx);
  const std::size_t row = (static_cast<std::size_t>(j) * nx + i) * nz;
  const double exy = exm[a], qxy = qxm[a] + p.qy;
  int b = blo;
  int k = slit_wrap_index(iz0[m] + blo, nz);
  while (b <= bhi) {
    const int len = std::min(bhi - b + 1, nz - k);
    run(len, ezm + b, qzm + b, exy, qxy, p.cfx, p.cfy, p.cfz, rx + row + k, ry + row + k, rz + row + k);
    b += len;
    k = 0;
  }
}

// Points per direction of the tensor-product Lagrange interpolation (kInterpPoints - 1 is the degree).
constexpr int kInterpPoints = 9;  // degree 8: quartic (5 points) leaves 1e-3 to 5e-3 errors near sources (docs/method.md)
constexpr int kInterpHalf = kInterpPoints / 2;

// Lagrange weights at nodes xs[0..kInterpPoints-1] for the point x.
inline void lagrange_weights(const double* xs, double x, double* w) {
  for (int o = 0; o < kInterpPoints; ++o) {
    double num = 1.0, den = 1.0;
    for (int p = 0; p < kInterpPoints; ++p) {
      if (p == o) continue;
      num *= x - xs[p];
      den *= xs[o] - xs[p];
    }
    w[o] = num / den;
  }
}

// The interpolation stencil of a point: its nearest grid indices ix, iz, the first of its P Chebyshev planes jlo
// (the nearest plane by inverting y_j = (H/2)(1 - cos(pi j/N)), shifted inward at the walls) and the Lagrange
// weights along x, z and y. Shared by the scalar and the AVX-512 interpolation.
struct InterpStencil {
  int ix, iz, jlo;
  double wx[kInterpPoints], wz[kInterpPoints], wy[kInterpPoints];
};

inline void interp_stencil(int N, double hx, double hz, double H, const double* yv, double x, double y, double z,
                           InterpStencil& st) {
  constexpr int P = kInterpPoints, h = kInterpHalf;
  double offs[P], ys[P];
  for (int o = 0; o < P; ++o) offs[o] = o - h;
  const double tx = x / hx, tz = z / hz;
  st.ix = static_cast<int>(std::floor(tx + 0.5));
  st.iz = static_cast<int>(std::floor(tz + 0.5));
  lagrange_weights(offs, tx - st.ix, st.wx);
  lagrange_weights(offs, tz - st.iz, st.wz);
  double c = 1.0 - 2.0 * y / H;
  c = c < -1.0 ? -1.0 : (c > 1.0 ? 1.0 : c);
  const int jn = static_cast<int>(std::floor(N * std::acos(c) / kPi + 0.5));
  int jlo = jn - h;
  if (jlo < 0) jlo = 0;
  if (jlo > N + 1 - P) jlo = N + 1 - P;
  st.jlo = jlo;
  for (int o = 0; o < P; ++o) ys[o] = yv[jlo + o];
  lagrange_weights(ys, y, st.wy);
}

inline void interpolate_point(int nx, int nz, int N, double hx, double hz, double H, const double* yv,
                              const double* gx, const double* gy, const double* gz, double x, double y, double z,
                              double& ux, double& uy, double& uz) {
  constexpr int P = kInterpPoints, h = kInterpHalf;
  InterpStencil st;
  interp_stencil(N, hx, hz, H, yv, x, y, z, st);
  const int ix = st.ix, iz = st.iz, jlo = st.jlo;
  const double *wx = st.wx, *wz = st.wz, *wy = st.wy;
  double sx = 0.0, sy = 0.0, sz = 0.0;
  for (int oy = 0; oy < P; ++oy) {
    for (int ox = 0; ox < P; ++ox) {
      const int i = slit_wrap_index(ix + ox - h, nx);
      const std::size_t row = (static_cast<std::size_t>(jlo + oy) * nx + i) * nz;
      const double wxy = wy[oy] * wx[ox];
      for (int oz = 0; oz < P; ++oz) {
        const std::size_t idx = row + slit_wrap_index(iz + oz - h, nz);
        const double w = wxy * wz[oz];
        sx += w * gx[idx];
        sy += w * gy[idx];
        sz += w * gz[idx];
      }
    }
  }
  ux += sx;
  uy += sy;
  uz += sz;
}

// One axis of a source's stencil: the first grid index, the count, and q = (alpha d)^2, e = exp(-q) per point.
inline void stencil_axis(double c, double h, int n, int W, double alpha, double rc, int& i0, int& cnt, double* e,
                         double* q) {
  const double a2 = alpha * alpha;
  i0 = static_cast<int>(std::ceil((c - rc) / h));
  cnt = static_cast<int>(std::floor((c + rc) / h)) - i0 + 1;
  const int lim = n < W ? n : W;  // a period shorter than the stencil never double-counts a point
  cnt = cnt < lim ? cnt : lim;
  for (int a = 0; a < cnt; ++a) {
    const double d = (i0 + a) * h - c;
    q[a] = a2 * d * d;
    e[a] = std::exp(-q[a]);
  }
}

// First index j in [0, n) with y[j] >= v (upper: y[j] > v), n if none: std::lower_bound / upper_bound on the
// increasing plane positions, as plain loops for the device.
inline int first_plane_at_least(const double* y, int n, double v, bool upper) {
  int lo = 0, len = n;
  while (len > 0) {
    const int half = len / 2;
    const bool before = upper ? !(v < y[lo + half]) : y[lo + half] < v;
    if (before) {
      lo += half + 1;
      len -= half + 1;
    } else {
      len = half;
    }
  }
  return lo;
}

// 1D stencils in x and z and the y-plane range of source m (flat arrays, W values per source).
inline void prepare_source_flat(int m, int nx, int nz, int N, double hx, double hz, const double* y, int W,
                                double alpha, double rc, const double* sx, const double* sy, const double* sz,
                                int* ix0, int* nxs, double* ex, double* qx, int* iz0, int* nzs, double* ez,
                                double* qz, int* j0, int* j1) {
  const std::size_t o = static_cast<std::size_t>(m) * W;
  stencil_axis(sx[m], hx, nx, W, alpha, rc, ix0[m], nxs[m], ex + o, qx + o);
  stencil_axis(sz[m], hz, nz, W, alpha, rc, iz0[m], nzs[m], ez + o, qz + o);
  j0[m] = first_plane_at_least(y, N + 1, sy[m] - rc, false);
  j1[m] = first_plane_at_least(y, N + 1, sy[m] + rc, true) - 1;
}

CAPSFLOW_DEVICE_END

#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD) && (defined(__GNUC__) || defined(__clang__))
#define CAPSFLOW_INTERP_AVX512 1
// interpolate_point with each z row of the stencil as one 8-lane vector plus a scalar ninth point (rows that cross
// the periodic seam take the scalar path): the same weights, summed in another order.
__attribute__((target("avx512f"))) void interpolate_point_avx512(int nx, int nz, int N, double hx, double hz, double H,
                                                                 const double* yv, const double* gx, const double* gy,
                                                                 const double* gz, double x, double y, double z,
                                                                 double& ux, double& uy, double& uz) {
  constexpr int P = kInterpPoints, h = kInterpHalf;
  static_assert(P == 9, "one vector of 8 plus one point per row");
  InterpStencil st;
  interp_stencil(N, hx, hz, H, yv, x, y, z, st);
  const int ix = st.ix, iz = st.iz, jlo = st.jlo;
  const double *wx = st.wx, *wz = st.wz, *wy = st.wy;
  const int z0 = iz - h;
  const bool contiguous = z0 >= 0 && z0 + P <= nz;
  int zk[P];
  for (int oz = 0; oz < P; ++oz) zk[oz] = slit_wrap_index(z0 + oz, nz);
  const __m512d wz8 = _mm512_loadu_pd(wz);
  __m512d vx = _mm512_setzero_pd(), vy = _mm512_setzero_pd(), vz = _mm512_setzero_pd();
  double sx = 0.0, sy = 0.0, sz = 0.0;
  for (int oy = 0; oy < P; ++oy) {
    for (int ox = 0; ox < P; ++ox) {
      const int i = slit_wrap_index(ix + ox - h, nx);
      const std::size_t row = (static_cast<std::size_t>(jlo + oy) * nx + i) * nz;
      const double wxy = wy[oy] * wx[ox];
      if (contiguous) {
        const __m512d w = _mm512_mul_pd(_mm512_set1_pd(wxy), wz8);
        const std::size_t b = row + static_cast<std::size_t>(z0);
        vx = _mm512_fmadd_pd(w, _mm512_loadu_pd(gx + b), vx);
        vy = _mm512_fmadd_pd(w, _mm512_loadu_pd(gy + b), vy);
        vz = _mm512_fmadd_pd(w, _mm512_loadu_pd(gz + b), vz);
        // Fused, as GCC contracted these before this file was compiled without contraction (the same bits).
        const double w8 = wxy * wz[8];
        sx = std::fma(w8, gx[b + 8], sx);
        sy = std::fma(w8, gy[b + 8], sy);
        sz = std::fma(w8, gz[b + 8], sz);
      } else {
        for (int oz = 0; oz < P; ++oz) {
          const std::size_t idx = row + static_cast<std::size_t>(zk[oz]);
          const double w = wxy * wz[oz];
          sx = std::fma(w, gx[idx], sx);
          sy = std::fma(w, gy[idx], sy);
          sz = std::fma(w, gz[idx], sz);
        }
      }
    }
  }
  alignas(64) double l[3][8];  // stores, not _mm512_reduce_add_pd (GCC 12 warns on its undefined temporaries)
  _mm512_store_pd(l[0], vx), _mm512_store_pd(l[1], vy), _mm512_store_pd(l[2], vz);
  double r[3];
  for (int k = 0; k < 3; ++k) r[k] = ((l[k][0] + l[k][1]) + (l[k][2] + l[k][3])) + ((l[k][4] + l[k][5]) + (l[k][6] + l[k][7]));
  ux += sx + r[0];
  uy += sy + r[1];
  uz += sz + r[2];
}

bool interpolate_with_avx512() { return host_simd_path() == SimdPath::Avx512; }
#endif

// Host pass: the same per-source preparation into the workspace.
void prepare_source(std::size_t m, const SlitGridView& g, double alpha, double rc, const double* sx,
                    const double* sy, const double* sz, SpreadWorkspace& ws) {
  prepare_source_flat(static_cast<int>(m), g.nx, g.nz, g.N, g.hx, g.hz, g.y, ws.width, alpha, rc, sx, sy, sz,
                      ws.ix0.data(), ws.nxs.data(), ws.ex.data(), ws.qx.data(), ws.iz0.data(), ws.nzs.data(),
                      ws.ez.data(), ws.qz.data(), ws.j0.data(), ws.j1.data());
}

// The host deposit loops. On CPUs with AVX-512 (checked once at run time) each run of a row is 8 points per
// operation with masked loads and stores (runs are ~15 points: no scalar remainder); otherwise the portable loop.
// The AVX-512 loop is flattened (the rows' bounds and runs inlined into one function of that instruction set): a call
// per row of ~10 points cost a fifth of the spreading (set A's: 1.28x, docs/performance.md 18).
// Serial and threads call the same variant, so they stay bit-identical; another CPU may round differently.
#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD) && (defined(__GNUC__) || defined(__clang__))
#define CAPSFLOW_DEPOSIT_AVX512 1
struct Avx512RunDeposit {
  __attribute__((target("avx512f"))) inline void operator()(
      int len, const double* e, const double* q, double exy, double qxy, double cfx, double cfy, double cfz,
      double* px, double* py, double* pz) const {
    const __m512d vexy = _mm512_set1_pd(exy), vqxy = _mm512_set1_pd(qxy), c25 = _mm512_set1_pd(2.5);
    const __m512d vx = _mm512_set1_pd(cfx), vy = _mm512_set1_pd(cfy), vz = _mm512_set1_pd(cfz);
    for (int t = 0; t < len; t += 8) {
      const int m = len - t < 8 ? len - t : 8;
      const __mmask8 k = static_cast<__mmask8>((1u << m) - 1u);
      const __m512d ee = _mm512_mul_pd(vexy, _mm512_maskz_loadu_pd(k, e + t));
      const __m512d g = _mm512_mul_pd(_mm512_sub_pd(c25, _mm512_add_pd(vqxy, _mm512_maskz_loadu_pd(k, q + t))), ee);
      _mm512_mask_storeu_pd(px + t, k, _mm512_fmadd_pd(vx, g, _mm512_maskz_loadu_pd(k, px + t)));
      _mm512_mask_storeu_pd(py + t, k, _mm512_fmadd_pd(vy, g, _mm512_maskz_loadu_pd(k, py + t)));
      _mm512_mask_storeu_pd(pz + t, k, _mm512_fmadd_pd(vz, g, _mm512_maskz_loadu_pd(k, pz + t)));
    }
  }
};

bool deposit_with_avx512() { return host_simd_path() == SimdPath::Avx512; }
#define CAPSFLOW_DEPOSIT_TARGET __attribute__((target("avx512f"), flatten))
#endif

// Host backends: plane j, its sources src[b..e) in ascending order, source by source (every point sums its sources
// in ascending order: threads split the planes, and give the serial bits). Tiling the plane into L1-sized slabs of
// rows (the same order per point) measured no faster on set A (docs/performance.md 18).
template <class Run>
inline void deposit_plane_sources(const int* src, int b, int e, int j, int nx, int nz, double hz, const double* yv,
                                  double alpha, double rc, const double* sy, const double* sz, const double* fx,
                                  const double* fy, const double* fz, int width, const int* ix0, const int* nxs,
                                  const double* ex, const double* qx, const int* iz0, const int* nzs, const double* ez,
                                  const double* qz, double* rx, double* ry, double* rz, double div) {
  const Run run;
  for (int k = b; k < e; ++k) {
    const int m = src[k];
    PlaneCloud p;
    if (!plane_cloud(m, j, yv, alpha, rc, sy, fx, fy, fz, div, p)) continue;
    for (int a = 0; a < nxs[m]; ++a)
      deposit_row(p, m, j, a, nx, nz, hz, alpha, sz, width, ix0, ex, qx, iz0, nzs, ez, qz, rx, ry, rz, run);
  }
}

#ifdef CAPSFLOW_DEPOSIT_AVX512
// The AVX-512 instantiation, compiled for that instruction set (the run functor inlines only there).
CAPSFLOW_DEPOSIT_TARGET void deposit_plane_sources_avx512(const int* src, int b, int e, int j, int nx, int nz,
                                                          double hz, const double* yv, double alpha, double rc,
                                                          const double* sy, const double* sz, const double* fx,
                                                          const double* fy, const double* fz, int width,
                                                          const int* ix0, const int* nxs, const double* ex,
                                                          const double* qx, const int* iz0, const int* nzs,
                                                          const double* ez, const double* qz, double* rx, double* ry,
                                                          double* rz, double div) {
  deposit_plane_sources<Avx512RunDeposit>(src, b, e, j, nx, nz, hz, yv, alpha, rc, sy, sz, fx, fy, fz, width, ix0,
                                          nxs, ex, qx, iz0, nzs, ez, qz, rx, ry, rz, div);
}
#endif

// Device: the stencils are prepared on the device too (positions and forces may already be resident there: the
// map clauses then copy nothing, and the stencil arrays exist on the device only for this call), then one team per
// source deposits the (plane, x) rows of its cloud in parallel with the same row body as the host, with atomics.
void spread_forces_device(const SlitGridView& g, double alpha, double cutoff, std::size_t ns, const double* sx,
                          const double* sy, const double* sz, const double* fx, const double* fy, const double* fz,
                          double* rho_x, double* rho_y, double* rho_z, SpreadWorkspace& ws, double div) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
  const int nx = g.nx, nz = g.nz, N = g.N, np = g.N + 1, W = ws.width;
  const double hx = g.hx, hz = g.hz, rc = cutoff;
  const double* yv = g.y;
  const std::size_t ng = static_cast<std::size_t>(np) * nx * nz;
  const std::size_t nw = ns * W;
  int* ix0 = ws.ix0.data();
  int* nxs = ws.nxs.data();
  int* iz0 = ws.iz0.data();
  int* nzs = ws.nzs.data();
  int* j0 = ws.j0.data();
  int* j1 = ws.j1.data();
  double* ex = ws.ex.data();
  double* qx = ws.qx.data();
  double* ez = ws.ez.data();
  double* qz = ws.qz.data();
  const int nsi = static_cast<int>(ns);
#pragma omp target data map(to : sx[0:ns], sy[0:ns], sz[0:ns], fx[0:ns], fy[0:ns], fz[0:ns], yv[0:np])           \
    map(alloc : ix0[0:ns], nxs[0:ns], iz0[0:ns], nzs[0:ns], j0[0:ns], j1[0:ns], ex[0:nw], qx[0:nw], ez[0:nw], \
            qz[0:nw]) map(tofrom : rho_x[0:ng], rho_y[0:ng], rho_z[0:ng])
  {
#pragma omp target teams distribute parallel for map(to : sx[0:ns], sy[0:ns], sz[0:ns], yv[0:np])                 \
    map(alloc : ix0[0:ns], nxs[0:ns], iz0[0:ns], nzs[0:ns], j0[0:ns], j1[0:ns], ex[0:nw], qx[0:nw], ez[0:nw], \
            qz[0:nw])
    for (int m = 0; m < nsi; ++m)
      prepare_source_flat(m, nx, nz, N, hx, hz, yv, W, alpha, rc, sx, sy, sz, ix0, nxs, ex, qx, iz0, nzs, ez, qz, j0,
                          j1);
#pragma omp target teams distribute map(to : sx[0:ns], sy[0:ns], sz[0:ns], fx[0:ns], fy[0:ns], fz[0:ns], yv[0:np]) \
    map(alloc : ix0[0:ns], nxs[0:ns], iz0[0:ns], nzs[0:ns], j0[0:ns], j1[0:ns], ex[0:nw], qx[0:nw], ez[0:nw],  \
            qz[0:nw]) map(tofrom : rho_x[0:ng], rho_y[0:ng], rho_z[0:ng])
    for (int m = 0; m < nsi; ++m) {
      const int nj = j1[m] - j0[m] + 1;
      const int nxm = nxs[m];
#pragma omp parallel for collapse(2)
      for (int jj = 0; jj < nj; ++jj) {
        for (int a = 0; a < nxm; ++a) {
          const int j = j0[m] + jj;
          PlaneCloud p;
          if (plane_cloud(m, j, yv, alpha, rc, sy, fx, fy, fz, div, p))
            deposit_row(p, m, j, a, nx, nz, hz, alpha, sz, W, ix0, ex, qx, iz0, nzs, ez, qz, rho_x, rho_y, rho_z,
                        PortableRunDeposit<true>());
        }
      }
    }
  }
#else
  (void)g, (void)alpha, (void)cutoff, (void)ns, (void)sx, (void)sy, (void)sz, (void)fx, (void)fy, (void)fz;
  (void)rho_x, (void)rho_y, (void)rho_z, (void)ws, (void)div;
#endif
}

}  // namespace

void prepare_spread(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                    const double* sx, const double* sy, const double* sz, SpreadWorkspace& ws) {
  require_built(backend, "prepare_spread");
  const int W = static_cast<int>(std::ceil(2.0 * cutoff / std::min(g.hx, g.hz))) + 2;
  ws.width = W;
  ws.prepared_sources = 0;
  ws.prepared_backend = backend;
  ws.prepared_alpha = alpha;
  ws.prepared_cutoff = cutoff;
  if (ns == 0) return;
  const std::size_t nw = ns * W;
  for (auto* v : {&ws.ix0, &ws.nxs, &ws.iz0, &ws.nzs, &ws.j0, &ws.j1}) v->resize(ns);
  for (auto* v : {&ws.ex, &ws.qx, &ws.ez, &ws.qz}) v->resize(nw);
  // The device prepares its stencils inside spread_forces_device, on the device, per call.
  if (backend != Backend::Device) {
    const long long nsl = static_cast<long long>(ns);
#pragma omp parallel for schedule(static) if (backend != Backend::Serial)
    for (long long m = 0; m < nsl; ++m) prepare_source(static_cast<std::size_t>(m), g, alpha, cutoff, sx, sy, sz, ws);
    // Plane-major CSR: plane j's sources in ascending order, so every grid point sums in source order and threads
    // equal serial bit for bit. Per plane the grid stays in cache: the source-major order took 52 ms serial on set A
    // where this takes 42.
    const int np = g.N + 1;
    ws.plane_start.assign(np + 1, 0);
    for (std::size_t m = 0; m < ns; ++m)
      for (int j = ws.j0[m]; j <= ws.j1[m]; ++j) ++ws.plane_start[j + 1];
    for (int j = 0; j < np; ++j) ws.plane_start[j + 1] += ws.plane_start[j];
    ws.plane_src.resize(ws.plane_start[np]);
    std::vector<int> fill(ws.plane_start.begin(), ws.plane_start.end() - 1);
    for (std::size_t m = 0; m < ns; ++m)
      for (int j = ws.j0[m]; j <= ws.j1[m]; ++j) ws.plane_src[fill[j]++] = static_cast<int>(m);
  }
  ws.prepared_sources = ns;
}

void spread_prepared(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                     const double* sx, const double* sy, const double* sz, const double* fx, const double* fy,
                     const double* fz, double* rho_x, double* rho_y, double* rho_z, SpreadWorkspace& ws,
                     double force_divisor) {
  require_built(backend, "spread_prepared");
  if (ns == 0) return;
  if (ws.prepared_sources != ns || ws.prepared_backend != backend || ws.prepared_alpha != alpha ||
      ws.prepared_cutoff != cutoff)
    throw std::logic_error("spread_prepared: the workspace was not prepared for these sources");
  const double div = force_divisor;
  if (backend == Backend::Device) {
    spread_forces_device(g, alpha, cutoff, ns, sx, sy, sz, fx, fy, fz, rho_x, rho_y, rho_z, ws, div);
    return;
  }
  const int nx = g.nx, nz = g.nz, W = ws.width;
  const double hz = g.hz;
  const double* yv = g.y;
  const int* ix0 = ws.ix0.data();
  const int* nxs = ws.nxs.data();
  const int* iz0 = ws.iz0.data();
  const int* nzs = ws.nzs.data();
  const double* ex = ws.ex.data();
  const double* qx = ws.qx.data();
  const double* ez = ws.ez.data();
  const double* qz = ws.qz.data();
  const int np = g.N + 1;
  const int* ps = ws.plane_start.data();
  const int* src = ws.plane_src.data();
#ifdef CAPSFLOW_DEPOSIT_AVX512
  if (deposit_with_avx512()) {
#pragma omp parallel for schedule(dynamic, 1) if (backend == Backend::Threads)
    for (int j = 0; j < np; ++j)
      deposit_plane_sources_avx512(src, ps[j], ps[j + 1], j, nx, nz, hz, yv, alpha, cutoff, sy, sz, fx, fy, fz, W,
                                   ix0, nxs, ex, qx, iz0, nzs, ez, qz, rho_x, rho_y, rho_z, div);
    return;
  }
#endif
#pragma omp parallel for schedule(dynamic, 1) if (backend == Backend::Threads)
  for (int j = 0; j < np; ++j)
    deposit_plane_sources<PortableRunDeposit<false>>(src, ps[j], ps[j + 1], j, nx, nz, hz, yv, alpha, cutoff, sy, sz,
                                                     fx, fy, fz, W, ix0, nxs, ex, qx, iz0, nzs, ez, qz, rho_x, rho_y,
                                                     rho_z, div);
}

void spread_forces(Backend backend, const SlitGridView& g, double alpha, double cutoff, std::size_t ns,
                   const double* sx, const double* sy, const double* sz, const double* fx, const double* fy,
                   const double* fz, double* rho_x, double* rho_y, double* rho_z, SpreadWorkspace& ws,
                   double force_divisor) {
  require_built(backend, "spread_forces");
  if (ns == 0) return;
  prepare_spread(backend, g, alpha, cutoff, ns, sx, sy, sz, ws);
  spread_prepared(backend, g, alpha, cutoff, ns, sx, sy, sz, fx, fy, fz, rho_x, rho_y, rho_z, ws, force_divisor);
}

void interpolate_velocity(Backend backend, const SlitGridView& g, const double* gx, const double* gy,
                          const double* gz, std::size_t nt, const double* tx, const double* ty, const double* tz,
                          double* ux, double* uy, double* uz) {
  require_built(backend, "interpolate_velocity");
  const int nx = g.nx, nz = g.nz, N = g.N;
  const double hx = g.hx, hz = g.hz, H = g.H;
  const double* yv = g.y;
  const long long n = static_cast<long long>(nt);
  if (backend == Backend::Device) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
    const std::size_t ng = static_cast<std::size_t>(N + 1) * nx * nz;
#pragma omp target teams distribute parallel for map(to : gx[0:ng], gy[0:ng], gz[0:ng], yv[0:N + 1], \
                                                             tx[0:nt], ty[0:nt], tz[0:nt])             \
    map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p)
      interpolate_point(nx, nz, N, hx, hz, H, yv, gx, gy, gz, tx[p], ty[p], tz[p], ux[p], uy[p], uz[p]);
#endif
    return;
  }
#ifdef CAPSFLOW_INTERP_AVX512
  if (interpolate_with_avx512()) {
#pragma omp parallel for schedule(static) if (backend == Backend::Threads)
    for (long long p = 0; p < n; ++p)
      interpolate_point_avx512(nx, nz, N, hx, hz, H, yv, gx, gy, gz, tx[p], ty[p], tz[p], ux[p], uy[p], uz[p]);
    return;
  }
#endif
#pragma omp parallel for schedule(static) if (backend == Backend::Threads)
  for (long long p = 0; p < n; ++p)
    interpolate_point(nx, nz, N, hx, hz, H, yv, gx, gy, gz, tx[p], ty[p], tz[p], ux[p], uy[p], uz[p]);
}

}  // namespace capsflow
