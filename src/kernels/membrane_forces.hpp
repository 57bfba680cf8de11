#pragma once
// Elastic membrane forces on flat linear triangles by virtual work, invariant form (docs/method.md §2.3;
// docs/method.md).
//
// Per element e with reference area A0 and constant shape-function gradients gradN_a (local 2D frame of the
// reference triangle):
//     F = [x1 - x0, x2 - x0] D^-1 = sum_a x_a (x) gradN_a  (3x2),   C = F^T F,   I1 = tr C - 2,  I2 = det C - 1
//     S = 2 dW/dC                                           (second Piola-Kirchhoff tension, 2x2)
//     F_a = -A0 F S gradN_a                                 (elastic nodal force = -dE/dx_a, E = sum_e A0 W)
// Laws (W per unit reference area):
//     neo-Hookean  W = (Gs/2)(I1 - 1 + 1/(I2 + 1)),                    S = Gs (I - adj(C)/det(C)^2)
//     Skalak       W = (Gs/4)(I1^2 + 2 I1 - 2 I2 + Cs I2^2),            S = Gs ((I1 + 1) I + (Cs I2 - 1) adj(C))
//     surface tension (a drop; Gs plays sigma)  W = Gs J,  J = sqrt(det C),  S = Gs adj(C) / J
//                  (energy sigma x current area; Cauchy tension sigma in every direction; no reference state)
// with adj(C) = det(C) C^-1. The invariant form has no 0/0 at equal principal stretches (pitfall P3).
//
// Nodal lumping (docs/method.md §2.2-2.3): A_i = (1/3) sum of the current areas of the triangles at node i, and the
// single-layer density is the force ON THE FLUID, f_i = +F_i / A_i (pitfall P1).
//
// Assembly is two-pass and race-free: each element writes its 9 nodal force components and its current area
// into an element buffer, then each node gathers over its (triangle, corner) incidence in a fixed order. The
// serial and threads backends therefore agree bit for bit; the device backend runs the same two passes.
//
// Data layout: ncap capsules share one mesh (nv nodes, ntri triangles); capsule k owns nodes [k nv, (k+1) nv)
// and elements [k ntri, (k+1) ntri). Reference data (A0, gradN1, gradN2) is per element (ncap * ntri).
#include <cmath>

#include "kernels/backend.hpp"
#include "kernels/device_macros.hpp"

namespace capsflow {

enum class MembraneLaw { NeoHookean, Skalak, SurfaceTension };

// Shared connectivity of the capsules' mesh, as raw pointers (see host/state/icosphere.hpp for the meaning).
struct MeshTopology {
  int nv = 0;                        // nodes per capsule
  int ntri = 0;                      // triangles per capsule
  const int* tri = nullptr;          // 3 * ntri
  const int* inc_offsets = nullptr;  // nv + 1
  const int* inc_tri = nullptr;      // 3 * ntri
  const int* inc_corner = nullptr;   // 3 * ntri
};

// Per-element reference data (computed once from the stress-free shape), ncap * ntri entries each.
struct MembraneReference {
  const double* area0 = nullptr;  // A0, reference area
  const double* g1x = nullptr;    // gradN1 in the element's local frame
  const double* g1y = nullptr;
  const double* g2x = nullptr;    // gradN2 (gradN0 = -gradN1 - gradN2)
  const double* g2y = nullptr;
};

CAPSFLOW_DEVICE_BEGIN

// Reference data of one triangle from its stress-free corner positions. Local frame: u along X1 - X0,
// v in the triangle's plane, so D = [[d11, d12], [0, d22]] and D^-1 rows are gradN1, gradN2.
inline void membrane_reference_element(double X0, double Y0, double Z0, double X1, double Y1, double Z1, double X2,
                                       double Y2, double Z2, double& area0, double& g1x, double& g1y, double& g2x,
                                       double& g2y) {
  const double ax = X1 - X0, ay = Y1 - Y0, az = Z1 - Z0;
  const double bx = X2 - X0, by = Y2 - Y0, bz = Z2 - Z0;
  const double d11 = std::sqrt(ax * ax + ay * ay + az * az);
  const double d12 = (ax * bx + ay * by + az * bz) / d11;
  const double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
  const double d22 = std::sqrt(cx * cx + cy * cy + cz * cz) / d11;  // |a x b| / |a|: height over edge 01
  const double det = d11 * d22;
  area0 = 0.5 * det;
  g1x = d22 / det;
  g1y = -d12 / det;
  g2x = 0.0;
  g2y = d11 / det;
}

// Second Piola-Kirchhoff tension S (symmetric 2x2: s11, s12, s22) and energy density W for C = [[c11, c12],
// [c12, c22]].
inline void membrane_stress(MembraneLaw law, double Gs, double Cs, double c11, double c12, double c22, double& s11,
                            double& s12, double& s22, double& W) {
  const double detC = c11 * c22 - c12 * c12;
  const double I1 = c11 + c22 - 2.0, I2 = detC - 1.0;
  // adj(C) = det(C) C^-1 = [[c22, -c12], [-c12, c11]]
  if (law == MembraneLaw::NeoHookean) {
    const double k = 1.0 / (detC * detC);
    s11 = Gs * (1.0 - k * c22);
    s12 = Gs * (k * c12);
    s22 = Gs * (1.0 - k * c11);
    W = 0.5 * Gs * (I1 - 1.0 + 1.0 / detC);
  } else if (law == MembraneLaw::SurfaceTension) {
    const double J = std::sqrt(detC);
    const double k = Gs / J;
    s11 = k * c22;
    s12 = -k * c12;
    s22 = k * c11;
    W = Gs * J;
  } else {
    const double p = I1 + 1.0, q = Cs * I2 - 1.0;
    s11 = Gs * (p + q * c22);
    s12 = Gs * (-q * c12);
    s22 = Gs * (p + q * c11);
    W = 0.25 * Gs * (I1 * I1 + 2.0 * I1 - 2.0 * I2 + Cs * I2 * I2);
  }
}

// Elastic nodal forces f[3 a + d] (a corner, d component) of one element, its current area and its energy A0 W.
inline void membrane_element_forces(MembraneLaw law, double Gs, double Cs, double x0, double y0, double z0, double x1,
                                    double y1, double z1, double x2, double y2, double z2, double area0, double g1x,
                                    double g1y, double g2x, double g2y, double* f, double& area, double& energy) {
  const double ax = x1 - x0, ay = y1 - y0, az = z1 - z0;
  const double bx = x2 - x0, by = y2 - y0, bz = z2 - z0;
  // Columns of F (3x2): F_j = a gradN1_j + b gradN2_j
  const double F0x = ax * g1x + bx * g2x, F0y = ay * g1x + by * g2x, F0z = az * g1x + bz * g2x;
  const double F1x = ax * g1y + bx * g2y, F1y = ay * g1y + by * g2y, F1z = az * g1y + bz * g2y;
  const double c11 = F0x * F0x + F0y * F0y + F0z * F0z;
  const double c12 = F0x * F1x + F0y * F1y + F0z * F1z;
  const double c22 = F1x * F1x + F1y * F1y + F1z * F1z;
  double s11, s12, s22, W;
  membrane_stress(law, Gs, Cs, c11, c12, c22, s11, s12, s22, W);
  energy = area0 * W;
  const double nx = ay * bz - az * by, ny = az * bx - ax * bz, nz = ax * by - ay * bx;
  area = 0.5 * std::sqrt(nx * nx + ny * ny + nz * nz);
  const double gx[3] = {-g1x - g2x, g1x, g2x};
  const double gy[3] = {-g1y - g2y, g1y, g2y};
  for (int c = 0; c < 3; ++c) {
    // -A0 F (S gradN_c)
    const double sx = s11 * gx[c] + s12 * gy[c];
    const double sy = s12 * gx[c] + s22 * gy[c];
    f[3 * c + 0] = -area0 * (F0x * sx + F1x * sy);
    f[3 * c + 1] = -area0 * (F0y * sx + F1y * sy);
    f[3 * c + 2] = -area0 * (F0z * sx + F1z * sy);
  }
}

// Principal Cauchy tensions t1 >= t2 (force per current length) and the energy density W (per reference area) of one
// element. The nonzero eigenvalues of the Cauchy tension F S F^T / J (J = sqrt(det C), the area ratio) are those of
// S C / J, which is similar to a symmetric matrix: real, and no 0/0 at equal stretches.
inline void membrane_element_tensions(MembraneLaw law, double Gs, double Cs, double x0, double y0, double z0,
                                      double x1, double y1, double z1, double x2, double y2, double z2, double g1x,
                                      double g1y, double g2x, double g2y, double& t1, double& t2, double& W) {
  const double ax = x1 - x0, ay = y1 - y0, az = z1 - z0;
  const double bx = x2 - x0, by = y2 - y0, bz = z2 - z0;
  const double F0x = ax * g1x + bx * g2x, F0y = ay * g1x + by * g2x, F0z = az * g1x + bz * g2x;
  const double F1x = ax * g1y + bx * g2y, F1y = ay * g1y + by * g2y, F1z = az * g1y + bz * g2y;
  const double c11 = F0x * F0x + F0y * F0y + F0z * F0z;
  const double c12 = F0x * F1x + F0y * F1y + F0z * F1z;
  const double c22 = F1x * F1x + F1y * F1y + F1z * F1z;
  double s11, s12, s22;
  membrane_stress(law, Gs, Cs, c11, c12, c22, s11, s12, s22, W);
  const double m11 = s11 * c11 + s12 * c12, m12 = s11 * c12 + s12 * c22;
  const double m21 = s12 * c11 + s22 * c12, m22 = s12 * c12 + s22 * c22;
  // (tr/2)^2 - det written without the cancellation that costs sqrt(eps) at equal stretches.
  const double half_tr = 0.5 * (m11 + m22), half_diff = 0.5 * (m11 - m22);
  const double disc = std::sqrt(std::fmax(0.0, half_diff * half_diff + m12 * m21));
  const double J = std::sqrt(c11 * c22 - c12 * c12);
  t1 = (half_tr + disc) / J;
  t2 = (half_tr - disc) / J;
}

CAPSFLOW_DEVICE_END

// Reference data of ncap * ntri elements from stress-free node positions X, Y, Z (ncap * nv nodes).
// Writes area0, g1x, g1y, g2x, g2y (ncap * ntri each). Host-side, serial: it runs once per capsule.
void membrane_reference(int ncap, int nv, int ntri, const int* tri, const double* X, const double* Y, const double* Z,
                        double* area0, double* g1x, double* g1y, double* g2x, double* g2y);

// Scratch for membrane_forces: 10 doubles per element (9 force components and the current area).
struct MembraneWork {
  double* element = nullptr;  // 10 * ncap * ntri
};

// Elastic forces of all capsules. law, Gs and Cs are per capsule (ncap values each): the constitutive law, the
// shear modulus and the Skalak area-dilatation parameter (ignored by the neo-Hookean law), so that one run may mix
// species of different laws (issue 23). Outputs per node (ncap * nv): the elastic nodal forces Fx/Fy/Fz
// (= -dE/dx), the lumped current nodal areas `node_area`, and the density on the fluid fx/fy/fz = F / A.
// Any of Fx (with Fy, Fz) may be null when not wanted. The backend must have passed require_backend().
void membrane_forces(Backend backend, const MembraneLaw* law, const double* Cs, int ncap, const MeshTopology& mesh,
                     const MembraneReference& ref, const double* Gs, const double* x, const double* y, const double* z,
                     MembraneWork work, double* Fx, double* Fy, double* Fz, double* node_area, double* fx, double* fy,
                     double* fz);

// Total elastic energy sum_e A0_e W(C_e) per capsule (energy[ncap]); serial (tests and diagnostics).
void membrane_energy(const MembraneLaw* law, const double* Cs, int ncap, const MeshTopology& mesh,
                     const MembraneReference& ref, const double* Gs, const double* x, const double* y, const double* z, double* energy);

}  // namespace capsflow
