#pragma once
// SingleLayerPlan: the velocity operator of the capsule membranes, one owner with FINUFFT's plan life cycle (make
// plan, set points, execute many times) and UAMMD's named stages (docs/method.md §1-§3, docs/method_quadrature.md):
//
//     S[f](x_i) = u_l(x_i) + I[u_g](x_i)
//
// u_l: local single-layer integrals of the linear density f over the elements within the cutoff (singular, regular
// and near-singular rules of element_quadrature.hpp); u_g: the GGEM global part forced by the nodal point forces
// F_i = f_i A_i (decision D3), with wall data -u_l evaluated by the same element integrals at the wall grid points.
// The imposed flow is not part of S (the caller adds it).
//
//   SingleLayerPlan plan(geo, ggem, backend);       // grid, global solve (chosen once), wall points
//   plan.set_geometry(state, ws);                   // per geometry: element cell list, packed element geometry,
//                                                   // the spreading stencils of the nodal point forces
//   plan.apply(f, F, u);                            // any number of times on that geometry, the same bits each time
//
// apply = local_at_nodes, local_at_walls, global (walls, spread, solve, interpolate): each public, timed, testable.
// Everything that depends only on the node positions is made in set_geometry, so an iterative solve (a viscosity
// ratio other than 1) pays only the density-dependent work per application. set_geometry keeps a reference to the
// state's positions: they must not change until the next set_geometry (Simulation calls it after every update).
//
// Device backend: the element cell list is binned on the device from the resident positions; the plan's own arrays
// (node ids, wall points, the local velocity at the wall points) are registered in the run's StepWorkspace on the
// first set_geometry, and every array a stage reads or writes is declared there as it is taken, so the global part's
// kernels find them resident and nothing crosses.
#include <memory>
#include <vector>

#include "host/state/capsule_state.hpp"
#include "host/solver/ggem_global.hpp"
#include "host/solver/slit_parameters.hpp"
#include "host/state/step_workspace.hpp"
#include "kernels/device_cells.hpp"
#include "kernels/element_quadrature.hpp"
#include "kernels/local_single_layer.hpp"

namespace capsflow {

struct SingleLayerTimings {  // seconds of the last set_geometry() and apply()
  double set_geometry = 0.0, local_nodes = 0.0, local_walls = 0.0, global = 0.0, apply = 0.0;
};

// Three node fields (x, y, z components) by reference: densities, forces or velocities.
struct NodeField {
  const std::vector<double>& x;
  const std::vector<double>& y;
  const std::vector<double>& z;
};
struct NodeFieldOut {
  std::vector<double>& x;
  std::vector<double>& y;
  std::vector<double>& z;
};

class SingleLayerPlan {
 public:
  SingleLayerPlan(const SlitGeometry& geo, const GgemOptions& opt, Backend backend, QuadratureOrders orders = {});
  SingleLayerPlan(const SingleLayerPlan&) = delete;
  SingleLayerPlan& operator=(const SingleLayerPlan&) = delete;

  // The geometry of every later apply: s's mesh and current node positions. ws: the run's workspace on the device
  // backend (s's arrays registered in it), nullptr otherwise.
  void set_geometry(const CapsuleState& s, StepWorkspace* ws = nullptr);

  // u = S[f] at the nodes (resized to the node count): density f, nodal forces F = f A (the same membrane load).
  // Throws std::logic_error before the first set_geometry. On the device backend u is left valid on the device.
  void apply(NodeField density, NodeField nodal_force, NodeFieldOut u);
  // The membrane load of the state (s.fx.., s.Fx..): the form Simulation uses.
  void apply(const CapsuleState& s, std::vector<double>& ux, std::vector<double>& uy, std::vector<double>& uz);

  // S[f] at nt points anywhere in the slit (written, not added): the local element sums of f at the points and the
  // global part forced by F interpolated there, with the wall data of f, as apply makes them at the nodes (`capsflow
  // flow`). target_node[p]: the node that point p is (its elements then take the singular rule, as in apply), or -1;
  // nullptr: none. Points are host arrays; host backends only (std::logic_error on the device backend).
  void apply_at(NodeField density, NodeField nodal_force, std::size_t nt, const double* tx, const double* ty,
                const double* tz, const int* target_node, double* ux, double* uy, double* uz);

  // The stages of apply, in its order. local_at_nodes adds u_l to u; local_at_walls fills wall_local_velocity();
  // global adds I[u_g] forced by F with the wall data of the last local_at_walls.
  void local_at_nodes(NodeField density, NodeFieldOut u);
  void local_at_walls(NodeField density);
  void global(NodeField nodal_force, NodeFieldOut u);

  const std::vector<double>& wall_local_velocity(int c) const { return wall_u_[c]; }
  const GgemGlobalPart& global_part() const { return global_; }
  GgemGlobalPart& global_part_mutable() { return global_; }
  // The geometry of the last set_geometry (DoubleLayerPlan shares it): the state and the element cell list.
  const CapsuleState& state() const {
    require_geometry("state");
    return *state_;
  }
  const ElementCellList& cell_list() const {
    require_geometry("cell_list");
    return *cl_;
  }
  const QuadratureOrders& orders() const { return orders_; }
  const GgemGrid& grid() const { return global_.grid(); }
  const SlitGeometry& geometry() const { return global_.geometry(); }
  Backend backend() const { return backend_; }
  const SingleLayerTimings& last_timings() const { return timings_; }

 private:
  void require_geometry(const char* what) const;
  void pack_density(NodeField f);
  void local_nodes(NodeField f, NodeFieldOut u);  // the stages without packing the density
  void local_walls(NodeField f);
  // The element integrals of density f at nt targets (target_node: the node index of each target, or nullptr).
  void local_sum(NodeField f, std::size_t nt, const double* tx, const double* ty, const double* tz,
                 const int* target_node, double* ux, double* uy, double* uz);

  GgemGlobalPart global_;
  Backend backend_;
  QuadratureOrders orders_;
  double scale_;  // 1 / (8 pi mu)
  // Geometry (set_geometry): the state whose positions and mesh it was made from, the cell list and pack.
  const CapsuleState* state_ = nullptr;
  StepWorkspace* ws_ = nullptr;
  StepWorkspace no_workspace_{Backend::Serial};  // inactive: its declarations are no-ops
  ElementCellList cells_;
  std::unique_ptr<DeviceElementCells> device_cells_;  // device backend: the list binned there, resident for the run
  const ElementCellList* cl_ = nullptr;
  ElementPack pack_;
  std::vector<int> node_ids_;
  std::vector<double> wall_u_[3];
  SingleLayerTimings timings_;
};

}  // namespace capsflow
