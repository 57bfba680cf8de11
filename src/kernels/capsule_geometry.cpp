// The implementation of capsule_geometry.hpp: volume, area, centroid and D of flat-triangle surfaces.
#include "kernels/capsule_geometry.hpp"

#include <stdexcept>

#include "kernels/dispatch.hpp"
#include "kernels/for_each.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

// Sum over the triangles around node i of (x1 - x0) x (x2 - x0), twice their area vectors: the common sum of the
// node normal and the volume gradient.
inline void incident_cross_sum(long i, int nv, const int* tri, const int* inc_offsets, const int* inc_tri,
                               const double* x, const double* y, const double* z, double& sx, double& sy, double& sz) {
  const long k = i / nv;
  const long local = i - k * nv, base = k * nv;
  sx = sy = sz = 0.0;
  for (int j = inc_offsets[local]; j < inc_offsets[local + 1]; ++j) {
    const int t = inc_tri[j];
    const long i0 = base + tri[3 * t], i1 = base + tri[3 * t + 1], i2 = base + tri[3 * t + 2];
    const double ax = x[i1] - x[i0], ay = y[i1] - y[i0], az = z[i1] - z[i0];
    const double bx = x[i2] - x[i0], by = y[i2] - y[i0], bz = z[i2] - z[i0];
    sx += ay * bz - az * by;
    sy += az * bx - ax * bz;
    sz += ax * by - ay * bx;
  }
}

inline void node_normal_one(long i, int nv, const int* tri, const int* inc_offsets, const int* inc_tri, const double* x,
                            const double* y, const double* z, double* nx, double* ny, double* nz) {
  double sx, sy, sz;  // the factor 2 cancels on normalisation
  incident_cross_sum(i, nv, tri, inc_offsets, inc_tri, x, y, z, sx, sy, sz);
  const double inv = 1.0 / std::sqrt(sx * sx + sy * sy + sz * sz);
  nx[i] = sx * inv;
  ny[i] = sy * inv;
  nz[i] = sz * inv;
}

// dV/dx_i = (1/3) sum of the area vectors of the triangles around node i (V = (1/6) sum x0 . (x1 x x2) over
// triangles; around a closed fan the cross terms telescope).
inline void volume_gradient_one(long i, int nv, const int* tri, const int* inc_offsets, const int* inc_tri,
                                const double* x, const double* y, const double* z, double* wx, double* wy,
                                double* wz) {
  double sx, sy, sz;
  incident_cross_sum(i, nv, tri, inc_offsets, inc_tri, x, y, z, sx, sy, sz);
  wx[i] = sx / 6.0;  // (1/3) (1/2) |cross|
  wy[i] = sy / 6.0;
  wz[i] = sz / 6.0;
}

// u <- u - lambda w with lambda = (w . u) / (w . w) over one capsule: the smallest change (in the node-velocity
// norm) that makes the discrete volume rate sum_i w_i . u_i zero. Sums in node order: every backend agrees.
inline void project_volume_rate_one(long k, int nv, const double* wx, const double* wy, const double* wz,
                                    double* ux, double* uy, double* uz) {
  const long o = k * nv;
  double wu = 0.0, ww = 0.0;
  for (long i = o; i < o + nv; ++i) {
    wu += wx[i] * ux[i] + wy[i] * uy[i] + wz[i] * uz[i];
    ww += wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i];
  }
  const double lambda = wu / ww;
  for (long i = o; i < o + nv; ++i) {
    ux[i] -= lambda * wx[i];
    uy[i] -= lambda * wy[i];
    uz[i] -= lambda * wz[i];
  }
}

inline double min_edge_one(int nedge, const int* edges, const double* x, const double* y, const double* z) {
  double h2 = 1e300;
  for (int e = 0; e < nedge; ++e) {
    const int a = edges[2 * e], b = edges[2 * e + 1];
    const double dx = x[b] - x[a], dy = y[b] - y[a], dz = z[b] - z[a];
    const double d2 = dx * dx + dy * dy + dz * dz;
    h2 = d2 < h2 ? d2 : h2;
  }
  return std::sqrt(h2);
}

CAPSFLOW_DEVICE_END

}  // namespace

void capsule_shape(Backend backend, int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                   const double* z, double* volume, double* area, double* centroid, double* moments) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int n3 = 3 * ntri;
  CAPSFLOW_DEVICE_DATA(backend, map(to : tri[0 : n3], x[0 : nn], y[0 : nn], z[0 : nn])
                                    map(from : volume[0 : ncap], area[0 : ncap], centroid[0 : 3 * ncap],
                                        moments[0 : 6 * ncap]))
  for_each_index(backend, ncap, [=](long k) {
    capsule_shape_moments(nv, ntri, tri, x + k * nv, y + k * nv, z + k * nv, volume[k], area[k], centroid + 3 * k,
                          moments + 6 * k);
  });
}

void capsule_mean_velocity(Backend backend, int ncap, int nv, int ntri, const int* tri, const double* x,
                           const double* y, const double* z, const double* ux, const double* uy, const double* uz,
                           double* U, double* omega) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int n3 = 3 * ntri;
  CAPSFLOW_DEVICE_DATA(backend, map(to : tri[0 : n3], x[0 : nn], y[0 : nn], z[0 : nn], ux[0 : nn], uy[0 : nn],
                                        uz[0 : nn]) map(from : U[0 : 3 * ncap], omega[0 : 3 * ncap]))
  for_each_index(backend, ncap, [=](long k) {
    capsule_velocity_moments(nv, ntri, tri, x + k * nv, y + k * nv, z + k * nv, ux + k * nv, uy + k * nv, uz + k * nv,
                             U + 3 * k, omega + 3 * k);
  });
}

void node_normals(Backend backend, int ncap, int nv, const int* tri, const int* inc_offsets, const int* inc_tri,
                  const double* x, const double* y, const double* z, double* nx, double* ny, double* nz) {
  require_built(backend, __func__);
  const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int ninc = backend == Backend::Device ? inc_offsets[nv] : 0;
  CAPSFLOW_DEVICE_DATA(backend, map(to : tri[0 : ninc], inc_offsets[0 : nv + 1], inc_tri[0 : ninc], x[0 : nn],
                                        y[0 : nn], z[0 : nn]) map(from : nx[0 : nn], ny[0 : nn], nz[0 : nn]))
  for_each_index(backend, nn,
                 [=](long i) { node_normal_one(i, nv, tri, inc_offsets, inc_tri, x, y, z, nx, ny, nz); });
}

void volume_gradient(Backend backend, int ncap, int nv, const int* tri, const int* inc_offsets, const int* inc_tri,
                     const double* x, const double* y, const double* z, double* wx, double* wy, double* wz) {
  require_built(backend, __func__);
  const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int ninc = backend == Backend::Device ? inc_offsets[nv] : 0;
  CAPSFLOW_DEVICE_DATA(backend, map(to : tri[0 : ninc], inc_offsets[0 : nv + 1], inc_tri[0 : ninc], x[0 : nn],
                                        y[0 : nn], z[0 : nn]) map(from : wx[0 : nn], wy[0 : nn], wz[0 : nn]))
  for_each_index(backend, nn,
                 [=](long i) { volume_gradient_one(i, nv, tri, inc_offsets, inc_tri, x, y, z, wx, wy, wz); });
}

void project_volume_rate(Backend backend, int ncap, int nv, const double* wx, const double* wy, const double* wz,
                         double* ux, double* uy, double* uz) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  CAPSFLOW_DEVICE_DATA(backend, map(to : wx[0 : nn], wy[0 : nn], wz[0 : nn]) map(tofrom : ux[0 : nn], uy[0 : nn],
                                                                                     uz[0 : nn]))
  for_each_index(backend, ncap, [=](long k) { project_volume_rate_one(k, nv, wx, wy, wz, ux, uy, uz); });
}

void min_edge_length(Backend backend, int ncap, int nv, int nedge, const int* edges, const double* x, const double* y,
                     const double* z, double* hmin) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int n2 = 2 * nedge;
  CAPSFLOW_DEVICE_DATA(backend, map(to : edges[0 : n2], x[0 : nn], y[0 : nn], z[0 : nn]) map(from : hmin[0 : ncap]))
  for_each_index(backend, ncap,
                 [=](long k) { hmin[k] = min_edge_one(nedge, edges, x + k * nv, y + k * nv, z + k * nv); });
}

}  // namespace capsflow
