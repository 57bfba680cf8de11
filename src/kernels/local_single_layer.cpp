// The implementation of local_single_layer.hpp: the local part of GGEM for the membranes' single layer.
#include "kernels/local_single_layer.hpp"
#include "kernels/slit_cells.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <vector>

#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/double_layer_kernels.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/ggem_local_table16.hpp"
#include "kernels/simd_path.hpp"
#include "kernels/local_traversal.hpp"

// Host builds on x86-64 without the device backend: batched AVX2 evaluation of G_l (see PointBatch below).
#if defined(__x86_64__) && !defined(CAPSFLOW_HAVE_OFFLOAD) && (defined(__GNUC__) || defined(__clang__))
#define CAPSFLOW_BATCHED_LOCAL_KERNEL 1
#include <immintrin.h>
// GCC 12's AVX-512 intrinsics start from _mm512_undefined_pd(), which its -Wmaybe-uninitialized reports in user code.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
#endif

namespace capsflow {
namespace {

using local_detail::local_target_sum;

CAPSFLOW_DEVICE_BEGIN

inline void kernel_finish(const LocalKernel&, double*) {}

// The element rule of the single layer for local_target_sum (kNear: the near-singular rules compiled in).
template <class Kernel, NearRules kNear = NearRules::Any>
struct SingleLayerRule {
  Kernel kernel;
  QuadratureOrders q;
  void operator()(const double* xt, const double* v, const double* f, int singular, double* acc) const {
    element_integral_add<kNear>(kernel, xt, v, f, singular, q, acc);
  }
};

template <NearRules kNear = NearRules::Any, class Kernel>
inline void sl_target(const Kernel& kernel, const ElementCellsView& cells, double cutoff, const SurfaceView& surface,
                      const Vec3In& f, const QuadratureOrders& q, double scale, double px, double py, double pz,
                      int tnode, double& ux, double& uy, double& uz) {
  SingleLayerRule<Kernel, kNear> rule{kernel, q};
  double acc[3] = {0.0, 0.0, 0.0};
  local_target_sum(rule, cells, cutoff, surface, f, px, py, pz, tnode, acc);
  kernel_finish(kernel, acc);
  ux += scale * acc[0];
  uy += scale * acc[1];
  uz += scale * acc[2];
}

CAPSFLOW_DEVICE_END

#ifdef CAPSFLOW_BATCHED_LOCAL_KERNEL
// Host backends on x86-64: the element rules are evaluated several points at a time, 8 with AVX-512 or 4 with
// AVX2 + FMA when the CPU has them (checked once at run time), else point by point (ggem_local_add_tabulated). The
// collapsed Gauss, 7-point and singular rules are fixed point sets in the element's parametric coordinates (ParamRule,
// evaluated by rule_eval without a buffer); the near-singular rule's points, which depend on the target, go through
// BatchedLocalKernel::add into a per-target buffer (PointBatch). Same points, weights and table as the scalar kernel;
// the terms differ from it by rounding (FMA) and are summed in a different order. Deterministic: the buffer is
// flushed at fixed counts and at the end of each target, and the instruction set is chosen once per process, so the
// serial and threads backends stay bit-identical. Two machines with different vector widths differ at rounding level
// (a restart on another node type continues the run, not its bits).
//
// "Which points" and "evaluate G_l on them" are separate here: rule_eval_* and batch_eval_* only make the points
// (r, g = w f) and hand each vector of them to gl_accumulate_*, the one SIMD evaluator per instruction set.
// The instruction set: the process's vector path (kernels/simd_path.hpp, the CPU's best capped by CAPSFLOW_SIMD).

// What the batch's points are summed with: G_l.g (single layer), W_l(r; g, n) (double layer, n the element's unit
// normal), or W_l for the three unit densities at once (the subtraction's C_i: g = (w, w, w), nine sums).
enum class LayerKind : int { Single = 0, Double = 1, DoubleMatrix = 2 };

struct PointBatch {
  static constexpr int kCap = 128;  // flushed when full
  static constexpr int kSize = kCap + 8;
  alignas(64) double rx[kSize], ry[kSize], rz[kSize], gx[kSize], gy[kSize], gz[kSize];
  alignas(64) double nx[kSize], ny[kSize], nz[kSize];  // double layers only: each point's element normal
  int n = 0;
  double alpha = 0.0;
  int degree = 17;  // of the AVX-512 evaluator's polynomials ([quadrature] kernel_degree: 17 or 9)
  SimdPath simd = SimdPath::Portable;
  LayerKind layer = LayerKind::Single;
  double normal[3] = {0.0, 0.0, 0.0};  // the current element's (double layers)
  double acc[3] = {0.0, 0.0, 0.0};
  double m[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};  // DoubleMatrix: m[3 c + d]
};

// Lanes outside the table (coincident or alpha r >= 6) go through the scalar kernel, the whole vector at once.
inline void gl_accumulate_scalar(double alpha, int lanes, const double* rx, const double* ry, const double* rz,
                                 const double* gx, const double* gy, const double* gz, double* acc) {
  for (int l = 0; l < lanes; ++l)
    ggem_local_add_tabulated(alpha, rx[l], ry[l], rz[l], gx[l], gy[l], gz[l], acc[0], acc[1], acc[2]);
}

// The double layers' lanes point by point (lanes outside the table, and the scalar host path): W_l from the
// table-based closed forms of kernels/double_layer_kernels.hpp.
inline void dl_accumulate_scalar(LayerKind layer, double alpha, int lanes, const double* rx, const double* ry,
                                 const double* rz, const double* gx, const double* gy, const double* gz,
                                 const double* nx, const double* ny, const double* nz, double* acc, double* m) {
  for (int l = 0; l < lanes; ++l) {
    if (layer == LayerKind::Double)
      ggem_dl_local_add_tabulated(alpha, rx[l], ry[l], rz[l], gx[l], gy[l], gz[l], nx[l], ny[l], nz[l], acc[0],
                                  acc[1], acc[2]);
    else
      ggem_dl_local_matrix_add(alpha, rx[l], ry[l], rz[l], gx[l], nx[l], ny[l], nz[l], m);
  }
}

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

// Whether every lane of t lies inside the 144-interval table (else the caller evaluates the vector point by point).
__attribute__((target("avx2,fma"))) inline bool in_table_avx2(__m256d t) {
  const __m256d ok = _mm256_and_pd(_mm256_cmp_pd(t, _mm256_set1_pd(kCoincidentAlphaR * kCoincidentAlphaR), _CMP_GE_OQ),
                                   _mm256_cmp_pd(t, _mm256_set1_pd(kGgemTabTMax), _CMP_LT_OQ));
  return _mm256_movemask_pd(ok) == 15;
}

// The 144-interval table's two polynomials at t = (alpha r)^2 for four points (pq[0] = P or -A, pq[1] = Q or -B),
// 1/r, and s1 = 1/r below t = 4, 0 beyond (the intervals holding P, Q). Every lane inside the table (in_table_avx2).
__attribute__((target("avx2,fma"), always_inline)) inline void tab144_pq_avx2(__m256d r2, __m256d t, __m256d* pq, __m256d& s1,
                                                               __m256d& inv_r) {
  const __m256d one = _mm256_set1_pd(1.0), two = _mm256_set1_pd(2.0);
  const __m256d tw = _mm256_mul_pd(t, _mm256_set1_pd(kGgemTabInvWidth));
  const __m128i iv = _mm256_cvttpd_epi32(tw);
  const __m128i off = _mm_mullo_epi32(iv, _mm_set1_epi32(kGgemTabStride));
  const __m256d u = _mm256_fmsub_pd(two, _mm256_sub_pd(tw, _mm256_cvtepi32_pd(iv)), one);
  const int o[4] = {_mm_extract_epi32(off, 0), _mm_extract_epi32(off, 1), _mm_extract_epi32(off, 2),
                    _mm_extract_epi32(off, 3)};
  // One polynomial at a time (9 coefficient vectors live, not 18: no spills); Estrin as in the scalar kernel.
  const __m256d u2 = _mm256_mul_pd(u, u), u4 = _mm256_mul_pd(u2, u2), u8 = _mm256_mul_pd(u4, u4);
  for (int j = 0; j < 2; ++j) {
    __m256d c[9];
    load_table_rows_avx2(j == 0 ? kGgemTabA : kGgemTabB, o, c);
    const __m256d p01 = _mm256_fmadd_pd(c[1], u, c[0]), p23 = _mm256_fmadd_pd(c[3], u, c[2]);
    const __m256d p45 = _mm256_fmadd_pd(c[5], u, c[4]), p67 = _mm256_fmadd_pd(c[7], u, c[6]);
    pq[j] = _mm256_fmadd_pd(u8, c[8],
                            _mm256_fmadd_pd(u4, _mm256_fmadd_pd(u2, p67, p45), _mm256_fmadd_pd(u2, p23, p01)));
  }
  inv_r = _mm256_div_pd(one, _mm256_sqrt_pd(r2));
  s1 = _mm256_and_pd(_mm256_cmp_pd(t, _mm256_set1_pd(kGgemTabDirectFrom / kGgemTabInvWidth), _CMP_LT_OQ), inv_r);
}

// Adds G_l(r).g of four points to (sx, sy, sz) (table lanes) or acc (a vector with a lane outside the table).
__attribute__((target("avx2,fma"))) inline void gl_accumulate_avx2(double alpha, __m256d rx, __m256d ry, __m256d rz,
                                                                   __m256d gx, __m256d gy, __m256d gz, __m256d& sx,
                                                                   __m256d& sy, __m256d& sz, double* acc) {
  const double a2 = alpha * alpha;
  const __m256d r2 = _mm256_fmadd_pd(rz, rz, _mm256_fmadd_pd(ry, ry, _mm256_mul_pd(rx, rx)));
  const __m256d t = _mm256_mul_pd(_mm256_set1_pd(a2), r2);
  if (!in_table_avx2(t)) {
    alignas(32) double b[6][4];
    _mm256_store_pd(b[0], rx), _mm256_store_pd(b[1], ry), _mm256_store_pd(b[2], rz);
    _mm256_store_pd(b[3], gx), _mm256_store_pd(b[4], gy), _mm256_store_pd(b[5], gz);
    gl_accumulate_scalar(alpha, 4, b[0], b[1], b[2], b[3], b[4], b[5], acc);
    return;
  }
  __m256d pq[2], s1, inv_r;
  tab144_pq_avx2(r2, t, pq, s1, inv_r);
  const __m256d a = _mm256_fnmadd_pd(_mm256_set1_pd(alpha), pq[0], s1);
  const __m256d rf = _mm256_fmadd_pd(rz, gz, _mm256_fmadd_pd(ry, gy, _mm256_mul_pd(rx, gx)));
  const __m256d bb = _mm256_mul_pd(
      _mm256_fnmadd_pd(_mm256_set1_pd(alpha * a2), pq[1], _mm256_mul_pd(_mm256_mul_pd(s1, inv_r), inv_r)), rf);
  sx = _mm256_add_pd(sx, _mm256_fmadd_pd(bb, rx, _mm256_mul_pd(a, gx)));
  sy = _mm256_add_pd(sy, _mm256_fmadd_pd(bb, ry, _mm256_mul_pd(a, gy)));
  sz = _mm256_add_pd(sz, _mm256_fmadd_pd(bb, rz, _mm256_mul_pd(a, gz)));
}

__attribute__((target("avx2,fma"))) inline void reduce_add_avx2(__m256d sx, __m256d sy, __m256d sz, double* acc) {
  alignas(32) double lx[4], ly[4], lz[4];
  _mm256_store_pd(lx, sx), _mm256_store_pd(ly, sy), _mm256_store_pd(lz, sz);
  acc[0] += (lx[0] + lx[1]) + (lx[2] + lx[3]);
  acc[1] += (ly[0] + ly[1]) + (ly[2] + ly[3]);
  acc[2] += (lz[0] + lz[1]) + (lz[2] + lz[3]);
}

// W_l's radial coefficients (double_layer_kernels.hpp: A1 = 6 (c1 + c2)/r^4 + 4 alpha^2 c2/r^2, T = 2 alpha^2 c2) of
// four points from the 144-interval table, whose P, Q (t < 4) and -A, -B (t >= 4) give c1 + c2 = s1 - alpha t Q and
// c2 = alpha (P - t Q)/2, s1 = 1/r below t = 4 and 0 beyond. Every lane inside the table (the caller checks).
__attribute__((target("avx2,fma"))) inline void dl_coefficients_avx2(double alpha, __m256d r2, __m256d t, __m256d& A1,
                                                                     __m256d& T) {
  const double a2 = alpha * alpha;
  __m256d pq[2], s1, inv_r;
  tab144_pq_avx2(r2, t, pq, s1, inv_r);
  const __m256d cc = _mm256_fnmadd_pd(_mm256_mul_pd(_mm256_set1_pd(alpha), t), pq[1], s1);
  const __m256d c2 = _mm256_mul_pd(_mm256_set1_pd(0.5 * alpha), _mm256_fnmadd_pd(t, pq[1], pq[0]));
  const __m256d inv_r2 = _mm256_mul_pd(inv_r, inv_r);
  A1 = _mm256_mul_pd(_mm256_fmadd_pd(_mm256_mul_pd(_mm256_set1_pd(6.0), cc), inv_r2,
                                     _mm256_mul_pd(_mm256_set1_pd(4.0 * a2), c2)),
                     inv_r2);
  T = _mm256_mul_pd(_mm256_set1_pd(2.0 * a2), c2);
}

// The double layers' batch, four points at a time (AVX2 + FMA): W_l(r; g, n) into acc, or the unit densities'
// nine sums into m.
__attribute__((target("avx2,fma"))) void dl_batch_avx2(const PointBatch& b, double* acc, double* m) {
  const double a2 = b.alpha * b.alpha;
  const bool matrix = b.layer == LayerKind::DoubleMatrix;
  __m256d s[9];
  for (auto& v : s) v = _mm256_setzero_pd();
  for (int k = 0; k < b.n; k += 4) {
    const __m256d rx = _mm256_load_pd(b.rx + k), ry = _mm256_load_pd(b.ry + k), rz = _mm256_load_pd(b.rz + k);
    const __m256d r2 = _mm256_fmadd_pd(rz, rz, _mm256_fmadd_pd(ry, ry, _mm256_mul_pd(rx, rx)));
    const __m256d t = _mm256_mul_pd(_mm256_set1_pd(a2), r2);
    if (!in_table_avx2(t)) {
      dl_accumulate_scalar(b.layer, b.alpha, 4, b.rx + k, b.ry + k, b.rz + k, b.gx + k, b.gy + k, b.gz + k, b.nx + k,
                           b.ny + k, b.nz + k, acc, m);
      continue;
    }
    __m256d A1, T;
    dl_coefficients_avx2(b.alpha, r2, t, A1, T);
    const __m256d nx = _mm256_load_pd(b.nx + k), ny = _mm256_load_pd(b.ny + k), nz = _mm256_load_pd(b.nz + k);
    const __m256d nr = _mm256_fmadd_pd(nz, rz, _mm256_fmadd_pd(ny, ry, _mm256_mul_pd(nx, rx)));
    const __m256d gx = _mm256_load_pd(b.gx + k);
    if (matrix) {
      // m[3 c + d] += w (A1 r_d nr - T n_d) r_c - w T (delta_cd nr + n_c r_d), w = gx
      const __m256d wa = _mm256_mul_pd(_mm256_mul_pd(gx, A1), nr), wt = _mm256_mul_pd(gx, T);
      const __m256d r[3] = {rx, ry, rz}, n[3] = {nx, ny, nz};
      for (int d = 0; d < 3; ++d) {
        const __m256d sd = _mm256_fmsub_pd(wa, r[d], _mm256_mul_pd(wt, n[d]));
        for (int c = 0; c < 3; ++c) {
          __m256d e = _mm256_mul_pd(n[c], r[d]);
          if (c == d) e = _mm256_add_pd(e, nr);
          s[3 * c + d] = _mm256_add_pd(s[3 * c + d], _mm256_fnmadd_pd(wt, e, _mm256_mul_pd(sd, r[c])));
        }
      }
      continue;
    }
    const __m256d gy = _mm256_load_pd(b.gy + k), gz = _mm256_load_pd(b.gz + k);
    const __m256d qr = _mm256_fmadd_pd(gz, rz, _mm256_fmadd_pd(gy, ry, _mm256_mul_pd(gx, rx)));
    const __m256d qn = _mm256_fmadd_pd(gz, nz, _mm256_fmadd_pd(gy, ny, _mm256_mul_pd(gx, nx)));
    const __m256d sc = _mm256_fmsub_pd(_mm256_mul_pd(A1, qr), nr, _mm256_mul_pd(T, qn));
    s[0] = _mm256_add_pd(s[0], _mm256_fnmadd_pd(T, _mm256_fmadd_pd(gx, nr, _mm256_mul_pd(nx, qr)), _mm256_mul_pd(sc, rx)));
    s[1] = _mm256_add_pd(s[1], _mm256_fnmadd_pd(T, _mm256_fmadd_pd(gy, nr, _mm256_mul_pd(ny, qr)), _mm256_mul_pd(sc, ry)));
    s[2] = _mm256_add_pd(s[2], _mm256_fnmadd_pd(T, _mm256_fmadd_pd(gz, nr, _mm256_mul_pd(nz, qr)), _mm256_mul_pd(sc, rz)));
  }
  alignas(32) double l[4];
  const int sums = matrix ? 9 : 3;
  for (int j = 0; j < sums; ++j) {
    _mm256_store_pd(l, s[j]);
    (matrix ? m : acc)[j] += (l[0] + l[1]) + (l[2] + l[3]);
  }
}

// Coefficient m of table T (kernels/ggem_local_table16.hpp) for each lane's interval idx.
__attribute__((target("avx512f"), always_inline)) inline __m512d tab16_coef(const double* T, int m, __m512i idx) {
  return _mm512_permutex2var_pd(_mm512_load_pd(T + 16 * m), idx, _mm512_load_pd(T + 16 * m + 8));
}

// The table's two polynomials at t = (alpha r)^2 for eight points (pq[0] = P or -A, pq[1] = Q or -B), 1/r, and s1 =
// 1/r below t = 4, 0 beyond (the intervals holding P, Q). Every lane inside the table (the caller checks). Deg 17: the
// whole table; Deg 9: its first ten coefficients ([quadrature] kernel_degree: the dropped terms are at most 1.6e-7 of
// 1/x in P, A and 4.1e-7 of 1/x^3 in Q, B, x = alpha r; 20 coefficient permutes per 8 points instead of 36).
template <int Deg>
__attribute__((target("avx512f"), always_inline)) inline void tab16_pq_avx512(__m512d r2, __m512d t, __m512d* pq,
                                                                               __m512d& s1, __m512d& inv_r) {
  static_assert(kGgemTab16Degree == 17 && (Deg == 17 || Deg == 9), "18 coefficients, of which 18 or 10 are used");
  // Interval i = floor(t / 2), local variable u = t - (2 i + 1) in [-1, 1).
  const __m512d half_t = _mm512_roundscale_pd(_mm512_mul_pd(t, _mm512_set1_pd(0.5)),
                                              _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  const __m512d u = _mm512_sub_pd(t, _mm512_fmadd_pd(_mm512_set1_pd(2.0), half_t, _mm512_set1_pd(1.0)));
  const __m512i idx = _mm512_cvtepi32_epi64(_mm512_cvttpd_epi32(half_t));
  // Two Horner halves per polynomial (p = lo + u^h hi, h = (Deg + 1)/2: four chains of h FMAs instead of two of 2h).
  constexpr int h = (Deg + 1) / 2;
  __m512d alo = tab16_coef(kGgemTab16A, h - 1, idx), ahi = tab16_coef(kGgemTab16A, Deg, idx),
          blo = tab16_coef(kGgemTab16B, h - 1, idx), bhi = tab16_coef(kGgemTab16B, Deg, idx);
  for (int m = h - 2; m >= 0; --m) {
    alo = _mm512_fmadd_pd(alo, u, tab16_coef(kGgemTab16A, m, idx));
    ahi = _mm512_fmadd_pd(ahi, u, tab16_coef(kGgemTab16A, m + h, idx));
    blo = _mm512_fmadd_pd(blo, u, tab16_coef(kGgemTab16B, m, idx));
    bhi = _mm512_fmadd_pd(bhi, u, tab16_coef(kGgemTab16B, m + h, idx));
  }
  const __m512d u2 = _mm512_mul_pd(u, u), u4 = _mm512_mul_pd(u2, u2);
  const __m512d uh = Deg == 17 ? _mm512_mul_pd(_mm512_mul_pd(u4, u4), u) : _mm512_mul_pd(u4, u);
  pq[0] = _mm512_fmadd_pd(uh, ahi, alo);
  pq[1] = _mm512_fmadd_pd(uh, bhi, blo);
  // 1/r from the 14-bit estimate and two Newton steps (~1 ulp): sqrt and divide are the slowest instructions here.
  const __m512d half = _mm512_set1_pd(0.5), three_half = _mm512_set1_pd(1.5), hr2 = _mm512_mul_pd(half, r2);
  inv_r = _mm512_rsqrt14_pd(r2);
  inv_r = _mm512_mul_pd(inv_r, _mm512_fnmadd_pd(hr2, _mm512_mul_pd(inv_r, inv_r), three_half));
  inv_r = _mm512_mul_pd(inv_r, _mm512_fnmadd_pd(hr2, _mm512_mul_pd(inv_r, inv_r), three_half));
  s1 = _mm512_maskz_mov_pd(_mm512_cmp_pd_mask(t, _mm512_set1_pd(kGgemTabDirectFrom / kGgemTabInvWidth), _CMP_LT_OQ),
                           inv_r);
}

// gl_accumulate_avx2 for eight points, from the 16-interval table (kernels/ggem_local_table16.hpp): each lane's
// coefficient comes from two registers by one two-source permute (vpermt2pd), 2 x 18 of them per 8 points, instead
// of 16 row loads, 48 shuffles and 2 gathers for the 144-interval table of the scalar kernel. Lanes with
// alpha r >= sqrt(32) (rare: r_c + 2 R_e) or coincident send the vector to the scalar kernel.
template <int Deg>
__attribute__((target("avx512f"), always_inline)) inline void gl_accumulate_avx512(
    double alpha, __m512d rx, __m512d ry, __m512d rz, __m512d gx, __m512d gy, __m512d gz, __m512d& sx, __m512d& sy,
    __m512d& sz, double* acc) {
  const double a2 = alpha * alpha;
  const __m512d r2 = _mm512_fmadd_pd(rz, rz, _mm512_fmadd_pd(ry, ry, _mm512_mul_pd(rx, rx)));
  const __m512d t = _mm512_mul_pd(_mm512_set1_pd(a2), r2);
  const __mmask8 ok =
      _mm512_cmp_pd_mask(t, _mm512_set1_pd(kCoincidentAlphaR * kCoincidentAlphaR), _CMP_GE_OQ) &
      _mm512_cmp_pd_mask(t, _mm512_set1_pd(kGgemTab16TMax), _CMP_LT_OQ);
  if (ok != 0xFF) {
    alignas(64) double b[6][8];
    _mm512_store_pd(b[0], rx), _mm512_store_pd(b[1], ry), _mm512_store_pd(b[2], rz);
    _mm512_store_pd(b[3], gx), _mm512_store_pd(b[4], gy), _mm512_store_pd(b[5], gz);
    gl_accumulate_scalar(alpha, 8, b[0], b[1], b[2], b[3], b[4], b[5], acc);
    return;
  }
  __m512d pq[2], s1, inv_r;
  tab16_pq_avx512<Deg>(r2, t, pq, s1, inv_r);
  const __m512d a = _mm512_fnmadd_pd(_mm512_set1_pd(alpha), pq[0], s1);
  const __m512d rf = _mm512_fmadd_pd(rz, gz, _mm512_fmadd_pd(ry, gy, _mm512_mul_pd(rx, gx)));
  const __m512d bb = _mm512_mul_pd(
      _mm512_fnmadd_pd(_mm512_set1_pd(alpha * a2), pq[1], _mm512_mul_pd(_mm512_mul_pd(s1, inv_r), inv_r)), rf);
  sx = _mm512_add_pd(sx, _mm512_fmadd_pd(bb, rx, _mm512_mul_pd(a, gx)));
  sy = _mm512_add_pd(sy, _mm512_fmadd_pd(bb, ry, _mm512_mul_pd(a, gy)));
  sz = _mm512_add_pd(sz, _mm512_fmadd_pd(bb, rz, _mm512_mul_pd(a, gz)));
}

__attribute__((target("avx512f"))) inline void reduce_add_avx512(__m512d sx, __m512d sy, __m512d sz, double* acc) {
  alignas(64) double l[3][8];
  _mm512_store_pd(l[0], sx), _mm512_store_pd(l[1], sy), _mm512_store_pd(l[2], sz);
  for (int c = 0; c < 3; ++c)
    acc[c] += ((l[c][0] + l[c][1]) + (l[c][2] + l[c][3])) + ((l[c][4] + l[c][5]) + (l[c][6] + l[c][7]));
}

// dl_batch_avx2 for eight points at a time, from the 16-interval table (the single layer's AVX-512 evaluator's
// polynomials): W_l = [A1 (g.r)(n.r) - T (g.n)] r - T [g (n.r) + n (g.r)], or the unit densities' nine sums.
template <int Deg>
__attribute__((target("avx512f"))) void dl_batch_avx512(const PointBatch& b, double* acc, double* m) {
  const double alpha = b.alpha, a2 = alpha * alpha;
  const bool matrix = b.layer == LayerKind::DoubleMatrix;
  __m512d s[9];
  for (auto& v : s) v = _mm512_setzero_pd();
  for (int k = 0; k < b.n; k += 8) {
    const __m512d rx = _mm512_load_pd(b.rx + k), ry = _mm512_load_pd(b.ry + k), rz = _mm512_load_pd(b.rz + k);
    const __m512d r2 = _mm512_fmadd_pd(rz, rz, _mm512_fmadd_pd(ry, ry, _mm512_mul_pd(rx, rx)));
    const __m512d t = _mm512_mul_pd(_mm512_set1_pd(a2), r2);
    const __mmask8 ok = _mm512_cmp_pd_mask(t, _mm512_set1_pd(kCoincidentAlphaR * kCoincidentAlphaR), _CMP_GE_OQ) &
                        _mm512_cmp_pd_mask(t, _mm512_set1_pd(kGgemTab16TMax), _CMP_LT_OQ);
    if (ok != 0xFF) {
      dl_accumulate_scalar(b.layer, alpha, 8, b.rx + k, b.ry + k, b.rz + k, b.gx + k, b.gy + k, b.gz + k, b.nx + k,
                           b.ny + k, b.nz + k, acc, m);
      continue;
    }
    __m512d pq[2], s1, inv_r;
    tab16_pq_avx512<Deg>(r2, t, pq, s1, inv_r);
    // c1 + c2 = s1 - alpha t Q, c2 = alpha (P - t Q)/2 (double_layer_kernels.hpp, from the same table's P, Q / -A, -B)
    const __m512d cc = _mm512_fnmadd_pd(_mm512_mul_pd(_mm512_set1_pd(alpha), t), pq[1], s1);
    const __m512d c2 = _mm512_mul_pd(_mm512_set1_pd(0.5 * alpha), _mm512_fnmadd_pd(t, pq[1], pq[0]));
    const __m512d inv_r2 = _mm512_mul_pd(inv_r, inv_r);
    const __m512d A1 = _mm512_mul_pd(
        _mm512_fmadd_pd(_mm512_mul_pd(_mm512_set1_pd(6.0), cc), inv_r2, _mm512_mul_pd(_mm512_set1_pd(4.0 * a2), c2)),
        inv_r2);
    const __m512d T = _mm512_mul_pd(_mm512_set1_pd(2.0 * a2), c2);
    const __m512d nx = _mm512_load_pd(b.nx + k), ny = _mm512_load_pd(b.ny + k), nz = _mm512_load_pd(b.nz + k);
    const __m512d nr = _mm512_fmadd_pd(nz, rz, _mm512_fmadd_pd(ny, ry, _mm512_mul_pd(nx, rx)));
    const __m512d gx = _mm512_load_pd(b.gx + k);
    if (matrix) {
      const __m512d wa = _mm512_mul_pd(_mm512_mul_pd(gx, A1), nr), wt = _mm512_mul_pd(gx, T);
      const __m512d r[3] = {rx, ry, rz}, n[3] = {nx, ny, nz};
      for (int d = 0; d < 3; ++d) {
        const __m512d sd = _mm512_fmsub_pd(wa, r[d], _mm512_mul_pd(wt, n[d]));
        for (int c = 0; c < 3; ++c) {
          __m512d e = _mm512_mul_pd(n[c], r[d]);
          if (c == d) e = _mm512_add_pd(e, nr);
          s[3 * c + d] = _mm512_add_pd(s[3 * c + d], _mm512_fnmadd_pd(wt, e, _mm512_mul_pd(sd, r[c])));
        }
      }
      continue;
    }
    const __m512d gy = _mm512_load_pd(b.gy + k), gz = _mm512_load_pd(b.gz + k);
    const __m512d qr = _mm512_fmadd_pd(gz, rz, _mm512_fmadd_pd(gy, ry, _mm512_mul_pd(gx, rx)));
    const __m512d qn = _mm512_fmadd_pd(gz, nz, _mm512_fmadd_pd(gy, ny, _mm512_mul_pd(gx, nx)));
    const __m512d sc = _mm512_fmsub_pd(_mm512_mul_pd(A1, qr), nr, _mm512_mul_pd(T, qn));
    s[0] = _mm512_add_pd(s[0], _mm512_fnmadd_pd(T, _mm512_fmadd_pd(gx, nr, _mm512_mul_pd(nx, qr)), _mm512_mul_pd(sc, rx)));
    s[1] = _mm512_add_pd(s[1], _mm512_fnmadd_pd(T, _mm512_fmadd_pd(gy, nr, _mm512_mul_pd(ny, qr)), _mm512_mul_pd(sc, ry)));
    s[2] = _mm512_add_pd(s[2], _mm512_fnmadd_pd(T, _mm512_fmadd_pd(gz, nr, _mm512_mul_pd(nz, qr)), _mm512_mul_pd(sc, rz)));
  }
  alignas(64) double l[8];
  const int sums = matrix ? 9 : 3;
  for (int j = 0; j < sums; ++j) {
    _mm512_store_pd(l, s[j]);
    (matrix ? m : acc)[j] += ((l[0] + l[1]) + (l[2] + l[3])) + ((l[4] + l[5]) + (l[6] + l[7]));
  }
}

// Pads the buffer to a multiple of `lanes` with copies of point 0 carrying zero density (zero weight for the matrix):
// they add exactly zero.
inline void batch_pad(PointBatch& b, int lanes) {
  const bool normals = b.layer != LayerKind::Single;
  while (b.n % lanes != 0) {
    b.rx[b.n] = b.rx[0], b.ry[b.n] = b.ry[0], b.rz[b.n] = b.rz[0];
    b.gx[b.n] = 0.0, b.gy[b.n] = 0.0, b.gz[b.n] = 0.0;
    if (normals) b.nx[b.n] = b.nx[0], b.ny[b.n] = b.ny[0], b.nz[b.n] = b.nz[0];
    ++b.n;
  }
}

__attribute__((target("avx2,fma"))) void batch_eval_avx2(PointBatch& b) {
  batch_pad(b, 4);
  __m256d sx = _mm256_setzero_pd(), sy = _mm256_setzero_pd(), sz = _mm256_setzero_pd();
  for (int k = 0; k < b.n; k += 4)
    gl_accumulate_avx2(b.alpha, _mm256_load_pd(b.rx + k), _mm256_load_pd(b.ry + k), _mm256_load_pd(b.rz + k),
                       _mm256_load_pd(b.gx + k), _mm256_load_pd(b.gy + k), _mm256_load_pd(b.gz + k), sx, sy, sz,
                       b.acc);
  reduce_add_avx2(sx, sy, sz, b.acc);
  b.n = 0;
}

template <int Deg>
__attribute__((target("avx512f"))) void batch_eval_avx512(PointBatch& b) {
  batch_pad(b, 8);
  __m512d sx = _mm512_setzero_pd(), sy = _mm512_setzero_pd(), sz = _mm512_setzero_pd();
  for (int k = 0; k < b.n; k += 8)
    gl_accumulate_avx512<Deg>(b.alpha, _mm512_load_pd(b.rx + k), _mm512_load_pd(b.ry + k), _mm512_load_pd(b.rz + k),
                         _mm512_load_pd(b.gx + k), _mm512_load_pd(b.gy + k), _mm512_load_pd(b.gz + k), sx, sy, sz,
                         b.acc);
  reduce_add_avx512(sx, sy, sz, b.acc);
  b.n = 0;
}

void batch_flush(PointBatch& b) {
  if (b.n == 0) return;
  if (b.layer != LayerKind::Single) {
    switch (b.simd) {
      case SimdPath::Avx512:
        batch_pad(b, 8);
        b.degree == 9 ? dl_batch_avx512<9>(b, b.acc, b.m) : dl_batch_avx512<17>(b, b.acc, b.m);
        break;
      case SimdPath::Avx2: batch_pad(b, 4), dl_batch_avx2(b, b.acc, b.m); break;
      case SimdPath::Portable:
        dl_accumulate_scalar(b.layer, b.alpha, b.n, b.rx, b.ry, b.rz, b.gx, b.gy, b.gz, b.nx, b.ny, b.nz, b.acc, b.m);
        break;
    }
    b.n = 0;
    return;
  }
  switch (b.simd) {
    case SimdPath::Avx512: b.degree == 9 ? batch_eval_avx512<9>(b) : batch_eval_avx512<17>(b); return;
    case SimdPath::Avx2: batch_eval_avx2(b); return;
    case SimdPath::Portable: break;
  }
  gl_accumulate_scalar(b.alpha, b.n, b.rx, b.ry, b.rz, b.gx, b.gy, b.gz, b.acc);
  b.n = 0;
}

struct BatchedLocalKernel {
  PointBatch* b;
  void add(double rx, double ry, double rz, double fx, double fy, double fz, double&, double&, double&) const {
    PointBatch& B = *b;
    B.rx[B.n] = rx, B.ry[B.n] = ry, B.rz[B.n] = rz, B.gx[B.n] = fx, B.gy[B.n] = fy, B.gz[B.n] = fz;
    if (B.layer != LayerKind::Single) B.nx[B.n] = B.normal[0], B.ny[B.n] = B.normal[1], B.nz[B.n] = B.normal[2];
    if (++B.n >= PointBatch::kCap) batch_flush(B);
  }
};

// Fixed rules in the element's parametric coordinates: y = v0 + eta (v1 - v0) + xi (v2 - v0), weight jac * w
// (jac = twice the area). Stored padded to a multiple of 8 with zero-weight copies of point 0 (they add exactly
// zero); the AVX2 and scalar evaluators stop at n4, the count rounded up to 4.
struct ParamRule {
  std::vector<double> eta, xi, w;
  int count = 0;  // points before padding
  int n4 = 0;
  void add(double e, double x, double wt) {
    eta.push_back(e), xi.push_back(x), w.push_back(wt);
  }
  void pad() {
    count = static_cast<int>(eta.size());
    while (eta.size() % 4 != 0) add(eta[0], xi[0], 0.0);
    n4 = static_cast<int>(eta.size());
    while (eta.size() % 8 != 0) add(eta[0], xi[0], 0.0);
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

// The 16-point symmetric rule, as in quad_detail::symmetric16_add (eta, xi = l1, l2; half the weight per jac).
const ParamRule& symmetric16_rule() {
  static const ParamRule rule = [] {
    ParamRule r;
    for (const auto& p : quad_detail::kSym16) r.add(p[1], p[2], 0.5 * p[3]);
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

// The points (r = xt - y, g = jac w f(y)) of rule R on element (v, f), handed to the evaluator a vector at a time.
__attribute__((target("avx2,fma"))) void rule_eval_avx2(double alpha, const double* xt, const double* v,
                                                        const double* f, double jac, const ParamRule& R, double* acc) {
  const __m256d x0x = _mm256_set1_pd(xt[0] - v[0]), x0y = _mm256_set1_pd(xt[1] - v[1]),
                x0z = _mm256_set1_pd(xt[2] - v[2]);
  const __m256d e1x = _mm256_set1_pd(v[3] - v[0]), e1y = _mm256_set1_pd(v[4] - v[1]), e1z = _mm256_set1_pd(v[5] - v[2]);
  const __m256d e2x = _mm256_set1_pd(v[6] - v[0]), e2y = _mm256_set1_pd(v[7] - v[1]), e2z = _mm256_set1_pd(v[8] - v[2]);
  const __m256d d1x = _mm256_set1_pd(f[3] - f[0]), d1y = _mm256_set1_pd(f[4] - f[1]), d1z = _mm256_set1_pd(f[5] - f[2]);
  const __m256d d2x = _mm256_set1_pd(f[6] - f[0]), d2y = _mm256_set1_pd(f[7] - f[1]), d2z = _mm256_set1_pd(f[8] - f[2]);
  const __m256d f0x = _mm256_set1_pd(f[0]), f0y = _mm256_set1_pd(f[1]), f0z = _mm256_set1_pd(f[2]);
  const __m256d vjac = _mm256_set1_pd(jac);
  __m256d sx = _mm256_setzero_pd(), sy = _mm256_setzero_pd(), sz = _mm256_setzero_pd();
  for (int k = 0; k < R.n4; k += 4) {
    const __m256d eta = _mm256_loadu_pd(R.eta.data() + k), xi = _mm256_loadu_pd(R.xi.data() + k);
    const __m256d w = _mm256_mul_pd(vjac, _mm256_loadu_pd(R.w.data() + k));
    const __m256d rx = _mm256_fnmadd_pd(xi, e2x, _mm256_fnmadd_pd(eta, e1x, x0x));
    const __m256d ry = _mm256_fnmadd_pd(xi, e2y, _mm256_fnmadd_pd(eta, e1y, x0y));
    const __m256d rz = _mm256_fnmadd_pd(xi, e2z, _mm256_fnmadd_pd(eta, e1z, x0z));
    const __m256d gx = _mm256_mul_pd(w, _mm256_fmadd_pd(xi, d2x, _mm256_fmadd_pd(eta, d1x, f0x)));
    const __m256d gy = _mm256_mul_pd(w, _mm256_fmadd_pd(xi, d2y, _mm256_fmadd_pd(eta, d1y, f0y)));
    const __m256d gz = _mm256_mul_pd(w, _mm256_fmadd_pd(xi, d2z, _mm256_fmadd_pd(eta, d1z, f0z)));
    gl_accumulate_avx2(alpha, rx, ry, rz, gx, gy, gz, sx, sy, sz, acc);
  }
  reduce_add_avx2(sx, sy, sz, acc);
}

// With AVX-512 the rule's points go into the target's buffer (only the rule's own points, no padding) and are
// evaluated in long runs by batch_eval_avx512: one reduction per flush instead of one per element, and independent
// vectors back to back for the out-of-order core.
__attribute__((target("avx512f"))) void rule_emit_avx512(PointBatch& B, const double* xt, const double* v,
                                                         const double* f, double jac, const ParamRule& R) {
  const __m512d x0x = _mm512_set1_pd(xt[0] - v[0]), x0y = _mm512_set1_pd(xt[1] - v[1]),
                x0z = _mm512_set1_pd(xt[2] - v[2]);
  const __m512d e1x = _mm512_set1_pd(v[3] - v[0]), e1y = _mm512_set1_pd(v[4] - v[1]), e1z = _mm512_set1_pd(v[5] - v[2]);
  const __m512d e2x = _mm512_set1_pd(v[6] - v[0]), e2y = _mm512_set1_pd(v[7] - v[1]), e2z = _mm512_set1_pd(v[8] - v[2]);
  const __m512d d1x = _mm512_set1_pd(f[3] - f[0]), d1y = _mm512_set1_pd(f[4] - f[1]), d1z = _mm512_set1_pd(f[5] - f[2]);
  const __m512d d2x = _mm512_set1_pd(f[6] - f[0]), d2y = _mm512_set1_pd(f[7] - f[1]), d2z = _mm512_set1_pd(f[8] - f[2]);
  const __m512d f0x = _mm512_set1_pd(f[0]), f0y = _mm512_set1_pd(f[1]), f0z = _mm512_set1_pd(f[2]);
  const __m512d vjac = _mm512_set1_pd(jac);
  for (int k = 0; k < R.count; k += 8) {
    if (B.n > PointBatch::kCap - 8) batch_flush(B);
    const int m = R.count - k < 8 ? R.count - k : 8;
    const __mmask8 mask = static_cast<__mmask8>((1u << m) - 1u);
    const __m512d eta = _mm512_loadu_pd(R.eta.data() + k), xi = _mm512_loadu_pd(R.xi.data() + k);
    const __m512d w = _mm512_mul_pd(vjac, _mm512_loadu_pd(R.w.data() + k));
    const int o = B.n;
    _mm512_mask_storeu_pd(B.rx + o, mask, _mm512_fnmadd_pd(xi, e2x, _mm512_fnmadd_pd(eta, e1x, x0x)));
    _mm512_mask_storeu_pd(B.ry + o, mask, _mm512_fnmadd_pd(xi, e2y, _mm512_fnmadd_pd(eta, e1y, x0y)));
    _mm512_mask_storeu_pd(B.rz + o, mask, _mm512_fnmadd_pd(xi, e2z, _mm512_fnmadd_pd(eta, e1z, x0z)));
    _mm512_mask_storeu_pd(B.gx + o, mask, _mm512_mul_pd(w, _mm512_fmadd_pd(xi, d2x, _mm512_fmadd_pd(eta, d1x, f0x))));
    _mm512_mask_storeu_pd(B.gy + o, mask, _mm512_mul_pd(w, _mm512_fmadd_pd(xi, d2y, _mm512_fmadd_pd(eta, d1y, f0y))));
    _mm512_mask_storeu_pd(B.gz + o, mask, _mm512_mul_pd(w, _mm512_fmadd_pd(xi, d2z, _mm512_fmadd_pd(eta, d1z, f0z))));
    if (B.layer != LayerKind::Single) {
      _mm512_mask_storeu_pd(B.nx + o, mask, _mm512_set1_pd(B.normal[0]));
      _mm512_mask_storeu_pd(B.ny + o, mask, _mm512_set1_pd(B.normal[1]));
      _mm512_mask_storeu_pd(B.nz + o, mask, _mm512_set1_pd(B.normal[2]));
    }
    B.n = o + m;
  }
}

// jac = twice the element's area; negative: computed here.
void rule_eval(const BatchedLocalKernel& k, const double* xt, const double* v, const double* f, const ParamRule& R,
               double jac = -1.0) {
  PointBatch& B = *k.b;
  if (jac < 0.0) jac = quad_detail::twice_area(v);
  if (B.simd == SimdPath::Avx512) {
    rule_emit_avx512(B, xt, v, f, jac, R);
    return;
  }
  if (B.layer != LayerKind::Single) {  // the double layers: the rule's points into the buffer (batch_flush evaluates)
    for (int i = 0; i < R.count; ++i) {
      const double e = R.eta[i], x = R.xi[i], w = jac * R.w[i];
      double r[3], g[3];
      for (int c = 0; c < 3; ++c) {
        r[c] = xt[c] - (v[c] + e * (v[3 + c] - v[c]) + x * (v[6 + c] - v[c]));
        g[c] = w * (f[c] + e * (f[3 + c] - f[c]) + x * (f[6 + c] - f[c]));
      }
      double unused[3];
      k.add(r[0], r[1], r[2], g[0], g[1], g[2], unused[0], unused[1], unused[2]);
    }
    return;
  }
  if (B.simd == SimdPath::Avx2) {
    rule_eval_avx2(B.alpha, xt, v, f, jac, R, B.acc);
    return;
  }
  for (int i = 0; i < R.n4; ++i) {
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
void symmetric16_add(const BatchedLocalKernel& k, const double* xt, const double* v, const double* f, double*) {
  rule_eval(k, xt, v, f, symmetric16_rule());
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

// Candidate scan, 8 elements of a cell at a time: the centroid offsets (minimum image) and which of them lie within
// cutoff + R_e of the target (bit l of the result for element l; m <= 8 elements).
struct Scan8 {
  alignas(64) double rx[8], ry[8], rz[8], d2[8];
};

unsigned scan8_scalar(const double* ex, const double* ey, const double* ez, const double* er, int m, double px,
                      double py, double pz, double Lx, double Lz, double inv_Lx, double inv_Lz, double cutoff,
                      Scan8& o) {
  unsigned hits = 0;
  for (int l = 0; l < m; ++l) {
    const double rx = min_image_fast(ex[l] - px, Lx, inv_Lx), ry = ey[l] - py, rz = min_image_fast(ez[l] - pz, Lz, inv_Lz);
    const double reach = cutoff + er[l];
    o.rx[l] = rx, o.ry[l] = ry, o.rz[l] = rz;
    o.d2[l] = rx * rx + ry * ry + rz * rz;
    if (o.d2[l] < reach * reach) hits |= 1u << l;
  }
  return hits;
}

// The same with AVX-512; the image is rounded half to even instead of half away from zero, which differs only for
// offsets of exactly L/2, far beyond reach (L > 2 reach).
__attribute__((target("avx512f"))) unsigned scan8_avx512(const double* ex, const double* ey, const double* ez,
                                                         const double* er, int m, double px, double py, double pz,
                                                         double Lx, double Lz, double inv_Lx, double inv_Lz,
                                                         double cutoff, Scan8& o) {
  const __mmask8 mask = static_cast<__mmask8>((1u << m) - 1u);
  constexpr int kNearest = _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC;
  __m512d rx = _mm512_sub_pd(_mm512_maskz_loadu_pd(mask, ex), _mm512_set1_pd(px));
  rx = _mm512_fnmadd_pd(_mm512_set1_pd(Lx), _mm512_roundscale_pd(_mm512_mul_pd(rx, _mm512_set1_pd(inv_Lx)), kNearest),
                        rx);
  const __m512d ry = _mm512_sub_pd(_mm512_maskz_loadu_pd(mask, ey), _mm512_set1_pd(py));
  __m512d rz = _mm512_sub_pd(_mm512_maskz_loadu_pd(mask, ez), _mm512_set1_pd(pz));
  rz = _mm512_fnmadd_pd(_mm512_set1_pd(Lz), _mm512_roundscale_pd(_mm512_mul_pd(rz, _mm512_set1_pd(inv_Lz)), kNearest),
                        rz);
  const __m512d d2 = _mm512_fmadd_pd(rz, rz, _mm512_fmadd_pd(ry, ry, _mm512_mul_pd(rx, rx)));
  const __m512d reach = _mm512_add_pd(_mm512_set1_pd(cutoff), _mm512_maskz_loadu_pd(mask, er));
  const __mmask8 hits = _mm512_mask_cmp_pd_mask(mask, d2, _mm512_mul_pd(reach, reach), _CMP_LT_OQ);
  _mm512_store_pd(o.rx, rx), _mm512_store_pd(o.ry, ry), _mm512_store_pd(o.rz, rz), _mm512_store_pd(o.d2, d2);
  return hits;
}

// Quadrature class of an element at distance d (element_integral_add without the singular case): 0 near-singular,
// 1 near-regular, 2 mid, 3 outer mid, 4 far, 5 symmetric (between outer mid and far).
inline int band_of(double d, double h_e, const QuadratureOrders& q) {
  const double r = d / h_e;
  if (r < q.near_ratio) return 0;
  if (r >= q.far_ratio) return 4;
  if (r >= q.symmetric_ratio) return 5;
  if (r >= q.outer_ratio) return 3;
  return r >= q.mid_ratio ? 2 : 1;
}

// band_of for a distance bound b against thresholds t (near, mid, outer, symmetric, far ratios) times scale: b and
// scale = h_e with the ratios, or b^2 and h_e^2 with the squared ratios.
inline int band_scaled(double b, double scale, const double* t) {
  if (b < t[0] * scale) return 0;
  if (b >= t[4] * scale) return 4;
  if (b >= t[3] * scale) return 5;
  if (b >= t[2] * scale) return 3;
  return b >= t[1] * scale ? 2 : 1;
}

// Distance from v to the interval [lo, hi) (0 inside).
inline double interval_distance(double v, double lo, double hi) {
  return v < lo ? lo - v : (v > hi ? v - hi : 0.0);
}

// sl_target for the host: the same cells in the same order, the same elements and rules, with (a) cells whose box
// lies beyond cutoff + max_radius of the target skipped (they hold no element within reach), (b) the element data
// from the pack, in target-centred coordinates (the target at the origin), and (c) the far class decided from the
// centroid distance where |c - x| - R_e >= far_ratio h_e already implies it (a lower bound of the exact distance),
// so point_triangle_distance runs only for elements that may be near, mid or near-singular.
// The double layers (kernel.b->layer) run the same traversal with each element's unit normal set before its rule;
// the unit densities' matrix (DoubleMatrix) integrates densities of ones and adds scale * its nine sums to m9.
void sl_target_host(const BatchedLocalKernel& kernel, const ElementCellList& cl, const PackedElement* pack,
                    double cutoff, const QuadratureOrders& q, double scale, double px, double py, double pz, int tnode,
                    double& ux, double& uy, double& uz, double* m9 = nullptr) {
  const LayerKind layer = kernel.b->layer;
  static const double kOnes[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1};
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double cx = cl.cx, cy = cl.cy, cz = cl.cz, Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const double *ex = cl.ex.data(), *ey = cl.ey.data(), *ez = cl.ez.data(), *er = cl.er.data();
  const int ucx = slit_cell_coord(px, cx), ucz = slit_cell_coord(pz, cz);
  const int icx = slit_wrap_cell(ucx, ncx), icz = slit_wrap_cell(ucz, ncz);
  int icy = slit_cell_coord(py, cy);
  icy = icy < 0 ? 0 : (icy >= ncy ? ncy - 1 : icy);
  const int dx_lo = ncx >= 3 ? -1 : 0, dx_hi = ncx >= 3 ? 1 : ncx - 1;
  const int dz_lo = ncz >= 3 ? -1 : 0, dz_hi = ncz >= 3 ? 1 : ncz - 1;
  const double inv_Lx = 1.0 / Lx, inv_Lz = 1.0 / Lz;
  const double reach_max = cutoff + cl.max_radius;
  const double cull2 = reach_max * reach_max * (1.0 + 1e-12);
  const double far_lb = q.far_ratio > q.near_ratio ? q.far_ratio : q.near_ratio;
  const bool monotone_bands =
      q.near_ratio <= q.mid_ratio && q.mid_ratio <= q.outer_ratio && q.outer_ratio <= q.symmetric_ratio &&
      q.symmetric_ratio <= q.far_ratio;
  const double xt[3] = {0.0, 0.0, 0.0};
  const double inf = std::numeric_limits<double>::infinity();
  const bool simd512 = kernel.b->simd == SimdPath::Avx512;
  const ParamRule& far_rule = q.far_dunavant ? dunavant_rule() : duffy_rule(gauss_clamp_order(q.regular_far));
  const ParamRule& mid_rule = duffy_rule(gauss_clamp_order(q.regular_mid));
  const ParamRule& outer_rule = duffy_rule(gauss_clamp_order(q.regular_outer));
  const ParamRule& sym_rule = symmetric16_rule();
  const ParamRule& near_rule = duffy_rule(gauss_clamp_order(q.regular_near));
  const ParamRule* const class_rule[6] = {nullptr, &near_rule, &mid_rule, &outer_rule, &far_rule, &sym_rule};
  const double lin_t[5] = {q.near_ratio, q.mid_ratio, q.outer_ratio, q.symmetric_ratio, q.far_ratio};
  double sq_t[5];
  for (int k = 0; k < 5; ++k) sq_t[k] = lin_t[k] > 0.0 ? lin_t[k] * lin_t[k] : 0.0;
  Scan8 hit;
  double acc[3] = {0.0, 0.0, 0.0};
  for (int dyc = -1; dyc <= 1; ++dyc) {
    const int cyy = icy + dyc;
    if (cyy < 0 || cyy >= ncy) continue;
    // Centroids are binned with the y cell clamped: the outer layers extend to +-infinity.
    const double by = interval_distance(py, cyy == 0 ? -inf : cyy * cy, cyy == ncy - 1 ? inf : (cyy + 1) * cy);
    for (int dxc = dx_lo; dxc <= dx_hi; ++dxc) {
      const int cxx = ncx >= 3 ? slit_wrap_cell(icx + dxc, ncx) : dxc;
      const double bx = ncx >= 3 ? interval_distance(px, (ucx + dxc) * cx, (ucx + dxc + 1) * cx) : 0.0;
      for (int dzc = dz_lo; dzc <= dz_hi; ++dzc) {
        const int czz = ncz >= 3 ? slit_wrap_cell(icz + dzc, ncz) : dzc;
        const double bz = ncz >= 3 ? interval_distance(pz, (ucz + dzc) * cz, (ucz + dzc + 1) * cz) : 0.0;
        if (bx * bx + by * by + bz * bz >= cull2) continue;
        const int cell = (cyy * ncx + cxx) * ncz + czz;
        for (int s0 = start[cell]; s0 < start[cell + 1]; s0 += 8) {
          const int m = start[cell + 1] - s0 < 8 ? start[cell + 1] - s0 : 8;
          unsigned hits = simd512 ? scan8_avx512(ex + s0, ey + s0, ez + s0, er + s0, m, px, py, pz, Lx, Lz, inv_Lx,
                                                 inv_Lz, cutoff, hit)
                                  : scan8_scalar(ex + s0, ey + s0, ez + s0, er + s0, m, px, py, pz, Lx, Lz, inv_Lx,
                                                 inv_Lz, cutoff, hit);
          for (; hits != 0; hits &= hits - 1) {
            const int l = __builtin_ctz(hits), s = s0 + l;
            const double rx = hit.rx[l], ry = hit.ry[l], rz = hit.rz[l], d2 = hit.d2[l];
            const PackedElement& P = pack[s];
            if (P.degenerate) continue;
            double v[9];
            int singular = -1;
            for (int c = 0; c < 3; ++c) {
              v[3 * c] = rx + P.dv[3 * c];
              v[3 * c + 1] = ry + P.dv[3 * c + 1];
              v[3 * c + 2] = rz + P.dv[3 * c + 2];
              if (P.g[c] == tnode) singular = c;
            }
            const double* f = layer == LayerKind::DoubleMatrix ? kOnes : P.f;
            if (singular >= 0) {
              v[3 * singular] = v[3 * singular + 1] = v[3 * singular + 2] = 0.0;  // the target, exactly
              if (layer != LayerKind::Single) triangle_unit_normal(v, kernel.b->normal);  // buffered points keep theirs
              element_integral_add(kernel, xt, v, f, singular, q, acc);
              continue;
            }
            // The exact distance d lies in [lb, ub] with ub = min(|c - x|, |v_i - x|) (points of the element) and
            // lb = min_i u.(v_i - x), u = (c - x)/|c - x| (|y - x| >= u.(y - x), linear in y, least at a vertex;
            // never below |c - x| - R_e): where no class threshold falls inside, the class is known without
            // point_triangle_distance.
            const double h_e = P.h_e;
            const double uc = std::sqrt(d2);
            double pmin = 0.0, v2min = d2;
            for (int c = 0; c < 3; ++c) {
              const double pc = rx * P.dv[3 * c] + ry * P.dv[3 * c + 1] + rz * P.dv[3 * c + 2];
              const double vc2 = v[3 * c] * v[3 * c] + v[3 * c + 1] * v[3 * c + 1] + v[3 * c + 2] * v[3 * c + 2];
              pmin = pc < pmin ? pc : pmin;
              v2min = vc2 < v2min ? vc2 : v2min;
            }
            // Classes of the bounds against thresholds scaled by h_e (no sqrt for ub, no division): lb linear, ub
            // squared (thresholds clamped at 0, so a negative ratio still admits every distance).
            const double lb = std::max(uc - er[s], uc > 0.0 ? uc + pmin / uc : 0.0);
            int cls;
            if (lb >= far_lb * h_e) {
              cls = 4;
            } else if (monotone_bands && band_scaled(lb, h_e, lin_t) == band_scaled(v2min, h_e * h_e, sq_t)) {
              cls = band_scaled(lb, h_e, lin_t);
            } else {
              cls = band_of(quad_detail::point_triangle_distance(xt, v), h_e, q);
            }
            if (layer != LayerKind::Single) triangle_unit_normal(v, kernel.b->normal);
            if (cls == 0) {
              if (q.near_method == NearSingularMethod::Subdivision)
                quad_detail::near_subdivision_add(kernel, xt, v, f, q, acc);
              else
                quad_detail::near_projection_add(kernel, xt, v, f, q, acc);
              continue;
            }
            // regular_add's choice, with the element's precomputed area.
            rule_eval(kernel, xt, v, f, *class_rule[cls], P.jac);
          }
        }
      }
    }
  }
  kernel_finish(kernel, acc);
  if (layer == LayerKind::DoubleMatrix) {
    for (int j = 0; j < 9; ++j) {
      m9[j] += scale * kernel.b->m[j];
      kernel.b->m[j] = 0.0;
    }
    return;
  }
  ux += scale * acc[0];
  uy += scale * acc[1];
  uz += scale * acc[2];
}
#endif

#ifdef CAPSFLOW_BATCHED_LOCAL_KERNEL
// The host traversal over nt targets, each target's batch per thread (flushed at fixed counts and at the target's
// end, so serial and threads give the same bits).
void batched_layer_sum(LayerKind layer, Backend backend, const ElementCellList& cl, const ElementPack& pack,
                       const LocalSplit& split, const QuadratureOrders& q, const TargetView& targets,
                       const Vec3Out& u, double* m) {
  const double alpha = split.alpha, cutoff = split.cutoff, scale = split.scale;
  const double *tx = targets.x, *ty = targets.y, *tz = targets.z;
  const int* target_node = targets.node;
  double *ux = u.x, *uy = u.y, *uz = u.z;
  const std::size_t nt = targets.n;
  const SimdPath simd = host_simd_path();
  const PackedElement* pk = pack.elements.data();
  const long long n = static_cast<long long>(nt);
#pragma omp parallel if (backend == Backend::Threads)
  {
    PointBatch batch;
    batch.alpha = alpha;
    batch.degree = q.kernel_degree;
    batch.simd = simd;
    batch.layer = layer;
    const BatchedLocalKernel kernel{&batch};
#pragma omp for schedule(dynamic, 16)
    for (long long p = 0; p < n; ++p) {
      const int tn = target_node ? target_node[p] : -1;
      if (layer == LayerKind::DoubleMatrix) {
        double unused[3] = {0.0, 0.0, 0.0};
        sl_target_host(kernel, cl, pk, cutoff, q, scale, tx[p], ty[p], tz[p], tn, unused[0], unused[1], unused[2],
                       m + 9 * p);
      } else {
        sl_target_host(kernel, cl, pk, cutoff, q, scale, tx[p], ty[p], tz[p], tn, ux[p], uy[p], uz[p]);
      }
    }
  }
}
#endif

}  // namespace

void local_double_layer_batched(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                                const LocalSplit& split, const QuadratureOrders& q, const TargetView& targets,
                                const Vec3Out& u, double* m) {
  require_built(backend, "local_double_layer_batched");
  if (backend == Backend::Device || !element_pack_used())
    throw std::invalid_argument("local_double_layer_batched: host backends of x86-64 builds without offload only");
  if (pack.elements.size() != cl.size() || (m == nullptr && !pack.with_density))
    throw std::invalid_argument("local_double_layer_batched: the element pack was not made from this cell list, or "
                                "has no densities");
#ifdef CAPSFLOW_BATCHED_LOCAL_KERNEL
  batched_layer_sum(m != nullptr ? LayerKind::DoubleMatrix : LayerKind::Double, backend, cl, pack, split, q, targets, u,
                    m);
#else
  (void)split, (void)q, (void)targets, (void)u;
#endif
}

bool element_pack_used() {
#ifdef CAPSFLOW_BATCHED_LOCAL_KERNEL
  return true;
#else
  return false;
#endif
}

void pack_element_geometry(Backend backend, const ElementCellList& cl, int nv, int ntri, const int* tri,
                           const double* x, const double* y, const double* z, ElementPack& pack) {
  pack.with_density = false;
  if (!element_pack_used()) {
    pack.elements.clear();
    return;
  }
  const long long ne = static_cast<long long>(cl.size());
  pack.elements.resize(cl.size());
  PackedElement* pk = pack.elements.data();
  const double Lx = cl.Lx, Lz = cl.Lz, inv_Lx = 1.0 / Lx, inv_Lz = 1.0 / Lz;
#pragma omp parallel for schedule(static) if (backend == Backend::Threads)
  for (long long s = 0; s < ne; ++s) {
    PackedElement& P = pk[s];
    const int e = cl.elem[static_cast<std::size_t>(s)];
    const int k = e / ntri, t = e - k * ntri;
    const double c[3] = {cl.ex[static_cast<std::size_t>(s)], cl.ey[static_cast<std::size_t>(s)],
                         cl.ez[static_cast<std::size_t>(s)]};
    for (int i = 0; i < 3; ++i) {
      const int gi = k * nv + tri[3 * t + i];
      P.g[i] = gi;
      P.dv[3 * i] = min_image_fast(x[gi] - c[0], Lx, inv_Lx);
      P.dv[3 * i + 1] = y[gi] - c[1];
      P.dv[3 * i + 2] = min_image_fast(z[gi] - c[2], Lz, inv_Lz);
    }
    P.h_e = quad_detail::longest_edge(P.dv);
    P.jac = quad_detail::twice_area(P.dv);
    P.degenerate = P.jac > 1e-14 * P.h_e * P.h_e ? 0 : 1;
  }
}

void pack_element_density(Backend backend, const ElementCellList& cl, const double* fx, const double* fy,
                          const double* fz, ElementPack& pack) {
  if (!element_pack_used()) return;
  if (pack.elements.size() != cl.size())
    throw std::invalid_argument("pack_element_density: the pack was not made from this cell list's geometry");
  const long long ne = static_cast<long long>(pack.elements.size());
  PackedElement* pk = pack.elements.data();
#pragma omp parallel for schedule(static) if (backend == Backend::Threads)
  for (long long s = 0; s < ne; ++s) {
    PackedElement& P = pk[s];
    for (int i = 0; i < 3; ++i) {
      const int gi = P.g[i];
      P.f[3 * i] = fx[gi];
      P.f[3 * i + 1] = fy[gi];
      P.f[3 * i + 2] = fz[gi];
    }
  }
  pack.with_density = true;
}

void build_element_cell_list(ElementCellList& cl, double Lx, double H, double Lz, double cutoff, int ncap, int nv,
                             int ntri, const int* tri, const double* x, const double* y, const double* z) {
  if (!(Lx > 0.0 && Lz > 0.0 && H > 0.0 && cutoff > 0.0) || ncap < 0 || nv < 0 || ntri < 0)
    throw std::invalid_argument("build_element_cell_list: invalid box, cutoff or sizes");
  const std::size_t ne = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(ntri);
  std::vector<double> cxs(ne), cys(ne), czs(ne), rad(ne);
  double max_r = 0.0;
  for (std::size_t e = 0; e < ne; ++e) {
    element_centroid_radius(static_cast<long long>(e), nv, ntri, tri, x, y, z, Lx, Lz, cxs[e], cys[e], czs[e], rad[e]);
    max_r = std::max(max_r, rad[e]);
  }
  const double reach = cutoff + max_r;
  if (!(Lx > 2.0 * reach && Lz > 2.0 * reach))
    throw std::invalid_argument("build_element_cell_list: Lx and Lz must exceed 2 (cutoff + largest element radius)");
  cl.max_radius = max_r;
  size_cell_grid(cl, Lx, H, Lz, reach);
  const int ncell = cl.ncx * cl.ncy * cl.ncz;
  std::vector<int> cell(ne);
  cl.start.assign(static_cast<std::size_t>(ncell) + 1, 0);
  for (std::size_t e = 0; e < ne; ++e) {
    cell[e] = slit_cell_of(cxs[e], cys[e], czs[e], cl.cx, cl.cy, cl.cz, cl.ncx, cl.ncy, cl.ncz);
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

namespace {
#ifdef CAPSFLOW_HAVE_OFFLOAD
// The device regions of local_single_layer_velocity, for one near-singular rule.
template <NearRules kNear>
void sl_device(const ElementCellList& cl, const LocalSplit& split, const SurfaceView& surface, const Vec3In& f,
               const QuadratureOrders& q, const TargetView& targets, const Vec3Out& u) {
  const double alpha = split.alpha, cutoff = split.cutoff, scale = split.scale;
  const std::size_t nt = targets.n;
  const long long n = static_cast<long long>(nt);
  const double *tx = targets.x, *ty = targets.y, *tz = targets.z;
  const int* target_node = targets.node;
  double *ux = u.x, *uy = u.y, *uz = u.z;
  // The views' arrays one by one (a region translates mapped pointer variables); the views are rebuilt inside.
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double cx = cl.cx, cy = cl.cy, cz = cl.cz, Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const int* elem = cl.elem.data();
  const double *ex = cl.ex.data(), *ey = cl.ey.data(), *ez = cl.ez.data(), *er = cl.er.data();
  const int ncap = surface.ncap, nv = surface.nv, ntri = surface.ntri;
  const int* tri = surface.tri;
  const double *x = surface.x, *y = surface.y, *z = surface.z, *fx = f.x, *fy = f.y, *fz = f.z;
  const std::size_t ne = cl.size();
  const std::size_t nc = cl.start.size();
  const std::size_t nn = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(nv);
  const std::size_t n3 = 3 * static_cast<std::size_t>(ntri);
  // The list's arrays are present when DeviceElementCells built it (resident: nothing copied), copied per call
  // when it was built on the host. Targets that are not nodes (targets.node == nullptr) get their own region, so
  // no placeholder array is built and mapped.
  if (target_node != nullptr) {
    const int* tn = target_node;
#pragma omp target teams distribute parallel for firstprivate(q)                                                 \
  map(to : start[0:nc], elem[0:ne], ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne], tri[0:n3], x[0:nn], y[0:nn], z[0:nn], \
          fx[0:nn], fy[0:nn], fz[0:nn], tx[0:nt], ty[0:nt], tz[0:nt], tn[0:nt])                                \
  map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p) {
      const ElementCellsView cells{ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er};
      sl_target<kNear>(LocalKernel{alpha}, cells, cutoff, SurfaceView{ncap, nv, ntri, tri, x, y, z},
                       Vec3In{fx, fy, fz}, q, scale, tx[p], ty[p], tz[p], tn[p], ux[p], uy[p], uz[p]);
    }
  } else {
#pragma omp target teams distribute parallel for firstprivate(q)                                                 \
  map(to : start[0:nc], elem[0:ne], ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne], tri[0:n3], x[0:nn], y[0:nn], z[0:nn], \
          fx[0:nn], fy[0:nn], fz[0:nn], tx[0:nt], ty[0:nt], tz[0:nt])                                          \
  map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p) {
      const ElementCellsView cells{ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er};
      sl_target<kNear>(LocalKernel{alpha}, cells, cutoff, SurfaceView{ncap, nv, ntri, tri, x, y, z},
                       Vec3In{fx, fy, fz}, q, scale, tx[p], ty[p], tz[p], -1, ux[p], uy[p], uz[p]);
    }
  }
}
#endif

}  // namespace

void local_single_layer_velocity(Backend backend, const ElementCellList& cl, const LocalSplit& split,
                                 const SurfaceView& surface, const Vec3In& f, const QuadratureOrders& q,
                                 const TargetView& targets, const Vec3Out& u) {
  require_built(backend, "local_single_layer_velocity");
  ElementPack pack;
  if (backend != Backend::Device) {
    pack_element_geometry(backend, cl, surface.nv, surface.ntri, surface.tri, surface.x, surface.y, surface.z, pack);
    pack_element_density(backend, cl, f.x, f.y, f.z, pack);
  }
  local_single_layer_velocity(backend, cl, pack, split, surface, f, q, targets, u);
}

void local_single_layer_velocity(Backend backend, const ElementCellList& cl, const ElementPack& pack,
                                 const LocalSplit& split, const SurfaceView& surface, const Vec3In& f,
                                 const QuadratureOrders& q_in, const TargetView& targets, const Vec3Out& u) {
  require_built(backend, "local_single_layer_velocity");
  (void)pack;  // read by the host traversal only
  if (cl.size() != static_cast<std::size_t>(surface.ncap) * static_cast<std::size_t>(surface.ntri))
    throw std::invalid_argument("local_single_layer_velocity: cell list built for a different element count");
  const QuadratureOrders q = q_in;
  // The portable loop's scalars and arrays (the host traversal takes the views; sl_device its own).
  [[maybe_unused]] const double alpha = split.alpha, cutoff = split.cutoff, scale = split.scale;
  [[maybe_unused]] const std::size_t nt = targets.n;
  [[maybe_unused]] const long long n = static_cast<long long>(nt);
  [[maybe_unused]] const double *tx = targets.x, *ty = targets.y, *tz = targets.z;
  [[maybe_unused]] const int* target_node = targets.node;
  [[maybe_unused]] double *ux = u.x, *uy = u.y, *uz = u.z;
  if (backend == Backend::Device) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
    // One region per near-singular rule (NearRules): each carries only the stack of the rule it runs.
    if (q.near_method == NearSingularMethod::Subdivision)
      sl_device<NearRules::Subdivision>(cl, split, surface, f, q, targets, u);
    else
      sl_device<NearRules::Projection>(cl, split, surface, f, q, targets, u);
#endif
    return;
  }
#ifdef CAPSFLOW_BATCHED_LOCAL_KERNEL
  if (pack.elements.size() != cl.size() || !pack.with_density)
    throw std::invalid_argument("local_single_layer_velocity: the element pack was not made from this cell list, or "
                                "has no densities");
  (void)f;  // read through the pack
  batched_layer_sum(LayerKind::Single, backend, cl, pack, split, q, targets, u, nullptr);
#else
  const ElementCellsView cells = element_cells_view(cl);
#pragma omp parallel for schedule(dynamic, 16) if (backend == Backend::Threads)
  for (long long p = 0; p < n; ++p)
    sl_target(LocalKernel{alpha}, cells, cutoff, surface, f, q, scale, tx[p], ty[p], tz[p],
              target_node ? target_node[p] : -1, ux[p], uy[p], uz[p]);
#endif
}

}  // namespace capsflow
