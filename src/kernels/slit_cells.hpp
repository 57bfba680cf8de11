#pragma once
// A periodic cell list of points in the slit (periodic in x and z, walls in y) and the searches built on it
// (architecture review R5). Cells are at least `min_cell` wide, so every pair of points closer than min_cell lies in
// the same or neighbouring cells; along a periodic direction with fewer than 3 cells every cell is visited once.
// Binning is a stable counting sort (points keep increasing index inside a cell).
//
// Usage (the time step's h, docs/method.md D8):
//     SlitCells cells;
//     bin_points(cells, Lx, H, Lz, h, n, x, y, z);
//     const double d = min_node_distance_between_capsules(Backend::Threads, cells, nv, x, y, z, h);
//     // d < h: the smallest distance between nodes of different capsules; otherwise +infinity
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "kernels/backend.hpp"
#include "kernels/device_macros.hpp"
#include "kernels/ggem_kernels.hpp"

namespace capsflow {

struct SlitCells {
  int ncx = 1, ncy = 1, ncz = 1;
  double cx = 0.0, cy = 0.0, cz = 0.0;  // cell sizes
  double Lx = 0.0, H = 0.0, Lz = 0.0;
  std::vector<int> start;  // ncells + 1
  std::vector<int> index;  // point indices sorted by cell
  std::vector<int> cell;   // cell of each point (input order)
};

// The cell grid of a slit box, shared by every cell list (SlitCells, ElementCellList, PointCellList): as many cells
// of at least `size` as fit along each direction, at least one, so that neighbours closer than `size` lie in the
// same or adjacent cells.
template <class Cells>
void size_cell_grid(Cells& cl, double Lx, double H, double Lz, double size) {
  cl.Lx = Lx;
  cl.H = H;
  cl.Lz = Lz;
  cl.ncx = std::max(1, static_cast<int>(std::floor(Lx / size)));
  cl.ncy = std::max(1, static_cast<int>(std::floor(H / size)));
  cl.ncz = std::max(1, static_cast<int>(std::floor(Lz / size)));
  cl.cx = Lx / cl.ncx;
  cl.cy = H / cl.ncy;
  cl.cz = Lz / cl.ncz;
}

CAPSFLOW_DEVICE_BEGIN
// Cell arithmetic shared by the host and device binning of the node and element cell lists (kernels/device_cells),
// so both give the same cells: the unwrapped cell coordinate (callers wrap x and z, clamp y), the cell of a wrapped
// coordinate, and a neighbour of an in-range cell (at most one period away: no integer division).
inline int slit_cell_coord(double v, double size) { return static_cast<int>(std::floor(v / size)); }
inline int slit_wrap_cell(int c, int n) {
  const int r = c % n;
  return r < 0 ? r + n : r;
}
inline int slit_step_cell(int c, int n) { return c < 0 ? c + n : (c >= n ? c - n : c); }
// A periodic grid index (the spreading and interpolation stencils): within one period of the box almost always, so no
// integer division there; any index otherwise. Equal to slit_wrap_cell.
inline int slit_wrap_index(int i, int n) {
  if (i >= 0 && i < n) return i;
  if (i < 0 && i >= -n) return i + n;
  if (i >= n && i < 2 * n) return i - n;
  return slit_wrap_cell(i, n);
}
// The cell coordinates of a point: x and z wrapped, y clamped to the slit.
inline void slit_cell_coords(double x, double y, double z, double cx, double cy, double cz, int ncx, int ncy, int ncz,
                             int& a, int& b, int& c) {
  a = slit_wrap_cell(slit_cell_coord(x, cx), ncx);
  c = slit_wrap_cell(slit_cell_coord(z, cz), ncz);
  b = slit_cell_coord(y, cy);
  b = b < 0 ? 0 : (b > ncy - 1 ? ncy - 1 : b);
}
// The cell of a point in the [y][x][z] numbering of the lists.
inline int slit_cell_of(double x, double y, double z, double cx, double cy, double cz, int ncx, int ncy, int ncz) {
  int a, b, c;
  slit_cell_coords(x, y, z, cx, cy, cz, ncx, ncy, ncz, a, b, c);
  return (b * ncx + a) * ncz + c;
}

// The one neighbour window of the cell searches (the point-force and element local sums, the closest-pair search):
// visit(cell) for every cell within one step of the in-range cell (icx, icy, icz), in [y][x][z] order. Cells beyond
// the walls are skipped; along a periodic direction with fewer than 3 cells every cell is visited once (a 3-cell
// window would revisit cells through the seam). At most 27 cells.
template <class Visit>
inline void slit_cell_window(int icx, int icy, int icz, int ncx, int ncy, int ncz, Visit&& visit) {
  const int dx_lo = ncx >= 3 ? -1 : 0, dx_hi = ncx >= 3 ? 1 : ncx - 1;
  const int dz_lo = ncz >= 3 ? -1 : 0, dz_hi = ncz >= 3 ? 1 : ncz - 1;
  for (int dyc = -1; dyc <= 1; ++dyc) {
    const int cyy = icy + dyc;
    if (cyy < 0 || cyy >= ncy) continue;
    for (int dxc = dx_lo; dxc <= dx_hi; ++dxc) {
      const int cxx = ncx >= 3 ? slit_step_cell(icx + dxc, ncx) : dxc;
      for (int dzc = dz_lo; dzc <= dz_hi; ++dzc) {
        const int czz = ncz >= 3 ? slit_step_cell(icz + dzc, ncz) : dzc;
        visit((cyy * ncx + cxx) * ncz + czz);
      }
    }
  }
}

// The one body of the closest-pair searches (host: min_node_distance_between_capsules; device: DeviceNodeCells):
// min(best, the smallest squared distance from node i to a node j > i of another capsule (capsule = index / nv) in
// i's cell window, minimum images in x and z). A minimum, exact in any order.
inline double closest_other_capsule_d2(long long i, int nv, int ncx, int ncy, int ncz, double Lx, double Lz,
                                       const int* start, const int* index, const int* cell, const double* x,
                                       const double* y, const double* z, double best) {
  const int c = cell[i];
  const int icz = c % ncz, icx = (c / ncz) % ncx, icy = c / (ncz * ncx);
  const long long ki = i / nv;
  slit_cell_window(icx, icy, icz, ncx, ncy, ncz, [&](int cc) {
    for (int s = start[cc]; s < start[cc + 1]; ++s) {
      const long long j = index[s];
      if (j <= i || j / nv == ki) continue;
      const double dx = min_image(x[i] - x[j], Lx), dy = y[i] - y[j], dz = min_image(z[i] - z[j], Lz);
      const double d2 = dx * dx + dy * dy + dz * dz;
      best = d2 < best ? d2 : best;
    }
  });
  return best;
}

// The one centroid and bounding radius of element e (capsule e / ntri, triangle e % ntri; vertices unwrapped about
// vertex 0 by minimum images in x and z) for the element cell lists, host (build_element_cell_list) and device
// (DeviceElementCells): the same arithmetic, so both bin every element into the same cell.
inline void element_centroid_radius(long long e, int nv, int ntri, const int* tri, const double* x, const double* y,
                                    const double* z, double Lx, double Lz, double& c0, double& c1, double& c2,
                                    double& r) {
  const int k = static_cast<int>(e / ntri);
  const int t = static_cast<int>(e % ntri);
  double v[9];
  const int g0 = k * nv + tri[3 * t];
  for (int c = 0; c < 3; ++c) {
    const int g = k * nv + tri[3 * t + c];
    v[3 * c] = x[g0] + min_image(x[g] - x[g0], Lx);
    v[3 * c + 1] = y[g];
    v[3 * c + 2] = z[g0] + min_image(z[g] - z[g0], Lz);
  }
  c0 = (v[0] + v[3] + v[6]) / 3.0;
  c1 = (v[1] + v[4] + v[7]) / 3.0;
  c2 = (v[2] + v[5] + v[8]) / 3.0;
  double r2 = 0.0;
  for (int c = 0; c < 3; ++c) {
    const double dx = v[3 * c] - c0, dy = v[3 * c + 1] - c1, dz = v[3 * c + 2] - c2;
    const double d2 = dx * dx + dy * dy + dz * dz;
    r2 = d2 > r2 ? d2 : r2;
  }
  r = std::sqrt(r2);
}
CAPSFLOW_DEVICE_END

// Bins n points (x and z may lie outside [0, L): they are wrapped; y is clamped to the wall layers). The cell size
// is at least min_cell and at least the size that gives about one point per cell (a cap on the cell count).
// Throws std::invalid_argument for a non-positive box or min_cell.
void bin_points(SlitCells& cells, double Lx, double H, double Lz, double min_cell, std::size_t n, const double* x,
                const double* y, const double* z);

// Smallest distance (minimum image in x and z) between two nodes of different capsules (node i belongs to capsule
// i / nv) when it is below `limit`, else +infinity. cells must have been binned from the same points with
// min_cell >= limit. Exact (a minimum), so every backend returns the same value; Device runs on the host threads
// here (the device step bins and searches on the device: DeviceNodeCells, kernels/device_cells).
double min_node_distance_between_capsules(Backend backend, const SlitCells& cells, int nv, const double* x,
                                          const double* y, const double* z, double limit);

}  // namespace capsflow
