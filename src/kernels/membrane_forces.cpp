// The implementation of membrane_forces.hpp: the elastic membrane forces on flat linear triangles.
#include "kernels/membrane_forces.hpp"

#include <stdexcept>

#include "kernels/dispatch.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

// Pass 1, element t of capsule k: 9 force components and the current area into ebuf[10 e ..], e = k ntri + t.
// (k, t) rather than a flat index: a 64-bit division per element costs as much as a third of its arithmetic.
inline void element_pass(long k, long t, const MembraneLaw* law, const double* Cs, int nv, int ntri, const int* tri,
                         const double* A0, const double* g1x, const double* g1y, const double* g2x, const double* g2y,
                         const double* Gs, const double* x, const double* y, const double* z, double* ebuf) {
  const long e = k * ntri + t;
  const long base = k * nv;
  const long i0 = base + tri[3 * t], i1 = base + tri[3 * t + 1], i2 = base + tri[3 * t + 2];
  double energy;
  membrane_element_forces(law[k], Gs[k], Cs[k], x[i0], y[i0], z[i0], x[i1], y[i1], z[i1], x[i2], y[i2], z[i2], A0[e],
                          g1x[e], g1y[e], g2x[e], g2y[e], ebuf + 10 * e, ebuf[10 * e + 9], energy);
}

// Pass 2, node `local` of capsule k: gather over its incident (triangle, corner) pairs in CSR order.
inline void node_pass(long k, long local, int nv, int ntri, const int* inc_offsets, const int* inc_tri, const int* inc_corner,
                      const double* ebuf, double* Fx, double* Fy, double* Fz, double* node_area, double* fx,
                      double* fy, double* fz) {
  const long i = k * nv + local;
  double sx = 0.0, sy = 0.0, sz = 0.0, sa = 0.0;
  for (int j = inc_offsets[local]; j < inc_offsets[local + 1]; ++j) {
    const double* eb = ebuf + 10 * (k * ntri + inc_tri[j]);
    const int c = inc_corner[j];
    sx += eb[3 * c];
    sy += eb[3 * c + 1];
    sz += eb[3 * c + 2];
    sa += eb[9];
  }
  sa *= (1.0 / 3.0);
  if (Fx) {
    Fx[i] = sx;
    Fy[i] = sy;
    Fz[i] = sz;
  }
  node_area[i] = sa;
  // Force on the fluid = +elastic nodal force / lumped area (pitfall P1).
  fx[i] = sx / sa;
  fy[i] = sy / sa;
  fz[i] = sz / sa;
}

CAPSFLOW_DEVICE_END

}  // namespace

void membrane_reference(int ncap, int nv, int ntri, const int* tri, const double* X, const double* Y, const double* Z,
                        double* area0, double* g1x, double* g1y, double* g2x, double* g2y) {
  for (long k = 0; k < ncap; ++k)
    for (long t = 0; t < ntri; ++t) {
      const long e = k * ntri + t;
      const long i0 = k * nv + tri[3 * t], i1 = k * nv + tri[3 * t + 1], i2 = k * nv + tri[3 * t + 2];
      membrane_reference_element(X[i0], Y[i0], Z[i0], X[i1], Y[i1], Z[i1], X[i2], Y[i2], Z[i2], area0[e], g1x[e],
                                 g1y[e], g2x[e], g2y[e]);
    }
}

void membrane_forces(Backend backend, const MembraneLaw* law, const double* Cs, int ncap, const MeshTopology& mesh,
                     const MembraneReference& ref, const double* Gs, const double* x, const double* y, const double* z,
                     MembraneWork work, double* Fx, double* Fy, double* Fz, double* node_area, double* fx, double* fy,
                     double* fz) {
  const int nv = mesh.nv, ntri = mesh.ntri;
  const int *tri = mesh.tri, *inc_offsets = mesh.inc_offsets, *inc_tri = mesh.inc_tri, *inc_corner = mesh.inc_corner;
  const double *A0 = ref.area0, *g1x = ref.g1x, *g1y = ref.g1y, *g2x = ref.g2x, *g2y = ref.g2y;
  double* ebuf = work.element;

  switch (backend) {
    case Backend::Serial:
      for (long k = 0; k < ncap; ++k)
        for (long t = 0; t < ntri; ++t)
          element_pass(k, t, law, Cs, nv, ntri, tri, A0, g1x, g1y, g2x, g2y, Gs, x, y, z, ebuf);
      for (long k = 0; k < ncap; ++k)
        for (long v = 0; v < nv; ++v)
          node_pass(k, v, nv, ntri, inc_offsets, inc_tri, inc_corner, ebuf, Fx, Fy, Fz, node_area, fx, fy, fz);
      return;
    case Backend::Threads:
#pragma omp parallel
    {
      // Static schedule over capsules: each thread gathers mostly its own capsules' elements (cache-warm).
#pragma omp for schedule(static)
      for (long k = 0; k < ncap; ++k)
        for (long t = 0; t < ntri; ++t)
          element_pass(k, t, law, Cs, nv, ntri, tri, A0, g1x, g1y, g2x, g2y, Gs, x, y, z, ebuf);
      // The implicit barrier of the first loop orders the two passes.
#pragma omp for schedule(static)
      for (long k = 0; k < ncap; ++k)
        for (long v = 0; v < nv; ++v)
          node_pass(k, v, nv, ntri, inc_offsets, inc_tri, inc_corner, ebuf, Fx, Fy, Fz, node_area, fx, fy, fz);
    }
      return;
    case Backend::Device: {
#ifdef CAPSFLOW_HAVE_OFFLOAD
      const long ne = static_cast<long>(ncap) * ntri, nn = static_cast<long>(ncap) * nv;
      const int n3 = 3 * ntri;
      // Nodal force output is optional: map a dummy when absent so the clauses stay uniform.
      double dummy[3] = {0, 0, 0};
      const bool want_F = Fx != nullptr;
      double *pFx = want_F ? Fx : dummy, *pFy = want_F ? Fy : dummy + 1, *pFz = want_F ? Fz : dummy + 2;
      const long nF = want_F ? nn : 1;
#pragma omp target data map(to : tri[0 : n3], inc_offsets[0 : nv + 1], inc_tri[0 : n3], inc_corner[0 : n3],      \
                                A0[0 : ne], g1x[0 : ne], g1y[0 : ne], g2x[0 : ne], g2y[0 : ne], Gs[0 : ncap],        \
                                law[0 : ncap], Cs[0 : ncap],                                                        \
                                x[0 : nn], y[0 : nn], z[0 : nn]) map(alloc : ebuf[0 : 10 * ne])                        \
    map(from : pFx[0 : nF], pFy[0 : nF], pFz[0 : nF], node_area[0 : nn], fx[0 : nn], fy[0 : nn], fz[0 : nn])
      {
#pragma omp target teams distribute parallel for collapse(2)
        for (long k = 0; k < ncap; ++k)
          for (long t = 0; t < ntri; ++t)
            element_pass(k, t, law, Cs, nv, ntri, tri, A0, g1x, g1y, g2x, g2y, Gs, x, y, z, ebuf);
#pragma omp target teams distribute parallel for collapse(2)
        for (long k = 0; k < ncap; ++k)
          for (long v = 0; v < nv; ++v)
            node_pass(k, v, nv, ntri, inc_offsets, inc_tri, inc_corner, ebuf, want_F ? pFx : nullptr, pFy, pFz,
                      node_area, fx, fy, fz);
      }
#else
      device_not_built(__func__);
#endif
      return;
    }
  }
}

void membrane_energy(const MembraneLaw* law, const double* Cs, int ncap, const MeshTopology& mesh,
                     const MembraneReference& ref, const double* Gs, const double* x, const double* y, const double* z,
                     double* energy) {
  for (long k = 0; k < ncap; ++k) {
    double sum = 0.0;
    for (long t = 0; t < mesh.ntri; ++t) {
      const long e = k * mesh.ntri + t;
      const long i0 = k * mesh.nv + mesh.tri[3 * t], i1 = k * mesh.nv + mesh.tri[3 * t + 1],
                 i2 = k * mesh.nv + mesh.tri[3 * t + 2];
      double f[9], area, en;
      membrane_element_forces(law[k], Gs[k], Cs[k], x[i0], y[i0], z[i0], x[i1], y[i1], z[i1], x[i2], y[i2], z[i2],
                              ref.area0[e], ref.g1x[e], ref.g1y[e], ref.g2x[e], ref.g2y[e], f, area, en);
      sum += en;
    }
    energy[k] = sum;
  }
}

}  // namespace capsflow
