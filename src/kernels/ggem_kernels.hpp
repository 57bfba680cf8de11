#pragma once
// GGEM splitting of the Stokeslet (method-spec section 4; docs/method.md "GGEM kernels").
//
// The point force f delta(x - x_m) is split into f[delta - g] (local, summed directly) and f g (global,
// solved on the grid), with the modified Gaussian of zero second moment
//     g(r) = (alpha^3 / pi^1.5) exp(-alpha^2 r^2) (5/2 - alpha^2 r^2).
// With c1 = erfc(alpha r)/r and c2 = (2 alpha/sqrt(pi)) exp(-alpha^2 r^2):
//     G_l = c1 (I + rr) - c2 (I - rr),    G_g = (erf(alpha r)/r)(I + rr) + c2 (I - rr),    G_l + G_g = Stokeslet.
// Velocities are G.f / (8 pi mu); the functions here return G.f without that factor.
// Plain scalar code: these run inside OpenMP target regions.
#include <cmath>

#include "kernels/device_macros.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN

constexpr double kPi = 3.14159265358979323846;
constexpr double kSqrtPi = 1.77245385090551602730;

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

// Minimum-image displacement in a periodic direction of length L.
inline double min_image(double d, double L) { return d - L * std::nearbyint(d / L); }

CAPSFLOW_DEVICE_END

}  // namespace capsflow
