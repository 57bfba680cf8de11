// The implementation of bending_forces.hpp: the membranes' bending resistance.
#include "kernels/bending_forces.hpp"

#include <vector>

#include "kernels/dispatch.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

inline void load_nodes(const int* ids, int count, long base, const double* x, const double* y, const double* z,
                       double* P) {
  for (int s = 0; s < count; ++s) {
    const long i = base + ids[s];
    P[3 * s] = x[i];
    P[3 * s + 1] = y[i];
    P[3 * s + 2] = z[i];
  }
}

// Pass 1: l theta of edge j of capsule k into ebuf[13 (k ne + j) + 12] and its gradient into ebuf[13 (..) ..11]
// (pass 3 only scales it), the Voronoi parts of triangle t into tbuf[12 (k nt + t) + 9 ..].
inline void edge_pass1(long k, long j, const BendingTopology& m, const double* x, const double* y, const double* z,
                       double* ebuf) {
  double P[12];
  load_nodes(m.quad + 4 * j, 4, k * m.nv, x, y, z, P);
  double* e = ebuf + 13 * (k * m.nedge + j);
  e[12] = bending_edge(P, e);
}

inline void triangle_pass1(long k, long t, const BendingTopology& m, const double* x, const double* y,
                           const double* z, double* tbuf) {
  double P[9];
  load_nodes(m.tri + 3 * t, 3, k * m.nv, x, y, z, P);
  bending_voronoi(P, tbuf + 12 * (k * m.ntri + t) + 9, nullptr, nullptr);
}

// M_i and A_i of node v of capsule k from the pass-1 buffers.
inline void node_curvature(long k, long v, const BendingTopology& m, const double* ebuf, const double* tbuf,
                           double& M, double& A) {
  M = 0.0;
  A = 0.0;
  for (int q = m.einc_offsets[v]; q < m.einc_offsets[v + 1]; ++q)
    if (m.einc_slot[q] < 2) M += ebuf[13 * (k * m.nedge + m.einc_edge[q]) + 12];
  for (int q = m.inc_offsets[v]; q < m.inc_offsets[v + 1]; ++q)
    A += tbuf[12 * (k * m.ntri + m.inc_tri[q]) + 9 + m.inc_corner[q]];
  M *= 0.25;
}

// Pass 2, node v of capsule k: nbuf = (dE/dM_i, dE/dA_i) for E = 2 kappa sum M^2 / A.
inline void node_pass2(long k, long v, const BendingTopology& m, const double* kappa, const double* ebuf,
                       const double* tbuf, double* nbuf) {
  double M, A;
  node_curvature(k, v, m, ebuf, tbuf, M, A);
  const double h = M / A;
  const long i = k * m.nv + v;
  nbuf[2 * i] = 4.0 * kappa[k] * h;
  nbuf[2 * i + 1] = -2.0 * kappa[k] * h * h;
}

// Pass 3: each edge's and triangle's forces on its nodes, -dE/dM * dM/dx and -dE/dA * dA/dx (A the Voronoi areas).
inline void edge_pass3(long k, long j, const BendingTopology& m, const double* nbuf, double* ebuf) {
  const int* q = m.quad + 4 * j;
  double* out = ebuf + 13 * (k * m.nedge + j);
  // l theta enters M_a and M_b with weight 1/4 each.
  const double w = -0.25 * (nbuf[2 * (k * m.nv + q[0])] + nbuf[2 * (k * m.nv + q[1])]);
  for (int s = 0; s < 12; ++s) out[s] *= w;
}

inline void triangle_pass3(long k, long t, const BendingTopology& m, const double* x, const double* y,
                           const double* z, const double* nbuf, double* tbuf) {
  const int* c = m.tri + 3 * t;
  double P[9];
  load_nodes(c, 3, k * m.nv, x, y, z, P);
  const long b = k * m.nv;
  const double beta[3] = {nbuf[2 * (b + c[0]) + 1], nbuf[2 * (b + c[1]) + 1], nbuf[2 * (b + c[2]) + 1]};
  double V[3];
  bending_voronoi(P, V, beta, tbuf + 12 * (k * m.ntri + t));
}

// Pass 4, node v of capsule k: gather in CSR order, add to F, and the density on the fluid F / A.
inline void node_pass4(long k, long v, const BendingTopology& m, const double* ebuf, const double* tbuf, double* Fx,
                       double* Fy, double* Fz, const double* node_area, double* fx, double* fy, double* fz) {
  double sx = 0.0, sy = 0.0, sz = 0.0;
  for (int q = m.einc_offsets[v]; q < m.einc_offsets[v + 1]; ++q) {
    const double* eb = ebuf + 13 * (k * m.nedge + m.einc_edge[q]) + 3 * m.einc_slot[q];
    sx += eb[0];
    sy += eb[1];
    sz += eb[2];
  }
  for (int q = m.inc_offsets[v]; q < m.inc_offsets[v + 1]; ++q) {
    const double* tb = tbuf + 12 * (k * m.ntri + m.inc_tri[q]) + 3 * m.inc_corner[q];
    sx += tb[0];
    sy += tb[1];
    sz += tb[2];
  }
  const long i = k * m.nv + v;
  Fx[i] += sx;
  Fy[i] += sy;
  Fz[i] += sz;
  fx[i] = Fx[i] / node_area[i];
  fy[i] = Fy[i] / node_area[i];
  fz[i] = Fz[i] / node_area[i];
}

CAPSFLOW_DEVICE_END

}  // namespace

void bending_forces(Backend backend, int ncap, const BendingTopology& m, const double* kappa, const double* x,
                    const double* y, const double* z, BendingWork work, double* Fx, double* Fy, double* Fz,
                    const double* node_area, double* fx, double* fy, double* fz) {
  double *ebuf = work.edge, *tbuf = work.tri, *nbuf = work.node;
  const long nc = ncap, nv = m.nv, ne = m.nedge, nt = m.ntri;
  switch (backend) {
    case Backend::Serial:
      for (long k = 0; k < nc; ++k) {
        for (long j = 0; j < ne; ++j) edge_pass1(k, j, m, x, y, z, ebuf);
        for (long t = 0; t < nt; ++t) triangle_pass1(k, t, m, x, y, z, tbuf);
      }
      for (long k = 0; k < nc; ++k)
        for (long v = 0; v < nv; ++v) node_pass2(k, v, m, kappa, ebuf, tbuf, nbuf);
      for (long k = 0; k < nc; ++k) {
        for (long j = 0; j < ne; ++j) edge_pass3(k, j, m, nbuf, ebuf);
        for (long t = 0; t < nt; ++t) triangle_pass3(k, t, m, x, y, z, nbuf, tbuf);
      }
      for (long k = 0; k < nc; ++k)
        for (long v = 0; v < nv; ++v) node_pass4(k, v, m, ebuf, tbuf, Fx, Fy, Fz, node_area, fx, fy, fz);
      return;
    case Backend::Threads:
#pragma omp parallel
    {
      // Static schedules over capsules, as in membrane_forces; the implicit barriers order the passes.
#pragma omp for schedule(static)
      for (long k = 0; k < nc; ++k) {
        for (long j = 0; j < ne; ++j) edge_pass1(k, j, m, x, y, z, ebuf);
        for (long t = 0; t < nt; ++t) triangle_pass1(k, t, m, x, y, z, tbuf);
      }
#pragma omp for schedule(static)
      for (long k = 0; k < nc; ++k)
        for (long v = 0; v < nv; ++v) node_pass2(k, v, m, kappa, ebuf, tbuf, nbuf);
#pragma omp for schedule(static)
      for (long k = 0; k < nc; ++k) {
        for (long j = 0; j < ne; ++j) edge_pass3(k, j, m, nbuf, ebuf);
        for (long t = 0; t < nt; ++t) triangle_pass3(k, t, m, x, y, z, nbuf, tbuf);
      }
#pragma omp for schedule(static)
      for (long k = 0; k < nc; ++k)
        for (long v = 0; v < nv; ++v) node_pass4(k, v, m, ebuf, tbuf, Fx, Fy, Fz, node_area, fx, fy, fz);
    }
      return;
    case Backend::Device: {
#ifdef CAPSFLOW_HAVE_OFFLOAD
      const long nn = nc * nv;
      const int mnv = m.nv, mnt = m.ntri, mne = m.nedge;  // scalars, not the host struct, go into the regions
      const int n3 = 3 * m.ntri, n4 = 4 * m.nedge;
      const int *tri = m.tri, *quad = m.quad, *io = m.inc_offsets, *it = m.inc_tri, *ic = m.inc_corner;
      const int *eo = m.einc_offsets, *ee = m.einc_edge, *es = m.einc_slot;
#pragma omp target data map(to : tri[0 : n3], quad[0 : n4], io[0 : nv + 1], it[0 : n3], ic[0 : n3], eo[0 : nv + 1], \
                                ee[0 : n4], es[0 : n4], kappa[0 : nc], x[0 : nn], y[0 : nn], z[0 : nn],            \
                                node_area[0 : nn])                                                                 \
    map(alloc : ebuf[0 : 13 * nc * ne], tbuf[0 : 12 * nc * nt], nbuf[0 : 2 * nn])                                  \
    map(tofrom : Fx[0 : nn], Fy[0 : nn], Fz[0 : nn]) map(from : fx[0 : nn], fy[0 : nn], fz[0 : nn])
      {
        // The topology struct holds host pointers: rebuild it inside the regions from the mapped arrays.
#pragma omp target teams distribute parallel for collapse(2)
        for (long k = 0; k < nc; ++k)
          for (long j = 0; j < ne + nt; ++j) {
            const BendingTopology d{mnv, mnt, mne, tri, quad, io, it, ic, eo, ee, es};
            if (j < ne)
              edge_pass1(k, j, d, x, y, z, ebuf);
            else
              triangle_pass1(k, j - ne, d, x, y, z, tbuf);
          }
#pragma omp target teams distribute parallel for collapse(2)
        for (long k = 0; k < nc; ++k)
          for (long v = 0; v < nv; ++v) {
            const BendingTopology d{mnv, mnt, mne, tri, quad, io, it, ic, eo, ee, es};
            node_pass2(k, v, d, kappa, ebuf, tbuf, nbuf);
          }
#pragma omp target teams distribute parallel for collapse(2)
        for (long k = 0; k < nc; ++k)
          for (long j = 0; j < ne + nt; ++j) {
            const BendingTopology d{mnv, mnt, mne, tri, quad, io, it, ic, eo, ee, es};
            if (j < ne)
              edge_pass3(k, j, d, nbuf, ebuf);
            else
              triangle_pass3(k, j - ne, d, x, y, z, nbuf, tbuf);
          }
#pragma omp target teams distribute parallel for collapse(2)
        for (long k = 0; k < nc; ++k)
          for (long v = 0; v < nv; ++v) {
            const BendingTopology d{mnv, mnt, mne, tri, quad, io, it, ic, eo, ee, es};
            node_pass4(k, v, d, ebuf, tbuf, Fx, Fy, Fz, node_area, fx, fy, fz);
          }
      }
#else
      device_not_built(__func__);
#endif
      return;
    }
  }
}

void bending_energy(int ncap, const BendingTopology& m, const double* kappa, const double* x, const double* y,
                    const double* z, double* energy, double* H) {
  // Pass 1 into scratch, then the same per-node sums as the kernel's pass 2: one definition of M_i and A_i.
  std::vector<double> ebuf(13 * static_cast<std::size_t>(m.nedge)), tbuf(12 * static_cast<std::size_t>(m.ntri));
  for (long k = 0; k < ncap; ++k) {
    for (long j = 0; j < m.nedge; ++j) edge_pass1(0, j, m, x + k * m.nv, y + k * m.nv, z + k * m.nv, ebuf.data());
    for (long t = 0; t < m.ntri; ++t)
      triangle_pass1(0, t, m, x + k * m.nv, y + k * m.nv, z + k * m.nv, tbuf.data());
    double E = 0.0;
    for (long v = 0; v < m.nv; ++v) {
      double M, A;
      node_curvature(0, v, m, ebuf.data(), tbuf.data(), M, A);
      E += 2.0 * kappa[k] * M * M / A;
      if (H) H[k * m.nv + v] = M / A;
    }
    energy[k] = E;
  }
}

}  // namespace capsflow
