// Non-spherical reference shapes (issue 23): exact volumes and areas against independent quadratures, the mapped
// icosphere's volume and area converging at second order, nodes on the exact surfaces, outward faces, triangle
// quality, bad input. The measured numbers are printed; docs/method_shapes.md tabulates them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "host/base/errors.hpp"
#include "host/state/icosphere.hpp"
#include "support/vec3.hpp"
#include "host/state/shapes.hpp"

using namespace capsflow;

namespace {

constexpr double kPi = 3.14159265358979323846;
// Evans & Fung's coefficients typed again here, so a slip in the library's constants shows.
constexpr double kC0 = 0.2072, kC2 = 2.0026, kC4 = -1.1228;
constexpr double kRadius = 1.3;  // not 1, so a missing scale factor shows

using test::Vec;
using test::node;
using test::sub;
using test::cross;
using test::dot;
using test::norm;

struct MeshMeasures {
  double volume = 0.0, area = 0.0;
  double min_angle_deg = 180.0;  // smallest triangle angle
  double max_edge_ratio = 0.0;   // largest (longest / shortest edge) of a triangle
  double area_spread = 0.0;      // largest / smallest triangle area
};

MeshMeasures measure(const TriMesh& m) {
  MeshMeasures r;
  double amin = 1e300, amax = 0.0;
  for (int t = 0; t < m.num_triangles(); ++t) {
    const Vec p[3] = {node(m, m.tri[3 * t]), node(m, m.tri[3 * t + 1]), node(m, m.tri[3 * t + 2])};
    const Vec n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
    const double a = 0.5 * norm(n);
    r.area += a;
    r.volume += dot(p[0], cross(p[1], p[2])) / 6.0;  // signed: positive for outward (CCW) faces
    amin = std::min(amin, a);
    amax = std::max(amax, a);
    double len[3];
    for (int k = 0; k < 3; ++k) len[k] = norm(sub(p[(k + 1) % 3], p[k]));
    r.max_edge_ratio = std::max(r.max_edge_ratio, *std::max_element(len, len + 3) / *std::min_element(len, len + 3));
    for (int k = 0; k < 3; ++k) {  // angle at corner k, opposite edge (k+1, k+2)
      const Vec u = sub(p[(k + 1) % 3], p[k]), v = sub(p[(k + 2) % 3], p[k]);
      const double c = std::clamp(dot(u, v) / (norm(u) * norm(v)), -1.0, 1.0);
      r.min_angle_deg = std::min(r.min_angle_deg, std::acos(c) * 180.0 / kPi);
    }
  }
  r.area_spread = amax / amin;
  return r;
}

// Composite Simpson rule, n (even) intervals. Deliberately not the library's Gauss-Legendre: an independent route.
template <class F>
double simpson(const F& f, double a, double b, int n) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4.0 : 2.0) * f(a + i * h);
  return s * h / 3.0;
}

// Simpson with n and 2n intervals must agree to `tol` (relative); returns the finer value.
template <class F>
double converged_simpson(const F& f, double a, double b, int n, double tol) {
  const double coarse = simpson(f, a, b, n), fine = simpson(f, a, b, 2 * n);
  EXPECT_NEAR(coarse, fine, tol * std::fabs(fine)) << "reference quadrature not converged";
  return fine;
}

// Spheroid (b, b, c) area as a surface of revolution in the polar parameter t (r = b sin t, z = c cos t).
double spheroid_area_reference(double b, double c) {
  auto f = [&](double t) {
    return 4.0 * kPi * b * std::sin(t) * std::hypot(b * std::cos(t), c * std::sin(t));
  };
  return converged_simpson(f, 0.0, 0.5 * kPi, 4000, 1e-13);
}

// The Evans-Fung disc with R0 = 1, integrated in t with rho = 1 - t^2: sqrt(1 - rho^2) = t sqrt(2 - t^2), and the
// rim's infinite slope dh/drho ~ 1/t is cancelled by drho = -2t dt, so both integrands are smooth on [0, 1].
double ef_poly(double s) { return kC0 + kC2 * s + kC4 * s * s; }
double ef_half_thickness_unit(double rho) {  // rho in [0, 1], R0 = 1
  return 0.5 * std::sqrt(std::max(0.0, 1.0 - rho * rho)) * ef_poly(rho * rho);
}
double ef_volume_unit() {
  auto f = [](double t) {
    const double rho = 1.0 - t * t;
    const double h = 0.5 * t * std::sqrt(2.0 - t * t) * ef_poly(rho * rho);
    return 2.0 * (2.0 * kPi * rho * h) * 2.0 * t;  // both halves
  };
  return converged_simpson(f, 0.0, 1.0, 4000, 1e-13);
}
double ef_area_unit() {
  auto f = [](double t) {
    const double rho = 1.0 - t * t, s = rho * rho, w = std::sqrt(2.0 - t * t);
    // t * dh/drho, with dh/drho = (1/2) (-rho P / sqrt(1 - rho^2) + 2 rho sqrt(1 - rho^2) P'(rho^2))
    const double t_dh = 0.5 * (-rho * ef_poly(s) / w + 2.0 * rho * t * t * w * (kC2 + 2.0 * kC4 * s));
    return 2.0 * 2.0 * kPi * rho * std::hypot(t, t_dh) * 2.0;  // both halves; sqrt(1 + h'^2) |drho/dt|
  };
  return converged_simpson(f, 0.0, 1.0, 4000, 1e-13);
}
double ef_disc_radius_reference(double radius) { return radius * std::cbrt(4.0 * kPi / 3.0 / ef_volume_unit()); }

// Gradient of an implicit function F that is < 0 inside and > 0 outside: the outward normal direction.
Vec spheroid_gradient(Vec p, double b, double c) { return {2 * p.x / (b * b), 2 * p.y / (b * b), 2 * p.z / (c * c)}; }
// F = 4 z^2 / R0^2 - G(s), G(s) = (1 - s) P(s)^2, s = (x^2 + y^2) / R0^2.
Vec biconcave_gradient(Vec p, double R0) {
  const double s = (p.x * p.x + p.y * p.y) / (R0 * R0), P = ef_poly(s), dP = kC2 + 2.0 * kC4 * s;
  const double dG = -P * P + 2.0 * (1.0 - s) * P * dP;
  return {-dG * 2.0 * p.x / (R0 * R0), -dG * 2.0 * p.y / (R0 * R0), 8.0 * p.z / (R0 * R0)};
}

// Smallest cosine between a face normal and the exact outward normal at each of its three (on-surface) corners.
// Positive everywhere means every face is oriented outward, the dimple's included (where the old test
// "normal . centroid > 0" says nothing: there the outward normal and the centroid direction can disagree).
template <class Grad>
double min_orientation_cosine(const TriMesh& m, const Grad& grad) {
  double worst = 1.0;
  for (int t = 0; t < m.num_triangles(); ++t) {
    const Vec p[3] = {node(m, m.tri[3 * t]), node(m, m.tri[3 * t + 1]), node(m, m.tri[3 * t + 2])};
    const Vec n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
    for (const Vec& q : p) {
      const Vec g = grad(q);
      worst = std::min(worst, dot(n, g) / (norm(n) * norm(g)));
    }
  }
  return worst;
}

const char* name_of(const ShapeSpec& s) {
  if (s.kind == ShapeKind::Biconcave) return "biconcave";
  if (s.kind == ShapeKind::Sphere) return "sphere";
  return s.aspect < 1.0 ? "spheroid 0.5" : "spheroid 2";
}

}  // namespace

TEST(Shapes, SpheroidAxesHaveTheAspectAndTheVolume) {
  for (double aspect : {0.1, 0.5, 1.0, 2.0, 10.0}) {
    const SpheroidAxes ax = spheroid_axes(aspect, kRadius);
    EXPECT_NEAR(ax.c / ax.b, aspect, 1e-14 * aspect);
    EXPECT_NEAR(ax.b * ax.b * ax.c, std::pow(kRadius, 3), 1e-14);
    EXPECT_NEAR(shape_volume_exact({ShapeKind::Spheroid, aspect}, kRadius), 4.0 * kPi / 3.0 * std::pow(kRadius, 3),
                1e-14);
  }
  EXPECT_NEAR(shape_volume_exact({}, kRadius), 4.0 * kPi / 3.0 * std::pow(kRadius, 3), 1e-14);
  EXPECT_NEAR(shape_area_exact({}, kRadius), 4.0 * kPi * kRadius * kRadius, 1e-14);
}

TEST(Shapes, SpheroidAreaClosedFormsMatchQuadrature) {
  // Prolate (asin form), oblate (atanh form), both sides of the series switch at e = 1e-3 (aspect 1 -+ 5e-7),
  // and the sphere limit.
  for (double aspect : {0.05, 0.5, 0.999, 1.0 - 4e-7, 1.0 - 6e-7, 1.0, 1.0 + 4e-7, 1.0 + 6e-7, 1.001, 2.0, 20.0}) {
    const SpheroidAxes ax = spheroid_axes(aspect, kRadius);
    const double exact = shape_area_exact({ShapeKind::Spheroid, aspect}, kRadius);
    EXPECT_NEAR(exact, spheroid_area_reference(ax.b, ax.c), 1e-12 * exact) << "aspect " << aspect;
  }
  for (double aspect : {1.0 - 1e-9, 1.0, 1.0 + 1e-9})
    EXPECT_NEAR(shape_area_exact({ShapeKind::Spheroid, aspect}, kRadius), 4.0 * kPi * kRadius * kRadius, 1e-12);
}

TEST(Shapes, EvansFungProfileVolumeAndArea) {
  // The profile's own landmarks: half-thickness c0 R0 / 2 at the centre, zero at the rim.
  EXPECT_NEAR(evans_fung_half_thickness(0.0, 2.0), kC0, 1e-15);
  EXPECT_DOUBLE_EQ(evans_fung_half_thickness(1.0, 2.0), 0.0);
  for (double rho : {0.1, 0.3, 0.5, 0.7, 0.8, 0.9, 0.99, 0.999999})
    EXPECT_NEAR(evans_fung_half_thickness(rho, 2.0), 2.0 * ef_half_thickness_unit(rho), 1e-15) << rho;

  // Equal volume: R0 from the library against R0 from this file's quadrature; the library's volume and area
  // against the quadratures.
  const double R0 = evans_fung_disc_radius(kRadius);
  EXPECT_NEAR(R0, ef_disc_radius_reference(kRadius), 1e-13 * R0);
  const ShapeSpec rbc{ShapeKind::Biconcave};
  EXPECT_NEAR(shape_volume_exact(rbc, kRadius), 4.0 * kPi / 3.0 * std::pow(kRadius, 3), 1e-13);
  EXPECT_NEAR(shape_volume_exact(rbc, kRadius), ef_volume_unit() * R0 * R0 * R0, 1e-13);
  const double area = shape_area_exact(rbc, kRadius);
  EXPECT_NEAR(area, ef_area_unit() * R0 * R0, 1e-12 * area);
  std::printf("Evans-Fung: R0 / a = %.15f, V / R0^3 = %.15f, A / R0^2 = %.15f, A / (4 pi a^2) = %.6f\n",
              R0 / kRadius, ef_volume_unit(), ef_area_unit(), area / (4.0 * kPi * kRadius * kRadius));

  // Sanity against the red cell the fit describes (R0 = 3.91 um): centre thickness 0.81 um, rim thickness about
  // 2.6 um, about 94 um^3 and 135 um^2 (the numbers usually quoted for Evans & Fung's mean cell).
  const double um = 3.91;
  EXPECT_NEAR(2.0 * evans_fung_half_thickness(0.0, um), 0.81, 0.005);
  double thickest = 0.0;
  for (int i = 0; i <= 10000; ++i) thickest = std::max(thickest, 2.0 * evans_fung_half_thickness(i / 1e4, um));
  EXPECT_NEAR(thickest, 2.58, 0.03);
  EXPECT_NEAR(ef_volume_unit() * um * um * um, 94.0, 0.02 * 94.0);
  EXPECT_NEAR(ef_area_unit() * um * um, 135.0, 0.02 * 135.0);
}

TEST(Shapes, SphereAndSpheroidNodesLieOnTheSurface) {
  for (double aspect : {0.5, 1.0, 2.0}) {
    const double b = kRadius * std::pow(aspect, -1.0 / 3.0), c = kRadius * std::pow(aspect, 2.0 / 3.0);
    const ShapeSpec spec = aspect == 1.0 ? ShapeSpec{} : ShapeSpec{ShapeKind::Spheroid, aspect};
    for (int level = 0; level <= 4; ++level) {
      const TriMesh m = shape_mesh(spec, kRadius, level);
      double worst = 0.0;
      for (int i = 0; i < m.num_nodes(); ++i)
        worst = std::max(worst, std::fabs((m.x[i] * m.x[i] + m.y[i] * m.y[i]) / (b * b) + m.z[i] * m.z[i] / (c * c) - 1));
      EXPECT_LT(worst, 1e-14) << "aspect " << aspect << " level " << level;
      // A linear map scales every volume by b^2 c: the triangulated volume is exactly (to rounding) the unit
      // icosphere's times radius^3.
      const double unit = measure(icosphere(level)).volume;
      EXPECT_NEAR(measure(m).volume, unit * std::pow(kRadius, 3), 1e-13 * unit);
    }
  }
}

TEST(Shapes, BiconcaveNodesLieOnTheEvansFungProfile) {
  const double R0 = ef_disc_radius_reference(kRadius);
  for (int level = 0; level <= 4; ++level) {
    const TriMesh m = shape_mesh({ShapeKind::Biconcave}, kRadius, level);
    double worst = 0.0, rho_max = 0.0;
    int upper = 0, lower = 0;
    for (int i = 0; i < m.num_nodes(); ++i) {
      const double rho = std::hypot(m.x[i], m.y[i]) / R0;
      rho_max = std::max(rho_max, rho);
      worst = std::max(worst, std::fabs(std::fabs(m.z[i]) - R0 * ef_half_thickness_unit(rho)));
      // The map keeps each node's side of z = 0 and its azimuth.
      const Vec u = node(icosphere(level), i);
      upper += (u.z > 0) == (m.z[i] > 0);
      lower += (u.z < 0) == (m.z[i] < 0);
      if (std::hypot(u.x, u.y) > 0) {
        EXPECT_NEAR(std::atan2(m.y[i], m.x[i]), std::atan2(u.y, u.x), 1e-14);
      }
    }
    EXPECT_LT(worst, 1e-12 * R0) << "level " << level;
    EXPECT_LE(rho_max, 1.0 + 1e-15);
    EXPECT_EQ(upper, m.num_nodes());
    EXPECT_EQ(lower, m.num_nodes());
    std::printf("biconcave level %d: max | |z| - profile(rho) | = %.2e R0, max rho = %.17g\n", level, worst / R0,
                rho_max);
  }
}

// The heart of the file: volume and area of the mapped icosphere against the exact values, levels 2, 3, 4.
// Flat triangles with nodes on the surface: errors O(h^2), so about 4x smaller per level. Bounds were set from
// the measured values (printed) with margin: the level-4 errors at about 1.5x what was measured.
TEST(Shapes, VolumeAndAreaConvergeAtSecondOrder) {
  struct Case {
    ShapeSpec spec;
    double max_volume_error_l4, max_area_error_l4;  // relative
  };
  // Measured at level 4: sphere and spheroids 2.16e-3 (volume; identical, the map is linear) and 1.20e-3 (area);
  // biconcave 3.33e-3 and 1.89e-3.
  const Case cases[] = {{{ShapeKind::Sphere, 1.0}, 3.3e-3, 1.8e-3},
                        {{ShapeKind::Spheroid, 0.5}, 3.3e-3, 1.8e-3},
                        {{ShapeKind::Spheroid, 2.0}, 3.3e-3, 1.8e-3},
                        {{ShapeKind::Biconcave, 1.0}, 5.0e-3, 2.9e-3}};
  for (const Case& c : cases) {
    const double v_exact = shape_volume_exact(c.spec, kRadius), a_exact = shape_area_exact(c.spec, kRadius);
    double ev[3], ea[3];
    for (int level = 2; level <= 4; ++level) {
      const MeshMeasures mm = measure(shape_mesh(c.spec, kRadius, level));
      ev[level - 2] = std::fabs(mm.volume - v_exact) / v_exact;
      ea[level - 2] = std::fabs(mm.area - a_exact) / a_exact;
      std::printf("%-12s level %d: volume rel. error %.3e, area rel. error %.3e\n", name_of(c.spec), level,
                  ev[level - 2], ea[level - 2]);
    }
    for (int k = 0; k < 2; ++k) {
      const double rv = std::log2(ev[k] / ev[k + 1]), ra = std::log2(ea[k] / ea[k + 1]);
      std::printf("%-12s rate %d->%d: volume %.3f, area %.3f\n", name_of(c.spec), k + 2, k + 3, rv, ra);
      EXPECT_GT(rv, 1.7) << name_of(c.spec);
      EXPECT_LT(rv, 2.3) << name_of(c.spec);
      EXPECT_GT(ra, 1.7) << name_of(c.spec);
      EXPECT_LT(ra, 2.3) << name_of(c.spec);
    }
    EXPECT_LT(ev[2], c.max_volume_error_l4) << name_of(c.spec);
    EXPECT_LT(ea[2], c.max_area_error_l4) << name_of(c.spec);
  }
}

TEST(Shapes, EveryFaceIsOrientedOutward) {
  const SpheroidAxes flat = spheroid_axes(0.5, kRadius), tall = spheroid_axes(2.0, kRadius);
  const double R0 = ef_disc_radius_reference(kRadius);
  for (int level = 0; level <= 4; ++level) {
    const double cos_flat = min_orientation_cosine(shape_mesh({ShapeKind::Spheroid, 0.5}, kRadius, level),
                                                   [&](Vec p) { return spheroid_gradient(p, flat.b, flat.c); });
    const double cos_tall = min_orientation_cosine(shape_mesh({ShapeKind::Spheroid, 2.0}, kRadius, level),
                                                   [&](Vec p) { return spheroid_gradient(p, tall.b, tall.c); });
    const TriMesh rbc = shape_mesh({ShapeKind::Biconcave}, kRadius, level);
    const double cos_rbc = min_orientation_cosine(rbc, [&](Vec p) { return biconcave_gradient(p, R0); });
    std::printf("level %d: min cos(face normal, exact normal at a corner): spheroid 0.5 %.3f, spheroid 2 %.3f, "
                "biconcave %.3f\n", level, cos_flat, cos_tall, cos_rbc);
    EXPECT_GT(cos_flat, 0.0);
    EXPECT_GT(cos_tall, 0.0);
    EXPECT_GT(cos_rbc, 0.0);
    if (level >= 2) {  // and no face far from the surface's tangent plane (measured >= 0.88 at level 2)
      EXPECT_GT(cos_flat, 0.8);
      EXPECT_GT(cos_tall, 0.8);
      EXPECT_GT(cos_rbc, 0.8);
    }
    EXPECT_GT(measure(rbc).volume, 0.0);
  }
}

TEST(Shapes, TriangleQuality) {
  struct Bound {
    ShapeSpec spec;
    double min_angle_deg, max_edge_ratio, max_area_spread;  // over levels 2-4
  };
  // Measured worst over levels 2-4 (min angle, edge ratio, area spread): sphere 54.0 deg, 1.18, 1.30; spheroids
  // 29.0 deg, 2.02, 2.55 (the linear map stretches by the aspect where the meridian is steep); biconcave
  // 44.0 deg, 1.43, 1.67. Bounds leave a few degrees and about 10% of margin.
  const Bound bounds[] = {{{ShapeKind::Sphere, 1.0}, 51.0, 1.25, 1.4},
                          {{ShapeKind::Spheroid, 0.5}, 26.0, 2.2, 2.8},
                          {{ShapeKind::Spheroid, 2.0}, 26.0, 2.2, 2.8},
                          {{ShapeKind::Biconcave, 1.0}, 41.0, 1.55, 1.85}};
  for (const Bound& b : bounds)
    for (int level = 2; level <= 4; ++level) {
      const MeshMeasures mm = measure(shape_mesh(b.spec, kRadius, level));
      std::printf("%-12s level %d: min angle %.2f deg, max edge ratio %.3f, max/min triangle area %.3f\n",
                  name_of(b.spec), level, mm.min_angle_deg, mm.max_edge_ratio, mm.area_spread);
      EXPECT_GT(mm.min_angle_deg, b.min_angle_deg) << name_of(b.spec) << " level " << level;
      EXPECT_LT(mm.max_edge_ratio, b.max_edge_ratio) << name_of(b.spec) << " level " << level;
      EXPECT_LT(mm.area_spread, b.max_area_spread) << name_of(b.spec) << " level " << level;
    }
}

TEST(Shapes, BadInputIsAnInputError) {
  const double nan = std::nan(""), inf = HUGE_VAL;
  for (double aspect : {0.0, -1.0, nan, inf}) {
    EXPECT_THROW(validate_shape({ShapeKind::Spheroid, aspect}, 1.0), InputError) << aspect;
    EXPECT_THROW(shape_mesh({ShapeKind::Spheroid, aspect}, 1.0, 2), InputError) << aspect;
    EXPECT_THROW(shape_volume_exact({ShapeKind::Spheroid, aspect}, 1.0), InputError) << aspect;
    EXPECT_THROW(shape_area_exact({ShapeKind::Spheroid, aspect}, 1.0), InputError) << aspect;
    EXPECT_THROW(spheroid_axes(aspect, 1.0), InputError) << aspect;
  }
  for (double radius : {0.0, -1.0, nan, inf})
    for (ShapeKind kind : {ShapeKind::Sphere, ShapeKind::Spheroid, ShapeKind::Biconcave}) {
      EXPECT_THROW(shape_mesh({kind, 1.0}, radius, 2), InputError) << radius;
      EXPECT_THROW(shape_volume_exact({kind, 1.0}, radius), InputError) << radius;
      EXPECT_THROW(shape_area_exact({kind, 1.0}, radius), InputError) << radius;
    }
  EXPECT_THROW(evans_fung_disc_radius(0.0), InputError);
  EXPECT_THROW(evans_fung_half_thickness(1.01, 1.0), InputError);
  EXPECT_THROW(evans_fung_half_thickness(-0.01, 1.0), InputError);
  EXPECT_THROW(evans_fung_half_thickness(0.5, 0.0), InputError);
  EXPECT_NO_THROW(evans_fung_half_thickness(1.0 + 1e-13, 1.0));  // rounding at the rim
  // The aspect belongs to spheroids; elsewhere it must stay at its default rather than be ignored.
  EXPECT_THROW(validate_shape({ShapeKind::Biconcave, 2.0}, 1.0), InputError);
  EXPECT_THROW(validate_shape({ShapeKind::Sphere, 0.5}, 1.0), InputError);
  EXPECT_THROW(validate_shape({static_cast<ShapeKind>(7), 1.0}, 1.0), InputError);
  EXPECT_THROW(shape_mesh({ShapeKind::Biconcave}, 1.0, 5), InputError);  // icosphere level
  try {
    validate_shape({ShapeKind::Spheroid, -2.0}, 1.0);
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("aspect"), std::string::npos) << msg;
    EXPECT_NE(msg.find("> 0"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }

  std::vector<double> x{1.0, 0.0}, y{0.0, 0.0}, z{0.0, 0.0};
  EXPECT_THROW(map_to_shape({}, 1.0, x, y, z), std::invalid_argument);  // the second node has no direction
  std::vector<double> shorter{0.0};
  EXPECT_THROW(map_to_shape({}, 1.0, x, shorter, z), std::invalid_argument);
}

TEST(Shapes, OnlyDirectionsMatter) {
  // Nodes off the unit sphere map like their directions (scaling by 2 is exact in floating point).
  const TriMesh& s = icosphere(2);
  for (ShapeSpec spec : {ShapeSpec{ShapeKind::Spheroid, 2.0}, ShapeSpec{ShapeKind::Biconcave}}) {
    std::vector<double> x = s.x, y = s.y, z = s.z;
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] *= 2.0;
      y[i] *= 2.0;
      z[i] *= 2.0;
    }
    map_to_shape(spec, kRadius, x, y, z);
    const TriMesh m = shape_mesh(spec, kRadius, 2);
    for (int i = 0; i < m.num_nodes(); ++i) {
      EXPECT_EQ(x[i], m.x[i]);
      EXPECT_EQ(y[i], m.y[i]);
      EXPECT_EQ(z[i], m.z[i]);
    }
  }
}
