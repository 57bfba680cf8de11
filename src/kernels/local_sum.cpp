// The implementation of local_sum.hpp: the local part of GGEM for point forces.
#include "kernels/local_sum.hpp"
#include "kernels/slit_cells.hpp"

#include <algorithm>
#include <cmath>

#include "kernels/device_macros.hpp"
#include "kernels/dispatch.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {
namespace {

CAPSFLOW_DEVICE_BEGIN

// Sum over the neighbouring cells of one target (slit_cell_window).
inline void local_target(int ncx, int ncy, int ncz, double cx, double cy, double cz, double Lx, double Lz,
                         const int* start, const double* sx, const double* sy, const double* sz, const double* fx,
                         const double* fy, const double* fz, double alpha, double rc2, double scale, double px,
                         double py, double pz, double& ux, double& uy, double& uz) {
  int icx, icy, icz;
  slit_cell_coords(px, py, pz, cx, cy, cz, ncx, ncy, ncz, icx, icy, icz);
  double ax = 0.0, ay = 0.0, az = 0.0;
  slit_cell_window(icx, icy, icz, ncx, ncy, ncz, [&](int cell) {
    for (int s = start[cell]; s < start[cell + 1]; ++s) {
      const double rx = min_image(px - sx[s], Lx);
      const double ry = py - sy[s];
      const double rz = min_image(pz - sz[s], Lz);
      if (rx * rx + ry * ry + rz * rz >= rc2) continue;
      ggem_local_add(alpha, rx, ry, rz, fx[s], fy[s], fz[s], ax, ay, az);
    }
  });
  ux += scale * ax;
  uy += scale * ay;
  uz += scale * az;
}

CAPSFLOW_DEVICE_END

}  // namespace

void build_point_cell_list(PointCellList& cl, double Lx, double H, double Lz, double cutoff, std::size_t n,
                           const double* x, const double* y, const double* z, const double* fx, const double* fy,
                           const double* fz) {
  size_cell_grid(cl, Lx, H, Lz, cutoff);
  const int ncell = cl.ncx * cl.ncy * cl.ncz;
  std::vector<int> cell(n);
  cl.start.assign(ncell + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    cell[i] = slit_cell_of(x[i], y[i], z[i], cl.cx, cl.cy, cl.cz, cl.ncx, cl.ncy, cl.ncz);
    ++cl.start[cell[i] + 1];
  }
  for (int c = 0; c < ncell; ++c) cl.start[c + 1] += cl.start[c];
  std::vector<int> fill(cl.start.begin(), cl.start.end() - 1);
  for (auto* v : {&cl.x, &cl.y, &cl.z, &cl.fx, &cl.fy, &cl.fz}) v->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int s = fill[cell[i]]++;
    cl.x[s] = x[i];
    cl.y[s] = y[i];
    cl.z[s] = z[i];
    cl.fx[s] = fx[i];
    cl.fy[s] = fy[i];
    cl.fz[s] = fz[i];
  }
}

void local_velocity_point_forces(Backend backend, const PointCellList& cl, double alpha, double cutoff,
                                 double scale, std::size_t nt, const double* tx, const double* ty, const double* tz,
                                 double* ux, double* uy, double* uz) {
  require_built(backend, "local_velocity_point_forces");
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double cx = cl.cx, cy = cl.cy, cz = cl.cz, Lx = cl.Lx, Lz = cl.Lz;
  const double rc2 = cutoff * cutoff;
  const int* start = cl.start.data();
  const double *sx = cl.x.data(), *sy = cl.y.data(), *sz = cl.z.data();
  const double *fx = cl.fx.data(), *fy = cl.fy.data(), *fz = cl.fz.data();
  const long long n = static_cast<long long>(nt);
  if (backend == Backend::Device) {
#ifdef CAPSFLOW_HAVE_OFFLOAD
    const std::size_t ns = cl.size();
    const std::size_t nc = cl.start.size();
#pragma omp target teams distribute parallel for map(to : start[0:nc], sx[0:ns], sy[0:ns], sz[0:ns], fx[0:ns], \
                                                             fy[0:ns], fz[0:ns], tx[0:nt], ty[0:nt], tz[0:nt])  \
    map(tofrom : ux[0:nt], uy[0:nt], uz[0:nt])
    for (long long p = 0; p < n; ++p)
      local_target(ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, sx, sy, sz, fx, fy, fz, alpha, rc2, scale, tx[p], ty[p],
                   tz[p], ux[p], uy[p], uz[p]);
#endif
    return;
  }
#pragma omp parallel for schedule(dynamic, 64) if (backend == Backend::Threads)
  for (long long p = 0; p < n; ++p)
    local_target(ncx, ncy, ncz, cx, cy, cz, Lx, Lz, start, sx, sy, sz, fx, fy, fz, alpha, rc2, scale, tx[p], ty[p],
                 tz[p], ux[p], uy[p], uz[p]);
}

}  // namespace capsflow
