#pragma once
// Local part of GGEM for point forces: u_l(x) = (1/8 pi mu) sum_{|x - x_m| < r_c} G_l(x - x_m) f_m, with minimum
// images in x and z (never in y), found through a cell list (docs/method.md §1.1, docs/method_quadrature.md).
//
// The cell list is built on the host (counting sort, stable, so the order inside a cell is the input order);
// the per-target sum is a gather, race-free on every backend, and sums in the same order on every backend.
#include <cstddef>
#include <vector>

#include "kernels/backend.hpp"

namespace capsflow {

struct PointCellList {
  int ncx = 1, ncy = 1, ncz = 1;
  double cx = 0.0, cy = 0.0, cz = 0.0;  // cell sizes (>= cutoff)
  double Lx = 0.0, Lz = 0.0, H = 0.0;
  std::vector<int> start;                   // ncells + 1
  std::vector<double> x, y, z, fx, fy, fz;  // sources sorted by cell
  std::size_t size() const { return x.size(); }
};

void build_point_cell_list(PointCellList& cl, double Lx, double H, double Lz, double cutoff, std::size_t n,
                           const double* x, const double* y, const double* z, const double* fx, const double* fy,
                           const double* fz);

// Adds scale * sum G_l(t - s) f over sources within the cutoff of each target. A target coinciding with a
// source receives that source's regular part (-G_g(0) f), see ggem_local_add.
void local_velocity_point_forces(Backend backend, const PointCellList& cl, double alpha, double cutoff,
                                 double scale, std::size_t nt, const double* tx, const double* ty, const double* tz,
                                 double* ux, double* uy, double* uz);

}  // namespace capsflow
