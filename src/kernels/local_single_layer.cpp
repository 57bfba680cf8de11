#include "kernels/local_single_layer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"

// Host builds on x86-64 without the device backend: batched AVX2 evaluation of G_l (see PointBatch below).
#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD) && (defined(__GNUC__) || defined(__clang__))
#define CAPSFLOW_BATCHED_LOCAL_KERNEL 1
#include <immintrin.h>
#endif

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

// Unwrapped cell coordinate; callers wrap (periodic x, z) or clamp (y).
inline int sl_cell_coord(double v, double size) { return static_cast<int>(std::floor(v / size)); }

inline int sl_wrap_cell(int c, int n) {
  const int r = c % n;
  return r < 0 ? r + n : r;
}

inline void kernel_finish(const LocalKernel&, double*) {}

// Minimum image d - L round(d / L) without a libm call (std::nearbyint is not inlined on baseline x86-64); rounds
// half away from zero, which differs from nearbyint only at d = +-L/2 exactly, far outside cutoff + radius < L/2.
inline double sl_min_image(double d, double L, double inv_L) {
  const double s = d * inv_L;
  return d - L * static_cast<double>(static_cast<long long>(s + std::copysign(0.5, s)));
}

// Sum over the neighbouring cells of one target (same window as the point-force local sum: with fewer than 3 cells
// along a periodic direction every cell is visited once).
template <class Kernel>
inline void sl_target(const Kernel& kernel, int ncx, int ncy, int ncz, double cx, double cy, double cz, double Lx, double Lz,
                      const int* start, const int* elem, const double* ex, const double* ey, const double* ez,
                      const double* er, double cutoff, int nv, int ntri, const int* tri, const double* x,
                      const double* y, const double* z, const double* fx, const double* fy, const double* fz,
                      const QuadratureOrders& q, double scale, double px, double py, double pz,
                      int tnode, double& ux, double& uy, double& uz) {
  const int icx = sl_wrap_cell(sl_cell_coord(px, cx), ncx);
  const int icz = sl_wrap_cell(sl_cell_coord(pz, cz), ncz);
  int icy = sl_cell_coord(py, cy);
  icy = icy < 0 ? 0 : (icy >= ncy ? ncy - 1 : icy);
  const int dx_lo = ncx >= 3 ? -1 : 0, dx_hi = ncx >= 3 ? 1 : ncx - 1;
  const int dz_lo = ncz >= 3 ? -1 : 0, dz_hi = ncz >= 3 ? 1 : ncz - 1;
  const double xt[3] = {px, py, pz};
  const double inv_Lx = 1.0 / Lx, inv_Lz = 1.0 / Lz;
  double acc[3] = {0.0, 0.0, 0.0};
  for (int dyc = -1; dyc <= 1; ++dyc) {
    const int cyy = icy + dyc;
    if (cyy < 0 || cyy >= ncy) continue;
    for (int dxc = dx_lo; dxc <= dx_hi; ++dxc) {
      const int cxx = ncx >= 3 ? sl_wrap_cell(icx + dxc, ncx) : dxc;
      for (int dzc = dz_lo; dzc <= dz_hi; ++dzc) {
        const int czz = ncz >= 3 ? sl_wrap_cell(icz + dzc, ncz) : dzc;
        const int cell = (cyy * ncx + cxx) * ncz + czz;
        for (int s = start[cell]; s < start[cell + 1]; ++s) {
          const double rx = sl_min_image(ex[s] - px, Lx, inv_Lx);
          const double ry = ey[s] - py;
          const double rz = sl_min_image(ez[s] - pz, Lz, inv_Lz);
          const double reach = cutoff + er[s];
          if (rx * rx + ry * ry + rz * rz >= reach * reach) continue;
          const int e = elem[s];
          const int k = e / ntri;
          const int t = e - k * ntri;
          double v[9], f[9];
          int singular = -1;
          for (int c = 0; c < 3; ++c) {
            const int g = k * nv + tri[3 * t + c];
            v[3 * c] = px + sl_min_image(x[g] - px, Lx, inv_Lx);
            v[3 * c + 1] = y[g];
            v[3 * c + 2] = pz + sl_min_image(z[g] - pz, Lz, inv_Lz);
            f[3 * c] = fx[g];
            f[3 * c + 1] = fy[g];
            f[3 * c + 2] = fz[g];
            if (g == tnode) singular = c;
          }
          element_integral_add(kernel, xt, v, f, singular, q, acc);
        }
      }
    }
  }
  kernel_finish(kernel, acc);
  ux += scale * acc[0];
  uy += scale * acc[1];
  uz += scale * acc[2];
}

CAPSFLOW_DEVICE_END

#ifdef CAPSFLOW_BATCHED_LOCAL_KERNEL
// Host backends on x86-64: the element rules are evaluated four points at a time with AVX2 + FMA when the CPU has them
// (checked at run time), else point by point (ggem_local_add_tabulated). The collapsed Gauss, 7-point and singular
// rules are fixed point sets in the element's parametric coordinates (ParamRule, evaluated by rule_eval without a
// buffer); the near-singular rule's points, which depend on the target, go through BatchedLocalKernel::add into a
// per-target buffer (PointBatch). Same points, weights and table as the scalar kernel; the terms differ from it by
// rounding (FMA) and are summed in a different order. Deterministic: the buffer is flushed at fixed counts and at the
// end of each target, so the serial and threads backends stay bit-identical.
struct PointBatch {
  static constexpr int kCap = 128;  // flushed when full
  static constexpr int kSize = kCap + 4;
  alignas(32) double rx[kSize], ry[kSize], rz[kSize], gx[kSize], gy[kSize], gz[kSize];
  int n = 0;
  double alpha = 0.0;
  bool avx2 = false;
  double acc[3] = {0.0, 0.0, 0.0};
};

// The 9 coefficients of table rows o[0..3] of T, transposed so that c[m] holds coefficient m of the four rows
// (row loads + unpack/permute: hardware gathers were 1.4x slower here).
__attribute__((target("avx2,fma"))) inline void load_table_rows_avx2(const double* T, const int* o, __m256d* c) {
  for (int m = 0; m < 8; m += 4) {
    const __m256d w0 = _mm256_loadu_pd(T + o[0] + m), w1 = _mm256_loadu_pd(T + o[1] + m);
    const __m256d w2 = _mm256_loadu_pd(T + o[2] + m), w3 = _mm256_loadu_pd(T + o[3] + m);
    const __m256d t0 = _mm256_unpacklo_pd(w0, w1), t1 = _mm256_unpackhi_pd(w0, w1);
    const __m256d t2 = _mm256_unpacklo_pd(w2, w3), t3 = _mm256_unpackhi_pd(w2, w3);
    c[m] = _mm256_permute2f128_pd(t0, t2, 0x20);
    c[m + 1] = _mm256_permute2f128_pd(t1, t3, 0x20);
    c[m + 2] = _mm256_permute2f128_pd(t0, t2, 0x31);
    c[m + 3] = _mm256_permute2f128_pd(t1, t3, 0x31);
  }
  c[8] = _mm256_set_pd(T[o[3] + 8], T[o[2] + 8], T[o[1] + 8], T[o[0] + 8]);
}

__attribute__((target("avx2,fma"))) void batch_eval_avx2(PointBatch& b) {
  // Pad to a multiple of 4 with copies of point 0 carrying zero density: they add exactly zero.
  while (b.n % 4 != 0) {
    b.rx[b.n] = b.rx[0], b.ry[b.n] = b.ry[0], b.rz[b.n] = b.rz[0];
    b.gx[b.n] = 0.0, b.gy[b.n] = 0.0, b.gz[b.n] = 0.0;
    ++b.n;
  }
  const double alpha = b.alpha, a2 = alpha * alpha;
  const __m256d one = _mm256_set1_pd(1.0), two = _mm256_set1_pd(2.0);
  const __m256d valpha = _mm256_set1_pd(alpha), va2 = _mm256_set1_pd(a2), va3 = _mm256_set1_pd(alpha * a2);
  const __m256d invw = _mm256_set1_pd(kGgemTabInvWidth), tmax = _mm256_set1_pd(kGgemTabTMax);
  const __m256d tlo = _mm256_set1_pd(kCoincidentAlphaR * kCoincidentAlphaR);
  const __m256d tsplit = _mm256_set1_pd(kGgemTabDirectFrom / kGgemTabInvWidth);
  const __m128i stride = _mm_set1_epi32(kGgemTabStride);
  __m256d sx = _mm256_setzero_pd(), sy = _mm256_setzero_pd(), sz = _mm256_setzero_pd();
  for (int k = 0; k < b.n; k += 4) {
    const __m256d rx = _mm256_load_pd(b.rx + k), ry = _mm256_load_pd(b.ry + k), rz = _mm256_load_pd(b.rz + k);
    const __m256d gx = _mm256_load_pd(b.gx + k), gy = _mm256_load_pd(b.gy + k), gz = _mm256_load_pd(b.gz + k);
    const __m256d r2 = _mm256_fmadd_pd(rz, rz, _mm256_fmadd_pd(ry, ry, _mm256_mul_pd(rx, rx)));
    const __m256d t = _mm256_mul_pd(va2, r2);
    const __m256d ok = _mm256_and_pd(_mm256_cmp_pd(t, tlo, _CMP_GE_OQ), _mm256_cmp_pd(t, tmax, _CMP_LT_OQ));
    if (_mm256_movemask_pd(ok) != 15) {
      for (int l = k; l < k + 4; ++l)
        ggem_local_add_tabulated(alpha, b.rx[l], b.ry[l], b.rz[l], b.gx[l], b.gy[l], b.gz[l], b.acc[0], b.acc[1],
                                 b.acc[2]);
      continue;
    }
    const __m256d tw = _mm256_mul_pd(t, invw);
    const __m128i iv = _mm256_cvttpd_epi32(tw);
    const __m128i off = _mm_mullo_epi32(iv, stride);
    const __m256d u = _mm256_fmsub_pd(two, _mm256_sub_pd(tw, _mm256_cvtepi32_pd(iv)), one);
    // Coefficients: row loads and 4 x 4 transposes (vgatherdpd is slow on CPUs with the gather-data-sampling fix).
    const int o[4] = {_mm_extract_epi32(off, 0), _mm_extract_epi32(off, 1), _mm_extract_epi32(off, 2),
                      _mm_extract_epi32(off, 3)};
    __m256d cp[9], cq[9];
    for (int j = 0; j < 2; ++j) {
      const double* T = j == 0 ? kGgemTabA : kGgemTabB;
      __m256d* c = j == 0 ? cp : cq;
      load_table_rows_avx2(T, o, c);
    }
    const __m256d u2 = _mm256_mul_pd(u, u), u4 = _mm256_mul_pd(u2, u2), u8 = _mm256_mul_pd(u4, u4);
    __m256d pq[2];
    for (int j = 0; j < 2; ++j) {  // Estrin, as in ggem_local_tab_coefficients
      const __m256d* c = j == 0 ? cp : cq;
      const __m256d p01 = _mm256_fmadd_pd(c[1], u, c[0]), p23 = _mm256_fmadd_pd(c[3], u, c[2]);
      const __m256d p45 = _mm256_fmadd_pd(c[5], u, c[4]), p67 = _mm256_fmadd_pd(c[7], u, c[6]);
      pq[j] = _mm256_fmadd_pd(u8, c[8],
                              _mm256_fmadd_pd(u4, _mm256_fmadd_pd(u2, p67, p45), _mm256_fmadd_pd(u2, p23, p01)));
    }
    const __m256d p = pq[0], q = pq[1];
    const __m256d inv_r = _mm256_div_pd(one, _mm256_sqrt_pd(r2));
    const __m256d s1 = _mm256_and_pd(_mm256_cmp_pd(t, tsplit, _CMP_LT_OQ), inv_r);
    const __m256d a = _mm256_fnmadd_pd(valpha, p, s1);
    const __m256d rf = _mm256_fmadd_pd(rz, gz, _mm256_fmadd_pd(ry, gy, _mm256_mul_pd(rx, gx)));
    const __m256d bb = _mm256_mul_pd(_mm256_fnmadd_pd(va3, q, _mm256_mul_pd(_mm256_mul_pd(s1, inv_r), inv_r)), rf);
    sx = _mm256_add_pd(sx, _mm256_fmadd_pd(bb, rx, _mm256_mul_pd(a, gx)));
    sy = _mm256_add_pd(sy, _mm256_fmadd_pd(bb, ry, _mm256_mul_pd(a, gy)));
    sz = _mm256_add_pd(sz, _mm256_fmadd_pd(bb, rz, _mm256_mul_pd(a, gz)));
  }
  alignas(32) double lx[4], ly[4], lz[4];
  _mm256_store_pd(lx, sx), _mm256_store_pd(ly, sy), _mm256_store_pd(lz, sz);
  b.acc[0] += (lx[0] + lx[1]) + (lx[2] + lx[3]);
  b.acc[1] += (ly[0] + ly[1]) + (ly[2] + ly[3]);
  b.acc[2] += (lz[0] + lz[1]) + (lz[2] + lz[3]);
  b.n = 0;
}

void batch_flush(PointBatch& b) {
  if (b.n == 0) return;
  if (b.avx2) {
    batch_eval_avx2(b);
    return;
  }
  for (int l = 0; l < b.n; ++l)
    ggem_local_add_tabulated(b.alpha, b.rx[l], b.ry[l], b.rz[l], b.gx[l], b.gy[l], b.gz[l], b.acc[0], b.acc[1],
                             b.acc[2]);
  b.n = 0;
}

struct BatchedLocalKernel {
  PointBatch* b;
  void add(double rx, double ry, double rz, double fx, double fy, double fz, double&, double&, double&) const {
    PointBatch& B = *b;
    B.rx[B.n] = rx, B.ry[B.n] = ry, B.rz[B.n] = rz, B.gx[B.n] = fx, B.gy[B.n] = fy, B.gz[B.n] = fz;
    if (++B.n >= PointBatch::kCap) batch_flush(B);
  }
};

// Fixed rules in the element's parametric coordinates: y = v0 + eta (v1 - v0) + xi (v2 - v0), weight jac * w
// (jac = twice the area). Padded to a multiple of 4 with zero-weight copies of point 0 (they add exactly zero).
struct ParamRule {
  std::vector<double> eta, xi, w;
  void add(double e, double x, double wt) {
    eta.push_back(e), xi.push_back(x), w.push_back(wt);
  }
  void pad() {
    while (eta.size() % 4 != 0) add(eta[0], xi[0], 0.0);
  }
};

// The collapsed Gauss rule of order n, points and weights as in quad_detail::duffy_add.
const ParamRule& duffy_rule(int n) {
  static const std::vector<ParamRule> rules = [] {
    std::vector<ParamRule> r(kMaxGaussOrder + 1);
    for (int m = 1; m <= kMaxGaussOrder; ++m) {
      for (int ia = 0; ia < m; ++ia) {
        const double eta = 0.5 * (1.0 + gauss_node(m, ia));
        const double wa = gauss_weight(m, ia) * 0.25 * (1.0 - eta);
        for (int ib = 0; ib < m; ++ib)
          r[m].add(eta, 0.5 * (1.0 + gauss_node(m, ib)) * (1.0 - eta), wa * gauss_weight(m, ib));
      }
      r[m].pad();
    }
    return r;
  }();
  return rules[n];
}

// The symmetric 7-point rule, as in quad_detail::dunavant7_add (weights per unit area: half of them per jac).
const ParamRule& dunavant_rule() {
  static const ParamRule rule = [] {
    ParamRule r;
    const double third = 1.0 / 3.0;
    r.add(third, third, 0.5 * kDunavant7W0);
    r.add(kDunavant7B1, kDunavant7B1, 0.5 * kDunavant7W1);
    r.add(kDunavant7A1, kDunavant7B1, 0.5 * kDunavant7W1);
    r.add(kDunavant7B1, kDunavant7A1, 0.5 * kDunavant7W1);
    r.add(kDunavant7B2, kDunavant7B2, 0.5 * kDunavant7W2);
    r.add(kDunavant7A2, kDunavant7B2, 0.5 * kDunavant7W2);
    r.add(kDunavant7B2, kDunavant7A2, 0.5 * kDunavant7W2);
    r.pad();
    return r;
  }();
  return rule;
}

// The polar rule about vertex 0 of order n, as in quad_detail::singular_add (the caller rotates the vertices).
const ParamRule& singular_rule(int n) {
  static const std::vector<ParamRule> rules = [] {
    std::vector<ParamRule> r(kMaxGaussOrder + 1);
    const double quarter_pi = 0.25 * kPi;
    for (int m = 1; m <= kMaxGaussOrder; ++m) {
      for (int ip = 0; ip < m; ++ip) {
        const double phi = quarter_pi * (1.0 + gauss_node(m, ip));
        const double sp = std::sin(phi), cp = std::cos(phi);
        const double rho_max = 1.0 / (sp + cp);
        const double wp = gauss_weight(m, ip) * quarter_pi * 0.5 * rho_max;
        for (int ir = 0; ir < m; ++ir) {
          const double rho = 0.5 * rho_max * (1.0 + gauss_node(m, ir));
          r[m].add(rho * cp, rho * sp, wp * gauss_weight(m, ir) * rho);
        }
      }
      r[m].pad();
    }
    return r;
  }();
  return rules[n];
}

__attribute__((target("avx2,fma"))) void rule_eval_avx2(double alpha, const double* xt, const double* v,
                                                        const double* f, double jac, const ParamRule& R, double* acc) {
  const double a2 = alpha * alpha;
  const __m256d one = _mm256_set1_pd(1.0), two = _mm256_set1_pd(2.0);
  const __m256d valpha = _mm256_set1_pd(alpha), va2 = _mm256_set1_pd(a2), va3 = _mm256_set1_pd(alpha * a2);
  const __m256d invw = _mm256_set1_pd(kGgemTabInvWidth), tmax = _mm256_set1_pd(kGgemTabTMax);
  const __m256d tlo = _mm256_set1_pd(kCoincidentAlphaR * kCoincidentAlphaR);
  const __m256d tsplit = _mm256_set1_pd(kGgemTabDirectFrom / kGgemTabInvWidth);
  const __m128i stride = _mm_set1_epi32(kGgemTabStride);
  const double e1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]}, e2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
  const double d1[3] = {f[3] - f[0], f[4] - f[1], f[5] - f[2]}, d2[3] = {f[6] - f[0], f[7] - f[1], f[8] - f[2]};
  const __m256d x0x = _mm256_set1_pd(xt[0] - v[0]), x0y = _mm256_set1_pd(xt[1] - v[1]),
                x0z = _mm256_set1_pd(xt[2] - v[2]);
  const __m256d e1x = _mm256_set1_pd(e1[0]), e1y = _mm256_set1_pd(e1[1]), e1z = _mm256_set1_pd(e1[2]);
  const __m256d e2x = _mm256_set1_pd(e2[0]), e2y = _mm256_set1_pd(e2[1]), e2z = _mm256_set1_pd(e2[2]);
  const __m256d d1x = _mm256_set1_pd(d1[0]), d1y = _mm256_set1_pd(d1[1]), d1z = _mm256_set1_pd(d1[2]);
  const __m256d d2x = _mm256_set1_pd(d2[0]), d2y = _mm256_set1_pd(d2[1]), d2z = _mm256_set1_pd(d2[2]);
  const __m256d f0x = _mm256_set1_pd(f[0]), f0y = _mm256_set1_pd(f[1]), f0z = _mm256_set1_pd(f[2]);
  const __m256d vjac = _mm256_set1_pd(jac);
  __m256d sx = _mm256_setzero_pd(), sy = _mm256_setzero_pd(), sz = _mm256_setzero_pd();
  const int count = static_cast<int>(R.eta.size());
  for (int k = 0; k < count; k += 4) {
    const __m256d eta = _mm256_loadu_pd(R.eta.data() + k), xi = _mm256_loadu_pd(R.xi.data() + k);
    const __m256d w = _mm256_mul_pd(vjac, _mm256_loadu_pd(R.w.data() + k));
    const __m256d rx = _mm256_fnmadd_pd(xi, e2x, _mm256_fnmadd_pd(eta, e1x, x0x));
    const __m256d ry = _mm256_fnmadd_pd(xi, e2y, _mm256_fnmadd_pd(eta, e1y, x0y));
    const __m256d rz = _mm256_fnmadd_pd(xi, e2z, _mm256_fnmadd_pd(eta, e1z, x0z));
    const __m256d gx = _mm256_mul_pd(w, _mm256_fmadd_pd(xi, d2x, _mm256_fmadd_pd(eta, d1x, f0x)));
    const __m256d gy = _mm256_mul_pd(w, _mm256_fmadd_pd(xi, d2y, _mm256_fmadd_pd(eta, d1y, f0y)));
    const __m256d gz = _mm256_mul_pd(w, _mm256_fmadd_pd(xi, d2z, _mm256_fmadd_pd(eta, d1z, f0z)));
    const __m256d r2 = _mm256_fmadd_pd(rz, rz, _mm256_fmadd_pd(ry, ry, _mm256_mul_pd(rx, rx)));
    const __m256d t = _mm256_mul_pd(va2, r2);
    const __m256d ok = _mm256_and_pd(_mm256_cmp_pd(t, tlo, _CMP_GE_OQ), _mm256_cmp_pd(t, tmax, _CMP_LT_OQ));
    if (_mm256_movemask_pd(ok) != 15) {
      alignas(32) double b[6][4];
      _mm256_store_pd(b[0], rx), _mm256_store_pd(b[1], ry), _mm256_store_pd(b[2], rz);
      _mm256_store_pd(b[3], gx), _mm256_store_pd(b[4], gy), _mm256_store_pd(b[5], gz);
      for (int l = 0; l < 4; ++l)
        ggem_local_add_tabulated(alpha, b[0][l], b[1][l], b[2][l], b[3][l], b[4][l], b[5][l], acc[0], acc[1], acc[2]);
      continue;
    }
    const __m256d tw = _mm256_mul_pd(t, invw);
    const __m128i iv = _mm256_cvttpd_epi32(tw);
    const __m128i off = _mm_mullo_epi32(iv, stride);
    const __m256d u = _mm256_fmsub_pd(two, _mm256_sub_pd(tw, _mm256_cvtepi32_pd(iv)), one);
    const int o[4] = {_mm_extract_epi32(off, 0), _mm_extract_epi32(off, 1), _mm_extract_epi32(off, 2),
                      _mm_extract_epi32(off, 3)};
    // One polynomial at a time (9 coefficient vectors live, not 18: no spills).
    const __m256d u2 = _mm256_mul_pd(u, u), u4 = _mm256_mul_pd(u2, u2), u8 = _mm256_mul_pd(u4, u4);
    __m256d pq[2];
    for (int j = 0; j < 2; ++j) {
      const double* T = j == 0 ? kGgemTabA : kGgemTabB;
      __m256d c[9];
      load_table_rows_avx2(T, o, c);
      const __m256d p01 = _mm256_fmadd_pd(c[1], u, c[0]), p23 = _mm256_fmadd_pd(c[3], u, c[2]);
      const __m256d p45 = _mm256_fmadd_pd(c[5], u, c[4]), p67 = _mm256_fmadd_pd(c[7], u, c[6]);
      pq[j] = _mm256_fmadd_pd(u8, c[8],
                              _mm256_fmadd_pd(u4, _mm256_fmadd_pd(u2, p67, p45), _mm256_fmadd_pd(u2, p23, p01)));
    }
    const __m256d inv_r = _mm256_div_pd(one, _mm256_sqrt_pd(r2));
    const __m256d s1 = _mm256_and_pd(_mm256_cmp_pd(t, tsplit, _CMP_LT_OQ), inv_r);
    const __m256d a = _mm256_fnmadd_pd(valpha, pq[0], s1);
    const __m256d rf = _mm256_fmadd_pd(rz, gz, _mm256_fmadd_pd(ry, gy, _mm256_mul_pd(rx, gx)));
    const __m256d bb =
        _mm256_mul_pd(_mm256_fnmadd_pd(va3, pq[1], _mm256_mul_pd(_mm256_mul_pd(s1, inv_r), inv_r)), rf);
    sx = _mm256_add_pd(sx, _mm256_fmadd_pd(bb, rx, _mm256_mul_pd(a, gx)));
    sy = _mm256_add_pd(sy, _mm256_fmadd_pd(bb, ry, _mm256_mul_pd(a, gy)));
    sz = _mm256_add_pd(sz, _mm256_fmadd_pd(bb, rz, _mm256_mul_pd(a, gz)));
  }
  alignas(32) double lx[4], ly[4], lz[4];
  _mm256_store_pd(lx, sx), _mm256_store_pd(ly, sy), _mm256_store_pd(lz, sz);
  acc[0] += (lx[0] + lx[1]) + (lx[2] + lx[3]);
  acc[1] += (ly[0] + ly[1]) + (ly[2] + ly[3]);
  acc[2] += (lz[0] + lz[1]) + (lz[2] + lz[3]);
}

void rule_eval(const BatchedLocalKernel& k, const double* xt, const double* v, const double* f, const ParamRule& R) {
  PointBatch& B = *k.b;
  const double jac = quad_detail::twice_area(v);
  if (B.avx2) {
    rule_eval_avx2(B.alpha, xt, v, f, jac, R, B.acc);
    return;
  }
  for (std::size_t i = 0; i < R.eta.size(); ++i) {
    const double e = R.eta[i], x = R.xi[i], w = jac * R.w[i];
    double r[3], g[3];
    for (int c = 0; c < 3; ++c) {
      r[c] = xt[c] - (v[c] + e * (v[3 + c] - v[c]) + x * (v[6 + c] - v[c]));
      g[c] = w * (f[c] + e * (f[3 + c] - f[c]) + x * (f[6 + c] - f[c]));
    }
    ggem_local_add_tabulated(B.alpha, r[0], r[1], r[2], g[0], g[1], g[2], B.acc[0], B.acc[1], B.acc[2]);
  }
}

// Overloads found by argument-dependent lookup from quad_detail::regular_add: the collapsed Gauss and 7-point rules
// for the batched kernel evaluate their fixed point sets directly (no buffer).
void duffy_add(const BatchedLocalKernel& k, const double* xt, const double* v, const double* f, int n, double*) {
  rule_eval(k, xt, v, f, duffy_rule(gauss_clamp_order(n)));
}
void dunavant7_add(const BatchedLocalKernel& k, const double* xt, const double* v, const double* f, double*) {
  rule_eval(k, xt, v, f, dunavant_rule());
}
// From element_integral_add (singular vertex vk): the vertices rotated so that vk comes first, as in the generic rule.
void singular_add(const BatchedLocalKernel& k, const double* xt, const double* v, const double* f, int vk, int n,
                  double*) {
  double w9[9], f9[9];
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) {
      w9[3 * i + c] = v[3 * ((vk + i) % 3) + c];
      f9[3 * i + c] = f[3 * ((vk + i) % 3) + c];
    }
  rule_eval(k, xt, w9, f9, singular_rule(gauss_clamp_order(n)));
}

// Evaluates what is left and moves the batch's sum into acc (the quadrature rules added nothing to acc themselves).
inline void kernel_finish(const BatchedLocalKernel& k, double* acc) {
  batch_flush(*k.b);
  for (int c = 0; c < 3; ++c) {
    acc[c] += k.b->acc[c];
    k.b->acc[c] = 0.0;
  }
}

bool cpu_has_avx2_fma() {
  static const bool yes = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return yes;
}
#endif

}  // namespace

void build_element_cell_list(ElementCellList& cl, double Lx, double H, double Lz, double cutoff, int ncap, int nv,
                             int ntri, const int* tri, const double* x, const double* y, const double* z) {
  if (!(Lx > 0.0 && Lz > 0.0 && H > 0.0 && cutoff > 0.0) || ncap < 0 || nv < 0 || ntri < 0)
    throw std::invalid_argument("build_element_cell_list: invalid box, cutoff or sizes");
  const std::size_t ne = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(ntri);
  std::vector<double> cxs(ne), cys(ne), czs(ne), rad(ne);
  double max_r = 0.0;
  for (std::size_t e = 0; e < ne; ++e) {
    const int k = static_cast<int>(e / static_cast<std::size_t>(ntri));
    const int t = static_cast<int>(e % static_cast<std::size_t>(ntri));
    double v[9];
    const int g0 = k * nv + tri[3 * t];
    for (int c = 0; c < 3; ++c) {
      const int g = k * nv + tri[3 * t + c];
      v[3 * c] = x[g0] + min_image(x[g] - x[g0], Lx);
      v[3 * c + 1] = y[g];
      v[3 * c + 2] = z[g0] + min_image(z[g] - z[g0], Lz);
    }
    const double c0 = (v[0] + v[3] + v[6]) / 3.0, c1 = (v[1] + v[4] + v[7]) / 3.0, c2 = (v[2] + v[5] + v[8]) / 3.0;
    double r2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double dx = v[3 * c] - c0, dy = v[3 * c + 1] - c1, dz = v[3 * c + 2] - c2;
      r2 = std::max(r2, dx * dx + dy * dy + dz * dz);
    }
    cxs[e] = c0;
    cys[e] = c1;
    czs[e] = c2;
    rad[e] = std::sqrt(r2);
    max_r = std::max(max_r, rad[e]);
  }
  const double reach = cutoff + max_r;
  if (!(Lx > 2.0 * reach && Lz > 2.0 * reach))
    throw std::invalid_argument("build_element_cell_list: Lx and Lz must exceed 2 (cutoff + largest element radius)");
  cl.Lx = Lx;
  cl.Lz = Lz;
  cl.H = H;
  cl.max_radius = max_r;
  cl.ncx = std::max(1, static_cast<int>(std::floor(Lx / reach)));
  cl.ncz = std::max(1, static_cast<int>(std::floor(Lz / reach)));
  cl.ncy = std::max(1, static_cast<int>(std::floor(H / reach)));
  cl.cx = Lx / cl.ncx;
  cl.cz = Lz / cl.ncz;
  cl.cy = H / cl.ncy;
  const int ncell = cl.ncx * cl.ncy * cl.ncz;
  std::vector<int> cell(ne);
  cl.start.assign(static_cast<std::size_t>(ncell) + 1, 0);
  for (std::size_t e = 0; e < ne; ++e) {
    const int a = sl_wrap_cell(sl_cell_coord(cxs[e], cl.cx), cl.ncx);
    const int c = sl_wrap_cell(sl_cell_coord(czs[e], cl.cz), cl.ncz);
    const int b = std::clamp(sl_cell_coord(cys[e], cl.cy), 0, cl.ncy - 1);
    cell[e] = (b * cl.ncx + a) * cl.ncz + c;
    ++cl.start[static_cast<std::size_t>(cell[e]) + 1];
  }
  for (int c = 0; c < ncell; ++c) cl.start[static_cast<std::size_t>(c) + 1] += cl.start[static_cast<std::size_t>(c)];
  std::vector<int> fill(cl.start.begin(), cl.start.end() - 1);
  cl.elem.resize(ne);
  for (auto* w : {&cl.ex, &cl.ey, &cl.ez, &cl.er}) w->resize(ne);
  for (std::size_t e = 0; e < ne; ++e) {
    const auto s = static_cast<std::size_t>(fill[static_cast<std::size_t>(cell[e])]++);
    cl.elem[s] = static_cast<int>(e);
    cl.ex[s] = cxs[e];
    cl.ey[s] = cys[e];
    cl.ez[s] = czs[e];
    cl.er[s] = rad[e];
  }
}

void local_single_layer_velocity(Backend backend, const ElementCellList& cl, double alpha, double cutoff, double scale,
                                 int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                                 const double* z, const double* fx, const double* fy, const double* fz,
                                 const QuadratureOrders& q_in, std::size_t nt, const double* tx, const double* ty,
                                 const double* tz, const int* target_node, double* ux, double* uy, double* uz) {
  require_built(backend, "local_single_layer_velocity");
  if (cl.size() != static_cast<std::size_t>(ncap) * static_cast<std::size_t>(ntri))
    throw std::invalid_argument("local_single_layer_velocity: cell list built for a different element count");
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double cx = cl.cx, cy = cl.cy, cz = cl.cz, Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const int* elem = cl.elem.data();
  const double *ex = cl.ex.data(), *ey = cl.ey.data(), *ez = cl.ez.data(), *er = cl.er.data();
  const QuadratureOrders q = q_in;
  const long long n = static_cast<long long>(nt);
  if (backend == Backend::Device) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
    std::vector<int> no_node;
    const int* tn = target_node;
    if (tn == nullptr) {
      no_node.assign(nt, -1);
      tn = no_node.data();
    }
    const std::size_t ne = cl.size();
    const std::size_t nc = cl.start.size();
    const std::size_t nn = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(nv);
    const std::size_t n3 = 3 * static_cast<std::size_t>(ntri);
#pragma omp target teams distribute parallel for firstprivate(q)                                                   \
    map(to : start[0:nc], elem[0:ne], ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne], tri[0:n3], x[0:nn], y[0:nn], z[0:nn], \
            fx[0:nn], fy[0:nn], fz[0:nn], tx[0:nt], ty[0:nt], tz[0:nt], tn[0:nt])                                \
    map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p)
      sl_target(LocalKernel{alpha}, ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er, cutoff, nv, ntri,
                tri, x, y, z, fx, fy, fz, q, scale, tx[p], ty[p], tz[p], tn[p], ux[p], uy[p], uz[p]);
#else
    (void)ncap;
#endif
    return;
  }
#ifdef CAPSFLOW_BATCHED_LOCAL_KERNEL
  const bool avx2 = cpu_has_avx2_fma();
#pragma omp parallel if (backend == Backend::Threads)
  {
    PointBatch batch;
    batch.alpha = alpha;
    batch.avx2 = avx2;
    const BatchedLocalKernel kernel{&batch};
#pragma omp for schedule(dynamic, 16)
    for (long long p = 0; p < n; ++p)
      sl_target(kernel, ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er, cutoff, nv, ntri, tri, x, y, z,
                fx, fy, fz, q, scale, tx[p], ty[p], tz[p], target_node ? target_node[p] : -1, ux[p], uy[p],
                uz[p]);
  }
#else
#pragma omp parallel for schedule(dynamic, 16) if (backend == Backend::Threads)
  for (long long p = 0; p < n; ++p)
    sl_target(LocalKernel{alpha}, ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er, cutoff, nv, ntri, tri,
              x, y, z, fx, fy, fz, q, scale, tx[p], ty[p], tz[p], target_node ? target_node[p] : -1, ux[p],
              uy[p], uz[p]);
#endif
}

}  // namespace capsflow
