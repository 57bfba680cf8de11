// The implementation of step_update.hpp: the per-step loops of the time integration over flat node arrays.
#include "kernels/step_update.hpp"

#include <climits>
#include <cmath>

#include "kernels/capsule_geometry.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/for_each.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN
inline double element_radius2(long k, int e, int nv, const int* tri, const double* x, const double* y,
                              const double* z) {
  const long o = k * nv;
  const long a = o + tri[3 * e], b = o + tri[3 * e + 1], c = o + tri[3 * e + 2];
  const double cx = (x[a] + x[b] + x[c]) / 3, cy = (y[a] + y[b] + y[c]) / 3, cz = (z[a] + z[b] + z[c]) / 3;
  double r2 = 0.0;
  const long v3[3] = {a, b, c};
  for (int j = 0; j < 3; ++j) {
    const long v = v3[j];
    const double dx = x[v] - cx, dy = y[v] - cy, dz = z[v] - cz;
    const double d2 = dx * dx + dy * dy + dz * dz;
    r2 = d2 > r2 ? d2 : r2;
  }
  return r2;
}

inline void volume_correction_one(long k, int nv, const double* volume0, const double* volume, const double* wx,
                                  const double* wy, const double* wz, double* x, double* y, double* z) {
  const long o = k * nv;
  double dV = 0.0;
  for (long i = o; i < o + nv; ++i) dV += std::sqrt(wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i]);
  const double delta = (volume0[k] - volume[k]) / dV;
  for (long i = o; i < o + nv; ++i) {
    const double len = std::sqrt(wx[i] * wx[i] + wy[i] * wy[i] + wz[i] * wz[i]);
    x[i] += delta * wx[i] / len;
    y[i] += delta * wy[i] / len;
    z[i] += delta * wz[i] / len;
  }
}

inline double second_difference_norm(long i, const double* ux, const double* uy, const double* uz, const double* vx,
                                     const double* vy, const double* vz, const double* wx, const double* wy,
                                     const double* wz) {
  const double a = ux[i] - 2.0 * vx[i] + wx[i], b = uy[i] - 2.0 * vy[i] + wy[i], c = uz[i] - 2.0 * vz[i] + wz[i];
  return std::sqrt(a * a + b * b + c * c);
}

inline void translate_node(long i, int nv, const double* off, double* x, double* y, double* z) {
  const long k = i / nv;
  const double ox = off[3 * k], oy = off[3 * k + 1], oz = off[3 * k + 2];
  if (ox != 0.0) x[i] += ox;
  if (oy != 0.0) y[i] += oy;
  if (oz != 0.0) z[i] += oz;
}
CAPSFLOW_DEVICE_END

}  // namespace


void fill3(Backend backend, std::size_t n, double value, double* a, double* b, double* c) {
  require_built(backend, __func__);
  CAPSFLOW_DEVICE_DATA(backend, map(from : a[0:n], b[0:n], c[0:n]))
  for_each_index(backend, static_cast<long>(n), [=](long i) { a[i] = b[i] = c[i] = value; });
}

void copy3(Backend backend, std::size_t n, const double* sx, const double* sy, const double* sz, double* dx,
           double* dy, double* dz) {
  require_built(backend, __func__);
  CAPSFLOW_DEVICE_DATA(backend, map(to : sx[0:n], sy[0:n], sz[0:n]) map(from : dx[0:n], dy[0:n], dz[0:n]))
  for_each_index(backend, static_cast<long>(n), [=](long i) {
    dx[i] = sx[i];
    dy[i] = sy[i];
    dz[i] = sz[i];
  });
}

void ab2_update(Backend backend, std::size_t n, double dtp, double a, double b, const double* ux, const double* uy,
                const double* uz, const double* uxp, const double* uyp, const double* uzp, double* x, double* y,
                double* z) {
  require_built(backend, __func__);
  CAPSFLOW_DEVICE_DATA(backend, map(to : ux[0:n], uy[0:n], uz[0:n], uxp[0:n], uyp[0:n], uzp[0:n])
                                    map(tofrom : x[0:n], y[0:n], z[0:n]))
  for_each_index(backend, static_cast<long>(n), [=](long i) {
    x[i] += dtp * (a * ux[i] + b * uxp[i]);
    y[i] += dtp * (a * uy[i] + b * uyp[i]);
    z[i] += dtp * (a * uz[i] + b * uzp[i]);
  });
}

void add_imposed_flow_x(Backend backend, std::size_t n, int code, double rate, double H, const double* y,
                        double* ux) {
  require_built(backend, __func__);
  CAPSFLOW_DEVICE_DATA(backend, map(to : y[0:n]) map(tofrom : ux[0:n]))
  for_each_index(backend, static_cast<long>(n), [=](long i) { ux[i] += imposed_flow_x(code, rate, H, y[i]); });
}

double max_second_difference(Backend backend, std::size_t n, const double* ux, const double* uy, const double* uz,
                             const double* vx, const double* vy, const double* vz, const double* wx, const double* wy,
                             const double* wz) {
  require_built(backend, __func__);
  double best = 0.0;  // a maximum: exact in any order
  CAPSFLOW_DEVICE_DATA(backend, map(to : ux[0:n], uy[0:n], uz[0:n], vx[0:n], vy[0:n], vz[0:n], wx[0:n], wy[0:n],
                                        wz[0:n]))
  best = reduce_max(backend, static_cast<long>(n), 0.0,
                    [=](long i) { return second_difference_norm(i, ux, uy, uz, vx, vy, vz, wx, wy, wz); });
  return best;
}

bool all_finite3(Backend backend, std::size_t n, const double* a, const double* b, const double* c) {
  require_built(backend, __func__);
  int bad = 0;  // count of non-finite entries: a sum of 0/1 is exact in any order
  CAPSFLOW_DEVICE_DATA(backend, map(to : a[0:n], b[0:n], c[0:n]))
  bad = reduce_sum(backend, static_cast<long>(n), 0, [=](long i) {
    return static_cast<int>(!(std::isfinite(a[i]) && std::isfinite(b[i]) && std::isfinite(c[i])));
  });
  return bad == 0;
}

long first_outside(Backend backend, std::size_t n, const double* y, double lo, double hi) {
  require_built(backend, __func__);
  long first = LONG_MAX;  // the smallest index outside: a minimum, exact in any order
  CAPSFLOW_DEVICE_DATA(backend, map(to : y[0:n]))
  first = reduce_min(backend, static_cast<long>(n), LONG_MAX,
                     [=](long i) { return y[i] < lo || y[i] > hi ? i : LONG_MAX; });
  return first == LONG_MAX ? -1 : first;
}

double max_element_radius(Backend backend, int ncap, int nv, int ntri, const int* tri, const double* x,
                          const double* y, const double* z) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const int n3 = 3 * ntri;
  double r2 = 0.0;  // max is exact in any order
  // One index per element (capsule k = j / ntri, triangle j % ntri).
  CAPSFLOW_DEVICE_DATA(backend, map(to : tri[0:n3], x[0:nn], y[0:nn], z[0:nn]))
  r2 = reduce_max(backend, static_cast<long>(ncap) * ntri, 0.0, [=](long j) {
    const long k = j / ntri;
    return element_radius2(k, static_cast<int>(j - k * ntri), nv, tri, x, y, z);
  });
  return std::sqrt(r2);
}

void capsule_node_means(Backend backend, int ncap, int nv, const double* x, const double* y, const double* z,
                        double* mean) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv, n3 = 3L * ncap;
  CAPSFLOW_DEVICE_DATA(backend, map(to : x[0:nn], y[0:nn], z[0:nn]) map(from : mean[0:n3]))
  for_each_index(backend, ncap, [=](long k) {
    node_mean(nv, x + k * nv, y + k * nv, z + k * nv, mean[3 * k], mean[3 * k + 1], mean[3 * k + 2]);
  });
}

void translate_capsules(Backend backend, int ncap, int nv, const double* off, double* x, double* y, double* z) {
  require_built(backend, __func__);
  const long nn = static_cast<long>(ncap) * nv;
  [[maybe_unused]] const long n3 = 3L * ncap;
  CAPSFLOW_DEVICE_DATA(backend, map(to : off[0:n3]) map(tofrom : x[0:nn], y[0:nn], z[0:nn]))
  for_each_index(backend, nn, [=](long i) { translate_node(i, nv, off, x, y, z); });
}

void volume_correction_step(Backend backend, int ncap, int nv, const double* volume0, const double* volume,
                            const double* wx, const double* wy, const double* wz, double* x, double* y, double* z) {
  require_built(backend, __func__);
  [[maybe_unused]] const long nn = static_cast<long>(ncap) * nv;
  // One index per capsule: its sum runs in node order on every backend.
  CAPSFLOW_DEVICE_DATA(backend, map(to : volume0[0:ncap], volume[0:ncap], wx[0:nn], wy[0:nn], wz[0:nn])
                                    map(tofrom : x[0:nn], y[0:nn], z[0:nn]))
  for_each_index(backend, ncap,
                 [=](long k) { volume_correction_one(k, nv, volume0, volume, wx, wy, wz, x, y, z); });
}

}  // namespace capsflow
