// The implementation of shapes.hpp: non-spherical reference shapes (issue 23).
#include "host/state/shapes.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "host/base/errors.hpp"
#include "kernels/constants.hpp"

namespace capsflow {
namespace {

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// 20-point Gauss-Legendre rule on [-1, 1], built once by Newton's method on the Legendre recurrence (no table to
// mistype). Composite rules of it integrate the smooth meridian integrands below to rounding.
struct GaussLegendre20 {
  static constexpr int n = 20;
  std::array<double, n> x{}, w{};
  GaussLegendre20() {
    auto legendre = [](double t, double& p, double& dp) {
      double p0 = 1.0, p1 = t;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * t * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      p = p1;
      dp = n * (t * p1 - p0) / (t * t - 1.0);
    };
    for (int i = 0; i < n; ++i) {
      double t = std::cos(kPi * (i + 0.75) / (n + 0.5));  // close to the i-th root
      double p = 0.0, dp = 1.0;
      for (int it = 0; it < 100; ++it) {
        legendre(t, p, dp);
        const double step = p / dp;
        t -= step;
        if (std::fabs(step) < 1e-15) break;
      }
      legendre(t, p, dp);
      x[i] = t;
      w[i] = 2.0 / ((1.0 - t * t) * dp * dp);
    }
  }
};

template <class F>
double gauss_integrate(const F& f, double a, double b, int panels) {
  static const GaussLegendre20 rule;
  const double h = (b - a) / panels;
  double sum = 0.0;
  for (int k = 0; k < panels; ++k) {
    const double mid = a + (k + 0.5) * h;
    double s = 0.0;
    for (int i = 0; i < GaussLegendre20::n; ++i) s += rule.w[i] * f(mid + 0.5 * h * rule.x[i]);
    sum += s;
  }
  return 0.5 * h * sum;
}

// The Evans-Fung meridian in units of R0, parametrized by psi in [0, pi/2] from the top of the dimple to the rim:
// r = sin(psi), z = cos(psi) P(sin^2 psi) / 2. rho = sin(psi) turns sqrt(1 - rho^2) into cos(psi), so the curve is
// analytic in psi (in rho, dz/drho is infinite at the rim) and its speed never vanishes: that makes both the area
// quadrature and the arc-length inversion below converge fast.
double ef_poly(double s) { return kEvansFungC0 + s * (kEvansFungC2 + s * kEvansFungC4); }
double ef_poly_derivative(double s) { return kEvansFungC2 + 2.0 * kEvansFungC4 * s; }

double ef_speed(double psi) {
  const double s = std::sin(psi), c = std::cos(psi), s2 = s * s;
  const double dz = 0.5 * (-s * ef_poly(s2) + 2.0 * s * c * c * ef_poly_derivative(s2));
  return std::hypot(c, dz);
}

double ef_arc_length(double psi) { return gauss_integrate(ef_speed, 0.0, psi, 8); }

// psi at which the arc length from the dimple's centre is `target` (0 <= target <= half_length = ef_arc_length(pi/2)):
// Newton (ds/dpsi is the speed, which never vanishes), kept inside a bisection bracket for safety.
double ef_psi_at_arc_length(double target, double half_length) {
  if (target <= 0.0) return 0.0;
  if (target >= half_length) return 0.5 * kPi;
  double lo = 0.0, hi = 0.5 * kPi, psi = 0.5 * kPi * target / half_length;
  for (int it = 0; it < 60; ++it) {
    const double f = ef_arc_length(psi) - target;
    if (f > 0.0)
      hi = psi;
    else
      lo = psi;
    double next = psi - f / ef_speed(psi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const bool done = std::fabs(next - psi) < 1e-14;
    psi = next;
    if (done) break;
  }
  return psi;
}

// V / R0^3 of the Evans-Fung disc: 2 pi int_0^1 rho sqrt(1 - rho^2) P(rho^2) drho, with u = 1 - rho^2
// = pi int_0^1 sqrt(u) (c0 + c2 (1 - u) + c4 (1 - u)^2) du = pi (2 c0 / 3 + 4 c2 / 15 + 16 c4 / 105).
double ef_volume_factor() {
  return kPi * (2.0 * kEvansFungC0 / 3.0 + 4.0 * kEvansFungC2 / 15.0 + 16.0 * kEvansFungC4 / 105.0);
}

// asin(e) / e and atanh(e) / e; the series (truncation error below e^8 < 1e-24) only to avoid 0 / 0 at e = 0.
double asin_over(double e) {
  if (e < 1e-3) {
    const double e2 = e * e;
    return 1.0 + e2 * (1.0 / 6.0 + e2 * (3.0 / 40.0 + e2 * 5.0 / 112.0));
  }
  return std::asin(e) / e;
}
double atanh_over(double e) {
  if (e < 1e-3) {
    const double e2 = e * e;
    return 1.0 + e2 * (1.0 / 3.0 + e2 * (1.0 / 5.0 + e2 / 7.0));
  }
  return std::atanh(e) / e;
}

double spheroid_area(double b, double c) {
  if (c > b) {  // prolate: 2 pi b^2 (1 + (c / b) asin(e) / e), e^2 = 1 - b^2 / c^2
    const double e = std::sqrt(1.0 - (b / c) * (b / c));
    return 2.0 * kPi * b * b * (1.0 + (c / b) * asin_over(e));
  }
  // oblate (and the sphere, e = 0): 2 pi b^2 (1 + (c / b)^2 atanh(e) / e), e^2 = 1 - c^2 / b^2
  const double q = c / b;
  const double e = std::sqrt(1.0 - q * q);
  return 2.0 * kPi * b * b * (1.0 + q * q * atanh_over(e));
}

}  // namespace

void validate_shape(const ShapeSpec& shape, double radius) {
  if (shape.kind != ShapeKind::Sphere && shape.kind != ShapeKind::Spheroid && shape.kind != ShapeKind::Biconcave)
    throw InputError("shape: unknown shape kind " + std::to_string(static_cast<int>(shape.kind)) +
                     " (expected sphere, spheroid or biconcave)");
  if (!(std::isfinite(shape.aspect) && shape.aspect > 0.0))
    throw InputError("shape: aspect (c / b of a spheroid) must be a finite number > 0, got " + number(shape.aspect));
  // A silently ignored aspect would hide a config mistake.
  if (shape.kind != ShapeKind::Spheroid && shape.aspect != 1.0)
    throw InputError("shape: aspect applies to spheroids only; a sphere or biconcave disc needs aspect 1, got " +
                     number(shape.aspect));
  if (!(std::isfinite(radius) && radius > 0.0))
    throw InputError("shape: radius (the equal-volume radius) must be a finite number > 0, got " + number(radius));
}

SpheroidAxes spheroid_axes(double aspect, double radius) {
  validate_shape({ShapeKind::Spheroid, aspect}, radius);
  // b^2 c = radius^3 with c = aspect b.
  return {radius / std::cbrt(aspect), radius * std::cbrt(aspect * aspect)};
}

double evans_fung_half_thickness(double rho, double R0) {
  if (!(std::isfinite(R0) && R0 > 0.0))
    throw InputError("Evans-Fung profile: R0 must be a finite number > 0, got " + number(R0));
  if (!(rho >= 0.0 && rho <= 1.0 + 1e-12))
    throw InputError("Evans-Fung profile: rho = r / R0 must lie in [0, 1], got " + number(rho));
  const double s = std::min(rho * rho, 1.0);
  return 0.5 * R0 * std::sqrt(1.0 - s) * ef_poly(s);
}

double evans_fung_disc_radius(double radius) {
  validate_shape({ShapeKind::Biconcave, 1.0}, radius);
  return radius * std::cbrt(4.0 * kPi / 3.0 / ef_volume_factor());
}

void map_to_shape(const ShapeSpec& shape, double radius, std::vector<double>& x, std::vector<double>& y,
                  std::vector<double>& z) {
  validate_shape(shape, radius);
  if (x.size() != y.size() || x.size() != z.size())
    throw std::invalid_argument("map_to_shape: x, y and z differ in length");
  const std::size_t n = x.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double len = std::sqrt(x[i] * x[i] + y[i] * y[i] + z[i] * z[i]);
    if (!(len > 0.0 && std::isfinite(len))) throw std::invalid_argument("map_to_shape: a node has no direction");
    x[i] /= len;
    y[i] /= len;
    z[i] /= len;
  }

  if (shape.kind == ShapeKind::Sphere || shape.kind == ShapeKind::Spheroid) {
    // A linear map: nodes land exactly on the spheroid; triangles keep their orientation (positive determinant).
    const SpheroidAxes ax = shape.kind == ShapeKind::Sphere ? SpheroidAxes{radius, radius}
                                                            : spheroid_axes(shape.aspect, radius);
    for (std::size_t i = 0; i < n; ++i) {
      x[i] *= ax.b;
      y[i] *= ax.b;
      z[i] *= ax.c;
    }
    return;
  }

  // Biconcave disc. Azimuth kept; the sphere's polar angle theta (from the nearer pole, so the map is symmetric
  // about z = 0) is mapped to the meridian point at the same FRACTION OF ARC LENGTH: theta / (pi/2) = s / s_rim.
  // The naive map psi = theta (rho = sin theta) squeezes the steep flank and the rim along the meridian
  // (min angle 31 deg at level 4 against 44 deg here; docs/method_shapes.md has the comparison). Equal arc
  // length keeps the meridional spacing uniform; near the poles the map is a similarity (theta and s both odd
  // there), so the mesh stays smooth across the axis and the rim.
  const double R0 = evans_fung_disc_radius(radius);
  const double half_length = ef_arc_length(0.5 * kPi);
  for (std::size_t i = 0; i < n; ++i) {
    const double rxy = std::hypot(x[i], y[i]);
    const double theta = std::atan2(rxy, std::fabs(z[i]));  // in [0, pi/2]
    const double psi = ef_psi_at_arc_length(half_length * theta / (0.5 * kPi), half_length);
    const double rho = std::sin(psi);
    const double h = 0.5 * R0 * std::cos(psi) * ef_poly(rho * rho);
    x[i] = rxy > 0.0 ? R0 * rho * x[i] / rxy : 0.0;
    y[i] = rxy > 0.0 ? R0 * rho * y[i] / rxy : 0.0;
    z[i] = z[i] > 0.0 ? h : (z[i] < 0.0 ? -h : 0.0);  // nodes on the equator stay exactly on the rim
  }
}

TriMesh shape_mesh(const ShapeSpec& shape, double radius, int level) {
  validate_shape(shape, radius);
  TriMesh m = icosphere(level);
  map_to_shape(shape, radius, m.x, m.y, m.z);
  return m;
}

double shape_volume_exact(const ShapeSpec& shape, double radius) {
  validate_shape(shape, radius);
  if (shape.kind == ShapeKind::Biconcave) {
    const double R0 = evans_fung_disc_radius(radius);
    return ef_volume_factor() * R0 * R0 * R0;
  }
  return 4.0 * kPi / 3.0 * radius * radius * radius;  // b^2 c = radius^3 for every spheroid
}

double shape_area_exact(const ShapeSpec& shape, double radius) {
  validate_shape(shape, radius);
  switch (shape.kind) {
    case ShapeKind::Sphere:
      return 4.0 * kPi * radius * radius;
    case ShapeKind::Spheroid: {
      const SpheroidAxes ax = spheroid_axes(shape.aspect, radius);
      return spheroid_area(ax.b, ax.c);
    }
    case ShapeKind::Biconcave:
      break;
  }
  // Area of revolution of both halves: 4 pi R0^2 int_0^{pi/2} sin(psi) |d(r,z)/dpsi| dpsi. The integrand is
  // analytic, so panel doubling settles within a few steps; stop when two agree to 1e-15.
  auto integrand = [](double psi) { return std::sin(psi) * ef_speed(psi); };
  double prev = gauss_integrate(integrand, 0.0, 0.5 * kPi, 2);
  for (int panels = 4; panels <= 1024; panels *= 2) {
    const double next = gauss_integrate(integrand, 0.0, 0.5 * kPi, panels);
    const bool settled = std::fabs(next - prev) <= 1e-15 * next;
    prev = next;
    if (settled) break;
  }
  const double R0 = evans_fung_disc_radius(radius);
  return 4.0 * kPi * R0 * R0 * prev;
}

double shape_bounding_radius(const ShapeSpec& shape, double radius) {
  validate_shape(shape, radius);
  switch (shape.kind) {
    case ShapeKind::Sphere:
      return radius;
    case ShapeKind::Spheroid: {
      const SpheroidAxes ax = spheroid_axes(shape.aspect, radius);
      return std::max(ax.b, ax.c);
    }
    case ShapeKind::Biconcave:
      break;
  }
  // r^2 + z^2 = R0^2 (rho^2 + (1 - rho^2) P(rho^2)^2 / 4) grows to rho = 1 because P^2 / 4 < 1 on [0, 1]
  // (P <= 1.10): the rim is the farthest point.
  return evans_fung_disc_radius(radius);
}

Rotation rotation_to_axis(const std::array<double, 3>& axis) {
  const double len = std::hypot(axis[0], axis[1], axis[2]);  // no overflow for any finite axis
  if (!(std::isfinite(len) && len > 0.0))
    throw InputError("orientation: expected a non-zero finite axis [x, y, z], got [" + number(axis[0]) + ", " +
                     number(axis[1]) + ", " + number(axis[2]) + "]");
  const double nx = axis[0] / len, ny = axis[1] / len, nz = axis[2] / len;
  if (nx == 0.0 && ny == 0.0) return nz > 0.0 ? kIdentityRotation : Rotation{1, 0, 0, 0, -1, 0, 0, 0, -1};
  // Rodrigues about k = (z x n) / |z x n| = (-ny, nx, 0) / s by the angle whose cosine is nz and sine s.
  const double s = std::hypot(nx, ny), c = nz;
  const double kx = -ny / s, ky = nx / s;  // kz = 0
  const double v = 1.0 - c;
  return {c + kx * kx * v, kx * ky * v, ky * s,   //
          kx * ky * v, c + ky * ky * v, -kx * s,  //
          -ky * s, kx * s, c};
}

Rotation uniform_rotation(double u1, double u2, double u3) {
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
  const double w = a * std::sin(2.0 * kPi * u2), x = a * std::cos(2.0 * kPi * u2);
  const double y = b * std::sin(2.0 * kPi * u3), z = b * std::cos(2.0 * kPi * u3);
  return {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
          2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
          2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
}

}  // namespace capsflow
