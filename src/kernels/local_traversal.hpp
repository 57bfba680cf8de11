#pragma once
// The per-target gather over an element cell list (kernels/local_single_layer.hpp), shared by the local single and
// double layers. Plain scalar code: runs inside OpenMP target regions.
#include <cmath>

#include "kernels/constants.hpp"
#include "kernels/device_macros.hpp"
#include "kernels/slit_cells.hpp"
#include "kernels/surface_views.hpp"

namespace capsflow {
namespace local_detail {

CAPSFLOW_DEVICE_BEGIN

// Sum over the neighbouring cells of one target (same window as the point-force local sum: with fewer than 3 cells
// along a periodic direction every cell is visited once): for every element within reach, its vertices unwrapped
// about the target and its nodal densities, rule(xt, v, f, singular_vertex, acc) adds the element's integral to acc.
// The single and double layers share it, so both visit the same elements in the same order.
template <class Rule>
inline void local_target_sum(const Rule& rule, const ElementCellsView& cells, double cutoff, const SurfaceView& surface,
                             const Vec3In& density, double px, double py, double pz, int tnode, double* acc) {
  const int ncx = cells.ncx, ncy = cells.ncy, ncz = cells.ncz, nv = surface.nv, ntri = surface.ntri;
  const double Lx = cells.Lx, Lz = cells.Lz;
  const int *start = cells.start, *elem = cells.elem, *tri = surface.tri;
  const double *ex = cells.ex, *ey = cells.ey, *ez = cells.ez, *er = cells.er;
  const double *x = surface.x, *y = surface.y, *z = surface.z, *fx = density.x, *fy = density.y, *fz = density.z;
  int icx, icy, icz;
  slit_cell_coords(px, py, pz, cells.cx, cells.cy, cells.cz, ncx, ncy, ncz, icx, icy, icz);
  const double xt[3] = {px, py, pz};
  const double inv_Lx = 1.0 / Lx, inv_Lz = 1.0 / Lz;
  slit_cell_window(icx, icy, icz, ncx, ncy, ncz, [&](int cell) {
    for (int s = start[cell]; s < start[cell + 1]; ++s) {
      const double rx = min_image_fast(ex[s] - px, Lx, inv_Lx);
      const double ry = ey[s] - py;
      const double rz = min_image_fast(ez[s] - pz, Lz, inv_Lz);
      const double reach = cutoff + er[s];
      if (rx * rx + ry * ry + rz * rz >= reach * reach) continue;
      const int e = elem[s];
      const int k = e / ntri;
      const int t = e - k * ntri;
      double v[9], f[9];
      int singular = -1;
      for (int c = 0; c < 3; ++c) {
        const int g = k * nv + tri[3 * t + c];
        v[3 * c] = px + min_image_fast(x[g] - px, Lx, inv_Lx);
        v[3 * c + 1] = y[g];
        v[3 * c + 2] = pz + min_image_fast(z[g] - pz, Lz, inv_Lz);
        f[3 * c] = fx[g];
        f[3 * c + 1] = fy[g];
        f[3 * c + 2] = fz[g];
        if (g == tnode) singular = c;
      }
      rule(xt, v, f, singular, acc);
    }
  });
}

CAPSFLOW_DEVICE_END

}  // namespace local_detail
}  // namespace capsflow
