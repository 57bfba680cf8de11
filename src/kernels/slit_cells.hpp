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
