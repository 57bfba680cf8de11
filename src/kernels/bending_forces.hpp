#pragma once
// Bending resistance: a discrete Helfrich energy with zero spontaneous curvature and its exact nodal forces
// (docs/method.md, "Bending").
//
// Continuum: E = (kappa/2) int (2H)^2 dA = 2 kappa int H^2 dA, H the mean curvature (1/R on a sphere with the
// outward normal), so E = 8 pi kappa on every sphere. Discretisation (Jülicher 1996): per edge e with length l_e and
// dihedral angle theta_e between its two triangles' outward normals (positive where the surface is convex), the
// integrated mean curvature of node i and its area are
//     M_i = (1/4) sum_{e at i} l_e theta_e,      A_i = sum_{t at i} V_i^t  (Voronoi area, bending_voronoi),
// and E = 2 kappa sum_i M_i^2 / A_i. The Voronoi area is the one that pairs with M: on a sphere each dihedral angle
// is (r1 + r2) / R to leading order, r the distances of the two triangles' circumcentres from the edge, so
// M_i = A_i / R + O(h^2) at every node; the barycentric third of the areas gives O(1) errors in H_i at irregular
// nodes, and so force densities growing like 1/h^2 (measured: tests/test_bending.cpp, docs/method.md). The nodal forces are the exact gradient F_i = -dE/dx_i, in closed form (the
// gradients of l, theta and the triangle areas), so they conserve momentum and angular momentum to rounding and
// the discrete energy only decreases under the forces. Why this scheme: docs/method.md.
//
// Assembly is race-free in four passes, as for the elastic forces: per edge l theta and its gradient, per triangle
// its Voronoi parts; per node dE/dM_i and dE/dA_i; per edge (the stored gradient scaled) and per triangle the force
// contributions on their 4 and 3 nodes into buffers; per node a gather in a fixed order. Serial and threads therefore agree bit for bit.
//
// Data layout as in membrane_forces.hpp: ncap capsules share one closed mesh; kappa is per capsule.
#include <cmath>

#include "kernels/backend.hpp"
#include "kernels/device_macros.hpp"

namespace capsflow {

// Connectivity the bending kernel needs (host/state/icosphere.hpp TriMesh, as raw pointers).
struct BendingTopology {
  int nv = 0, ntri = 0, nedge = 0;
  const int* tri = nullptr;           // 3 * ntri, counter-clockwise from outside
  const int* quad = nullptr;          // 4 * nedge: (a, b, c, d), triangles (a, b, c) and (b, a, d)
  const int* inc_offsets = nullptr;   // nv + 1: node -> incident (triangle, corner)
  const int* inc_tri = nullptr;
  const int* inc_corner = nullptr;
  const int* einc_offsets = nullptr;  // nv + 1: node -> (edge, slot in its quad)
  const int* einc_edge = nullptr;
  const int* einc_slot = nullptr;
};

// Scratch, sized for ncap capsules.
struct BendingWork {
  double* edge = nullptr;  // 13 * ncap * nedge
  double* tri = nullptr;   // 12 * ncap * ntri
  double* node = nullptr;  // 2 * ncap * nv
};

CAPSFLOW_DEVICE_BEGIN

// l theta of the edge quad (a, b, c, d) = P[0..2], P[3..5], P[6..8], P[9..11]; with g non-null also its gradient
// g[3 s + d] = d(l theta)/d(P_s)_d. theta = atan2((n1 x n2) . e/l, n1 . n2), e = b - a, n1 and n2 the normals of
// (a, b, c) and (b, a, d); moving c or d along its triangle's normal by dh turns theta by -dh / (its height over e)
// (raising c or d along its normal flattens a convex fold: the minus signs), and the gradients at a and b follow
// from invariance under translation and rotation.
inline double bending_edge(const double* P, double* g) {
  double e[3], ca[3], da[3];
  for (int i = 0; i < 3; ++i) {
    e[i] = P[3 + i] - P[i];
    ca[i] = P[6 + i] - P[i];
    da[i] = P[9 + i] - P[i];
  }
  // N1 = e x ca = (b - a) x (c - a);  N2 = (a - b) x (d - b) = da x e.
  const double N1[3] = {e[1] * ca[2] - e[2] * ca[1], e[2] * ca[0] - e[0] * ca[2], e[0] * ca[1] - e[1] * ca[0]};
  const double N2[3] = {da[1] * e[2] - da[2] * e[1], da[2] * e[0] - da[0] * e[2], da[0] * e[1] - da[1] * e[0]};
  const double l2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  const double l = std::sqrt(l2);
  const double X[3] = {N1[1] * N2[2] - N1[2] * N2[1], N1[2] * N2[0] - N1[0] * N2[2], N1[0] * N2[1] - N1[1] * N2[0]};
  const double s = (X[0] * e[0] + X[1] * e[1] + X[2] * e[2]) / l;
  const double c = N1[0] * N2[0] + N1[1] * N2[1] + N1[2] * N2[2];
  const double theta = std::atan2(s, c);
  if (g) {
    const double n1sq = N1[0] * N1[0] + N1[1] * N1[1] + N1[2] * N1[2];
    const double n2sq = N2[0] * N2[0] + N2[1] * N2[1] + N2[2] * N2[2];
    const double sc = (ca[0] * e[0] + ca[1] * e[1] + ca[2] * e[2]) / l2;
    const double sd = (da[0] * e[0] + da[1] * e[1] + da[2] * e[2]) / l2;
    for (int i = 0; i < 3; ++i) {
      const double tc = -l * N1[i] / n1sq, td = -l * N2[i] / n2sq;  // d theta / dc, d theta / dd
      const double ta = -(1.0 - sc) * tc - (1.0 - sd) * td;
      const double tb = -sc * tc - sd * td;
      const double eh = e[i] / l;  // d l / db = -d l / da
      g[i] = -theta * eh + l * ta;
      g[3 + i] = theta * eh + l * tb;
      g[6 + i] = l * tc;
      g[9 + i] = l * td;
    }
  }
  return l * theta;
}

// Area of triangle (p0, p1, p2) (P[0..8]); with g non-null also dArea/dp_s in g[3 s + d]: (1/2) n x (p_{s+2} - p_{s+1}).
inline double bending_triangle_area(const double* P, double* g) {
  double u[3], v[3];
  for (int i = 0; i < 3; ++i) {
    u[i] = P[3 + i] - P[i];
    v[i] = P[6 + i] - P[i];
  }
  const double N[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double nn = std::sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
  if (g) {
    const double n[3] = {N[0] / nn, N[1] / nn, N[2] / nn};
    for (int s = 0; s < 3; ++s) {
      const double* p1 = P + 3 * ((s + 1) % 3);
      const double* p2 = P + 3 * ((s + 2) % 3);
      const double w[3] = {p2[0] - p1[0], p2[1] - p1[1], p2[2] - p1[2]};
      g[3 * s + 0] = 0.5 * (n[1] * w[2] - n[2] * w[1]);
      g[3 * s + 1] = 0.5 * (n[2] * w[0] - n[0] * w[2]);
      g[3 * s + 2] = 0.5 * (n[0] * w[1] - n[1] * w[0]);
    }
  }
  return 0.5 * nn;
}

// The Voronoi (circumcentric) parts V[s] of triangle P's area at its corners: with w_k = l_k^2 cot(alpha_k), l_k the
// edge opposite corner k, V_s = (w_{s+1} + w_{s+2}) / 8 (Meyer et al. 2003; sum V = area for any triangle, and V_s < 0
// only at a corner next to an obtuse angle). With beta non-null also out[3 r + d] = -sum_s beta_s dV_s/dp_r.
inline void bending_voronoi(const double* P, double* V, const double* beta, double* out) {
  double gA[9];
  const double A = bending_triangle_area(P, beta ? gA : nullptr);
  double w[3], cot[3], L2[3];
  for (int k = 0; k < 3; ++k) {
    const double* p = P + 3 * k;
    const double* q = P + 3 * ((k + 1) % 3);
    const double* r = P + 3 * ((k + 2) % 3);
    double D = 0.0;
    L2[k] = 0.0;
    for (int d = 0; d < 3; ++d) {
      D += (q[d] - p[d]) * (r[d] - p[d]);
      L2[k] += (q[d] - r[d]) * (q[d] - r[d]);
    }
    cot[k] = D / (2.0 * A);
    w[k] = L2[k] * cot[k];
  }
  for (int s = 0; s < 3; ++s) V[s] = 0.125 * (w[(s + 1) % 3] + w[(s + 2) % 3]);
  if (!beta) return;
  for (int i = 0; i < 9; ++i) out[i] = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double c = -0.125 * (beta[(k + 1) % 3] + beta[(k + 2) % 3]);  // -(sum of beta_s over the V_s holding w_k)
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    const double* p = P + 3 * k;
    const double* q = P + 3 * k1;
    const double* r = P + 3 * k2;
    for (int d = 0; d < 3; ++d) {
      // d cot_k = (dD_k - 2 cot_k dA) / (2A), dD_k/dq = r - p, dD_k/dr = q - p, dD_k/dp = -(q - p) - (r - p).
      const double dD[3] = {-(q[d] - p[d]) - (r[d] - p[d]), r[d] - p[d], q[d] - p[d]};
      const int corner[3] = {k, k1, k2};
      for (int j = 0; j < 3; ++j) {
        const int rr = corner[j];
        const double dcot = (dD[j] - 2.0 * cot[k] * gA[3 * rr + d]) / (2.0 * A);
        // d(l_k^2) = 2 (q - r) at q, -2 (q - r) at r.
        const double dL2 = j == 1 ? 2.0 * (q[d] - r[d]) : j == 2 ? -2.0 * (q[d] - r[d]) : 0.0;
        out[3 * rr + d] += c * (L2[k] * dcot + cot[k] * dL2);
      }
    }
  }
}

CAPSFLOW_DEVICE_END

// Adds the bending nodal forces (-dE/dx, kappa per capsule, ncap values) to Fx/Fy/Fz and sets the density on the
// fluid fx = Fx / node_area (node_area as membrane_forces left it: the barycentric lumped areas that every other
// density of the single layer uses; the Voronoi areas belong to the energy only). Call after
// membrane_forces. The backend must have passed require_backend().
void bending_forces(Backend backend, int ncap, const BendingTopology& mesh, const double* kappa, const double* x,
                    const double* y, const double* z, BendingWork work, double* Fx, double* Fy, double* Fz,
                    const double* node_area, double* fx, double* fy, double* fz);

// Serial diagnostics (tests, output): the bending energy of each capsule (energy[ncap]) and, when H is non-null,
// every node's discrete mean curvature H_i = M_i / A_i (ncap * nv values; A_i the Voronoi area).
void bending_energy(int ncap, const BendingTopology& mesh, const double* kappa, const double* x, const double* y,
                    const double* z, double* energy, double* H = nullptr);

}  // namespace capsflow
