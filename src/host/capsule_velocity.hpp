#pragma once
// CapsuleVelocitySolver: velocity of every membrane node (method-spec 7, 10; issue 4, step 1-7 of the per-step data
// flow):
//     u(x_i) = u_inf(y_i) + u_l(x_i) + I[u_g](x_i)
// u_l: local single-layer integrals of the linear density f = F/A over the elements within the cutoff (singular,
// regular and near-singular rules of element_quadrature.hpp); u_g: the GGEM global part forced by the nodal point
// forces F_i = f_i A_i, with wall data -u_l evaluated by the same element integrals at the wall grid points.
// The caller computes the membrane forces first (CapsuleState::compute_membrane_forces).
#include <vector>

#include "host/capsule_state.hpp"
#include "host/config.hpp"
#include "host/ggem_solver.hpp"
#include "host/step_workspace.hpp"
#include "kernels/element_quadrature.hpp"
#include "kernels/local_single_layer.hpp"

namespace capsflow {

// The undisturbed flow: Poiseuille gammadot_w y (1 - y/H) (wall shear rate gammadot_w), simple shear
// gammadot (y - H/2) with moving walls, or none. Only the x component is non-zero.
double imposed_velocity_x(const FlowOptions& flow, double H, double y);

struct CapsuleVelocityTimings {
  double local_nodes = 0.0, local_walls = 0.0, global = 0.0, total = 0.0;
};

class CapsuleVelocitySolver {
 public:
  CapsuleVelocitySolver(const SlitGeometry& geo, const GgemOptions& opt, Backend backend,
                        QuadratureOrders orders = {});

  // Node velocities (ux, uy, uz: num_nodes each) from the current densities s.fx.. and nodal forces s.Fx...
  // With an active workspace (device backend) the state's arrays and ux, uy, uz must be registered in it; the
  // solver registers its own wall data there on the first call, and the velocities are left valid on the device.
  void node_velocities(const CapsuleState& s, const FlowOptions& flow, std::vector<double>& ux,
                       std::vector<double>& uy, std::vector<double>& uz, StepWorkspace* ws = nullptr);

  const GgemSolver& ggem() const { return ggem_; }
  const CapsuleVelocityTimings& last_timings() const { return timings_; }

 private:
  GgemSolver ggem_;
  Backend backend_;
  QuadratureOrders orders_;
  ElementCellList cells_;
  std::vector<int> node_ids_;
  std::vector<double> wall_u_[3];
  CapsuleVelocityTimings timings_;
};

}  // namespace capsflow
