#pragma once
// Per-capsule geometry of closed flat-triangle surfaces (docs/method.md §2.4; docs/method.md).
//
// Every integral is a surface integral over flat triangles (divergence theorem), evaluated exactly:
//     V = (1/3) sum_e x0 . N_e                                   (N_e = (x1-x0)x(x2-x0)/2 = A_e n_e)
//     x_c = (1/(2V)) sum_e N_e (1/3) sum_edge-midpoints |m|^2    (|x|^2 is quadratic: midpoint rule is exact)
//     M_ij = int_V r_i r_j dV = (1/5) oint r_i r_j (r.n) dS = sum_e (r0.N_e)/60 (sum_a r_a,i r_a,j + s_i s_j),
//            s = r0 + r1 + r2, r = x - p about a provisional centre p, then shifted to x_c (parallel axes)
//     U = (1/V) oint x (u.n) dS      (u linear on each triangle: midpoint rule, exact)
//     Omega_jk = (1/V) oint u_j n_k dS,  omega_i = (1/2) eps_ijk Omega_kj   (rigid rotation w gives omega = w)
// Loops run over capsules (each capsule's triangles sequentially), so every backend gives the same sums.
#include <cmath>

#include "kernels/backend.hpp"
#include "kernels/device_macros.hpp"

namespace capsflow {

// Volume, area, centroid and second moments of one capsule (nodes x[0..nv), triangles tri[3 ntri]).
// m6 = {Mxx, Myy, Mzz, Mxy, Mxz, Myz} about the centroid.
CAPSFLOW_DEVICE_BEGIN
// Mean of a capsule's nodes: the reference point of the surface sums (keeps digits far from the origin).
inline void node_mean(int nv, const double* x, const double* y, const double* z, double& px, double& py,
                      double& pz) {
  px = py = pz = 0.0;
  for (int i = 0; i < nv; ++i) {
    px += x[i];
    py += y[i];
    pz += z[i];
  }
  px /= nv;
  py /= nv;
  pz /= nv;
}

inline void capsule_shape_moments(int nv, int ntri, const int* tri, const double* x, const double* y, const double* z,
                                  double& volume, double& area, double* centroid, double* m6) {
  // Provisional centre: the node mean, so the sums below do not lose digits far from the origin.
  double px, py, pz;
  node_mean(nv, x, y, z, px, py, pz);
  double V = 0.0, A = 0.0, qx = 0.0, qy = 0.0, qz = 0.0;
  double M[6] = {0, 0, 0, 0, 0, 0};
  for (int t = 0; t < ntri; ++t) {
    const int i0 = tri[3 * t], i1 = tri[3 * t + 1], i2 = tri[3 * t + 2];
    const double r0[3] = {x[i0] - px, y[i0] - py, z[i0] - pz};
    const double r1[3] = {x[i1] - px, y[i1] - py, z[i1] - pz};
    const double r2[3] = {x[i2] - px, y[i2] - py, z[i2] - pz};
    const double a[3] = {r1[0] - r0[0], r1[1] - r0[1], r1[2] - r0[2]};
    const double b[3] = {r2[0] - r0[0], r2[1] - r0[1], r2[2] - r0[2]};
    const double N[3] = {0.5 * (a[1] * b[2] - a[2] * b[1]), 0.5 * (a[2] * b[0] - a[0] * b[2]),
                         0.5 * (a[0] * b[1] - a[1] * b[0])};
    A += std::sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
    const double h = r0[0] * N[0] + r0[1] * N[1] + r0[2] * N[2];
    V += h / 3.0;
    double q = 0.0;  // sum over edge midpoints of |m|^2
    for (int d = 0; d < 3; ++d) {
      const double m01 = 0.5 * (r0[d] + r1[d]), m12 = 0.5 * (r1[d] + r2[d]), m20 = 0.5 * (r2[d] + r0[d]);
      q += m01 * m01 + m12 * m12 + m20 * m20;
    }
    qx += N[0] * q / 3.0;
    qy += N[1] * q / 3.0;
    qz += N[2] * q / 3.0;
    const double s[3] = {r0[0] + r1[0] + r2[0], r0[1] + r1[1] + r2[1], r0[2] + r1[2] + r2[2]};
    const int ii[6] = {0, 1, 2, 0, 0, 1}, jj[6] = {0, 1, 2, 1, 2, 2};
    for (int c = 0; c < 6; ++c) {
      const int i = ii[c], j = jj[c];
      M[c] += h / 60.0 * (r0[i] * r0[j] + r1[i] * r1[j] + r2[i] * r2[j] + s[i] * s[j]);
    }
  }
  volume = V;
  area = A;
  const double d[3] = {qx / (2.0 * V), qy / (2.0 * V), qz / (2.0 * V)};  // centroid - p
  centroid[0] = px + d[0];
  centroid[1] = py + d[1];
  centroid[2] = pz + d[2];
  const int ii[6] = {0, 1, 2, 0, 0, 1}, jj[6] = {0, 1, 2, 1, 2, 2};
  for (int c = 0; c < 6; ++c) m6[c] = M[c] - V * d[ii[c]] * d[jj[c]];
}

// Volume-averaged velocity U and mean rotation omega of one capsule from node velocities u (linear on each
// triangle). Exact for flat triangles.
inline void capsule_velocity_moments(int nv, int ntri, const int* tri, const double* x, const double* y,
                                     const double* z, const double* ux, const double* uy, const double* uz, double* U,
                                     double* omega) {
  double px, py, pz;
  node_mean(nv, x, y, z, px, py, pz);
  double V = 0.0, flux = 0.0;
  double S[3] = {0, 0, 0};                  // oint (x - p)(u.n) dS
  double G[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};  // oint u_j n_k dS, G[3 j + k]
  for (int t = 0; t < ntri; ++t) {
    const int v[3] = {tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]};
    double r[3][3], u[3][3];
    for (int c = 0; c < 3; ++c) {
      r[c][0] = x[v[c]] - px;
      r[c][1] = y[v[c]] - py;
      r[c][2] = z[v[c]] - pz;
      u[c][0] = ux[v[c]];
      u[c][1] = uy[v[c]];
      u[c][2] = uz[v[c]];
    }
    const double a[3] = {r[1][0] - r[0][0], r[1][1] - r[0][1], r[1][2] - r[0][2]};
    const double b[3] = {r[2][0] - r[0][0], r[2][1] - r[0][1], r[2][2] - r[0][2]};
    const double N[3] = {0.5 * (a[1] * b[2] - a[2] * b[1]), 0.5 * (a[2] * b[0] - a[0] * b[2]),
                         0.5 * (a[0] * b[1] - a[1] * b[0])};
    V += (r[0][0] * N[0] + r[0][1] * N[1] + r[0][2] * N[2]) / 3.0;
    double um[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c) {
      // Edge midpoint (c, c+1): the three-midpoint rule integrates the quadratic x (u.n) exactly.
      const int c1 = (c + 1) % 3;
      double mr[3], mu[3];
      for (int d = 0; d < 3; ++d) {
        mr[d] = 0.5 * (r[c][d] + r[c1][d]);
        mu[d] = 0.5 * (u[c][d] + u[c1][d]);
        um[d] += u[c][d] / 3.0;
      }
      const double un = mu[0] * N[0] + mu[1] * N[1] + mu[2] * N[2];
      for (int d = 0; d < 3; ++d) S[d] += mr[d] * un / 3.0;
    }
    flux += um[0] * N[0] + um[1] * N[1] + um[2] * N[2];
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) G[3 * j + k] += um[j] * N[k];
  }
  // U = (1/V) oint (x - p)(u.n) dS: equal to (1/V) oint x (u.n) dS when the flux oint u.n vanishes, as it does
  // for the divergence-free flow, but translation-invariant when the discrete flux is not exactly zero (with the
  // absolute x a capsule at x_c would pick up a spurious x_c * flux / V).
  (void)flux;
  U[0] = S[0] / V;
  U[1] = S[1] / V;
  U[2] = S[2] / V;
  // omega_i = (1/2) eps_ijk Omega_kj with Omega_kj = G[3 k + j] / V
  omega[0] = 0.5 * (G[3 * 2 + 1] - G[3 * 1 + 2]) / V;
  omega[1] = 0.5 * (G[3 * 0 + 2] - G[3 * 2 + 0]) / V;
  omega[2] = 0.5 * (G[3 * 1 + 0] - G[3 * 0 + 1]) / V;
}
CAPSFLOW_DEVICE_END

// Volume, area, centroid (3 ncap) and second moments about the centroid (6 ncap, order of
// capsule_shape_moments) of ncap capsules sharing one mesh.
void capsule_shape(Backend backend, int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                   const double* z, double* volume, double* area, double* centroid, double* moments);

// Volume-averaged velocity U (3 ncap) and mean rotation omega (3 ncap) from node velocities.
void capsule_mean_velocity(Backend backend, int ncap, int nv, int ntri, const int* tri, const double* x,
                           const double* y, const double* z, const double* ux, const double* uy, const double* uz,
                           double* U, double* omega);

// Unit outward node normals, area-weighted: n_i ~ sum over incident triangles of (x1-x0)x(x2-x0)/2.
// inc_offsets / inc_tri describe the per-capsule node->triangle incidence (host/state/icosphere.hpp).
void node_normals(Backend backend, int ncap, int nv, const int* tri, const int* inc_offsets, const int* inc_tri,
                  const double* x, const double* y, const double* z, double* nx, double* ny, double* nz);

// Gradient of each capsule's volume with respect to its node positions, w_i = dV/dx_i (3 x nn), from the same
// incidence as node_normals. sum_i w_i . u_i is the discrete volume rate of node velocities u.
void volume_gradient(Backend backend, int ncap, int nv, const int* tri, const int* inc_offsets, const int* inc_tri,
                     const double* x, const double* y, const double* z, double* wx, double* wy, double* wz);
// Projects node velocities to zero discrete volume rate per capsule with the minimal-norm correction
// u_i <- u_i - lambda w_i, lambda = sum w.u / sum w.w (D11).
void project_volume_rate(Backend backend, int ncap, int nv, const double* wx, const double* wy, const double* wz,
                         double* ux, double* uy, double* uz);

// Shortest edge of each capsule (hmin[ncap]); edges[2 nedge] as in TriMesh::edges.
void min_edge_length(Backend backend, int ncap, int nv, int nedge, const int* edges, const double* x, const double* y,
                     const double* z, double* hmin);

}  // namespace capsflow
