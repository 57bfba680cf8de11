#pragma once
// Flat-array kernels of the overlap / contact control (method-spec 8.3, decision D5; docs/method_contact.md).
//
// Capsules move rigidly during contact control, so the kernels see each node at its stored position plus a
// per-capsule offset: p_i = x_i + off[k] (k = i / nv). The host accumulates offsets over the iterations and adds
// them to the nodes once at the end, so node positions relative to the centroid change by one rounding at most.
//
// Pair gap (Amit's find_overlaps_gap): for node i of capsule P and the nearest node j of capsule Q != P,
// d = p_i - p_j (minimum image in x and z), r = |d|. If d . n_j < 0 (n_j: Q's outward node normal) node i is
// inside Q and the candidate gap is -r, else it is r. The pair gap is the minimum over both directions (P -> Q
// and Q -> P). Only nodes i within Q's bounding sphere (|p_i - c_Q| < rmax_Q + range) are examined: outside
// it every node of Q is at least `range` away, so those nodes cannot produce a gap below `range`.
// The nearest node is found by a full scan over Q's nodes (exact even for deep overlaps): O(nv) per candidate
// node.
//
// Loops run over capsules or pairs with a fixed per-item order, so every backend gives the same bits.
#include <cmath>

#include "kernels/backend.hpp"
#include "kernels/device_macros.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {

CAPSFLOW_DEVICE_BEGIN

// Gap of the ordered pair (P -> Q): nodes of P tested against the nearest nodes of Q. Returns `cap` when no node
// of P is within Q's bounding sphere + range, otherwise min(cap, smallest candidate gap).
inline double directed_gap(int nv, const double* xp, const double* yp, const double* zp, const double* offp,
                           const double* xq, const double* yq, const double* zq, const double* offq,
                           const double* nxq, const double* nyq, const double* nzq, const double* cq, double rmaxq,
                           double range, double Lx, double Lz, double cap) {
  const double reach = rmaxq + range, reach2 = reach * reach;
  // p_i - p_j = (x_i - x_j) + (offp - offq)
  const double sx = offp[0] - offq[0], sy = offp[1] - offq[1], sz = offp[2] - offq[2];
  double best = cap;
  for (int i = 0; i < nv; ++i) {
    const double pix = xp[i] + offp[0], piy = yp[i] + offp[1], piz = zp[i] + offp[2];
    const double cx = min_image(pix - cq[0], Lx), cy = piy - cq[1], cz = min_image(piz - cq[2], Lz);
    if (cx * cx + cy * cy + cz * cz >= reach2) continue;
    double r2min = 1e300, dx = 0.0, dy = 0.0, dz = 0.0;
    int jmin = 0;
    for (int j = 0; j < nv; ++j) {
      const double ex = min_image(xp[i] - xq[j] + sx, Lx), ey = yp[i] - yq[j] + sy,
                   ez = min_image(zp[i] - zq[j] + sz, Lz);
      const double r2 = ex * ex + ey * ey + ez * ez;
      if (r2 < r2min) {
        r2min = r2;
        jmin = j;
        dx = ex;
        dy = ey;
        dz = ez;
      }
    }
    const double r = std::sqrt(r2min);
    const double g = (dx * nxq[jmin] + dy * nyq[jmin] + dz * nzq[jmin] < 0.0) ? -r : r;
    best = g < best ? g : best;
  }
  return best;
}

CAPSFLOW_DEVICE_END

// Per-capsule bounds about the given centres (3 ncap): rmax[k] = max node distance from centre k (no minimum
// image: capsules are stored unwrapped), ymin[k], ymax[k] = extreme node y.
void capsule_bounds(Backend backend, int ncap, int nv, const double* x, const double* y, const double* z,
                    const double* centre, double* rmax, double* ymin, double* ymax);

// Gap of each listed pair (pairs[2 p], pairs[2 p + 1]), p < npair, as described above; `range` bounds the search
// (gaps >= range may be reported as `range`). off and centre: 3 per capsule (current centre = stored + offset).
// n{x,y,z}: outward node normals of all nodes (translation-invariant, so computed once by the caller).
void pair_gaps(Backend backend, int ncap, int nv, const double* x, const double* y, const double* z,
               const double* nx, const double* ny, const double* nz, const double* off, const double* centre,
               const double* rmax, int npair, const int* pairs, double range, double Lx, double Lz, double* gap);

}  // namespace capsflow
