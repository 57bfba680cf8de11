#pragma once
// Exact interior volume of a closed triangulated capsule below a plane y = c, and per-slab volumes over the slit
// (docs/analysis.md §7).
//
// Algorithm. For a closed, outward-oriented surface S and F = (0, y - c, 0), div F = 1 and F vanishes on the plane
// y = c, so the divergence theorem over the part of the interior below the plane gives
//     V_below(c) = int_{S and y < c} (y - c) n_y dS .
// Each triangle is clipped to y < c (Sutherland-Hodgman against one plane: a triangle or a quadrilateral), the
// clipped polygon is fanned into sub-triangles (p1, p2, p3), and each adds A_y ((y1 + y2 + y3)/3 - c) with
// A_y = 1/2 [(p2 - p1) x (p3 - p1)]_y. The integrand is linear on each flat piece, so the sum is exact for the
// polyhedron: V_below(+inf) is the mesh volume (1/3) oint x.n dS, and a slab's volume is
// V_below(c_hi) - V_below(c_lo). A vertex or a whole face lying on the plane is harmless: pieces of zero height or
// zero projected area add zero, and every intersection is taken on an edge with one end strictly below the plane
// and the other at or above it, so no division is by zero.
//
// Cost: one pass over a capsule's triangles per cut plane, and only the planes inside the capsule's y-extent are
// cut (about 2a / slab width + 1 of them), i.e. O(triangles x spanned slabs) per capsule.
//
// Usage (recording per species at a series record; out holds nslots * nbins doubles, zeroed by the caller):
//     species_slab_volumes(ncap, nv, ntri, tri, x, y, z, species, H, nbins, out);
#include "kernels/device_macros.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN

// Contribution of one triangle (p0, p1, p2), given counter-clockwise seen from outside, to V_below(c): the
// integral of (y - c) n_y over its part with y < c. Coordinates y enter through d = y - c only.
inline double triangle_volume_below(double x0, double y0, double z0, double x1, double y1, double z1, double x2,
                                    double y2, double z2, double c) {
  const double px[3] = {x0, x1, x2}, pd[3] = {y0 - c, y1 - c, y2 - c}, pz[3] = {z0, z1, z2};
  const bool in[3] = {pd[0] < 0.0, pd[1] < 0.0, pd[2] < 0.0};
  if (!in[0] && !in[1] && !in[2]) return 0.0;
  // Clipped polygon (at most 4 vertices), in the triangle's orientation.
  double qx[4], qd[4], qz[4];
  int n = 0;
  for (int a = 0; a < 3; ++a) {
    const int b = a == 2 ? 0 : a + 1;
    if (in[a]) {
      qx[n] = px[a];
      qd[n] = pd[a];
      qz[n] = pz[a];
      ++n;
    }
    if (in[a] != in[b]) {
      // One end strictly below (d < 0), the other at or above (d >= 0): pd[a] - pd[b] != 0.
      const double t = pd[a] / (pd[a] - pd[b]);
      qx[n] = px[a] + t * (px[b] - px[a]);
      qd[n] = 0.0;  // on the plane
      qz[n] = pz[a] + t * (pz[b] - pz[a]);
      ++n;
    }
  }
  double v = 0.0;
  for (int k = 1; k + 1 < n; ++k) {
    const double ax = qx[k] - qx[0], az = qz[k] - qz[0];
    const double bx = qx[k + 1] - qx[0], bz = qz[k + 1] - qz[0];
    const double Ay = 0.5 * (az * bx - ax * bz);  // y component of (a x b) / 2
    v += Ay * (qd[0] + qd[k] + qd[k + 1]) / 3.0;
  }
  return v;
}

// V_below(c) of one capsule: nodes x, y, z (local numbering), ntri triangles tri[3 ntri], outward orientation.
inline double capsule_volume_below(int ntri, const int* tri, const double* x, const double* y, const double* z,
                                   double c) {
  double v = 0.0;
  for (int t = 0; t < ntri; ++t) {
    const int i0 = tri[3 * t], i1 = tri[3 * t + 1], i2 = tri[3 * t + 2];
    v += triangle_volume_below(x[i0], y[i0], z[i0], x[i1], y[i1], z[i1], x[i2], y[i2], z[i2], c);
  }
  return v;
}

// Adds (does not overwrite) one capsule's interior volume in each of nbins equal slabs [j H/nbins, (j+1) H/nbins)
// of [0, H] to out[j]. Only the slabs the capsule's nodes span are touched; volume outside [0, H] (a capsule that
// crosses a wall, which the contact model forbids) is not counted. The bottom cut of the lowest spanned slab is
// taken as exactly 0 when it lies at or below every node.
inline void capsule_slab_volumes(int nv, int ntri, const int* tri, const double* x, const double* y, const double* z,
                                 double H, int nbins, double* out) {
  if (nv <= 0 || nbins <= 0) return;
  double ymin = y[0], ymax = y[0];
  for (int i = 1; i < nv; ++i) {
    ymin = y[i] < ymin ? y[i] : ymin;
    ymax = y[i] > ymax ? y[i] : ymax;
  }
  // Spanned slabs jlo..jhi, clamped to the slit (clamping before the cast keeps it defined for any y).
  const double w = H / nbins, top = nbins - 1;
  const double rlo = ymin / w, rhi = ymax / w;
  int jlo = static_cast<int>(rlo < 0.0 ? 0.0 : (rlo > top ? top : rlo));
  int jhi = static_cast<int>(rhi < 0.0 ? 0.0 : (rhi > top ? top : rhi));
  // The planes are at H j / nbins, which may round differently from j w: widen so they bracket the nodes.
  while (jlo > 0 && H * jlo / nbins > ymin) --jlo;
  while (jhi < nbins - 1 && H * (jhi + 1) / nbins < ymax) ++jhi;
  // Plane j is at c_j = H j / nbins (H * j first, so c_nbins == H exactly).
  double c = H * jlo / nbins;
  double below = c <= ymin ? 0.0 : capsule_volume_below(ntri, tri, x, y, z, c);
  for (int j = jlo; j <= jhi; ++j) {
    c = H * (j + 1) / nbins;
    const double next = capsule_volume_below(ntri, tri, x, y, z, c);
    out[j] += next - below;
    below = next;
  }
}

CAPSFLOW_DEVICE_END

// V_below(c) of each of ncap capsules sharing one mesh (capsule k: nodes k nv .. k nv + nv - 1); below[ncap].
void capsules_volume_below(int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                           const double* z, double c, double* below);

// Per-species slab volumes at one record: adds capsule k's slab volumes (nbins equal slabs over [0, H]) to
// out[slot[k] * nbins + j]. out is not cleared. Serial, in capsule order (deterministic sums).
void species_slab_volumes(int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                          const double* z, const int* slot, double H, int nbins, double* out);

}  // namespace capsflow
