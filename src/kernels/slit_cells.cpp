// The implementation of slit_cells.hpp: a periodic cell list of points in the slit and its searches.
#include "kernels/slit_cells.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "kernels/ggem_kernels.hpp"

namespace capsflow {

void bin_points(SlitCells& cl, double Lx, double H, double Lz, double min_cell, std::size_t n, const double* x,
                const double* y, const double* z) {
  if (!(Lx > 0.0 && H > 0.0 && Lz > 0.0 && min_cell > 0.0))
    throw std::invalid_argument("bin_points: the box and the cell size must be positive");
  // About one point per cell at most: a tiny min_cell must not make a huge, empty grid.
  const double per_point = n > 0 ? std::cbrt(Lx * H * Lz / static_cast<double>(n)) : Lx;
  const double size = std::max(min_cell, per_point);
  size_cell_grid(cl, Lx, H, Lz, size);
  const int ncell = cl.ncx * cl.ncy * cl.ncz;
  cl.start.assign(static_cast<std::size_t>(ncell) + 1, 0);
  cl.cell.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    cl.cell[i] = slit_cell_of(x[i], y[i], z[i], cl.cx, cl.cy, cl.cz, cl.ncx, cl.ncy, cl.ncz);
    ++cl.start[static_cast<std::size_t>(cl.cell[i]) + 1];
  }
  for (int c = 0; c < ncell; ++c) cl.start[static_cast<std::size_t>(c) + 1] += cl.start[static_cast<std::size_t>(c)];
  std::vector<int> fill(cl.start.begin(), cl.start.end() - 1);
  cl.index.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    cl.index[static_cast<std::size_t>(fill[static_cast<std::size_t>(cl.cell[i])]++)] = static_cast<int>(i);
}

double min_node_distance_between_capsules(Backend backend, const SlitCells& cl, int nv, const double* x,
                                          const double* y, const double* z, double limit) {
  const long long n = static_cast<long long>(cl.cell.size());
  const int ncx = cl.ncx, ncy = cl.ncy, ncz = cl.ncz;
  const double Lx = cl.Lx, Lz = cl.Lz;
  const int* start = cl.start.data();
  const int* index = cl.index.data();
  const int* cell = cl.cell.data();
  double best = limit * limit;
  // min is exact and order-independent: every backend gives the same value.
#pragma omp parallel for reduction(min : best) schedule(static) if (backend != Backend::Serial)
  for (long long i = 0; i < n; ++i)
    best = closest_other_capsule_d2(i, nv, ncx, ncy, ncz, Lx, Lz, start, index, cell, x, y, z, best);
  return best < limit * limit ? std::sqrt(best) : std::numeric_limits<double>::infinity();
}

}  // namespace capsflow
