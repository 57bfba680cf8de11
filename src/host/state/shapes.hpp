#pragma once
// Non-spherical reference shapes (issue 23): the icosphere mapped onto a spheroid or an Evans-Fung biconcave disc
// of a given equal-volume radius a (the species' `radius`: the shape encloses (4/3) pi a^3), centred at the
// origin. All shapes are axisymmetric about the z axis of the body frame; rotating them into a capsule's
// orientation is the caller's business. Method and measured errors: docs/method_shapes.md.
//
//   Sphere     radius a.
//   Spheroid   semi-axes (b, b, c), aspect = c / b (> 1 prolate, < 1 oblate), b^2 c = a^3.
//   Biconcave  Evans & Fung (1972): |z| = (R0/2) sqrt(1 - rho^2) (c0 + c2 rho^2 + c4 rho^4), rho = r / R0 in [0, 1],
//              r the distance from the z axis; R0 (the disc's radius) set by the volume.
//
// Usage:  TriMesh m = shape_mesh({ShapeKind::Biconcave}, a, 2);   // 162 nodes on the red-cell profile
//         double v = shape_volume_exact(spec, a), s = shape_area_exact(spec, a);
#include <array>
#include <vector>

#include "host/state/icosphere.hpp"

namespace capsflow {

enum class ShapeKind { Sphere, Spheroid, Biconcave };

struct ShapeSpec {
  ShapeKind kind = ShapeKind::Sphere;
  double aspect = 1.0;  // c / b; spheroids only (the other kinds require the default 1)
};

// Evans & Fung (1972), "Improved measurements of the erythrocyte geometry", Microvasc. Res. 4, 335-347: their mean
// cell has R0 = 3.91 um and thickness 2|z| = sqrt(1 - rho^2) (0.81 + 7.83 rho^2 - 4.39 rho^4) um; divided by R0 these
// are the c0, c2, c4 below. Taken as reproduced in public code in both that form and the diameter form
// (D = 7.82 um, a0 = 0.0518 = c0 / 4, a1 = 2.0026 = c2, a2 = -4.491 = 4 c4), not from the paper's full text.
constexpr double kEvansFungC0 = 0.2072;
constexpr double kEvansFungC2 = 2.0026;
constexpr double kEvansFungC4 = -1.1228;

// Throws InputError unless the kind is known, the aspect is finite and > 0 (and 1 for non-spheroids), and the
// radius is finite and > 0.
void validate_shape(const ShapeSpec& shape, double radius);

// Spheroid semi-axes: b (equatorial, x and y) and c (along z) for an equal-volume radius.
struct SpheroidAxes {
  double b, c;
};
SpheroidAxes spheroid_axes(double aspect, double radius);

// Evans-Fung half-thickness |z| at rho = r / R0 in [0, 1] (rho within 1e-12 of 1 counts as 1: rounding at the
// rim); R0 > 0. Throws InputError for rho outside that range.
double evans_fung_half_thickness(double rho, double R0);
// R0 of the Evans-Fung disc whose volume is (4/3) pi radius^3 (1.385738 radius).
double evans_fung_disc_radius(double radius);

// Maps node positions in place onto the shape of equal-volume radius `radius`. Only each node's direction from the
// origin is used (icosphere nodes: unit vectors); a zero vector or different lengths of x, y, z throw
// std::invalid_argument. The map is an orientation-preserving bijection of the sphere onto the shape, so
// triangles that were counter-clockwise seen from outside stay so.
void map_to_shape(const ShapeSpec& shape, double radius, std::vector<double>& x, std::vector<double>& y,
                  std::vector<double>& z);

// icosphere(level) with its nodes mapped by map_to_shape (connectivity unchanged).
TriMesh shape_mesh(const ShapeSpec& shape, double radius, int level);

// Volume and area of the exact (smooth) shape: closed forms, except the biconcave area (Gauss-Legendre quadrature,
// relative error below 1e-14).
double shape_volume_exact(const ShapeSpec& shape, double radius);
double shape_area_exact(const ShapeSpec& shape, double radius);

// Radius of the smallest sphere about the centre that holds the shape (placement and the box and wall checks use
// it): a for a sphere, max(b, c) for a spheroid, R0 for the biconcave disc (its rim is the farthest point).
double shape_bounding_radius(const ShapeSpec& shape, double radius);

// A rotation from a capsule's body frame (the shape's symmetry axis is body z) to the lab frame, row-major:
// lab = R body. The identity leaves a capsule as the mesh generator made it (what every sphere gets).
using Rotation = std::array<double, 9>;
inline constexpr Rotation kIdentityRotation{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};

// The rotation that takes body z onto the direction `axis` (any non-zero length) by the shortest turn (about
// z x axis); the identity for axis along +z, a half turn about x for -z. Throws InputError for a zero or
// non-finite axis.
Rotation rotation_to_axis(const std::array<double, 3>& axis);
// A rotation uniformly distributed over SO(3) from three independent uniform variates in [0, 1) (Shoemake's
// quaternion construction, Graphics Gems III, 1992).
Rotation uniform_rotation(double u1, double u2, double u3);

}  // namespace capsflow
