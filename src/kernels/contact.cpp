// The implementation of contact.hpp: the flat-array kernels of the contact control.
#include "kernels/contact.hpp"

#include <stdexcept>

#include "kernels/dispatch.hpp"
#include "kernels/for_each.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

inline void bounds_one(long k, int nv, const double* x, const double* y, const double* z, const double* centre,
                       double* rmax, double* ymin, double* ymax) {
  const long base = k * nv;
  double r2 = 0.0, lo = 1e300, hi = -1e300;
  for (int i = 0; i < nv; ++i) {
    const double dx = x[base + i] - centre[3 * k], dy = y[base + i] - centre[3 * k + 1],
                 dz = z[base + i] - centre[3 * k + 2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    r2 = d2 > r2 ? d2 : r2;
    lo = y[base + i] < lo ? y[base + i] : lo;
    hi = y[base + i] > hi ? y[base + i] : hi;
  }
  rmax[k] = std::sqrt(r2);
  ymin[k] = lo;
  ymax[k] = hi;
}

// Pair p: both directed halves, P's nodes against Q's surface (P moves along +e), then Q's against P's (-e).
inline void pair_gap_one(long p, const MeshTopology& mesh, const Vec3In& pos, const double* off, const double* centre,
                         const double* rmax, const int* pairs, const PairGapLimits& lim, double Lx, double Lz,
                         double* gap, double* need) {
  const long P = pairs[2 * p], Q = pairs[2 * p + 1];
  const long bp = P * mesh.nv, bq = Q * mesh.nv;
  const PairSide sp{pos.x + bp, pos.y + bp, pos.z + bp, nullptr, nullptr, nullptr,
                    off + 3 * P, centre + 3 * P, rmax[P]};
  const PairSide sq{pos.x + bq, pos.y + bq, pos.z + bq, nullptr, nullptr, nullptr,
                    off + 3 * Q, centre + 3 * Q, rmax[Q]};
  double e[3];
  pair_push_direction(centre + 3 * P, centre + 3 * Q, Lx, Lz, e);
  const double me[3] = {-e[0], -e[1], -e[2]};
  double g = lim.range, s = 0.0;
  directed_gap(mesh, sp, sq, e, lim, Lx, Lz, g, s);
  directed_gap(mesh, sq, sp, me, lim, Lx, Lz, g, s);
  gap[p] = g;
  need[p] = s;
}

inline void pair_closing_one(long p, const MeshTopology& mesh, const Vec3In& pos, const Vec3In& vel,
                             const double* centre, const double* rmax, const int* pairs, const ClosingThresholds& lim,
                             double Lx, double Lz, double* gap, double* tmin) {
  const long P = pairs[2 * p], Q = pairs[2 * p + 1];
  const long bp = P * mesh.nv, bq = Q * mesh.nv;
  const PairSide sp{pos.x + bp, pos.y + bp, pos.z + bp, vel.x + bp, vel.y + bp, vel.z + bp, nullptr, centre + 3 * P,
                    rmax[P]};
  const PairSide sq{pos.x + bq, pos.y + bq, pos.z + bq, vel.x + bq, vel.y + bq, vel.z + bq, nullptr, centre + 3 * Q,
                    rmax[Q]};
  double g = lim.range, t = 1e300;
  directed_closing(mesh, sp, sq, lim, Lx, Lz, g, t);
  directed_closing(mesh, sq, sp, lim, Lx, Lz, g, t);
  gap[p] = g;
  tmin[p] = t;
}

CAPSFLOW_DEVICE_END

}  // namespace

void capsule_bounds(Backend backend, int ncap, int nv, const double* x, const double* y, const double* z,
                    const double* centre, double* rmax, double* ymin, double* ymax) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  CAPSFLOW_DEVICE_DATA(backend, map(to : x[0 : nn], y[0 : nn], z[0 : nn], centre[0 : 3 * ncap])
                                    map(from : rmax[0 : ncap], ymin[0 : ncap], ymax[0 : ncap]))
  for_each_index(backend, ncap, [=](long k) { bounds_one(k, nv, x, y, z, centre, rmax, ymin, ymax); });
}

void pair_gaps(Backend backend, int ncap, const MeshTopology& mesh, const Vec3In& pos, const double* off,
               const double* centre, const double* rmax, int npair, const int* pairs, const PairGapLimits& lim,
               double Lx, double Lz, double* gap, double* need) {
  require_built(backend, __func__);
  if (npair == 0) return;
  // The lambda captures the arrays one by one (on the device each is translated to its mapped copy) and rebuilds
  // the views inside.
  const int nv = mesh.nv, ntri = mesh.ntri;
  const int *tri = mesh.tri, *inc_offsets = mesh.inc_offsets, *inc_tri = mesh.inc_tri, *inc_corner = mesh.inc_corner;
  const double *x = pos.x, *y = pos.y, *z = pos.z;
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int n3 = 3 * ntri;
  CAPSFLOW_DEVICE_DATA(backend, map(to : x[0 : nn], y[0 : nn], z[0 : nn], off[0 : 3 * ncap], centre[0 : 3 * ncap],
                                        rmax[0 : ncap], pairs[0 : 2 * npair], tri[0 : n3], inc_offsets[0 : nv + 1],
                                        inc_tri[0 : n3], inc_corner[0 : n3]) map(from : gap[0 : npair],
                                                                                 need[0 : npair]))
  for_each_index(
      backend, npair,
      [=](long p) {
        pair_gap_one(p, MeshTopology{nv, ntri, tri, inc_offsets, inc_tri, inc_corner}, Vec3In{x, y, z}, off, centre,
                     rmax, pairs, lim, Lx, Lz, gap, need);
      },
      ThreadSchedule::dynamic(1));
}

void pair_closing(Backend backend, int ncap, const MeshTopology& mesh, const Vec3In& pos, const Vec3In& vel,
                  const double* centre, const double* rmax, int npair, const int* pairs, const ClosingThresholds& lim,
                  double Lx, double Lz, double* gap, double* tmin) {
  require_built(backend, __func__);
  if (npair == 0) return;
  const int nv = mesh.nv, ntri = mesh.ntri;
  const int *tri = mesh.tri, *inc_offsets = mesh.inc_offsets, *inc_tri = mesh.inc_tri, *inc_corner = mesh.inc_corner;
  const double *x = pos.x, *y = pos.y, *z = pos.z, *ux = vel.x, *uy = vel.y, *uz = vel.z;
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int n3 = 3 * ntri;
  CAPSFLOW_DEVICE_DATA(backend, map(to : x[0 : nn], y[0 : nn], z[0 : nn], ux[0 : nn], uy[0 : nn], uz[0 : nn],
                                        centre[0 : 3 * ncap], rmax[0 : ncap], pairs[0 : 2 * npair], tri[0 : n3],
                                        inc_offsets[0 : nv + 1], inc_tri[0 : n3], inc_corner[0 : n3])
                                    map(from : gap[0 : npair], tmin[0 : npair]))
  for_each_index(
      backend, npair,
      [=](long p) {
        pair_closing_one(p, MeshTopology{nv, ntri, tri, inc_offsets, inc_tri, inc_corner}, Vec3In{x, y, z},
                         Vec3In{ux, uy, uz}, centre, rmax, pairs, lim, Lx, Lz, gap, tmin);
      },
      ThreadSchedule::dynamic(1));
}

void wall_closing(Backend backend, int ncap, int nv, const double* y, const double* uy, double H, double range,
                  double floor, double* gap, double* tmin) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  CAPSFLOW_DEVICE_DATA(backend, map(to : y[0 : nn], uy[0 : nn]) map(from : gap[0 : ncap], tmin[0 : ncap]))
  for_each_index(backend, ncap, [=](long k) { wall_closing_one(k, nv, y, uy, H, range, floor, gap, tmin); });
}

}  // namespace capsflow
