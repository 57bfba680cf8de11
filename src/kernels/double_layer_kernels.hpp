#pragma once
// The double layer and its GGEM splitting (docs/method.md "Double layer"; issue 22).
//
// Normalisation (Pozrikidis 1992, normal n pointing out of the capsule, r = x - y):
//     K[q](x) = (1/8 pi) \int q_i(y) T_ijk(y, x) n_k(y) dS_y = (1/8 pi) \int W(r; q, n) dS_y,
//     W(r; q, n) = 6 (q.r)(n.r) r / r^5.
// A constant density gives K = -q inside, -q/2 on (principal value) and 0 outside a closed surface.
//
// GGEM split. A density element Q = q n^T dS is a force dipole D = Q + Q^T plus a mass source m = tr Q = q.n dS:
//     W Q = -D_ik d_k S_ji(r) + 2 m r_j / r^3,
// S the Stokeslet, 2 r/r^3 = 8 pi grad(-1/(4 pi r)) the field of a unit source. Splitting the delta of the dipole and
// of the source with the modified Gaussian g of the single layer (ggem_kernels.hpp) gives, with x = alpha r,
// c1 = erfc(x)/r, c2 = (2 alpha/sqrt(pi)) exp(-x^2):
//   local (screened, decays as exp(-x^2)):
//     W_l = -2 alpha^2 c2 [q (n.r) + n (q.r)]
//           + [(6 (c1 + c2)/r^4 + 4 alpha^2 c2/r^2) (q.r)(n.r) - 2 alpha^2 c2 (q.n)] r,
//   global (smooth): the slit Stokes flow of the body force b = -div(D g) and the potential flow grad(phi) of the
//     source m g (lap phi = m g), with
//     b(x) = h(|x - y|) D (x - y),   h(r) = (2 alpha^5 / pi^1.5) exp(-x^2) (7/2 - x^2).
//   The free-space global kernel W_g = W - W_l (tests only) is finite at r = 0.
// The screened source's enclosed strength M(x) = erf(x) - (2x/sqrt(pi))(1 - x^2) exp(-x^2) cancels against the
// dipole's trace term, which is why W_l carries no separate source term (derivation in docs/method.md).
// Velocities are K = W / (8 pi); the functions here add W (no 1/(8 pi)). Plain scalar code: these run inside OpenMP
// target regions.
#include <cmath>

#include "kernels/device_macros.hpp"
#include "kernels/element_quadrature.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/ggem_local_table.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN

// Adds the free-space stresslet W(r; q, n) = 6 (q.r)(n.r) r / r^5.
inline void stresslet_add(double rx, double ry, double rz, double qx, double qy, double qz, double nx, double ny,
                          double nz, double& ux, double& uy, double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double inv_r2 = 1.0 / r2;
  const double s = 6.0 * (qx * rx + qy * ry + qz * rz) * (nx * rx + ny * ry + nz * rz) * inv_r2 * inv_r2 *
                   std::sqrt(inv_r2);
  ux += s * rx;
  uy += s * ry;
  uz += s * rz;
}

// W_l's two radial coefficients in closed form (see ggem_dl_local_coefficients_tabulated for their names):
// A1 = 6 (c1 + c2)/r^4 + 4 alpha^2 c2/r^2, T = 2 alpha^2 c2. Requires r > 0.
inline void ggem_dl_local_coefficients(double alpha, double r2, double& A1, double& T) {
  const double r = std::sqrt(r2);
  const double a2 = alpha * alpha;
  const double inv_r = 1.0 / r, inv_r2 = inv_r * inv_r;
  const double c1 = std::erfc(alpha * r) * inv_r;
  const double c2 = 2.0 * alpha / kSqrtPi * std::exp(-a2 * r2);
  A1 = (6.0 * (c1 + c2) * inv_r2 + 4.0 * a2 * c2) * inv_r2;
  T = 2.0 * a2 * c2;
}

// Adds the screened (local) stresslet W_l. At coincidence (alpha r < kCoincidentAlphaR) it adds the limit r -> 0,
// which is 0: every term carries r.
inline void ggem_dl_local_add(double alpha, double rx, double ry, double rz, double qx, double qy, double qz,
                              double nx, double ny, double nz, double& ux, double& uy, double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  if (alpha * std::sqrt(r2) < kCoincidentAlphaR) return;
  double A1, T;
  ggem_dl_local_coefficients(alpha, r2, A1, T);
  const double qr = qx * rx + qy * ry + qz * rz, nr = nx * rx + ny * ry + nz * rz;
  const double qn = qx * nx + qy * ny + qz * nz;
  const double s = A1 * qr * nr - T * qn;
  ux += s * rx - T * (qx * nr + nx * qr);
  uy += s * ry - T * (qy * nr + ny * qr);
  uz += s * rz - T * (qz * nr + nz * qr);
}

// W_l without erfc and exp: the screened coefficients from the single layer's table (ggem_local_table.hpp), which
// holds, in t = (alpha r)^2, P and Q for t < 4 and -A, -B beyond (ggem_local_add_tabulated). With x = alpha r:
//     t < 4:   c1 + c2 = 1/r - alpha t Q,   c2 = alpha (P - t Q) / 2     (P - t Q = (4/sqrt(pi)) e^-t: no cancellation)
//     t >= 4:  c1 + c2 = alpha t B,         c2 = alpha (t B - A) / 2
// Beyond the table (alpha r >= 6) and at coincidence it defers to ggem_local_add. Agrees with it to ~1e-13
// relative to the stresslet (tests/test_double_layer.cpp); the element integrals use it (the local part's cost).
// The two radial coefficients of W_l = [A1 (q.r)(n.r) - T (q.n)] r - T [q (n.r) + n (q.r)] from the table:
// A1 = 6 (c1 + c2)/r^4 + 4 alpha^2 c2/r^2, T = 2 alpha^2 c2. Requires kCoincidentAlphaR^2 <= t < kGgemTabTMax.
inline void ggem_dl_local_coefficients_tabulated(double alpha, double r2, double& A1, double& T) {
  const double a2 = alpha * alpha;
  const double t = a2 * r2;
  int i = static_cast<int>(t * kGgemTabInvWidth);
  i = i < kGgemTabSegments ? i : kGgemTabSegments - 1;
  const double u = 2.0 * (t * kGgemTabInvWidth - i) - 1.0;
  const double* cp = kGgemTabA + i * kGgemTabStride;
  const double* cq = kGgemTabB + i * kGgemTabStride;
  const double u2 = u * u, u4 = u2 * u2, u8 = u4 * u4;
  const double p = (cp[0] + cp[1] * u) + u2 * (cp[2] + cp[3] * u) +
                   u4 * ((cp[4] + cp[5] * u) + u2 * (cp[6] + cp[7] * u)) + u8 * cp[8];
  const double q = (cq[0] + cq[1] * u) + u2 * (cq[2] + cq[3] * u) +
                   u4 * ((cq[4] + cq[5] * u) + u2 * (cq[6] + cq[7] * u)) + u8 * cq[8];
  const double inv_r2 = 1.0 / r2;
  // 1/r only below t = 4 (0 * x + y == y exactly beyond): no branch on the interval kind.
  const double sel = static_cast<double>(i < kGgemTabDirectFrom);
  const double cc = sel * std::sqrt(inv_r2) - alpha * t * q;
  const double c2 = 0.5 * alpha * (p - t * q);
  A1 = (6.0 * cc * inv_r2 + 4.0 * a2 * c2) * inv_r2;
  T = 2.0 * a2 * c2;
}

inline void ggem_dl_local_add_tabulated(double alpha, double rx, double ry, double rz, double qx, double qy,
                                        double qz, double nx, double ny, double nz, double& ux, double& uy,
                                        double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double t = alpha * alpha * r2;
  if (!(t < kGgemTabTMax) || t < kCoincidentAlphaR * kCoincidentAlphaR) {
    ggem_dl_local_add(alpha, rx, ry, rz, qx, qy, qz, nx, ny, nz, ux, uy, uz);
    return;
  }
  double A1, T;
  ggem_dl_local_coefficients_tabulated(alpha, r2, A1, T);
  const double qr = qx * rx + qy * ry + qz * rz, nr = nx * rx + ny * ry + nz * rz;
  const double qn = qx * nx + qy * ny + qz * nz;
  const double s = A1 * qr * nr - T * qn;
  ux += s * rx - T * (qx * nr + nx * qr);
  uy += s * ry - T * (qy * nr + ny * qr);
  uz += s * rz - T * (qz * nr + nz * qr);
}

// W_l for the three unit densities at once: m[3 c + d] += (W_l(r; w e_d, n))_c, w the weight (the element rules pass
// g = w (1, 1, 1) for a constant density of ones). The singularity subtraction's C_i in one pass.
inline void ggem_dl_local_matrix_add(double alpha, double rx, double ry, double rz, double w, double nx, double ny,
                                     double nz, double* m) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double t = alpha * alpha * r2;
  double A1, T;
  if (!(t < kGgemTabTMax) || t < kCoincidentAlphaR * kCoincidentAlphaR) {
    if (alpha * std::sqrt(r2) < kCoincidentAlphaR) return;  // W_l vanishes at coincidence
    ggem_dl_local_coefficients(alpha, r2, A1, T);
  } else {
    ggem_dl_local_coefficients_tabulated(alpha, r2, A1, T);
  }
  const double r[3] = {rx, ry, rz}, n[3] = {nx, ny, nz};
  const double nr = nx * rx + ny * ry + nz * rz;
  for (int d = 0; d < 3; ++d) {
    const double s = w * (A1 * r[d] * nr - T * n[d]);
    for (int c = 0; c < 3; ++c) m[3 * c + d] += s * r[c] - w * T * ((c == d ? nr : 0.0) + n[c] * r[d]);
  }
}

// Adds the free-space global kernel W_g = W - W_l (tests and diagnostics, never in the slit solve):
//     W_g = 2 alpha^2 c2 [q (n.r) + n (q.r)] + [B(r) (q.r)(n.r) + 2 alpha^2 c2 (q.n)] r,
//     B = 6 erf(x)/r^5 - 6 c2/r^4 - 4 alpha^2 c2/r^2  ->  (2 alpha^5/sqrt(pi)) (8/5 - (8/7) x^2) for small x.
inline void ggem_dl_global_free_add(double alpha, double rx, double ry, double rz, double qx, double qy, double qz,
                                    double nx, double ny, double nz, double& ux, double& uy, double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double a2 = alpha * alpha;
  const double x2 = a2 * r2;
  const double c2 = 2.0 * alpha / kSqrtPi * std::exp(-x2);
  double B;
  if (x2 < 1e-4) {
    B = 2.0 * a2 * a2 * alpha / kSqrtPi * (1.6 - 8.0 / 7.0 * x2);  // series: the three terms cancel to O(1)
  } else {
    const double r = std::sqrt(r2);
    const double inv_r2 = 1.0 / r2;
    B = (6.0 * std::erf(alpha * r) / r - 6.0 * c2) * inv_r2 * inv_r2 - 4.0 * a2 * c2 * inv_r2;
  }
  const double qr = qx * rx + qy * ry + qz * rz, nr = nx * rx + ny * ry + nz * rz;
  const double qn = qx * nx + qy * ny + qz * nz;
  const double t = 2.0 * a2 * c2;
  const double s = B * qr * nr + t * qn;
  ux += s * rx + t * (qx * nr + nx * qr);
  uy += s * ry + t * (qy * nr + ny * qr);
  uz += s * rz + t * (qz * nr + nz * qr);
}

// The global forcing of one density element: body force h(r) D r at offset r = x - y from the source
// (D = q n^T + n q^T, times dS), and source m g(r) (m = q.n dS, g = ggem_screen). h without the dipole:
inline double ggem_dl_dipole_profile(double alpha, double r2) {
  const double a2 = alpha * alpha;
  return 2.0 * a2 * a2 * alpha / (kPi * kSqrtPi) * std::exp(-a2 * r2) * (3.5 - a2 * r2);
}

// Unit outward normal of a flat triangle (vertices v[9], counter-clockwise seen from outside).
inline void triangle_unit_normal(const double* v, double* n) {
  const double a[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]};
  const double b[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
  const double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  const double len = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  const double inv = len > 0.0 ? 1.0 / len : 0.0;
  n[0] = c[0] * inv;
  n[1] = c[1] * inv;
  n[2] = c[2] * inv;
}

// Kernels for the element integrals of element_quadrature.hpp: add(r, q, u) with the element's normal bound in.
struct DoubleLayerLocalKernel {  // W_l (GGEM local part, tabulated)
  double alpha;
  double n[3];
  void add(double rx, double ry, double rz, double qx, double qy, double qz, double& ux, double& uy,
           double& uz) const {
    ggem_dl_local_add_tabulated(alpha, rx, ry, rz, qx, qy, qz, n[0], n[1], n[2], ux, uy, uz);
  }
};
struct DoubleLayerMatrixKernel {  // W_l for the unit densities (element rules given nodal densities of ones)
  double alpha;
  double n[3];
  double* m;  // 9 accumulators, m[3 c + d]
  void add(double rx, double ry, double rz, double gx, double, double, double&, double&, double&) const {
    ggem_dl_local_matrix_add(alpha, rx, ry, rz, gx, n[0], n[1], n[2], m);
  }
};
struct StressletKernel {  // W (free space: tests, diagnostics)
  double n[3];
  void add(double rx, double ry, double rz, double qx, double qy, double qz, double& ux, double& uy,
           double& uz) const {
    // On the element's own plane (n.r = 0 to rounding) W vanishes; skipping r = 0 keeps the singular rule finite.
    const double r2 = rx * rx + ry * ry + rz * rz;
    if (r2 == 0.0) return;
    stresslet_add(rx, ry, rz, qx, qy, qz, n[0], n[1], n[2], ux, uy, uz);
  }
};

// Element integrals of the double layer over a flat linear triangle (vertices v unwrapped about xt, density q linear
// from its nodal values), with the rules of element_quadrature.hpp; the element's own normal is bound into the kernel.
// When xt is vertex k of the element, n.r = 0 on the whole element: W vanishes and W_l keeps only its regular terms.
// Add W_l (local) or W (free space), without 1/(8 pi), to u.
// kNear: the near-singular rules compiled in (element_quadrature.hpp; the device regions make one per rule).
template <NearRules kNear = NearRules::Any>
inline void element_double_layer_add(double alpha, const double* xt, const double* v, const double* q,
                                     int singular_vertex, const QuadratureOrders& orders, double* u) {
  DoubleLayerLocalKernel k{alpha, {0.0, 0.0, 0.0}};
  triangle_unit_normal(v, k.n);
  element_integral_add<kNear>(k, xt, v, q, singular_vertex, orders, u);
}
// The integrals of W_l over the element for the three unit densities, added to m[3 c + d] (ones: nodal densities
// of 1 in every component, so the rules' weighted density is w (1, 1, 1)).
template <NearRules kNear = NearRules::Any>
inline void element_double_layer_matrix_add(double alpha, const double* xt, const double* v, int singular_vertex,
                                            const QuadratureOrders& orders, double* m) {
  DoubleLayerMatrixKernel k{alpha, {0.0, 0.0, 0.0}, m};
  triangle_unit_normal(v, k.n);
  const double ones[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1};
  double unused[3] = {0.0, 0.0, 0.0};
  element_integral_add<kNear>(k, xt, v, ones, singular_vertex, orders, unused);
}
inline void element_stresslet_add(const double* xt, const double* v, const double* q, int singular_vertex,
                                  const QuadratureOrders& orders, double* u) {
  StressletKernel k{{0.0, 0.0, 0.0}};
  triangle_unit_normal(v, k.n);
  element_integral_add(k, xt, v, q, singular_vertex, orders, u);
}

CAPSFLOW_DEVICE_END

}  // namespace capsflow
