#pragma once
// GGEM splitting of the Stokeslet (docs/method.md §1.1; docs/method.md "GGEM kernels").
//
// The point force f delta(x - x_m) is split into f[delta - g] (local, summed directly) and f g (global,
// solved on the grid), with the modified Gaussian of zero second moment
//     g(r) = (alpha^3 / pi^1.5) exp(-alpha^2 r^2) (5/2 - alpha^2 r^2).
// With c1 = erfc(alpha r)/r and c2 = (2 alpha/sqrt(pi)) exp(-alpha^2 r^2):
//     G_l = c1 (I + rr) - c2 (I - rr),    G_g = (erf(alpha r)/r)(I + rr) + c2 (I - rr),    G_l + G_g = Stokeslet.
// Velocities are G.f / (8 pi mu); the functions here return G.f without that factor.
// Plain scalar code: these run inside OpenMP target regions.
#include <cmath>

#include "kernels/constants.hpp"
#include "kernels/device_macros.hpp"
#include "kernels/ggem_local_table.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN

// Distances below this (relative to 1/alpha) count as coincident: the target sits on the source.
constexpr double kCoincidentAlphaR = 1e-9;

// Screening function g(r) (the global part's force cloud), from r^2.
inline double ggem_screen(double alpha, double r2) {
  const double a2 = alpha * alpha;
  return alpha * a2 / (kPi * kSqrtPi) * std::exp(-a2 * r2) * (2.5 - a2 * r2);
}

// Adds G_l(r).f to (ux, uy, uz), r = target - source. For a coincident target it adds the regular part
// -G_g(0).f = -(4 alpha / sqrt(pi)) f: the local kernel with the source's own free-space Stokeslet removed.
inline void ggem_local_add(double alpha, double rx, double ry, double rz, double fx, double fy, double fz,
                           double& ux, double& uy, double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double r = std::sqrt(r2);
  if (alpha * r < kCoincidentAlphaR) {
    const double s = -4.0 * alpha / kSqrtPi;
    ux += s * fx;
    uy += s * fy;
    uz += s * fz;
    return;
  }
  const double inv_r = 1.0 / r;
  const double c1 = std::erfc(alpha * r) * inv_r;
  const double c2 = 2.0 * alpha / kSqrtPi * std::exp(-alpha * alpha * r2);
  const double rdotf = (rx * fx + ry * fy + rz * fz) * inv_r * inv_r;  // (r.f)/r^2
  const double a = c1 - c2, b = (c1 + c2) * rdotf;
  ux += a * fx + b * rx;
  uy += a * fy + b * ry;
  uz += a * fz + b * rz;
}

// Same as ggem_local_add without erfc and exp: generated piecewise polynomials in t = (alpha r)^2
// (kernels/ggem_local_table.hpp, tools/gen_ggem_local_table.py; 144 intervals of width 0.25 on [0, 36], degree 8).
// With x = alpha r, G_l.f = a f + b (r.f) r, and
//     t < 4:   a = 1/r - alpha P(t),  b = 1/r^3 - alpha^3 Q(t)   (Stokeslet minus the smooth global part,
//              P = erf(x)/x + (2/sqrt(pi)) e^-t, Q = (erf(x)/x - (2/sqrt(pi)) e^-t)/t: no singularity in the table)
//     t >= 4:  a = alpha A(t),        b = alpha^3 B(t)           (A = erfc(x)/x - (2/sqrt(pi)) e^-t,
//              B = (erfc(x)/x + (2/sqrt(pi)) e^-t)/t: the screened coefficients directly, relative accuracy kept)
// Table error: 2e-16 relative to the Stokeslet coefficients for t < 4 (cancellation there at most ~30x, i.e.
// ~5e-15 relative to the screened value), 1e-14 relative for t >= 4. Beyond the table (alpha r >= 6) and at
// coincidence it defers to ggem_local_add. Used by the element
// integrals (LocalKernel); agrees with ggem_local_add to ~1e-14 relative.
inline void ggem_local_add_tabulated(double alpha, double rx, double ry, double rz, double fx, double fy, double fz,
                                     double& ux, double& uy, double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double a2 = alpha * alpha;
  const double t = a2 * r2;
  if (!(t < kGgemTabTMax) || t < kCoincidentAlphaR * kCoincidentAlphaR) {
    ggem_local_add(alpha, rx, ry, rz, fx, fy, fz, ux, uy, uz);
    return;
  }
  int i = static_cast<int>(t * kGgemTabInvWidth);
  i = i < kGgemTabSegments ? i : kGgemTabSegments - 1;
  const double u = 2.0 * (t * kGgemTabInvWidth - i) - 1.0;
  const double* cp = kGgemTabA + i * kGgemTabStride;
  const double* cq = kGgemTabB + i * kGgemTabStride;
  // Estrin's scheme (degree 8): short dependency chains, the two polynomials interleaved.
  static_assert(kGgemTabStride == 9, "ggem_local_add_tabulated evaluates degree-8 polynomials");
  const double u2 = u * u, u4 = u2 * u2, u8 = u4 * u4;
  const double p = (cp[0] + cp[1] * u) + u2 * (cp[2] + cp[3] * u) +
                   u4 * ((cp[4] + cp[5] * u) + u2 * (cp[6] + cp[7] * u)) + u8 * cp[8];
  const double q = (cq[0] + cq[1] * u) + u2 * (cq[2] + cq[3] * u) +
                   u4 * ((cq[4] + cq[5] * u) + u2 * (cq[6] + cq[7] * u)) + u8 * cq[8];
  // Intervals t >= 4 hold -A, -B: a = s/r - alpha p, b = s/r^3 - alpha^3 q with s = 1 below t = 4 and 0 beyond
  // (0 * (1/r) + x == x exactly): no branch on the interval kind.
  const double sel = static_cast<double>(i < kGgemTabDirectFrom);
  const double inv_r = 1.0 / std::sqrt(r2);
  const double s1 = sel * inv_r;
  const double a = s1 - alpha * p;
  const double b = (s1 * inv_r * inv_r - alpha * a2 * q) * (rx * fx + ry * fy + rz * fz);
  ux += a * fx + b * rx;
  uy += a * fy + b * ry;
  uz += a * fz + b * rz;
}

// Adds the free-space global kernel G_g(r).f (used by tests and diagnostics, never in the slit solve).
inline void ggem_global_free_add(double alpha, double rx, double ry, double rz, double fx, double fy, double fz,
                                 double& ux, double& uy, double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double r = std::sqrt(r2);
  if (alpha * r < 1e-4) {
    // Taylor series: G_g ~ (4a/sqrt(pi) - 8a^3 r^2/(3 sqrt(pi))) I + (4 a^3/(3 sqrt(pi))) r r.
    const double a3 = alpha * alpha * alpha;
    const double a = 4.0 * alpha / kSqrtPi - 8.0 * a3 * r2 / (3.0 * kSqrtPi);
    const double b = 4.0 * a3 / (3.0 * kSqrtPi) * (rx * fx + ry * fy + rz * fz);
    ux += a * fx + b * rx;
    uy += a * fy + b * ry;
    uz += a * fz + b * rz;
    return;
  }
  const double inv_r = 1.0 / r;
  const double c1 = std::erf(alpha * r) * inv_r;
  const double c2 = 2.0 * alpha / kSqrtPi * std::exp(-alpha * alpha * r2);
  const double rdotf = (rx * fx + ry * fy + rz * fz) * inv_r * inv_r;
  const double a = c1 + c2, b = (c1 - c2) * rdotf;
  ux += a * fx + b * rx;
  uy += a * fy + b * ry;
  uz += a * fz + b * rz;
}

// Adds the free-space Stokeslet (I + rr/r^2)/r . f.
inline void stokeslet_add(double rx, double ry, double rz, double fx, double fy, double fz, double& ux,
                          double& uy, double& uz) {
  const double r2 = rx * rx + ry * ry + rz * rz;
  const double inv_r = 1.0 / std::sqrt(r2);
  const double b = (rx * fx + ry * fy + rz * fz) * inv_r * inv_r * inv_r;
  ux += inv_r * fx + b * rx;
  uy += inv_r * fy + b * ry;
  uz += inv_r * fz + b * rz;
}

CAPSFLOW_DEVICE_END

}  // namespace capsflow
