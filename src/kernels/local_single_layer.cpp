#include "kernels/local_single_layer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "kernels/device_macros.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

// Unwrapped cell coordinate; callers wrap (periodic x, z) or clamp (y).
inline int sl_cell_coord(double v, double size) { return static_cast<int>(std::floor(v / size)); }

inline int sl_wrap_cell(int c, int n) {
  const int r = c % n;
  return r < 0 ? r + n : r;
}

// Minimum image d - L round(d / L) without a libm call (std::nearbyint is not inlined on baseline x86-64); rounds
// half away from zero, which differs from nearbyint only at d = +-L/2 exactly, far outside cutoff + radius < L/2.
inline double sl_min_image(double d, double L, double inv_L) {
  const double s = d * inv_L;
  return d - L * static_cast<double>(static_cast<long long>(s + std::copysign(0.5, s)));
}

// Sum over the neighbouring cells of one target (same window as the point-force local sum: with fewer than 3 cells
// along a periodic direction every cell is visited once).
inline void sl_target(int ncx, int ncy, int ncz, double cx, double cy, double cz, double Lx, double Lz,
                      const int* start, const int* elem, const double* ex, const double* ey, const double* ez,
                      const double* er, double cutoff, int nv, int ntri, const int* tri, const double* x,
                      const double* y, const double* z, const double* fx, const double* fy, const double* fz,
                      double alpha, const QuadratureOrders& q, double scale, double px, double py, double pz,
                      int tnode, double& ux, double& uy, double& uz) {
  const int icx = sl_wrap_cell(sl_cell_coord(px, cx), ncx);
  const int icz = sl_wrap_cell(sl_cell_coord(pz, cz), ncz);
  int icy = sl_cell_coord(py, cy);
  icy = icy < 0 ? 0 : (icy >= ncy ? ncy - 1 : icy);
  const int dx_lo = ncx >= 3 ? -1 : 0, dx_hi = ncx >= 3 ? 1 : ncx - 1;
  const int dz_lo = ncz >= 3 ? -1 : 0, dz_hi = ncz >= 3 ? 1 : ncz - 1;
  const double xt[3] = {px, py, pz};
  const double inv_Lx = 1.0 / Lx, inv_Lz = 1.0 / Lz;
  double acc[3] = {0.0, 0.0, 0.0};
  for (int dyc = -1; dyc <= 1; ++dyc) {
    const int cyy = icy + dyc;
    if (cyy < 0 || cyy >= ncy) continue;
    for (int dxc = dx_lo; dxc <= dx_hi; ++dxc) {
      const int cxx = ncx >= 3 ? sl_wrap_cell(icx + dxc, ncx) : dxc;
      for (int dzc = dz_lo; dzc <= dz_hi; ++dzc) {
        const int czz = ncz >= 3 ? sl_wrap_cell(icz + dzc, ncz) : dzc;
        const int cell = (cyy * ncx + cxx) * ncz + czz;
        for (int s = start[cell]; s < start[cell + 1]; ++s) {
          const double rx = sl_min_image(ex[s] - px, Lx, inv_Lx);
          const double ry = ey[s] - py;
          const double rz = sl_min_image(ez[s] - pz, Lz, inv_Lz);
          const double reach = cutoff + er[s];
          if (rx * rx + ry * ry + rz * rz >= reach * reach) continue;
          const int e = elem[s];
          const int k = e / ntri;
          const int t = e - k * ntri;
          double v[9], f[9];
          int singular = -1;
          for (int c = 0; c < 3; ++c) {
            const int g = k * nv + tri[3 * t + c];
            v[3 * c] = px + sl_min_image(x[g] - px, Lx, inv_Lx);
            v[3 * c + 1] = y[g];
            v[3 * c + 2] = pz + sl_min_image(z[g] - pz, Lz, inv_Lz);
            f[3 * c] = fx[g];
            f[3 * c + 1] = fy[g];
            f[3 * c + 2] = fz[g];
            if (g == tnode) singular = c;
          }
          element_single_layer_add(alpha, xt, v, f, singular, q, acc);
        }
      }
    }
  }
  ux += scale * acc[0];
  uy += scale * acc[1];
  uz += scale * acc[2];
}

CAPSFLOW_DEVICE_END

}  // namespace

void build_element_cell_list(ElementCellList& cl, double Lx, double H, double Lz, double cutoff, int ncap, int nv,
                             int ntri, const int* tri, const double* x, const double* y, const double* z) {
  if (!(Lx > 0.0 && Lz > 0.0 && H > 0.0 && cutoff > 0.0) || ncap < 0 || nv < 0 || ntri < 0)
    throw std::invalid_argument("build_element_cell_list: invalid box, cutoff or sizes");
  const std::size_t ne = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(ntri);
  std::vector<double> cxs(ne), cys(ne), czs(ne), rad(ne);
  double max_r = 0.0;
  for (std::size_t e = 0; e < ne; ++e) {
    const int k = static_cast<int>(e / static_cast<std::size_t>(ntri));
    const int t = static_cast<int>(e % static_cast<std::size_t>(ntri));
    double v[9];
    const int g0 = k * nv + tri[3 * t];
    for (int c = 0; c < 3; ++c) {
      const int g = k * nv + tri[3 * t + c];
      v[3 * c] = x[g0] + min_image(x[g] - x[g0], Lx);
      v[3 * c + 1] = y[g];
      v[3 * c + 2] = z[g0] + min_image(z[g] - z[g0], Lz);
    }
    const double c0 = (v[0] + v[3] + v[6]) / 3.0, c1 = (v[1] + v[4] + v[7]) / 3.0, c2 = (v[2] + v[5] + v[8]) / 3.0;
    double r2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double dx = v[3 * c] - c0, dy = v[3 * c + 1] - c1, dz = v[3 * c + 2] - c2;
      r2 = std::max(r2, dx * dx + dy * dy + dz * dz);
    }
    cxs[e] = c0;
    cys[e] = c1;
    czs[e] = c2;
    rad[e] = std::sqrt(r2);
    max_r = std::max(max_r, rad[e]);
  }
  const double reach = cutoff + max_r;
  if (!(Lx > 2.0 * reach && Lz > 2.0 * reach))
    throw std::invalid_argument("build_element_cell_list: Lx and Lz must exceed 2 (cutoff + largest element radius)");
  cl.Lx = Lx;
  cl.Lz = Lz;
  cl.H = H;
  cl.max_radius = max_r;
  cl.ncx = std::max(1, static_cast<int>(std::floor(Lx / reach)));
  cl.ncz = std::max(1, static_cast<int>(std::floor(Lz / reach)));
  cl.ncy = std::max(1, static_cast<int>(std::floor(H / reach)));
  cl.cx = Lx / cl.ncx;
  cl.cz = Lz / cl.ncz;
  cl.cy = H / cl.ncy;
  const int ncell = cl.ncx * cl.ncy * cl.ncz;
  std::vector<int> cell(ne);
  cl.start.assign(static_cast<std::size_t>(ncell) + 1, 0);
  for (std::size_t e = 0; e < ne; ++e) {
    const int a = sl_wrap_cell(sl_cell_coord(cxs[e], cl.cx), cl.ncx);
    const int c = sl_wrap_cell(sl_cell_coord(czs[e], cl.cz), cl.ncz);
    const int b = std::clamp(sl_cell_coord(cys[e], cl.cy), 0, cl.ncy - 1);
    cell[e] = (b * cl.ncx + a) * cl.ncz + c;
    ++cl.start[static_cast<std::size_t>(cell[e]) + 1];
  }
  for (int c = 0; c < ncell; ++c) cl.start[static_cast<std::size_t>(c) + 1] += cl.start[static_cast<std::size_t>(c)];
  std::vector<int> fill(cl.start.begin(), cl.start.end() - 1);
  cl.elem.resize(ne);
  for (auto* w : {&cl.ex, &cl.ey, &cl.ez, &cl.er}) w->resize(ne);
  for (std::size_t e = 0; e < ne; ++e) {
    const auto s = static_cast<std::size_t>(fill[static_cast<std::size_t>(cell[e])]++);
    cl.elem[s] = static_cast<int>(e);
    cl.ex[s] = cxs[e];
    cl.ey[s] = cys[e];
    cl.ez[s] = czs[e];
    cl.er[s] = rad[e];
  }
}

void local_single_layer_velocity(Backend backend, const ElementCellList& cl, double alpha, double cutoff, double scale,
                                 int ncap, int nv, int ntri, const int* tri, const double* x, const double* y,
                                 const double* z, const double* fx, const double* fy, const double* fz,
                                 const QuadratureOrders& q_in, std::size_t nt, const double* tx, const double* ty,
                                 const double* tz, const int* target_node, double* ux, double* uy, double* uz) {
  if (cl.size() != static_cast<std::size_t>(ncap) * static_cast<std::size_t>(ntri))
    throw std::invalid_argument("local_single_layer_velocity: cell list built for a different element count");
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double cx = cl.cx, cy = cl.cy, cz = cl.cz, Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const int* elem = cl.elem.data();
  const double *ex = cl.ex.data(), *ey = cl.ey.data(), *ez = cl.ez.data(), *er = cl.er.data();
  const QuadratureOrders q = q_in;
  const long long n = static_cast<long long>(nt);
  if (backend == Backend::Device) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
    std::vector<int> no_node;
    const int* tn = target_node;
    if (tn == nullptr) {
      no_node.assign(nt, -1);
      tn = no_node.data();
    }
    const std::size_t ne = cl.size();
    const std::size_t nc = cl.start.size();
    const std::size_t nn = static_cast<std::size_t>(ncap) * static_cast<std::size_t>(nv);
    const std::size_t n3 = 3 * static_cast<std::size_t>(ntri);
#pragma omp target teams distribute parallel for firstprivate(q)                                                   \
    map(to : start[0:nc], elem[0:ne], ex[0:ne], ey[0:ne], ez[0:ne], er[0:ne], tri[0:n3], x[0:nn], y[0:nn], z[0:nn], \
            fx[0:nn], fy[0:nn], fz[0:nn], tx[0:nt], ty[0:nt], tz[0:nt], tn[0:nt])                                \
    map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p)
      sl_target(ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er, cutoff, nv, ntri, tri, x, y, z, fx, fy,
                fz, alpha, q, scale, tx[p], ty[p], tz[p], tn[p], ux[p], uy[p], uz[p]);
#else
    (void)ncap;
#endif
    return;
  }
#pragma omp parallel for schedule(dynamic, 16) if (backend == Backend::Threads)
  for (long long p = 0; p < n; ++p)
    sl_target(ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, elem, ex, ey, ez, er, cutoff, nv, ntri, tri, x, y, z, fx, fy,
              fz, alpha, q, scale, tx[p], ty[p], tz[p], target_node ? target_node[p] : -1, ux[p], uy[p], uz[p]);
}

}  // namespace capsflow
