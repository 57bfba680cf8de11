#pragma once
// Flat-array kernels of the overlap / contact control (docs/method_contact.md, decision D5; docs/method_contact.md).
//
// Capsules move rigidly during contact control, so the kernels see each node at its stored position plus a
// per-capsule offset: p_i = x_i + off[k] (k = i / nv). The host accumulates offsets over the iterations and adds
// them to the nodes once at the end, so node positions relative to the centroid change by one rounding at most.
//
// Pair gap (decision D5): the signed distance of a node to the other capsule's triangulated surface, not to its
// nearest node (a node facing the middle of a triangle is closer to the triangle than to its corners; with the old
// node-node gap a vertex 0.005 above a face centroid read as -0.15). For node i of P:
//   1. j = Q's node nearest to p_i (full scan over Q, minimum image in x and z; exact even for deep overlaps).
//   2. Exact point-triangle distance (closest point in the interior, on an edge or at a corner; Ericson 5.1.5) to
//      the triangles around j and around j's neighbours. The 1-ring of j alone is not enough: on a deformed mesh
//      the closest point can lie on a triangle without j as a corner (test ContactSignedDistance.*).
//   3. Sign from the closest feature's pseudo-normal (Baerentzen & Aanaes 2005): the face normal for an interior
//      point, the sum of the two face normals for an edge, the angle-weighted sum of the incident face normals for
//      a corner. For a closed, consistently oriented mesh this sign is exact: negative means inside Q.
// The pair gap is the minimum over the nodes of both capsules (P -> Q and Q -> P), capped at `range`. Only nodes
// within the other capsule's bounding sphere + range are examined: outside it the whole surface is >= range away.
//
// Push amount: moving P by +s e and Q by -s e changes the gap of a node of P by 2 s (e . n), with n the outward
// normal of Q at the closest point (for a node of Q: by 2 s (-e . n_P)). A node with gap g < min_gap therefore
// needs a relative displacement (target - g) / (e . n) along e to end at `target`; `need` is the largest such
// value over the violating nodes of the pair, with e . n floored at min_alignment (a grazing or reversed contact,
// e . n <= 0, would otherwise ask for an unbounded push; iterations finish the job).
// n is the exact gradient of the distance: the face normal for an interior closest point, (p - c) / |p - c| (signed)
// at an edge or a corner, falling back to the pseudo-normal when p is on the surface.
//
// Loops run over capsules or pairs with a fixed per-item order, so every backend gives the same bits.
#include <cmath>

#include "kernels/backend.hpp"
#include "kernels/device_macros.hpp"
#include "kernels/ggem_kernels.hpp"
#include "kernels/membrane_forces.hpp"
#include "kernels/surface_views.hpp"

namespace capsflow {

// Thresholds of the pair test, in units of a.
struct PairGapLimits {
  double range = 0.0;          // search range: gaps >= range are reported as range
  double limit = 0.0;          // a node with gap < limit violates (min_gap less a round-off allowance)
  double target = 0.0;         // the gap a proportional push aims at (1.01 min_gap)
  double min_alignment = 0.0;  // floor of e . n in the push amount
};

// The collision cap's thresholds: gaps >= range are reported as range; a gap closes in max(g, floor) / w.
struct ClosingThresholds {
  double range = 0.0;
  double floor = 0.0;
};

// One capsule of a directed pair search (a view; device code builds it from mapped pointers): its nodes (nv each),
// for the closing rate their velocities, the rigid offset added to its nodes (3; the gap search only), its current
// centre (3) and its bounding radius about it.
struct PairSide {
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
  const double* ux = nullptr;
  const double* uy = nullptr;
  const double* uz = nullptr;
  const double* off = nullptr;
  const double* centre = nullptr;
  double rmax = 0.0;
};

CAPSFLOW_DEVICE_BEGIN

// Closest-feature codes of closest_point_on_triangle.
constexpr int kTriInterior = 0;  // 1, 2, 3: corner a, b, c; 4, 5, 6: edge ab, bc, ca
constexpr int kTriCorner = 1;
constexpr int kTriEdge = 4;

// Closest point cp on triangle (a, b, c) to the origin (coordinates relative to the query point), Ericson, Real-Time
// Collision Detection, 5.1.5. Returns the squared distance and sets feature (codes above). In the interior the
// distance is taken from the plane, (a . n)^2, which keeps point-to-plane distances exact to rounding.
// uw (optional): cp = a + uw[0] (b - a) + uw[1] (c - a), i.e. barycentric weights (1 - u - w, u, w).
inline double closest_point_on_triangle(const double* a, const double* b, const double* c, double* cp, int& feature,
                                        double* uw = nullptr) {
  const double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double ac[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  // p = 0, so p - a = -a etc.
  const double d1 = -(ab[0] * a[0] + ab[1] * a[1] + ab[2] * a[2]);
  const double d2 = -(ac[0] * a[0] + ac[1] * a[1] + ac[2] * a[2]);
  double u = 0.0, w = 0.0;  // cp = a + u ab + w ac
  if (d1 <= 0.0 && d2 <= 0.0) {
    feature = kTriCorner;
  } else {
    const double d3 = -(ab[0] * b[0] + ab[1] * b[1] + ab[2] * b[2]);
    const double d4 = -(ac[0] * b[0] + ac[1] * b[1] + ac[2] * b[2]);
    const double d5 = -(ab[0] * c[0] + ab[1] * c[1] + ab[2] * c[2]);
    const double d6 = -(ac[0] * c[0] + ac[1] * c[1] + ac[2] * c[2]);
    const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
    if (d3 >= 0.0 && d4 <= d3) {
      feature = kTriCorner + 1;
      u = 1.0;
    } else if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
      feature = kTriEdge;
      u = d1 / (d1 - d3);
    } else if (d6 >= 0.0 && d5 <= d6) {
      feature = kTriCorner + 2;
      w = 1.0;
    } else if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
      feature = kTriEdge + 2;
      w = d2 / (d2 - d6);
    } else if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
      feature = kTriEdge + 1;
      const double t = (d4 - d3) / ((d4 - d3) + (d5 - d6));  // cp = b + t (c - b)
      u = 1.0 - t;
      w = t;
    } else {
      feature = kTriInterior;
      const double den = 1.0 / (va + vb + vc);
      u = vb * den;
      w = vc * den;
    }
  }
  for (int d = 0; d < 3; ++d) cp[d] = a[d] + u * ab[d] + w * ac[d];
  if (uw) {
    uw[0] = u;
    uw[1] = w;
  }
  if (feature == kTriInterior) {
    const double n[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0]};
    const double h = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
    return h * h / (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  }
  return cp[0] * cp[0] + cp[1] * cp[1] + cp[2] * cp[2];
}

// Position of node v relative to the query point: r_v = (x_v - x_j) - d, with d = p - x_j (minimum image), so the
// whole neighbourhood is in the query point's image and the numbers stay small.
inline void contact_relative(int v, int j, const double* x, const double* y, const double* z, const double* d,
                             double* r) {
  r[0] = (x[v] - x[j]) - d[0];
  r[1] = (y[v] - y[j]) - d[1];
  r[2] = (z[v] - z[j]) - d[2];
}

// Adds w * (unit normal of triangle t) to n. Node coordinates of one capsule; differences only.
inline void add_face_normal(int t, const int* tri, const double* x, const double* y, const double* z, double w,
                            double* n) {
  const int a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
  const double u[3] = {x[b] - x[a], y[b] - y[a], z[b] - z[a]};
  const double v[3] = {x[c] - x[a], y[c] - y[a], z[c] - z[a]};
  const double N[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double s = w / std::sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]);
  n[0] += s * N[0];
  n[1] += s * N[1];
  n[2] += s * N[2];
}

// Pseudo-normal (not normalised) of the closest feature `feature` of triangle t (Baerentzen & Aanaes): face normal;
// edge: sum of the unit normals of the two triangles sharing it; corner: sum of the unit normals of its triangles,
// each weighted by the triangle's angle at the corner.
inline void feature_pseudo_normal(int t, int feature, const int* tri, const int* inc_offsets, const int* inc_tri,
                                  const int* inc_corner, const double* x, const double* y, const double* z,
                                  double* n) {
  n[0] = n[1] = n[2] = 0.0;
  if (feature == kTriInterior) {
    add_face_normal(t, tri, x, y, z, 1.0, n);
  } else if (feature < kTriEdge) {
    const int v = tri[3 * t + feature - kTriCorner];
    for (int f = inc_offsets[v]; f < inc_offsets[v + 1]; ++f) {
      const int s = inc_tri[f], c = inc_corner[f];
      const int b = tri[3 * s + (c + 1) % 3], e = tri[3 * s + (c + 2) % 3];
      const double u[3] = {x[b] - x[v], y[b] - y[v], z[b] - z[v]};
      const double w[3] = {x[e] - x[v], y[e] - y[v], z[e] - z[v]};
      const double N[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      const double angle =
          std::atan2(std::sqrt(N[0] * N[0] + N[1] * N[1] + N[2] * N[2]), u[0] * w[0] + u[1] * w[1] + u[2] * w[2]);
      add_face_normal(s, tri, x, y, z, angle, n);
    }
  } else {
    const int k = feature - kTriEdge;
    const int a = tri[3 * t + k], b = tri[3 * t + (k + 1) % 3];
    for (int f = inc_offsets[a]; f < inc_offsets[a + 1]; ++f) {
      const int s = inc_tri[f];
      if (tri[3 * s] == b || tri[3 * s + 1] == b || tri[3 * s + 2] == b) add_face_normal(s, tri, x, y, z, 1.0, n);
    }
  }
}

// Closest point of triangle t (of the capsule with nodes x, y, z) to the query point; see contact_relative.
inline double triangle_distance2(int t, int j, const int* tri, const double* x, const double* y, const double* z,
                                 const double* d, double* cp, int& feature, double* uw = nullptr) {
  double a[3], b[3], c[3];
  contact_relative(tri[3 * t], j, x, y, z, d, a);
  contact_relative(tri[3 * t + 1], j, x, y, z, d, b);
  contact_relative(tri[3 * t + 2], j, x, y, z, d, c);
  return closest_point_on_triangle(a, b, c, cp, feature, uw);
}

// Keeps triangle t's closest point to p if it is nearer than the best so far (squared distance best, triangle
// best_t, feature best_feature, closest point cp relative to node j, its barycentric u, w in best_uw): the one step
// of both searches below.
inline void keep_closer_triangle(int t, int j, const int* tri, const double* x, const double* y, const double* z,
                                 const double* d, double& best, int& best_t, int& best_feature, double* cp,
                                 double* best_uw) {
  double q[3], uw[2];
  int feature = 0;
  const double r2 = triangle_distance2(t, j, tri, x, y, z, d, q, feature, uw);
  if (r2 < best) {
    best = r2;
    best_t = t;
    best_feature = feature;
    cp[0] = q[0];
    cp[1] = q[1];
    cp[2] = q[2];
    best_uw[0] = uw[0];
    best_uw[1] = uw[1];
  }
}

// Signed distance from a point p to a capsule's closed surface (nodes x, y, z of that capsule; mesh as in
// host/state/icosphere.hpp), searched over the triangles around node j (the capsule's node nearest to p) and around its
// neighbours; d = p - x_j (minimum image). Negative inside. Sets n to the unit outward direction in which the
// distance grows fastest (see the header comment); `tiny`: below this distance n falls back to the pseudo-normal.
// Optional: the closest point's triangle (*tri_out) and barycentric u, w (uw_out, as closest_point_on_triangle).
inline double signed_surface_distance(int j, const int* tri, const int* inc_offsets, const int* inc_tri,
                                      const int* inc_corner, const double* x, const double* y, const double* z,
                                      const double* d, double tiny, double* n, int* tri_out = nullptr,
                                      double* uw_out = nullptr) {
  double best = 1e300, cp[3] = {0.0, 0.0, 0.0}, best_uw[2] = {0.0, 0.0};
  int best_t = -1, best_feature = 0;
  // The fan of j first, then the fans of j's neighbours without the triangles at j. Each neighbour is the next corner
  // after j in exactly one triangle of j's fan (consistent orientation), so each neighbour's fan is visited once;
  // a triangle across the fan's rim is visited from both its corners, which is harmless (equal distance, strict <).
  for (int f = inc_offsets[j]; f < inc_offsets[j + 1]; ++f)
    keep_closer_triangle(inc_tri[f], j, tri, x, y, z, d, best, best_t, best_feature, cp, best_uw);
  for (int f = inc_offsets[j]; f < inc_offsets[j + 1]; ++f) {
    const int k = tri[3 * inc_tri[f] + (inc_corner[f] + 1) % 3];
    for (int g = inc_offsets[k]; g < inc_offsets[k + 1]; ++g) {
      const int t = inc_tri[g];
      if (tri[3 * t] == j || tri[3 * t + 1] == j || tri[3 * t + 2] == j) continue;
      keep_closer_triangle(t, j, tri, x, y, z, d, best, best_t, best_feature, cp, best_uw);
    }
  }
  double pn[3];
  feature_pseudo_normal(best_t, best_feature, tri, inc_offsets, inc_tri, inc_corner, x, y, z, pn);
  const double pl = std::sqrt(pn[0] * pn[0] + pn[1] * pn[1] + pn[2] * pn[2]);
  // p - cp = -cp (relative coordinates); on the surface (p == cp) the point counts as outside.
  const double side = -(cp[0] * pn[0] + cp[1] * pn[1] + cp[2] * pn[2]);
  const double sign = side < 0.0 ? -1.0 : 1.0;
  const double dist = std::sqrt(best);
  if (best_feature != kTriInterior && dist > tiny) {
    for (int k = 0; k < 3; ++k) n[k] = -sign * cp[k] / dist;
  } else {
    for (int k = 0; k < 3; ++k) n[k] = pn[k] / pl;
  }
  if (tri_out) *tri_out = best_t;
  if (uw_out) {
    uw_out[0] = best_uw[0];
    uw_out[1] = best_uw[1];
  }
  return sign * dist;
}

// Unit push direction of pair (P, Q): from centre Q to centre P, minimum image in x and z; +x for coincident
// centres (any direction separates them; x is deterministic). Shared by the kernels and the host push.
inline void pair_push_direction(const double* cP, const double* cQ, double Lx, double Lz, double* e) {
  e[0] = min_image(cP[0] - cQ[0], Lx);
  e[1] = cP[1] - cQ[1];
  e[2] = min_image(cP[2] - cQ[2], Lz);
  const double len = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
  if (len > 0.0) {
    e[0] /= len;
    e[1] /= len;
    e[2] /= len;
  } else {
    e[0] = 1.0;
    e[1] = e[2] = 0.0;
  }
}

// The node j of Q (nodes xq, yq, zq) nearest to the point (px, py, pz) + shift, minimum image in x and z; full scan
// (exact even for deep overlaps). d = point - x_j. Both directed searches below start from it.
inline int nearest_node(int nv, const double* xq, const double* yq, const double* zq, double px, double py, double pz,
                        double sx, double sy, double sz, double Lx, double Lz, double* d) {
  double r2min = 1e300;
  int jmin = 0;
  d[0] = d[1] = d[2] = 0.0;
  for (int j = 0; j < nv; ++j) {
    const double ex = min_image(px - xq[j] + sx, Lx), ey = py - yq[j] + sy, ez = min_image(pz - zq[j] + sz, Lz);
    const double r2 = ex * ex + ey * ey + ez * ez;
    if (r2 < r2min) {
      r2min = r2;
      jmin = j;
      d[0] = ex;
      d[1] = ey;
      d[2] = ez;
    }
  }
  return jmin;
}

// Nodes of P against the surface of Q (the directed half of a pair). e: P's push direction (+e for the first
// capsule of the pair, -e for the second). Lowers `gap` to the smallest signed gap found (gap starts at the cap) and
// raises `need` to the largest relative displacement along e a violating node asks for (header comment).
inline void directed_gap(const MeshTopology& mesh, const PairSide& P, const PairSide& Q, const double* e,
                         const PairGapLimits& lim, double Lx, double Lz, double& gap, double& need) {
  const int nv = mesh.nv;
  const int *tri = mesh.tri, *inc_offsets = mesh.inc_offsets, *inc_tri = mesh.inc_tri, *inc_corner = mesh.inc_corner;
  const double *xp = P.x, *yp = P.y, *zp = P.z, *offp = P.off, *xq = Q.x, *yq = Q.y, *zq = Q.z, *offq = Q.off,
               *cq = Q.centre;
  const double range = lim.range, limit = lim.limit, target = lim.target, min_alignment = lim.min_alignment;
  const double rmaxq = Q.rmax;
  const double reach = rmaxq + range, reach2 = reach * reach;
  const double tiny = 1e-6 * target;
  // p_i - p_j = (x_i - x_j) + (offp - offq)
  const double sx = offp[0] - offq[0], sy = offp[1] - offq[1], sz = offp[2] - offq[2];
  for (int i = 0; i < nv; ++i) {
    const double pix = xp[i] + offp[0], piy = yp[i] + offp[1], piz = zp[i] + offp[2];
    const double cx = min_image(pix - cq[0], Lx), cy = piy - cq[1], cz = min_image(piz - cq[2], Lz);
    if (cx * cx + cy * cy + cz * cz >= reach2) continue;
    double d[3];
    const int jmin = nearest_node(nv, xq, yq, zq, xp[i], yp[i], zp[i], sx, sy, sz, Lx, Lz, d);
    double n[3];
    const double g = signed_surface_distance(jmin, tri, inc_offsets, inc_tri, inc_corner, xq, yq, zq, d, tiny, n);
    gap = g < gap ? g : gap;
    if (g < limit) {
      double c = e[0] * n[0] + e[1] * n[1] + e[2] * n[2];
      c = c > min_alignment ? c : min_alignment;
      const double s = (target - g) / c;
      need = s > need ? s : need;
    }
  }
}

// Collision cap of the membrane step rule (docs/method.md section 4.1): nodes of P against the surface of Q. A node
// at signed gap g < range from Q whose gap closes at the rate w = -(u_i - u_Q(c)) . n > 0 (u_Q linear on Q's closest
// triangle, evaluated at the closest point c; n the outward direction in which the gap grows) could close its gap in
// g / w: the smallest max(g, floor) / w lowers `tmin`, the smallest g lowers `gap` (gap starts at the cap `range`).
// Nodes outside Q's bounding sphere + range are skipped, as in directed_gap.
inline void directed_closing(const MeshTopology& mesh, const PairSide& P, const PairSide& Q,
                             const ClosingThresholds& lim, double Lx, double Lz, double& gap, double& tmin) {
  const int nv = mesh.nv;
  const int *tri = mesh.tri, *inc_offsets = mesh.inc_offsets, *inc_tri = mesh.inc_tri, *inc_corner = mesh.inc_corner;
  const double *xp = P.x, *yp = P.y, *zp = P.z, *uxp = P.ux, *uyp = P.uy, *uzp = P.uz;
  const double *xq = Q.x, *yq = Q.y, *zq = Q.z, *uxq = Q.ux, *uyq = Q.uy, *uzq = Q.uz, *cq = Q.centre;
  const double range = lim.range, floor = lim.floor, rmaxq = Q.rmax;
  const double reach = rmaxq + range, reach2 = reach * reach;
  const double tiny = 1e-6 * floor;
  for (int i = 0; i < nv; ++i) {
    const double cx = min_image(xp[i] - cq[0], Lx), cy = yp[i] - cq[1], cz = min_image(zp[i] - cq[2], Lz);
    if (cx * cx + cy * cy + cz * cz >= reach2) continue;
    double d[3];
    const int jmin = nearest_node(nv, xq, yq, zq, xp[i], yp[i], zp[i], 0.0, 0.0, 0.0, Lx, Lz, d);
    double n[3], uw[2];
    int t = 0;
    const double g = signed_surface_distance(jmin, tri, inc_offsets, inc_tri, inc_corner, xq, yq, zq, d, tiny, n,
                                             &t, uw);
    if (!(g < range)) continue;
    gap = g < gap ? g : gap;
    const int a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
    const double la = 1.0 - uw[0] - uw[1];
    const double vx = uxp[i] - (la * uxq[a] + uw[0] * uxq[b] + uw[1] * uxq[c]);
    const double vy = uyp[i] - (la * uyq[a] + uw[0] * uyq[b] + uw[1] * uyq[c]);
    const double vz = uzp[i] - (la * uzq[a] + uw[0] * uzq[b] + uw[1] * uzq[c]);
    const double w = -(vx * n[0] + vy * n[1] + vz * n[2]);
    if (w > 0.0) {
      const double tc = (g > floor ? g : floor) / w;
      tmin = tc < tmin ? tc : tmin;
    }
  }
}

// Wall part of the collision cap for capsule k: node gaps y and H - y below `range`, closing at -u_y and +u_y.
inline void wall_closing_one(long k, int nv, const double* y, const double* uy, double H, double range, double floor,
                             double* gap, double* tmin) {
  double g = range, t = 1e300;
  for (long i = k * nv; i < (k + 1) * nv; ++i) {
    const double gl = y[i], gh = H - y[i];
    if (gl < range) {
      g = gl < g ? gl : g;
      if (uy[i] < 0.0) {
        const double tc = (gl > floor ? gl : floor) / -uy[i];
        t = tc < t ? tc : t;
      }
    }
    if (gh < range) {
      g = gh < g ? gh : g;
      if (uy[i] > 0.0) {
        const double tc = (gh > floor ? gh : floor) / uy[i];
        t = tc < t ? tc : t;
      }
    }
  }
  gap[k] = g;
  tmin[k] = t;
}

CAPSFLOW_DEVICE_END

// Per-capsule bounds about the given centres (3 ncap): rmax[k] = max node distance from centre k (no minimum
// image: capsules are stored unwrapped), ymin[k], ymax[k] = extreme node y.
void capsule_bounds(Backend backend, int ncap, int nv, const double* x, const double* y, const double* z,
                    const double* centre, double* rmax, double* ymin, double* ymax);

// Gap and push need of each listed pair (pairs[2 p], pairs[2 p + 1]), p < npair, as described above. gap[p] is
// capped at lim.range; need[p] = 0 when no node of the pair violates. off and centre: 3 per capsule (current
// centre = stored + offset); the push direction of a pair comes from pair_push_direction(centre P, centre Q).
void pair_gaps(Backend backend, int ncap, const MeshTopology& mesh, const Vec3In& pos, const double* off,
               const double* centre, const double* rmax, int npair, const int* pairs, const PairGapLimits& lim,
               double Lx, double Lz, double* gap, double* need);

// Collision cap of each listed pair (directed_closing both ways): gap[p] = smallest node-surface gap (capped at
// range), tmin[p] = smallest max(g, floor) / w over closing nodes with g < range (1e300 when none closes).
// Node velocities vel as the positions pos.
void pair_closing(Backend backend, int ncap, const MeshTopology& mesh, const Vec3In& pos, const Vec3In& vel,
                  const double* centre, const double* rmax, int npair, const int* pairs, const ClosingThresholds& lim,
                  double Lx, double Lz, double* gap, double* tmin);

// The wall part per capsule (wall_closing_one): gap[k] (capped at range) and tmin[k] (1e300 when none closes).
void wall_closing(Backend backend, int ncap, int nv, const double* y, const double* uy, double H, double range,
                  double floor, double* gap, double* tmin);

}  // namespace capsflow
