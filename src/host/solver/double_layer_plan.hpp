#pragma once
// DoubleLayerPlan: the double layer of the capsule membranes in the slit (docs/method.md "Double layer"; issue 22),
//     K[q](x) = (1/8 pi) \int q_i(y) T_ijk(y, x) n_k(y) dS_y      (T the stress of the slit Green's function),
// by GGEM on the geometry, grid and slit solve of a SingleLayerPlan (set up once per geometry, applied many times, as
// the iterative solve for a viscosity ratio other than 1 needs):
//   local   the screened stresslet W_l over the elements within the cutoff (element rules of the single layer; on the
//           target's own elements only W_l's regular terms survive), at the nodes and at the wall grid points;
//   global  the slit Stokes flow of the dipole clouds (body force h(r) D r) plus grad(phi) of their mass sources
//           (lap phi = m g, phi = 0 on the walls), with wall data -(local + grad phi) so that K vanishes on the walls.
// apply() returns the operator the boundary-integral equation uses:
//     K~[q](x_i) = K_d[P q](x_i) - C_i (P q)_i - (P q)_i / 2,     C_i = K_d[I](x_i) (three constant densities),
// K_d the discrete operator above. The subtraction makes the principal value exact for rigid motions (the polyhedron's
// cone at a node otherwise gives -Omega_i/4pi instead of -1/2: first order in h; with it, second order). P removes
// each capsule's net flux sum_m q_m.a_m (a_m the nodal vector area): the smoothed sources of a density with net flux
// cannot leave a periodic slit with no-slip walls; the exact solution has zero flux, so P changes only the
// eigenvalue of the normal mode (a Wielandt deflation).
//
// Serial and threads give the same bits. On the device backend the local sums (nodes, wall points, the C_i pass) and
// the dipole spreading run as target regions on the single layer's device cell list and resident grid, the Stokes
// solve is the single layer's device plan, and the Poisson solve stays on the host (its source comes back and the
// gradient goes out: one grid and three grids per application; cuFFT for it is not written). The caller keeps the
// positions valid on both sides (Simulation declares them in its StepWorkspace before the solve).
#include <memory>
#include <vector>

#include "host/solver/single_layer_plan.hpp"
#include "host/solver/slit_poisson.hpp"

namespace capsflow {

struct DoubleLayerTimings {  // seconds of the last apply (and of the last set_geometry)
  double set_geometry = 0.0, local_nodes = 0.0, local_walls = 0.0, global = 0.0, apply = 0.0;
};

class DoubleLayerPlan {
 public:
  explicit DoubleLayerPlan(SingleLayerPlan& single_layer);
  DoubleLayerPlan(const DoubleLayerPlan&) = delete;
  DoubleLayerPlan& operator=(const DoubleLayerPlan&) = delete;

  // After single_layer.set_geometry(s): nodal vector areas and normals, and C_i (three applications of K_d).
  void set_geometry();

  // K~[q] at the nodes (resized to the node count).
  void apply(NodeField q, NodeFieldOut k);
  // K_d[q] (no deflation, no subtraction) at nt targets; target_node[p] the node index of target p or -1 (nullptr:
  // none is a node). The tests' form: interior and exterior points, the raw operator at the nodes.
  void apply_discrete(NodeField q, std::size_t nt, const double* tx, const double* ty, const double* tz,
                      const int* target_node, double* kx, double* ky, double* kz);

  // K_d[P q] at nt targets: the density as apply() deflates it, off the membrane (`capsflow flow`: the representation
  // consistent with the interface solve, whose operator sees P q). target_node as apply_discrete's.
  void apply_deflated(NodeField q, std::size_t nt, const double* tx, const double* ty, const double* tz,
                      const int* target_node, double* kx, double* ky, double* kz);

  // Nodal vector areas a_m = (1/3) sum of the incident triangles' A_e n_e.
  const std::vector<double>& vector_area(int c) const { return area_[c]; }
  const DoubleLayerTimings& last_timings() const { return timings_; }

 private:
  void deflate(NodeField q);  // P q into pq_
  // The local part of K_d[q] at the wall grid points into wall_ (the host traversal reads pack_'s densities: q's).
  void local_walls(NodeField q);
  // Adds the global part of K_d[q] at nt targets, with wall data wall_ (the local part there) made for q.
  void global_from_walls(NodeField q, std::size_t nt, const double* tx, const double* ty, const double* tz,
                         double* kx, double* ky, double* kz);

  SingleLayerPlan& sl_;
  std::unique_ptr<SlitPoissonGradient> poisson_;
  double scale_;  // 1 / (8 pi)
  std::vector<double> area_[3], unit_[3];   // a_m and a_m / |a_m|
  std::vector<double> cmat_;                // C_i: 9 per node, row-major (component, density direction)
  std::vector<double> pq_[3], kd_[3], wall_[3], tmp_[3];
  std::vector<int> node_ids_;
  ElementPack pack_;            // the host traversal's element data (geometry per set_geometry, densities per apply)
  std::vector<double> wall_matrix_;  // the unit densities' local part at the wall points (9 per point)
  bool have_geometry_ = false;
  DoubleLayerTimings timings_;
};

}  // namespace capsflow
